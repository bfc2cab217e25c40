//! Why the outputs could not be encoded or written (its own leaf, so every encoder shares it).

use std::path::PathBuf;

use stencil_io::WriteError;

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
    /// A mask resolution that is not a finite number > 0 (`MaskConfig::dpi`).
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
