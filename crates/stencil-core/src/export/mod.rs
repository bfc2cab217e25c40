//! Output files. Everything that touches the file system for output goes through here, and every
//! file is written atomically ([`stencil_io::write_atomic`], [`stencil_io::replace_all`]).

pub(crate) mod dxf;
pub(crate) mod mask;
mod names;
pub mod png;
pub(crate) mod svg;

use std::path::{Path, PathBuf};

pub use mask::{Etch, MaskConfig, MaskReport, MaskSide, POLARITY};
pub use names::{owned_names, FOLDERS, OUTPUT_NAMES};
pub use stencil_io::Replaced;
use stencil_io::{plain_io, WriteError};

/// Why an output file could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// Writing a file (all or nothing) failed.
    #[error(transparent)]
    Write(#[from] WriteError),
    /// The output folder could not be made.
    #[error("{path}: cannot create the output folder: {source}")]
    CreateDir {
        /// The folder.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    #[error("{path}: cannot encode: {msg}")]
    /// An encoder refused the data.
    Encode {
        /// The file.
        path: PathBuf,
        /// What the encoder said.
        msg: String,
    },
    /// A mask resolution that is not a finite number > 0 ([`mask::MaskConfig::dpi`]).
    #[error("mask.png: cannot encode: the mask resolution must be > 0 dpi, got {0}")]
    MaskDpi(f64),
    /// The mask would have more pixels than `mask::MAX_MASK_PIXELS`.
    #[error("mask.png: cannot encode: {width}x{height} pixels at {dpi} dpi is too large")]
    MaskTooLarge {
        /// Mask width, px.
        width: u32,
        /// Height, px.
        height: u32,
        /// The resolution asked for.
        dpi: f64,
    },
}

/// Create the output folder (if missing) up front, so a run fails before its work, not after.
pub(crate) fn prepare_dir(dir: &Path) -> Result<(), ExportError> {
    std::fs::create_dir_all(dir).map_err(|source| ExportError::CreateDir {
        path: dir.to_path_buf(),
        source: plain_io(source),
    })
}

/// Write a set of files into `dir` (created if missing), all or nothing, and remove the files
/// named in `stale` that this set does not write: see [`stencil_io::replace_all`]. If anything fails,
/// the folder is left as it was, old files included.
pub(crate) fn write_files(
    dir: &Path,
    files: &[(String, Vec<u8>)],
    stale: &[&str],
) -> Result<Replaced, ExportError> {
    prepare_dir(dir)?;
    Ok(stencil_io::replace_all(dir, files, stale)?)
}
