//! Every call into Clipper (geo-clipper) goes through here, after [`check_rings`] and a work
//! estimate.
//!
//! Why a gate: Clipper works on integers (coordinates times [`CLIPPER_FACTOR`]). geo-clipper
//! converts with `to_i64().unwrap()`, which panics on NaN, infinities and anything past `i64`, and
//! Clipper itself throws a C++ exception, which aborts the process, for a coordinate past about
//! 4.6e18 units. So every coordinate must be finite and within [`MAX_COORD_MM`] before it is
//! handed over; [`check_rings`] says which is not, and callers name the file or option it came
//! from.
//!
//! Why an estimate: Clipper sweeps a line across the shapes, and for every scanbeam (the band
//! between two consecutive vertex heights) walks every edge that crosses the band, a few times,
//! and bubble-sorts them; each crossing of two edges becomes a vertex of its output, and its
//! bookkeeping of output rings grows with their square. A path whose edges all span the sheet (a
//! zigzag, a comb, a scribble) made that quadratic: 140,000 points took minutes and gigabytes.
//! `sweep` counts Clipper's walks (on its integer grid, as it sees them) and the crossings,
//! stopping at the limit, so that
//! - a shape that is cheap to sweep the other way (edges all near-vertical) is turned a quarter
//!   turn for Clipper and back (exact in floating point);
//! - a job past [`MAX_SWEEP_WORK`] either way is refused at once;
//! - an offset (the kerf) of a path that crosses itself more than [`MAX_SELF_CROSSINGS`] times is
//!   refused: Clipper's offset first splits such a path at every crossing, and a few thousand
//!   pieces took seconds to minutes. (A cut outline that crosses itself has no inside to cut
//!   anyway; stencils from `make` never do.)
//!
//! Measured on the 2-core test machine (a debug build: Clipper is compiled optimised either way),
//! Clipper does about 3 to 5e7 of these steps per second; a comb of 40,000 points, estimated at
//! 2e9, took 103 s swept along y and 0.02 s turned.

use geo::{Coord, LineString, MultiPolygon, Polygon};
use geo_clipper::{Clipper, EndType, JoinType};
use rayon::prelude::*;

/// Clipper's integer scale: coordinates in mm are multiplied by this (1 unit = 0.1 µm).
pub const CLIPPER_FACTOR: f64 = 1e4;

/// The largest coordinate (absolute value, mm) handed to Clipper: 1000 km. Times
/// [`CLIPPER_FACTOR`] that is 1e13 units, far inside the 4.6e18 Clipper accepts, with room for an
/// offset and for its 128-bit products.
pub const MAX_COORD_MM: f64 = 1e9;

/// The most sweep steps (see `sweep`) one call may take, all its jobs together: a few seconds
/// on the test machine. The stencils `make` writes need a few per vertex.
pub const MAX_SWEEP_WORK: f64 = 1e8;

/// The most times the paths given to one offset may cross themselves (see the module notes).
pub const MAX_SELF_CROSSINGS: usize = 1000;

/// The largest offset distance, mm.
pub const MAX_OFFSET_MM: f64 = 1000.0;

/// Why geometry cannot be handed to Clipper. Callers add the file or option it came from.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ClipError {
    /// A coordinate is NaN or infinite.
    #[error("point ({x}, {y}) is not a finite number")]
    NotFinite {
        /// The point, mm.
        x: f64,
        /// The point, mm.
        y: f64,
    },
    /// A point beyond the clipper's integer range.
    #[error(
        "point ({x:e}, {y:e}) mm is beyond ±{MAX_COORD_MM:e} mm (1000 km), the range the polygon \
         clipper works in"
    )]
    OutOfRange {
        /// The point, mm.
        x: f64,
        /// The point, mm.
        y: f64,
    },
    /// An offset distance, mm, NaN or too large.
    #[error("an offset of {0} mm is not a finite distance within ±{MAX_OFFSET_MM} mm")]
    Offset(f64),
    /// An outline that crosses itself, where offsets need simple ones.
    #[error(
        "a path crosses itself {} times (the first near x {:.3}, y {:.3} mm); a cut outline \
         must be a simple closed shape: remove the crossings (e.g. Inkscape: Path > Union) or \
         split it into separate shapes",
        if *crossings > MAX_SELF_CROSSINGS {
            format!("more than {MAX_SELF_CROSSINGS}")
        } else {
            crossings.to_string()
        },
        at[0], at[1]
    )]
    SelfCrossing {
        /// How many crossings (counting stops past the limit).
        crossings: usize,
        /// The first crossing, mm.
        at: [f64; 2],
    },
    /// One tangle of paths too costly to sweep.
    #[error(
        "the paths are too tangled to process in reasonable time: about {work:.1e} sweep steps \
         (the limit is {MAX_SWEEP_WORK:.0e}), with up to {max_active} edges across one line; \
         simplify them or split them into smaller shapes"
    )]
    TooComplex {
        /// The estimated sweep steps.
        work: f64,
        /// The most edges across one sweep line.
        max_active: usize,
    },
    /// Many shapes, each cheap, too many together: the count is the cause, not a tangle.
    #[error(
        "{shapes} shapes are too many to process in reasonable time: together about {work:.1e} \
         sweep steps (the limit is {MAX_SWEEP_WORK:.0e}), so about {fit} shapes like these at \
         once; split the drawing into parts of fewer shapes and make a job of each"
    )]
    TooMany {
        /// How many shapes.
        shapes: usize,
        /// Their estimated sweep steps together.
        work: f64,
        /// About how many of these shapes fit under the limit.
        fit: usize,
    },
}

/// Check that every point of `rings` is finite and within [`MAX_COORD_MM`]: what Clipper can take,
/// and what any later stage can compute with.
pub fn check_rings<'a>(
    rings: impl IntoIterator<Item = &'a LineString<f64>>,
) -> Result<(), ClipError> {
    rings
        .into_iter()
        .flat_map(|r| r.0.iter())
        .try_for_each(|c| check_point(c.x, c.y))
}

/// [`check_rings`] for one point.
pub fn check_point(x: f64, y: f64) -> Result<(), ClipError> {
    if !(x.is_finite() && y.is_finite()) {
        Err(ClipError::NotFinite { x, y })
    } else if x.abs() > MAX_COORD_MM || y.abs() > MAX_COORD_MM {
        Err(ClipError::OutOfRange { x, y })
    } else {
        Ok(())
    }
}

fn rings_of(p: &Polygon<f64>) -> impl Iterator<Item = &LineString<f64>> {
    std::iter::once(p.exterior()).chain(p.interiors())
}

/// A quarter turn counter-clockwise (orientation kept), or `back`: exact in floating point.
fn turn(p: &Polygon<f64>, back: bool) -> Polygon<f64> {
    let f = |c: &Coord<f64>| {
        if back {
            Coord { x: c.y, y: -c.x }
        } else {
            Coord { x: -c.y, y: c.x }
        }
    };
    let r = |l: &LineString<f64>| LineString::new(l.0.iter().map(f).collect());
    Polygon::new(r(p.exterior()), p.interiors().iter().map(r).collect())
}

fn turn_all(m: &MultiPolygon<f64>, back: bool) -> MultiPolygon<f64> {
    MultiPolygon::new(m.0.iter().map(|p| turn(p, back)).collect())
}

/// The path Clipper's offset resolves (a union) after moving the edges: each vertex moved `delta`
/// along its edges' normals, joined round with `steps_per_rad` points per radian of turn (as
/// Clipper's `DoRound` counts them). Only the cost model reads it.
fn raw_offset(p: &Polygon<f64>, delta: f64, steps_per_rad: f64) -> Polygon<f64> {
    let ring = |r: &LineString<f64>| {
        let mut pts: Vec<Coord<f64>> = r.0.clone();
        if pts.len() > 1 && pts.first() == pts.last() {
            pts.pop();
        }
        let n = pts.len();
        let normal = |j: usize| {
            let (a, b) = (pts[j], pts[(j + 1) % n]);
            let (dx, dy) = (b.x - a.x, b.y - a.y);
            let l = dx.hypot(dy);
            if l > 0.0 {
                (dy / l, -dx / l)
            } else {
                (0.0, 0.0)
            }
        };
        let mut out = Vec::with_capacity(n * 3);
        for (j, &p) in pts.iter().enumerate() {
            let (nk, nj) = (normal((j + n - 1) % n), normal(j));
            let a0 = nk.1.atan2(nk.0);
            let mut turn = nj.1.atan2(nj.0) - a0;
            if turn > std::f64::consts::PI {
                turn -= std::f64::consts::TAU;
            } else if turn < -std::f64::consts::PI {
                turn += std::f64::consts::TAU;
            }
            let steps = ((steps_per_rad * turn.abs()).round() as usize).max(1);
            for i in 0..=steps {
                let a = a0 + turn * i as f64 / steps as f64;
                out.push(Coord {
                    x: p.x + delta * a.cos(),
                    y: p.y + delta * a.sin(),
                });
            }
        }
        LineString::new(out)
    };
    Polygon::new(ring(p.exterior()), p.interiors().iter().map(ring).collect())
}

/// What one Clipper sweep over some shapes costs (see `sweep`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Sweep {
    /// Steps: edges walked per beam (once, once more per place the farthest-moving edge moves
    /// left in the bubble sort, and once per local minimum starting there), plus crossings. Past
    /// the cap when counting stopped there.
    pub work: f64,
    /// Crossings of two edges (counted up to the crossing cap, then one more).
    pub crossings: usize,
    /// Where the first crossing found is, in mm (in the frame of the shapes given).
    pub first_crossing: Option<[f64; 2]>,
    /// The most edges active across one beam.
    pub max_active: usize,
}

/// Clipper's sweep over `polys`, counted as it would run it (on its integer grid); with `turned`,
/// over the shapes turned a quarter turn (a sweep along x). Counting stops once the work passes
/// `max_work` or the crossings pass `max_crossings`.
pub(crate) fn sweep(
    polys: &[&Polygon<f64>],
    turned: bool,
    max_work: f64,
    max_crossings: usize,
) -> Sweep {
    let (mut edges, ys) = sweep_edges(polys, turned);
    let mut out = Sweep::default();
    // First only the number of edges across each beam: if walking them once is already past the
    // limit, stop here.
    let (walks, max_active) = walks_per_beam(&edges, &ys);
    out.max_active = max_active;
    if walks > max_work {
        out.work = walks;
        return out;
    }
    // Then beam by beam as Clipper goes: the active edges in order along x at the beam's bottom,
    // then sorted by x at its top (an insertion sort: each edge's swaps are crossings, and how far
    // it moves left).
    edges.sort_unstable_by(|a, b| a[0].total_cmp(&b[0]));
    let mut active = ActiveEdges::default();
    let mut next = 0usize;
    for w in ys.windows(2) {
        let (y0, y1) = (w[0], w[1]);
        active.order.retain(|&e| edges[e][1] > y0);
        let first_new = next;
        while next < edges.len() && edges[next][0] <= y0 {
            next += 1;
        }
        if next > first_new {
            active.insert_starting(&edges, first_new..next, y0, y1);
        }
        let farthest = active.sort_at_top(&edges, y0, y1, turned, &mut out);
        out.work += active.order.len() as f64 * ((1 + farthest) as f64 + minima(next - first_new));
        if out.work + out.crossings as f64 > max_work || out.crossings > max_crossings {
            break;
        }
        active.take_top_order();
    }
    out.work += out.crossings as f64;
    out
}

/// The non-horizontal edges of `polys` as (y low, y high, x at low, x at high), and every vertex
/// height (sorted, once each: the beams' bounds), on Clipper's integer grid and in the sweep's
/// frame (turned a quarter turn with `turned`), since that is what Clipper's cost depends on.
fn sweep_edges(polys: &[&Polygon<f64>], turned: bool) -> (Vec<[f64; 4]>, Vec<f64>) {
    let mut edges: Vec<[f64; 4]> = Vec::new();
    let mut ys: Vec<f64> = Vec::new();
    let q = |v: f64| (v * CLIPPER_FACTOR).round();
    for p in polys {
        for r in rings_of(p) {
            let pts = &r.0;
            let n = pts.len();
            for i in 0..n {
                let (a, b) = (pts[i], pts[(i + 1) % n]);
                let (ax, ay, bx, by) = if turned {
                    (q(-a.y), q(a.x), q(-b.y), q(b.x))
                } else {
                    (q(a.x), q(a.y), q(b.x), q(b.y))
                };
                ys.push(ay);
                if ay < by {
                    edges.push([ay, by, ax, bx]);
                } else if by < ay {
                    edges.push([by, ay, bx, ax]);
                }
            }
        }
    }
    ys.sort_unstable_by(f64::total_cmp);
    ys.dedup();
    (edges, ys)
}

/// A lower bound of the sweep's work, cheap to count (sorting, no geometry): each beam's edges
/// (started at or below its bottom, not ended there) walked once, plus the walks of the local
/// minima starting there; and the most edges across one beam. A tangle is refused on this alone.
fn walks_per_beam(edges: &[[f64; 4]], ys: &[f64]) -> (f64, usize) {
    let mut lo: Vec<f64> = edges.iter().map(|e| e[0]).collect();
    let mut hi: Vec<f64> = edges.iter().map(|e| e[1]).collect();
    lo.sort_unstable_by(f64::total_cmp);
    hi.sort_unstable_by(f64::total_cmp);
    let (mut started, mut ended, mut walks) = (0usize, 0usize, 0.0f64);
    let mut max_active = 0usize;
    for &y in ys {
        let before = started;
        while started < lo.len() && lo[started] <= y {
            started += 1;
        }
        while ended < hi.len() && hi[ended] <= y {
            ended += 1;
        }
        let active = (started - ended) as f64;
        max_active = max_active.max(started - ended);
        walks += active * (1.0 + minima(started - before));
    }
    (walks, max_active)
}

/// Edge `e`'s x at height `y`, clamped to its ends.
#[inline]
fn x_at(e: &[f64; 4], y: f64) -> f64 {
    if y <= e[0] {
        e[2]
    } else if y >= e[1] {
        e[3]
    } else {
        e[2] + (e[3] - e[2]) * (y - e[0]) / (e[1] - e[0])
    }
}

/// Clipper's active edge list as the sweep moves up: the edges across the current beam, in
/// order along x at its bottom, with scratch buffers kept from beam to beam.
#[derive(Default)]
struct ActiveEdges {
    /// Indices into the edges, left to right at the beam's bottom.
    order: Vec<usize>,
    /// Each active edge's x at the beam's top (indexed like `order`).
    top: Vec<f64>,
    /// `order`'s positions, sorted by x at the beam's top.
    idx: Vec<usize>,
    merged: Vec<usize>,
}

impl ActiveEdges {
    /// Merge the edges `fresh` (starting at this beam's bottom `y0`) into the order, by x at the
    /// bottom and then at the top, as Clipper inserts each local minimum.
    #[inline]
    fn insert_starting(
        &mut self,
        edges: &[[f64; 4]],
        fresh: std::ops::Range<usize>,
        y0: f64,
        y1: f64,
    ) {
        let key = |e: usize| (x_at(&edges[e], y0), x_at(&edges[e], y1));
        let mut fresh: Vec<usize> = fresh.collect();
        fresh.sort_unstable_by(|&a, &b| {
            key(a)
                .partial_cmp(&key(b))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        let order = &self.order;
        self.merged.clear();
        let (mut i, mut j) = (0, 0);
        while i < order.len() || j < fresh.len() {
            if j == fresh.len() || (i < order.len() && key(order[i]) <= key(fresh[j])) {
                self.merged.push(order[i]);
                i += 1;
            } else {
                self.merged.push(fresh[j]);
                j += 1;
            }
        }
        std::mem::swap(&mut self.order, &mut self.merged);
    }

    /// Insertion-sort the active edges by x at the beam's top `y1`, as Clipper's bubble sort of
    /// its intersections does: every swap is a crossing (counted in `out`, the first one located),
    /// and the return value is how far the farthest-moving edge moved left.
    #[inline]
    fn sort_at_top(
        &mut self,
        edges: &[[f64; 4]],
        y0: f64,
        y1: f64,
        turned: bool,
        out: &mut Sweep,
    ) -> usize {
        let (order, top, idx) = (&self.order, &mut self.top, &mut self.idx);
        top.clear();
        top.extend(order.iter().map(|&e| x_at(&edges[e], y1)));
        idx.clear();
        idx.extend(0..order.len());
        let mut farthest = 0usize;
        for k in 1..idx.len() {
            let mut m = k;
            while m > 0 && top[idx[m - 1]] > top[idx[m]] {
                if out.first_crossing.is_none() {
                    let at = crossing(&edges[order[idx[m - 1]]], &edges[order[idx[m]]], y0, y1);
                    let at = if turned { [at[1], -at[0]] } else { at };
                    out.first_crossing = Some(at.map(|v| v / CLIPPER_FACTOR));
                }
                idx.swap(m - 1, m);
                m -= 1;
                out.crossings += 1;
            }
            farthest = farthest.max(k - m);
        }
        farthest
    }

    /// Take the order at the beam's top (what [`ActiveEdges::sort_at_top`] found) as the next
    /// beam's order at its bottom.
    #[inline]
    fn take_top_order(&mut self) {
        self.merged.clear();
        self.merged.extend(self.idx.iter().map(|&k| self.order[k]));
        std::mem::swap(&mut self.order, &mut self.merged);
    }
}

/// Local minima among `starting` edges that start at one height (two edges each): Clipper inserts
/// each into the active edges by a walk from the left, and starts an output ring there whose hole
/// state is found by another walk.
fn minima(starting: usize) -> f64 {
    (starting / 2) as f64
}

/// Where edges `a` and `b` cross within the beam from `y0` to `y1` (their order along x swaps).
fn crossing(a: &[f64; 4], b: &[f64; 4], y0: f64, y1: f64) -> [f64; 2] {
    let (d0, d1) = (x_at(a, y0) - x_at(b, y0), x_at(a, y1) - x_at(b, y1));
    let t = if d0 != d1 {
        (d0 / (d0 - d1)).clamp(0.0, 1.0)
    } else {
        0.5
    };
    let y = y0 + t * (y1 - y0);
    [x_at(a, y), y]
}

/// One Clipper job: the shapes it sweeps first, and for an offset, the distance and the round
/// joins' points per radian (the path Clipper then resolves, see [`raw_offset`]).
struct Job<'a> {
    shapes: Vec<&'a Polygon<f64>>,
    offset: Option<(f64, f64)>,
}

impl<'a> Job<'a> {
    /// A boolean operation's job: its shapes, no offset.
    fn of(shapes: Vec<&'a Polygon<f64>>) -> Self {
        Job {
            shapes,
            offset: None,
        }
    }
}

/// Whether to turn each job a quarter turn (the cheaper way to sweep it); refuses an offset of a
/// path crossing itself more than [`MAX_SELF_CROSSINGS`] times, and jobs that together would take
/// more than [`MAX_SWEEP_WORK`] steps either way.
fn plan(jobs: &[Job]) -> Result<Vec<bool>, ClipError> {
    // A job this cheap at worst (every edge across every beam) is not counted, and not turned:
    // most shapes of a stencil, in no time, and always swept as before.
    const SMALL: f64 = 1e5;
    // Turned only when that saves most of the work (the result is the same, up to Clipper's
    // rounding of a coordinate to its grid).
    const WORTH_TURNING: f64 = 0.25;
    let plans: Vec<(f64, bool, usize)> = jobs
        .par_iter()
        .map(|j| {
            let n: usize = j
                .shapes
                .iter()
                .flat_map(|p| rings_of(p))
                .map(|r| r.0.len())
                .sum();
            // An offset's path has the shape's points plus its round joins' (at most half a turn
            // each, and the two ends).
            let joins = j
                .offset
                .map_or(0.0, |(_, spr)| 2.0 + spr * std::f64::consts::PI);
            let worst = (n as f64).powi(2) * (1.0 + joins * joins);
            if worst <= SMALL {
                return Ok((worst, false, 0));
            }
            let raw: Option<Vec<Polygon<f64>>> =
                (j.offset).map(|(d, spr)| j.shapes.iter().map(|p| raw_offset(p, d, spr)).collect());
            let cost = |turned: bool, cap: f64| -> Result<(f64, usize), ClipError> {
                let limit = raw.as_ref().map_or(usize::MAX, |_| MAX_SELF_CROSSINGS);
                let s = sweep(&j.shapes, turned, cap, limit);
                if raw.is_some() && s.crossings > MAX_SELF_CROSSINGS {
                    return Err(ClipError::SelfCrossing {
                        crossings: s.crossings,
                        at: s.first_crossing.unwrap_or_default(),
                    });
                }
                let r = raw
                    .as_ref()
                    .map(|r| {
                        sweep(
                            &r.iter().collect::<Vec<_>>(),
                            turned,
                            cap - s.work,
                            usize::MAX,
                        )
                    })
                    .unwrap_or_default();
                Ok((s.work + r.work, s.max_active.max(r.max_active)))
            };
            let (w, m) = cost(false, MAX_SWEEP_WORK)?;
            if w <= SMALL {
                return Ok((w, false, m));
            }
            let (wt, mt) = cost(true, (w * WORTH_TURNING).min(MAX_SWEEP_WORK))?;
            Ok(if wt < w * WORTH_TURNING {
                (wt, true, mt)
            } else {
                (w, false, m)
            })
        })
        .collect::<Result<_, ClipError>>()?;
    let work: f64 = plans.iter().map(|c| c.0).sum();
    if work > MAX_SWEEP_WORK {
        // No one job near the limit: it is their number that is too large.
        let largest = plans.iter().map(|c| c.0).fold(0.0, f64::max);
        if plans.len() > 1 && largest * 10.0 < MAX_SWEEP_WORK {
            let shapes: usize = jobs.iter().map(|j| j.shapes.len()).sum();
            return Err(ClipError::TooMany {
                shapes,
                work,
                fit: (shapes as f64 * MAX_SWEEP_WORK / work) as usize,
            });
        }
        let max_active = plans.iter().map(|c| c.2).max().unwrap_or(0);
        return Err(ClipError::TooComplex { work, max_active });
    }
    Ok(plans.iter().map(|c| c.1).collect())
}

/// `a` minus `b`, for each pair, in parallel (Clipper's integer difference).
pub fn difference_each(
    pairs: &[(&Polygon<f64>, MultiPolygon<f64>)],
) -> Result<Vec<MultiPolygon<f64>>, ClipError> {
    for (a, b) in pairs {
        check_rings(rings_of(a).chain(b.0.iter().flat_map(rings_of)))?;
    }
    let jobs: Vec<Job> = (pairs.iter())
        .map(|(a, b)| Job::of(std::iter::once(*a).chain(b.0.iter()).collect()))
        .collect();
    let turns = plan(&jobs)?;
    Ok(pairs
        .par_iter()
        .zip(turns)
        .map(|((a, b), t)| {
            if t {
                let d = turn(a, false).difference(&turn_all(b, false), CLIPPER_FACTOR);
                turn_all(&d, true)
            } else {
                a.difference(b, CLIPPER_FACTOR)
            }
        })
        .collect())
}

/// The union of each group of polygons, in parallel (Clipper's integer union with the non-zero
/// fill rule: the polygons of a group must wind the same way, as `Orient` leaves them).
pub fn union_each(groups: &[Vec<Polygon<f64>>]) -> Result<Vec<MultiPolygon<f64>>, ClipError> {
    for g in groups {
        check_rings(g.iter().flat_map(rings_of))?;
    }
    let jobs: Vec<Job> = groups.iter().map(|g| Job::of(g.iter().collect())).collect();
    let turns = plan(&jobs)?;
    let none = MultiPolygon::new(Vec::new());
    Ok(groups
        .par_iter()
        .zip(turns)
        .map(|(g, t)| {
            let m = MultiPolygon::new(g.clone());
            if t {
                turn_all(&turn_all(&m, false).union(&none, CLIPPER_FACTOR), true)
            } else {
                m.union(&none, CLIPPER_FACTOR)
            }
        })
        .collect())
}

/// A boolean operation of two sets of polygons (see [`boolean`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    /// What lies in both.
    Intersection,
    /// What lies in either.
    Union,
    /// What lies in exactly one.
    Xor,
}

/// `a` op `b` (Clipper's integer boolean, non-zero fill: each ring counts with the winding it is
/// given, so rings drawn the same way add up and a ring drawn the other way inside one is a hole).
pub fn boolean(
    a: &MultiPolygon<f64>,
    b: &MultiPolygon<f64>,
    op: Op,
) -> Result<MultiPolygon<f64>, ClipError> {
    check_rings(a.0.iter().chain(&b.0).flat_map(rings_of))?;
    let jobs = [Job::of(a.0.iter().chain(&b.0).collect())];
    let t = plan(&jobs)?[0];
    let run = |a: &MultiPolygon<f64>, b: &MultiPolygon<f64>| match op {
        Op::Intersection => a.intersection(b, CLIPPER_FACTOR),
        Op::Union => a.union(b, CLIPPER_FACTOR),
        Op::Xor => a.xor(b, CLIPPER_FACTOR),
    };
    Ok(if t {
        turn_all(&run(&turn_all(a, false), &turn_all(b, false)), true)
    } else {
        run(a, b)
    })
}

/// The parts of open `lines` that lie inside `region` (Clipper's open-path intersection,
/// non-zero fill as in [`boolean`]).
pub fn clip_lines(
    lines: &[LineString<f64>],
    region: &MultiPolygon<f64>,
) -> Result<Vec<LineString<f64>>, ClipError> {
    use geo_clipper::ClipperOpen;
    check_rings(lines.iter().chain(region.0.iter().flat_map(rings_of)))?;
    // Costed as if each line were closed: one edge more than it has.
    let closed: Vec<Polygon<f64>> = lines
        .iter()
        .map(|l| Polygon::new(l.clone(), vec![]))
        .collect();
    let jobs = [Job::of(closed.iter().chain(&region.0).collect())];
    plan(&jobs)?;
    let m = geo::MultiLineString::new(lines.to_vec());
    Ok(m.intersection(region, CLIPPER_FACTOR).0)
}

/// Each of `polys` grown by `delta_mm` (shrunk when negative) with round joins within
/// `arc_tolerance_mm` of the true arc, in parallel (Clipper's offset).
pub fn offset_each(
    polys: &[Polygon<f64>],
    delta_mm: f64,
    arc_tolerance_mm: f64,
) -> Result<Vec<MultiPolygon<f64>>, ClipError> {
    if !(delta_mm.is_finite() && delta_mm.abs() <= MAX_OFFSET_MM) {
        return Err(ClipError::Offset(delta_mm));
    }
    check_rings(polys.iter().flat_map(rings_of))?;
    // Round joins with as many points as Clipper puts in them (its `ClipperOffset` formula).
    let d = (delta_mm * CLIPPER_FACTOR).abs().max(1.0);
    let tol = (arc_tolerance_mm * CLIPPER_FACTOR).clamp(f64::MIN_POSITIVE, d * 0.25);
    let steps = (std::f64::consts::PI / (1.0 - tol / d).acos()).min(d * std::f64::consts::PI);
    let jobs: Vec<Job> = polys
        .iter()
        .map(|p| Job {
            shapes: vec![p],
            offset: Some((delta_mm, steps / std::f64::consts::TAU)),
        })
        .collect();
    let turns = plan(&jobs)?;
    let join = JoinType::Round(arc_tolerance_mm * CLIPPER_FACTOR);
    Ok(polys
        .par_iter()
        .zip(turns)
        .map(|(p, t)| {
            if t {
                let m =
                    turn(p, false).offset(delta_mm, join, EndType::ClosedPolygon, CLIPPER_FACTOR);
                turn_all(&m, true)
            } else {
                p.offset(delta_mm, join, EndType::ClosedPolygon, CLIPPER_FACTOR)
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use geo::{Area, Rect};

    fn square(x0: f64, y0: f64, s: f64) -> Polygon<f64> {
        Rect::new((x0, y0), (x0 + s, y0 + s)).to_polygon()
    }

    #[test]
    fn non_finite_and_huge_points_are_refused_before_clipper() {
        for (x, y) in [
            (f64::NAN, 0.0),
            (0.0, f64::INFINITY),
            (1e30, 0.0),
            (0.0, -2e9),
        ] {
            let mut p = square(0.0, 0.0, 1.0);
            p.exterior_mut(|r| r.0[1] = Coord { x, y });
            assert!(offset_each(std::slice::from_ref(&p), -0.1, 0.01).is_err());
            let e = difference_each(&[(&p, MultiPolygon::new(vec![square(0.5, 0.5, 1.0)]))]);
            assert!(e.is_err(), "({x}, {y})");
        }
        let p = square(0.0, 0.0, 1.0);
        assert!(matches!(
            offset_each(std::slice::from_ref(&p), f64::NAN, 0.01),
            Err(ClipError::Offset(_))
        ));
        assert!(offset_each(std::slice::from_ref(&p), -0.1, 0.01).is_ok());
    }

    /// A zigzag between two heights: every edge spans the whole shape.
    fn zigzag(n: usize, crossing: bool) -> Polygon<f64> {
        let mut pts: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let x = i as f64 / n as f64 * 100.0;
                // Crossing: every other up-stroke leans back past the previous down-stroke.
                let x = if crossing && i % 4 == 1 {
                    x - 300.0 / n as f64
                } else {
                    x
                };
                (x, if i % 2 == 0 { 0.0 } else { 100.0 })
            })
            .collect();
        pts.push((100.0, -10.0));
        pts.push((0.0, -10.0));
        Polygon::new(LineString::from(pts), vec![])
    }

    #[test]
    fn the_estimate_counts_active_edges_and_crossings() {
        let all = |p: &Polygon<f64>, turned| sweep(&[p], turned, 1e12, usize::MAX);
        // A square: two edges across its one beam (walked once, and once to insert its local
        // minimum), nothing to sort.
        let s = all(&square(0.0, 0.0, 1.0), false);
        assert_eq!((s.work, s.crossings, s.max_active), (4.0, 0, 2));
        // A bow tie's two slanted edges cross once, at its middle.
        let bow = Polygon::new(
            LineString::from(vec![(0.0, 0.0), (1.0, 1.0), (0.0, 1.0), (1.0, 0.0)]),
            vec![],
        );
        let s = all(&bow, false);
        assert_eq!(s.crossings, 1);
        let at = s.first_crossing.unwrap();
        assert!(
            (at[0] - 0.5).abs() < 1e-9 && (at[1] - 0.5).abs() < 1e-9,
            "{at:?}"
        );
        let t = all(&bow, true);
        assert_eq!(t.crossings, 1);
        let at = t.first_crossing.unwrap();
        assert!(
            (at[0] - 0.5).abs() < 1e-9 && (at[1] - 0.5).abs() < 1e-9,
            "{at:?}"
        );
        // A zigzag of n points has about n edges across its tall beam, and few across x.
        let z = zigzag(1000, false);
        let s = all(&z, false);
        assert!(s.max_active >= 999 && s.work >= 999.0, "{s:?}");
        let t = all(&z, true);
        assert!(t.max_active <= 4 && t.work < 5000.0, "{t:?}");
        assert_eq!(s.crossings + t.crossings, 0);
        // Its crossing variant crosses itself about n / 4 times, either way.
        let zc = zigzag(1000, true);
        let (s, t) = (all(&zc, false), all(&zc, true));
        assert!(
            s.crossings >= 200 && s.crossings == t.crossings,
            "{s:?} {t:?}"
        );
        // Counting stops at the caps.
        assert!(sweep(&[&zc], false, 1e12, 10).crossings <= 11 + 1000);
        assert!(sweep(&[&z], false, 10.0, usize::MAX).work > 10.0);
    }

    #[test]
    fn a_tall_zigzag_is_offset_turned_and_comes_back_in_place() {
        let z = zigzag(20_000, false);
        let out = offset_each(std::slice::from_ref(&z), -0.01, 0.01).unwrap();
        let area: f64 = out.iter().map(|m| m.unsigned_area()).sum();
        assert!(area > 0.0 && area < z.unsigned_area(), "{area}");
        let b = geo::BoundingRect::bounding_rect(&out[0]).unwrap();
        assert!(
            b.min().y > -10.0 && b.max().y < 100.0 && b.min().x >= 0.0,
            "{b:?}"
        );
    }

    #[test]
    fn a_path_crossing_itself_is_refused_for_an_offset_and_named() {
        let zc = zigzag(20_000, true);
        let e = offset_each(std::slice::from_ref(&zc), -0.05, 0.01).unwrap_err();
        assert!(matches!(e, ClipError::SelfCrossing { .. }), "{e}");
        let m = e.to_string();
        assert!(
            m.contains("crosses itself more than 1000 times") && m.contains("near x"),
            "{m}"
        );
        // A few crossings are resolved as before (a hand-drawn loop that overlaps at its end).
        let zc = zigzag(400, true);
        assert!(offset_each(std::slice::from_ref(&zc), -0.01, 0.01).is_ok());
    }

    #[test]
    fn a_scribble_is_refused_quickly() {
        // Random-looking strokes across the whole square: quadratic in crossings and beams.
        let n = 20_000;
        let mut s = 12345u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 * 100.0
        };
        let pts: Vec<(f64, f64)> = (0..n).map(|_| (rnd(), rnd())).collect();
        let p = Polygon::new(LineString::from(pts), vec![]);
        let e = offset_each(std::slice::from_ref(&p), -0.05, 0.01).unwrap_err();
        assert!(
            matches!(
                e,
                ClipError::SelfCrossing { .. } | ClipError::TooComplex { .. }
            ),
            "{e}"
        );
        // Without the crossings limit (a difference), the sweep's work alone refuses it.
        let q = square(0.0, 0.0, 100.0);
        let e = difference_each(&[(&q, MultiPolygon::new(vec![p]))]).unwrap_err();
        assert!(matches!(e, ClipError::TooComplex { .. }), "{e}");
        assert!(e.to_string().contains("too tangled"), "{e}");
    }
}
