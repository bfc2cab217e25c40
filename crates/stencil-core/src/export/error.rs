//! Why the outputs could not be encoded or written (its own leaf, so every encoder shares it).

use std::path::PathBuf;

use stencil_io::WriteError;

#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error(transparent)]
    Write(#[from] WriteError),
    #[error("{path}: cannot create the output folder: {source}")]
    CreateDir {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: cannot encode: {msg}")]
    Encode { path: PathBuf, msg: String },
    /// A mask resolution that is not a finite number > 0 ([`super::mask::MaskConfig::dpi`]).
    #[error("mask.png: cannot encode: the mask resolution must be > 0 dpi, got {0}")]
    MaskDpi(f64),
    /// The mask would have more pixels than `mask::MAX_MASK_PIXELS`.
    #[error("mask.png: cannot encode: {width}x{height} pixels at {dpi} dpi is too large")]
    MaskTooLarge { width: u32, height: u32, dpi: f64 },
}
