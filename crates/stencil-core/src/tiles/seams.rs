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
//!
//! ## Registration marks on a seam
//! Two tiles meet along a *segment* of a seam (between the seams that cross it, or the picture's
//! outer band). Each segment gets at least two pin holes centred on it, cut into both tiles at
//! the same place on the wall (see [`place_marks`]): in the outer band of material around the
//! picture where the segment reaches it (always clear); near a third and two thirds of its length
//! where the picture is material around the hole ([`MarkPlace::Clear`]); and, where a segment
//! still has fewer than two, a *pad* ([`MarkPlace::Pad`]): the hole's ring of material put into
//! the picture where it changes the fewest pixels, never over a cut feature thinner than the
//! material's smallest (it would close it).

use serde::Serialize;

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
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Crossing {
    /// Seam pixels in the cut.
    pub cut_px: usize,
    /// Seam pixels in a cut feature narrower than the material's smallest feature.
    pub thin_px: usize,
    /// Seam pixels in all.
    pub len_px: usize,
    /// Its runs through the cut, as first and last steps along it: where the earlier tile's
    /// strip is the seam's bridge.
    pub runs: Vec<(u32, u32)>,
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
    /// The band of material around the picture, px (the seams' ends lie in it).
    pub band_px: u32,
}

/// What lies along a seam's path, step by step, for its marks: how far the picture's cut is
/// (px), and how many cut pixels a pad there would fill (`u32::MAX`: a thin cut feature).
#[derive(Clone, Debug, Default)]
pub(crate) struct Along {
    clear: Vec<f32>,
    pad_cut: Vec<u32>,
}

/// How a registration mark on a seam was placed (see the module notes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MarkPlace {
    /// Where the picture is material around it.
    Clear,
    /// In the band of material around the picture.
    Band,
    /// On a pad of material put into the picture for it.
    Pad,
}

/// A registration pin hole on a seam, shared by the two tiles of its segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SeamMark {
    /// Its seam (vertical seams first).
    pub seam: usize,
    /// Its segment along the seam (from 0: the tiles of row or column `segment + 1`).
    pub segment: usize,
    /// Its centre, working px of the whole picture.
    pub at: (u32, u32),
    /// How it was placed.
    pub place: MarkPlace,
}

/// The seams found, what each crossed (vertical seams first), and what lies along them.
pub(crate) fn find(r: &SeamRequest) -> (Seams, Vec<Crossing>, Vec<Along>) {
    let (w, h) = (r.bits.width, r.bits.height);
    let mut seams = Seams::default();
    let mut crossings = Vec::new();
    let mut alongs = Vec::new();
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
                    match cr.runs.last_mut() {
                        Some(r) if r.1 + 1 == s as u32 => r.1 = s as u32,
                        _ => cr.runs.push((s as u32, s as u32)),
                    }
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
                alongs.push(along(&p, &bits, b0, &to_cut, &to_material, r));
            } else {
                alongs.push(Along::default());
            }
            crossings.push(cr);
            if vertical {
                seams.xs.push(p);
            } else {
                seams.ys.push(p);
            }
        }
    }
    (seams, crossings, alongs)
}

/// What lies along path `p` (across positions from `b0` in the band's box `bits`, seen along).
fn along(
    p: &[u32],
    bits: &BitGrid,
    b0: u32,
    to_cut: &[f32],
    to_material: &[f32],
    r: &SeamRequest,
) -> Along {
    let bw = bits.width;
    // Wide cut: within half the smallest feature of a point that far from material (the cut's
    // opening by a disc of the smallest feature); a cut pixel not in it is a thin feature.
    let half = (r.min_px / 2.0).max(0.5) as f32;
    let centres = BitGrid::from_fn(bw, bits.height, |x, y| {
        to_material[(y * bw + x) as usize] >= half * half
    });
    let to_centre = squared_distance_to(&centres, true);
    let pad = r.pin_clear_px;
    let k = pad.ceil() as i64;
    let mut out = Along::default();
    for (s, &a) in p.iter().enumerate() {
        let i = (s as u32 * bw + (a - b0)) as usize;
        out.clear.push(to_cut[i].sqrt());
        let mut n = 0u32;
        'disc: for dy in -k..=k {
            for dx in -k..=k {
                let (q, t) = (a as i64 - b0 as i64 + dx, s as i64 + dy);
                if (dx * dx + dy * dy) as f64 > pad * pad
                    || q < 0
                    || t < 0
                    || q >= bw as i64
                    || t >= bits.height as i64
                {
                    continue;
                }
                let j = (t as u32 * bw + q as u32) as usize;
                if !bits.data[j] {
                    if to_centre[j] > half * half + 0.5 {
                        n = u32::MAX;
                        break 'disc;
                    }
                    n += 1;
                }
            }
        }
        out.pad_cut.push(n);
    }
    out
}

/// The steps where seam `k` (vertical when `vertical`) passes from one segment to the next:
/// where it enters the next row (column) of tiles the crossing seams make.
fn segment_ends(seams: &Seams, vertical: bool, k: usize) -> Vec<usize> {
    let path = if vertical { &seams.xs[k] } else { &seams.ys[k] };
    let mut ends = Vec::new();
    let mut last = 0;
    for (s, &a) in path.iter().enumerate() {
        let (x, y) = if vertical {
            (a, s as u32)
        } else {
            (s as u32, a)
        };
        let seg = if vertical {
            seams.row(x, y)
        } else {
            seams.col(x, y)
        };
        while seg > last {
            ends.push(s);
            last += 1;
        }
    }
    ends.push(path.len());
    ends
}

/// The registration marks of every seam's segments, and so the pads to put into the picture
/// (see the module notes). `alongs` is what [`find`] gave, one per seam.
pub(crate) fn place_marks(seams: &Seams, alongs: &[Along], r: &SeamRequest) -> Vec<SeamMark> {
    let mut out = Vec::new();
    if r.pin_clear_px <= 0.0 {
        return out;
    }
    let keep = (r.overlap_px + r.pin_clear_px).ceil() as usize + 1;
    let band = r.band_px as usize;
    let all = seams
        .xs
        .iter()
        .map(|p| (true, p))
        .chain(seams.ys.iter().map(|p| (false, p)));
    for (k, ((vertical, path), al)) in all.zip(alongs).enumerate() {
        let len = path.len();
        let kk = if vertical { k } else { k - seams.xs.len() };
        let mut start = 0;
        for (seg, end) in segment_ends(seams, vertical, kk).into_iter().enumerate() {
            let at = |s: usize| {
                let a = path[s];
                if vertical {
                    (a, s as u32)
                } else {
                    (s as u32, a)
                }
            };
            let mut marks: Vec<(usize, MarkPlace)> = Vec::new();
            // The outer band's, at the segment's ends there.
            if band > 0 && start == 0 && end > band {
                marks.push((band / 2, MarkPlace::Band));
            }
            if band > 0 && end == len && len > band && start + band < len {
                marks.push((len - 1 - band / 2, MarkPlace::Band));
            }
            // The picture's steps of the segment, clear of the crossing seams.
            let lo = if start == 0 { band } else { start + keep };
            let hi = if end == len {
                len.saturating_sub(band)
            } else {
                end.saturating_sub(keep)
            };
            if hi > lo {
                let n = hi - lo;
                let mut wants = Vec::new();
                for frac in [1.0 / 3.0, 2.0 / 3.0] {
                    let c = lo + (n as f64 * frac) as usize;
                    let reach = (n / 6).max(1);
                    let span = c.saturating_sub(reach).max(lo)..(c + reach).min(hi);
                    let best = span
                        .clone()
                        .max_by(|&i, &j| al.clear[i].total_cmp(&al.clear[j]));
                    match best {
                        Some(i) if al.clear[i] as f64 >= r.pin_clear_px => {
                            marks.push((i, MarkPlace::Clear))
                        }
                        _ => wants.push(span),
                    }
                }
                // Fewer than two: pads, where they change the fewest pixels.
                for span in wants {
                    if marks.len() >= 2 {
                        break;
                    }
                    let best = span
                        .filter(|&i| al.pad_cut[i] != u32::MAX)
                        .min_by_key(|&i| al.pad_cut[i]);
                    if let Some(i) = best {
                        marks.push((i, MarkPlace::Pad));
                    }
                }
            }
            for (s, place) in marks {
                out.push(SeamMark {
                    seam: k,
                    segment: seg,
                    at: at(s),
                    place,
                });
            }
            start = end;
        }
    }
    out
}

/// Put the pads of `marks` into a two-tone: material within `pad_px` of each pad's centre.
pub(crate) fn put_pads(bits: &mut BitGrid, marks: &[SeamMark], pad_px: f64) {
    let k = pad_px.ceil() as i64;
    for m in marks.iter().filter(|m| m.place == MarkPlace::Pad) {
        let (cx, cy) = (m.at.0 as i64, m.at.1 as i64);
        for dy in -k..=k {
            for dx in -k..=k {
                let (x, y) = (cx + dx, cy + dy);
                if (dx * dx + dy * dy) as f64 <= pad_px * pad_px
                    && x >= 0
                    && y >= 0
                    && (x as u32) < bits.width
                    && (y as u32) < bits.height
                {
                    bits.set(x as u32, y as u32, true);
                }
            }
        }
    }
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
            band_px: 0,
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
            band_px: 0,
        });
        assert_eq!(crossings[0].cut_px, 4, "{:?}", seams.xs[0]);
    }

    #[test]
    fn every_segment_gets_two_marks_and_no_pad_fills_a_thin_line() {
        let (w, h) = (200u32, 100u32);
        let run = |bits: &BitGrid| {
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
                centres_px: vec![100],
                band_px: 5,
            };
            let rows = Side {
                count: 2,
                centres_px: vec![50],
                band_px: 5,
            };
            let req = SeamRequest {
                bits,
                gray: &gray,
                cols: &cols,
                rows: &rows,
                overlap_px: 2.0,
                min_px: 4.0,
                pin_clear_px: 6.0,
                band_px: 10,
            };
            let (seams, _, alongs) = find(&req);
            place_marks(&seams, &alongs, &req)
        };
        // A dark block over the vertical seam (the band around the picture is material): each of
        // its two segments gets its band's mark and a pad in the dark.
        let dark = BitGrid::from_fn(w, h, |x, y| {
            !((70..130).contains(&x) && (10..90).contains(&y))
        });
        let marks = run(&dark);
        for seg in 0..2 {
            let on: Vec<&SeamMark> = marks
                .iter()
                .filter(|m| m.seam == 0 && m.segment == seg)
                .collect();
            assert_eq!(on.len(), 2, "{marks:?}");
            assert!(on.iter().any(|m| m.place == MarkPlace::Band), "{on:?}");
            let pad = on
                .iter()
                .find(|m| m.place == MarkPlace::Pad)
                .expect("a pad");
            assert!(
                !dark.get(pad.at.0, pad.at.1),
                "the pad is in the dark: {pad:?}"
            );
            let mut padded = dark.clone();
            put_pads(&mut padded, &marks, 6.0);
            assert!(
                padded.get(pad.at.0 + 5, pad.at.1),
                "material around the pad"
            );
        }
        // Thin cut lines (1 px, under the 4 px smallest feature) all over the seam: no pad.
        let lines = BitGrid::from_fn(w, h, |x, y| {
            !((70..130).contains(&x) && (10..90).contains(&y) && y % 3 == 0)
        });
        let marks = run(&lines);
        assert!(marks.iter().all(|m| m.place != MarkPlace::Pad), "{marks:?}");
    }
}
