//! The two-tone stage's errors (a leaf: the picture reader and the mesh share them).

use std::path::PathBuf;

use super::mesh::error::MeshError;

/// Errors of the two-tone stage. Each names the file and says what to do.
#[derive(Debug, thiserror::Error)]
pub enum ToneError {
    /// Refused by the bounded reader: too large for a picture, or not a regular file.
    #[error(transparent)]
    Read(#[from] stencil_io::ReadError),
    /// The file could not be opened.
    #[error("{path}: cannot open: {source}")]
    Open {
        /// The picture.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    #[error("{path}: not an image stencil can read (PNG, JPEG, BMP or TIFF expected){detail}")]
    /// Not a PNG, JPEG, BMP or TIFF.
    UnknownFormat {
        /// The picture.
        path: PathBuf,
        /// What it looks like instead, if known (with its leading `; `).
        detail: String,
    },
    #[error("{path}: the image is damaged or truncated ({msg}); re-export it from your editor")]
    /// Damaged or truncated.
    Decode {
        /// The picture.
        path: PathBuf,
        /// What the decoder said.
        msg: String,
    },
    /// A valid file of a variant the decoders do not read (a TIFF compression or bit depth).
    #[error(
        "{path}: this kind of image is not supported ({msg}); the file may be fine: convert it \
         to an 8-bit PNG (or a plain JPEG) in your editor, or e.g. `magick in.tif out.png`"
    )]
    Unsupported {
        /// The picture.
        path: PathBuf,
        /// What the decoder said.
        msg: String,
    },
    /// More pixels than the limit.
    #[error(
        "{path}: {width}x{height} pixels ({mp:.1} megapixels) is above the limit of {limit_mp:.1} megapixels; \
         downscale the image or raise the pixel limit (at most {})", crate::limits::MAX_PIXELS_CEILING
    )]
    TooLarge {
        /// The picture.
        path: PathBuf,
        /// Width, px.
        width: u32,
        /// Height, px.
        height: u32,
        /// Its size, megapixels.
        mp: f64,
        /// The limit, megapixels.
        limit_mp: f64,
    },
    #[error("{path}: the {format} file is truncated (it ends before its end-of-image marker, so part of the picture is missing); download or export it again")]
    /// Ends before its end-of-image marker.
    Truncated {
        /// The picture.
        path: PathBuf,
        /// The format (`JPEG`).
        format: &'static str,
    },
    /// It would take more memory to decode than stencil allows.
    #[error(
        "{path}: {width}x{height} pixels would need {gb:.1} GB to decode, more than the {limit_gb:.1} GB \
         stencil allows whatever the pixel limit; downscale the image"
    )]
    TooMuchMemory {
        /// The picture.
        path: PathBuf,
        /// Width, px.
        width: u32,
        /// Height, px.
        height: u32,
        /// Memory needed, GB.
        gb: f64,
        /// The limit, GB.
        limit_gb: f64,
    },
    #[error("{path}: the decoder needed more than the {limit_gb:.1} GB of memory stencil allows for a picture; the file may be damaged, or downscale the image")]
    /// The decoder hit the memory limit.
    DecoderLimit {
        /// The picture.
        path: PathBuf,
        /// The limit, GB.
        limit_gb: f64,
    },
    #[error("{path}: the image has no pixels")]
    /// No pixels.
    Empty {
        /// The picture.
        path: PathBuf,
    },
    /// A supersampling factor outside 1..=8.
    #[error("scale factor {0} is out of range: use 1 to 8")]
    BadScale(u32),
    /// Supersampled, more working pixels than the limit.
    #[error(
        "{path}: a scale factor of {factor} makes {width}x{height} working pixels ({mp:.1} \
         megapixels), above the limit of {limit_mp:.1} megapixels; lower the factor (or let stencil \
         choose it) or raise the pixel limit"
    )]
    ScaleTooLarge {
        /// The picture.
        path: PathBuf,
        /// The factor.
        factor: u32,
        /// Working width, px.
        width: u64,
        /// Working height, px.
        height: u64,
        /// Working size, megapixels.
        mp: f64,
        /// The limit, megapixels.
        limit_mp: f64,
    },
    /// Loading or rendering a mesh.
    #[error(transparent)]
    Mesh(#[from] MeshError),
}
impl ToneError {
    /// The picture or mesh this error is about (its message starts with it); `None` for a
    /// setting out of range.
    pub fn subject(&self) -> Option<&std::path::Path> {
        use ToneError::*;
        match self {
            Read(e) => Some(e.subject()),
            Mesh(e) => e.subject(),
            BadScale(_) => None,
            Open { path, .. }
            | UnknownFormat { path, .. }
            | Decode { path, .. }
            | Unsupported { path, .. }
            | TooLarge { path, .. }
            | Truncated { path, .. }
            | TooMuchMemory { path, .. }
            | DecoderLimit { path, .. }
            | Empty { path }
            | ScaleTooLarge { path, .. } => Some(path),
        }
    }
}
