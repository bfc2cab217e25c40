//! Output files. Everything that touches the file system for output goes through here, and every
//! file is written atomically ([`atomic::write_atomic`]).

pub mod atomic;
pub mod dxf;
pub mod mask;
pub mod png;
pub mod svg;

use std::path::{Path, PathBuf};

pub use atomic::{write_atomic, write_atomic_with};

#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("{path}: cannot write: {source}")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: cannot create the output folder: {source}; choose another with -o")]
    CreateDir {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: cannot encode: {msg}")]
    Encode { path: PathBuf, msg: String },
}

/// Create the output folder (if missing) up front, so a run fails before its work, not after.
pub fn prepare_dir(dir: &Path) -> Result<(), ExportError> {
    std::fs::create_dir_all(dir).map_err(|source| ExportError::CreateDir {
        path: dir.to_path_buf(),
        source,
    })
}

/// Write a set of files into `dir` (created if missing), all or nothing: each file is written
/// atomically, and if one fails the ones this call already wrote are removed again.
pub fn write_files(dir: &Path, files: &[(String, Vec<u8>)]) -> Result<Vec<PathBuf>, ExportError> {
    std::fs::create_dir_all(dir).map_err(|source| ExportError::CreateDir {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut written = Vec::new();
    for (name, bytes) in files {
        let path = dir.join(name);
        if let Err(e) = write_atomic(&path, bytes) {
            for p in &written {
                let _ = std::fs::remove_file(p);
            }
            return Err(e);
        }
        written.push(path);
    }
    Ok(written)
}
