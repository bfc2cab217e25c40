//! The working resolution: how much a picture is supersampled before thresholding (the paper's
//! supersampling). Coarse pixels make every edge a staircase the cut follows; upsampling the gray
//! smoothly ([`super::image::upsample`]) first puts edges where the shading says. Unless the user
//! gives `--scale`, [`auto`] picks the factor.
//!
//! ## The rule
//! The working pixel must be at most [`target_mm_per_px`] = min(`min_feature_mm` / 5,
//! 2 × `tolerance_mm`), with the smallest factor K (1..=8) that gets there:
//! - **The smallest feature, 5 pixels**: later stages measure whole pixels and the check allows at
//!   least one, so features 1.0×, 1.2× and 1.6× the minimum stay distinct (5, 6, 8 px) and the
//!   allowance costs 20 % of the minimum.
//! - **The tolerance, half a pixel**: a traced edge lies within half a pixel of its raster, so the
//!   staircase stays within the simplification tolerance (0 does not raise the factor).
//!
//! The default (0.1 mm per pixel, cardstock's 0.5 mm, 0.05 mm) meets both: no supersampling.
//!
//! ## Memory
//! About 30–40 bytes per working pixel, so the automatic factor is capped to
//! [`AUTO_MAX_WORKING_PIXELS`] (about 0.6 GB) and `--max-pixels`, never below 1;
//! [`AutoScale::capped_by`] says which cap bound.

use serde::{Deserialize, Serialize};

use crate::limits::AUTO_MAX_WORKING_PIXELS;

/// The largest supersampling factor, automatic or given.
pub(crate) const MAX_FACTOR: u32 = 8;

/// Working pixels per `min_feature_mm` the automatic factor aims for (see the module notes).
pub(crate) const PX_PER_MIN_FEATURE: f64 = 5.0;

/// What limited an automatic factor below what the rule asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ScaleCap {
    /// The largest factor, `MAX_FACTOR`.
    MaxFactor,
    /// The memory budget, `AUTO_MAX_WORKING_PIXELS`.
    Memory,
    /// The caller's pixel limit (`--max-pixels` in the `stencil` binary).
    MaxPixels,
}

impl std::fmt::Display for ScaleCap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ScaleCap::MaxFactor => write!(f, "the largest factor, {MAX_FACTOR}"),
            ScaleCap::Memory => write!(
                f,
                "the memory budget of {} megapixels",
                AUTO_MAX_WORKING_PIXELS / 1_000_000
            ),
            ScaleCap::MaxPixels => write!(f, "the pixel limit"),
        }
    }
}

/// How an automatic factor was chosen (in the report as `scale_auto`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AutoScale {
    /// The coarsest working pixel the rule accepts, in mm (`target_mm_per_px`).
    pub target_mm_per_px: f64,
    /// The factor the rule asked for, before any cap.
    pub wanted: u32,
    /// What lowered the factor below `wanted`, if anything.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub capped_by: Option<ScaleCap>,
}

/// The coarsest working pixel, in mm, that resolves the material's smallest feature by
/// [`PX_PER_MIN_FEATURE`] pixels and keeps a pixel staircase within the tolerance (see the module
/// notes). A tolerance of 0 (no simplification) does not count.
pub(crate) fn target_mm_per_px(min_feature_mm: f64, tolerance_mm: f64) -> f64 {
    let feature = min_feature_mm / PX_PER_MIN_FEATURE;
    if tolerance_mm > 0.0 {
        feature.min(2.0 * tolerance_mm)
    } else {
        feature
    }
}

/// The largest factor k (at least 1) with `input_pixels × k²` within `limit`.
fn largest_within(input_pixels: u64, limit: u64) -> u32 {
    (1..=MAX_FACTOR)
        .rev()
        .find(|&k| input_pixels.saturating_mul(u64::from(k * k)) <= limit)
        .unwrap_or(1)
}

/// The automatic factor for a picture of `input_pixels` pixels of `mm_per_input_px` each: the
/// smallest K with `mm_per_input_px / K <= target_mm`, capped by [`MAX_FACTOR`], the memory budget
/// and `max_pixels` (never below 1). Returns the factor and how it was chosen.
pub(crate) fn auto(
    mm_per_input_px: f64,
    target_mm: f64,
    input_pixels: u64,
    max_pixels: u64,
) -> (u32, AutoScale) {
    // A hair of slack so that 0.1 mm at a target of 0.5 / 5 counts as fine enough.
    let ratio = mm_per_input_px / target_mm * (1.0 - 1e-9);
    let wanted = if ratio.is_finite() && ratio > 1.0 {
        ratio.ceil().min(f64::from(u32::MAX)) as u32
    } else {
        1
    };
    let caps = [
        (MAX_FACTOR, ScaleCap::MaxFactor),
        (
            largest_within(input_pixels, AUTO_MAX_WORKING_PIXELS),
            ScaleCap::Memory,
        ),
        (
            largest_within(input_pixels, max_pixels),
            ScaleCap::MaxPixels,
        ),
    ];
    let (limit, why) = caps
        .into_iter()
        .min_by_key(|&(k, _)| k)
        .expect("three caps");
    let factor = wanted.min(limit);
    (
        factor,
        AutoScale {
            target_mm_per_px: target_mm,
            wanted,
            capped_by: (factor < wanted).then_some(why),
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn target_is_the_stricter_of_feature_and_tolerance() {
        // Cardstock at the default tolerance: both give 0.1 mm.
        assert!((target_mm_per_px(0.5, 0.05) - 0.1).abs() < 1e-12);
        // Plywood (1.5 mm): the tolerance decides.
        assert!((target_mm_per_px(1.5, 0.05) - 0.1).abs() < 1e-12);
        // Brass etch (0.33 mm): the feature decides.
        assert!((target_mm_per_px(0.33, 0.05) - 0.066).abs() < 1e-12);
        // A looser tolerance leaves the feature; a tolerance of 0 does not count.
        assert!((target_mm_per_px(1.5, 0.2) - 0.3).abs() < 1e-12);
        assert!((target_mm_per_px(1.5, 0.0) - 0.3).abs() < 1e-12);
    }

    #[test]
    fn factor_is_the_smallest_that_is_fine_enough() {
        let big = u64::MAX;
        // The default size with cardstock: exactly fine enough, not supersampled.
        let t = target_mm_per_px(0.5, 0.05);
        assert_eq!(auto(0.1, t, 1_000_000, big).0, 1);
        // Finer than needed: never downsampled.
        assert_eq!(auto(0.02, t, 1_000_000, big).0, 1);
        // 320 px at 200 mm: 0.625 mm per pixel needs 7 (0.089 mm); 6 would give 0.104.
        let (k, a) = auto(200.0 / 320.0, t, 320 * 320, big);
        assert_eq!((k, a.wanted, a.capped_by), (7, 7, None));
        // Just over the target needs one step more.
        assert_eq!(auto(0.1001, t, 100, big).0, 2);
        // Brass etch at the default size: 0.1 / 0.066 -> 2.
        assert_eq!(auto(0.1, target_mm_per_px(0.33, 0.05), 100, big).0, 2);
    }

    #[test]
    fn caps_bind_and_say_which() {
        let t = 0.1;
        // 2.0 mm per pixel wants 20: the largest factor is 8.
        let (k, a) = auto(2.0, t, 100, u64::MAX);
        assert_eq!(
            (k, a.wanted, a.capped_by),
            (8, 20, Some(ScaleCap::MaxFactor))
        );
        // A 1000 × 1000 picture wanting 7 would be 49 MP: the 16 MP budget allows 4 (16 MP).
        let (k, a) = auto(0.7, t, 1_000_000, u64::MAX);
        assert_eq!((k, a.wanted, a.capped_by), (4, 7, Some(ScaleCap::Memory)));
        assert!(1_000_000 * u64::from(k * k) <= AUTO_MAX_WORKING_PIXELS);
        // --max-pixels lower than the budget: it binds instead (9 MP allows 3).
        let (k, a) = auto(0.7, t, 1_000_000, 9_000_000);
        assert_eq!((k, a.capped_by), (3, Some(ScaleCap::MaxPixels)));
        // A picture already over the budget stays at 1, never below.
        let (k, a) = auto(0.7, t, 20_000_000, u64::MAX);
        assert_eq!((k, a.wanted, a.capped_by), (1, 7, Some(ScaleCap::Memory)));
        // A cap that does not bind is not reported.
        let (k, a) = auto(0.3, t, 1_000_000, u64::MAX);
        assert_eq!((k, a.capped_by), (3, None));
    }
}
