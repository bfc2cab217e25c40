//! Reading a user's text file with a size limit, so that a huge file or a device such as
//! /dev/zero is refused instead of read forever.

use std::io::Read;
use std::path::{Path, PathBuf};

/// A file read with a size limit.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("{path}: cannot read this {what}: {source}")]
    Io {
        path: PathBuf,
        what: &'static str,
        source: std::io::Error,
    },
    #[error("{path}: larger than the {limit_kb} KB a {what} can be; is it the right file?")]
    TooLarge {
        path: PathBuf,
        limit_kb: u64,
        what: &'static str,
    },
    #[error("{path}: not UTF-8 text; a {what} is a text file")]
    NotText { path: PathBuf, what: &'static str },
}

/// Read a text file of at most `limit` bytes (a device such as /dev/zero, or a huge file, is
/// refused after `limit` bytes instead of being read forever). `what` names the kind of file for
/// the message ("material or machine profile").
pub fn read_text(path: &Path, limit: u64, what: &'static str) -> Result<String, ReadError> {
    let io = |source: std::io::Error| ReadError::Io {
        path: path.to_path_buf(),
        what,
        source: crate::atomic::plain_io(source),
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > limit {
        return Err(ReadError::TooLarge {
            path: path.to_path_buf(),
            limit_kb: limit / 1024,
            what,
        });
    }
    String::from_utf8(bytes).map_err(|_| ReadError::NotText {
        path: path.to_path_buf(),
        what,
    })
}
