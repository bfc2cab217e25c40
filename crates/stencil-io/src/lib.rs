//! Files in and out for `stencil`, shared by every other crate of the workspace.
//!
//! Public API:
//! - [`write_atomic`], [`write_atomic_with`], [`replace_all`] ([`Replaced`]), [`WriteError`],
//!   [`plain_io`]: every output file is written into a temp file and renamed into place, so no
//!   crash or error leaves a half-written file a machine could pick up.
//! - [`read_text`], [`ReadError`]: a user's text file read with a size limit.
//! - [`profile`]: the TOML profile loader (materials and machines), with the [`shipped!`] macro
//!   that embeds a shipped profile.
//! - [`excerpt`]: a user's text quoted in a message, cut short.

#![forbid(unsafe_code)]

mod atomic;
pub mod profile;
mod read;
mod text;

pub use atomic::{plain_io, replace_all, write_atomic, write_atomic_with, Replaced, WriteError};
pub use read::{read_text, ReadError};
pub use text::{excerpt, EXCERPT_CHARS};
