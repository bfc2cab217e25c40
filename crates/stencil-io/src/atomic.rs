//! One way to write a file: into a temp file beside the target, then rename into place.
//!
//! A crash, a full disk or an error half-way never leaves a half-written output that a user (or a
//! laser) could pick up. Every single output file (G-code, a simulation picture, the send
//! journal) is written through [`write_atomic`]; a set of files (`make`'s folder) through
//! [`crate::replace_all`], a transaction. A temp file is locked while it is written, so that the
//! next write into the folder can tell a killed run's orphan from a live one and delete it.

use std::io::Write;
use std::path::{Path, PathBuf};

use tempfile::NamedTempFile;

use crate::disk::{not_a_file, plain_io, SWAP_DIR, TEMP_PREFIX};

/// A file that could not be written (or an old one removed); nothing half-written is left.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    #[error("{path}: cannot write: {source}")]
    /// The write, rename or removal failed.
    Write {
        /// The file.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    #[error("{path}: another stencil run is writing this folder now; wait for it to finish, or choose another folder with -o")]
    /// Another run holds the folder's lock.
    Busy {
        /// The folder.
        path: PathBuf,
    },
    #[error("{path}: not a plan stencil wrote, so it is not run; look at the folder {} and remove it yourself", path.parent().map_or(path.display(), |p| p.display()))]
    /// A half-finished swap's plan that stencil did not write.
    BadPlan {
        /// The plan file.
        path: PathBuf,
    },
    #[error("{path}: is {is}; stencil writes only regular files and replaces nothing else (choose another output path)")]
    /// The output exists and is not a regular file.
    NotAFile {
        /// The path.
        path: PathBuf,
        /// What it is instead.
        is: &'static str,
    },
    /// A path a half-finished swap goes through ([`crate::replace_all`]) is not the folder or file stencil
    /// made there: a link (in a folder received from elsewhere) is never followed.
    #[error("{path}: is {is}, where the half-finished swap of a `stencil make` folder needs a folder or file of its own (stencil never makes a link there; was the folder received from elsewhere?); nothing was moved through it. Look at it, and remove the folder's {} yourself", SWAP_DIR)]
    NotSwapFolder {
        /// The path.
        path: PathBuf,
        /// What it is instead.
        is: &'static str,
    },
}

/// Write `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// Write to `path` atomically through a closure that gets the temp file (a test's failing writer
/// shows that nothing is left behind).
fn write_atomic_with(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), WriteError> {
    // A device, a FIFO or a folder (or a link to one) is never replaced by a file.
    if let Ok(m) = std::fs::metadata(path) {
        if let Some(is) = not_a_file(&m.file_type()) {
            return Err(WriteError::NotAFile {
                path: path.to_path_buf(),
                is,
            });
        }
    }
    let tmp = staged(path, f)?;
    tmp.persist(path).map_err(|e| write_error(path, e.error))?;
    sweep_temps(folder_of(path));
    Ok(())
}

/// The error for `path`, with the operating system's words only (no temp file's name).
fn write_error(path: &Path, source: std::io::Error) -> WriteError {
    WriteError::Write {
        path: path.to_path_buf(),
        source: plain_io(source),
    }
}

/// The folder a file goes into.
fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// A new, empty temp file in `dir`, readable by others like any output.
fn temp_in(dir: &Path) -> std::io::Result<NamedTempFile> {
    let mut builder = tempfile::Builder::new();
    builder.prefix(TEMP_PREFIX).suffix(".tmp");
    // A temp file is private (0600) by default; an output is an ordinary file that other programs
    // (a laser's software, a print shop's upload) must read, so give it the usual 0644.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    let tmp = builder.tempfile_in(dir)?;
    // Held until the temp file is closed (renamed into place or deleted): see `sweep_temps`.
    let _ = tmp.as_file().try_lock();
    Ok(tmp)
}

/// `path`'s new content, written in full to a temp file beside it (not yet in place).
fn staged(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<NamedTempFile, WriteError> {
    let err = |e| write_error(path, e);
    let mut tmp = temp_in(folder_of(path)).map_err(err)?;
    f(tmp.as_file_mut()).map_err(err)?;
    Ok(tmp)
}

/// What [`crate::replace_all`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Replaced {
    /// The files written, in order.
    pub written: Vec<PathBuf>,
    /// Files of the owned names that were there, were not written again, and are gone.
    pub removed: Vec<PathBuf>,
}

/// How long a new, still empty temp file is left alone by [`sweep_temps`]: a writer creates its
/// temp file, then locks it, and in between another run's sweep must not take it for an orphan.
const FRESH_TEMP: std::time::Duration = std::time::Duration::from_secs(60);

/// Delete the hidden temp files in `dir` that a killed write left: a temp file is locked by the
/// process writing it for as long as that process lives, so one that can be locked is an orphan.
/// (A temp of an older stencil, which took no lock, is an orphan too.) One still empty and less
/// than [`FRESH_TEMP`] old may be a live write's that is not locked yet: it is left for a later
/// sweep, so that concurrent runs writing into one folder never delete each other's temp files.
pub(crate) fn sweep_temps(dir: &Path) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let name = e.file_name();
        let name = name.to_string_lossy();
        if !(name.starts_with(TEMP_PREFIX) && name.ends_with(".tmp")) {
            continue;
        }
        let Ok(m) = std::fs::symlink_metadata(e.path()) else {
            continue;
        };
        if !m.is_file() {
            continue;
        }
        let fresh = m
            .modified()
            .ok()
            .and_then(|t| t.elapsed().ok())
            .is_none_or(|age| age < FRESH_TEMP);
        if m.len() == 0 && fresh {
            continue;
        }
        let Ok(f) = std::fs::File::open(e.path()) else {
            continue;
        };
        if f.try_lock().is_ok() {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_and_leaves_no_temp_on_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        write_atomic(&p, b"hello").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"hello");

        let q = dir.path().join("b.txt");
        let r = write_atomic_with(&q, |_| Err(std::io::Error::other("boom")));
        assert!(r.is_err());
        assert!(!q.exists());
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
            assert_eq!(
                mode & 0o044,
                0o044,
                "outputs are readable by others: {mode:o}"
            );
        }
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "only a.txt remains: {names:?}");
    }
}
