//! The threshold (the paper's Stage 1: a pixel above the level is material): the level, fixed or
//! Otsu's, and the two tones of a gray at it.

use std::sync::Arc;

use crate::raster::{BitGrid, Gray, TwoTone};

/// How grayscale becomes two tones.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Threshold {
    /// A fixed level, 0..255 on the 8-bit scale: a pixel at or above it is light.
    Level(u8),
    /// Otsu's method: the level that best separates the histogram into two classes.
    Otsu,
    /// The level whose cleaned-up two-tone looks most like the picture (see `likeness()`): every
    /// level is tried through the clean-up the material needs and the likeliest kept. For a
    /// rendered mesh, which has no gray picture to resemble, the same as `Otsu`.
    Auto,
    /// The command line's default, decided once the picture is read ([`by_picture`]): two-tone
    /// art (a scan of a drawing, a logo) keeps its own tones, any other picture is cut at the
    /// level `Auto` chooses; a rendered mesh, or a picture under a local threshold, at 128.
    ByPicture,
}

impl Default for Threshold {
    fn default() -> Self {
        Threshold::Level(128)
    }
}

/// What [`Threshold::ByPicture`] means for this picture: `Level` for two-tone art, else `Auto`.
///
/// Two-tone art has at most 5 % of its pixels in the middle half between the means of its two
/// Otsu classes, which stand at least a quarter of full scale apart (anti-aliased edges are a
/// thin share; a photo's middle tones are not). Its level is 128 where that lies in the middle
/// half (black-and-white art is cut as it always was), else halfway between the two means
/// (a dark red drawing on black).
///
/// ```
/// use stencil_core::{raster::Gray, tone::{by_picture, Threshold}};
/// let mut art = Gray::new(100, 1, 0.02);
/// (40..100).for_each(|x| art.set(x, 0, 0.97));
/// art.set(39, 0, 0.5); // an anti-aliased edge
/// assert_eq!(by_picture(&art), Threshold::Level(128));
/// let mut ramp = Gray::new(100, 1, 0.0);
/// (0..100).for_each(|x| ramp.set(x, 0, x as f32 / 99.0));
/// assert_eq!(by_picture(&ramp), Threshold::Auto);
/// ```
pub fn by_picture(gray: &Gray) -> Threshold {
    let hist = histogram(gray);
    let t = usize::from(otsu_level(gray));
    let class = |r: std::ops::Range<usize>| {
        let n: u64 = hist[r.clone()].iter().sum();
        let sum: f64 = r.map(|i| i as f64 * hist[i] as f64).sum();
        (n, sum / n.max(1) as f64)
    };
    let ((n0, m0), (n1, m1)) = (class(0..t), class(t..256));
    let d = m1 - m0;
    if n0 == 0 || n1 == 0 || d < 64.0 {
        return Threshold::Auto;
    }
    let (lo, hi) = (m0 + d / 4.0, m1 - d / 4.0);
    let middle: u64 = (0..256)
        .filter(|&i| (i as f64) > lo && (i as f64) < hi)
        .map(|i| hist[i])
        .sum();
    if middle as f64 > 0.05 * (n0 + n1) as f64 {
        return Threshold::Auto;
    }
    Threshold::Level(if lo < 128.0 && 128.0 < hi {
        128
    } else {
        ((m0 + m1) / 2.0).round() as u8
    })
}

/// The paper's darkest and lightest across `gray` when it looks like a page in uneven light: in
/// each cell of an 8 × 8 grid the 90th percentile is the paper's light there and the 10th the
/// ink's; a page has paper in every cell (never under 0.25), lit unevenly (ranging over 0.3),
/// with ink on it in three cells of four. A photo fails the first (its dark places have no
/// paper), art and evenly lit pages the second.
pub fn uneven_page(gray: &Gray) -> Option<[f32; 2]> {
    const N: u32 = 8;
    let (w, h) = (gray.width, gray.height);
    if w < N || h < N {
        return None;
    }
    let (mut lo, mut hi, mut inked) = (f32::MAX, f32::MIN, 0);
    let mut cell = Vec::new();
    for i in 0..N {
        for j in 0..N {
            cell.clear();
            for y in i * h / N..(i + 1) * h / N {
                let row = &gray.data[(y * w) as usize..((y + 1) * w) as usize];
                cell.extend_from_slice(&row[(j * w / N) as usize..((j + 1) * w / N) as usize]);
            }
            cell.sort_by(f32::total_cmp);
            let at = |q: usize| cell[(cell.len() - 1) * q / 100];
            let (ink, paper) = (at(10), at(90));
            lo = lo.min(paper);
            hi = hi.max(paper);
            inked += usize::from(paper - ink >= 0.15);
        }
    }
    (lo >= 0.25 && hi - lo > 0.3 && inked * 4 >= (N * N) as usize * 3).then_some([lo, hi])
}

/// How many pixels of `gray` round to each 8-bit level.
fn histogram(gray: &Gray) -> [u64; 256] {
    let mut hist = [0u64; 256];
    for &v in &gray.data {
        hist[(v.clamp(0.0, 1.0) * 255.0).round() as usize] += 1;
    }
    hist
}

/// Otsu's threshold on a gray in 0..1, as an 8-bit level: the level maximising between-class variance.
///
/// ```
/// let mut gray = stencil_core::raster::Gray::new(10, 1, 0.2);
/// (5..10).for_each(|x| gray.set(x, 0, 0.8));
/// assert!((51..204).contains(&stencil_core::tone::otsu_level(&gray)));
/// ```
pub fn otsu_level(gray: &Gray) -> u8 {
    let hist = histogram(gray);
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

/// Whether a gray value (0 = black .. 1 = white) is light at the 8-bit `level`, as an image editor
/// means `--threshold 128`: `round(v·255) >= level` without the rounding (exact in f32 from
/// `level - 0.5` up); level 0 makes every value light, even a negative or NaN one.
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
        // Decided before the stages (`resolve::stage_params`); 128 where it was not.
        Threshold::ByPicture => 128,
    };
    let bits = bits_at(&gray, level, invert);
    (TwoTone { bits, gray }, level)
}

/// The two tones of `gray` at `level`: light (at or above it) is material unless `invert`.
pub(crate) fn bits_at(gray: &Gray, level: u8, invert: bool) -> BitGrid {
    let data = gray.data.iter().map(|&v| is_light(v, level) != invert);
    BitGrid::from_data(gray.width, gray.height, data.collect())
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
