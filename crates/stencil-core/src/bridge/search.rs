//! The fallback for a group of nodes no walk leaves (the paper leaves it open): the cheapest path
//! through the cut, of any length, to another node or to the image edge (the sheet beyond the
//! picture), by Dijkstra's search priced per pixel like a strip, then straightened where that
//! costs nothing; so every island can be joined.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::f64::consts::SQRT_2;

use super::cost::StepCost;
use super::strips::{intensity, Fields, Strip};
use crate::islands::{IslandMap, CUT};

/// Reusable buffers of [`search`]: a path cost and a predecessor per pixel, allocated on the first
/// search of a run (8 bytes per pixel, only when some island needs the fallback) and reset only
/// where a search wrote, so that many small searches cost what they explore, not the image.
#[derive(Default)]
pub(crate) struct SearchScratch {
    dist: Vec<f32>,
    parent: Vec<u32>,
    touched: Vec<u32>,
    /// (cost bits << 32 | pixel): a non-negative f32's bits order as the number does.
    heap: BinaryHeap<Reverse<u64>>,
}

impl SearchScratch {
    fn prepare(&mut self, pixels: usize) {
        if self.dist.len() != pixels {
            // Zeroed memory is handed out untouched by the allocator: a search that explores a
            // corner of a large picture pays for that corner, not for the whole grid.
            self.dist = vec![0.0; pixels];
            self.parent = vec![0; pixels];
        } else {
            for &i in &self.touched {
                self.dist[i as usize] = 0.0;
            }
        }
        self.touched.clear();
        self.heap.clear();
    }

    /// Record a path of cost `d` (always above 0: every step costs something) to pixel `i`
    /// through `from` if it is the cheapest yet; 0 in `dist` means not reached.
    #[inline]
    fn relax(&mut self, i: u32, d: f32, from: u32) {
        let slot = &mut self.dist[i as usize];
        if *slot == 0.0 || d < *slot {
            if *slot == 0.0 {
                self.touched.push(i);
            }
            *slot = d;
            self.parent[i as usize] = from;
            self.heap
                .push(Reverse(((d.to_bits() as u64) << 32) | i as u64));
        }
    }
}

/// The fallback when no walk leaves a group of nodes: the cheapest path of any length through the
/// cut from the border of every node in `group` (a mask over nodes) to material of another node
/// or the image edge. Dijkstra over the cut pixels priced by `step` ([`StepCost`]), in eight
/// directions (a diagonal step at √2 its pixel's price, through a corner of open cut), then
/// straightened (`straighten`). Returns the start candidate pixel and the strip. Such a path always
/// exists (a row's rightmost group pixel has cut to its right), so `None` means the labels do not
/// describe the bits. O(pixels) at worst; it stops at the first arrival.
pub(crate) fn search(
    f: &Fields,
    map: &IslandMap,
    group: &[bool],
    step: &StepCost,
    scratch: &mut SearchScratch,
) -> Option<((u32, u32), Strip)> {
    let w = f.width;
    scratch.prepare((f.width * f.height) as usize);
    let cost = |i: u32| step.at(f.gray, i);
    for (n, node) in map.nodes.iter().enumerate() {
        if !group[n] {
            continue;
        }
        for &(x, y) in &node.border {
            let (x, y) = (x as i64, y as i64);
            for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
                let (nx, ny) = (x + dx, y + dy);
                if f.inside(nx, ny) && f.label(nx, ny) == CUT && !f.blocked(nx, ny) {
                    let i = (ny * w + nx) as u32;
                    scratch.relax(i, cost(i), (y * w + x) as u32);
                }
            }
        }
    }
    let in_group = |l: u32| (l as usize) < group.len() && group[l as usize];
    let open = |x: i64, y: i64| f.inside(x, y) && f.label(x, y) == CUT && !f.blocked(x, y);
    while let Some(Reverse(key)) = scratch.heap.pop() {
        let (d, i) = (f32::from_bits((key >> 32) as u32), key as u32);
        if d > scratch.dist[i as usize] {
            continue; // superseded by a cheaper entry
        }
        let (x, y) = ((i as i64) % w, (i as i64) / w);
        for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
            let (nx, ny) = (x + dx, y + dy);
            let l = f.label(nx, ny);
            if l != CUT && !in_group(l) {
                // Arrived: walk the predecessors back to the start (8-connected; `straighten`
                // makes the strip 4-connected).
                let mut pixels = vec![i];
                let mut cur = i;
                let start = loop {
                    let p = scratch.parent[cur as usize];
                    if f.labels[p as usize] != CUT {
                        break p;
                    }
                    pixels.push(p);
                    cur = p;
                };
                pixels.reverse();
                let pixels = straighten(f, &pixels, step);
                let (sx, sy) = ((start as i64 % w) as u32, (start as i64 / w) as u32);
                let from = f.labels[start as usize];
                let intensity = intensity(f.gray, &pixels);
                return Some((
                    (sx, sy),
                    Strip {
                        from,
                        to: l,
                        pixels,
                        end: (nx, ny),
                        intensity,
                    },
                ));
            }
        }
        for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
            let (nx, ny) = (x + dx, y + dy);
            if open(nx, ny) {
                let j = (ny * w + nx) as u32;
                scratch.relax(j, d + cost(j), i);
            }
        }
        // Diagonal steps at √2 the price: a bridge is drawn as a band along its path, whose
        // area grows with the path's length, not with its 4-connected pixel count. With
        // straight steps only, every monotone staircase cost the same, so a path that followed
        // a lighter row or column and turned (an L, or steps of a few tens of pixels) was as
        // cheap as the straight diagonal, though its band covered up to √2 times the pixels.
        for (dx, dy) in [(1i64, 1i64), (1, -1), (-1, 1), (-1, -1)] {
            let (nx, ny) = (x + dx, y + dy);
            if open(nx, ny) && (open(nx, y) || open(x, ny)) {
                let j = (ny * w + nx) as u32;
                scratch.relax(j, d + std::f32::consts::SQRT_2 * cost(j), i);
            }
        }
    }
    None
}

/// The pixel a diagonal step of the search from `from` to `to` (linear indices) goes through
/// to stay 4-connected: the cheaper of the two corners that are open cut; `None` when the step
/// is not diagonal.
fn corner(f: &Fields, step: &StepCost, to: u32, from: u32) -> Option<u32> {
    let w = f.width;
    let (tx, ty) = (to as i64 % w, to as i64 / w);
    let (fx, fy) = (from as i64 % w, from as i64 / w);
    if tx == fx || ty == fy {
        return None;
    }
    [(tx, fy), (fx, ty)]
        .into_iter()
        .filter(|&(x, y)| f.inside(x, y) && f.label(x, y) == CUT && !f.blocked(x, y))
        .map(|(x, y)| (y * w + x) as u32)
        .min_by(|&a, &b| step.at(f.gray, a).total_cmp(&step.at(f.gray, b)))
}

/// A searched path (8-connected) made straight where that costs no more, and 4-connected:
/// from each anchor, the straight 4-connected line ([`line4`]) to the farthest later path pixel
/// it can reach through cut for no more than the stretch it replaces (doubling, then bisection:
/// O(n log n)); a diagonal step no line fits goes through its cheaper open corner. Costs are
/// per length, as the search's: a stretch costs its steps' prices (a diagonal √2 times its
/// pixel's), a line its pixels' mean price times its length, so a staircase of lighter pixels
/// gives way to the straight line only where the line's band would not cost more. The ends stay
/// where they were.
fn straighten(f: &Fields, path: &[u32], step: &StepCost) -> Vec<u32> {
    let n = path.len();
    let w = f.width;
    let xy = |p: u32| (p as i64 % w, p as i64 / w);
    if n < 2 {
        return path.to_vec();
    }
    let mut prefix = Vec::with_capacity(n);
    prefix.push(0.0f64);
    for k in 1..n {
        let ((xa, ya), (xb, yb)) = (xy(path[k - 1]), xy(path[k]));
        let diagonal = xa != xb && ya != yb;
        let price = step.at(f.gray, path[k]) as f64;
        prefix.push(prefix[k - 1] + if diagonal { SQRT_2 * price } else { price });
    }
    let fits = |a: usize, b: usize| {
        let budget = prefix[b] - prefix[a] + 1e-6;
        let ((xa, ya), (xb, yb)) = (xy(path[a]), xy(path[b]));
        let (dx, dy) = ((xb - xa) as f64, (yb - ya) as f64);
        // Each line pixel after the first stands for this much of the line's length.
        let per = dx.hypot(dy) / (dx.abs() + dy.abs()).max(1.0);
        let mut cost = 0.0f64;
        let mut first = true;
        line4(xy(path[a]), xy(path[b]), |x, y| {
            if std::mem::take(&mut first) {
                return true;
            }
            if f.material(x, y) || f.blocked(x, y) {
                cost = f64::INFINITY;
                return false;
            }
            cost += step.at(f.gray, (y * w + x) as u32) as f64 * per;
            cost <= budget
        }) && cost <= budget
    };
    let mut out = vec![path[0]];
    let mut a = 0;
    while a + 1 < n {
        // Gallop from the next path pixel, then bisect up to the first misfit.
        let (mut good, mut span, mut bad) = (a + 1, 2, None);
        while bad.is_none() && good < n - 1 {
            let j = (a + span).min(n - 1);
            if fits(a, j) {
                good = j;
                span *= 2;
            } else {
                bad = Some(j);
            }
        }
        if let Some(mut hi) = bad {
            while hi - good > 1 {
                let mid = (good + hi) / 2;
                if fits(a, mid) {
                    good = mid;
                } else {
                    hi = mid;
                }
            }
        }
        if good == a + 1 && !fits(a, good) {
            // A diagonal step whose line's corner is material or dearer: the other corner.
            out.extend(corner(f, step, path[good], path[a]));
            out.push(path[good]);
        } else {
            let mut first = true;
            line4(xy(path[a]), xy(path[good]), |x, y| {
                if !std::mem::take(&mut first) {
                    out.push((y * w + x) as u32);
                }
                true
            });
        }
        a = good;
    }
    out
}

/// The 4-connected digital line from pixel `a` to pixel `b`, both included (|dx| + |dy| + 1
/// pixels): each step goes along the axis whose next pixel boundary the straight segment between
/// the pixel centres crosses first (on a tie, vertically). `visit` returns false to stop; the
/// result says whether the line was visited to its end.
fn line4(a: (i64, i64), b: (i64, i64), mut visit: impl FnMut(i64, i64) -> bool) -> bool {
    let (nx, ny) = ((b.0 - a.0).abs(), (b.1 - a.1).abs());
    let (sx, sy) = ((b.0 - a.0).signum(), (b.1 - a.1).signum());
    let (mut x, mut y, mut ix, mut iy) = (a.0, a.1, 0, 0);
    if !visit(x, y) {
        return false;
    }
    while ix < nx || iy < ny {
        // Crossing the next vertical boundary at t = (ix + ½)/nx, the next horizontal one at
        // (iy + ½)/ny; compared without division.
        if (1 + 2 * ix) * ny < (1 + 2 * iy) * nx {
            x += sx;
            ix += 1;
        } else {
            y += sy;
            iy += 1;
        }
        if !visit(x, y) {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bridge::candidates::collect;
    use crate::bridge::strips::{walk_candidate, WalkEnd};
    use crate::bridge::tests::{four_connected, two};
    use crate::islands::{label, FRAME};
    use crate::raster::{BitGrid, Gray, TwoTone};

    #[test]
    fn too_long_walks_are_dropped_and_search_finds_the_shortest_path() {
        let t = two(&[
            "############",
            "#..........#",
            "#..........#",
            "#...##.....#",
            "#...##.....#",
            "#..........#",
            "############",
        ]);
        let m = label(&t.bits);
        let f = Fields::new(&t, &m);
        let c = collect(&m);
        let id = c.id_at(&m, 1, 4, 3).unwrap();
        assert_eq!(walk_candidate(&f, &c, id, 1), Err(WalkEnd::TooLong));
        let mut group = vec![false; m.nodes.len()];
        group[1] = true;
        let step = StepCost {
            intensity: 1.0,
            length: 1.0,
        };
        let mut scratch = SearchScratch::default();
        let (start, s) = search(&f, &m, &group, &step, &mut scratch).unwrap();
        assert_eq!(s.to, FRAME);
        // The island's bottom row is one cut pixel above the frame's bottom row.
        assert_eq!(s.len(), 1, "{start:?}");
        assert_eq!(start.1, 4);
        // The scratch is reset between searches: the same search again finds the same strip.
        assert_eq!(
            search(&f, &m, &group, &step, &mut scratch).unwrap(),
            (start, s)
        );
    }

    #[test]
    fn search_prefers_light_gray_to_a_shorter_path_over_black_when_told_to() {
        // A bar island 10 cut pixels from the left image edge over black, 29 from the right one
        // along a corridor of light gray, 25 from the top and bottom over black.
        let (w, h) = (40u32, 61u32);
        let bits = BitGrid::from_fn(w, h, |x, y| x == 10 && (25..36).contains(&y));
        let gray = Gray {
            width: w,
            height: h,
            data: (0..w * h)
                .map(|i| {
                    let (x, y) = (i % w, i / w);
                    if x > 10 && (25..36).contains(&y) {
                        0.95
                    } else {
                        0.0
                    }
                })
                .collect(),
        };
        let t = TwoTone {
            bits,
            gray: gray.into(),
        };
        let m = label(&t.bits);
        let f = Fields::new(&t, &m);
        let group = [false, true];
        let mut scratch = SearchScratch::default();
        let mut find = |intensity, length| {
            search(
                &f,
                &m,
                &group,
                &StepCost { intensity, length },
                &mut scratch,
            )
            .unwrap()
            .1
        };
        // Darkness priced: right, over the gray, to beyond the right edge.
        let light = find(1.0, 0.1);
        assert_eq!((light.len(), light.end.0), (29, 40), "{light:?}");
        // Length only: the short way, left.
        let short = find(0.0, 1.0);
        assert_eq!((short.len(), short.end.0), (10, -1), "{short:?}");
        assert!(light.intensity < short.intensity);
    }

    #[test]
    fn a_searched_path_is_straightened_where_that_costs_nothing() {
        // A one-pixel island in the middle of a black field, 50 px from the image edge; the
        // nearest other material is the tip of a frame spike 20 px right and 15 px down. Over flat
        // black every monotone staircase there costs the same; the strip is the straight one.
        let n = 101u32;
        let bits = BitGrid::from_fn(n, n, |x, y| (x == 50 && y == 50) || (x == 70 && y >= 65));
        let t = crate::bridge::tests::black_white(bits);
        let m = label(&t.bits);
        assert_eq!(m.island_count(), 1);
        let f = Fields::new(&t, &m);
        let group: Vec<bool> = (0..m.nodes.len()).map(|k| k == 1).collect();
        let step = StepCost {
            intensity: 1.0,
            length: 1.0,
        };
        let (start, s) = search(&f, &m, &group, &step, &mut SearchScratch::default()).unwrap();
        assert_eq!((start, s.to), ((50, 50), FRAME));
        assert_eq!(
            s.len(),
            34,
            "the shortest 4-connected way: 20 + 15 - 1 pixels"
        );
        assert!(four_connected(&s.pixels, n));
        let xy = |p: u32| ((p % n) as f64, (p / n) as f64);
        let (a, b) = (xy(s.pixels[0]), xy(*s.pixels.last().unwrap()));
        let len = (b.0 - a.0).hypot(b.1 - a.1);
        for &p in &s.pixels {
            let q = xy(p);
            let off = ((q.0 - a.0) * (b.1 - a.1) - (q.1 - a.1) * (b.0 - a.0)).abs() / len;
            assert!(
                off <= 1.0,
                "pixel {q:?} is {off:.2} px off the line {a:?}-{b:?}"
            );
        }
    }

    #[test]
    fn a_digital_line_is_four_connected_and_joins_its_ends() {
        for (a, b) in [
            ((0, 0), (7, 3)),
            ((5, 5), (5, -2)),
            ((3, 1), (-4, 1)),
            ((0, 0), (-6, -6)),
        ] {
            let mut px = Vec::new();
            assert!(line4(a, b, |x, y| {
                px.push((x, y));
                true
            }));
            let (dx, dy): (i64, i64) = (b.0 - a.0, b.1 - a.1);
            assert_eq!(px.len() as i64, dx.abs() + dy.abs() + 1);
            assert_eq!((px[0], *px.last().unwrap()), (a, b));
            assert!(px
                .windows(2)
                .all(|p| (p[0].0 - p[1].0).abs() + (p[0].1 - p[1].1).abs() == 1));
            // Never farther than a pixel from the segment between the centres.
            for &(x, y) in &px {
                let cross = ((x - a.0) * dy - (y - a.1) * dx) as f64;
                assert!(cross.abs() / (dx as f64).hypot(dy as f64) <= 1.0, "{px:?}");
            }
        }
        // Stopped early.
        let mut n = 0;
        assert!(!line4((0, 0), (9, 0), |_, _| {
            n += 1;
            n < 3
        }));
        assert_eq!(n, 3);
    }
}
