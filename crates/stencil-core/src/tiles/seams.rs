//! The seams: each the least-cost path through the whole picture's cleaned two-tone within a
//! band around its straight line, one step at most across per step along (so it is one
//! connected line), found by dynamic programming.
//!
//! ## The cost of a pixel the seam runs through
//! Where the seam runs, both tiles keep a strip of material past it (the overlap), so a seam
//! through the cut is a bridge across it; the costs are the bridges' own (see the bridge cost's
//! intensity term, `(1 − gray)²`: a light cut is cheaper to hide than a dark one) and their
//! detail term in pixels (near an edge, where a strip would eat into a shape or leave a sliver):
//! - material: 1, plus up to [`NEAR_EDGE`] within the overlap and the material's smallest
//!   feature of a cut (the strip would cover its edge);
//! - cut: 1 + [`CROSS_CUT`] · (¼ + (1 − gray)²), plus up to [`NEAR_EDGE`] within the smallest
//!   feature of its edge (crossing a shape at its rim leaves a sliver on one side).
//!
//! A step across costs [`DIAGONAL`] more, so of equal paths the straighter one wins.

use crate::raster::{squared_distance_to, BitGrid, Gray};

use super::layout::Side;

/// Extra cost of a pixel near an edge (at the edge; falling to 0 at the reach).
pub const NEAR_EDGE: f32 = 6.0;
/// Cost scale of crossing a cut pixel.
pub const CROSS_CUT: f32 = 20.0;
/// Extra cost of a step across.
pub const DIAGONAL: f32 = 0.4;

/// The seams of a grid, in working pixels of the whole picture: `xs[k][y]` is the first column
/// of tile column `k + 1` on row `y`; `ys[k][x]` the first row of tile row `k + 1` on column `x`.
#[derive(Clone, Debug, Default)]
pub struct Seams {
    /// Vertical seams, one column per row.
    pub xs: Vec<Vec<u32>>,
    /// Horizontal seams, one row per column.
    pub ys: Vec<Vec<u32>>,
}

impl Seams {
    /// The tile column of a working pixel (from 0).
    pub fn col(&self, x: u32, y: u32) -> usize {
        self.xs.iter().filter(|s| x >= s[y as usize]).count()
    }

    /// The tile row of a working pixel (from 0).
    pub fn row(&self, x: u32, y: u32) -> usize {
        self.ys.iter().filter(|s| y >= s[x as usize]).count()
    }
}

/// What a seam crossed: its length through the cut, and through cut narrower than the smallest
/// feature (none, after the clean-up; counted so the report can say so).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Crossing {
    /// Seam pixels in the cut.
    pub cut_px: usize,
    /// Seam pixels in a cut feature narrower than the material's smallest feature.
    pub thin_px: usize,
    /// Seam pixels in all.
    pub len_px: usize,
}

/// Pin places on a seam: up to two points on it, each where the whole stencil is material for
/// at least `clear_px` around (working px), near a third and two thirds of its length (or, when
/// neither is clear, the clearest place on it).
fn pins_on(path: &[u32], clear2: &dyn Fn(u32, u32) -> f32, clear_px: f64) -> Vec<(u32, u32)> {
    let n = path.len();
    let mut out = Vec::new();
    for frac in [1.0 / 3.0, 2.0 / 3.0] {
        let at = (n as f64 * frac) as usize;
        let reach = n / 6;
        let best = (at.saturating_sub(reach)..(at + reach).min(n))
            .map(|i| (i, clear2(i as u32, path[i])))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((i, d2)) = best {
            if (d2 as f64).sqrt() >= clear_px {
                out.push((i as u32, path[i]));
            }
        }
    }
    if out.is_empty() {
        // None near the thirds: the clearest place anywhere on the seam, if any is clear.
        let best = (0..n)
            .map(|i| (i, clear2(i as u32, path[i])))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((i, _)) = best.filter(|b| (b.1 as f64).sqrt() >= clear_px) {
            out.push((i as u32, path[i]));
        }
    }
    out
}

/// One seam through a band of the picture seen along its length: `len` steps along, `across`
/// positions across, the path that minimises the sum of `cost(along, across)` (positions given
/// from `lo`), each step moving at most one across.
fn path(len: u32, lo: u32, hi: u32, cost: impl Fn(u32, u32) -> f32) -> Vec<u32> {
    let n = (hi - lo + 1) as usize;
    let mut acc: Vec<f32> = (0..n).map(|a| cost(0, lo + a as u32)).collect();
    let mut back = vec![0u8; len as usize * n];
    let mut next = vec![0f32; n];
    for s in 1..len {
        for a in 0..n {
            let mut best = (acc[a], 1u8);
            if a > 0 && acc[a - 1] + DIAGONAL < best.0 {
                best = (acc[a - 1] + DIAGONAL, 0);
            }
            if a + 1 < n && acc[a + 1] + DIAGONAL < best.0 {
                best = (acc[a + 1] + DIAGONAL, 2);
            }
            next[a] = best.0 + cost(s, lo + a as u32);
            back[s as usize * n + a] = best.1;
        }
        std::mem::swap(&mut acc, &mut next);
    }
    let mut a = (0..n)
        .min_by(|&i, &j| acc[i].total_cmp(&acc[j]))
        .unwrap_or(0);
    let mut out = vec![0u32; len as usize];
    for s in (0..len).rev() {
        out[s as usize] = lo + a as u32;
        if s > 0 {
            a = a + back[s as usize * n + a] as usize - 1;
        }
    }
    out
}

/// What the seams are searched with, in working pixels.
pub(crate) struct SeamRequest<'a> {
    /// The whole picture's cleaned two-tone (material true).
    pub bits: &'a BitGrid,
    /// Its gray.
    pub gray: &'a Gray,
    /// Columns of tiles.
    pub cols: &'a Side,
    /// Rows of tiles.
    pub rows: &'a Side,
    /// The overlap past a seam, px.
    pub overlap_px: f64,
    /// The material's smallest feature, px.
    pub min_px: f64,
    /// A pin hole's radius plus the smallest feature around it, px (0: no pins).
    pub pin_clear_px: f64,
}

/// The seams found, what each crossed (vertical seams first), and the pins on them (x, y).
pub(crate) fn find(r: &SeamRequest) -> (Seams, Vec<Crossing>, Vec<(u32, u32)>) {
    let (w, h) = (r.bits.width, r.bits.height);
    let mut seams = Seams::default();
    let mut crossings = Vec::new();
    let mut pins = Vec::new();
    for (vertical, side) in [(true, r.cols), (false, r.rows)] {
        let (len, across_len) = if vertical { (h, w) } else { (w, h) };
        for &c in &side.centres_px {
            let lo = c.saturating_sub(side.band_px).max(1);
            let hi = (c + side.band_px).min(across_len - 1).max(lo);
            // The band's box, grown by the reach of the edge terms.
            let reach = (r.overlap_px + r.min_px).max(r.pin_clear_px).ceil() as u32 + 1;
            let (b0, b1) = (lo.saturating_sub(reach), (hi + reach).min(across_len - 1));
            let bw = b1 - b0 + 1;
            // The box in along/across order: `bw` across, `len` along, as a grid of `bw` columns.
            let at = |s: u32, a: u32| if vertical { (a, s) } else { (s, a) };
            let bits = BitGrid::from_fn(bw, len, |a, s| {
                let (x, y) = at(s, a + b0);
                r.bits.get(x, y)
            });
            let to_cut = squared_distance_to(&bits, false);
            let to_material = squared_distance_to(&bits, true);
            let idx = |s: u32, a: u32| (s * bw + (a - b0)) as usize;
            let near = r.overlap_px + r.min_px;
            let cost = |s: u32, a: u32| -> f32 {
                let i = idx(s, a);
                if bits.data[i] {
                    let d = to_cut[i].sqrt() as f64;
                    1.0 + NEAR_EDGE * (1.0 - d / near).max(0.0) as f32
                } else {
                    let (x, y) = at(s, a);
                    let g = r.gray.get(x, y).clamp(0.0, 1.0);
                    let d = to_material[i].sqrt() as f64;
                    1.0 + CROSS_CUT * (0.25 + (1.0 - g) * (1.0 - g))
                        + NEAR_EDGE * (1.0 - d / r.min_px.max(1.0)).max(0.0) as f32
                }
            };
            let p = path(len, lo, hi, cost);
            let mut cr = Crossing {
                len_px: p.len(),
                ..Crossing::default()
            };
            for (s, &a) in p.iter().enumerate() {
                let i = idx(s as u32, a);
                if !bits.data[i] {
                    cr.cut_px += 1;
                    // The cut's width here: twice the radius of the widest disc of cut that
                    // holds this pixel (a thin line crossed is narrower than the feature).
                    let k = (r.min_px / 2.0).ceil() as u32;
                    let mut widest = 0f32;
                    for ds in s.saturating_sub(k as usize)..(s + k as usize + 1).min(len as usize) {
                        for q in a.saturating_sub(k).max(b0)..=(a + k).min(b1) {
                            widest = widest.max(to_material[idx(ds as u32, q)]);
                        }
                    }
                    if 2.0 * (widest.sqrt() as f64) < r.min_px - 1.0 {
                        cr.thin_px += 1;
                    }
                }
            }
            if r.pin_clear_px > 0.0 {
                let clear2 = |s: u32, a: u32| to_cut[idx(s, a)];
                for (s, a) in pins_on(&p, &clear2, r.pin_clear_px) {
                    pins.push(if vertical { (a, s) } else { (s, a) });
                }
            }
            crossings.push(cr);
            if vertical {
                seams.xs.push(p);
            } else {
                seams.ys.push(p);
            }
        }
    }
    (seams, crossings, pins)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_seam_goes_round_the_dark() {
        // A dark bar across the middle with one light gap: the seam takes the gap.
        let (w, h) = (60u32, 40u32);
        let bits = BitGrid::from_fn(w, h, |x, y| !(18..22).contains(&y) || (40..46).contains(&x));
        let gray = Gray::from_data(
            w,
            h,
            bits.data
                .iter()
                .map(|&b| if b { 1.0 } else { 0.0 })
                .collect(),
        );
        let cols = Side {
            count: 2,
            centres_px: vec![30],
            band_px: 20,
        };
        let rows = Side {
            count: 1,
            centres_px: vec![],
            band_px: 0,
        };
        let (seams, crossings, _) = find(&SeamRequest {
            bits: &bits,
            gray: &gray,
            cols: &cols,
            rows: &rows,
            overlap_px: 1.0,
            min_px: 2.0,
            pin_clear_px: 0.0,
        });
        let s = &seams.xs[0];
        assert_eq!(s.len(), h as usize);
        assert!((41..46).contains(&s[20]), "{:?}", s);
        assert_eq!(crossings[0].cut_px, 0);
        // One step across at most per row.
        assert!(s.windows(2).all(|p| p[0].abs_diff(p[1]) <= 1));
        assert_eq!(seams.col(0, 20), 0);
        assert_eq!(seams.col(59, 20), 1);
        // Where it must cross, it crosses once, straight.
        let bar = BitGrid::from_fn(w, h, |_, y| !(18..22).contains(&y));
        let (seams, crossings, _) = find(&SeamRequest {
            bits: &bar,
            gray: &gray,
            cols: &cols,
            rows: &rows,
            overlap_px: 1.0,
            min_px: 2.0,
            pin_clear_px: 0.0,
        });
        assert_eq!(crossings[0].cut_px, 4, "{:?}", seams.xs[0]);
    }
}
