//! Files in and out for `stencil`, shared by every other crate of the workspace.
//!
//! - [`write_atomic`]: every single output file is written into a temp file and renamed into
//!   place, so no crash or error leaves a half-written file a machine could pick up.
//! - [`replace_all`], [`set_aside`], [`recover`], [`recover_around`], [`lock_folder`]: an output
//!   folder's set of files replaced as one transaction that a kill at any moment leaves whole.
//! - [`check_output`], [`check_output_dir`]: an output path refused when it is an input or not a
//!   regular file.
//! - [`read_text`], [`read_bytes`], [`open_bounded`]: the one bounded reader every file goes
//!   through (a size cap per [`Kind`]; FIFOs and devices refused at once).
//! - [`profile`]: the TOML profile loader (materials and machines), with the [`shipped!`] macro
//!   that embeds a shipped profile.
//! - [`excerpt`], [`printable`]: a user's text quoted in a message, cut short, its control
//!   characters written out.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod atomic;
mod disk;
mod output;
pub mod profile;
mod read;
mod swap;
mod text;

pub use atomic::{write_atomic, Replaced, WriteError};
pub use disk::plain_io;
pub use output::{check_output, check_output_dir, OutputError};
pub use read::{open_bounded, read_bytes, read_text, Kind, ReadError};
pub use swap::{
    lock_folder, recover, recover_around, replace_all, set_aside, FolderLock, Recovered, SetAside,
};
pub use text::{excerpt, excerpt_name, printable};
