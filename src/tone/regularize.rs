//! Design-rule regularisation: the two-tone clean-up that makes every web of material and every
//! hole of cut at least as wide as the material can hold, changing the picture as little as it can.
//!
//! ## The rule
//! A phase (material or cut) is *wide enough* at a pixel when some disc of the required width that
//! lies wholly in that phase covers the pixel: the pixel survives the morphological opening of its
//! phase by that disc. A pixel that does not is *thin*. When neither phase has a thin pixel, every
//! boundary point has a disc of the required width on both sides of it, so no neck of material
//! (web) or of cut (hole) is narrower than the disc: at the narrowest chord across a region, the
//! disc touching one end would reach past the other end. The disc holds the pixels whose centres
//! lie within `span / 2` of its centre, `span` the required width rounded up to whole pixels; it
//! is centred on a pixel for an odd span and on a pixel corner for an even one, so its rows and
//! columns span exactly `span` pixels: a straight line or hole `span` pixels wide or more is wide
//! enough as it is, and one pixel narrower is not. (On a pixel grid this is the rule up to about
//! a pixel: the pipeline asks for the material's smallest feature plus one pixel, and widens what
//! the width check of the traced outline still finds.)
//!
//! The outside of the picture is material (the sheet continues past the border, as in `islands`
//! and the tracer): discs of material may lie partly outside, discs of cut may not. One exception:
//! a cut filling a corner of the picture keeps its square corner (see `Work::corner_caps`); other
//! square corners are rounded by the disc, a pixel or two, as any opening rounds them.
//!
//! ## Cost
//! Thinness is kept per 64-pixel tile and recomputed only in tiles near what a round changed
//! (a pixel's thinness depends only on the pixels within two disc radii), from distances exact up
//! to the disc's radius; tiles whose window is one tone hold nothing thin and are skipped.
//!
//! ## Deciding
//! Thin pixels are grouped into features (8-connected). A thin feature can be *removed* (its
//! pixels take the other tone: a web dropped, a hole filled) or *widened* (the other tone's pixels
//! within the disc's radius of its ridge, the pixels farthest from its edges, take its tone, so a
//! disc fits along it). Each choice is priced on the gray picture: a flipped pixel costs
//! `0.1 + |gray − threshold|` (a pixel whose gray sits on the threshold could go either way; one far
//! from it is plainly one tone), and the cheaper choice is made. Features that are wide enough are
//! never touched, except where a neighbour's widening reaches into them.
//!
//! ## Why it ends
//! Deciding runs in rounds, all features of a round at once. In the first phase (at most
//! [`FREE_ROUNDS`] rounds) a pixel that has changed tone is locked: a choice that would change it
//! back is not available, so no pixel flips twice and nothing oscillates. What is still thin after
//! that is settled by a second, *monotone* phase: thin holes are filled and thin webs widened, both
//! of which only add material. Opening is increasing, so a material pixel that is wide enough stays
//! so when material is added; and each round adds at least one pixel (a thin web's ridge pixel
//! farthest from the cut is thin, so its disc still holds a cut pixel, which widening fills; a thin
//! hole's pixels are filled). Material grows strictly every round, so the second phase ends after at
//! most as many rounds as there are cut pixels, with nothing thin left; in practice in a few.

use serde::{Deserialize, Serialize};

use crate::raster::{BitGrid, Gray};

/// Rounds of cost-based deciding before the monotone phase settles what is left.
pub const FREE_ROUNDS: usize = 4;

/// Options of the regularisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegularizeConfig {
    /// The narrowest web of material and hole of cut, in working pixels.
    pub min_width_px: f64,
    /// The gray level (0..1) the two-tone was cut at: a flip costs more the farther its gray is.
    pub threshold: f32,
    /// True when material is the dark side (`--invert`): only for the cost, which is symmetric.
    pub invert: bool,
}

/// What the regularisation changed, for the report.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub struct RegularizeStats {
    /// The disc's span in pixels (the smallest odd number at least the required width).
    pub disc_px: u32,
    /// Thin webs of material removed and widened, and thin holes of cut filled and widened.
    pub webs_removed: usize,
    pub webs_widened: usize,
    pub holes_filled: usize,
    pub holes_widened: usize,
    /// Material pixels that became cut, and cut pixels that became material (net, against the
    /// input two-tone).
    pub material_removed_px: usize,
    pub material_added_px: usize,
    /// Rounds of the cost-based phase and of the monotone phase.
    pub rounds: usize,
    pub monotone_rounds: usize,
}

/// The disc: `span` pixels across, centred on a pixel (odd span) or on a pixel corner (even
/// span), holding the pixels whose centres lie within `span / 2` of its centre.
#[derive(Clone, Copy, Debug)]
struct Disc {
    span: u32,
    /// Squared radius, `(span / 2)²` and a hair, so pixels exactly on the circle count.
    r2: f32,
}

impl Disc {
    fn for_width(px: f64) -> Disc {
        let span = if px.is_finite() && px > 1.0 {
            (px - 1e-6).ceil().min(u32::MAX as f64 / 4.0) as u32
        } else {
            1
        };
        let r = span as f32 / 2.0;
        Disc {
            span,
            r2: r * r + 1e-3,
        }
    }
    /// Centres sit on pixel corners: the lattice is offset by half a pixel.
    fn on_corners(&self) -> bool {
        self.span.is_multiple_of(2)
    }
    /// How far a disc's pixels reach from its centre pixel, in whole pixels.
    fn reach(&self) -> i64 {
        self.span as i64 / 2
    }
}

/// Squared Euclidean distance from lattice points to the nearest target of another lattice, exact
/// up to `(k + 1)²` (a larger distance is reported as some value above `k²`). Targets are
/// `targets[y * tw + x]` at positions `(x, y)`; queries are the `qw × qh` points at
/// `(q0 + i, q0 + j)`, `q0` a whole or half number. Along rows the nearest target left and right of
/// each query; along columns the minimum over the target rows within `k` of the query row, a few
/// straight passes over whole rows. O((targets + queries) · k).
fn lattice_distance(
    targets: &[bool],
    tw: usize,
    th: usize,
    q0: f32,
    qw: usize,
    qh: usize,
    k: usize,
) -> Vec<f32> {
    let mut rows = vec![0f32; th * qw];
    let (mut prev, mut next) = (vec![0i32; tw], vec![0i32; tw]);
    for y in 0..th {
        let row = &targets[y * tw..(y + 1) * tw];
        nearest_in_row(
            row,
            q0,
            &mut rows[y * qw..(y + 1) * qw],
            &mut prev,
            &mut next,
        );
    }
    let mut d = vec![f32::INFINITY; qw * qh];
    let kf = k as f32;
    for j in 0..qh {
        let q = q0 + j as f32;
        let t0 = (q - kf).ceil().max(0.0) as usize;
        let t1 = ((q + kf).floor() as i64).min(th as i64 - 1);
        let out = &mut d[j * qw..(j + 1) * qw];
        let mut t = t0 as i64;
        while t <= t1 {
            let dy = q - t as f32;
            let dy2 = dy * dy;
            let src = &rows[t as usize * qw..(t as usize + 1) * qw];
            for (o, &r) in out.iter_mut().zip(src) {
                *o = o.min(r + dy2);
            }
            t += 1;
        }
    }
    d
}

/// Squared distance from each query `q0 + j` to the nearest `true` of `row` (positions 0..n);
/// `prev` and `next` are scratch of the row's length.
fn nearest_in_row(row: &[bool], q0: f32, out: &mut [f32], prev: &mut [i32], next: &mut [i32]) {
    const NONE: i32 = i32::MIN / 2;
    let n = row.len();
    let mut last = NONE;
    for (x, (&r, p)) in row.iter().zip(prev.iter_mut()).enumerate() {
        if r {
            last = x as i32;
        }
        *p = last;
    }
    let mut first = i32::MAX / 2;
    for x in (0..n).rev() {
        if row[x] {
            first = x as i32;
        }
        next[x] = first;
    }
    let (n, o) = (n as i64, q0.floor() as i64);
    let half = q0 != q0.floor();
    for (j, d) in out.iter_mut().enumerate() {
        // Whole query positions look at their own pixel both ways; half ones at the pixels on
        // either side.
        let (lx, rx) = (j as i64 + o, j as i64 + o + half as i64);
        let q = q0 + j as f32;
        let l = if (0..n).contains(&lx) {
            prev[lx as usize]
        } else if lx >= n {
            prev[n as usize - 1]
        } else {
            NONE
        };
        let r = if (0..n).contains(&rx) {
            next[rx as usize]
        } else if rx < 0 {
            next[0]
        } else {
            i32::MAX / 2
        };
        let dl = if l == NONE {
            f32::INFINITY
        } else {
            q - l as f32
        };
        let dr = if r == i32::MAX / 2 {
            f32::INFINITY
        } else {
            r as f32 - q
        };
        *d = (dl * dl).min(dr * dr);
    }
}

/// A working grid: a window of the picture padded by more than the disc's reach with material on
/// every side (the frame: discs of material may reach past the picture's border), and which of its
/// pixels may change.
struct Work {
    bits: BitGrid,
    /// Per pixel: cost of flipping it (infinite where it may not change).
    price: Vec<f32>,
    /// Per pixel: changed tone in the cost-based phase (may not change back there).
    locked: Vec<bool>,
    pad: u32,
    /// Top-left corners (padded coordinates) of the span × span blocks at the picture's own
    /// corners that lie in this window (see [`Work::corner_caps`]).
    corners: Vec<(u32, u32)>,
    maps: Maps,
    disc: Disc,
    /// Per pixel: the id of the thin feature holding it, and the last feature whose widening
    /// counted it. Ids grow across rounds, so neither needs clearing.
    in_feature: Vec<u32>,
    stamp: Vec<u32>,
    next_id: u32,
}

impl Work {
    /// The window `x0..x1 × y0..y1` of `bits`, padded; pixels in `core` (window coordinates,
    /// `[x0, y0, x1, y1)`) may change, priced by `price(x, y)` in picture coordinates.
    fn new(
        bits: &BitGrid,
        window: [u32; 4],
        core: [u32; 4],
        disc: Disc,
        price: impl Fn(u32, u32) -> f32,
    ) -> Work {
        let pad = disc.reach() as u32 + 1;
        let [x0, y0, x1, y1] = window;
        let (pw, ph) = (x1 - x0 + 2 * pad, y1 - y0 + 2 * pad);
        let inside =
            |x: u32, y: u32| x >= pad && y >= pad && x < x1 - x0 + pad && y < y1 - y0 + pad;
        let padded = BitGrid::from_fn(pw, ph, |x, y| {
            !inside(x, y) || bits.get(x - pad + x0, y - pad + y0)
        });
        let prices = (0..pw * ph)
            .map(|i| {
                let (x, y) = (i % pw, i / pw);
                let (wx, wy) = (x.wrapping_sub(pad), y.wrapping_sub(pad));
                if inside(x, y) && wx >= core[0] && wy >= core[1] && wx < core[2] && wy < core[3] {
                    price(wx + x0, wy + y0)
                } else {
                    f32::INFINITY
                }
            })
            .collect();
        let (iw, ih) = (x1 - x0, y1 - y0);
        let sp = disc.span.min(iw).min(ih);
        let mut corners = Vec::new();
        for (cx, cy) in [
            (0, 0),
            (bits.width - sp, 0),
            (0, bits.height - sp),
            (bits.width - sp, bits.height - sp),
        ] {
            if cx >= x0 && cy >= y0 && cx + sp <= x1 && cy + sp <= y1 {
                corners.push((cx - x0 + pad, cy - y0 + pad));
            }
        }
        Work {
            locked: vec![false; (pw * ph) as usize],
            maps: Maps::new(&padded, disc),
            bits: padded,
            price: prices,
            pad,
            corners,
            disc,
            in_feature: vec![u32::MAX; (pw * ph) as usize],
            stamp: vec![u32::MAX; (pw * ph) as usize],
            next_id: 0,
        }
    }

    /// A cut that fills a corner of the picture has a square corner against the sheet's margin,
    /// which no round disc covers, yet it is no neck (the width check does not count cutting
    /// across a corner). Where the span × span block at a picture corner is all cut, its pixels
    /// are not thin.
    fn corner_caps(&self, mask: &mut [bool], span: u32) {
        let w = self.bits.width;
        for &(cx, cy) in &self.corners {
            let block = || {
                (cy..cy + span)
                    .flat_map(move |y| (cx..cx + span).map(move |x| (y * w + x) as usize))
            };
            if block().all(|i| !self.bits.data[i]) {
                block().for_each(|i| mask[i] = false);
            }
        }
    }

    /// Flip pixel `i` to `v`, marking the maps near it for recomputation.
    fn set(&mut self, i: usize, v: bool) {
        if self.bits.data[i] != v {
            self.bits.data[i] = v;
            let (w, h) = (self.bits.width as usize, self.bits.height as usize);
            self.maps.touch(i, w, h, self.disc);
        }
    }

    fn changeable(&self, i: usize) -> bool {
        self.price[i].is_finite()
    }

    /// The window without its padding.
    fn window(&self) -> BitGrid {
        let p = self.pad;
        BitGrid::from_fn(self.bits.width - 2 * p, self.bits.height - 2 * p, |x, y| {
            self.bits.get(x + p, y + p)
        })
    }
}

/// The thin pixels of one phase, and per centre-lattice point its squared distance to the other
/// phase (the ridge finder reads it).
struct Thin {
    mask: Vec<bool>,
    /// Per centre-lattice point (pixels, or corners `(w + 1) × (h + 1)` for an even span).
    d_centre: Vec<f32>,
}

impl Thin {
    /// The largest squared distance to the other phase over a pixel's candidate centres (itself,
    /// or its four corners for an even span): how deep in its phase the pixel lies.
    fn depth(&self, x: usize, y: usize, w: usize, disc: Disc) -> f32 {
        if disc.on_corners() {
            let cw = w + 1;
            let c = |xx: usize, yy: usize| self.d_centre[yy * cw + xx];
            c(x, y)
                .max(c(x + 1, y))
                .max(c(x, y + 1))
                .max(c(x + 1, y + 1))
        } else {
            self.d_centre[y * w + x]
        }
    }
}

/// Pixels of `phase` that no disc lying wholly in `phase` covers, in `bits` alone (what lies past
/// its edges counts as neither phase: callers pad or take margins).
fn thin(bits: &BitGrid, phase: bool, disc: Disc) -> Thin {
    let (w, h) = (bits.width as usize, bits.height as usize);
    let other: Vec<bool> = bits.data.iter().map(|&b| b != phase).collect();
    // Centre lattice: pixels, or corners (w + 1) × (h + 1) at positions −0.5 … w − 0.5.
    let (cw, ch, c0) = if disc.on_corners() {
        (w + 1, h + 1, -0.5)
    } else {
        (w, h, 0.0)
    };
    // Exact up to the radius, which is all the rule reads: whether a centre is farther than the
    // radius from the other phase, whether a pixel is within the radius of a centre, and the
    // depths of thin pixels' candidate centres (none of which is farther than the radius).
    let k = (disc.span as usize).div_ceil(2);
    let d_centre = lattice_distance(&other, w, h, c0, cw, ch, k);
    let centres: Vec<bool> = d_centre.iter().map(|&d| d > disc.r2).collect();
    // Pixel (x, y) sits at x − c0 in centre-lattice indices.
    let d_cover = lattice_distance(&centres, cw, ch, -c0, w, h, k);
    let mask = bits
        .data
        .iter()
        .zip(&d_cover)
        .map(|(&b, &d)| b == phase && d > disc.r2)
        .collect();
    Thin { mask, d_centre }
}

/// Side of the square tiles the thin maps are kept up to date in.
const TILE: usize = 64;

/// Both phases' thin maps over a whole working grid, recomputed only in tiles near what changed.
struct Maps {
    phases: [Thin; 2],
    /// Per tile: something within reach changed since the maps were computed there.
    dirty: Vec<bool>,
    tiles_x: usize,
}

impl Maps {
    fn new(bits: &BitGrid, disc: Disc) -> Maps {
        let (w, h) = (bits.width as usize, bits.height as usize);
        let (cw, ch) = if disc.on_corners() {
            (w + 1, h + 1)
        } else {
            (w, h)
        };
        let blank = || Thin {
            mask: vec![false; w * h],
            d_centre: vec![0.0; cw * ch],
        };
        let (tiles_x, tiles_y) = (w.div_ceil(TILE), h.div_ceil(TILE));
        Maps {
            phases: [blank(), blank()],
            dirty: vec![true; tiles_x * tiles_y],
            tiles_x,
        }
    }

    /// How far a change reaches: a pixel's thinness depends on the pixels within two disc radii
    /// (a centre within a radius, its disc within another), plus a pixel for the corner lattice.
    fn reach(disc: Disc) -> usize {
        disc.span as usize + 2
    }

    /// Mark the tiles whose maps a change at pixel `i` may alter.
    fn touch(&mut self, i: usize, w: usize, h: usize, disc: Disc) {
        let r = Self::reach(disc);
        let (x, y) = (i % w, i / w);
        let (tx0, tx1) = (x.saturating_sub(r) / TILE, (x + r).min(w - 1) / TILE);
        let (ty0, ty1) = (y.saturating_sub(r) / TILE, (y + r).min(h - 1) / TILE);
        for ty in ty0..=ty1 {
            for tx in tx0..=tx1 {
                self.dirty[ty * self.tiles_x + tx] = true;
            }
        }
    }

    /// Recompute the maps in every dirty tile (in parallel), each from a window with a margin wide
    /// enough that the tile's values are exact.
    fn refresh(&mut self, bits: &BitGrid, disc: Disc) {
        use rayon::prelude::*;
        let (w, h) = (bits.width as usize, bits.height as usize);
        let m = Self::reach(disc);
        let corners = disc.on_corners() as usize;
        let (cw, ch) = (w + corners, h + corners);
        let tiles: Vec<usize> = (0..self.dirty.len()).filter(|&t| self.dirty[t]).collect();
        let results: Vec<(usize, Option<[Thin; 2]>, [usize; 4])> = tiles
            .par_iter()
            .map(|&t| {
                let (tx, ty) = (t % self.tiles_x, t / self.tiles_x);
                let (x0, y0) = (tx * TILE, ty * TILE);
                let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
                let ext = [
                    x0.saturating_sub(m),
                    y0.saturating_sub(m),
                    (x1 + m).min(w),
                    (y1 + m).min(h),
                ];
                // A window of one tone holds no thin pixel in its tile: every tile pixel is the
                // centre of a disc of that tone (the margin is wider than the disc). Photos are
                // mostly such windows.
                let first = bits.data[ext[1] * w + ext[0]];
                let uniform = (ext[1]..ext[3]).all(|y| {
                    bits.data[y * w + ext[0]..y * w + ext[2]]
                        .iter()
                        .all(|&b| b == first)
                });
                if uniform {
                    return (t, None, ext);
                }
                let sub = BitGrid::from_fn(
                    (ext[2] - ext[0]) as u32,
                    (ext[3] - ext[1]) as u32,
                    |x, y| bits.get(x + ext[0] as u32, y + ext[1] as u32),
                );
                (
                    t,
                    Some([thin(&sub, true, disc), thin(&sub, false, disc)]),
                    ext,
                )
            })
            .collect();
        for (t, th, ext) in results {
            let (tx, ty) = (t % self.tiles_x, t / self.tiles_x);
            let (x0, y0) = (tx * TILE, ty * TILE);
            let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
            let sw = ext[2] - ext[0];
            let scw = sw + corners;
            // Centre-lattice points owned by this tile: its pixels' own, plus the last row and
            // column of corners at the grid's far edges.
            let (cx1, cy1) = (if x1 == w { cw } else { x1 }, if y1 == h { ch } else { y1 });
            let Some(th) = th else {
                // Nothing thin; depths are only read on thin pixels.
                for dst in &mut self.phases {
                    for y in y0..y1 {
                        dst.mask[y * w + x0..y * w + x1].fill(false);
                    }
                    for y in y0..cy1 {
                        dst.d_centre[y * cw + x0..y * cw + cx1].fill(f32::INFINITY);
                    }
                }
                self.dirty[t] = false;
                continue;
            };
            for (p, sub) in th.into_iter().enumerate() {
                let dst = &mut self.phases[p];
                for y in y0..y1 {
                    for x in x0..x1 {
                        dst.mask[y * w + x] = sub.mask[(y - ext[1]) * sw + x - ext[0]];
                    }
                }
                for y in y0..cy1 {
                    for x in x0..cx1 {
                        dst.d_centre[y * cw + x] = sub.d_centre[(y - ext[1]) * scw + x - ext[0]];
                    }
                }
            }
            self.dirty[t] = false;
        }
    }
}

/// 8-connected groups of `mask` pixels: a list of pixel indices per group.
fn groups(mask: &[bool], width: usize) -> Vec<Vec<usize>> {
    let h = mask.len() / width.max(1);
    let mut seen = vec![false; mask.len()];
    let mut out = Vec::new();
    let mut stack = Vec::new();
    for seed in 0..mask.len() {
        if !mask[seed] || seen[seed] {
            continue;
        }
        seen[seed] = true;
        stack.push(seed);
        let mut g = Vec::new();
        while let Some(i) = stack.pop() {
            g.push(i);
            let (x, y) = ((i % width) as i64, (i / width) as i64);
            for dy in -1..=1i64 {
                for dx in -1..=1i64 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= width as i64 || ny >= h as i64 {
                        continue;
                    }
                    let j = ny as usize * width + nx as usize;
                    if mask[j] && !seen[j] {
                        seen[j] = true;
                        stack.push(j);
                    }
                }
            }
        }
        out.push(g);
    }
    out
}

/// One thin feature and what each way of resolving it would flip.
struct Feature {
    /// The tone of its pixels.
    phase: bool,
    pixels: Vec<usize>,
    /// The other tone's pixels a widening turns to `phase`.
    widen: Vec<usize>,
}

/// The pixels of the other tone within the disc of each ridge pixel of a thin feature: its pixels
/// whose depth is at least each of their 8-neighbours' in the feature. The disc is centred on the
/// pixel (odd span) or on its deepest corner (even span), so once painted that centre is a valid
/// one and covers the ridge pixel.
fn widening(
    bits: &BitGrid,
    feature: &[usize],
    in_feature: &[u32],
    id: u32,
    t: &Thin,
    disc: Disc,
    stamp: &mut [u32],
) -> Vec<usize> {
    let w = bits.width as i64;
    let h = bits.height as i64;
    let phase = bits.data[feature[0]];
    let mut out = Vec::new();
    let k = disc.reach();
    for &i in feature {
        let (x, y) = ((i as i64) % w, (i as i64) / w);
        let mut ridge = true;
        'n: for dy in -1..=1i64 {
            for dx in -1..=1i64 {
                let (nx, ny) = (x + dx, y + dy);
                if (dx, dy) == (0, 0) || nx < 0 || ny < 0 || nx >= w || ny >= h {
                    continue;
                }
                let j = (ny * w + nx) as usize;
                if in_feature[j] == id
                    && t.depth(nx as usize, ny as usize, w as usize, disc)
                        > t.depth(x as usize, y as usize, w as usize, disc)
                {
                    ridge = false;
                    break 'n;
                }
            }
        }
        if !ridge {
            continue;
        }
        // A ridge two pixels thick (a line an even number of pixels wide) keeps one of its rows
        // or columns: discs on both would widen the line by a pixel more than it needs.
        let depth_at = |nx: i64, ny: i64| -> f32 {
            if nx < 0 || ny < 0 || nx >= w || ny >= h || in_feature[(ny * w + nx) as usize] != id {
                f32::NEG_INFINITY
            } else {
                t.depth(nx as usize, ny as usize, w as usize, disc)
            }
        };
        let d = depth_at(x, y);
        if (depth_at(x, y - 1) == d && depth_at(x, y + 1) < d)
            || (depth_at(x - 1, y) == d && depth_at(x + 1, y) < d)
        {
            continue;
        }
        // The centre, in doubled coordinates (pixel centres at odd values for a corner lattice).
        let (cx2, cy2) = if disc.on_corners() {
            let cw = w + 1;
            let mut best = (2 * x, 2 * y, f32::NEG_INFINITY);
            for (ox, oy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let d = t.d_centre[((y + oy) * cw + x + ox) as usize];
                if d > best.2 {
                    best = (2 * (x + ox) - 1, 2 * (y + oy) - 1, d);
                }
            }
            (best.0, best.1)
        } else {
            (2 * x, 2 * y)
        };
        for dy in -k - 1..=k + 1 {
            for dx in -k - 1..=k + 1 {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= w || ny >= h {
                    continue;
                }
                let (ex, ey) = ((2 * nx - cx2) as f32 / 2.0, (2 * ny - cy2) as f32 / 2.0);
                if ex * ex + ey * ey > disc.r2 {
                    continue;
                }
                let j = (ny * w + nx) as usize;
                if bits.data[j] != phase && stamp[j] != id {
                    stamp[j] = id;
                    out.push(j);
                }
            }
        }
    }
    out
}

/// Every thin feature of both phases, with its widening.
fn features(work: &mut Work, disc: Disc) -> Vec<Feature> {
    work.maps.refresh(&work.bits, disc);
    // In place: a corner block that stops being all cut changed, so its tile is recomputed.
    let mut cut_mask = std::mem::take(&mut work.maps.phases[1].mask);
    work.corner_caps(&mut cut_mask, disc.span);
    work.maps.phases[1].mask = cut_mask;
    let bits = &work.bits;
    let w = bits.width as usize;
    let mut out = Vec::new();
    for (p, phase) in [true, false].into_iter().enumerate() {
        let t = &work.maps.phases[p];
        for g in groups(&t.mask, w) {
            let id = work.next_id;
            work.next_id += 1;
            for &i in &g {
                work.in_feature[i] = id;
            }
            let widen = widening(bits, &g, &work.in_feature, id, t, disc, &mut work.stamp);
            out.push(Feature {
                phase,
                pixels: g,
                widen,
            });
        }
    }
    out
}

/// The price of flipping a picture pixel: `0.1 + |gray − threshold|`.
fn pricer<'a>(gray: &'a Gray, cfg: &RegularizeConfig) -> impl Fn(u32, u32) -> f32 + 'a {
    let t = cfg.threshold;
    move |x, y| 0.1 + (gray.get(x, y) - t).abs()
}

/// Regularise `bits` (material = true) so that no web or hole is narrower than
/// `cfg.min_width_px`, deciding each thin feature by the gray picture. See the module comment.
pub fn regularize(
    bits: &BitGrid,
    gray: &Gray,
    cfg: &RegularizeConfig,
) -> (BitGrid, RegularizeStats) {
    let disc = Disc::for_width(cfg.min_width_px);
    let mut stats = RegularizeStats {
        disc_px: disc.span,
        ..Default::default()
    };
    if disc.span <= 1 || bits.is_empty() {
        return (bits.clone(), stats);
    }
    let all = [0, 0, bits.width, bits.height];
    let mut work = Work::new(bits, all, all, disc, pricer(gray, cfg));
    decide(&mut work, disc, &mut stats);
    settle(&mut work, disc, &mut stats);
    let out = work.window();
    for (a, b) in bits.data.iter().zip(&out.data) {
        match (a, b) {
            (true, false) => stats.material_removed_px += 1,
            (false, true) => stats.material_added_px += 1,
            _ => {}
        }
    }
    (out, stats)
}

/// The cost-based phase: each round, every thin feature is removed or widened, whichever costs
/// less; a pixel that changed may not change back; at most [`FREE_ROUNDS`] rounds.
fn decide(work: &mut Work, disc: Disc, stats: &mut RegularizeStats) {
    for _ in 0..FREE_ROUNDS {
        let feats = features(work, disc);
        if feats.is_empty() {
            break;
        }
        stats.rounds += 1;
        let mut changed = vec![false; work.bits.len()];
        let mut any = false;
        // Cheapest first, so where two features' choices meet the cheaper one's stands.
        let mut choices: Vec<(f32, usize, bool)> = Vec::new();
        for (n, f) in feats.iter().enumerate() {
            // Removing needs every pixel of the feature; a widening paints what it may (the frame
            // past the picture's border is material already, and cut may not reach into it).
            let cost = |px: &[usize], all: bool| -> Option<f32> {
                let mut c = 0.0;
                for &i in px {
                    if work.locked[i] || (all && !work.changeable(i)) {
                        return None;
                    }
                    if work.changeable(i) {
                        c += work.price[i];
                    }
                }
                Some(c)
            };
            let remove = cost(&f.pixels, true);
            let widen = if f.widen.is_empty() {
                None
            } else {
                cost(&f.widen, false)
            };
            match (remove, widen) {
                (Some(r), Some(wd)) if wd < r => choices.push((wd, n, true)),
                (Some(r), _) => choices.push((r, n, false)),
                (None, Some(wd)) => choices.push((wd, n, true)),
                (None, None) => {}
            }
        }
        choices.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (_, n, widen) in choices {
            let f = &feats[n];
            let px = if widen { &f.widen } else { &f.pixels };
            if px.iter().any(|&i| changed[i]) {
                continue;
            }
            for &i in px {
                if !work.changeable(i) {
                    continue;
                }
                let v = !work.bits.data[i];
                work.set(i, v);
                work.locked[i] = true;
                changed[i] = true;
            }
            any = true;
            match (f.phase, widen) {
                (true, false) => stats.webs_removed += 1,
                (true, true) => stats.webs_widened += 1,
                (false, false) => stats.holes_filled += 1,
                (false, true) => stats.holes_widened += 1,
            }
        }
        if !any {
            break;
        }
    }
}

/// The monotone phase: fill thin holes and widen thin webs (both only add material) until nothing
/// that may change is thin. Ends: see the module comment.
fn settle(work: &mut Work, disc: Disc, stats: &mut RegularizeStats) {
    loop {
        let feats: Vec<Feature> = features(work, disc)
            .into_iter()
            .filter(|f| f.pixels.iter().any(|&i| work.changeable(i)))
            .collect();
        if feats.is_empty() {
            break;
        }
        stats.monotone_rounds += 1;
        let mut added = 0usize;
        for f in &feats {
            let px = if f.phase { &f.widen } else { &f.pixels };
            for &i in px {
                if work.changeable(i) && !work.bits.data[i] {
                    work.set(i, true);
                    added += 1;
                }
            }
            if f.phase {
                stats.webs_widened += 1;
            } else {
                stats.holes_filled += 1;
            }
        }
        // Cannot happen over the whole picture (see the module comment); in a window a widening
        // may lie outside the part that may change. Either way, stop rather than spin.
        if added == 0 {
            break;
        }
    }
}

/// How many pixels of material and of cut are thin for a web or hole `min_width_px` wide: both 0
/// for what [`regularize`] returns.
pub fn thin_count(bits: &BitGrid, min_width_px: f64) -> [usize; 2] {
    let disc = Disc::for_width(min_width_px);
    if disc.span <= 1 || bits.is_empty() {
        return [0, 0];
    }
    let all = [0, 0, bits.width, bits.height];
    let mut work = Work::new(bits, all, all, disc, |_, _| 1.0);
    work.maps.refresh(&work.bits, disc);
    let mut caps = work.maps.phases[1].mask.clone();
    work.corner_caps(&mut caps, disc.span);
    [&work.maps.phases[0].mask, &caps].map(|m| m.iter().filter(|&&t| t).count())
}

/// Settle the whole stencil with the monotone phase alone: fill thin holes and widen thin webs,
/// only adding material, until nothing is thin. `clean` is a grid with nothing thin (the
/// regularised two-tone, or the stencil after the last settle) that `bits` only adds material to. After bridges are drawn into a regularised
/// two-tone, every thin pixel is one a bridge made (a cut sliver beside it, a notch in its edge),
/// so this tidies exactly where bridges meet the picture; being monotone it never cuts a bridge
/// and ends (see the module comment). Returns the number of pixels added.
pub fn settle_all(bits: &mut BitGrid, clean: &BitGrid, min_width_px: f64) -> usize {
    let disc = Disc::for_width(min_width_px);
    if disc.span <= 1 || bits.is_empty() {
        return 0;
    }
    let all = [0, 0, bits.width, bits.height];
    let mut work = Work::new(bits, all, all, disc, |_, _| 1.0);
    // `clean` has nothing thin: only the tiles near where `bits` differs from it can.
    work.maps.dirty.iter_mut().for_each(|d| *d = false);
    let (w, pad) = (bits.width as usize, work.pad as usize);
    let (pw, ph) = (work.bits.width as usize, work.bits.height as usize);
    for (i, (a, b)) in bits.data.iter().zip(&clean.data).enumerate() {
        if a != b {
            let (x, y) = (i % w + pad, i / w + pad);
            work.maps.touch(y * pw + x, pw, ph, disc);
        }
    }
    let mut stats = RegularizeStats::default();
    settle(&mut work, disc, &mut stats);
    let out = work.window();
    let added = out.count_material() - bits.count_material();
    *bits = out;
    added
}

/// Fill the pockets of cut that bridges sealed off: cut pieces of `after` whose every material
/// neighbour is material `after` added to `before` (overlapping bridges enclose a piece of the
/// picture's cut). Such a pocket shows nothing of the picture's outline and its ring lies wholly
/// inside bridges, where it only weakens them. Only adds material. Returns the pixels filled.
pub fn fill_sealed_pockets(before: &BitGrid, after: &mut BitGrid) -> usize {
    let (labels, areas) = crate::islands::components(after, false);
    let (w, h) = (after.width as usize, after.height as usize);
    // Per cut piece: touches original material, or the picture's border (the frame).
    let mut open = vec![false; areas.len()];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let l = labels[i];
            if l == crate::islands::CUT || open[l as usize] {
                continue;
            }
            if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
                open[l as usize] = true;
                continue;
            }
            for j in [i - 1, i + 1, i - w, i + w] {
                if after.data[j] && before.data[j] {
                    open[l as usize] = true;
                }
            }
        }
    }
    let mut filled = 0;
    for (i, &l) in labels.iter().enumerate() {
        if l != crate::islands::CUT && !open[l as usize] {
            after.data[i] = true;
            filled += 1;
        }
    }
    filled
}

/// Where bridges meet the picture: settle the pixels within reach of the bridges' bounding boxes
/// (`[x0, y0, x1, y1)` in pixels), only adding material, so no cut sliver and no web narrower than
/// the material's smallest feature is left beside a bridge. Each box is settled in a window large
/// enough that thinness inside the box's reach is measured exactly (a pixel's thinness depends on
/// the pixels within two disc spans of it). Returns the number of pixels added.
pub fn settle_near(
    bits: &mut BitGrid,
    boxes: &[[u32; 4]],
    min_width_px: f64,
    spread: u32,
) -> usize {
    let disc = Disc::for_width(min_width_px);
    if disc.span <= 1 || bits.is_empty() {
        return 0;
    }
    let reach = disc.span + 1;
    let (w, h) = (bits.width, bits.height);
    let grow = |b: [u32; 4], m: u32| {
        [
            b[0].saturating_sub(m),
            b[1].saturating_sub(m),
            (b[2] + m).min(w),
            (b[3] + m).min(h),
        ]
    };
    let mut added = 0;
    let mut stats = RegularizeStats::default();
    for &b in boxes {
        // Pixels within two spans of the window's cut edges may be misjudged (the padding stands
        // in for what lies beyond): only the part inside that margin may change, and it reaches
        // `spread` spans past the box, so what a widening there pushes outward is settled too.
        let window = grow(b, (2 + spread) * reach);
        let m = 2 * reach;
        let core = [
            if window[0] == 0 { 0 } else { window[0] + m },
            if window[1] == 0 { 0 } else { window[1] + m },
            if window[2] == w { w } else { window[2] - m },
            if window[3] == h { h } else { window[3] - m },
        ];
        let rel = [
            core[0] - window[0],
            core[1] - window[1],
            core[2] - window[0],
            core[3] - window[1],
        ];
        let mut work = Work::new(bits, window, rel, disc, |_, _| 1.0);
        settle(&mut work, disc, &mut stats);
        let out = work.window();
        for y in core[1]..core[3] {
            for x in core[0]..core[2] {
                let v = out.get(x - window[0], y - window[1]);
                if v && !bits.get(x, y) {
                    bits.set(x, y, true);
                    added += 1;
                }
            }
        }
    }
    added
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(px: f64) -> RegularizeConfig {
        RegularizeConfig {
            min_width_px: px,
            threshold: 0.5,
            invert: false,
        }
    }

    fn any_thin(bits: &BitGrid, px: f64) -> bool {
        thin_count(bits, px) != [0, 0]
    }

    #[test]
    fn disc_spans_the_smallest_odd_width() {
        assert_eq!(Disc::for_width(5.0).span, 5);
        assert_eq!(Disc::for_width(4.2).span, 5);
        assert_eq!(Disc::for_width(6.0).span, 6);
        assert_eq!(Disc::for_width(0.5).span, 1);
    }

    #[test]
    fn lattice_distance_matches_brute_force_up_to_its_reach() {
        let (w, h) = (23usize, 17usize);
        let mut seed = 7u64;
        let targets: Vec<bool> = (0..w * h)
            .map(|_| {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
                (seed >> 60) == 0
            })
            .collect();
        for (q0, qw, qh) in [(0.0f32, w, h), (-0.5, w + 1, h + 1), (0.5, w - 1, h - 1)] {
            for k in [2usize, 4, 30] {
                let d = lattice_distance(&targets, w, h, q0, qw, qh, k);
                for j in 0..qh {
                    for i in 0..qw {
                        let (qx, qy) = (q0 + i as f32, q0 + j as f32);
                        let mut best = f32::INFINITY;
                        for y in 0..h {
                            for x in 0..w {
                                if targets[y * w + x] {
                                    let (dx, dy) = (qx - x as f32, qy - y as f32);
                                    best = best.min(dx * dx + dy * dy);
                                }
                            }
                        }
                        let got = d[j * qw + i];
                        let kk = (k * k) as f32;
                        if best <= kk {
                            assert_eq!(got, best, "q0 {q0} k {k} at ({i}, {j})");
                        } else {
                            assert!(got > kk, "q0 {q0} k {k} at ({i}, {j}): {got} vs {best}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn checkerboards_end_with_nothing_thin_and_wide_ones_are_kept() {
        for cell in [1u32, 2, 3, 5, 8, 13] {
            let bits = BitGrid::from_fn(90, 70, |x, y| ((x / cell) + (y / cell)) % 2 == 0);
            let gray = Gray::new(90, 70, 0.5);
            let (out, _) = regularize(&bits, &gray, &cfg(6.0));
            assert!(!any_thin(&out, 6.0), "cell {cell}");
        }
        // Squares wider than the disc touching only at corners: the corners are thin (no width
        // there), the squares' middles stay.
        let bits = BitGrid::from_fn(80, 80, |x, y| ((x / 20) + (y / 20)) % 2 == 0);
        let (out, _) = regularize(&bits, &Gray::new(80, 80, 0.5), &cfg(6.0));
        assert!(!any_thin(&out, 6.0));
        for (x, y) in [(10, 10), (30, 30), (50, 10), (10, 50)] {
            assert_eq!(out.get(x, y), bits.get(x, y), "({x}, {y})");
        }
    }

    #[test]
    fn the_gray_picture_decides_between_removing_and_widening() {
        // A cut line 4 px wide (the disc is 6) across paper. Same bits, two pictures.
        let bits = BitGrid::from_fn(60, 40, |_, y| !(18..22).contains(&y));
        let line_width = |out: &BitGrid| (0..40).filter(|&y| !out.get(30, y)).count();
        // A black line on paper that is barely light: widening (into near-threshold paper) is
        // cheaper than erasing a plainly dark line.
        let mut gray = Gray::new(60, 40, 0.55);
        for y in 18..22 {
            for x in 0..60 {
                gray.set(x, y, 0.0);
            }
        }
        let (out, s) = regularize(&bits, &gray, &cfg(6.0));
        assert_eq!(line_width(&out), 6, "{s:?}");
        // A faint line (just under the threshold) on white paper: erasing it changes less.
        let mut gray = Gray::new(60, 40, 1.0);
        for y in 18..22 {
            for x in 0..60 {
                gray.set(x, y, 0.45);
            }
        }
        let (out, s) = regularize(&bits, &gray, &cfg(6.0));
        assert_eq!(line_width(&out), 0, "{s:?}");
    }

    #[test]
    fn noise_ends_with_nothing_thin() {
        // Pseudo-random noise: the hardest case for deciding; the monotone phase must finish it.
        let mut s = 12345u64;
        let bits = BitGrid::from_fn(80, 60, |_, _| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 33) & 1 == 1
        });
        let gray = Gray::new(80, 60, 0.5);
        let (out, stats) = regularize(&bits, &gray, &cfg(5.0));
        assert!(!any_thin(&out, 5.0), "{stats:?}");
    }
}
