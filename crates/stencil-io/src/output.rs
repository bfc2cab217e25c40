//! Output paths checked before a run does its work: an output never overwrites one of the run's
//! inputs, and never replaces what is not a regular file (a device node, a FIFO, a socket, a
//! folder). Why before: `simulate job.gcode -o job.gcode` used to turn the program into a PNG,
//! and `-o /dev/null` run as root replaced the device with a file.

use std::path::{Path, PathBuf};

use crate::disk::not_a_file;

/// An output path refused; every message names both paths where there are two.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{out}: this output is the input {input}; writing it would destroy the input (choose another output path)")]
    /// The output file is an input.
    IsInput {
        /// The output.
        out: PathBuf,
        /// The input it is.
        input: PathBuf,
    },
    #[error("{out}: this output folder's {name} would be replaced, and it is the input {input}; choose another folder with -o, or copy the input elsewhere first")]
    /// A file the output folder would replace is an input.
    ReplacesInput {
        /// The output folder.
        out: PathBuf,
        /// The file name in it.
        name: String,
        /// The input that file is.
        input: PathBuf,
    },
    #[error("{out}: is {is}; stencil writes only regular files and replaces nothing else (choose another output path)")]
    /// The output exists and is not a regular file.
    NotAFile {
        /// The output.
        out: PathBuf,
        /// What it is instead.
        is: &'static str,
    },
    #[error("{out}: is {is}, not a folder; -o names the folder the outputs go into")]
    /// The output folder exists and is not a folder.
    NotAFolder {
        /// The output folder.
        out: PathBuf,
        /// What it is instead.
        is: &'static str,
    },
}

/// Whether `a` and `b` are one file (the same inode through any name, link or hard link).
fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        match (a.canonicalize(), b.canonicalize()) {
            (Ok(x), Ok(y)) => x == y,
            _ => false,
        }
    }
}

/// Refuse the output file `out` when it is one of `inputs`, or there as anything but a regular
/// file (a link is followed: `-o /dev/stdout` is a device too).
pub fn check_output(out: &Path, inputs: &[&Path]) -> Result<(), OutputError> {
    if let Ok(m) = std::fs::metadata(out) {
        if let Some(is) = not_a_file(&m.file_type()) {
            return Err(OutputError::NotAFile {
                out: out.to_path_buf(),
                is,
            });
        }
    }
    for input in inputs {
        if same_file(out, input) {
            return Err(OutputError::IsInput {
                out: out.to_path_buf(),
                input: input.to_path_buf(),
            });
        }
    }
    Ok(())
}

/// Refuse the output folder `dir` when it is there as anything but a folder, when one of the
/// files it would replace (the `owned` names, in it or in its `previous/`) is one of `inputs`, or
/// when one of them is not a regular file.
pub fn check_output_dir(dir: &Path, owned: &[&str], inputs: &[&Path]) -> Result<(), OutputError> {
    match std::fs::metadata(dir) {
        Ok(m) if !m.is_dir() => {
            return Err(OutputError::NotAFolder {
                out: dir.to_path_buf(),
                is: not_a_file(&m.file_type()).unwrap_or("a file"),
            })
        }
        Ok(_) => {}
        Err(_) => return Ok(()),
    }
    let prev = dir.join(crate::swap::PREVIOUS_DIR);
    for folder in [dir, prev.as_path()] {
        for name in owned {
            let p = folder.join(name);
            let Ok(m) = std::fs::symlink_metadata(&p) else {
                continue;
            };
            if !(m.is_file() || m.file_type().is_symlink()) {
                return Err(OutputError::NotAFile {
                    out: p,
                    is: not_a_file(&m.file_type()).unwrap_or("not a regular file"),
                });
            }
            for input in inputs {
                if same_file(&p, input) {
                    return Err(OutputError::ReplacesInput {
                        out: dir.to_path_buf(),
                        name: p.strip_prefix(dir).unwrap_or(&p).display().to_string(),
                        input: input.to_path_buf(),
                    });
                }
            }
        }
    }
    Ok(())
}
