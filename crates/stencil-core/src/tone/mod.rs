//! Stage 1: the two-tone image, from a picture ([`load_gray`]) or a mesh ([`mesh`]), then the
//! topological filter ([`FilterConfig`]), or the design-rule regularisation, that removes specks before islands are labelled.

pub mod adjust;
pub(crate) mod filter;
pub(crate) mod image;
pub mod likeness;
pub mod mesh;
pub(crate) mod regularize;
pub(crate) mod resolution;

pub use adjust::Adjust;
pub use filter::{FilterConfig, FilterStats};
pub use image::{load_gray, orientation_note, picture_size};
pub use likeness::{likeness, LevelChoice, Likeness};
pub use regularize::RegularizeStats;
pub use resolution::{AutoScale, ScaleCap};

use std::path::PathBuf;
use std::sync::Arc;

use crate::raster::{BitGrid, Gray, TwoTone};

/// Errors of the two-tone stage. Each names the file and says what to do.
#[derive(Debug, thiserror::Error)]
pub enum ToneError {
    /// Refused by the bounded reader: too large for a picture, or not a regular file.
    #[error(transparent)]
    Read(#[from] stencil_io::ReadError),
    #[error("{path}: cannot open: {source}")]
    Open {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not an image stencil can read (PNG, JPEG, BMP or TIFF expected){detail}")]
    UnknownFormat { path: PathBuf, detail: String },
    #[error("{path}: the image is damaged or truncated ({msg}); re-export it from your editor")]
    Decode { path: PathBuf, msg: String },
    /// A valid file of a variant the decoders do not read (a TIFF compression or bit depth).
    #[error(
        "{path}: this kind of image is not supported ({msg}); the file may be fine: convert it \
         to an 8-bit PNG (or a plain JPEG) in your editor, or e.g. `magick in.tif out.png`"
    )]
    Unsupported { path: PathBuf, msg: String },
    #[error(
        "{path}: {width}x{height} pixels ({mp:.1} megapixels) is above the limit of {limit_mp:.1} megapixels; \
         downscale the image or raise the pixel limit (at most {})", crate::limits::MAX_PIXELS_CEILING
    )]
    TooLarge {
        path: PathBuf,
        width: u32,
        height: u32,
        mp: f64,
        limit_mp: f64,
    },
    #[error("{path}: the {format} file is truncated (it ends before its end-of-image marker, so part of the picture is missing); download or export it again")]
    Truncated { path: PathBuf, format: &'static str },
    #[error(
        "{path}: {width}x{height} pixels would need {gb:.1} GB to decode, more than the {limit_gb:.1} GB \
         stencil allows whatever the pixel limit; downscale the image"
    )]
    TooMuchMemory {
        path: PathBuf,
        width: u32,
        height: u32,
        gb: f64,
        limit_gb: f64,
    },
    #[error("{path}: the decoder needed more than the {limit_gb:.1} GB of memory stencil allows for a picture; the file may be damaged, or downscale the image")]
    DecoderLimit { path: PathBuf, limit_gb: f64 },
    #[error("{path}: the image has no pixels")]
    Empty { path: PathBuf },
    #[error("scale factor {0} is out of range: use 1 to 8")]
    BadScale(u32),
    #[error(
        "{path}: a scale factor of {factor} makes {width}x{height} working pixels ({mp:.1} \
         megapixels), above the limit of {limit_mp:.1} megapixels; lower the factor (or let stencil \
         choose it) or raise the pixel limit"
    )]
    ScaleTooLarge {
        path: PathBuf,
        factor: u32,
        width: u64,
        height: u64,
        mp: f64,
        limit_mp: f64,
    },
    #[error(transparent)]
    Mesh(#[from] mesh::MeshError),
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

/// How grayscale becomes two tones.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Threshold {
    /// A fixed level, 0..255 on the 8-bit scale: a pixel at or above it is light.
    Level(u8),
    /// Otsu's method: the level that best separates the histogram into two classes.
    Otsu,
    /// The level whose cleaned-up two-tone looks most like the picture (see [`likeness()`]): every
    /// level is tried through the clean-up the material needs and the likeliest kept. For a
    /// rendered mesh, which has no gray picture to resemble, the same as `Otsu`.
    Auto,
}

impl Default for Threshold {
    fn default() -> Self {
        Threshold::Level(128)
    }
}

/// Options of the image path of stage 1.
#[derive(Clone, Debug)]
pub struct ToneConfig {
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

/// Otsu's threshold on a gray in 0..1, as an 8-bit level: the level maximising between-class variance.
pub fn otsu_level(gray: &Gray) -> u8 {
    let mut hist = [0u64; 256];
    for &v in &gray.data {
        hist[(v.clamp(0.0, 1.0) * 255.0).round() as usize] += 1;
    }
    let total: u64 = hist.iter().sum();
    let sum_all: f64 = hist
        .iter()
        .enumerate()
        .map(|(i, &c)| i as f64 * c as f64)
        .sum();
    let (mut w0, mut sum0) = (0u64, 0f64);
    let (mut best, mut best_t) = (-1f64, 128u8);
    for t in 0..256usize {
        // Class 0 = levels below t.
        if t > 0 {
            w0 += hist[t - 1];
            sum0 += (t - 1) as f64 * hist[t - 1] as f64;
        }
        let w1 = total - w0;
        if w0 == 0 || w1 == 0 {
            continue;
        }
        let m0 = sum0 / w0 as f64;
        let m1 = (sum_all - sum0) / w1 as f64;
        let between = w0 as f64 * w1 as f64 * (m0 - m1) * (m0 - m1);
        if between > best {
            best = between;
            best_t = t as u8;
        }
    }
    best_t
}

/// Whether a gray value (0 = black .. 1 = white) is light at the 8-bit `level`, for both the
/// picture's and the mesh's two tones. Compared on the 8-bit scale, so `--threshold 128` means what
/// a user of an image editor expects; level 0 makes every value light, even one below 0 or NaN.
///
/// `round(v·255) >= level` written without the rounding (a library call in the per-pixel loops):
/// for level >= 1, rounding half away from zero reaches `level` exactly from `level - 0.5` up
/// (exact in f32), and a negative or NaN value never does.
#[inline]
pub(crate) fn is_light(v: f32, level: u8) -> bool {
    v * 255.0 >= level as f32 - 0.5 || level == 0
}

/// Threshold a gray into two tones: light (at or above the level) is material unless `invert`.
/// Returns the two-tone and the level used.
pub(crate) fn threshold(gray: Arc<Gray>, threshold: Threshold, invert: bool) -> (TwoTone, u8) {
    let level = match threshold {
        Threshold::Level(l) => l,
        Threshold::Otsu => otsu_level(&gray),
        // Provisional: the clean-up stage searches the levels (`pipeline::clean`).
        Threshold::Auto => 128,
    };
    let bits = bits_at(&gray, level, invert);
    (TwoTone { bits, gray }, level)
}

/// The two tones of `gray` at `level`: light (at or above it) is material unless `invert`.
pub fn bits_at(gray: &Gray, level: u8, invert: bool) -> BitGrid {
    BitGrid {
        width: gray.width,
        height: gray.height,
        data: gray
            .data
            .iter()
            .map(|&v| is_light(v, level) != invert)
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn is_light_is_the_rounded_comparison() {
        // Every f32 step around each half-level, a sweep of the range, and the odd values.
        let mut vs: Vec<f32> = vec![-1.0, -0.0, 0.0, 1.0, 2.0, f32::NAN, f32::INFINITY];
        for l in 0..=256 {
            let mut v = (l as f32 - 0.5) / 255.0;
            for _ in 0..8 {
                v = f32::from_bits(v.to_bits().wrapping_sub(1));
            }
            for _ in 0..16 {
                vs.push(v);
                v = f32::from_bits(v.to_bits() + 1);
            }
        }
        vs.extend((0..100_000).map(|i| i as f32 / 99_999.0));
        for level in 0..=255u8 {
            for &v in &vs {
                let rounded = (v * 255.0).round() >= level as f32 || level == 0;
                assert_eq!(is_light(v, level), rounded, "{v} at {level}");
            }
        }
    }

    #[test]
    fn otsu_splits_two_populations() {
        let mut g = Gray::new(100, 1, 0.2);
        for x in 50..100 {
            g.set(x, 0, 0.8);
        }
        let l = otsu_level(&g);
        assert!(l > 51 && l <= 204, "level {l}");
        let (tt, _) = threshold(g.into(), Threshold::Otsu, false);
        assert_eq!(tt.bits.count_material(), 50);
        assert!(tt.bits.get(99, 0));
    }

    #[test]
    fn invert_swaps_tones() {
        let mut g = Gray::new(4, 1, 0.0);
        g.set(0, 0, 1.0);
        let (a, _) = threshold(g.clone().into(), Threshold::Level(128), false);
        let (b, _) = threshold(g.into(), Threshold::Level(128), true);
        assert!(a.bits.get(0, 0) && !a.bits.get(1, 0));
        assert!(!b.bits.get(0, 0) && b.bits.get(1, 0));
    }
}
