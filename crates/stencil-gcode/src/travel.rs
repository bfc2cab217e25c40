//! Travel optimisation: the order of the loops within a group and the vertex each starts at.
//!
//! A closed loop ends where it starts, so the travel between two loops is the distance between
//! their start vertices. The optimiser alternates two steps:
//! 1. order: nearest neighbour from the current head position, then 2-opt and Or-opt (moving runs
//!    of 1–3 loops, either way round) on the start points, with fixed start and free end, using
//!    K-nearest-neighbour candidate lists so large jobs stay fast;
//! 2. start points: walking the order, each loop starts at its vertex nearest the previous end.
//!
//! Round two repeats both with the new start points.

use crate::job::Loop;
use stencil_geom::ring::{bbox, dist};

/// Candidate neighbours per point for 2-opt and Or-opt.
const K: usize = 12;
/// Improvement rounds per optimisation (each round is a full sweep of all moves).
const MAX_ROUNDS: usize = 60;

/// Travel of open `lines` then `loops` drawn in this order (each loop from its `points[0]`,
/// each line from its first point, `passes` times back and forth, so it ends at its last point
/// after an odd number of passes and its first after an even one), starting and ending at
/// `home`.
pub(crate) fn travel_of(
    lines: &[Vec<[f64; 2]>],
    loops: &[Loop],
    home: [f64; 2],
    passes: u32,
) -> f64 {
    let mut cur = home;
    let mut t = 0.0;
    for l in lines {
        t += dist(cur, l[0]);
        cur = if passes % 2 == 1 {
            l[l.len() - 1]
        } else {
            l[0]
        };
    }
    for l in loops {
        t += dist(cur, l.points[0]);
        cur = l.points[0];
    }
    t + dist(cur, home)
}

/// The travel of the input order (each loop from its first vertex): the baseline we report.
pub(crate) fn naive_travel(lines: &[Vec<[f64; 2]>], loops: &[Loop], home: [f64; 2]) -> f64 {
    travel_of(lines, loops, home, 1)
}

/// Open lines in drawing order: nearest neighbour from `home`, each line entered at whichever end
/// is nearer (and then reversed to start there); of two as near, the first drawn.
pub(crate) fn order_lines(lines: Vec<Vec<[f64; 2]>>, home: [f64; 2]) -> Vec<Vec<[f64; 2]>> {
    let mut left = Nearest::new(lines.len());
    for (k, l) in lines.iter().enumerate() {
        left.push(k, bbox(l));
    }
    let mut lines: Vec<Option<Vec<[f64; 2]>>> = lines.into_iter().map(Some).collect();
    let mut out = Vec::with_capacity(lines.len());
    let mut cur = home;
    // Each line's nearer end; of two as near, its first.
    while let Some((k, reversed)) = left.take(cur, ListOrder::Kept, |k| {
        let l = lines[k].as_deref().unwrap_or_default();
        match (l.first(), l.last()) {
            (Some(&a), Some(&b)) => {
                let (a, b) = (dist(cur, a), dist(cur, b));
                if b < a {
                    (b, true)
                } else {
                    (a, false)
                }
            }
            _ => (f64::INFINITY, false),
        }
    }) {
        let Some(mut l) = lines[k].take() else {
            break;
        };
        if reversed {
            l.reverse();
        }
        cur = l[l.len() - 1];
        out.push(l);
    }
    out
}

/// The vertex of `l` nearest to `p`.
fn nearest_vertex(l: &Loop, p: [f64; 2]) -> (usize, f64) {
    let mut best = (0, f64::INFINITY);
    for (k, &q) in l.points.iter().enumerate() {
        let d = (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2);
        if d < best.1 {
            best = (k, d);
        }
    }
    (best.0, best.1.sqrt())
}

/// What is still to visit in a nearest-neighbour walk (loops, or open lines): which is nearest
/// the head, in about logarithmic time, through an R-tree of their boxes. The choice is the one
/// a scan of a list in order makes (see [`Nearest::take`]): the nearest, and of equally near ones
/// the first in the list. So jobs of tens of thousands of loops no longer compare every loop
/// with every other (60,000 squares: 136 s), and every job's order stays what it was.
struct Nearest {
    /// The keys waiting, in list order.
    list: Vec<usize>,
    /// Each key's place in `list` (`usize::MAX`: not in it).
    at: Vec<usize>,
    /// Each waiting key's box in the tree (to remove it exactly).
    boxes: Vec<Option<crate::order::BoxOf>>,
    tree: rstar::RTree<crate::order::BoxOf>,
}

/// How [`Nearest::take`] keeps its list, as the scan it replaces did.
#[derive(Clone, Copy, PartialEq)]
enum ListOrder {
    /// A key taken is replaced by the list's last (`Vec::swap_remove`).
    Swapped,
    /// Keys stay in the order they were pushed.
    Kept,
}

impl Nearest {
    /// An empty set over keys `0..n`.
    fn new(n: usize) -> Self {
        Nearest {
            list: Vec::with_capacity(n),
            at: vec![usize::MAX; n],
            boxes: vec![None; n],
            tree: rstar::RTree::new(),
        }
    }

    /// Add key `k`, whose points all lie in box `b`, at the end of the list.
    fn push(&mut self, k: usize, b: [f64; 4]) {
        self.at[k] = self.list.len();
        self.list.push(k);
        let g = crate::order::box_of(k, b);
        self.tree.insert(g);
        self.boxes[k] = Some(g);
    }

    /// Take the key whose `measure` from `p` (a distance to one of its points, and what the
    /// caller wants back with it: the vertex, the end) is least; of equal ones, the first in the
    /// list as `order` keeps it. `None` when empty.
    fn take<T: Copy>(
        &mut self,
        p: [f64; 2],
        order: ListOrder,
        mut measure: impl FnMut(usize) -> (f64, T),
    ) -> Option<(usize, T)> {
        // (place in the list, key, distance, what came with it)
        let mut best: Option<(usize, usize, f64, T)> = None;
        for (g, d2) in self.tree.nearest_neighbor_iter_with_distance_2(&p) {
            // A key's points lie in its box, so none farther than the best distance (with a
            // margin for rounding) can be nearer or as near.
            if let Some(b) = best {
                let reach = b.2 * (1.0 + 1e-9) + 1e-12;
                if d2 > reach * reach {
                    break;
                }
            }
            let k = g.data;
            let (d, t) = measure(k);
            let place = self.at[k];
            if best.is_none_or(|b| d < b.2 || (d == b.2 && place < b.0)) {
                best = Some((place, k, d, t));
            }
        }
        let (place, k, _, t) = best?;
        if let Some(g) = self.boxes[k].take() {
            self.tree.remove(&g);
        }
        match order {
            ListOrder::Swapped => {
                self.list.swap_remove(place);
                if let Some(&moved) = self.list.get(place) {
                    self.at[moved] = place;
                }
            }
            // The places of the others keep their order; the list itself is not needed.
            ListOrder::Kept => {}
        }
        self.at[k] = usize::MAX;
        Some((k, t))
    }
}

/// Order all groups, one after the other, from `home`. Returns (loop index, start vertex) in cut
/// order.
pub(crate) fn optimise(
    loops: &[Loop],
    groups: &[Vec<usize>],
    home: [f64; 2],
) -> Vec<(usize, usize)> {
    let mut out = Vec::with_capacity(loops.len());
    let mut cur = home;
    for g in groups {
        let seq = optimise_group(loops, g, cur);
        if let Some(&(i, s)) = seq.last() {
            cur = loops[i].points[s];
        }
        out.extend(seq);
    }
    refine_starts(loops, &mut out, home);
    out
}

/// Nearest neighbour under precedence: from `home`, go to the nearest loop (nearest vertex) whose
/// every `before` loop is cut. Finishes what lies inside a region before moving on, where
/// [`optimise`] over depth layers must visit every inner loop of the job first.
pub(crate) fn greedy_constrained(
    loops: &[Loop],
    before: &[Vec<usize>],
    home: [f64; 2],
) -> Vec<(usize, usize)> {
    let n = loops.len();
    let boxes: Vec<[f64; 4]> = loops.iter().map(|l| bbox(&l.points)).collect();
    let mut waiting: Vec<usize> = before.iter().map(Vec::len).collect();
    let mut after: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (j, b) in before.iter().enumerate() {
        for &i in b {
            after[i].push(j);
        }
    }
    let mut ready = Nearest::new(n);
    for i in (0..n).filter(|&i| waiting[i] == 0) {
        ready.push(i, boxes[i]);
    }
    let mut out = Vec::with_capacity(n);
    let mut cur = home;
    while let Some((k, v)) = ready.take(cur, ListOrder::Swapped, |k| {
        let (v, d) = nearest_vertex(&loops[k], cur);
        (d, v)
    }) {
        out.push((k, v));
        cur = loops[k].points[v];
        for &j in &after[k] {
            waiting[j] -= 1;
            if waiting[j] == 0 {
                ready.push(j, boxes[j]);
            }
        }
    }
    // A cycle cannot happen (the constraints follow a strict key), but never drop a loop.
    if out.len() < n {
        let mut seen = vec![false; n];
        out.iter().for_each(|&(i, _)| seen[i] = true);
        out.extend((0..n).filter(|&i| !seen[i]).map(|i| (i, 0)));
    }
    refine_starts(loops, &mut out, home);
    out
}

/// Whether a sequence cuts every loop after all its `before` loops.
pub(crate) fn respects(seq: &[(usize, usize)], before: &[Vec<usize>]) -> bool {
    let mut pos = vec![usize::MAX; before.len()];
    for (k, &(i, _)) in seq.iter().enumerate() {
        pos[i] = k;
    }
    before
        .iter()
        .enumerate()
        .all(|(j, b)| b.iter().all(|&i| pos[i] < pos[j]))
}

/// Travel of a sequence of (loop, start vertex) from and back to `home`.
pub(crate) fn sequence_travel(loops: &[Loop], seq: &[(usize, usize)], home: [f64; 2]) -> f64 {
    let mut cur = home;
    let mut t = 0.0;
    for &(i, s) in seq {
        t += dist(cur, loops[i].points[s]);
        cur = loops[i].points[s];
    }
    t + dist(cur, home)
}

/// Start-vertex sweeps over the whole sequence: each loop starts at the vertex that makes the
/// way in from the previous loop plus the way on to the next (or back home) shortest. Groups are
/// optimised one at a time, each greedily from where the last ended; this lets a loop's start
/// also look ahead, across group borders (where one-loop groups, as nested rings give, would
/// otherwise each start just at the nearest vertex to the last).
pub(crate) fn refine_starts(loops: &[Loop], seq: &mut [(usize, usize)], home: [f64; 2]) {
    let n = seq.len();
    for _sweep in 0..3 {
        let mut changed = false;
        for k in 0..n {
            let prev = if k == 0 {
                home
            } else {
                loops[seq[k - 1].0].points[seq[k - 1].1]
            };
            let next = if k + 1 == n {
                home
            } else {
                loops[seq[k + 1].0].points[seq[k + 1].1]
            };
            let (i, s) = seq[k];
            let cost = |v: usize| dist(prev, loops[i].points[v]) + dist(loops[i].points[v], next);
            let mut best = (s, cost(s));
            for v in 0..loops[i].points.len() {
                let c = cost(v);
                if c < best.1 - 1e-9 {
                    best = (v, c);
                }
            }
            if best.0 != s {
                seq[k].1 = best.0;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
}

fn optimise_group(loops: &[Loop], group: &[usize], from: [f64; 2]) -> Vec<(usize, usize)> {
    let n = group.len();
    if n == 0 {
        return vec![];
    }
    // Nearest neighbour over the nearest vertex of each remaining loop, pruned by bounding boxes.
    let mut remaining = Nearest::new(n);
    for (k, &i) in group.iter().enumerate() {
        remaining.push(k, bbox(&loops[i].points));
    }
    let mut seq: Vec<usize> = Vec::with_capacity(n);
    let mut start = vec![0usize; n];
    let mut cur = from;
    while let Some((k, v)) = remaining.take(cur, ListOrder::Swapped, |k| {
        let (v, d) = nearest_vertex(&loops[group[k]], cur);
        (d, v)
    }) {
        start[k] = v;
        cur = loops[group[k]].points[v];
        seq.push(k);
    }

    let mut best_len = f64::INFINITY;
    let mut best_seq = (seq.clone(), start.clone());
    for _round in 0..2 {
        let pts: Vec<[f64; 2]> = (0..n).map(|k| loops[group[k]].points[start[k]]).collect();
        improve(&mut seq, &pts, from);
        // Re-pick each start vertex nearest the previous end.
        let mut cur = from;
        for &k in &seq {
            let (v, _) = nearest_vertex(&loops[group[k]], cur);
            start[k] = v;
            cur = loops[group[k]].points[v];
        }
        let len = open_len(
            &seq,
            &(0..n)
                .map(|k| loops[group[k]].points[start[k]])
                .collect::<Vec<_>>(),
            from,
        );
        if len < best_len - 1e-9 {
            best_len = len;
            best_seq = (seq.clone(), start.clone());
        } else {
            break;
        }
    }
    let (seq, start) = best_seq;
    seq.into_iter().map(|k| (group[k], start[k])).collect()
}

fn open_len(seq: &[usize], pts: &[[f64; 2]], from: [f64; 2]) -> f64 {
    let mut cur = from;
    let mut t = 0.0;
    for &k in seq {
        t += dist(cur, pts[k]);
        cur = pts[k];
    }
    t
}

/// K nearest neighbours of each point, nearest first (ties by index). Points are binned in a
/// uniform grid of about one point per cell and each search widens ring by ring until no cell
/// left can hold a nearer point, so the cost grows with the number of points, not its square (a
/// brute-force search over 20,000 loops took seconds and, keeping every candidate list's
/// capacity, gigabytes).
fn knn(pts: &[[f64; 2]]) -> Vec<Vec<usize>> {
    let n = pts.len();
    let k = K.min(n.saturating_sub(1));
    if k == 0 {
        return vec![Vec::new(); n];
    }
    let b = bbox(pts);
    let (w, h) = ((b[2] - b[0]).max(0.0), (b[3] - b[1]).max(0.0));
    // About one point per cell; a line of points gets one row of cells.
    let area = (w * h).max((w.max(h) * w.max(h)) / n as f64);
    let cell = if area > 0.0 && area.is_finite() {
        (area / n as f64).sqrt()
    } else {
        1.0
    };
    let cols = ((w / cell).floor() as usize + 1).min(n.max(1));
    let rows = ((h / cell).floor() as usize + 1).min(n.max(1));
    let at = |p: [f64; 2]| {
        let c = (((p[0] - b[0]) / cell).floor().max(0.0) as usize).min(cols - 1);
        let r = (((p[1] - b[1]) / cell).floor().max(0.0) as usize).min(rows - 1);
        (c, r)
    };
    let mut bins: Vec<Vec<usize>> = vec![Vec::new(); cols * rows];
    for (i, &p) in pts.iter().enumerate() {
        let (c, r) = at(p);
        bins[r * cols + c].push(i);
    }
    let mut c: Vec<(f64, usize)> = Vec::new();
    (0..n)
        .map(|i| {
            let (ci, ri) = at(pts[i]);
            c.clear();
            let mut ring = 0usize;
            loop {
                let (c0, c1) = (ci.saturating_sub(ring), (ci + ring).min(cols - 1));
                let (r0, r1) = (ri.saturating_sub(ring), (ri + ring).min(rows - 1));
                for r in r0..=r1 {
                    for cc in c0..=c1 {
                        // Only the cells on this ring's border are new.
                        let border =
                            r + ring == ri || r == ri + ring || cc + ring == ci || cc == ci + ring;
                        if !border {
                            continue;
                        }
                        for &j in &bins[r * cols + cc] {
                            if j != i {
                                c.push((dist(pts[i], pts[j]), j));
                            }
                        }
                    }
                }
                let covered = c0 == 0 && r0 == 0 && c1 == cols - 1 && r1 == rows - 1;
                // Every point outside the rings searched is at least `ring * cell` away.
                if covered {
                    break;
                }
                if c.len() >= k {
                    c.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                    if c[k - 1].0 <= ring as f64 * cell {
                        break;
                    }
                }
                ring += 1;
            }
            if k < c.len() {
                c.select_nth_unstable_by(k, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                c.truncate(k);
            }
            c.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            c.iter().map(|&(_, j)| j).collect()
        })
        .collect()
}

/// 2-opt and Or-opt on an open path that starts at `from` and ends anywhere.
fn improve(seq: &mut Vec<usize>, pts: &[[f64; 2]], from: [f64; 2]) {
    let n = seq.len();
    if n < 2 {
        return;
    }
    let mut tour = Tour {
        pos: vec![0usize; n],
        nb: knn(pts),
        seq,
        pts,
        from,
    };
    tour.reindex();
    for _ in 0..MAX_ROUNDS {
        let two_opt = tour.two_opt();
        let or_opt = tour.or_opt();
        if !(two_opt || or_opt) {
            break;
        }
    }
}

/// A change shorter by less than this (mm) is no improvement: it keeps rounding noise from
/// undoing and redoing the same move.
const EPS: f64 = 1e-9;

/// An open path being improved in place: the visiting order, where each point sits in it, and
/// each point's nearest neighbours, the only new edges tried, so that a pass stays near-linear
/// instead of quadratic in the number of loops.
struct Tour<'a> {
    seq: &'a mut Vec<usize>,
    /// `pos[k]`: the index of point `k` in `seq`.
    pos: Vec<usize>,
    pts: &'a [[f64; 2]],
    nb: Vec<Vec<usize>>,
    from: [f64; 2],
}

impl Tour<'_> {
    /// Bring `pos` back in line with `seq` after a move.
    fn reindex(&mut self) {
        self.reindex_range(0..self.seq.len());
    }

    /// Bring `pos` back in line with `seq` where a move changed it: `seq[range]` (the rest of
    /// the path kept its places, so a long path is not walked for every short move).
    fn reindex_range(&mut self, range: std::ops::Range<usize>) {
        for i in range {
            self.pos[self.seq[i]] = i;
        }
    }

    /// Point at sequence index i; index -1 is `from`.
    #[inline]
    fn at(&self, i: isize) -> [f64; 2] {
        if i < 0 {
            self.from
        } else {
            self.pts[self.seq[i as usize]]
        }
    }

    /// Length change of reversing seq[i..=j]: new edges (prev(i), seq[j]) and (seq[i], seq[j+1]).
    #[inline]
    fn reversal_gain(&self, i: usize, j: usize) -> f64 {
        let prev = self.at(i as isize - 1);
        let (a, b) = (self.pts[self.seq[i]], self.pts[self.seq[j]]);
        let mut d = dist(prev, b) - dist(prev, a);
        if j + 1 < self.seq.len() {
            let next = self.pts[self.seq[j + 1]];
            d += dist(a, next) - dist(b, next);
        }
        d
    }

    /// Reverse seq[i..=j] if that shortens the path; true if it did.
    #[inline]
    fn reverse_if_shorter(&mut self, i: usize, j: usize) -> bool {
        if self.reversal_gain(i, j) < -EPS {
            self.seq[i..=j].reverse();
            self.reindex_range(i..j + 1);
            true
        } else {
            false
        }
    }

    /// One 2-opt pass: reverse a stretch of the path where that uncrosses or shortens two edges.
    /// Tried from both ends of the stretch, each time with the new edge going to a near neighbour.
    /// True if anything changed.
    fn two_opt(&mut self) -> bool {
        let n = self.seq.len();
        let mut improved = false;
        for i in 0..n {
            // Candidates for the new edge from prev(i): neighbours of prev, or all points from the
            // start (where prev is `from`, not a point with a neighbour list).
            let cands: Vec<usize> = if i == 0 {
                (0..n).collect()
            } else {
                self.nb[self.seq[i - 1]].clone()
            };
            for c in cands {
                let j = self.pos[c];
                if j > i {
                    improved |= self.reverse_if_shorter(i, j);
                }
            }
        }
        for j in 0..n.saturating_sub(1) {
            // Candidates for the new edge to seq[j+1]: its neighbours, as seq[i].
            // (Reversing seq[i..=j] leaves seq[j+1] where it is.)
            let to = self.seq[j + 1];
            for c_at in 0..self.nb[to].len() {
                let i = self.pos[self.nb[to][c_at]];
                if i < j {
                    improved |= self.reverse_if_shorter(i, j);
                }
            }
        }
        improved
    }

    /// One Or-opt pass: move each run of 1 to 3 consecutive loops, maybe reversed, to the best
    /// place next to one of its ends' neighbours. True if anything changed.
    fn or_opt(&mut self) -> bool {
        let n = self.seq.len();
        let mut improved = false;
        for len in 1..=3usize {
            let mut i = 0;
            while i + len <= n {
                if let Some((k, rev)) = self.best_insertion(i, len) {
                    self.move_run(i, len, k, rev);
                    improved = true;
                }
                i += 1;
            }
        }
        improved
    }

    /// Where moving seq[i..i+len] shortens the path most: between sequence positions k and k+1
    /// (k = -1: right after `from`), and whether reversed; `None` if no place is shorter.
    #[inline]
    fn best_insertion(&self, i: usize, len: usize) -> Option<(isize, bool)> {
        let (n, pts) = (self.seq.len(), self.pts);
        let (first, last) = (self.seq[i], self.seq[i + len - 1]);
        let prev = self.at(i as isize - 1);
        let next = (i + len < n).then(|| pts[self.seq[i + len]]);
        let removed =
            dist(prev, pts[first]) + next.map_or(0.0, |q| dist(pts[last], q) - dist(prev, q));
        let mut best: Option<(f64, isize, bool)> = None;
        for &c in self.nb[first].iter().chain(self.nb[last].iter()) {
            let pc = self.pos[c] as isize;
            for k in [pc - 1, pc] {
                if k >= i as isize - 1 && k < (i + len) as isize {
                    continue;
                }
                let u = self.at(k);
                let v = ((k + 1) < n as isize).then(|| pts[self.seq[(k + 1) as usize]]);
                for rev in [false, true] {
                    let (x, y) = if rev { (last, first) } else { (first, last) };
                    let added = dist(u, pts[x]) + v.map_or(0.0, |v| dist(pts[y], v) - dist(u, v));
                    let d = added - removed;
                    if d < -EPS && best.is_none_or(|b| d < b.0) {
                        best = Some((d, k, rev));
                    }
                }
            }
        }
        best.map(|(_, k, rev)| (k, rev))
    }

    /// Move seq[i..i+len] (reversed if `rev`) to between old positions k and k+1.
    fn move_run(&mut self, i: usize, len: usize, k: isize, rev: bool) {
        let mut seg: Vec<usize> = self.seq.drain(i..i + len).collect();
        if rev {
            seg.reverse();
        }
        // Position k+1 in the old sequence, shifted if it was after the segment.
        let ins = if k >= (i + len) as isize {
            (k + 1) as usize - len
        } else {
            (k + 1) as usize
        };
        self.seq.splice(ins..ins, seg);
        // Only the places between the run's old and new place changed.
        self.reindex_range(i.min(ins)..(i + len).max(ins + len));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny(x: f64, y: f64) -> Loop {
        Loop {
            points: vec![[x, y], [x + 1.0, y], [x + 1.0, y + 1.0], [x, y + 1.0]],
            outline: false,
            area_mm2: 1.0,
            curve: Vec::new(),
        }
    }

    /// A deterministic scatter (a linear congruential generator; no test depends on luck).
    fn scatter(n: usize, seed: u64) -> Vec<Loop> {
        let mut s = seed;
        let mut r = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 33) as f64) / (1u64 << 31) as f64
        };
        (0..n).map(|_| tiny(r() * 300.0, r() * 300.0)).collect()
    }

    #[test]
    fn optimised_beats_naive_and_visits_every_loop_once() {
        for (n, seed) in [(5, 1), (40, 2), (300, 3)] {
            let loops = scatter(n, seed);
            let group: Vec<usize> = (0..n).collect();
            let seq = optimise(&loops, &[group], [0.0, 0.0]);
            let mut seen: Vec<usize> = seq.iter().map(|s| s.0).collect();
            seen.sort();
            assert_eq!(seen, (0..n).collect::<Vec<_>>());
            let ordered: Vec<Loop> = seq
                .iter()
                .map(|&(i, s)| {
                    let mut l = loops[i].clone();
                    l.points.rotate_left(s);
                    l
                })
                .collect();
            let opt = travel_of(&[], &ordered, [0.0, 0.0], 1);
            let naive = naive_travel(&[], &loops, [0.0, 0.0]);
            assert!(opt < naive, "n={n}: {opt} vs naive {naive}");
            if n >= 40 {
                // Random order on a square: ~0.52·side per hop; a good tour ~0.7·sqrt(n·area).
                assert!(opt < 0.4 * naive, "n={n}: {opt} vs naive {naive}");
            }
        }
    }

    #[test]
    fn points_on_a_line_are_visited_in_order() {
        // Shuffled points on a line: the optimal open path from 0 is left to right.
        let xs = [50.0, 10.0, 90.0, 30.0, 70.0, 20.0, 80.0, 40.0, 60.0];
        let loops: Vec<Loop> = xs.iter().map(|&x| tiny(x, 0.0)).collect();
        let seq = optimise(&loops, &[(0..xs.len()).collect()], [0.0, 0.0]);
        let order: Vec<f64> = seq.iter().map(|&(i, s)| loops[i].points[s][0]).collect();
        let mut sorted = order.clone();
        sorted.sort_by(f64::total_cmp);
        assert_eq!(order, sorted);
    }

    #[test]
    fn nearest_neighbour_waits_for_what_must_come_first() {
        // Loop 0 is nearest home but must wait for loop 2 (far away); 1 has no constraint.
        let loops = vec![tiny(1.0, 1.0), tiny(10.0, 0.0), tiny(100.0, 0.0)];
        let before = vec![vec![2], vec![], vec![]];
        let seq = greedy_constrained(&loops, &before, [0.0, 0.0]);
        let order: Vec<usize> = seq.iter().map(|s| s.0).collect();
        assert_eq!(order, vec![1, 2, 0]);
        assert!(respects(&seq, &before));
        assert!(!respects(&[(0, 0), (1, 0), (2, 0)], &before));
    }

    #[test]
    fn start_vertex_is_nearest_previous_end() {
        let l = Loop {
            points: vec![[10.0, 10.0], [20.0, 10.0], [20.0, 20.0], [10.0, 20.0]],
            outline: false,
            area_mm2: 100.0,
            curve: Vec::new(),
        };
        let seq = optimise(&[l], &[vec![0]], [25.0, 25.0]);
        assert_eq!(seq, vec![(0, 2)]);
    }
}
