//! What `stencil` accepts, in one place: sizes that make physical sense, and pictures, options and
//! files that fit in reasonable time and memory. The CLI's option parsers and `--help` texts read
//! these constants; the checks that need the picture (its size in pixels) are here too, and the
//! pipeline calls them before the stage they protect.
//!
//! ## Sizes
//!
//! - The picture is at most [`MAX_PICTURE_MM`] (10 m) on its longer side: larger than any
//!   machine's bed, and small enough that every coordinate stays far inside what Clipper's and the
//!   triangulation's fixed-point and floating-point ranges hold.
//! - A pixel is at least [`MIN_PIXEL_MM`] (1 µm): finer than any laser, knife or etch resolves.
//! - With the design-rule clean-up (the default), the material's smallest feature is at most
//!   [`MAX_PX_PER_FEATURE`] working pixels: the clean-up's time grows with the pixels times the
//!   square of that width (a 2000 × 2000 photo: 25 px 0.3 s, 50 px 0.75 s, 100 px 2.8 s, 200 px
//!   10 s; rings.png supersampled to 2560 × 2560 at 1.25 µm pixels, 400 px, 30 s), and the
//!   automatic supersampling aims for 5.
//! - `--margin-mm` is at most [`MAX_MARGIN_MM`], `--tolerance-mm` at most [`MAX_TOLERANCE_MM`] (or
//!   0), `--mask-dpi` within [`MASK_DPI`].
//!
//! ## Pictures, time and memory
//! Measured in docs/measurements.md: the default `--max-pixels` of `make` and `tone` is
//! [`DEFAULT_MAX_PIXELS`] (50 MP: under 10 s and about 1.3 GB in make), `check`'s is
//! [`CHECK_DEFAULT_MAX_PIXELS`], it can be raised up to [`MAX_PIXELS_CEILING`], and whatever it
//! says, a picture whose decoded buffers would need more than `MAX_DECODE_BYTES` is refused from
//! its header, before any pixel is decoded.

use crate::units::{Scale, Size};

/// Most layers a set may have (`layers`).
pub const MAX_LAYERS: u32 = 6;

/// Most tiles along each side of a tiled stencil (`tiles`).
pub const MAX_TILES_PER_SIDE: u32 = 12;

/// The narrowest overlap past a seam, mm: the strip each tile keeps there holds it together.
pub const MIN_TILE_OVERLAP_MM: f64 = 0.5;

/// The widest overlap past a seam, mm.
pub const MAX_TILE_OVERLAP_MM: f64 = 50.0;

/// The longest side of the picture on the sheet, in mm (10 m).
pub const MAX_PICTURE_MM: f64 = 10_000.0;

/// The smallest pixel, in mm (1 µm), of the picture and of the working image.
pub const MIN_PIXEL_MM: f64 = 0.001;

/// With the design-rule clean-up, the most working pixels across the material's smallest feature
/// (see the module notes).
pub const MAX_PX_PER_FEATURE: f64 = 50.0;

/// The largest `--margin-mm`.
pub const MAX_MARGIN_MM: f64 = 1_000.0;

/// The largest `--tolerance-mm` (0 turns simplification off; below [`MIN_PIXEL_MM`] it is refused).
pub const MAX_TOLERANCE_MM: f64 = 10.0;

/// `--mask-dpi`: from one dot per millimetre to one per [`MIN_PIXEL_MM`].
pub const MASK_DPI: std::ops::RangeInclusive<f64> = 25.4..=25_400.0;

/// The default `--max-pixels` of `make` and `tone` (see the module notes).
pub const DEFAULT_MAX_PIXELS: u64 = 50_000_000;

/// The default `--max-pixels` of `check` (it vectorises and triangulates but does not clean up or
/// bridge: about 9 bytes per pixel; a 100 MP stencil in about 4 s).
pub const CHECK_DEFAULT_MAX_PIXELS: u64 = 100_000_000;

/// The largest `--max-pixels` accepted: 200 MP needs about 4.5 GB and 25 s in `make`, a minute
/// in `tone`.
pub const MAX_PIXELS_CEILING: u64 = 200_000_000;

/// A picture whose decoded buffers (the decoder's output at its bit depth, plus the gray in f32)
/// would need more than this (2 GiB) is refused from its header, whatever `--max-pixels` says: an
/// 8-bit gray or RGB picture at [`MAX_PIXELS_CEILING`] fits (1.0 and 1.4 GB), a 16-bit RGBA one
/// (2.4 GB) does not. The decoder is held to it too, and its buffer is allocated fallibly.
pub(crate) const MAX_DECODE_BYTES: u64 = 2 << 30;

/// The automatic supersampling never makes the working image larger than this (16 MP; see
/// [`crate::tone::resolution`]).
pub(crate) const AUTO_MAX_WORKING_PIXELS: u64 = 16_000_000;

/// A mesh is never rendered with more working pixels (size × supersample²) than this.
pub(crate) const MESH_MAX_WORKING_PIXELS: u64 = 80_000_000;

/// A size that makes no physical sense, or that stencil cannot work at, as data: what set the size
/// and the numbers that rule it out. The message here says what is wrong; the `stencil` binary
/// words it with the option to change (`--width-mm`, `--dpi`, `--scale`, `--filter-radius`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SizeError {
    /// A width or resolution that is not a finite number > 0 (`size` holds it).
    #[error("{} is not a size: use a finite number > 0", size_value(*size))]
    NotPositive {
        /// The size given.
        size: Size,
    },
    /// The size makes pixels too small or too large.
    #[error(
        "{} makes the {width_px}x{height_px} px picture {} x {} mm with pixels of {} mm; {}; {}",
        size_name(*size), num(*width_mm), num(*height_mm), num(*mm_per_px), out_of_range_reason(*mm_per_px),
        accepted_range(*size, *range)
    )]
    OutOfRange {
        /// What set the size.
        size: Size,
        /// The picture's width, px.
        width_px: u32,
        /// Its height, px.
        height_px: u32,
        /// The width that makes, mm.
        width_mm: f64,
        /// The height, mm.
        height_mm: f64,
        /// Millimetres per pixel.
        mm_per_px: f64,
        /// The values this picture accepts, rounded inwards to 4 significant digits, if any: in
        /// dots per inch for [`Size::Dpi`], else the picture's width in mm.
        range: Option<(f64, f64)>,
    },
    /// Working pixels so fine a feature spans too many.
    #[error(
        "working pixels of {} mm make the material's smallest feature ({feature_mm} mm) \
         {} pixels wide, more than the {MAX_PX_PER_FEATURE} stencil works with (the clean-up's time \
         grows with its square); {}",
        num(*mm_per_px), num(*feature_px), fix
    )]
    TooFine {
        /// What set the picture's size.
        size: Size,
        /// The supersampling factor.
        factor: u32,
        /// Millimetres per working pixel.
        mm_per_px: f64,
        /// The material's smallest feature, mm.
        feature_mm: f64,
        /// That feature in working pixels.
        feature_px: f64,
        /// What to change.
        fix: FinerFix,
    },
    /// A speck filter radius too large for the image.
    #[error("a filter radius of {radius} px is larger than this {width}x{height} px working image allows: use 0..={max} (a quarter of its shorter side)")]
    FilterRadius {
        /// The radius given, px.
        radius: u32,
        /// The working image's width, px.
        width: u32,
        /// Its height, px.
        height: u32,
        /// The largest radius allowed, px.
        max: u32,
    },
}

/// What makes working pixels coarse enough again ([`SizeError::TooFine`]); the numbers are rounded
/// to 4 significant digits on the accepted side.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum FinerFix {
    /// Supersample by at most this factor (the factor was given and is the only cause).
    #[error("supersample {0}x or less")]
    ScaleAtMost(u32),
    /// Size the picture at most this many dots per inch.
    #[error("use {} dpi or less (or a picture with fewer pixels)", num(*.0))]
    DpiAtMost(f64),
    /// Make the picture at least this wide, in mm.
    #[error("make the picture {} mm wide or more (or use a picture with fewer pixels)", num(*.0))]
    WidthMmAtLeast(f64),
}

/// A size's value with its unit, for a message.
fn size_value(size: Size) -> String {
    match size {
        Size::Default => format!("{} mm per pixel", Scale::default().mm_per_px),
        Size::WidthMm(v) => format!("a width of {v} mm"),
        Size::Dpi(v) => format!("{v} dpi"),
    }
}

/// What set the size, for a message.
fn size_name(size: Size) -> String {
    match size {
        Size::Default => format!(
            "the default size of {} mm per pixel",
            Scale::default().mm_per_px
        ),
        Size::WidthMm(v) => format!("a width of {} mm", num(v)),
        Size::Dpi(v) => format!("{} dpi", num(v)),
    }
}

/// Which bound a picture's size breaks: its pixels are too fine, or it is too large.
pub fn out_of_range_reason(mm_per_px: f64) -> String {
    if mm_per_px < MIN_PIXEL_MM {
        format!("pixels must be at least {MIN_PIXEL_MM} mm (1 micron)")
    } else {
        format!("the picture must be at most {MAX_PICTURE_MM} mm (10 m) on its longer side")
    }
}

fn accepted_range(size: Size, range: Option<(f64, f64)>) -> String {
    match (size, range) {
        (Size::Dpi(_), Some((lo, hi))) => {
            format!("use {} to {} dpi for this picture", num(lo), num(hi))
        }
        (_, Some((lo, hi))) => format!("make the picture {} to {} mm wide", num(lo), num(hi)),
        (_, None) => "no size fits a picture of this shape: crop or resize it".to_string(),
    }
}

/// Relative slack on the bounds, so that a bound printed to 4 significant digits is accepted.
const SLACK: f64 = 1e-6;

/// A number for a message: plain up to 6 significant digits, in exponent form when very large or
/// small.
pub fn num(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if !(1e-4..1e9).contains(&a) {
        let e = format!("{v:.3e}");
        let (mantissa, exp) = e.split_once('e').unwrap_or((&e, "0"));
        let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
        return format!("{mantissa}e{exp}");
    }
    let s = format!("{:.*}", (5 - a.log10().floor() as i32).max(0) as usize, v);
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// `v` rounded to 4 significant digits, up or down (so that a range printed in a message only
/// holds accepted values).
fn round_sig(v: f64, up: bool) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let p = 10f64.powi(3 - v.abs().log10().floor() as i32);
    // Binary noise (320 × 25.4 / 10000 = 0.8128000000000001) is not a digit to round up.
    let r = if up {
        (v * p - 1e-6).ceil()
    } else {
        (v * p + 1e-6).floor()
    };
    r / p
}

/// `value` of `size` if it is a finite number > 0.
fn positive(size: Size, value: f64) -> Result<f64, SizeError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(SizeError::NotPositive { size })
    }
}

/// Millimetres per pixel of a `width_px` × `height_px` picture at `size`, refused when the picture
/// would be larger than [`MAX_PICTURE_MM`] or its pixels finer than [`MIN_PIXEL_MM`].
pub(crate) fn picture_scale(size: Size, width_px: u32, height_px: u32) -> Result<Scale, SizeError> {
    let (w, h) = (f64::from(width_px.max(1)), f64::from(height_px.max(1)));
    let long = w.max(h);
    let (scale, range) = match size {
        // The default is given as a width.
        Size::Default => (
            Scale::default(),
            Some((w * MIN_PIXEL_MM, MAX_PICTURE_MM * w / long)),
        ),
        Size::WidthMm(v) => (
            Scale::from_width(width_px, positive(size, v)?),
            Some((w * MIN_PIXEL_MM, MAX_PICTURE_MM * w / long)),
        ),
        Size::Dpi(v) => (
            Scale::from_dpi(positive(size, v)?),
            Some((long * 25.4 / MAX_PICTURE_MM, 25.4 / MIN_PIXEL_MM)),
        ),
    };
    let mm = scale.mm_per_px;
    // A hair of slack so that the printed bounds themselves are accepted.
    let ok = mm >= MIN_PIXEL_MM * (1.0 - SLACK) && long * mm <= MAX_PICTURE_MM * (1.0 + SLACK);
    if ok {
        return Ok(scale);
    }
    Err(SizeError::OutOfRange {
        size,
        width_px,
        height_px,
        width_mm: w * mm,
        height_mm: h * mm,
        mm_per_px: mm,
        range: range
            .filter(|(lo, hi)| lo <= hi)
            .map(|(lo, hi)| (round_sig(lo, true), round_sig(hi, false))),
    })
}

/// With the design-rule clean-up: refuse a working pixel so fine that the material's smallest
/// feature is more than [`MAX_PX_PER_FEATURE`] pixels, or finer than [`MIN_PIXEL_MM`].
///
/// `size` and `width_px` say how the picture was sized (for the message), `factor` is the
/// supersampling and whether it was given (`--scale`).
pub(crate) fn check_working_pixel(
    size: Size,
    width_px: u32,
    working: Scale,
    factor: u32,
    factor_given: bool,
    feature_mm: f64,
) -> Result<(), SizeError> {
    let mm = working.mm_per_px;
    let feature_px = feature_mm / mm;
    // The finest working pixel allowed, and the picture pixel that gives it at this factor.
    let finest = (feature_mm / MAX_PX_PER_FEATURE).max(MIN_PIXEL_MM);
    if mm >= finest * (1.0 - SLACK) {
        return Ok(());
    }
    let input_mm = mm * f64::from(factor);
    let fix = if factor_given && factor > 1 && input_mm >= finest {
        FinerFix::ScaleAtMost((input_mm / finest).floor().max(1.0) as u32)
    } else {
        let need = finest * f64::from(factor);
        match size {
            Size::Dpi(_) => FinerFix::DpiAtMost(round_sig(25.4 / need, false)),
            _ => FinerFix::WidthMmAtLeast(round_sig(need * f64::from(width_px.max(1)), true)),
        }
    };
    Err(SizeError::TooFine {
        size,
        factor,
        mm_per_px: mm,
        feature_mm,
        feature_px,
        fix,
    })
}

/// The largest `--filter-radius` for a working image: a quarter of its shorter side (at least 1).
/// The filter pads the image by the radius on every side, so this keeps its copies within about
/// 2.25 times the image.
pub(crate) fn max_filter_radius(width: u32, height: u32) -> u32 {
    (width.min(height) / 4).max(1)
}

/// Refuse a filter radius over [`max_filter_radius`].
pub(crate) fn check_filter_radius(radius: u32, width: u32, height: u32) -> Result<(), SizeError> {
    let max = max_filter_radius(width, height);
    if radius > max {
        return Err(SizeError::FilterRadius {
            radius,
            width,
            height,
            max,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_well() {
        assert_eq!(num(0.32), "0.32");
        assert_eq!(num(10000.0), "10000");
        assert_eq!(num(1e15), "1e15");
        assert_eq!(num(3.125e-9), "3.125e-9");
        assert_eq!(num(0.1), "0.1");
        assert_eq!(round_sig(0.123456, true), 0.1235);
        assert_eq!(round_sig(0.123456, false), 0.1234);
    }

    /// The range a refused size carries (in the size's own unit).
    fn range_of(size: Size, w: u32, h: u32) -> Option<(f64, f64)> {
        match picture_scale(size, w, h) {
            Err(SizeError::OutOfRange { range, .. }) => range,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn picture_sizes_are_bounded_with_the_range_in_the_error() {
        assert!(picture_scale(Size::WidthMm(200.0), 320, 320).is_ok());
        assert!(picture_scale(Size::Default, 100_000, 1).is_ok());
        assert_eq!(
            range_of(Size::WidthMm(1e15), 320, 320),
            Some((0.32, 10000.0))
        );
        assert_eq!(
            range_of(Size::Dpi(1e-300), 320, 320),
            Some((0.8128, 25400.0))
        );
        assert_eq!(range_of(Size::Dpi(1e6), 320, 320), Some((0.8128, 25400.0)));
        let e = picture_scale(Size::WidthMm(1e-6), 320, 320)
            .unwrap_err()
            .to_string();
        assert!(e.contains("pixels must be at least"), "{e}");
        // The height counts too: a tall picture at 10 m wide is refused.
        assert_eq!(
            range_of(Size::WidthMm(10_000.0), 100, 200),
            Some((0.1, 5000.0))
        );
        // The printed bounds are accepted.
        assert!(picture_scale(Size::WidthMm(0.32), 320, 320).is_ok());
        assert!(picture_scale(Size::Dpi(0.8128), 320, 320).is_ok());
        assert!(picture_scale(Size::Dpi(25_400.0), 320, 320).is_ok());
        assert!(matches!(
            picture_scale(Size::WidthMm(f64::NAN), 1, 1),
            Err(SizeError::NotPositive { .. })
        ));
    }

    /// The fix a refused working pixel carries.
    fn fix_of(r: Result<(), SizeError>) -> FinerFix {
        match r {
            Err(SizeError::TooFine { fix, .. }) => fix,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn working_pixels_finer_than_the_material_needs_are_refused() {
        let ok = Scale { mm_per_px: 0.1 };
        assert!(check_working_pixel(Size::Default, 320, ok, 1, false, 0.5).is_ok());
        // 0.001 mm per pixel: cardstock's 0.5 mm is 500 px.
        let fine = Scale { mm_per_px: 0.001 };
        assert_eq!(
            fix_of(check_working_pixel(
                Size::WidthMm(0.32),
                320,
                fine,
                1,
                false,
                0.5
            )),
            FinerFix::WidthMmAtLeast(3.2)
        );
        // Too fine only because of --scale: lower it.
        let s = Scale {
            mm_per_px: 0.02 / 8.0,
        };
        assert_eq!(
            fix_of(check_working_pixel(
                Size::WidthMm(6.4),
                320,
                s,
                8,
                true,
                0.5
            )),
            FinerFix::ScaleAtMost(2)
        );
    }
}
