//! The cost `C = w0·ΣI + w1·L^α + w2·κ + w3·σ²` of a bridge placed at a candidate: one function per
//! term, named after it (ΣI, [`super::strips::intensity`], is measured on each strip as it is
//! made), and [`score_with`], which evaluates them over the leftward, centred and rightward
//! windows along the border and keeps the cheapest.
//!
//! Normalisation (so that a weight of 1 means "as much as a typical strip"): let `L̃` be the median
//! strip length (pixels) over the image.
//! - ΣI is divided by `L̃`: 1 = a typical-length strip over pure black, 0 = over pure white.
//! - L^α is divided by `L̃^α`: 1 = a typical strip.
//! - κ = √(λmin/λmax) of the candidates' coordinate covariance, already in 0 (straight) .. 1 (round).
//! - σ² is the variance of the strips' cost (normalised ΣI + L^α, unweighted, so the four weights
//!   stay independent) divided by the squared mean: 0 = all neighbours alike, about 1 when one
//!   neighbour in a window of three costs several times the others. A neighbour with no strip to
//!   the same node counts as a strip of the maximum length over black: it cannot be part of a
//!   bridge there, which is exactly what σ² is meant to warn about.
//!
//! The intensity and length terms of a window are the means over its strips that reach the same
//! node as the candidate's strip.

use super::candidates::Candidates;
use super::config::{BridgeConfig, CostTerms};
use super::strips::Strip;
use crate::raster::Gray;

/// Smallest window for the curvature term, in candidates. A digital straight edge at an odd angle
/// is a staircase whose pixels stray ±½ px from the line; over n candidates that alone gives
/// κ ≈ 0.8/n, so with fewer than ~15 a staircase looks as curved as a 20 px radius bend. κ
/// therefore uses `max(width, 15)` candidates (same alignment as the other terms' window).
pub(crate) const KAPPA_MIN_WINDOW: usize = 15;

/// L^α: small for short strips, growing faster than linearly for long ones (1 < α < 2).
pub(crate) fn length(len_px: f64, alpha: f64) -> f64 {
    len_px.powf(alpha)
}

/// κ: curvature of the border through `points` from the eigenvalues of their 2×2 coordinate
/// covariance: √(λmin/λmax), 0 on a straight edge (all spread along one axis) rising to 1 where the
/// points spread equally both ways (a tight curve). For points on an arc of small angle θ it grows
/// in proportion to θ, i.e. to curvature × window length. Fewer than 3 points: 0. (The stage
/// keeps running moments and calls [`curvature_from_moments`]; this form is for the tests.)
#[cfg(test)]
pub(crate) fn curvature(points: &[(f64, f64)]) -> f64 {
    let mut m = [0.0; 6];
    for &(x, y) in points {
        for (s, v) in m.iter_mut().zip([1.0, x, y, x * x, y * y, x * y]) {
            *s += v;
        }
    }
    curvature_from_moments(m)
}

/// [`curvature`] from the sums (n, Σx, Σy, Σx², Σy², Σxy) of the points.
pub(crate) fn curvature_from_moments([n, sx, sy, sxx, syy, sxy]: [f64; 6]) -> f64 {
    if n < 3.0 {
        return 0.0;
    }
    let (mx, my) = (sx / n, sy / n);
    // The covariance.
    let sxx = (sxx / n - mx * mx).max(0.0);
    let syy = (syy / n - my * my).max(0.0);
    let sxy = sxy / n - mx * my;
    let half_tr = (sxx + syy) / 2.0;
    let root = (((sxx - syy) / 2.0).powi(2) + sxy * sxy).sqrt();
    let (big, small) = (half_tr + root, (half_tr - root).max(0.0));
    if big <= 1e-12 {
        return 0.0;
    }
    (small / big).sqrt()
}

/// σ²: variance of strip costs relative to their squared mean (scale free). 0 for fewer than two.
pub(crate) fn variance(costs: &[f64]) -> f64 {
    if costs.len() < 2 {
        return 0.0;
    }
    let n = costs.len() as f64;
    let mean = costs.iter().sum::<f64>() / n;
    if mean <= 1e-12 {
        return 0.0;
    }
    let var = costs.iter().map(|c| (c - mean).powi(2)).sum::<f64>() / n;
    var / (mean * mean)
}

/// Normalised intensity and length of one strip.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct StripCost {
    pub(crate) intensity: f64,
    pub(crate) length: f64,
}

impl StripCost {
    /// The unweighted strip cost whose spread σ² measures.
    pub(crate) fn base(&self) -> f64 {
        self.intensity + self.length
    }

    /// The weighted strip cost: which neighbour is cheaper when a bridge grows.
    pub(crate) fn weighted(&self, cfg: &BridgeConfig) -> f64 {
        cfg.w_intensity * self.intensity + cfg.w_length * self.length
    }
}

/// The image's scale for the terms (see the module doc).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Norm {
    /// Median strip length L̃, at least 1.
    pub(crate) typical_len: f64,
    pub(crate) alpha: f64,
    /// What a missing neighbour counts as in σ².
    pub(crate) missing: StripCost,
    /// `L̃^α`, the divisor of every strip's length term, computed once (`powf` per strip was a
    /// visible share of the scoring phase).
    typical_pow: f64,
}

impl Norm {
    /// From all strip lengths of the image (any order; may be empty).
    pub(crate) fn new(mut lengths: Vec<usize>, cfg: &BridgeConfig) -> Self {
        let typical = if lengths.is_empty() {
            1.0
        } else {
            let mid = lengths.len() / 2;
            *lengths.select_nth_unstable(mid).1 as f64
        }
        .max(1.0);
        let typical_pow = length(typical, cfg.alpha);
        let m = cfg.max_length_px.max(1) as f64;
        Norm {
            typical_len: typical,
            alpha: cfg.alpha,
            missing: StripCost {
                intensity: m / typical,
                length: length(m, cfg.alpha) / typical_pow,
            },
            typical_pow,
        }
    }

    /// Per-pixel prices of the fallback search's paths (see [`StepCost`]).
    pub(crate) fn step_cost(&self, cfg: &BridgeConfig) -> StepCost {
        let limit = cfg.max_length_px.max(1) as f64;
        StepCost {
            intensity: cfg.w_intensity as f32,
            length: (cfg.w_length * self.alpha * (limit / self.typical_len).powf(self.alpha - 1.0))
                as f32
                + STEP_FLOOR,
        }
    }

    fn length_of(&self, len: f64) -> f64 {
        length(len, self.alpha) / self.typical_pow
    }

    pub(crate) fn strip(&self, s: &Strip) -> StripCost {
        StripCost {
            intensity: s.intensity / self.typical_len,
            length: self.length_of(s.len() as f64),
        }
    }
}

/// What every pixel of a searched path costs at least, in the units of [`StepCost`], so that with
/// both weights 0 the search still finds a shortest path (and never a zero-cost detour).
const STEP_FLOOR: f32 = 1e-3;

/// The cost of one pixel of a path found by the fallback search ([`super::search::search`]),
/// which needs a cost that adds up: the strip cost's intensity and length terms per pixel, in
/// units of ΣI, `w0·(1 − gray)² + w1·α·(L_max / L̃)^(α−1)` (the slope of L^α at the length limit).
/// With the default weights and L̃ ≈ 10 px a pixel of length costs about 0.67 pixels of black.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct StepCost {
    /// w0: the price of a pixel of pure black.
    pub(crate) intensity: f32,
    /// What each pixel costs for its length (never 0).
    pub(crate) length: f32,
}

impl StepCost {
    /// The cost of cut pixel `p` (linear index) as part of a path.
    #[inline]
    pub(crate) fn at(&self, gray: &Gray, p: u32) -> f32 {
        let d = 1.0 - gray.data[p as usize];
        self.intensity * d * d + self.length
    }
}

/// Where a window lies relative to its candidate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Align {
    /// The candidate is the window's last strip (the bridge extends backwards along the border).
    Left,
    Centre,
    /// The candidate is the window's first strip.
    Right,
}

/// Offsets (inclusive) along the chain of a window of `size` candidates around `id`. Clamped to
/// the chain: a closed chain shorter than `size` is taken whole; on an open chain the window is
/// shifted to lie inside it (near an end, the three alignments may coincide).
pub(crate) fn window(c: &Candidates, id: usize, size: usize, align: Align) -> (isize, isize) {
    let chain = &c.chains[c.chain_of[id] as usize];
    let size = size.clamp(1, chain.len) as isize;
    let mut lo = match align {
        Align::Left => -(size - 1),
        Align::Centre => -((size - 1) / 2),
        Align::Right => 0,
    };
    if !chain.closed {
        let pos = c.pos(id) as isize;
        let n = chain.len as isize;
        lo = lo.clamp(-pos, n - pos - size);
    }
    (lo, lo + size - 1)
}

/// The cheapest window of a candidate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Scored {
    /// Weighted terms and total.
    pub(crate) terms: CostTerms,
    /// The window's offsets along the chain.
    pub(crate) window: (isize, isize),
    pub(crate) align: Align,
    /// Bridge width needed there, px.
    pub(crate) width: u32,
    /// Intensity error the bridge is expected to add: mean ΣI of the window's strips × width.
    pub(crate) estimate: f64,
}

/// Score candidate `id` (which must have a strip): each term over the leftward, centred and
/// rightward windows of `width` candidates; the cheapest total is kept. `base` is a reusable
/// buffer for the window's strip costs: scoring runs once per candidate (tens of thousands), and a
/// fresh allocation each time showed up in profiles.
#[allow(clippy::too_many_arguments)]
pub(crate) fn score_with(
    c: &Candidates,
    strips: &[Option<Strip>],
    costs: &[Option<StripCost>],
    id: usize,
    width: u32,
    cfg: &BridgeConfig,
    norm: &Norm,
    base: &mut Vec<f64>,
) -> Option<Scored> {
    let to = strips[id].as_ref()?.to;
    let mut best: Option<Scored> = None;
    // Chain arithmetic once: `window` keeps offsets inside an open chain.
    let chain = &c.chains[c.chain_of[id] as usize];
    let (start, n, pos) = (chain.start, chain.len as isize, c.pos(id) as isize);
    // A window is never longer than its chain, so `pos + k` lies in -n..2n: one wrap at most,
    // without the division `rem_euclid` costs (three windows per candidate).
    let at = |k: isize| {
        let p = pos + k;
        start
            + if p < 0 {
                p + n
            } else if p >= n {
                p - n
            } else {
                p
            } as usize
    };
    for align in [Align::Left, Align::Centre, Align::Right] {
        let (lo, hi) = window(c, id, width as usize, align);
        base.clear();
        let (mut i_sum, mut l_sum, mut raw_i, mut valid) = (0.0, 0.0, 0.0, 0usize);
        for k in lo..=hi {
            let j = at(k);
            match (&strips[j], &costs[j]) {
                (Some(s), Some(sc)) if s.to == to => {
                    i_sum += sc.intensity;
                    l_sum += sc.length;
                    raw_i += s.intensity;
                    valid += 1;
                    base.push(sc.base());
                }
                _ => base.push(norm.missing.base()),
            }
        }
        let valid_f = valid.max(1) as f64;
        // With no weight on it (the default) the curvature is not measured at all.
        let curvature = if cfg.w_curvature == 0.0 {
            0.0
        } else {
            let (klo, khi) = window(c, id, KAPPA_MIN_WINDOW.max(width as usize), align);
            cfg.w_curvature * curvature_from_moments(c.moments(id, klo, khi))
        };
        let mut terms = CostTerms {
            intensity: cfg.w_intensity * i_sum / valid_f,
            length: cfg.w_length * l_sum / valid_f,
            curvature,
            variance: cfg.w_variance * variance(base),
            total: 0.0,
        };
        terms.total = terms.intensity + terms.length + terms.curvature + terms.variance;
        if best.is_none_or(|b| terms.total < b.terms.total) {
            best = Some(Scored {
                terms,
                window: (lo, hi),
                align,
                width,
                estimate: raw_i / valid_f * width as f64,
            });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn length_penalty_grows_faster_than_linear() {
        assert!((length(4.0, 1.5) - 8.0).abs() < 1e-9);
        assert!(length(20.0, 1.5) / length(10.0, 1.5) > 2.0);
    }

    #[test]
    fn curvature_is_zero_on_a_line_and_one_on_a_full_circle() {
        let line: Vec<_> = (0..9).map(|i| (i as f64, 3.0)).collect();
        assert!(curvature(&line) < 1e-9);
        let diagonal: Vec<_> = (0..9).map(|i| (i as f64, i as f64)).collect();
        assert!(curvature(&diagonal) < 1e-6);
        let circle: Vec<_> = (0..36)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 36.0;
                (5.0 * a.cos(), 5.0 * a.sin())
            })
            .collect();
        assert!((curvature(&circle) - 1.0).abs() < 1e-6);
        // A tighter arc of the same length is curvier.
        let arc = |r: f64| -> Vec<(f64, f64)> {
            (0..9)
                .map(|i| {
                    let a = (i as f64 - 4.0) / r;
                    (r * a.sin(), r * (1.0 - a.cos()))
                })
                .collect()
        };
        let (gentle, tight) = (curvature(&arc(40.0)), curvature(&arc(6.0)));
        assert!(gentle < tight, "{gentle} vs {tight}");
        assert!(gentle < 0.05 && tight > 0.15, "{gentle} {tight}");
    }

    #[test]
    fn variance_is_relative_to_the_mean() {
        assert_eq!(variance(&[2.0, 2.0, 2.0]), 0.0);
        // [1, 3]: mean 2, variance 1 → 1/4.
        assert!((variance(&[1.0, 3.0]) - 0.25).abs() < 1e-12);
        // Scale free.
        assert!((variance(&[10.0, 30.0]) - 0.25).abs() < 1e-12);
        assert_eq!(variance(&[5.0]), 0.0);
    }

    #[test]
    fn norm_uses_the_median_length() {
        let cfg = BridgeConfig::default();
        let n = Norm::new(vec![4, 10, 100], &cfg);
        assert_eq!(n.typical_len, 10.0);
        let s = Strip {
            from: 1,
            to: 0,
            pixels: (0..10).collect(),
            end: (0, 0),
            intensity: 5.0,
        };
        let sc = n.strip(&s);
        assert!((sc.intensity - 0.5).abs() < 1e-12);
        assert!((sc.length - 1.0).abs() < 1e-12);
        assert!(n.missing.length > 1.0);
    }

    #[test]
    fn a_search_step_prices_darkness_and_length() {
        let cfg = BridgeConfig {
            w_length: 1.0,
            ..BridgeConfig::default()
        };
        let n = Norm::new(vec![10; 5], &cfg);
        let step = n.step_cost(&cfg);
        // Length (w1 = 1): the slope of (L/10)^1.5 at L = 200, times 10: 1.5 × √20.
        assert!((step.length - (1.5 * 20f32.sqrt() + STEP_FLOOR)).abs() < 1e-4);
        let gray = Gray::from_data(3, 1, vec![0.0, 0.5, 1.0]);
        // Darkness: w0 (2 by default) × (1 − gray)².
        let w0 = cfg.w_intensity as f32;
        assert!((step.at(&gray, 0) - step.length - w0).abs() < 1e-6);
        assert!((step.at(&gray, 1) - step.length - 0.25 * w0).abs() < 1e-6);
        assert_eq!(step.at(&gray, 2), step.length);
        // No weights: still a positive price per pixel.
        let zero = BridgeConfig {
            w_intensity: 0.0,
            w_length: 0.0,
            ..cfg
        };
        assert!(n.step_cost(&zero).at(&gray, 0) > 0.0);
    }
}
