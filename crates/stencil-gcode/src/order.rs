//! Cut order constraints: what must be cut before what, so no piece drops or shifts before the
//! cuts inside it are finished.
//!
//! - **Pieces** ([`pieces`]): an island the cuts free is held, once they are done, by its bridges
//!   alone, free to tilt and shift under cuts still to come inside it. After bridging, the cut
//!   around an island is not a ring but one arc per bridge, none of which contains anything. So
//!   the pieces come from what `make` knew before bridging (each island a hole in the cut region
//!   around it: every arc lying in that region is around the island), or, for a drawing that says
//!   nothing of bridges, from closing bridge-wide gaps between loops. Every loop inside a piece is
//!   cut before every loop around it, however many bridges there are.
//! - **Hulls** ([`containers`]): a loop lying wholly inside another's convex hull (a C with its
//!   opening closed) is cut before it: this orders nesting without bridges and single broken
//!   rings whose gap is wider than the closing.
//! - Of the loops nothing must follow, the largest is cut last: it weakens the sheet the most.
//! - The sheet's outline (`--cut-outline`) comes after everything inside it.
//!
//! The result ([`order`]) is the constraints and a sequence of groups that keeps them (by the
//! longest chain of loops that must follow each); the travel optimiser orders loops freely within
//! a group, or walks the constraints directly. [`order`] says why they never cycle.

use crate::job::Loop;
use stencil_geom::clip::{self, ClipError};
use stencil_geom::ring::{area, bbox, point_in_ring};

/// The convex hull of a ring, counter-clockwise, without a closing point (Andrew's monotone
/// chain).
pub(crate) fn convex_hull(points: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut p: Vec<[f64; 2]> = points.to_vec();
    p.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut h: Vec<[f64; 2]> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = h.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while h.len() >= start + 2 && cross(h[h.len() - 2], h[h.len() - 1], q) <= 0.0 {
                h.pop();
            }
            h.push(q);
        }
        h.pop();
    }
    h
}

/// Whether `p` lies in the counter-clockwise convex polygon `hull` (its edges count as inside,
/// within `eps` mm).
fn in_convex(p: [f64; 2], hull: &[[f64; 2]], eps: f64) -> bool {
    let n = hull.len();
    if n < 3 {
        return false;
    }
    (0..n).all(|i| {
        let (a, b) = (hull[i], hull[(i + 1) % n]);
        let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
        let len = (ex * ex + ey * ey).sqrt().max(1e-12);
        // Signed distance of p to the left of edge a -> b.
        (ex * (p[1] - a[1]) - ey * (p[0] - a[0])) / len >= -eps
    })
}

/// For each loop, the loops whose freed region (convex hull) it lies in and that are cut after
/// it: `inside[i]` lists j with loop i inside hull(j), ascending. Outline loops take no part.
///
/// Only a loop whose box holds loop i's box can hold loop i: an R-tree of the boxes (grown by the
/// tolerance) gives those containing i's lowest corner, so 60,000 separate loops cost a few
/// lookups each instead of comparing every pair (136 s before).
pub(crate) fn containers(loops: &[Loop]) -> Vec<Vec<usize>> {
    let hulls: Vec<Vec<[f64; 2]>> = loops.iter().map(|l| convex_hull(&l.points)).collect();
    let hull_area: Vec<f64> = hulls.iter().map(|h| area(h)).collect();
    let boxes: Vec<[f64; 4]> = loops.iter().map(|l| bbox(&l.points)).collect();
    // A strict order on (hull area, index): only a larger key can contain a smaller one.
    let key_less = |i: usize, j: usize| (hull_area[i], i) < (hull_area[j], j);
    let eps = 1e-7;
    let tree = box_tree(
        (0..loops.len())
            .filter(|&j| !loops[j].outline)
            .map(|j| (j, grown(boxes[j], eps))),
    );
    let mut out = vec![Vec::new(); loops.len()];
    let mut candidates: Vec<usize> = Vec::new();
    for (i, li) in loops.iter().enumerate() {
        if li.outline {
            continue;
        }
        let bi = boxes[i];
        candidates.clear();
        candidates.extend(
            tree.locate_all_at_point(&[bi[0], bi[1]])
                .map(|g| g.data)
                .filter(|&j| {
                    let bj = boxes[j];
                    !(i == j
                        || !key_less(i, j)
                        || bi[0] < bj[0] - eps
                        || bi[1] < bj[1] - eps
                        || bi[2] > bj[2] + eps
                        || bi[3] > bj[3] + eps)
                }),
        );
        candidates.sort_unstable();
        for &j in &candidates {
            // Every vertex of i in hull(j) puts all of i there: the hull is convex.
            if li.points.iter().all(|&p| in_convex(p, &hulls[j], eps)) {
                out[i].push(j);
            }
        }
    }
    out
}

/// A box with its loop's index, as the R-trees here hold them.
pub(crate) type BoxOf =
    rstar::primitives::GeomWithData<rstar::primitives::Rectangle<[f64; 2]>, usize>;

/// An R-tree of `(index, [min x, min y, max x, max y])` boxes (bulk-loaded).
pub(crate) fn box_tree(boxes: impl Iterator<Item = (usize, [f64; 4])>) -> rstar::RTree<BoxOf> {
    rstar::RTree::bulk_load(boxes.map(|(j, b)| box_of(j, b)).collect())
}

/// One box of a [`box_tree`].
pub(crate) fn box_of(j: usize, b: [f64; 4]) -> BoxOf {
    BoxOf::new(
        rstar::primitives::Rectangle::from_corners([b[0], b[1]], [b[2], b[3]]),
        j,
    )
}

/// A cut region as designed before bridging, in machine mm: its outline and its holes (each the
/// outline of an island lying in it).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Region {
    pub exterior: Vec<[f64; 2]>,
    pub holes: Vec<Vec<[f64; 2]>>,
}

/// What the planner knows of the pieces the cuts free.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Gaps {
    /// The cut regions before bridging (`make` knows them): each island is a hole in the region
    /// around it, and the cut loops lying in that region, whatever bridges break it into, are
    /// the cuts around the island.
    Regions(Vec<Region>),
    /// Nothing is known about bridges (a drawing from another program): any gap of up to
    /// `2 * r_mm` between cut loops is taken for a bridge (a morphological closing of the loops),
    /// and the regions are the closed loops' union.
    Closing { r_mm: f64 },
    /// Known to hold no islands: no piece is held by bridges.
    None,
}

/// A piece of material the cuts free: an island, enclosed by cut loops and the bridges (or gaps)
/// between them. Cutting the last of `around` leaves it hanging on its bridges alone; every loop
/// in `inside` must be cut before then, while it is still held all round.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Piece {
    /// Loops lying inside it (at any depth), ascending.
    pub inside: Vec<usize>,
    /// The loops that, with the bridges, surround it, ascending.
    pub around: Vec<usize>,
}

/// Arc tolerance of the closing's round joins, mm.
const ARC_TOLERANCE_MM: f64 = 0.01;

/// A point well inside a ring (not on its edge): the middle of the widest stretch inside it along
/// one of a few horizontal lines across it. `None` for a ring with no inside.
pub(crate) fn interior_point(ring: &[[f64; 2]]) -> Option<[f64; 2]> {
    let b = bbox(ring);
    let h = b[3] - b[1];
    if h.is_nan() || h <= 0.0 {
        return None;
    }
    let mut best: Option<([f64; 2], f64)> = None;
    let mut xs: Vec<f64> = Vec::new();
    // Slightly off the simple fractions, so the lines miss vertices of drawn or traced shapes.
    for t in [0.5, 0.3, 0.7, 0.15, 0.85] {
        let y = b[1] + h * (t + 1.234_567e-4);
        xs.clear();
        let n = ring.len();
        for i in 0..n {
            let (a, c) = (ring[i], ring[(i + 1) % n]);
            if (a[1] > y) != (c[1] > y) {
                xs.push(a[0] + (y - a[1]) / (c[1] - a[1]) * (c[0] - a[0]));
            }
        }
        xs.sort_by(f64::total_cmp);
        for pair in xs.chunks_exact(2) {
            let w = pair[1] - pair[0];
            if best.is_none_or(|(_, bw)| w > bw) {
                best = Some(([(pair[0] + pair[1]) / 2.0, y], w));
            }
        }
    }
    best.filter(|b| b.1 > 0.0).map(|b| b.0)
}

fn grown(b: [f64; 4], d: f64) -> [f64; 4] {
    [b[0] - d, b[1] - d, b[2] + d, b[3] + d]
}

/// Groups of overlapping boxes (union-find over a sweep in x): the indices of each group with more
/// than one member, ascending.
fn clusters(boxes: &[[f64; 4]]) -> Vec<Vec<usize>> {
    let n = boxes.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let mut by_x: Vec<usize> = (0..n).filter(|&i| boxes[i][0].is_finite()).collect();
    by_x.sort_by(|&a, &b| boxes[a][0].total_cmp(&boxes[b][0]).then(a.cmp(&b)));
    for (k, &i) in by_x.iter().enumerate() {
        for &j in &by_x[k + 1..] {
            if boxes[j][0] > boxes[i][2] {
                break;
            }
            if boxes[i][1] <= boxes[j][3] && boxes[j][1] <= boxes[i][3] {
                let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
    }
    let mut groups: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for i in 0..n {
        let r = find(&mut parent, i);
        groups.entry(r).or_default().push(i);
    }
    groups.into_values().filter(|g| g.len() > 1).collect()
}

fn polygon(points: &[[f64; 2]]) -> geo::Polygon<f64> {
    use geo::orient::{Direction, Orient};
    let mut ring: Vec<geo::Coord<f64>> = points
        .iter()
        .map(|p| geo::Coord { x: p[0], y: p[1] })
        .collect();
    if let Some(&f) = ring.first() {
        ring.push(f);
    }
    geo::Polygon::new(geo::LineString::new(ring), vec![]).orient(Direction::Default)
}

fn ring_of(ls: &geo::LineString<f64>) -> Vec<[f64; 2]> {
    let mut v: Vec<[f64; 2]> = ls.0.iter().map(|c| [c.x, c.y]).collect();
    if v.len() > 1 && v.first() == v.last() {
        v.pop();
    }
    v
}

/// The regions a drawing's cut loops enclose when every gap of up to `2 * r` between them is
/// closed: the loops grown by `r`, unioned, shrunk back by `r` (the closing keeps every edge a
/// disc of radius `r` can touch from outside, so the holes are the pieces at their true size;
/// a piece narrower than `2 * r` closes up). Only loops within a gap of another loop take part:
/// one loop alone frees nothing its convex hull (see [`containers`]) does not already cover.
fn closed_regions(loops: &[Loop], r: f64) -> Result<Vec<Region>, ClipError> {
    let cut: Vec<usize> = (0..loops.len()).filter(|&i| !loops[i].outline).collect();
    let boxes: Vec<[f64; 4]> = cut
        .iter()
        .map(|&i| grown(bbox(&loops[i].points), r))
        .collect();
    let groups = clusters(&boxes);
    let grown_loops: Vec<Vec<geo::Polygon<f64>>> = groups
        .iter()
        .map(|g| {
            let polys: Vec<geo::Polygon<f64>> =
                g.iter().map(|&k| polygon(&loops[cut[k]].points)).collect();
            clip::offset_each(&polys, r, ARC_TOLERANCE_MM)
                .map(|v| v.into_iter().flat_map(|m| m.0).collect())
        })
        .collect::<Result<_, _>>()?;
    let mut out = Vec::new();
    for union in clip::union_each(&grown_loops)? {
        // Only a polygon with holes can enclose a piece.
        let holed: Vec<geo::Polygon<f64>> = union
            .0
            .into_iter()
            .filter(|p| !p.interiors().is_empty())
            .collect();
        for m in clip::offset_each(&holed, -r, ARC_TOLERANCE_MM)? {
            for p in m.0 {
                if !p.interiors().is_empty() {
                    out.push(Region {
                        exterior: ring_of(p.exterior()),
                        holes: p.interiors().iter().map(ring_of).collect(),
                    });
                }
            }
        }
    }
    Ok(out)
}

/// The pieces the cut loops free, with the loops inside and around each: for each region with
/// holes (see [`Gaps`]), each hole is a piece; a loop lies inside it when a point well inside the
/// loop (see [`interior_point`]) lies in the hole, and is one of the loops around it when that
/// point lies in the region's body (inside its outline, in none of its holes). A region with
/// several islands in it counts all its loops as around each: they cut out the islands together.
pub(crate) fn pieces(loops: &[Loop], gaps: &Gaps) -> Result<Vec<Piece>, ClipError> {
    let closed;
    let regions: &[Region] = match gaps {
        Gaps::None => return Ok(Vec::new()),
        Gaps::Regions(r) => r,
        Gaps::Closing { r_mm } if *r_mm > 0.0 && r_mm.is_finite() => {
            closed = closed_regions(loops, *r_mm)?;
            &closed
        }
        Gaps::Closing { .. } => return Ok(Vec::new()),
    };
    let inner: Vec<(usize, [f64; 2])> = (0..loops.len())
        .filter(|&i| !loops[i].outline)
        .filter_map(|i| interior_point(&loops[i].points).map(|p| (i, p)))
        .collect();
    let in_box =
        |p: [f64; 2], b: &[f64; 4]| p[0] >= b[0] && p[0] <= b[2] && p[1] >= b[1] && p[1] <= b[3];
    // The points by place, so that each region looks only at those in its box (a drawing of
    // thousands of rings, each a region, compared every region with every loop).
    let points = rstar::RTree::bulk_load(
        inner
            .iter()
            .enumerate()
            .map(|(k, &(_, p))| rstar::primitives::GeomWithData::new(p, k))
            .collect(),
    );
    let mut near: Vec<usize> = Vec::new();
    let mut out = Vec::new();
    for region in regions
        .iter()
        .filter(|r| !r.holes.is_empty() && r.exterior.len() >= 3)
    {
        let eb = bbox(&region.exterior);
        let hb: Vec<[f64; 4]> = region.holes.iter().map(|h| bbox(h)).collect();
        let in_hole = |p: [f64; 2]| {
            (0..region.holes.len())
                .find(|&k| in_box(p, &hb[k]) && point_in_ring(p, &region.holes[k]))
        };
        let mut around = Vec::new();
        let mut inside: Vec<Vec<usize>> = vec![Vec::new(); region.holes.len()];
        near.clear();
        near.extend(
            points
                .locate_in_envelope(&rstar::AABB::from_corners([eb[0], eb[1]], [eb[2], eb[3]]))
                .map(|g| g.data),
        );
        // In the loops' order, as a scan of them all found them.
        near.sort_unstable();
        for &(i, p) in near.iter().map(|&k| &inner[k]) {
            if !in_box(p, &eb) || !point_in_ring(p, &region.exterior) {
                continue;
            }
            match in_hole(p) {
                Some(k) => inside[k].push(i),
                None => around.push(i),
            }
        }
        if around.is_empty() {
            continue;
        }
        for inside in inside.into_iter().filter(|i| !i.is_empty()) {
            let around = around.clone();
            out.push(Piece { inside, around });
        }
    }
    Ok(out)
}

/// The cut order: what must be cut before what, and the loops layered into groups that keep it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Order {
    /// Groups of loop indices, to be cut group after group; the travel optimiser orders loops
    /// freely within a group.
    pub groups: Vec<Vec<usize>>,
    /// For each loop, the loops that must be cut before it.
    pub before: Vec<Vec<usize>>,
}

/// The cut order of `loops`, by the rules the module lists; a hull constraint is kept only where
/// it does not contradict the pieces.
///
/// Why it cannot cycle: a loop's piece depth (how many pieces it lies in) is strictly greater than
/// that of every loop around a piece it lies in; hull constraints are kept only from a piece depth
/// to an equal or smaller one, and among equal depths they follow the strict key (hull area, then
/// index) of [`containers`]. Every constraint so descends in (piece depth, -key), which never
/// returns.
pub(crate) fn order(loops: &[Loop], gaps: &Gaps) -> Order {
    let n = loops.len();
    // Geometry Clipper refuses (see `clip`) only loses the piece constraints; hulls still order.
    let pieces = pieces(loops, gaps).unwrap_or_default();
    let mut before = constraints(loops, &pieces);
    let level = levels(&before);
    let regions: Vec<usize> = (0..n).filter(|&i| !loops[i].outline).collect();
    let max_level = regions.iter().map(|&i| level[i]).max().unwrap_or(0);
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for d in (0..=max_level).rev() {
        let g: Vec<usize> = regions.iter().copied().filter(|&i| level[i] == d).collect();
        if !g.is_empty() {
            groups.push(g);
        }
    }
    largest_last(loops, &regions, &mut groups, &mut before);
    let outline: Vec<usize> = (0..n).filter(|&i| loops[i].outline).collect();
    for &i in &outline {
        before[i] = regions.clone();
    }
    if !outline.is_empty() {
        groups.push(outline);
    }
    Order { groups, before }
}

/// For each loop, the loops that must be cut before it (sorted, once each): those inside a piece
/// it lies around, then those inside its convex hull where the piece depths allow (see [`order`]
/// for why that cannot cycle).
fn constraints(loops: &[Loop], pieces: &[Piece]) -> Vec<Vec<usize>> {
    let n = loops.len();
    let mut depth = vec![0usize; n];
    for p in pieces {
        p.inside.iter().for_each(|&i| depth[i] += 1);
    }
    let mut before: Vec<Vec<usize>> = vec![Vec::new(); n];
    for p in pieces {
        for &j in &p.around {
            for &i in &p.inside {
                if depth[i] > depth[j] {
                    before[j].push(i);
                }
            }
        }
    }
    for (i, cs) in containers(loops).into_iter().enumerate() {
        for j in cs {
            if depth[i] >= depth[j] {
                before[j].push(i);
            }
        }
    }
    for b in &mut before {
        b.sort_unstable();
        b.dedup();
    }
    before
}

/// Each loop's layer: how long the longest chain of loops that must follow it is (Kahn's order
/// from the loops nothing follows). Cutting layer by layer, deepest first, keeps every constraint
/// while leaving the travel optimiser free within a layer.
fn levels(before: &[Vec<usize>]) -> Vec<usize> {
    let n = before.len();
    let mut after_count: Vec<usize> = vec![0; n];
    for b in before {
        b.iter().for_each(|&i| after_count[i] += 1);
    }
    let mut level = vec![0usize; n];
    let mut ready: Vec<usize> = (0..n).filter(|&i| after_count[i] == 0).collect();
    while let Some(j) = ready.pop() {
        for &i in &before[j] {
            level[i] = level[i].max(level[j] + 1);
            after_count[i] -= 1;
            if after_count[i] == 0 {
                ready.push(i);
            }
        }
    }
    level
}

/// Move the largest of the loops nothing follows (the last group) into a group of its own after
/// it, and make every other region come before it: it weakens the sheet the most, so it is cut
/// when nothing else needs the sheet's support.
fn largest_last(
    loops: &[Loop],
    regions: &[usize],
    groups: &mut Vec<Vec<usize>>,
    before: &mut [Vec<usize>],
) {
    let Some(top) = groups.last_mut() else {
        return;
    };
    if top.len() > 1 {
        // The first of the largest.
        let area = |k: usize| loops[top[k]].area_mm2;
        let k = (1..top.len()).fold(0, |best, k| if area(k) > area(best) { k } else { best });
        let largest = top.remove(k);
        before[largest] = regions.iter().copied().filter(|&i| i != largest).collect();
        groups.push(vec![largest]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nesting depth of each loop among the non-outline loops (0 = inside no other loop's convex
    /// hull): how many loops it must be cut before by hulls alone.
    fn depths(loops: &[Loop]) -> Vec<usize> {
        containers(loops).iter().map(Vec::len).collect()
    }

    /// The groups of [`order`] without piece data (hulls only).
    fn groups(loops: &[Loop]) -> Vec<Vec<usize>> {
        order(loops, &Gaps::None).groups
    }

    fn sq(x: f64, y: f64, s: f64, outline: bool) -> Loop {
        Loop {
            points: vec![[x, y], [x + s, y], [x + s, y + s], [x, y + s]],
            outline,
            area_mm2: s * s,
            curve: Vec::new(),
        }
    }

    #[test]
    fn nested_inner_first_largest_then_outline_last() {
        let loops = vec![
            sq(0.0, 0.0, 100.0, true), // outline
            sq(10.0, 10.0, 50.0, false),
            sq(20.0, 20.0, 10.0, false), // inside the 50 square
            sq(70.0, 70.0, 5.0, false),
            sq(70.0, 10.0, 20.0, false),
        ];
        assert_eq!(depths(&loops), vec![0, 0, 1, 0, 0]);
        let g = groups(&loops);
        assert_eq!(g, vec![vec![2], vec![3, 4], vec![1], vec![0]]);
    }

    /// A ring of 32 points with a gap (a C, as bridging leaves a cut around an island).
    fn c_shape(cx: f64, cy: f64, r_out: f64, r_in: f64) -> Loop {
        let arc = |r: f64, rev: bool| -> Vec<[f64; 2]> {
            let mut v: Vec<[f64; 2]> = (0..=30)
                .map(|k| {
                    let a = 0.3 + k as f64 / 30.0 * (std::f64::consts::TAU - 0.6);
                    [cx + r * a.cos(), cy + r * a.sin()]
                })
                .collect();
            if rev {
                v.reverse();
            }
            v
        };
        let mut points = arc(r_out, false);
        points.extend(arc(r_in, true));
        let a = std::f64::consts::PI * (r_out * r_out - r_in * r_in);
        Loop {
            points,
            outline: false,
            area_mm2: a,
            curve: Vec::new(),
        }
    }

    #[test]
    fn cuts_inside_a_c_shaped_cut_come_first() {
        // Three Cs nested like the rings sample, and a dot in the middle; the outer C is the
        // largest by area, yet nothing inside its opening may come after it.
        let loops = vec![
            c_shape(50.0, 50.0, 40.0, 35.0),
            sq(48.0, 48.0, 4.0, false),
            c_shape(50.0, 50.0, 20.0, 15.0),
            c_shape(50.0, 50.0, 30.0, 25.0),
            sq(120.0, 50.0, 5.0, false), // beside, inside nothing
        ];
        assert_eq!(depths(&loops), vec![0, 3, 2, 1, 0]);
        let g = groups(&loops);
        assert_eq!(g, vec![vec![1], vec![2], vec![3], vec![4], vec![0]]);
        // Two loops with the same hull: one goes first, no cycle.
        let twins = vec![sq(0.0, 0.0, 10.0, false), sq(0.0, 0.0, 10.0, false)];
        assert_eq!(depths(&twins), vec![1, 0]);
    }

    #[test]
    fn hull_of_a_c_is_its_disc() {
        let c = c_shape(0.0, 0.0, 10.0, 8.0);
        let h = convex_hull(&c.points);
        assert!(in_convex([0.0, 0.0], &h, 0.0));
        assert!(in_convex([9.0, 0.0], &h, 0.0), "the opening is closed");
        assert!(!in_convex([10.5, 0.0], &h, 0.0));
        assert!((area(&h) - std::f64::consts::PI * 100.0).abs() < 0.05 * 314.0);
    }

    #[test]
    fn point_in_ring_basics() {
        let r = sq(0.0, 0.0, 10.0, false).points;
        assert!(point_in_ring([5.0, 5.0], &r));
        assert!(!point_in_ring([15.0, 5.0], &r));
        assert!(!point_in_ring([-1.0, 5.0], &r));
    }

    /// A part of the ring `r_in..r_out` from angle `a0` to `a1`: a cut arc, as bridges leave it.
    fn arc(c: [f64; 2], r_in: f64, r_out: f64, a0: f64, a1: f64) -> Loop {
        let at = |r: f64, k: usize| {
            let a = a0 + (a1 - a0) * k as f64 / 24.0;
            [c[0] + r * a.cos(), c[1] + r * a.sin()]
        };
        let mut points: Vec<[f64; 2]> = (0..=24).map(|k| at(r_out, k)).collect();
        points.extend((0..=24).rev().map(|k| at(r_in, k)));
        Loop {
            points,
            outline: false,
            area_mm2: (a1 - a0) / 2.0 * (r_out * r_out - r_in * r_in),
            curve: Vec::new(),
        }
    }

    fn circle(c: [f64; 2], r: f64, n: usize) -> Vec<[f64; 2]> {
        (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                [c[0] + r * a.cos(), c[1] + r * a.sin()]
            })
            .collect()
    }

    /// A target: the outer ring (15..17) and the middle ring (6..8) each broken into two arcs by
    /// two bridges, a dot (r 2) in the middle. Loops 0, 1: outer arcs; 2, 3: middle arcs; 4: dot.
    fn two_bridge_target() -> Vec<Loop> {
        use std::f64::consts::PI;
        let c = [50.0, 50.0];
        // Half of a 2 mm gap, as an angle at the ring's middle.
        let (g, h) = (1.0 / 16.0, 1.0 / 7.0);
        vec![
            arc(c, 15.0, 17.0, g, PI - g),
            arc(c, 15.0, 17.0, PI + g, 2.0 * PI - g),
            arc(c, 6.0, 8.0, PI / 2.0 + h, 1.5 * PI - h),
            arc(c, 6.0, 8.0, -PI / 2.0 + h, PI / 2.0 - h),
            Loop {
                points: circle(c, 2.0, 24),
                outline: false,
                area_mm2: 12.5,
                curve: Vec::new(),
            },
        ]
    }

    fn respects(order: &Order, n: usize) -> bool {
        let seq: Vec<usize> = order.groups.iter().flatten().copied().collect();
        let mut pos = vec![usize::MAX; n];
        seq.iter().enumerate().for_each(|(k, &i)| pos[i] = k);
        seq.len() == n
            && order
                .before
                .iter()
                .enumerate()
                .all(|(j, b)| b.iter().all(|&i| pos[i] < pos[j]))
    }

    #[test]
    fn what_lies_in_an_island_held_by_two_bridges_comes_before_both_arcs() {
        let loops = two_bridge_target();
        let c = [50.0, 50.0];
        // As `make` knows it: before bridging, each cut ring is one region with its island as a
        // hole (the paper disc inside the outer ring, the paper ring inside the middle one).
        let regions = vec![
            Region {
                exterior: circle(c, 17.0, 64),
                holes: vec![circle(c, 15.0, 64)],
            },
            Region {
                exterior: circle(c, 8.0, 64),
                holes: vec![circle(c, 6.0, 64)],
            },
        ];
        // Without pieces, the hull rule alone cannot see it: the dot lies in neither half.
        let hulls = containers(&loops);
        assert!(
            !hulls[4].contains(&0) && !hulls[4].contains(&1),
            "{hulls:?}"
        );
        for gaps in [Gaps::Regions(regions), Gaps::Closing { r_mm: 1.5 }] {
            let o = order(&loops, &gaps);
            let mut p: Vec<(Vec<usize>, Vec<usize>)> = pieces(&loops, &gaps)
                .unwrap()
                .iter()
                .map(|p| (p.inside.clone(), p.around.clone()))
                .collect();
            p.sort();
            assert_eq!(
                p,
                vec![(vec![2, 3, 4], vec![0, 1]), (vec![4], vec![2, 3])],
                "{gaps:?}"
            );
            for outer in [0, 1] {
                for inner in [2, 3, 4] {
                    assert!(o.before[outer].contains(&inner), "{outer} after {inner}");
                }
            }
            assert!(o.before[2].contains(&4) && o.before[3].contains(&4));
            assert!(respects(&o, loops.len()), "{:?}", o.groups);
            assert_eq!(o.groups[0], vec![4], "the dot first");
        }
        // Gaps wider than the closing: nothing is taken for a piece.
        assert!(pieces(&loops, &Gaps::Closing { r_mm: 0.5 })
            .unwrap()
            .is_empty());
    }

    #[test]
    fn a_hull_that_contradicts_a_piece_gives_way() {
        // A U-shaped island (a hole in the square region) with a U-shaped cut in it, and a small
        // cut in the U's notch, which is part of the region around the island: the piece says
        // the U cut first, the U cut's hull (which holds the small cut) says the other way.
        let sq = |x0: f64, y0: f64, x1: f64, y1: f64| vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
        let u = |x0: f64, y0: f64, x1: f64, y1: f64, nx0: f64, nx1: f64, ny: f64| {
            vec![
                [x0, y0],
                [x1, y0],
                [x1, y1],
                [nx1, y1],
                [nx1, ny],
                [nx0, ny],
                [nx0, y1],
                [x0, y1],
            ]
        };
        let region = Region {
            exterior: sq(0.0, 0.0, 100.0, 100.0),
            holes: vec![u(10.0, 10.0, 90.0, 90.0, 40.0, 60.0, 30.0)],
        };
        let lp = |points: Vec<[f64; 2]>| Loop {
            area_mm2: area(&points),
            points,
            outline: false,
            curve: Vec::new(),
        };
        let loops = vec![
            lp(sq(45.0, 60.0, 55.0, 70.0)), // in the notch: around
            lp(u(20.0, 20.0, 80.0, 80.0, 35.0, 65.0, 25.0)), // in the island
            lp(sq(0.0, 0.0, 100.0, 5.0)),   // around too
        ];
        assert_eq!(
            containers(&loops)[0],
            vec![1],
            "the small cut lies in the U's hull"
        );
        let gaps = Gaps::Regions(vec![region]);
        let p = pieces(&loops, &gaps).unwrap();
        let o = order(&loops, &gaps);
        assert_eq!(p.len(), 1);
        assert_eq!(
            (p[0].inside.clone(), p[0].around.clone()),
            (vec![1], vec![0, 2])
        );
        assert!(o.before[0].contains(&1) && !o.before[1].contains(&0));
        assert!(respects(&o, loops.len()), "{:?}", o.groups);
    }

    #[test]
    fn interior_points_lie_well_inside() {
        for l in [
            c_shape(0.0, 0.0, 10.0, 8.0),
            sq(3.0, 4.0, 0.5, false),
            two_bridge_target()[2].clone(),
        ] {
            let p = interior_point(&l.points).unwrap();
            assert!(point_in_ring(p, &l.points), "{p:?}");
            let h = convex_hull(&l.points);
            // Not on an edge: a little way in every direction is still inside.
            for d in [[0.05, 0.0], [-0.05, 0.0], [0.0, 0.05], [0.0, -0.05]] {
                let q = [p[0] + d[0], p[1] + d[1]];
                assert!(
                    point_in_ring(q, &l.points) && in_convex(q, &h, 0.0),
                    "{q:?}"
                );
            }
        }
        assert_eq!(interior_point(&[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]), None);
    }
}
