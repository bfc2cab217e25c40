//! How much a two-tone looks like the picture it came from, seen from where a person stands.
//! [`Likeness`] chooses `--threshold auto`'s level; `ssim`, plain SSIM on the same box average and
//! blur, gives a layered set's `composite.likeness`.
//!
//! ## The measure
//! Both the two-tone (material light, cut dark) and the gray are box-averaged to at most
//! `EVAL_LONG_SIDE` pixels and blurred by σ = diagonal / `VIEW_BLUR_DIAGONALS` (a 200 × 150 mm
//! stencil seen from about 1 m). Their structural similarity (after SSIM, Wang, Bovik, Sheikh and
//! Simoncelli 2004, Gaussian window of σ = 2 × the blur) is averaged over the picture: 1 = the same.
//! The tone term is `1 − |μx − μy|` instead of SSIM's ratio, which is 0 wherever one side is black
//! and chose level 34 on the flower photo against a person's 112; the difference treats black and
//! white alike, as `--invert` needs. Two changes make it agree with a person's pick (six photos:
//! `docs/measurements.md`, "Auto against a person"):
//! - **The picture's own black and white**: the gray is stretched so its `STRETCH_PERCENTILE` and
//!   `1 − STRETCH_PERCENTILE` quantiles become 0 and 1 (else a dim photo is most "like" all black).
//! - **Flat areas count less**: each place is weighted by its local contrast plus `FLAT_WEIGHT`
//!   times the mean contrast, so a flat sky does not outvote a face.
//!
//! It is measured after the clean-up the material needs, so what the clean-up had to change counts
//! against the level that needed it.

use serde::{Deserialize, Serialize};

use crate::raster::{
    blur, blur_of, blur_of_into, box_average, box_average_bits_into, convolve, BitGrid, Gray,
};

/// The long side of the grid the measure is taken on, pixels.
pub(crate) const EVAL_LONG_SIDE: u32 = 512;

/// The viewing blur's σ is the picture's diagonal divided by this.
pub(crate) const VIEW_BLUR_DIAGONALS: f32 = 250.0;

/// The share of the picture's pixels taken as its black (and, from the top, its white) when its
/// gray is stretched to the full range.
pub(crate) const STRETCH_PERCENTILE: f32 = 0.01;

/// How much a flat place weighs, as a share of the picture's mean local contrast (a place of
/// mean contrast weighs 1 + this, a flat one this).
pub(crate) const FLAT_WEIGHT: f32 = 0.25;

/// The likeness (SSIM at viewing distance, see the module) of a two-tone to its gray picture.
/// Measuring several two-tones of one gray: make its [`Likeness`] once.
pub fn likeness(bits: &BitGrid, gray: &Gray, invert: bool) -> f64 {
    Likeness::of(gray).of_bits(bits, invert)
}

/// The picture's side of the [`likeness`] measure, which depends only on the gray: the gray
/// box-averaged, stretched and seen from afar, its local means and contrast in the SSIM window
/// and each place's weight. The two-tones of one gray (a threshold change in the studio, the
/// levels `--threshold auto` tries) are each measured against it, so it is made once per gray.
#[derive(Clone, Debug)]
pub struct Likeness {
    /// The size of the gray it was made of, and the box size it was averaged by.
    width: u32,
    height: u32,
    d: u32,
    /// The viewing blur's σ on the reduced grid (the SSIM window is twice it).
    sigma: f32,
    /// The gray seen from afar, its local mean and variance in the window.
    y: Vec<f32>,
    my: Vec<f32>,
    vy: Vec<f32>,
    /// The mean local contrast, which with each place's own gives its weight (`weight`, worked
    /// out where used: kept, they were the largest buffer here), and the weights' sum.
    mean_contrast: f64,
    weights: f64,
}

impl Likeness {
    /// The picture's side of the measure for `gray`.
    pub(crate) fn of(gray: &Gray) -> Likeness {
        let d = gray.width.max(gray.height).div_ceil(EVAL_LONG_SIDE).max(1);
        let g = stretch(box_average(gray.width, gray.height, d, |i| {
            gray.data[i].clamp(0.0, 1.0)
        }));
        let sigma = ((g.width as f32).hypot(g.height as f32) / VIEW_BLUR_DIAGONALS).max(0.5);
        let window = 2.0 * sigma;
        let y = blur(&g, sigma);
        drop(g);
        let my = blur(&y, window);
        let yy = blur_of(y.width, y.height, window, |i| y.data[i] * y.data[i]);
        let n = y.data.len();
        let vy: Vec<f32> = (0..n)
            .map(|i| (yy.data[i] - my.data[i] * my.data[i]).max(0.0))
            .collect();
        let mean_contrast = vy.iter().map(|&v| v.sqrt() as f64).sum::<f64>() / n.max(1) as f64;
        let mut weights = 0.0;
        for &v in &vy {
            weights += weight(v, mean_contrast);
        }
        Likeness {
            width: gray.width,
            height: gray.height,
            d,
            sigma,
            y: y.data,
            my: my.data,
            vy,
            mean_contrast,
            weights,
        }
    }

    /// The likeness of `bits`, a two-tone of the gray this was made of (the same size), to it.
    pub fn of_bits(&self, bits: &BitGrid, invert: bool) -> f64 {
        assert_eq!(
            (bits.width, bits.height),
            (self.width, self.height),
            "a two-tone is measured against its own gray"
        );
        if bits.data.is_empty() {
            return 0.0;
        }
        let window = 2.0 * self.sigma;
        // Each blur's buffer between its passes serves the next (made once, not four times).
        let mut across = Vec::new();
        let (mut x, mut mx, mut xx, mut xy) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (w, h) = if self.d == 1 {
            // Boxes of one pixel average to its tone, 0 or 1: no box average to make.
            let tone = |i: usize| (bits.data[i] != invert) as u32 as f32;
            blur_of_into(
                bits.width,
                bits.height,
                self.sigma,
                tone,
                &mut across,
                &mut x,
            );
            (bits.width, bits.height)
        } else {
            let mut boxed = Vec::new();
            let (w, h) = box_average_bits_into(bits, self.d, invert, &mut boxed);
            blur_of_into(w, h, self.sigma, |i| boxed[i], &mut across, &mut x);
            (w, h)
        };
        // One blur after another (each parallel inside).
        let x = &x[..];
        blur_of_into(w, h, window, |i| x[i], &mut across, &mut mx);
        blur_of_into(w, h, window, |i| x[i] * x[i], &mut across, &mut xx);
        blur_of_into(w, h, window, |i| x[i] * self.y[i], &mut across, &mut xy);
        drop(across);
        score(self, &mx, &xx, &xy)
    }
}

/// The weight of a place whose variance in the window is `v`, in a picture whose mean local
/// contrast (standard deviation) is `mean_contrast`: its contrast plus [`FLAT_WEIGHT`] times the
/// mean (a flat picture weighs every place alike).
fn weight(v: f32, mean_contrast: f64) -> f64 {
    if mean_contrast > 0.0 {
        v.sqrt() as f64 + FLAT_WEIGHT as f64 * mean_contrast
    } else {
        1.0
    }
}

/// `g` with its [`STRETCH_PERCENTILE`] quantiles made 0 and 1 (a flat picture is left alone).
fn stretch(mut g: Gray) -> Gray {
    const BINS: usize = 1024;
    let mut hist = [0u32; BINS];
    for &v in &g.data {
        hist[((v * (BINS - 1) as f32).round() as usize).min(BINS - 1)] += 1;
    }
    let n = g.data.len() as f32;
    let quantile = |q: f32| {
        let want = (q * n).max(1.0);
        let mut seen = 0.0;
        for (i, &c) in hist.iter().enumerate() {
            seen += c as f32;
            if seen >= want {
                return i as f32 / (BINS - 1) as f32;
            }
        }
        1.0
    };
    let (lo, hi) = (
        quantile(STRETCH_PERCENTILE),
        quantile(1.0 - STRETCH_PERCENTILE),
    );
    if hi - lo < 1.0 / 255.0 {
        return g;
    }
    for v in &mut g.data {
        *v = ((*v - lo) / (hi - lo)).clamp(0.0, 1.0);
    }
    g
}

/// SSIM-like score of a two-tone seen from afar against the picture (`look`), from the two-tone's
/// local mean `mx`, mean square `xx` and mean product with the picture `xy` in the window,
/// averaged with weights that follow the picture's local contrast (see the module notes).
fn score(look: &Likeness, mx: &[f32], xx: &[f32], xy: &[f32]) -> f64 {
    let c2 = 9e-4f32;
    let mut total = 0.0;
    for i in 0..mx.len() {
        let (ux, uy) = (mx[i], look.my[i]);
        let vx = (xx[i] - ux * ux).max(0.0);
        let vy = look.vy[i];
        let cxy = xy[i] - ux * uy;
        let score = ((1.0 - (ux - uy).abs()) * (2.0 * cxy + c2) / (vx + vy + c2)) as f64;
        total += weight(vy, look.mean_contrast) * score;
    }
    total / look.weights.max(f64::MIN_POSITIVE)
}

/// The long side, in pixels, that [`ssim`] looks at: about what a person sees of a picture at a
/// few times its width away.
pub(crate) const VIEWING_PX: u32 = 200;

/// Likeness of two lightness images (0..1, `w` × `h` each): plain mean SSIM (Wang et al. 2004:
/// Gaussian window σ = 1.5 px of 11 taps, C1 = 0.01², C2 = 0.03²) after both are box-averaged to
/// [`VIEWING_PX`] on their long side (what is left at viewing distance). 1 = the same. A layered
/// set's composite is measured with it against its picture; it shares [`likeness`]'s box average
/// and blur, not its tuned formula.
pub(crate) fn ssim(a: &[f32], b: &[f32], w: u32, h: u32) -> f64 {
    let k = w.max(h).div_ceil(VIEWING_PX).max(1);
    let a = box_average(w, h, k, |i| a[i]);
    let b = box_average(w, h, k, |i| b[i]);
    // The window: 5 taps each side of exp(−d² / 2σ²), each pass's sums divided by the taps' sum.
    let taps: Vec<f32> = (-5i32..=5)
        .map(|d| (-(d * d) as f32 / (2.0 * 1.5 * 1.5)).exp())
        .collect();
    let sum: f32 = taps.iter().sum();
    // The window over the products of `x` and `y` (over `x` alone when `y` is None).
    let window = |x: &Gray, y: Option<&Gray>| {
        let value = |i: usize| y.map_or(x.data[i], |y| x.data[i] * y.data[i]);
        convolve(x.width, x.height, &taps, sum, value).data
    };
    let (mu_a, mu_b) = (window(&a, None), window(&b, None));
    let saa = window(&a, Some(&a));
    let sbb = window(&b, Some(&b));
    let sab = window(&a, Some(&b));
    let (c1, c2) = (0.01f64 * 0.01, 0.03f64 * 0.03);
    let mut total = 0.0;
    for i in 0..a.data.len() {
        let (ma, mb) = (mu_a[i] as f64, mu_b[i] as f64);
        let va = (saa[i] as f64 - ma * ma).max(0.0);
        let vb = (sbb[i] as f64 - mb * mb).max(0.0);
        let cov = sab[i] as f64 - ma * mb;
        total +=
            ((2.0 * ma * mb + c1) * (2.0 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
    }
    total / a.data.len().max(1) as f64
}

/// How `--threshold auto` chose its level, for the report and the console.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct LevelChoice {
    /// The level chosen and its likeness (see [`likeness`]).
    pub(crate) level: u8,
    /// Its likeness.
    pub likeness: f64,
    /// The likeness at the default level 128, measured the same way (the chosen level is never
    /// worse than it or Otsu's: both are among the candidates).
    pub likeness_128: f64,
    /// Otsu's level.
    pub otsu_level: u8,
    /// The likeness at Otsu's level.
    pub likeness_otsu: f64,
    /// Every level tried and its likeness, in the order tried (on the reduced grid for a large
    /// picture; the finalists again at full size).
    pub(crate) tried: Vec<(u8, f64)>,
    /// The paper's lightest and darkest across the picture when it looks like a page in uneven
    /// light, where no single level shows it all (see `uneven_page`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uneven_paper: Option<[f32; 2]>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::box_average_bits;

    /// The measure as it was first written, every intermediate picture made and each place's
    /// weight kept, to the bit: the same as the measure that makes none of them.
    fn likeness_as_written(bits: &BitGrid, gray: &Gray, invert: bool) -> f64 {
        let map = |g: &Gray, f: &dyn Fn(f32) -> f32| Gray {
            data: g.data.iter().map(|&v| f(v)).collect(),
            ..g.clone()
        };
        // The gray seen from afar as the measure makes it (that part is unchanged).
        let look = Likeness::of(gray);
        let (d, sigma, window) = (look.d, look.sigma, 2.0 * look.sigma);
        let y = Gray {
            data: look.y.clone(),
            ..box_average(gray.width, gray.height, d, |_| 0.0)
        };
        let (my, yy) = (blur(&y, window), blur(&map(&y, &|v| v * v), window));
        let vy: Vec<f32> = (0..y.data.len())
            .map(|i| (yy.data[i] - my.data[i] * my.data[i]).max(0.0))
            .collect();
        let contrast: Vec<f32> = vy.iter().map(|v| v.sqrt()).collect();
        let mean = contrast.iter().map(|&c| c as f64).sum::<f64>() / vy.len().max(1) as f64;
        let weight: Vec<f64> = contrast
            .iter()
            .map(|&c| {
                if mean > 0.0 {
                    c as f64 + FLAT_WEIGHT as f64 * mean
                } else {
                    1.0
                }
            })
            .collect();
        let weights: f64 = weight.iter().fold(0.0, |s, w| s + w);
        let x = blur(&box_average_bits(bits, d, invert), sigma);
        let xy = Gray {
            data: x.data.iter().zip(&y.data).map(|(&a, &b)| a * b).collect(),
            ..x.clone()
        };
        let (mx, xx, xy) = (
            blur(&x, window),
            blur(&map(&x, &|v| v * v), window),
            blur(&xy, window),
        );
        let mut total = 0.0;
        for i in 0..mx.data.len() {
            let (ux, uy) = (mx.data[i], my.data[i]);
            let vx = (xx.data[i] - ux * ux).max(0.0);
            let cxy = xy.data[i] - ux * uy;
            let s = ((1.0 - (ux - uy).abs()) * (2.0 * cxy + 9e-4) / (vx + vy[i] + 9e-4)) as f64;
            total += weight[i] * s;
        }
        total / weights.max(f64::MIN_POSITIVE)
    }

    #[test]
    fn the_measure_is_the_measure_as_written() {
        let mut rng = crate::test_rng::Lcg(41);
        for (w, h) in [(1, 1), (7, 3), (40, 33), (130, 90), (700, 20), (600, 530)] {
            let mut g = Gray::new(w, h, 0.0);
            for (i, v) in g.data.iter_mut().enumerate() {
                // Smooth shapes and noise, sometimes flat.
                let (x, y) = ((i as u32 % w) as f32, (i as u32 / w) as f32);
                *v = if w == 7 {
                    0.5
                } else {
                    (x / 9.0).sin() * (y / 13.0).cos() * 0.4 + 0.5
                } + rng.unit() as f32 * 0.2;
            }
            let bits = BitGrid::from_fn(w, h, |x, y| g.get(x, y) > 0.55 || rng.below(9) == 0);
            for invert in [false, true] {
                let want = likeness_as_written(&bits, &g, invert);
                let got = likeness(&bits, &g, invert);
                assert_eq!(
                    got.to_bits(),
                    want.to_bits(),
                    "{w}x{h} {invert}: {got} {want}"
                );
            }
        }
    }

    /// The plain SSIM of a set's composite: 1 for the same picture, low for its negative.
    #[test]
    fn ssim_is_one_for_the_same_and_lower_for_noise() {
        let a: Vec<f32> = (0..400).map(|i| ((i % 20) as f32) / 20.0).collect();
        assert!((ssim(&a, &a, 20, 20) - 1.0).abs() < 1e-9);
        let b: Vec<f32> = a.iter().map(|v| 1.0 - v).collect();
        assert!(ssim(&a, &b, 20, 20) < 0.5);
    }

    /// A dark photo (a board under dim light): parts at 0.4 on a 0.1 ground. A person sees the
    /// parts as its white; the stencil that shows them must beat the all-black one.
    #[test]
    fn a_dark_picture_is_judged_by_its_own_black_and_white() {
        let (w, h) = (120, 90);
        let mut g = Gray::new(w, h, 0.1);
        let mut b = BitGrid::new(w, h, false);
        for y in 0..h {
            for x in 0..w {
                if (x / 15 + y / 15) % 2 == 0 && (10..110).contains(&x) && (10..80).contains(&y) {
                    g.set(x, y, 0.4);
                    b.set(x, y, true);
                }
            }
        }
        let shown = likeness(&b, &g, false);
        let black = likeness(&BitGrid::new(w, h, false), &g, false);
        assert!(shown > black + 0.2, "{shown} {black}");
    }

    #[test]
    fn a_faithful_two_tone_is_more_like_the_picture_than_a_blank_one() {
        let mut g = Gray::new(80, 60, 0.9);
        let mut b = BitGrid::new(80, 60, true);
        for y in 20..40 {
            for x in 20..60 {
                g.set(x, y, 0.1);
                b.set(x, y, false);
            }
        }
        let good = likeness(&b, &g, false);
        let blank = likeness(&BitGrid::new(80, 60, true), &g, false);
        assert!(good > 0.8 && good > blank + 0.15, "{good} {blank}");
        // Inverted, the same bits are the negative.
        assert!(
            likeness(&b, &g, true) < good - 0.3,
            "{}",
            likeness(&b, &g, true)
        );
    }
}
