//! Output files. Everything that touches the file system for output goes through here, and every
//! file is written atomically ([`stencil_io::write_atomic`], [`stencil_io::replace_all`]).

pub(crate) mod dxf;
mod error;
pub(crate) mod mask;
mod names;
pub mod png;
pub(crate) mod svg;

use std::path::Path;

pub use error::ExportError;
pub use mask::{Etch, MaskConfig, MaskReport, MaskSide, POLARITY};
pub use names::{owned_names, FOLDERS, OUTPUT_NAMES};
use stencil_io::plain_io;
pub use stencil_io::Replaced;

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
