//! Bridge or drop, by least change.
//!
//! An island is either bridged (material laid over cut) or dropped (its material becomes cut),
//! whichever changes the picture less, priced as the regularisation prices a flipped pixel,
//! `0.1 + |gray − threshold|`: dropping costs the sum over its pixels; the cheapest bridge costs
//! the sum over the cut pixels of the cheapest 4-connected path to other material, times the width
//! the bridge stage would give it (`⌈√A / 4⌉` px within the material's bridge widths). So a 1 mm²
//! highlight is dropped rather than held by a 13 mm bridge; a face is always bridged. The path
//! search (Dijkstra from the border) stops when its cost reaches the drop's, and gives up (keeping
//! the island) after `SEARCH_PER_AREA` × A + `SEARCH_BASE` pixels. Islands with a `--bridge-at`
//! are never dropped.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::islands::{IslandMap, CUT, FRAME};
use crate::raster::Gray;

/// The search for an island's cheapest bridge visits at most this many pixels per island pixel,
/// plus [`SEARCH_BASE`].
pub(crate) const SEARCH_PER_AREA: usize = 16;
pub(crate) const SEARCH_BASE: usize = 20_000;

/// One island dropped instead of bridged.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Dropped {
    /// Its centre (mean of its pixels), mm from the picture's top left corner (pixels until the
    /// pipeline scales it).
    pub at_mm: [f64; 2],
    /// Its area, mm² (px² until the pipeline scales it).
    pub area_mm2: f64,
    /// What dropping it changes, and what its cheapest bridge would (None: more than the drop,
    /// the search stopped there), in pixel-costs (`0.1 + |gray − threshold|` summed).
    pub(crate) drop_cost: f64,
    pub(crate) bridge_cost: Option<f64>,
}

/// The islands to drop (node ids of `map`) and their reports (in pixels: `at_mm` holds pixel
/// coordinates, `area_mm2` the pixel count, for the caller to scale). `protected[n]`: never drop
/// island n. `width(area)`: the bridge's width in pixels for an island of `area` pixels.
pub(crate) fn choose(
    map: &IslandMap,
    gray: &Gray,
    level: u8,
    protected: &[bool],
    width: impl Fn(usize) -> u32 + Sync,
) -> Vec<(u32, Dropped)> {
    let n = map.nodes.len();
    if n <= 1 {
        return Vec::new();
    }
    let t = level as f32 / 255.0;
    let price = |i: usize| 0.1 + (gray.data[i] - t).abs() as f64;
    let w = map.width as usize;
    // An island's drop cost and the sums for its centre, over its runs in scan order: the same
    // sums in the same order as a pass over the picture, but over its own pixels only, and in
    // its search's job (in parallel). Two full passes over the picture's labels were a fifth of
    // this function's time on the 1 MP photo, whose islands hold about 6 % of its pixels.
    let sums = |island: usize| {
        let (mut cost, mut sx, mut sy) = (0f64, 0f64, 0f64);
        for (y, x0, x1) in map.island_runs(island) {
            let row = y as usize * w;
            for x in x0 as usize..=x1 as usize {
                cost += price(row + x);
                sx += x as f64 + 0.5;
                sy += y as f64 + 0.5;
            }
        }
        (cost, sx, sy)
    };
    // Each island's search is independent of the others': they run in parallel. A search's
    // distances live in a scratch grid over what it can reach ([`Window`]): a stamp and a
    // distance per pixel, side by side (one cache line per visit), stamped per search so it is
    // never cleared. The grids are lent out from a pool ([`POOL`], which outlives the call), so
    // there are at most as many as searches running at once, not one per piece of work rayon
    // splits off.
    let pool = &POOL;
    let search = |island: usize| {
        if protected.get(island).copied().unwrap_or(false) {
            return None;
        }
        let mut s = pool
            .lock()
            .map(|mut p| p.pop())
            .ok()
            .flatten()
            .unwrap_or_default();
        let (limit, sx, sy) = sums(island);
        let out = search_one(map, &mut s, island, limit, &price, &width);
        if let Ok(mut p) = pool.lock() {
            if p.len() < KEPT_GRIDS {
                p.push(s);
            }
        }
        let (limit, bridge) = out?;
        let a = map.nodes[island].area as f64;
        Some((
            island as u32,
            Dropped {
                at_mm: [sx / a, sy / a],
                area_mm2: a,
                drop_cost: limit,
                bridge_cost: bridge,
            },
        ))
    };
    // One island per job: a photo has a few dozen islands whose searches take from 0.04 to 2 ms,
    // and runs of eight left one thread with most of them.
    (1..n)
        .into_par_iter()
        .with_min_len(1)
        .filter_map(search)
        .collect()
}

/// What keeping an island costs the sheet beyond its bridge's change to the picture, in the
/// same pixel-costs as a drop (`0.1 + |gray − threshold|` summed over pixels): a layered set's
/// sheets are lifted, sprayed and cleaned, and every bridge, every millimetre cut and every
/// island hanging on another island makes a sheet harder to handle, even where a later layer
/// paints over the bridge (see [`choose_for_sheet`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SheetCost {
    /// One bridge: a place the sheet bends and tears, and a joint to clean.
    pub(crate) per_bridge: f64,
    /// One border pixel of the island: the cut around it (the knife's or the beam's path).
    pub(crate) per_border_px: f64,
    /// Holding on another island rather than on the frame: one more link of a chain (see the
    /// chains in `bridge::tree`).
    pub(crate) per_hop: f64,
}

/// The islands a sheet of a layered set drops (node ids of `map`), with their reports in pixels
/// (as [`choose`]'s): an island stays when its cheapest bridge, priced by `bridge_price` per cut
/// pixel times its width (`width(area)`), plus what keeping it costs the sheet (`sheet`: a bridge,
/// its border's cut, and a hop when the bridge ends on another island rather than the frame),
/// costs less than dropping it, priced by `drop_price` per island pixel. The search is
/// [`choose`]'s (Dijkstra through the cut, bounded by the drop's cost and by
/// [`SEARCH_PER_AREA`] × A + [`SEARCH_BASE`] pixels, giving up by keeping the island), but it
/// goes on past other islands to find the frame when the hop makes an island dearer.
pub(crate) fn choose_for_sheet(
    map: &IslandMap,
    drop_price: &(dyn Fn(usize) -> f64 + Sync),
    bridge_price: &(dyn Fn(usize) -> f64 + Sync),
    sheet: SheetCost,
    width: &(dyn Fn(usize) -> u32 + Sync),
) -> Vec<(u32, Dropped)> {
    let n = map.nodes.len();
    let w = map.width as usize;
    let one = |island: usize| {
        let node = &map.nodes[island];
        let (mut cost, mut sx, mut sy) = (0f64, 0f64, 0f64);
        for (y, x0, x1) in map.island_runs(island) {
            let row = y as usize * w;
            for x in x0 as usize..=x1 as usize {
                cost += drop_price(row + x);
                sx += x as f64 + 0.5;
                sy += y as f64 + 0.5;
            }
        }
        let fixed = sheet.per_bridge + sheet.per_border_px * node.border.len() as f64;
        let bridge = sheet_search(
            map,
            island,
            cost - fixed,
            bridge_price,
            sheet.per_hop,
            width,
        );
        let kept = match bridge {
            Search::GaveUp | Search::Under => true,
            Search::Found(b) => b + fixed < cost,
            Search::Over => false,
        };
        let a = node.area as f64;
        (!kept).then(|| {
            (
                island as u32,
                Dropped {
                    at_mm: [sx / a, sy / a],
                    area_mm2: a,
                    drop_cost: cost,
                    bridge_cost: match bridge {
                        Search::Found(b) => Some(b + fixed),
                        _ => None,
                    },
                },
            )
        })
    };
    (1..n)
        .into_par_iter()
        .with_min_len(1)
        .filter_map(one)
        .collect()
}

/// What [`sheet_search`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Search {
    /// The cheapest way to the frame or to another island (with its hop), under the limit.
    Found(f64),
    /// None under the limit.
    Over,
    /// One under the limit, found by a straight path (its cost not known).
    Under,
    /// The search ran out of pixels before it knew.
    GaveUp,
}

/// The most pixels [`sheet_search`] visits for one island (its distances are in a map, a few
/// dozen bytes a pixel): past this it keeps the island, as [`choose`] does past its budget.
const SHEET_SEARCH_MAX: usize = 200_000;

/// [`choose_for_sheet`]'s search for one island: Dijkstra from its border through the cut, a
/// pixel costing `price × width`, ending at the image's edge or the frame, or at another island
/// for `hop` more (and going on, in case the frame is cheaper), stopped at `limit`. Distances in
/// a map, not a grid: a covered pixel costs as little as a twentieth of a visible one, so the
/// search may reach far, but it visits at most its budget, and at most [`SHEET_SEARCH_MAX`].
fn sheet_search(
    map: &IslandMap,
    island: usize,
    limit: f64,
    price: &(dyn Fn(usize) -> f64 + Sync),
    hop: f64,
    width: &(dyn Fn(usize) -> u32 + Sync),
) -> Search {
    if limit <= 0.0 {
        return Search::Over;
    }
    let (w, h) = (map.width as usize, map.height as usize);
    let node = &map.nodes[island];
    let bw = width(node.area).max(1) as f64;
    // A straight path to any material, hop and all, under the limit keeps the island: most
    // large ones, without a search.
    if straight_under(map, island, limit - hop, bw, price) {
        return Search::Under;
    }
    let budget = (SEARCH_PER_AREA * node.area + SEARCH_BASE).min(SHEET_SEARCH_MAX);
    let me = island as u32;
    let mut dist: std::collections::HashMap<usize, f64> = std::collections::HashMap::new();
    let mut heap: Heap = BinaryHeap::new();
    let mut relax = |heap: &mut Heap, j: usize, c: f64| {
        if c < limit && dist.get(&j).is_none_or(|&d| c < d) {
            dist.insert(j, c);
            heap.push(Reverse((c.to_bits(), j as u32)));
        }
    };
    for &(x, y) in &node.border {
        for (nx, ny) in neighbours(x as usize, y as usize, w, h) {
            let j = ny * w + nx;
            if map.labels[j] == CUT {
                relax(&mut heap, j, price(j) * bw);
            }
        }
    }
    let mut best = f64::INFINITY;
    let mut visited = 0usize;
    let mut settled = std::collections::HashSet::new();
    while let Some(Reverse((bits, i))) = heap.pop() {
        let (c, i) = (f64::from_bits(bits), i as usize);
        if c >= best.min(limit) {
            break;
        }
        if !settled.insert(i) {
            continue;
        }
        visited += 1;
        if visited > budget {
            return Search::GaveUp;
        }
        let (x, y) = (i % w, i / w);
        if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
            best = best.min(c);
            continue;
        }
        for (nx, ny) in neighbours(x, y, w, h) {
            let j = ny * w + nx;
            match map.labels[j] {
                CUT => relax(&mut heap, j, c + price(j) * bw),
                l if l == me => {}
                FRAME => best = best.min(c),
                _ => best = best.min(c + hop),
            }
        }
    }
    if best < limit {
        Search::Found(best)
    } else {
        Search::Over
    }
}

/// The scratch grids [`choose`] lends its searches, kept from one call to the next (a studio
/// re-runs it on every threshold change), at most [`KEPT_GRIDS`] of them.
static POOL: std::sync::Mutex<Vec<Scratch>> = std::sync::Mutex::new(Vec::new());

/// How many scratch grids [`POOL`] keeps between calls (16 bytes per pixel of a window each):
/// as many as searches run at once on a small machine; on a larger one the others are made per
/// call.
const KEPT_GRIDS: usize = 2;

/// A search's scratch grid and the stamp of the search using it. Per pixel, `[stamp, distance
/// bits]`: the distance counts only where the stamp is the search's. Zeros (no search yet), so
/// the grid comes zeroed from the allocator rather than written.
#[derive(Default)]
struct Scratch {
    cells: Vec<[u64; 2]>,
    stamp: u64,
}

/// The search's heap: (cost bits, pixel), least first.
type Heap = BinaryHeap<Reverse<(u64, u32)>>;

/// The search of [`choose`] for one island: `Some((drop cost, bridge cost))` when dropping it is
/// cheaper, `None` when it stays (a bridge as cheap, or the search gave up). Dijkstra over the cut;
/// a heap entry is the cost's bits above the pixel index (a finite non-negative `f64`'s bits order
/// as the number). Entries at or over the drop's cost are not pushed: the search would stop there.
fn search_one(
    map: &IslandMap,
    s: &mut Scratch,
    island: usize,
    limit: f64,
    price: &impl Fn(usize) -> f64,
    width: &impl Fn(usize) -> u32,
) -> Option<(f64, Option<f64>)> {
    let (w, h) = (map.width as usize, map.height as usize);
    let node = &map.nodes[island];
    let bw = width(node.area).max(1) as f64;
    let budget = SEARCH_PER_AREA * node.area + SEARCH_BASE;
    let mut heap: Heap = BinaryHeap::new();
    let me = island as u32;
    if straight_under(map, island, limit, bw, price) {
        return None;
    }
    let (win, cells) = Window::new(map, &node.border, limit, bw);
    if s.cells.len() < cells {
        s.cells = vec![[0; 2]; cells];
    }
    s.stamp += 1;
    if bridged_under(map, s, &win, island, limit, bw, price) {
        return None;
    }
    s.stamp += 1;
    let stamp = s.stamp;
    let cells = &mut s.cells[..];
    // A cost `c` for pixel `j` (`lj` in the window): kept if it is the first or lower, pushed if
    // under the limit.
    let relax = |cells: &mut [[u64; 2]], heap: &mut Heap, j: usize, lj: usize, c| {
        let cell = &mut cells[lj];
        if cell[0] != stamp || c < f64::from_bits(cell[1]) {
            *cell = [stamp, f64::to_bits(c)];
            if c < limit {
                heap.push(Reverse((f64::to_bits(c), j as u32)));
            }
        }
    };
    // Seeds: the cut 4-neighbours of the island's border pixels.
    for &(x, y) in &node.border {
        for (nx, ny) in neighbours(x as usize, y as usize, w, h) {
            let j = ny * w + nx;
            if map.labels[j] == CUT {
                relax(cells, &mut heap, j, win.at(nx, ny), price(j) * bw);
            }
        }
    }
    let mut visited = 0usize;
    let mut bridge: Option<f64> = None;
    let mut gave_up = false;
    while let Some(Reverse((bits, i))) = heap.pop() {
        let (c, i) = (f64::from_bits(bits), i as usize);
        let (x, y) = (i % w, i / w);
        let li = win.at(x, y);
        if c > f64::from_bits(cells[li][1]) {
            continue;
        }
        visited += 1;
        if visited > budget {
            gave_up = true;
            break;
        }
        // Reaching the image's edge reaches the sheet beyond it (the search ends here, so what
        // the pixel's neighbours would cost is never read).
        if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
            bridge = Some(c);
            break;
        }
        let mut reached = false;
        let lw = win.2;
        for (j, lj) in [
            (i - 1, li - 1),
            (i + 1, li + 1),
            (i - w, li - lw),
            (i + w, li + lw),
        ] {
            let l = map.labels[j];
            if l == CUT {
                relax(cells, &mut heap, j, lj, c + price(j) * bw);
            } else if l != me {
                reached = true;
            }
        }
        if reached {
            bridge = Some(c);
            break;
        }
    }
    if gave_up || bridge.is_some_and(|b| b <= limit) {
        return None;
    }
    Some((limit, bridge))
}

/// Whether some path through the cut from the island to a place the search of [`search_one`] ends
/// at costs less than `limit`, found breadth first (no heap); then that search keeps the island
/// too, since its own cost along the path can only be lower. `false` says nothing: the search
/// runs. Most islands are kept and near another piece, so this answers them in a few rings of
/// pixels. Uses the scratch grid as `[stamp, previous pixel]`.
fn bridged_under(
    map: &IslandMap,
    s: &mut Scratch,
    win: &Window,
    island: usize,
    limit: f64,
    bw: f64,
    price: &impl Fn(usize) -> f64,
) -> bool {
    const SEED: u64 = u64::MAX;
    let (w, h) = (map.width as usize, map.height as usize);
    let me = island as u32;
    let stamp = s.stamp;
    let cells = &mut s.cells[..];
    // A ring holds its pixels' coordinates (no division per pixel to find them).
    let mut ring: Vec<(u32, u32)> = Vec::new();
    for &(x, y) in &map.nodes[island].border {
        for (nx, ny) in neighbours(x as usize, y as usize, w, h) {
            let j = ny * w + nx;
            let lj = win.at(nx, ny);
            if map.labels[j] == CUT && cells[lj][0] != stamp {
                cells[lj] = [stamp, SEED];
                ring.push((nx as u32, ny as u32));
            }
        }
    }
    // Each pixel costs at least 0.1 × the width: no longer path can be under the limit.
    let longest = (limit / (0.1 * bw)).ceil() + 1.0;
    let mut next = Vec::new();
    let mut pixels = 1.0;
    while !ring.is_empty() && pixels <= longest {
        for &(x, y) in &ring {
            let (x, y) = (x as usize, y as usize);
            let i = y * w + x;
            // A pixel on the image's edge is an end: the path to it is the answer, whatever
            // its neighbours (which the first form marked before answering: marks that no
            // path already found passes through).
            let mut end = x == 0 || y == 0 || x + 1 == w || y + 1 == h;
            if !end {
                for (j, nx, ny) in [
                    (i - 1, x - 1, y),
                    (i + 1, x + 1, y),
                    (i - w, x, y - 1),
                    (i + w, x, y + 1),
                ] {
                    let (l, lj) = (map.labels[j], win.at(nx, ny));
                    if l == CUT {
                        if cells[lj][0] != stamp {
                            cells[lj] = [stamp, i as u64];
                            next.push((nx as u32, ny as u32));
                        }
                    } else if l != me {
                        end = true;
                    }
                }
            }
            if end {
                let mut path = vec![i];
                let prev = |p: usize| cells[win.at(p % w, p / w)][1];
                while prev(*path.last().expect("a path has a pixel")) != SEED {
                    path.push(prev(*path.last().expect("a path has a pixel")) as usize);
                }
                let mut c = price(path[path.len() - 1]) * bw;
                for &p in path.iter().rev().skip(1) {
                    c += price(p) * bw;
                }
                return c < limit;
            }
        }
        std::mem::swap(&mut ring, &mut next);
        next.clear();
        pixels += 1.0;
    }
    false
}

/// Whether one of four straight paths through the cut, from the island's extreme pixels straight
/// up, down, left and right (they never meet the island), reaches a place the search of
/// [`search_one`] ends at for less than `limit`, so that search keeps the island (see
/// [`bridged_under`]). A straight line costs its length, where [`bridged_under`]'s rings run round
/// a large island's whole border. `false` says nothing (the rings run).
fn straight_under(
    map: &IslandMap,
    island: usize,
    limit: f64,
    bw: f64,
    price: &(impl Fn(usize) -> f64 + ?Sized),
) -> bool {
    let (w, h) = (map.width as usize, map.height as usize);
    let me = island as u32;
    let border = &map.nodes[island].border;
    let (Some(&top), Some(&bottom)) = (border.first(), border.last()) else {
        return false;
    };
    // The first of the leftmost and of the rightmost in scan order (any would do).
    let left = border
        .iter()
        .copied()
        .reduce(|a, b| if b.0 < a.0 { b } else { a });
    let right = border
        .iter()
        .copied()
        .reduce(|a, b| if b.0 > a.0 { b } else { a });
    let probes = [
        (top, (0, -1)),
        (bottom, (0, 1)),
        (left.unwrap_or(top), (-1, 0)),
        (right.unwrap_or(top), (1, 0)),
    ];
    probes.into_iter().any(|((x, y), (dx, dy))| {
        let (mut x, mut y) = (x as isize + dx, y as isize + dy);
        if x < 0 || y < 0 || x as usize >= w || y as usize >= h {
            return false;
        }
        let mut i = y as usize * w + x as usize;
        if map.labels[i] != CUT {
            return false;
        }
        let mut c = price(i) * bw;
        loop {
            if c >= limit {
                return false;
            }
            let (ux, uy) = (x as usize, y as usize);
            if ux == 0 || uy == 0 || ux + 1 == w || uy + 1 == h {
                return true;
            }
            if [i - 1, i + 1, i - w, i + w].into_iter().any(|j| {
                let l = map.labels[j];
                l != CUT && l != me
            }) {
                return true;
            }
            (x, y) = (x + dx, y + dy);
            i = y as usize * w + x as usize;
            if map.labels[i] != CUT {
                // Never the island (see above), and other material beside the last pixel made
                // it an end: not reached.
                return false;
            }
            c += price(i) * bw;
        }
    })
}

/// The part of the picture the searches for an island can reach, where its scratch grid lies:
/// the box of its border grown by the longest path under the limit (each pixel costs at least
/// 0.1 × the width, as [`bridged_under`] counts) and the step to a neighbour, within the picture.
/// (A grid over the whole picture was zeroed per search.) `Window(x0, y0, width)`, and its size.
struct Window(usize, usize, usize);

impl Window {
    fn new(map: &IslandMap, border: &[(u32, u32)], limit: f64, bw: f64) -> (Window, usize) {
        let (w, h) = (map.width as usize, map.height as usize);
        let reach = ((limit / (0.1 * bw)).ceil() + 3.0).min((w + h) as f64) as usize;
        let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
        for &(x, y) in border {
            (x0, y0) = (x0.min(x as usize), y0.min(y as usize));
            (x1, y1) = (x1.max(x as usize), y1.max(y as usize));
        }
        let (x0, x1) = (x0.saturating_sub(reach).min(x1), (x1 + reach).min(w - 1));
        let (y0, y1) = (y0.saturating_sub(reach).min(y1), (y1 + reach).min(h - 1));
        (Window(x0, y0, x1 + 1 - x0), (x1 + 1 - x0) * (y1 + 1 - y0))
    }

    /// Pixel (x, y)'s cell: in scan order, as in the picture.
    #[inline]
    fn at(&self, x: usize, y: usize) -> usize {
        (y - self.1) * self.2 + (x - self.0)
    }
}

fn neighbours(x: usize, y: usize, w: usize, h: usize) -> impl Iterator<Item = (usize, usize)> {
    let mut v = [(usize::MAX, 0); 4];
    if x > 0 {
        v[0] = (x - 1, y);
    }
    if x + 1 < w {
        v[1] = (x + 1, y);
    }
    if y > 0 {
        v[2] = (x, y - 1);
    }
    if y + 1 < h {
        v[3] = (x, y + 1);
    }
    v.into_iter().filter(|p| p.0 != usize::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::islands;
    use crate::raster::BitGrid;
    use crate::test_rng::Lcg;

    /// A dark field with a small light speck and a large light disc, both far from the edge.
    #[test]
    fn a_speck_is_dropped_and_a_large_island_kept() {
        let (w, h) = (120u32, 80u32);
        let mut g = Gray::new(w, h, 0.05);
        let mut b = BitGrid::new(w, h, false);
        // A light frame all round, so the islands sit in a dark hole.
        for y in 0..h {
            for x in 0..w {
                let edge = x < 3 || y < 3 || x >= w - 3 || y >= h - 3;
                let speck = (30..33).contains(&x) && (40..43).contains(&y);
                let disc = (x as f32 - 85.0).hypot(y as f32 - 40.0) < 15.0;
                if edge || speck || disc {
                    g.set(x, y, 0.95);
                    b.set(x, y, true);
                }
            }
        }
        let map = islands::label(&b);
        assert_eq!(map.island_count(), 2);
        let d = choose(&map, &g, 128, &[], |_| 6);
        assert_eq!(d.len(), 1, "{d:?}");
        assert!((d[0].1.at_mm[0] - 31.5).abs() < 1.0 && d[0].1.area_mm2 == 9.0);
        // Protected, it stays.
        let speck = map.label(31, 41) as usize;
        let mut protect = vec![false; map.nodes.len()];
        protect[speck] = true;
        assert!(choose(&map, &g, 128, &protect, |_| 6).is_empty());
    }

    /// A speck beside a large island far from the frame: kept for the picture alone (its bridge
    /// to the island is short), dropped when hanging on an island costs the sheet a hop, and kept
    /// again when it sits as near the frame instead.
    #[test]
    fn a_speck_hanging_on_an_island_is_dropped_for_the_sheet() {
        let (w, h) = (140u32, 80u32);
        let picture = |speck_x: u32| {
            let mut g = Gray::new(w, h, 0.05);
            let mut b = BitGrid::new(w, h, false);
            for y in 0..h {
                for x in 0..w {
                    let edge = x < 3 || y < 3 || x >= w - 3 || y >= h - 3;
                    let speck = (speck_x..speck_x + 4).contains(&x) && (38..42).contains(&y);
                    let disc = (x as f32 - 70.0).hypot(y as f32 - 40.0) < 15.0;
                    if edge || speck || disc {
                        g.set(x, y, 0.95);
                        b.set(x, y, true);
                    }
                }
            }
            (g, b)
        };
        let run = |speck_x: u32, hop: f64| {
            let (g, b) = picture(speck_x);
            let map = islands::label(&b);
            assert_eq!(map.island_count(), 2);
            let price = |i: usize| 0.1 + (g.data[i] - 0.5).abs() as f64;
            let sheet = SheetCost {
                per_bridge: 0.0,
                per_border_px: 0.0,
                per_hop: hop,
            };
            let d = choose_for_sheet(&map, &price, &price, sheet, &|_| 2);
            d.into_iter().map(|(_, d)| d.area_mm2).collect::<Vec<_>>()
        };
        // Beside the disc (a pixel of cut between them), 35 px from the frame.
        assert_eq!(run(51, 0.0), Vec::<f64>::new());
        assert_eq!(run(51, 30.0), vec![16.0]);
        // Beside the frame (2 px of cut), the hop costs nothing.
        assert_eq!(run(5, 30.0), Vec::<f64>::new());
    }

    /// The search as first written (a heap of every entry, a grid per search, no breadth-first
    /// shortcut): which islands it drops, for comparing [`choose`] with.
    fn reference(map: &IslandMap, gray: &Gray, level: u8, bw: f64) -> Vec<u32> {
        let t = level as f32 / 255.0;
        let price = |i: usize| 0.1 + (gray.data[i] - t).abs() as f64;
        let (w, h) = (map.width as usize, map.height as usize);
        let mut drop_cost = vec![0f64; map.nodes.len()];
        for (i, &l) in map.labels.iter().enumerate() {
            if l != CUT && l != FRAME {
                drop_cost[l as usize] += price(i);
            }
        }
        let mut out = Vec::new();
        for (island, (node, &limit)) in map.nodes.iter().zip(&drop_cost).enumerate().skip(1) {
            let me = island as u32;
            let budget = SEARCH_PER_AREA * node.area + SEARCH_BASE;
            let mut dist = vec![f64::INFINITY; w * h];
            let mut heap = BinaryHeap::new();
            for &(x, y) in &node.border {
                for (nx, ny) in neighbours(x as usize, y as usize, w, h) {
                    let j = ny * w + nx;
                    if map.labels[j] == CUT && price(j) * bw < dist[j] {
                        dist[j] = price(j) * bw;
                        heap.push(Reverse((dist[j].to_bits(), j)));
                    }
                }
            }
            let (mut visited, mut keep) = (0, false);
            while let Some(Reverse((bits, i))) = heap.pop() {
                let c = f64::from_bits(bits);
                if c > dist[i] {
                    continue;
                }
                if c >= limit {
                    break;
                }
                visited += 1;
                if visited > budget {
                    keep = true;
                    break;
                }
                let (x, y) = (i % w, i / w);
                let mut reached = x == 0 || y == 0 || x + 1 == w || y + 1 == h;
                for (nx, ny) in neighbours(x, y, w, h) {
                    let j = ny * w + nx;
                    let l = map.labels[j];
                    if l == CUT {
                        if c + price(j) * bw < dist[j] {
                            dist[j] = c + price(j) * bw;
                            heap.push(Reverse((dist[j].to_bits(), j)));
                        }
                    } else if l != me {
                        reached = true;
                    }
                }
                if reached {
                    keep = true;
                    break;
                }
            }
            if !keep {
                out.push(me);
            }
        }
        out
    }

    /// A picture of random gray with material at random, `fill` in a hundred of its pixels
    /// (the gray and the bit of each pixel drawn in turn, row by row).
    fn random_picture(
        w: u32,
        h: u32,
        fill: u64,
        next: &mut impl FnMut() -> u64,
    ) -> (Gray, BitGrid) {
        let mut g = Gray::new(w, h, 0.0);
        let mut b = BitGrid::new(w, h, false);
        for y in 0..h {
            for x in 0..w {
                g.set(x, y, (next() % 1000) as f32 / 1000.0);
                b.set(x, y, next() % 100 < fill);
            }
        }
        (g, b)
    }

    /// Where a straight path answers (an island the search keeps), the plain search keeps the
    /// island, on random pictures of every density and bridge width; and it answers for some.
    #[test]
    fn a_straight_path_under_the_drop_cost_keeps_the_island() {
        let mut rng = Lcg(0x7f4a_7c15_9e37_79b9);
        let mut next = move || rng.next_u64() >> 33;
        let (mut answered, mut islands_seen) = (0, 0);
        for k in 0..80u32 {
            let (w, h) = (16 + k % 29, 14 + (k * 5) % 23);
            let fill = 20 + next() % 45;
            let (g, b) = random_picture(w, h, fill, &mut next);
            let map = islands::label(&b);
            let bw = (1 + k % 4) as f64;
            let level = (next() % 256) as u8;
            let t = level as f32 / 255.0;
            let price = |i: usize| 0.1 + (g.data[i] - t).abs() as f64;
            let dropped = reference(&map, &g, level, bw);
            for n in 1..map.nodes.len() {
                let limit: f64 = map
                    .island_runs(n)
                    .iter()
                    .flat_map(|&(y, x0, x1)| (x0..=x1).map(move |x| (y * w + x) as usize))
                    .map(price)
                    .sum();
                islands_seen += 1;
                if straight_under(&map, n, limit, bw, &price) {
                    answered += 1;
                    assert!(!dropped.contains(&(n as u32)), "picture {k} island {n}");
                }
            }
        }
        assert!(answered > islands_seen / 10, "{answered} of {islands_seen}");
    }

    /// On random pictures (specks and blobs of material in cut of random gray), `choose` drops
    /// the islands the plain search drops.
    #[test]
    fn choose_drops_what_the_plain_search_drops() {
        let mut rng = Lcg(0x2545_f491_4f6c_dd1d);
        let mut next = move || rng.next_u64() >> 33;
        let mut dropped = 0;
        for k in 0..60u32 {
            let (w, h) = (20 + k % 23, 18 + (k * 3) % 19);
            let fill = 25 + next() % 30;
            let (g, b) = random_picture(w, h, fill, &mut next);
            let map = islands::label(&b);
            let bw = 1 + k % 4;
            let level = (next() % 256) as u8;
            let chosen = choose(&map, &g, level, &[], |_| bw);
            // The drop costs and centres are the sums of a pass over the picture, bit for bit.
            let t = level as f32 / 255.0;
            let mut sums = vec![(0f64, 0f64, 0f64); map.nodes.len()];
            for (i, &l) in map.labels.iter().enumerate() {
                if l != CUT && l != FRAME {
                    let s = &mut sums[l as usize];
                    let (x, y) = (i % w as usize, i / w as usize);
                    s.0 += 0.1 + (g.data[i] - t).abs() as f64;
                    s.1 += x as f64 + 0.5;
                    s.2 += y as f64 + 0.5;
                }
            }
            for (n, d) in &chosen {
                let (c, sx, sy) = sums[*n as usize];
                let a = map.nodes[*n as usize].area as f64;
                assert_eq!(d.drop_cost.to_bits(), c.to_bits(), "picture {k} island {n}");
                assert_eq!(d.at_mm, [sx / a, sy / a], "picture {k} island {n}");
                assert_eq!(d.area_mm2, a, "picture {k} island {n}");
            }
            let ours: Vec<u32> = chosen.into_iter().map(|(n, _)| n).collect();
            assert_eq!(ours, reference(&map, &g, level, bw as f64), "picture {k}");
            dropped += ours.len();
        }
        assert!(dropped > 0, "the pictures drop some islands");
    }
}
