//! The one way `stencil` reads a file: [`open_bounded`], [`read_bytes`] and [`read_text`], each
//! with the size cap of the file's [`Kind`] named in the message.
//!
//! Why one reader: a huge file or a device such as `/dev/zero` must be refused instead of read
//! until memory runs out, and a named pipe or a terminal must be refused at once instead of
//! blocking the run forever. So a path is opened without blocking (`O_NONBLOCK`: opening a FIFO
//! with no writer returns at once), the opened handle's own metadata is checked (a regular file,
//! no larger than its kind's cap: checking the handle, not the path, leaves no gap for the file to
//! be swapped between the check and the read), and at most the cap is read even if the file grows.

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

use crate::disk::{not_a_file, plain_io};

/// What a file is read as: its name in messages and its size cap. The caps are far above any
/// file stencil writes or a person draws (each says why), and far below what would exhaust memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// PNG, JPEG, BMP or TIFF: 1 GiB (a 200-megapixel 16-bit RGB TIFF, the largest picture the
    /// pixel limits let through, is 1.2 GB uncompressed; decoding is capped separately).
    Picture,
    /// An OBJ mesh: 1 GiB (about 15 million triangles of text).
    Mesh,
    /// An SVG drawing: 256 MiB (a 100-megapixel stencil's SVG is about 30 MB).
    Svg,
    /// A G-code program: 512 MiB (about 20 million lines; a day of cutting).
    Gcode,
    /// A material or machine profile: 1 MiB (the shipped ones are under 2 KB).
    Profile,
    /// A send journal: 1 MiB (it holds a few numbers and names).
    Journal,
    /// A `stencil make` report.json: 256 MiB (a 100-megapixel stencil with 5,000 bridges writes
    /// about 3 MB).
    Report,
}

impl Kind {
    /// The largest file of this kind that is read, in bytes.
    pub const fn cap(self) -> u64 {
        match self {
            Kind::Picture | Kind::Mesh => 1 << 30,
            Kind::Svg | Kind::Report => 256 << 20,
            Kind::Gcode => 512 << 20,
            Kind::Profile | Kind::Journal => 1 << 20,
        }
    }

    /// The kind in a message ("a G-code file").
    pub const fn name(self) -> &'static str {
        match self {
            Kind::Picture => "picture",
            Kind::Mesh => "mesh (OBJ)",
            Kind::Svg => "drawing (SVG)",
            Kind::Gcode => "G-code file",
            Kind::Profile => "material or machine profile",
            Kind::Journal => "send journal",
            Kind::Report => "stencil report (report.json)",
        }
    }
}

/// A size in words: "512 MB", "1 MB", "256 KB".
fn size_words(bytes: u64) -> String {
    if bytes >= 1 << 20 && bytes.is_multiple_of(1 << 20) {
        format!("{} MB", bytes >> 20)
    } else if bytes >= 1 << 10 {
        format!("{} KB", bytes >> 10)
    } else {
        format!("{bytes} bytes")
    }
}

/// A file that could not be read within its kind's limits. No variant quotes the file's content.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("{path}: cannot open this {what}: {source}")]
    /// The file could not be opened.
    Open {
        /// The file.
        path: PathBuf,
        /// The kind of file, in words.
        what: &'static str,
        /// The system's error.
        source: std::io::Error,
    },
    #[error("{path}: cannot read this {what}: {source}")]
    /// Reading it failed.
    Io {
        /// The file.
        path: PathBuf,
        /// The kind of file, in words.
        what: &'static str,
        /// The system's error.
        source: std::io::Error,
    },
    #[error("{path}: larger than the {limit} a {what} can be; is it the right file?")]
    /// Larger than its kind's cap.
    TooLarge {
        /// The file.
        path: PathBuf,
        /// The cap, in words.
        limit: String,
        /// The kind of file, in words.
        what: &'static str,
    },
    #[error("{path}: {is}, not a file; a {what} is read from a regular file")]
    /// Not a regular file.
    NotAFile {
        /// The file.
        path: PathBuf,
        /// What it is instead.
        is: &'static str,
        /// The kind of file, in words.
        what: &'static str,
    },
    #[error("{path}: not UTF-8 text (at byte {at}); a {what} is a text file")]
    /// Not UTF-8 text.
    NotText {
        /// The file.
        path: PathBuf,
        /// The kind of file, in words.
        what: &'static str,
        /// The first byte that is not UTF-8.
        at: usize,
    },
}

impl ReadError {
    /// The file that could not be read.
    pub fn subject(&self) -> &Path {
        match self {
            ReadError::Open { path, .. }
            | ReadError::Io { path, .. }
            | ReadError::TooLarge { path, .. }
            | ReadError::NotAFile { path, .. }
            | ReadError::NotText { path, .. } => path,
        }
    }
}

/// Open `path` as a file of `kind`: refused at once when it is not a regular file (a FIFO, a
/// device, a socket, a folder) or larger than the kind's cap. Returns the file and its size; the
/// caller reads at most that much (a picture decoder that needs to seek gets the file itself).
pub fn open_bounded(path: &Path, kind: Kind) -> Result<(File, u64), ReadError> {
    let what = kind.name();
    let mut opts = std::fs::OpenOptions::new();
    opts.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // Opening a FIFO for reading blocks until a writer comes, and opening a terminal can make
        // it ours: neither, so that the type check below sees them and refuses.
        opts.custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY);
    }
    let file = opts.open(path).map_err(|source| ReadError::Open {
        path: path.to_path_buf(),
        what,
        source: plain_io(source),
    })?;
    let meta = file.metadata().map_err(|e| io_error(path, kind, e))?;
    if let Some(is) = not_a_file(&meta.file_type()) {
        return Err(ReadError::NotAFile {
            path: path.to_path_buf(),
            is,
            what,
        });
    }
    if meta.len() > kind.cap() {
        return Err(too_large(path, kind));
    }
    Ok((file, meta.len()))
}

fn io_error(path: &Path, kind: Kind, source: std::io::Error) -> ReadError {
    ReadError::Io {
        path: path.to_path_buf(),
        what: kind.name(),
        source: plain_io(source),
    }
}

fn too_large(path: &Path, kind: Kind) -> ReadError {
    ReadError::TooLarge {
        path: path.to_path_buf(),
        limit: size_words(kind.cap()),
        what: kind.name(),
    }
}

/// The bytes of a file of `kind` (see [`open_bounded`]); a file that grows past the cap while it
/// is read is refused too.
pub fn read_bytes(path: &Path, kind: Kind) -> Result<Vec<u8>, ReadError> {
    let (file, len) = open_bounded(path, kind)?;
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(len as usize)
        .map_err(|_| too_large(path, kind))?;
    file.take(kind.cap() + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| io_error(path, kind, e))?;
    if bytes.len() as u64 > kind.cap() {
        return Err(too_large(path, kind));
    }
    Ok(bytes)
}

/// A text file of `kind` (see [`open_bounded`]): refused when it is not UTF-8, saying where (not
/// what: the message never quotes a file that may not be the kind asked for).
pub fn read_text(path: &Path, kind: Kind) -> Result<String, ReadError> {
    let bytes = read_bytes(path, kind)?;
    String::from_utf8(bytes).map_err(|e| ReadError::NotText {
        path: path.to_path_buf(),
        what: kind.name(),
        at: e.utf8_error().valid_up_to(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn caps_are_named_and_devices_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big.toml");
        std::fs::write(&p, vec![b'#'; (Kind::Profile.cap() + 1) as usize]).unwrap();
        let e = read_text(&p, Kind::Profile).unwrap_err().to_string();
        assert!(
            e.contains("larger than the 1 MB a material or machine profile"),
            "{e}"
        );
        let e = read_text(dir.path(), Kind::Gcode).unwrap_err().to_string();
        assert!(e.contains("a folder, not a file"), "{e}");
        #[cfg(unix)]
        {
            let e = read_text(Path::new("/dev/zero"), Kind::Gcode)
                .unwrap_err()
                .to_string();
            assert!(e.contains("a device, not a file; a G-code file"), "{e}");
        }
    }
}
