//! Shortest-gap candidates: straight connections across the narrowest cut between two pieces.
//!
//! The paper's strips leave the border at right angles and follow the gradient, so where two
//! pieces come closest at a slant, or touch only at a corner, the short connection is often not
//! among the walks. These candidates offer it, from the same border pixels (twins of their chains,
//! [`Candidates::add_twins`]), costed the same way; the tree chooses between both kinds.
//!
//! Every border pixel of every piece is a *shore* (the frame adds points just beyond the image
//! beside cut pixels on its edge). From a border pixel, the nearest shore point of another piece
//! on its cut side ([`Shores::nearest_other`]) ends its shortest gap; pieces meeting at a corner
//! give a gap of one diagonal. Gaps are looked up from every [`SEED_STEP`]th candidate and every
//! corner pixel; other border pixels take the direction of the nearest gap within [`REACH`]
//! candidates, so a bridge can grow beside it. Each strip is then a straight walk
//! ([`strips::walk_straight`]), dropped if it runs back into its own piece or past the length
//! limit. Cost: shores sorted by row, a few rows read per lookup; no pass over the image.

use rayon::prelude::*;

use super::candidates::Candidates;
use super::reach::Reach;
use super::strips::{self, Fields, Strip};
use crate::islands::{IslandMap, FRAME};
use crate::raster::BitGrid;

/// How far along a contour, in candidates, a border pixel without a shortest gap of its own
/// borrows the direction of the nearest one. Wider than any bridge's strips on either side of
/// the gap it grows from (the widest bridges of the shipped materials are a few dozen pixels).
pub(crate) const REACH: usize = 48;

/// The shortest gap leaving one border pixel: its length (between pixel centres) and the other
/// end, in image pixel coordinates (may lie one pixel outside the image: the frame).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Gap {
    len: f32,
    to: (i32, i32),
}

/// Where a candidate's straight strip heads: a unit direction and the length of the shortest
/// gap it comes from (its own, or the one it borrowed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Heading {
    pub(crate) d: [f32; 2],
    pub(crate) gap: f32,
}

/// Shortest gaps are looked up from every this many candidates along a contour (and from every
/// pixel where two pieces meet at a corner); the others borrow the nearest one's heading. Gaps
/// change slowly along a contour, and neighbouring strips of one bridge should run parallel
/// anyway; looking them all up cost as much as all the walks.
pub(crate) const SEED_STEP: usize = 3;

/// For every candidate of the (original) chains, the heading of its straight strip, if it has
/// one: towards the other end of its own shortest gap, or borrowed from the nearest gap along its
/// contour within [`REACH`]. Gaps longer than `max_len` pixels are ignored.
pub(crate) fn directions(
    bits: &BitGrid,
    map: &IslandMap,
    cands: &Candidates,
    max_len: usize,
) -> Vec<Option<Heading>> {
    let n = cands.originals();
    let reach = Reach::chebyshev(map);
    let gaps = shortest_gaps(bits, map, cands, n, max_len as f32, Some(&reach));
    let own: Vec<Option<Heading>> = (0..n)
        .map(|id| {
            gaps[id].map(|g| {
                let (x, y) = cands.pixels[id];
                let d = [g.to.0 as f32 - x as f32, g.to.1 as f32 - y as f32];
                let m = (d[0] * d[0] + d[1] * d[1]).sqrt().max(1e-6);
                Heading {
                    d: [d[0] / m, d[1] / m],
                    gap: g.len,
                }
            })
        })
        .collect();
    borrow_along_chains(cands, &own, n)
}

/// For each place `k` of a chain `len` long (wrapping when `closed`), how many steps along it
/// the nearest place with a `value` is, and that value (`usize::MAX` and `None` if there is
/// none; the earlier one on a tie).
fn nearest_along<T: Copy>(
    len: usize,
    closed: bool,
    value: impl Fn(usize) -> Option<T>,
) -> Vec<(usize, Option<T>)> {
    let mut best = vec![(usize::MAX, None); len];
    let laps = if closed { 2 } else { 1 };
    for forward in [true, false] {
        let mut last: Option<(usize, T)> = None;
        for step in 0..laps * len {
            let k = if forward { step } else { laps * len - 1 - step } % len;
            if let Some(v) = value(k) {
                last = Some((step, v));
            }
            if let Some((s, v)) = last {
                if step - s < best[k].0 {
                    best[k] = (step - s, Some(v));
                }
            }
        }
    }
    best
}

/// Every candidate without a direction takes the one of the nearest candidate along its chain
/// that has one, within [`REACH`] (the earlier one on a tie), wrapping on closed chains.
fn borrow_along_chains(
    cands: &Candidates,
    own: &[Option<Heading>],
    n: usize,
) -> Vec<Option<Heading>> {
    let mut out = own.to_vec();
    for chain in cands.chains.iter().filter(|c| c.start < n) {
        let best = nearest_along(chain.len, chain.closed, |k| own[chain.start + k]);
        for (k, (dist, d)) in best.into_iter().enumerate() {
            if out[chain.start + k].is_none() && dist <= REACH {
                out[chain.start + k] = d;
            }
        }
    }
    out
}

/// Every piece's border pixels (material with a cut edge neighbour), row by row and sorted along
/// each row, with the frame beyond the image as points one step outside it beside cut pixels on
/// the image's edge: the shores of the cut, where every shortest gap starts and ends.
struct Shores {
    /// Row `y` (-1..=height) is `points[first[y + 1]..first[y + 2]]`.
    first: Vec<usize>,
    /// (x, node).
    points: Vec<(i32, u32)>,
    /// Where each row's points reach each column of [`BUCKET`] pixels: for row `y` and bucket
    /// `b`, `buckets[(y + 1) * per_row + b]` is the index within the row of its first point
    /// with `x + 1 >= b · BUCKET` (x from -1, the frame, on). A lookup's binary search then
    /// runs over one bucket's few points rather than the whole row: it was a fifth of
    /// [`Shores::nearest_other`]'s time, each step a dependent read.
    buckets: Vec<u32>,
    per_row: usize,
}

/// Width in pixels of [`Shores::buckets`]' columns.
const BUCKET: i32 = 16;

impl Shores {
    fn new(bits: &BitGrid, map: &IslandMap) -> Self {
        let (w, h) = (map.width as i32, map.height as i32);
        let cut = |x: i32, y: i32| !bits.data[(y * w + x) as usize];
        let mut outside: Vec<(i32, i32)> = Vec::new();
        for x in 0..w {
            for (y, out) in [(0, -1), (h - 1, h)] {
                if cut(x, y) {
                    outside.push((x, out));
                }
            }
        }
        for y in 0..h {
            for (x, out) in [(0, -1), (w - 1, w)] {
                if cut(x, y) {
                    outside.push((out, y));
                }
            }
        }
        let rows = (h + 2) as usize;
        let mut first = vec![0usize; rows + 1];
        for node in &map.nodes {
            for &(_, y) in &node.border {
                first[y as usize + 2] += 1;
            }
        }
        for &(_, y) in &outside {
            first[(y + 2) as usize] += 1;
        }
        for r in 0..rows {
            first[r + 1] += first[r];
        }
        let mut fill = first.clone();
        let mut points = vec![(0i32, 0u32); first[rows]];
        for (n, node) in map.nodes.iter().enumerate() {
            for &(x, y) in &node.border {
                let r = y as usize + 1;
                points[fill[r]] = (x as i32, n as u32);
                fill[r] += 1;
            }
        }
        for &(x, y) in &outside {
            let r = (y + 1) as usize;
            points[fill[r]] = (x, FRAME);
            fill[r] += 1;
        }
        // Each node's border comes in scan order, so a row is a few already sorted runs, which
        // the (stable, run-detecting) sort merges.
        let mut rest = points.as_mut_slice();
        let mut slices = Vec::with_capacity(rows);
        for r in 0..rows {
            let (row, tail) = rest.split_at_mut(first[r + 1] - first[r]);
            slices.push(row);
            rest = tail;
        }
        // Columns x + 1 = 0..=width + 1, and one bucket past the last.
        let per_row = (w as usize + 2).div_ceil(BUCKET as usize) + 1;
        let mut buckets = vec![0u32; rows * per_row];
        slices
            .into_par_iter()
            .zip(buckets.par_chunks_mut(per_row))
            .for_each(|(row, starts)| {
                row.sort();
                let mut k = 0;
                for (b, start) in starts.iter_mut().enumerate() {
                    while k < row.len() && row[k].0 + 1 < b as i32 * BUCKET {
                        k += 1;
                    }
                    *start = k as u32;
                }
            });
        Shores {
            first,
            points,
            buckets,
            per_row,
        }
    }

    /// The index within [`Shores::row`]`(y)` of its first point at `x` or to the right of it
    /// (the row's `partition_point(|p| p.0 < x)`), for any `x`: left of the image it is the
    /// first bucket's search, right of it the last one's.
    fn first_from(&self, y: i32, x: i32) -> usize {
        let row = self.row(y);
        if row.is_empty() {
            return 0;
        }
        let b = (x + 1).div_euclid(BUCKET).clamp(0, self.per_row as i32 - 2) as usize;
        let starts = &self.buckets[(y + 1) as usize * self.per_row..][..self.per_row];
        // Points before `lo` are left of the bucket, so left of x; points from `hi` on are in
        // later buckets, so right of x.
        let (lo, hi) = (starts[b] as usize, starts[b + 1] as usize);
        lo + row[lo..hi].partition_point(|&(px, _)| px < x)
    }

    fn row(&self, y: i32) -> &[(i32, u32)] {
        if y < -1 || (y + 2) as usize >= self.first.len() {
            return &[];
        }
        let r = (y + 1) as usize;
        &self.points[self.first[r]..self.first[r + 1]]
    }

    /// The nearest shore point of a node other than `own` to (x, y), nearer than `limit`, in the open
    /// half-plane the offset `side` points to (a point behind the pixel's own material is no gap).
    /// Each row is scanned outwards from `x` only over the columns that can lie on that side (at `dx`
    /// along, ahead when `dx · a > −c`), and a scan stops at the first point farther than the best, so
    /// it finds what scanning every point ([`Shores::nearest_other_every`], the tests' oracle) finds.
    fn nearest_other(
        &self,
        (x, y): (i32, i32),
        own: u32,
        side: (i32, i32),
        limit: f32,
    ) -> Option<Gap> {
        let mut best = limit * limit;
        let mut to = None;
        let scan = |yy: i32, dy2: f32, best: &mut f32, to: &mut Option<(i32, i32)>| {
            let row = self.row(yy);
            if row.is_empty() {
                return;
            }
            let c = (yy - y) * side.1;
            // Along a scan: ahead ⇔ dx · a > −c. Returns the least dx ahead and the first dx
            // past the ahead ones (`i32::MAX`: none), or `None` if no dx ≥ 0 is ahead.
            let span = |a: i32| -> Option<(i32, i32)> {
                match a.signum() {
                    0 => (c > 0).then_some((0, i32::MAX)),
                    1 => Some((if c > 0 { 0 } else { -c / a + 1 }, i32::MAX)),
                    _ => (c > 0).then(|| (0, (c + (-a) - 1) / (-a))),
                }
            };
            let k = self.first_from(yy, x);
            if let Some((lo, hi)) = span(side.0) {
                let start = if lo > 0 {
                    self.first_from(yy, x + lo)
                } else {
                    k
                };
                for &(px, n) in &row[start..] {
                    let dx = px - x;
                    let d2 = (dx as f32) * (dx as f32) + dy2;
                    if d2 >= *best || dx >= hi {
                        break;
                    }
                    if n != own {
                        *best = d2;
                        *to = Some((px, yy));
                    }
                }
            }
            if let Some((lo, hi)) = span(-side.0) {
                // Points left of x are at dx ≥ 1.
                let end = if lo > 1 {
                    self.first_from(yy, x - lo + 1)
                } else {
                    k
                };
                for &(px, n) in row[..end].iter().rev() {
                    let dx = x - px;
                    let d2 = (dx as f32) * (dx as f32) + dy2;
                    if d2 >= *best || dx >= hi {
                        break;
                    }
                    if n != own {
                        *best = d2;
                        *to = Some((px, yy));
                    }
                }
            }
        };
        scan(y, 0.0, &mut best, &mut to);
        let mut r = 1i32;
        while ((r * r) as f32) < best {
            let dy2 = (r * r) as f32;
            scan(y - r, dy2, &mut best, &mut to);
            scan(y + r, dy2, &mut best, &mut to);
            r += 1;
        }
        to.map(|to| Gap {
            len: best.sqrt(),
            to,
        })
    }

    /// [`Shores::nearest_other`] as it was, reading every point of each row out to the best
    /// distance: the oracle of its tests.
    #[cfg(test)]
    fn nearest_other_every(
        &self,
        (x, y): (i32, i32),
        own: u32,
        side: (i32, i32),
        limit: f32,
    ) -> Option<Gap> {
        let mut best = limit * limit;
        let mut to = None;
        let scan = |yy: i32, dy2: f32, best: &mut f32, to: &mut Option<(i32, i32)>| {
            let row = self.row(yy);
            let k = self.first_from(yy, x);
            let ahead = |px: i32| (px - x) * side.0 + (yy - y) * side.1 > 0;
            for &(px, n) in &row[k..] {
                let dx = (px - x) as f32;
                if dx * dx + dy2 >= *best {
                    break;
                }
                if n != own && ahead(px) {
                    *best = dx * dx + dy2;
                    *to = Some((px, yy));
                }
            }
            for &(px, n) in row[..k].iter().rev() {
                let dx = (x - px) as f32;
                if dx * dx + dy2 >= *best {
                    break;
                }
                if n != own && ahead(px) {
                    *best = dx * dx + dy2;
                    *to = Some((px, yy));
                }
            }
        };
        scan(y, 0.0, &mut best, &mut to);
        let mut r = 1i32;
        while ((r * r) as f32) < best {
            let dy2 = (r * r) as f32;
            scan(y - r, dy2, &mut best, &mut to);
            scan(y + r, dy2, &mut best, &mut to);
            r += 1;
        }
        to.map(|to| Gap {
            len: best.sqrt(),
            to,
        })
    }
}

/// The shortest gap starting on each of the first `n` candidates (see the module doc): its
/// nearest shore point of another piece, if nearer than `max_len`. With `reach` (of `map`, by
/// [`Reach::chebyshev`]), a pixel whose every other shore is provably `max_len` or farther is
/// answered without a search: such a search reads every row `max_len` up and down, twice when
/// the previous gap's hint fails first, and finds nothing.
fn shortest_gaps(
    bits: &BitGrid,
    map: &IslandMap,
    cands: &Candidates,
    n: usize,
    max_len: f32,
    reach: Option<&Reach>,
) -> Vec<Option<Gap>> {
    let shores = Shores::new(bits, map);
    let (w, h) = (map.width as i32, map.height as i32);
    let cut =
        |x: i32, y: i32| x >= 0 && y >= 0 && x < w && y < h && !bits.data[(y * w + x) as usize];
    let lookup = |id: usize, hint: Option<(i32, i32)>| -> Option<Gap> {
        let (x, y) = cands.pixels[id];
        let (x, y) = (x as i32, y as i32);
        let node = cands.node(id);
        let material =
            |x: i32, y: i32| x < 0 || y < 0 || x >= w || y >= h || bits.data[(y * w + x) as usize];
        // A corner where another piece meets this one diagonally is always looked up.
        let corner = [(1, 1), (1, -1), (-1, 1), (-1, -1)]
            .iter()
            .any(|&(dx, dy)| {
                material(x + dx, y + dy)
                    && !material(x + dx, y)
                    && !material(x, y + dy)
                    && (x + dx) >= 0
                    && (y + dy) >= 0
                    && (x + dx) < w
                    && (y + dy) < h
                    && map.labels[((y + dy) * w + x + dx) as usize] != node
            });
        if !cands.pos(id).is_multiple_of(SEED_STEP) && !corner {
            return None;
        }
        // Every other shore at a Chebyshev distance of `max_len` or more is at least as far in
        // Euclid's: none is nearer than the limit.
        if reach.is_some_and(|r| r.bound(x as i64, y as i64, node) as f32 >= max_len) {
            return None;
        }
        // Towards its cut edge neighbours (a one-pixel line may have them on both sides, then
        // either side will do).
        let mut side = (0, 0);
        for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            if cut(x + dx, y + dy) {
                side = (side.0 + dx, side.1 + dy);
            }
        }
        let sides: &[(i32, i32)] = if side == (0, 0) {
            &[(1, 0), (-1, 0), (0, 1), (0, -1)]
        } else {
            std::slice::from_ref(&side)
        };
        sides.iter().find_map(|&s| {
            // The previous gap's far end bounds the search, which then stops rows early (the
            // nearest shore moves little from one border pixel to the next); without it, or if
            // it is not on this pixel's side, the length limit does.
            hint.map(|(bx, by)| ((bx - x) as f32).hypot((by - y) as f32) + 0.01)
                .filter(|&d| d < max_len)
                .and_then(|d| shores.nearest_other((x, y), node, s, d))
                .or_else(|| shores.nearest_other((x, y), node, s, max_len))
        })
    };
    // Chain by chain (in parallel), in order along each, so each lookup starts from the last.
    let per_chain: Vec<Vec<(usize, Gap)>> = cands
        .chains
        .par_iter()
        .filter(|c| c.start < n)
        .map(|c| {
            let mut out = Vec::new();
            let mut hint = None;
            for id in c.start..c.start + c.len {
                if let Some(g) = lookup(id, hint) {
                    hint = Some(g.to);
                    out.push((id, g));
                }
            }
            out
        })
        .collect();
    let mut best = vec![None; n];
    for (id, g) in per_chain.into_iter().flatten() {
        best[id] = Some(g);
    }
    best
}

/// The straight strip of every twin candidate (ids `cands.twins`), in parallel: a straight walk
/// along its heading ([`directions`]), at most `max_len` pixels. Where the original's walk is no
/// longer, the twin copies it and is marked in the second vector (not scored on its own, but its
/// chain stays whole for its neighbours' windows and growth).
pub(crate) fn walk_twins(
    fields: &Fields,
    cands: &Candidates,
    heads: &[Option<Heading>],
    walks: &[Option<Strip>],
    max_len: usize,
    keep: usize,
) -> (Vec<Option<Strip>>, Vec<bool>) {
    let (mut strips, copies): (Vec<Option<Strip>>, Vec<bool>) = (cands.twins.0..cands.twins.1)
        .into_par_iter()
        .with_min_len(256)
        .map_init(Vec::new, |scratch, id| {
            let base = cands.base(id);
            let Some(h) = heads.get(base).copied().flatten() else {
                return (None, false);
            };
            let straight = h.gap * (h.d[0].abs() + h.d[1].abs());
            if let Some(w) = walks.get(base).and_then(|w| w.as_ref()) {
                if w.len() as f32 <= straight {
                    return (Some(w.clone()), true);
                }
            }
            let s = strips::walk_straight(
                fields,
                cands.pixels[id],
                cands.node(id),
                h.d,
                max_len,
                scratch,
            );
            (s.ok(), false)
        })
        .unzip();
    // Copies matter only to the windows and growth of the twins that walked, at most
    // `keep` candidates away along the contour; farther ones are dropped (on round islands in
    // flat gray, walks already run straight across, and copying them all cost more allocations
    // than the new walks).
    let t0 = cands.twins.0;
    for chain in cands
        .chains
        .iter()
        .filter(|c| c.start >= t0 && c.start < cands.twins.1)
    {
        let range = chain.start - t0..chain.start - t0 + chain.len;
        let walked: Vec<bool> = range
            .clone()
            .map(|k| strips[k].is_some() && !copies[k])
            .collect();
        let dist = nearest_along(chain.len, chain.closed, |k| walked[k].then_some(()));
        for (k, (d, _)) in range.zip(dist) {
            if copies[k] && d > keep {
                strips[k] = None;
            }
        }
    }
    (strips, copies)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::islands::label;
    use crate::raster::BitGrid;
    use crate::test_rng::Lcg;

    /// [`Shores::first_from`] is the binary search over the whole row, for every row (the
    /// frame's included) and every column from two left of the image to two right of it, on
    /// random pictures of several widths (the last bucket part full or full).
    #[test]
    fn first_from_is_the_rows_partition_point() {
        let mut rng = Lcg(0x9e37_79b9_7f4a_7c15);
        let mut next = move || rng.next_u64() >> 33;
        for k in 0..24u32 {
            let (w, h) = (1 + k * 7 % 70, 1 + k * 5 % 40);
            let fill = next() % 60;
            let bits = BitGrid::from_fn(w, h, |_, _| next() % 100 < fill);
            let m = label(&bits);
            let shores = Shores::new(&bits, &m);
            for y in -3..h as i32 + 3 {
                let row = shores.row(y);
                for x in -2..w as i32 + 2 {
                    let plain = row.partition_point(|&(px, _)| px < x);
                    assert_eq!(shores.first_from(y, x), plain, "picture {k} ({x}, {y})");
                }
            }
        }
    }

    /// [`Shores::nearest_other`], reading only the columns ahead of the pixel, finds what the
    /// scan of every point finds (length and far end), from every pixel of random pictures (the
    /// frame's too), towards every side a pixel's cut neighbours can point to, under several
    /// limits and for several owners.
    #[test]
    fn nearest_other_is_the_scan_of_every_point() {
        let mut rng = Lcg(0x05ee_d0f9_a95e);
        let mut next = move || rng.next_u64() >> 33;
        let mut found = 0;
        for k in 0..30u32 {
            let (w, h) = (5 + k * 11 % 57, 4 + k * 7 % 41);
            let fill = 5 + next() % 50;
            let bits = BitGrid::from_fn(w, h, |_, _| next() % 100 < fill);
            let m = label(&bits);
            let shores = Shores::new(&bits, &m);
            let owners = m.nodes.len() as u32 + 1;
            for y in -1..=h as i32 {
                for x in -1..=w as i32 {
                    for sx in -1..=1 {
                        for sy in -1..=1 {
                            if (sx, sy) == (0, 0) {
                                continue;
                            }
                            let own = (next() % owners as u64) as u32;
                            let limit = [1.0f32, 2.5, 7.0, 60.0][(next() % 4) as usize];
                            let want = shores.nearest_other_every((x, y), own, (sx, sy), limit);
                            let got = shores.nearest_other((x, y), own, (sx, sy), limit);
                            assert_eq!(got, want, "picture {k} ({x}, {y}) side ({sx}, {sy})");
                            found += want.is_some() as usize;
                        }
                    }
                }
            }
        }
        assert!(found > 1000, "gaps are found ({found})");
    }

    /// The twins' straight strips over a flat white picture of `g` (no walks to copy).
    fn twin_strips(
        g: &BitGrid,
        m: &IslandMap,
        c: &mut Candidates,
        dirs: &[Option<Heading>],
    ) -> Vec<Option<Strip>> {
        c.add_twins();
        let two = crate::raster::TwoTone {
            bits: g.clone(),
            gray: crate::raster::Gray::new(g.width, g.height, 1.0).into(),
        };
        let f = Fields::new(&two, m);
        walk_twins(&f, c, dirs, &[], 50, 10).0
    }

    #[test]
    fn a_gap_runs_to_the_nearest_piece_not_along_the_normal() {
        // Two pieces closest along a diagonal: an island and a block of the frame.
        let g = BitGrid::from_rows(&[
            "##########",
            "#.........",
            "#.........",
            "#.........",
            "#.........",
            "#.....##..",
            "#.....##..",
            "#.........",
            "#.........",
            "##########",
        ]);
        let m = label(&g);
        let mut c = super::super::candidates::collect(&m);
        let dirs = directions(&g, &m, &c, 50);
        // The island's top-left pixel is closest to the frame's top row (5 px; the left column
        // is 6): straight up, not along its normal.
        let id = c.id_at(&m, 1, 6, 5).unwrap();
        let d = dirs[id].unwrap().d;
        assert!(d[1] < -0.99, "{d:?}");
        let s = twin_strips(&g, &m, &mut c, &dirs);
        let strip = s[id].as_ref().unwrap();
        assert_eq!(strip.to, FRAME);
        assert_eq!(strip.len(), 4, "pixels y = 4..=1 of column 6");
    }

    #[test]
    fn nearest_shore_matches_a_brute_force_search() {
        let mut rng = Lcg(99);
        for round in 0..20 {
            let (w, h) = (17 + round % 5, 13 + round % 4);
            let g = BitGrid::from_fn(w, h, |_, _| rng.below(4) == 0);
            let m = label(&g);
            let shores = Shores::new(&g, &m);
            // Every shore point: border pixels of all nodes, and the frame one step outside
            // beside cut pixels on the edge.
            let mut all: Vec<(i32, i32, u32)> = Vec::new();
            for (n, node) in m.nodes.iter().enumerate() {
                all.extend(
                    node.border
                        .iter()
                        .map(|&(x, y)| (x as i32, y as i32, n as u32)),
                );
            }
            let (wi, hi) = (w as i32, h as i32);
            for y in -1..=hi {
                for x in -1..=wi {
                    let outside = x < 0 || y < 0 || x >= wi || y >= hi;
                    let beside_cut = [(1, 0), (-1, 0), (0, 1), (0, -1)].iter().any(|&(dx, dy)| {
                        let (u, v) = (x + dx, y + dy);
                        u >= 0 && v >= 0 && u < wi && v < hi && !g.get(u as u32, v as u32)
                    });
                    if outside && beside_cut {
                        all.push((x, y, FRAME));
                    }
                }
            }
            for (n, node) in m.nodes.iter().enumerate().skip(1) {
                for &(x, y) in &node.border {
                    let (x, y) = (x as i32, y as i32);
                    for side in [(1, 0), (0, -1), (-1, 1)] {
                        let want = all
                            .iter()
                            .filter(|p| p.2 != n as u32)
                            .filter(|p| (p.0 - x) * side.0 + (p.1 - y) * side.1 > 0)
                            .map(|p| (((p.0 - x).pow(2) + (p.1 - y).pow(2)) as f32).sqrt())
                            .filter(|&d| d < 9.0)
                            .fold(f32::INFINITY, f32::min);
                        let got = shores.nearest_other((x, y), n as u32, side, 9.0);
                        assert_eq!(got.map_or(f32::INFINITY, |g| g.len), want, "({x}, {y})");
                    }
                }
            }
        }
    }

    /// The gaps found with [`Reach`] answering the far pixels are the gaps searched for every
    /// pixel, on random pictures of specks and blobs, with short and long limits.
    #[test]
    fn shortest_gaps_with_reach_are_the_searched_ones() {
        let mut rng = Lcg(0x0123_4567_89ab_cdef);
        let mut next = move || rng.next_u64() >> 33;
        let mut found = 0;
        for k in 0..14u32 {
            let (w, h) = (50 + k * 13 % 61, 40 + k * 7 % 53);
            let centres: Vec<(i64, i64, i64)> = (0..(3 + k % 9))
                .map(|_| {
                    (
                        (next() % w as u64) as i64,
                        (next() % h as u64) as i64,
                        (next() % 6) as i64,
                    )
                })
                .collect();
            let g = BitGrid::from_fn(w, h, |x, y| {
                centres
                    .iter()
                    .any(|&(cx, cy, r)| (x as i64 - cx).pow(2) + (y as i64 - cy).pow(2) <= r * r)
            });
            let m = label(&g);
            let c = super::super::candidates::collect(&m);
            let n = c.originals();
            let reach = Reach::chebyshev(&m);
            for max_len in [4.0f32, 11.0, 30.0, 200.0] {
                let plain = shortest_gaps(&g, &m, &c, n, max_len, None);
                let fast = shortest_gaps(&g, &m, &c, n, max_len, Some(&reach));
                assert_eq!(plain, fast, "picture {k} limit {max_len}");
                found += plain.iter().flatten().count();
            }
        }
        assert!(found > 50, "some gaps are found ({found})");
    }

    #[test]
    fn pieces_touching_at_a_corner_get_a_one_pixel_patch() {
        let g = BitGrid::from_rows(&[
            "..........",
            "..........",
            "..###.....",
            "..###.....",
            "..###.....",
            ".....###..",
            ".....###..",
            ".....###..",
            "..........",
            "..........",
        ]);
        let m = label(&g);
        assert_eq!(m.island_count(), 2);
        let mut c = super::super::candidates::collect(&m);
        let dirs = directions(&g, &m, &c, 50);
        let a = m.labels[4 * 10 + 4];
        let id = c.id_at(&m, a, 4, 4).unwrap();
        let s = twin_strips(&g, &m, &mut c, &dirs);
        let strip = s[id].as_ref().unwrap();
        assert_eq!(strip.len(), 1);
        assert_eq!(strip.to, m.labels[5 * 10 + 5]);
    }
}
