//! One way to write a file: into a temp file beside the target, then rename into place.
//!
//! A crash, a full disk or an error half-way never leaves a half-written output that a user (or a
//! laser) could pick up. Every output file (stencil outputs, G-code, the send journal) is written
//! through [`write_atomic`] or [`replace_all`].

use std::io::Write;
use std::path::{Path, PathBuf};

use tempfile::{NamedTempFile, TempPath};

/// A file that could not be written (or an old one removed); nothing half-written is left.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    #[error("{path}: cannot write: {source}")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: cannot remove this file of an earlier run: {source}; remove it yourself or choose another folder with -o")]
    Remove {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// Temp files and set-aside old files start with this (hidden, and never an output's name).
const TEMP_PREFIX: &str = ".stencil-";

/// Write `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// Write to `path` atomically through a closure that gets a buffered writer.
pub fn write_atomic_with(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), WriteError> {
    let tmp = staged(path, f)?;
    tmp.persist(path).map_err(|e| write_error(path, e.error))?;
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
    builder.tempfile_in(dir)
}

/// `path`'s new content, written in full to a temp file beside it (not yet in place).
fn staged(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<NamedTempFile, WriteError> {
    let err = |e| write_error(path, e);
    let mut tmp = temp_in(folder_of(path)).map_err(err)?;
    {
        let mut buf = std::io::BufWriter::new(tmp.as_file_mut());
        f(&mut buf).map_err(err)?;
        buf.flush().map_err(err)?;
    }
    Ok(tmp)
}

/// An I/O error as the operating system words it, once: the OS error alone (without the context
/// some libraries wrap around it, such as tempfile's temp file name), or the error as it was when
/// it carries no OS code and names no temp file.
pub fn plain_io(e: std::io::Error) -> std::io::Error {
    if let Some(code) = e.raw_os_error() {
        return std::io::Error::from_raw_os_error(code);
    }
    let Some(inner) = e.get_ref() else {
        return e;
    };
    let mut cause: Option<&(dyn std::error::Error + 'static)> = Some(inner);
    while let Some(c) = cause {
        if let Some(code) = c
            .downcast_ref::<std::io::Error>()
            .and_then(std::io::Error::raw_os_error)
        {
            return std::io::Error::from_raw_os_error(code);
        }
        cause = c.source();
    }
    if inner.to_string().contains(TEMP_PREFIX) {
        std::io::Error::from(e.kind())
    } else {
        e
    }
}

/// What [`replace_all`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Replaced {
    /// The files written, in order.
    pub written: Vec<PathBuf>,
    /// Files of the `stale` names that were there and are gone.
    pub removed: Vec<PathBuf>,
}

/// An old file moved aside (to a temp name in its folder) until the new set is in place; dropped,
/// it is deleted.
struct SetAside {
    original: PathBuf,
    backup: TempPath,
}

impl SetAside {
    /// Move `path` aside, if it is there as a file (or a link).
    fn take(path: &Path) -> std::io::Result<Option<SetAside>> {
        match std::fs::symlink_metadata(path) {
            Ok(m) if m.is_file() || m.file_type().is_symlink() => {}
            Ok(_) => return Ok(None),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e),
        }
        let backup = temp_in(folder_of(path))?.into_temp_path();
        std::fs::rename(path, &backup)?;
        Ok(Some(SetAside {
            original: path.to_path_buf(),
            backup,
        }))
    }

    /// Put the old file back where it was.
    fn restore(self) {
        if std::fs::rename(&self.backup, &self.original).is_ok() {
            // The temp name is gone: nothing left to delete.
            let _ = self.backup.keep();
        }
    }
}

/// Write a set of files into `dir`, all or nothing, and remove the files named in `stale` that
/// this set does not write (an earlier run's outputs that would otherwise sit beside the new ones).
///
/// Every new file is first written in full to a temp file; only when all are written are they
/// renamed into place, each old file being set aside under a temp name first. If anything fails,
/// the new files are removed and every old file is put back, so the folder is as it was. The old
/// files are deleted only once every new file is in place.
pub fn replace_all(
    dir: &Path,
    files: &[(String, Vec<u8>)],
    stale: &[&str],
) -> Result<Replaced, WriteError> {
    let mut staged_files = Vec::with_capacity(files.len());
    for (name, bytes) in files {
        let path = dir.join(name);
        let tmp = staged(&path, |w| w.write_all(bytes))?;
        staged_files.push((path, tmp));
    }
    // New files in place, with the old file each replaced (if any).
    let mut placed: Vec<(PathBuf, Option<SetAside>)> = Vec::new();
    let mut removed: Vec<SetAside> = Vec::new();
    let rollback = |placed: Vec<(PathBuf, Option<SetAside>)>, removed: Vec<SetAside>| {
        for (path, old) in placed.into_iter().rev() {
            match old {
                Some(old) => old.restore(),
                None => {
                    let _ = std::fs::remove_file(&path);
                }
            }
        }
        for old in removed {
            old.restore();
        }
    };
    for (path, tmp) in staged_files {
        let old = match SetAside::take(&path) {
            Ok(old) => old,
            Err(e) => {
                rollback(placed, removed);
                return Err(write_error(&path, e));
            }
        };
        if let Err(e) = tmp.persist(&path) {
            if let Some(old) = old {
                old.restore();
            }
            rollback(placed, removed);
            return Err(write_error(&path, e.error));
        }
        placed.push((path, old));
    }
    for name in stale {
        if files.iter().any(|(n, _)| n == name) {
            continue;
        }
        let path = dir.join(name);
        match SetAside::take(&path) {
            Ok(Some(old)) => removed.push(old),
            Ok(None) => {}
            Err(e) => {
                rollback(placed, removed);
                return Err(WriteError::Remove {
                    path,
                    source: plain_io(e),
                });
            }
        }
    }
    // Everything is in place: the old files (dropped here) are deleted.
    Ok(Replaced {
        written: placed.into_iter().map(|(p, _)| p).collect(),
        removed: removed.into_iter().map(|old| old.original).collect(),
    })
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
