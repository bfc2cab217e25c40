//! Files in and out for `stencil`, shared by every other crate of the workspace.
//!
//! Public API:
//! - [`write_atomic`], [`write_atomic_with`], [`WriteError`], [`plain_io`]: every single output
//!   file is written into a temp file and renamed into place, so no crash or error leaves a
//!   half-written file a machine could pick up.
//! - [`replace_all`] ([`Replaced`]), [`set_aside`] ([`SetAside`]), [`recover`] ([`Recovered`]),
//!   [`recover_around`], [`lock_folder`] ([`FolderLock`]):
//!   an output folder's set of files replaced as one transaction that a kill at any moment
//!   leaves whole (see [`swap`]).
//! - [`check_output`], [`OutputError`]: an output path refused when it is an input or not a
//!   regular file.
//! - [`read_text`], [`read_bytes`], [`open_bounded`], [`Kind`], [`ReadError`]: the one bounded
//!   reader every file goes through (a size cap per kind; FIFOs and devices refused at once).
//! - [`profile`]: the TOML profile loader (materials and machines), with the [`shipped!`] macro
//!   that embeds a shipped profile.
//! - [`excerpt`], [`printable`]: a user's text quoted in a message, cut short, its control
//!   characters written out.

#![forbid(unsafe_code)]

mod atomic;
mod output;
pub mod profile;
mod read;
pub mod swap;
mod text;

pub use atomic::{plain_io, write_atomic, write_atomic_with, Replaced, WriteError};
pub use output::{check_output, check_output_dir, OutputError};
pub use read::{not_a_file, open_bounded, read_bytes, read_text, size_words, Kind, ReadError};
pub use swap::{
    lock_folder, recover, recover_around, replace_all, set_aside, FolderLock, Recovered, SetAside,
};
pub use text::{excerpt, printable, EXCERPT_CHARS};
