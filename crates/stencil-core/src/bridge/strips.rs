//! Strips: one-pixel-wide walks through the cut from a candidate to material of another node.
//!
//! A walk starts on the cut pixel beside the candidate that faces away from the island (the normal
//! of the smoothed two-tone), then steps pixel by pixel along a direction that follows the
//! grayscale gradient, or, where the grayscale is flat (a pure black-and-white input), the gradient
//! of the smoothed two-tone, so walks leave and meet edges at right angles. Steps are exact ray
//! traversals (Amanatides & Woo), one edge neighbour at a time, so a strip is 4-connected by
//! construction, and it ends on a cut pixel that has material of another node (or the sheet beyond
//! the image) as an edge neighbour, so setting its pixels to material joins both nodes 4-connectedly.
//! The paper's stage 3, first half ("from each candidate, walk through the cut along the
//! grayscale gradient"). Walks stop early where no other node is within their remaining length
//! ([`Reach`]); a group no walk leaves is joined by [`super::search`].

use super::candidates::Candidates;
use super::reach::Reach;
use crate::islands::{IslandMap, CUT, FRAME};
use crate::raster::{BitGrid, Gray, TwoTone};

/// ΣI, the cost's intensity term (`super::cost`): sum over the strip's pixels of the squared difference between the grayscale and white
/// (the bridge turns them white).
pub(crate) fn intensity(gray: &Gray, pixels: &[u32]) -> f64 {
    pixels
        .iter()
        .map(|&p| {
            let d = 1.0 - gray.data[p as usize] as f64;
            d * d
        })
        .sum()
}

/// A one-pixel-wide chain of cut pixels from a candidate of `from` to material of `to`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Strip {
    pub(crate) from: u32,
    pub(crate) to: u32,
    /// Linear pixel indices (`y * width + x`), 4-connected, first beside the candidate.
    pub(crate) pixels: Vec<u32>,
    /// Where the strip lands: the material pixel of `to` beside its last pixel (may lie one pixel
    /// outside the image when `to` is the sheet beyond the image).
    pub(crate) end: (i64, i64),
    /// ΣI, the intensity error of its pixels (see [`intensity`]).
    pub(crate) intensity: f64,
}

impl Strip {
    /// L: the number of pixels the strip turns into material.
    pub(crate) fn len(&self) -> usize {
        self.pixels.len()
    }
}

/// Radius of the box filter that smooths the two-tone for steering (3×3): it turns walks only
/// within a pixel or two of material, so walks meet edges square and run straight in between.
const STEER_RADIUS: i64 = 1;
/// Radius of the box filter for the start direction when the contour gives none.
const NORMAL_RADIUS: i64 = 2;
/// Half-length, in candidates, of the stretch of contour whose chord gives the edge tangent.
const TANGENT_REACH: isize = 3;
/// Below this grayscale gradient (gray levels per pixel, Sobel) the gray source counts as flat
/// and the smoothed two-tone steers instead.
const GRAY_FLAT: f32 = 0.02;
/// How strongly the local field turns the heading at each step (0 = straight lines).
const STEER: f32 = 0.5;
/// A field direction more than 60° off the heading is ambiguous (near perpendicular its sign
/// flips with noise) and would swing the walk sideways; it is ignored.
const MIN_ALIGN: f32 = 0.5;
/// Pixels checked for a revisit: a walk that comes back onto itself loops and is dropped. (A walk
/// that turns more than a right angle from its start is dropped first, so longer loops cannot
/// form: its progress along the start direction only grows.)
const LOOP_WINDOW: usize = 8;

/// What the walks read: the two-tone, the grayscale and the labels (of the same bits: cut tests
/// read the smaller bit grid). The steering fields (Sobel gradient of the gray, box-smoothed
/// gradient of the two-tone) are evaluated only at the pixels walks cross.
pub(crate) struct Fields<'a> {
    pub(crate) bits: &'a BitGrid,
    pub(crate) gray: &'a Gray,
    pub(crate) labels: &'a [u32],
    pub(crate) width: i64,
    pub(crate) height: i64,
    /// Cut pixels no strip may cross (the user's keep-out areas), if any.
    pub(crate) forbidden: Option<&'a BitGrid>,
    /// How near material of each node can be, block by block: walks that can no longer reach
    /// another node within their length limit stop early (see [`Reach`]). `None`: they walk on.
    reach: Option<Reach>,
}

impl<'a> Fields<'a> {
    pub(crate) fn new(two: &'a TwoTone, map: &'a IslandMap) -> Self {
        Fields {
            bits: &two.bits,
            gray: &two.gray,
            labels: &map.labels,
            width: two.bits.width as i64,
            height: two.bits.height as i64,
            forbidden: None,
            reach: None,
        }
    }

    /// The same fields with [`Reach`] of `map` (the map they were made from), so walks stop as
    /// soon as no other node lies within their remaining length. Worth it where many walks are
    /// made (the stage's thousands); the walks' results are the same with it or without it.
    pub(crate) fn with_reach(self, map: &IslandMap) -> Self {
        Fields {
            reach: Some(Reach::new(map)),
            ..self
        }
    }

    /// The same fields with cut pixels no strip may cross (a grid of the image's size).
    pub(crate) fn with_forbidden(self, forbidden: Option<&'a BitGrid>) -> Self {
        Fields { forbidden, ..self }
    }

    /// Whether a strip may not cross pixel (x, y) (inside the image).
    #[inline]
    pub(super) fn blocked(&self, x: i64, y: i64) -> bool {
        self.forbidden
            .is_some_and(|f| self.inside(x, y) && f.data[(y * self.width + x) as usize])
    }

    #[inline]
    pub(super) fn inside(&self, x: i64, y: i64) -> bool {
        x >= 0 && y >= 0 && x < self.width && y < self.height
    }

    /// Label of a pixel; outside the image is the frame (the sheet continues).
    #[inline]
    pub(crate) fn label(&self, x: i64, y: i64) -> u32 {
        if self.inside(x, y) {
            self.labels[(y * self.width + x) as usize]
        } else {
            FRAME
        }
    }

    /// Gradient of the two-tone smoothed by a (2r+1)² box at a pixel: points towards material,
    /// zero farther than r from it. Outside the image counts as material (the frame).
    pub(crate) fn twotone_gradient(&self, x: i64, y: i64, r: i64) -> [f32; 2] {
        let w = self.width;
        let data = &self.bits.data;
        let (mut gx, mut gy) = (0i32, 0i32);
        if r == 1 && x >= 1 && y >= 1 && x + 1 < w && y + 1 < self.height {
            // The steering case, at every step of every walk: the 3×3 sums written out.
            let c = (y * w + x) as usize;
            let (u, dn) = (c - w as usize, c + w as usize);
            let b = |i: usize| data[i] as i32;
            gx = (b(u + 1) + b(c + 1) + b(dn + 1)) - (b(u - 1) + b(c - 1) + b(dn - 1));
            gy = (b(dn - 1) + b(dn) + b(dn + 1)) - (b(u - 1) + b(u) + b(u + 1));
        } else if x >= r && y >= r && x + r < w && y + r < self.height {
            // Per row: material right of the column minus left of it (x), and the row's total
            // signed by its side of the centre (y). The same sums as pixel by pixel with
            // signum weights, without a branch per pixel: walks evaluate this at every step.
            let r = r as usize;
            for dy in -(r as i64)..=r as i64 {
                let row = ((y + dy) * w + x) as usize;
                let (mut left, mut right) = (0i32, 0i32);
                for dx in 1..=r {
                    left += data[row - dx] as i32;
                    right += data[row + dx] as i32;
                }
                gx += right - left;
                gy += dy.signum() as i32 * (left + right + data[row] as i32);
            }
        } else {
            for dy in -r..=r {
                for dx in -r..=r {
                    if self.bits.get_or_frame(x + dx, y + dy) {
                        gx += dx.signum() as i32;
                        gy += dy.signum() as i32;
                    }
                }
            }
        }
        [gx as f32, gy as f32]
    }

    /// Sobel gradient of the grayscale (levels per pixel), clamped at the image edge.
    pub(crate) fn gray_gradient(&self, x: i64, y: i64) -> [f32; 2] {
        let w = self.width;
        if x >= 1 && y >= 1 && x + 1 < w && y + 1 < self.height {
            let d = &self.gray.data;
            let c = (y * w + x) as usize;
            let (u, dn) = (c - w as usize, c + w as usize);
            let gx =
                (d[u + 1] + 2.0 * d[c + 1] + d[dn + 1]) - (d[u - 1] + 2.0 * d[c - 1] + d[dn - 1]);
            let gy = (d[dn - 1] + 2.0 * d[dn] + d[dn + 1]) - (d[u - 1] + 2.0 * d[u] + d[u + 1]);
            return [gx / 8.0, gy / 8.0];
        }
        let g = |dx: i64, dy: i64| {
            let xx = (x + dx).clamp(0, self.width - 1) as u32;
            let yy = (y + dy).clamp(0, self.height - 1) as u32;
            self.gray.get(xx, yy)
        };
        let gx = (g(1, -1) + 2.0 * g(1, 0) + g(1, 1)) - (g(-1, -1) + 2.0 * g(-1, 0) + g(-1, 1));
        let gy = (g(-1, 1) + 2.0 * g(0, 1) + g(1, 1)) - (g(-1, -1) + 2.0 * g(0, -1) + g(1, -1));
        [gx / 8.0, gy / 8.0]
    }

    /// The direction field a walk follows at a pixel, unoriented (a line field): the grayscale
    /// gradient where it is not flat, else the smoothed two-tone's. `None` where both are flat.
    pub(crate) fn field(&self, x: i64, y: i64) -> Option<[f32; 2]> {
        let g = self.gray_gradient(x, y);
        let m2 = g[0] * g[0] + g[1] * g[1];
        if m2 >= GRAY_FLAT * GRAY_FLAT {
            let m = m2.sqrt();
            return Some([g[0] / m, g[1] / m]);
        }
        let t = self.twotone_gradient(x, y, STEER_RADIUS);
        if t == [0.0, 0.0] {
            return None;
        }
        let m = (t[0] * t[0] + t[1] * t[1]).sqrt();
        Some([t[0] / m, t[1] / m])
    }

    /// Cut-side sense at a border pixel: the sum of the offsets to its cut edge neighbours, or
    /// where those balance (a one-pixel line), away from the smoothed material around it.
    fn cut_side(&self, x: i64, y: i64) -> [f32; 2] {
        let mut cut = [0f32; 2];
        for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            if !self.material(x + dx, y + dy) {
                cut[0] += dx as f32;
                cut[1] += dy as f32;
            }
        }
        if cut == [0.0, 0.0] {
            let t = self.twotone_gradient(x, y, NORMAL_RADIUS);
            cut = [-t[0], -t[1]];
        }
        cut
    }

    /// The node other than `own` that material beside (x, y) belongs to, if any (edge neighbours).
    #[inline]
    /// Reads the (small) bit grid first and the labels only beside material.
    fn arrival(&self, x: i64, y: i64, own: u32) -> Option<((i64, i64), u32)> {
        if x >= 1 && y >= 1 && x + 1 < self.width && y + 1 < self.height {
            // Away from the image edge (nearly every step): plain indexing, same order.
            let (c, w) = ((y * self.width + x) as usize, self.width as usize);
            for (i, (dx, dy)) in [
                (c + 1, (1, 0)),
                (c - 1, (-1, 0)),
                (c + w, (0, 1)),
                (c - w, (0, -1)),
            ] {
                if self.bits.data[i] {
                    let l = self.labels[i];
                    if l != CUT && l != own {
                        return Some(((x + dx, y + dy), l));
                    }
                }
            }
            return None;
        }
        for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            let (nx, ny) = (x + dx, y + dy);
            if !self.material(nx, ny) {
                continue;
            }
            let l = self.label(nx, ny);
            if l != CUT && l != own {
                return Some(((nx, ny), l));
            }
        }
        None
    }

    /// Material test; outside the image is the frame.
    #[inline]
    pub(super) fn material(&self, x: i64, y: i64) -> bool {
        !self.inside(x, y) || self.bits.data[(y * self.width + x) as usize]
    }
}

/// Why a walk produced no strip (kept for counting in tests and diagnostics).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum WalkEnd {
    /// Longer than the limit.
    TooLong,
    /// Walked back into its own node.
    Returned,
    /// Came back onto a pixel it had crossed, or could not move.
    Looped,
    /// No cut pixel beside the candidate.
    NoStart,
    /// Ran into a pixel no strip may cross (`--keep-out`, `--no-bridge-near`).
    Blocked,
}

/// Outward normal of the border at candidate `id`: perpendicular to the chord between the
/// candidates `TANGENT_REACH` steps before and after it along the contour, on the cut side. So
/// a walk leaves a straight edge at right angles even on a digital staircase.
pub(crate) fn normal(f: &Fields, c: &Candidates, id: usize) -> [f32; 2] {
    let (x, y) = c.pixels[id];
    let (x, y) = (x as i64, y as i64);
    let side = f.cut_side(x, y);
    let at = |k: isize| {
        (1..=TANGENT_REACH.abs())
            .rev()
            .find_map(|r| c.along(id, r * k.signum()))
            .map(|j| c.pixels[j])
    };
    let mut n = side;
    if let (Some(a), Some(b)) = (at(-1), at(1)) {
        let t = [b.0 as f32 - a.0 as f32, b.1 as f32 - a.1 as f32];
        let perp = [-t[1], t[0]];
        if perp != [0.0, 0.0] {
            let dot = perp[0] * side[0] + perp[1] * side[1];
            n = if dot >= 0.0 {
                perp
            } else {
                [-perp[0], -perp[1]]
            };
        }
    }
    let m = (n[0] * n[0] + n[1] * n[1]).sqrt();
    if m == 0.0 {
        [1.0, 0.0]
    } else {
        [n[0] / m, n[1] / m]
    }
}

/// The strip of candidate `id`: a walk from it along its [`normal`] (tests; the stage reuses a
/// scratch buffer through [`walk_candidate_with`]).
#[cfg(test)]
pub(crate) fn walk_candidate(
    f: &Fields,
    c: &Candidates,
    id: usize,
    max_len: usize,
) -> Result<Strip, WalkEnd> {
    walk_candidate_with(f, c, id, max_len, &mut Vec::new())
}

/// The strip of candidate `id`, a walk from it along its [`normal`], with a reusable scratch
/// buffer (no allocation for walks that fail).
pub(crate) fn walk_candidate_with(
    f: &Fields,
    c: &Candidates,
    id: usize,
    max_len: usize,
    scratch: &mut Vec<u32>,
) -> Result<Strip, WalkEnd> {
    let (x, y) = c.pixels[id];
    walk(f, x, y, c.node(id), normal(f, c, id), max_len, scratch)
}

/// Walk from candidate (x, y) of node `own`, starting along `n` (see [`normal`]); at most
/// `max_len` pixels.
pub(crate) fn walk(
    f: &Fields,
    x: u32,
    y: u32,
    own: u32,
    n: [f32; 2],
    max_len: usize,
    pixels: &mut Vec<u32>,
) -> Result<Strip, WalkEnd> {
    walk_steered(f, (x, y), own, n, STEER, max_len, pixels)
}

/// A straight walk from candidate (x, y) of node `own` along `d`, never steered: the ray
/// traversal of the same walk, for the shortest-gap candidates ([`super::gaps`]), whose direction
/// is already the one wanted. At most `max_len` pixels.
pub(crate) fn walk_straight(
    f: &Fields,
    (x, y): (u32, u32),
    own: u32,
    d: [f32; 2],
    max_len: usize,
    pixels: &mut Vec<u32>,
) -> Result<Strip, WalkEnd> {
    walk_steered(f, (x, y), own, d, 0.0, max_len, pixels)
}

/// The walk, turned towards the field by `steer` at every step (0: a straight ray).
fn walk_steered(
    f: &Fields,
    (x, y): (u32, u32),
    own: u32,
    n: [f32; 2],
    steer: f32,
    max_len: usize,
    pixels: &mut Vec<u32>,
) -> Result<Strip, WalkEnd> {
    pixels.clear();
    let (cx, cy) = (x as i64, y as i64);
    let Some((mut px, mut py)) = first_pixel(f, (cx, cy), n) else {
        return Err(WalkEnd::NoStart);
    };
    // Heading: the normal, or the step to the first pixel if the normal points elsewhere.
    let mut d = n;
    if d[0] * (px - cx) as f32 + d[1] * (py - cy) as f32 <= 0.0 {
        d = [(px - cx) as f32, (py - cy) as f32];
    }
    let start = d;
    // Continuous position in pixel units: pixel (x, y) covers [x, x+1) × [y, y+1).
    let mut pos = [px as f32 + 0.5, py as f32 + 0.5];
    let w = f.width;
    let mut prev: Option<(i64, i64)> = Some((cx, cy));
    loop {
        pixels.push((py * w + px) as u32);
        if let Some((end, to)) = f.arrival(px, py, own) {
            let intensity = intensity(f.gray, pixels);
            return Ok(Strip {
                from: own,
                to,
                pixels: pixels.clone(),
                end,
                intensity,
            });
        }
        if pixels.len() >= max_len {
            return Err(WalkEnd::TooLong);
        }
        // The pixels still allowed, `max_len - len`, reach at most that far (4-connected steps),
        // and an arrival is one step beyond the last: farther material cannot end this walk.
        if f.reach
            .as_ref()
            .is_some_and(|r| r.bound(px, py, own) as usize > max_len - pixels.len() + 1)
        {
            return Err(WalkEnd::TooLong);
        }
        if let Some(g) = (steer > 0.0).then(|| f.field(px, py)).flatten() {
            d = steered(d, g, steer, start)?;
        }
        // Next pixel: where the ray leaves this one; never straight back to where it came from.
        let Some((nx, ny, npos)) = next_pixel(px, py, pos, d, prev) else {
            return Err(WalkEnd::Looped);
        };
        if f.material(nx, ny) {
            // Material of another node would have been caught as an arrival: this is our own.
            return Err(WalkEnd::Returned);
        }
        if f.blocked(nx, ny) {
            return Err(WalkEnd::Blocked);
        }
        let ni = (ny * w + nx) as u32;
        if revisits(pixels, ni) {
            return Err(WalkEnd::Looped);
        }
        prev = Some((px, py));
        (px, py, pos) = (nx, ny, npos);
    }
}

/// Whether `next`, an edge neighbour of the last of `pixels` (a 4-connected chain) other than
/// the one before it, is among the last [`LOOP_WINDOW`] of them. Every step changes x + y by
/// one, so only the pixels an odd number of steps back have `next`'s parity, and the one a single
/// step back is excluded: `next` can only be the pixel 3, 5 or 7 steps back. Three reads where
/// the plain scan of the window made eight, at every step of every walk.
#[inline]
fn revisits(pixels: &[u32], next: u32) -> bool {
    const _: () = assert!(LOOP_WINDOW == 8, "the odd offsets below cover the window");
    let n = pixels.len();
    (n >= 4 && pixels[n - 4] == next)
        || (n >= 6 && pixels[n - 6] == next)
        || (n >= 8 && pixels[n - 8] == next)
}

/// The walk's first pixel: the cut neighbour of the edge pixel `c` (4-connected, not forbidden)
/// most in line with the normal `n`.
fn first_pixel(f: &Fields, (cx, cy): (i64, i64), n: [f32; 2]) -> Option<(i64, i64)> {
    let mut best: Option<((i64, i64), f32)> = None;
    for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
        let (nx, ny) = (cx + dx, cy + dy);
        if !f.material(nx, ny) && !f.blocked(nx, ny) {
            let dot = n[0] * dx as f32 + n[1] * dy as f32;
            if best.is_none_or(|(_, b)| dot > b) {
                best = Some(((nx, ny), dot));
            }
        }
    }
    best.map(|(p, _)| p)
}

/// The heading `d` turned by `steer` towards the field direction `g` (oriented to agree with the
/// heading; a field at nearly right angles, under [`MIN_ALIGN`], does not steer). A walk turned
/// back past a right angle from its `start` heading would curl onto itself: it ends, looped.
#[inline]
fn steered(d: [f32; 2], g: [f32; 2], steer: f32, start: [f32; 2]) -> Result<[f32; 2], WalkEnd> {
    let dot = g[0] * d[0] + g[1] * d[1];
    if dot.abs() < MIN_ALIGN {
        return Ok(d);
    }
    let s = dot.signum() * steer;
    let nd = [d[0] + s * g[0], d[1] + s * g[1]];
    let m = (nd[0] * nd[0] + nd[1] * nd[1]).sqrt();
    let d = if m > 1e-6 { [nd[0] / m, nd[1] / m] } else { d };
    if d[0] * start[0] + d[1] * start[1] <= 0.0 {
        return Err(WalkEnd::Looped);
    }
    Ok(d)
}

/// One ray-traversal step from pixel (px, py) at continuous `pos` along `d`: the edge neighbour
/// the ray enters next and the crossing point. If that is `prev`, the component of `d` pointing
/// back is dropped and the other axis is taken.
fn next_pixel(
    px: i64,
    py: i64,
    pos: [f32; 2],
    d: [f32; 2],
    prev: Option<(i64, i64)>,
) -> Option<(i64, i64, [f32; 2])> {
    let step = |d: [f32; 2]| -> Option<(i64, i64, [f32; 2])> {
        let t = |p: f32, lo: i64, v: f32| -> f32 {
            if v > 1e-6 {
                ((lo + 1) as f32 - p) / v
            } else if v < -1e-6 {
                (lo as f32 - p) / v
            } else {
                f32::INFINITY
            }
        };
        let tx = t(pos[0], px, d[0]).max(0.0);
        let ty = t(pos[1], py, d[1]).max(0.0);
        if !tx.is_finite() && !ty.is_finite() {
            return None;
        }
        if tx <= ty {
            let sx = if d[0] > 0.0 { 1 } else { -1 };
            let nx = px + sx;
            let y = (pos[1] + d[1] * tx).clamp(py as f32, py as f32 + 0.999);
            let x = if sx > 0 { nx as f32 } else { px as f32 - 1e-4 };
            Some((nx, py, [x, y]))
        } else {
            let sy = if d[1] > 0.0 { 1 } else { -1 };
            let ny = py + sy;
            let x = (pos[0] + d[0] * ty).clamp(px as f32, px as f32 + 0.999);
            let y = if sy > 0 { ny as f32 } else { py as f32 - 1e-4 };
            Some((px, ny, [x, y]))
        }
    };
    let first = step(d)?;
    if Some((first.0, first.1)) != prev {
        return Some(first);
    }
    // Turned back: keep only the sideways component of the heading.
    let side = if first.0 != px {
        [0.0, d[1]]
    } else {
        [d[0], 0.0]
    };
    let r = step(side)?;
    (Some((r.0, r.1)) != prev).then_some(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bridge::candidates::collect;
    use crate::bridge::tests::{four_connected, random_picture, rng, two};
    use crate::islands::label;

    #[test]
    fn intensity_is_the_squared_distance_from_white() {
        let gray = Gray::from_data(4, 1, vec![0.0, 0.5, 1.0, 0.25]);
        let v = intensity(&gray, &[0, 1, 2, 3]);
        assert!((v - (1.0 + 0.25 + 0.0 + 0.5625)).abs() < 1e-9);
        assert_eq!(intensity(&gray, &[2]), 0.0);
    }

    #[test]
    fn walk_leaves_a_straight_edge_at_right_angles_and_lands_on_the_frame() {
        let t = two(&[
            "###############",
            "#.............#",
            "#.............#",
            "#.............#",
            "#....#####....#",
            "#....#####....#",
            "#....#####....#",
            "#.............#",
            "#.............#",
            "#.............#",
            "###############",
        ]);
        let m = label(&t.bits);
        let f = Fields::new(&t, &m);
        // Middle of the island's top edge: straight up to the frame, 3 pixels.
        let c = collect(&m);
        let s = walk_candidate(&f, &c, c.id_at(&m, 1, 7, 4).unwrap(), 50).unwrap();
        assert_eq!(s.to, FRAME);
        let w = t.bits.width;
        let xy: Vec<_> = s.pixels.iter().map(|&p| (p % w, p / w)).collect();
        assert_eq!(xy, vec![(7, 3), (7, 2), (7, 1)]);
        assert_eq!(s.end, (7, 0));
        assert!((s.intensity - 3.0).abs() < 1e-9);
    }

    #[test]
    fn strips_are_four_connected_even_on_diagonals() {
        // A diamond island: walks from its slanted edges run diagonally.
        let n = 41i64;
        let bits = BitGrid::from_fn(n as u32, n as u32, |x, y| {
            (x as i64 - 20).abs() + (y as i64 - 20).abs() <= 6
        });
        let gray = Gray::new(bits.width, bits.height, 0.0);
        let t = TwoTone {
            bits,
            gray: gray.into(),
        };
        let m = label(&t.bits);
        let f = Fields::new(&t, &m);
        let mut ok = 0;
        let c = collect(&m);
        for (id, &(x, y)) in c.pixels.iter().enumerate() {
            if let Ok(s) = walk_candidate(&f, &c, id, 100) {
                ok += 1;
                assert!(four_connected(&s.pixels, t.bits.width));
                // First pixel beside the candidate, end beside the last pixel.
                let p0 = s.pixels[0];
                assert_eq!((p0 % 41).abs_diff(x) + (p0 / 41).abs_diff(y), 1);
                let pl = *s.pixels.last().unwrap() as i64;
                assert_eq!((pl % 41 - s.end.0).abs() + (pl / 41 - s.end.1).abs(), 1);
                assert_eq!(s.to, FRAME);
            }
        }
        assert_eq!(ok, m.nodes[1].border.len());
    }

    /// Walks (steered and straight) give the same strips with [`Reach`] as without, on random
    /// pictures and length limits short and long.
    #[test]
    fn walks_with_reach_are_the_walks_without() {
        let mut next = rng(0x00c0_ffee_u64);
        let mut ok = 0;
        for k in 0..16u32 {
            let (w, h) = (60 + k * 13 % 70, 50 + k * 17 % 60);
            let t = random_picture(w, h, &mut next);
            let m = label(&t.bits);
            if m.island_count() == 0 {
                continue;
            }
            let c = collect(&m);
            let plain = Fields::new(&t, &m);
            for shift in [2, 3] {
                let fast = Fields {
                    reach: Some(Reach::build(&m, shift, false)),
                    ..Fields::new(&t, &m)
                };
                for max_len in [3usize, 9, 20, 60, 200] {
                    for id in 0..c.len() {
                        let a = walk_candidate(&plain, &c, id, max_len).ok();
                        let b = walk_candidate(&fast, &c, id, max_len).ok();
                        assert_eq!(a, b, "picture {k} candidate {id} limit {max_len}");
                        ok += a.is_some() as usize;
                        let ang = (next() % 6283) as f32 / 1000.0;
                        let d = [ang.cos(), ang.sin()];
                        let (x, y) = c.pixels[id];
                        let mut sa = Vec::new();
                        let sb = walk_straight(&fast, (x, y), c.node(id), d, max_len, &mut sa).ok();
                        let sp =
                            walk_straight(&plain, (x, y), c.node(id), d, max_len, &mut sa).ok();
                        assert_eq!(sp, sb, "picture {k} candidate {id} straight {d:?}");
                    }
                }
            }
        }
        assert!(ok > 100, "some walks arrive ({ok})");
    }

    /// [`revisits`] answers what the plain scan of the last [`LOOP_WINDOW`] pixels answers, for
    /// every step a walk can take (an edge neighbour other than the previous pixel) after random
    /// 4-connected chains of every length up to twice the window.
    #[test]
    fn revisits_is_the_window_scan() {
        let mut next = rng(0x0dd_0ff5e7_u64);
        let w = 64i64;
        let steps = [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)];
        let mut found = 0;
        for _ in 0..2000 {
            let (mut x, mut y) = (32i64, 32i64);
            let mut chain = vec![(y * w + x) as u32];
            let len = 1 + (next() % 16) as usize;
            while chain.len() < len {
                let (dx, dy) = steps[(next() % 4) as usize];
                let i = ((y + dy) * w + x + dx) as u32;
                if chain.len() >= 2 && chain[chain.len() - 2] == i {
                    continue;
                }
                (x, y) = (x + dx, y + dy);
                chain.push(i);
            }
            for (dx, dy) in steps {
                let ni = ((y + dy) * w + x + dx) as u32;
                if chain.len() >= 2 && chain[chain.len() - 2] == ni {
                    continue;
                }
                let plain = chain[chain.len().saturating_sub(LOOP_WINDOW)..].contains(&ni);
                assert_eq!(revisits(&chain, ni), plain, "{chain:?} then {ni}");
                found += plain as usize;
            }
        }
        assert!(found > 50, "some steps revisit ({found})");
    }

    #[test]
    fn walks_stop_on_another_island_not_their_own() {
        let t = two(&[
            "..........",
            "..........",
            "..##..##..",
            "..##..##..",
            "..........",
            "..........",
        ]);
        let m = label(&t.bits);
        assert_eq!(m.island_count(), 2);
        let f = Fields::new(&t, &m);
        // From the right edge of the left island straight into the right one.
        let c = collect(&m);
        let s = walk_candidate(&f, &c, c.id_at(&m, 1, 3, 2).unwrap(), 20).unwrap();
        assert_eq!(s.to, 2);
        assert_eq!(s.len(), 2);
    }
}
