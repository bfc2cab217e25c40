//! Stage 1: the two-tone image, from a picture ([`load_gray`]) or a mesh ([`mesh`]), then the
//! topological filter ([`FilterConfig`]), or the design-rule regularisation, that removes specks before islands are labelled.

pub(crate) mod adjust;
mod error;
pub(crate) mod filter;
pub(crate) mod image;
mod level;
pub(crate) mod likeness;
pub mod mesh;
pub(crate) mod regularize;
pub(crate) mod resolution;

pub use adjust::Adjust;
pub use error::ToneError;
pub use filter::{FilterConfig, FilterStats};
pub use image::{load_gray, orientation_note, picture_size, png_mm_per_px};
pub(crate) use level::{bits_at, is_light, threshold};
pub use level::{by_picture, otsu_level, uneven_page, Threshold};
pub use likeness::{likeness, LevelChoice, Likeness};
pub use resolution::{AutoScale, ScaleCap};

/// Options of the image path of stage 1.
#[derive(Clone, Debug)]
pub struct ToneConfig {
    /// How gray becomes two tones.
    pub threshold: Threshold,
    /// Light is material by default (paint or light passes through the dark parts, which are cut).
    /// `invert` makes the dark parts material instead: the paper's "connect the lit regions".
    pub invert: bool,
    /// Supersampling factor: the gray is upsampled smoothly by this factor (1..=8) before
    /// thresholding, so edges follow the picture instead of its pixel staircase. 1 = off; `None`
    /// = chosen from the material and the tolerance (`resolution::auto`).
    pub scale: Option<u32>,
    /// Refuse images with more pixels than this, before decoding them; a working image (after
    /// supersampling) is never larger either.
    pub max_pixels: u64,
    /// Picture adjustments before the threshold (crop, turns, tone, smoothing, abstraction, local
    /// threshold); ignored for a mesh.
    pub adjust: Adjust,
}

impl Default for ToneConfig {
    fn default() -> Self {
        ToneConfig {
            threshold: Threshold::default(),
            invert: false,
            scale: None,
            max_pixels: crate::limits::DEFAULT_MAX_PIXELS,
            adjust: Adjust::default(),
        }
    }
}
