//! Closed outlines as lines and circular arcs: a traced polygon fitted within a tolerance, so that
//! SVG (`A`), DXF (LWPOLYLINE bulges) and G-code (`G2`/`G3`) all carry the same smooth path instead
//! of thousands of short segments.
//!
//! Why arcs and not Béziers: potrace and kurbo's `fit_to_bezpath` fit cubic Béziers, which SVG
//! carries but DXF polylines and Grbl cannot; they would need a second approximation (biarcs) on
//! the way to the machine, and the three files would then carry three different outlines. Fitting
//! arcs directly to the polygon gives one geometry that every writer carries exactly, within one
//! tolerance.
//!
//! How: a traced outline (fitted with its [`Sides`]) is fitted three ways, and the one that costs
//! the machine least is kept (pieces plus corners turning more than 15 degrees, a corner costing
//! as much as a piece: the machine slows there, and a kerf offset adds a join): the
//! tangent-continuous arc spline of the `smooth` module (pieces meeting with the same tangent
//! except at corners, ends within the tolerance of vertices), the same module's loose chain
//! (each piece the least-squares arc from the last one's end, joints turning by a few degrees),
//! and round 3's fit below. A ring a writer fits again (one a later step changed, without sides)
//! gets round 3's fit only.
//!
//! Round 3's fit: greedy, from the ring's first point, each piece runs from one polygon vertex to a
//! later one, as far as an arc (or a line) stays within the tolerance of every vertex and every
//! edge it replaces. The pieces' ends are polygon vertices, so corners are kept: no arc can round
//! a corner by more than the tolerance. An arc's radius is chosen as the middle of the range the
//! vertices allow (the circle through both ends and each vertex gives one bulge; the middle of
//! their spread halves the worst deviation), then every vertex and edge is measured against it.
//! Arcs sweep less than a half turn (their vertices project monotonically onto the chord, so the
//! order along the arc is the polygon's).
//!
//! The bulge is DXF's: `tan(sweep / 4)`, positive counter-clockwise in the numeric (x, y) plane.

mod arc;

use arc::{arc_box, quarter_points};
pub use arc::{arc_of, ArcGeom, Piece, Sides};

use crate::ring::{dist, point_box, seg_closest, seg_dist, union_box, wrap, NO_BOX};

/// Longest run of polygon vertices one piece may replace: bounds the fit's work (quadratic in
/// the run) on long smooth stretches.
const MAX_RUN: usize = 400;

/// Fit a closed ring (closing point not repeated) with lines and arcs, every vertex and edge of
/// the ring within `tol` of the pieces and the pieces within `tol` of the ring. The first piece
/// starts at `ring[0]`. A ring of fewer than 3 points, or `tol` ≤ 0, comes back as its lines.
pub fn fit_ring(ring: &[[f64; 2]], tol: f64) -> Vec<Piece> {
    fit_ring_within(ring, tol, None)
}

/// [`fit_ring`], keeping [`Sides`] (ignored unless it has one pair per vertex).
pub fn fit_ring_within(ring: &[[f64; 2]], tol: f64, sides: Option<Sides>) -> Vec<Piece> {
    fit(ring, tol, sides, None)
}

/// [`fit_ring`] with no arc reaching outside `bounds` (`[min x, min y, max x, max y]`, which
/// holds the ring): a G-code job is placed by its polygons' box, and an arc bulging past it
/// would leave that box (and, at the bed's edge, the bed). Near the box's edges the pieces are
/// then shorter, or lines, rather than the job moving.
pub fn fit_ring_inside(ring: &[[f64; 2]], tol: f64, bounds: [f64; 4]) -> Vec<Piece> {
    fit(ring, tol, None, Some(bounds))
}

fn fit(ring: &[[f64; 2]], tol: f64, sides: Option<Sides>, bounds: Option<[f64; 4]>) -> Vec<Piece> {
    let n = ring.len();
    let lines = || {
        ring.iter()
            .map(|&from| Piece { from, bulge: 0.0 })
            .collect::<Vec<_>>()
    };
    if n < 3 || tol.is_nan() || tol <= 0.0 {
        return lines();
    }
    let sides = sides.filter(|s| s.points.len() == n);
    // One piece from vertex i with its own bulge, as far as one fits: where no tangent-continuous
    // piece does.
    let fresh = |i: usize, s: [f64; 2]| -> (usize, f64) {
        let at = |k: usize| if k == i { s } else { ring[wrap(k, n)] };
        // Galloping, then halving: spans of 2, 4, 8, ... vertices until one fails, then the
        // longest that fits between the last that fitted and the first that failed (a span that
        // fits usually means every shorter one does), so a long arc costs a few passes over its
        // vertices, not one per vertex.
        let mut best = (i + 1, 0.0);
        let last = (i + MAX_RUN).min(n);
        let mut step = 2;
        let mut fail = last + 1;
        while i + step <= last {
            match fit_span(&at, sides, bounds, i, i + step, tol) {
                Some(b) => best = (i + step, b),
                None => {
                    fail = i + step;
                    break;
                }
            }
            step *= 2;
        }
        if fail > last && best.0 < last {
            // Ran past the end without a failure: try the end itself.
            match fit_span(&at, sides, bounds, i, last, tol) {
                Some(b) => best = (last, b),
                None => fail = last,
            }
        }
        let (mut lo, mut hi) = (best.0, fail.min(last + 1));
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            match fit_span(&at, sides, bounds, i, mid, tol) {
                Some(b) => {
                    best = (mid, b);
                    lo = mid;
                }
                None => hi = mid,
            }
        }
        best
    };
    // The three fits ask for the same piece where their paths meet (at a vertex, after a
    // corner): each asked once.
    let known = std::cell::RefCell::new(std::collections::HashMap::new());
    let free = |i: usize, s: [f64; 2]| -> (usize, f64) {
        let key = (i, s.map(f64::to_bits));
        if let Some(&r) = known.borrow().get(&key) {
            return r;
        }
        let r = fresh(i, s);
        known.borrow_mut().insert(key, r);
        r
    };
    // Vertex to vertex, each piece with its own bulge: round 3's fit.
    let mut own = Vec::new();
    let mut i = 0;
    while i < n {
        let (j, bulge) = free(i, ring[i]);
        own.push(Piece {
            from: ring[i],
            bulge,
        });
        i = j;
    }
    // Only for the traced outlines (with their sides): a ring a writer fits again (changed by a
    // later step) keeps round 3's fit, whose lengths the G-code's report was verified against.
    if sides.is_none() {
        return own;
    }
    let smooth = smooth::fit(ring, tol, sides, bounds, MAX_RUN, free);
    let loose = smooth::fit_loose(ring, tol, sides, bounds, MAX_RUN, free);
    // The tangent-continuous pieces where they cost no more than the others: a kink costs as
    // much as a piece (the machine slows there, and a kerf offset adds a join).
    let cost = |p: &[Piece]| p.len() + smooth::kinks(p);
    if cost(&loose) < cost(&smooth).min(cost(&own)) {
        return loose;
    }
    if cost(&smooth) <= cost(&own) {
        smooth
    } else {
        own
    }
}

/// The bulge of one piece from vertex `i` to vertex `j` (indices into the ring, `j` may be the
/// ring's length: its first point again) within `tol` of every vertex and edge between, or `None`
/// when no line or half-turn arc fits.
fn fit_span(
    at: &impl Fn(usize) -> [f64; 2],
    sides: Option<Sides>,
    bounds: Option<[f64; 4]>,
    i: usize,
    j: usize,
    tol: f64,
) -> Option<f64> {
    let (a, b) = (at(i), at(j));
    let l = dist(a, b);
    if l <= tol {
        return None;
    }
    let t = [(b[0] - a[0]) / l, (b[1] - a[1]) / l];
    let m = [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
    // Chord frame: u along the chord from its midpoint, v along its left normal.
    let frame = |p: [f64; 2]| {
        let (x, y) = (p[0] - m[0], p[1] - m[1]);
        (x * t[0] + y * t[1], -x * t[1] + y * t[0])
    };
    let half = l / 2.0;
    let mut spread = Spread::new(half);
    let mut prev_u = -half;
    let mut straight = true;
    for k in i + 1..j {
        let (u, v) = frame(at(k));
        // Vertices must advance along the chord (a minor arc's order) and stay inside it.
        if u <= prev_u || u >= half {
            return None;
        }
        prev_u = u;
        straight &= v.abs() <= tol;
        spread.add(u, v)?;
    }
    let (lo, hi) = spread.range(|| (i + 1..j).map(|k| frame(at(k))));
    let n_ring = sides.map_or(0, |s| s.points.len());
    if straight {
        // Left of the chord: positive.
        let left = |p: [f64; 2]| frame(p).1;
        if kept_sides(sides, n_ring, i, j, left) {
            return Some(0.0);
        }
    }
    // The sides bound the bulge too: an arc passes right of a point when its bulge is larger
    // than the bulge through the point, so left points set a floor and right points a ceiling.
    let (mut floor, mut ceil) = (f64::NEG_INFINITY, f64::INFINITY);
    if let Some(s) = sides {
        let (mut lefts, mut rights) = (Spread::new(half), Spread::new(half));
        for k in i + 1..j {
            let [l, r] = s.points[wrap(k, n_ring)];
            let (ul, vl) = frame(l);
            if ul.abs() < half {
                // A point past the half turn sets no bound.
                let _ = lefts.add(ul, vl);
            }
            let (ur, vr) = frame(r);
            if ur.abs() < half {
                let _ = rights.add(ur, vr);
            }
        }
        let side = |pick: fn(&[[f64; 2]; 2]) -> [f64; 2]| {
            (i + 1..j)
                .map(move |k| frame(pick(&s.points[wrap(k, n_ring)])))
                .filter(|&(u, _)| u.abs() < half)
        };
        floor = lefts.range(|| side(|p| p[0])).1;
        ceil = rights.range(|| side(|p| p[1])).0;
    }
    let (blo, bhi) = (lo.max(floor), hi.min(ceil));
    let bulge = if blo <= bhi {
        (blo + bhi) / 2.0
    } else if floor < ceil {
        // No bulge within the vertices' spread keeps the sides: the middle of what the sides
        // allow, measured against the tolerance below.
        (floor.max(lo.min(ceil)) + ceil.min(hi.max(floor))) / 2.0
    } else {
        return None;
    };
    let bulge = bulge.clamp(-0.999, 0.999);
    if bulge == 0.0 {
        return None;
    }
    let arc = arc_of(a, b, bulge)?;
    // Left of a counter-clockwise arc is inside its circle.
    let left = |p: [f64; 2]| bulge.signum() * (arc.radius - dist(p, arc.center));
    if !kept_sides(sides, n_ring, i, j, left) {
        return None;
    }
    let (c, r) = (arc.center, arc.radius);
    // Which side of the chord the arc runs on: its midpoint's v.
    let side = -bulge.signum();
    let mut p = a;
    for k in i + 1..=j {
        let q = at(k);
        if k < j {
            let (_, v) = frame(q);
            if (dist(q, c) - r).abs() > tol || v * side < -tol {
                return None;
            }
        }
        // The edge bows inside the circle by at most r minus its closest approach to the centre
        // (its ends are on the circle within tol, and it cannot run farther out than its ends).
        if r - seg_dist(c, p, q) > tol {
            return None;
        }
        p = q;
    }
    if let Some(bx) = bounds {
        // Past the box by more than the arithmetic's noise (a nanometre).
        let e = arc_box(&arc, a, b);
        if e[0] < bx[0] - 1e-9 || e[1] < bx[1] - 1e-9 || e[2] > bx[2] + 1e-9 || e[3] > bx[3] + 1e-9
        {
            return None;
        }
    }
    Some(bulge)
}

/// The bulge of the circle through the ends of a chord `2 half` long and the point at (u, v) in
/// the chord's frame (u along it from its midpoint, v along its left normal). `None` for a point
/// outside the circle on the chord as diameter, which would need more than a half turn.
fn through(half: f64, u: f64, v: f64) -> Option<f64> {
    if v == 0.0 {
        return Some(0.0);
    }
    let w = u * u + v * v - half * half;
    if w > 0.0 {
        return None;
    }
    Some(bulge_at(half, w / (2.0 * v)))
}

/// The bulge of the circle through the ends of a chord `2 half` long with its centre at `d` on
/// the chord's normal: its minor arc's sagitta `h` over `half`.
fn bulge_at(half: f64, d: f64) -> f64 {
    let r = (d * d + half * half).sqrt();
    let h = -(half * half) / (d + d.signum() * r);
    -h / half
}

/// The least and greatest [`through`] of a run of points, to the bit what folding `min` and `max`
/// over every point's bulge gives, for one division a point instead of three and a square root.
///
/// Why it is exact: on each side of the chord (the sign of `d`) the bulge falls as `d` grows,
/// and every step from `d` to the bulge (square, sum, root, quotient) is a correctly rounded
/// operation, each monotone, so the computed bulges fall (weakly) with the computed `d`. The
/// extremes are then the bulges at the extreme `d` of each side: positive bulges on one side,
/// negative on the other, zero for points on the chord. A `d` too large for its square to stay
/// finite (where rounding reaches signed zeros) sends the run back to the plain fold.
struct Spread {
    half: f64,
    /// The least and greatest `d` of each side: `d` positive, then negative (empty: inverted).
    sides: [[f64; 2]; 2],
    on_chord: bool,
    plain: bool,
}

impl Spread {
    fn new(half: f64) -> Spread {
        Spread {
            half,
            sides: [[f64::INFINITY, f64::NEG_INFINITY]; 2],
            on_chord: false,
            plain: false,
        }
    }

    /// Take the point at (u, v); `None` where [`through`] gives none.
    #[inline]
    fn add(&mut self, u: f64, v: f64) -> Option<()> {
        if v == 0.0 {
            self.on_chord = true;
            return Some(());
        }
        let half = self.half;
        let w = u * u + v * v - half * half;
        if w > 0.0 {
            return None;
        }
        let d = w / (2.0 * v);
        // `min` and `max` pass over a NaN bulge as over a NaN `d`.
        if d.abs() >= 1e150 {
            self.plain = true;
        }
        let side = &mut self.sides[usize::from(d.is_sign_negative())];
        side[0] = side[0].min(d);
        side[1] = side[1].max(d);
        Some(())
    }

    /// The least and greatest bulge (infinities for none); `points` gives every point taken
    /// again, in order, for the plain fold.
    fn range<I: Iterator<Item = (f64, f64)>>(&self, points: impl Fn() -> I) -> (f64, f64) {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut fold = |b: f64| {
            lo = lo.min(b);
            hi = hi.max(b);
        };
        if self.plain {
            for (u, v) in points() {
                if let Some(b) = through(self.half, u, v) {
                    fold(b);
                }
            }
            return (lo, hi);
        }
        if self.on_chord {
            fold(0.0);
        }
        for &[least, most] in &self.sides {
            if least <= most {
                fold(bulge_at(self.half, least));
                fold(bulge_at(self.half, most));
            }
        }
        (lo, hi)
    }
}

/// Whether every vertex strictly between `i` and `j` has its [`Sides`] on their sides, `margin`
/// clear; `left` is a signed distance, positive on the left of the piece.
fn kept_sides(
    sides: Option<Sides>,
    n: usize,
    i: usize,
    j: usize,
    left: impl Fn([f64; 2]) -> f64,
) -> bool {
    let Some(s) = sides else {
        return true;
    };
    (i + 1..j).all(|k| {
        let [l, r] = s.points[wrap(k, n)];
        left(l) >= s.margin && left(r) <= -s.margin
    })
}

/// The pieces as a polygon (closing point not repeated): lines as they are, arcs cut into chords
/// no farther than `tol` from the arc, every chord end on the arc, and every point where an arc
/// passes 0, 90, 180 or 270 degrees about its centre a vertex (the very numbers [`bounds`]
/// gives).
///
/// Why those extremes: the polygon's box is then the arcs' own box, so a job placed by its
/// polygons' box is placed by what the head really cuts, and no arc of it reaches outside.
pub fn flatten(pieces: &[Piece], tol: f64) -> Vec<[f64; 2]> {
    flatten_clear(pieces, tol, &[])
}

/// [`flatten`], and no point of `keep` changes sides: where a point lies between an arc and its
/// chords (inside the arc's circle, within `tol` of it, in its sweep), the arc also gets a vertex
/// on it at the point's angle. Without such points the polygon is [`flatten`]'s to the bit.
///
/// Why: the fit keeps the pixel centres beside a traced outline on their sides of the curve, but
/// only by a hair (a fixed clearance as wide as the chords' sagitta cost a large smooth circle its
/// few long arcs: its pixel centres come that close to the circle somewhere on every turn). A
/// chord cuts only inside its arc's circle, and the two chords meeting at a vertex on the arc at
/// a point's angle both pass outside the point (the point is on the radius through their common
/// end, farther in), so the polygon separates the same pixel centres as the curve.
pub fn flatten_clear(pieces: &[Piece], tol: f64, keep: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let n = pieces.len();
    let mut out = Vec::with_capacity(n);
    // The points of `keep` by x, so each arc looks only at those in its box's x range (a ring's
    // points are two per traced vertex: looking at all of them for every arc was quadratic).
    // Non-finite points are in no box.
    let mut by_x: Vec<[f64; 2]> = keep
        .iter()
        .copied()
        .filter(|q| q[0].is_finite() && q[1].is_finite())
        .collect();
    by_x.sort_by(|a, b| a[0].total_cmp(&b[0]));
    for (k, p) in pieces.iter().enumerate() {
        out.push(p.from);
        let to = pieces[(k + 1) % n].from;
        if let Some(arc) = arc_of(p.from, to, p.bulge) {
            // The sweep's fractions (0..1, exclusive) where a point of `keep` lies between the
            // arc and its chords.
            let mut extra: Vec<f64> = if keep.is_empty() {
                Vec::new()
            } else {
                let bx = arc_box(&arc, p.from, to);
                // The order does not matter: the fractions are sorted below.
                let from = by_x.partition_point(|q| q[0] < bx[0]);
                by_x[from..]
                    .iter()
                    .take_while(|q| q[0] <= bx[2])
                    .filter(|q| {
                        q[1] >= bx[1] && q[1] <= bx[3] && {
                            let d = dist(**q, arc.center);
                            d < arc.radius && d >= arc.radius - tol
                        }
                    })
                    .filter_map(|q| {
                        let ang = (q[1] - arc.center[1]).atan2(q[0] - arc.center[0]);
                        let f = if arc.sweep > 0.0 {
                            (ang - arc.start_angle).rem_euclid(std::f64::consts::TAU)
                        } else {
                            (arc.start_angle - ang).rem_euclid(std::f64::consts::TAU)
                        } / arc.sweep.abs();
                        (f > 0.0 && f < 1.0).then_some(f)
                    })
                    .collect()
            };
            extra.sort_by(f64::total_cmp);
            extra.dedup();
            let mut extra = extra.into_iter().peekable();
            let step = if tol > 0.0 && tol < arc.radius {
                2.0 * (1.0 - tol / arc.radius).acos()
            } else {
                std::f64::consts::FRAC_PI_2
            };
            // The sweep cut at its quarter-turn points, each part into equal chords.
            let mut a0 = arc.start_angle;
            let quarters = quarter_points(&arc);
            let ends = quarters
                .iter()
                .map(|&(a, q)| (a, Some(q)))
                .chain([(arc.start_angle + arc.sweep, None)]);
            let on = |a: f64| {
                [
                    arc.center[0] + arc.radius * a.cos(),
                    arc.center[1] + arc.radius * a.sin(),
                ]
            };
            let frac = |a: f64| (a - arc.start_angle) / arc.sweep;
            for (a1, q) in ends {
                let count = ((a1 - a0).abs() / step).ceil().clamp(1.0, 1e5) as usize;
                for s in 1..=count {
                    let a = a0 + (a1 - a0) * s as f64 / count as f64;
                    // The points' vertices before the next regular one (or the part's end).
                    let upto = if s < count { frac(a) } else { frac(a1) };
                    // Whether the last vertex is a point's (a regular one equal to it is
                    // not pushed again).
                    let mut points = false;
                    while let Some(f) = extra.next_if(|&f| f < upto) {
                        let v = on(arc.start_angle + arc.sweep * f);
                        if out.last() != Some(&v) {
                            out.push(v);
                            points = true;
                        }
                    }
                    if s < count && !(points && out.last() == Some(&on(a))) {
                        out.push(on(a));
                    }
                }
                if let Some(q) = q {
                    extra.next_if(|&f| f == frac(a1));
                    out.push(q);
                }
                a0 = a1;
            }
        }
    }
    out
}

/// Each vertex of `ring` moved onto the piece that replaced it: the pieces from
/// [`fit_ring_within`] (or [`fit_ring`]) on this very ring, in its order, the first starting at
/// its first vertex. Pieces meet at vertices or where a vertex is nearest them; each vertex moves
/// onto the nearest of the piece it was last near and the few after it: along the radius onto
/// an arc, perpendicular onto a line (clamped to it). Each moves by at most the fit's tolerance
/// (the fit measured these distances). `None` when the first piece does not start at the ring's
/// first vertex, or a vertex sits on an arc's centre.
///
/// Why: the fitted curves run through the middle of a traced staircase; a polygon whose corners
/// sit on them, rather than on the staircase's steps, reaches farther within the same tolerance
/// (see the vector stage's straight outlines).
pub fn onto_pieces(ring: &[[f64; 2]], pieces: &[Piece]) -> Option<Vec<[f64; 2]>> {
    let (n, m) = (ring.len(), pieces.len());
    if m == 0 || n == 0 || ring[0] != pieces[0].from {
        return None;
    }
    let onto = |q: [f64; 2], k: usize| -> Option<[f64; 2]> {
        let (from, to) = (pieces[k].from, pieces[(k + 1) % m].from);
        Some(match arc_of(from, to, pieces[k].bulge) {
            Some(arc) => {
                let d = dist(q, arc.center);
                if d == 0.0 {
                    return None;
                }
                // Onto the circle, or the nearer end where the circle's point is off the arc.
                let s = arc.radius / d;
                let c = [
                    arc.center[0] + (q[0] - arc.center[0]) * s,
                    arc.center[1] + (q[1] - arc.center[1]) * s,
                ];
                let (u, v) = (
                    [from[0] - arc.center[0], from[1] - arc.center[1]],
                    [c[0] - arc.center[0], c[1] - arc.center[1]],
                );
                let ang = (u[0] * v[1] - u[1] * v[0]).atan2(u[0] * v[0] + u[1] * v[1]);
                let within = if arc.sweep > 0.0 {
                    (0.0..=arc.sweep).contains(&ang.rem_euclid(std::f64::consts::TAU))
                } else {
                    (arc.sweep..=0.0)
                        .contains(&(ang.rem_euclid(std::f64::consts::TAU) - std::f64::consts::TAU))
                };
                if within || ang == 0.0 {
                    c
                } else if dist(q, from) <= dist(q, to) {
                    from
                } else {
                    to
                }
            }
            None => seg_closest(q, from, to),
        })
    };
    let mut out = Vec::with_capacity(n);
    let mut p = 0;
    for &q in ring {
        let mut best: Option<(usize, [f64; 2])> = None;
        for k in p..(p + 4).min(m) {
            let c = onto(q, k)?;
            if best.is_none_or(|(_, b)| dist(c, q) < dist(b, q)) {
                best = Some((k, c));
            }
        }
        let (k, c) = best?;
        p = k;
        out.push(if q == pieces[k].from { q } else { c });
    }
    Some(out)
}

/// How many of the pieces are arcs.
pub fn arc_count(pieces: &[Piece]) -> usize {
    pieces.iter().filter(|p| p.bulge != 0.0).count()
}

/// The exact box `[min x, min y, max x, max y]` of the pieces' path: every piece's ends, and
/// each arc's points at 0, 90, 180 and 270 degrees about its centre where its sweep passes them
/// (an arc's extreme in x or y is either an end or one of those). `None` for no pieces.
///
/// Why exact, not the box widened by the fitting tolerance: the planner checks the bed by it,
/// and a blanket margin would refuse or move jobs that stay on the bed.
pub fn bounds(pieces: &[Piece]) -> Option<[f64; 4]> {
    let n = pieces.len();
    let boxes = pieces.iter().enumerate().map(|(k, p)| {
        let to = pieces[(k + 1) % n].from;
        match arc_of(p.from, to, p.bulge) {
            Some(arc) => arc_box(&arc, p.from, to),
            None => point_box(p.from),
        }
    });
    (n > 0).then_some(boxes.fold(NO_BOX, union_box))
}

/// The length of the closed path the pieces make: lines as chords, arcs as `radius · |sweep|`.
pub fn length(pieces: &[Piece]) -> f64 {
    let n = pieces.len();
    (0..n)
        .map(|k| {
            let (p, to) = (pieces[k], pieces[(k + 1) % n].from);
            match arc_of(p.from, to, p.bulge) {
                Some(a) => a.radius * a.sweep.abs(),
                None => dist(p.from, to),
            }
        })
        .sum()
}

/// The same path walked the other way: the pieces in reverse order, each from its old end,
/// its bulge negated (an arc walked back turns the other way); the first piece still starts at
/// `pieces[0].from`.
pub fn reversed(pieces: &[Piece]) -> Vec<Piece> {
    let m = pieces.len();
    (0..m)
        .map(|j| Piece {
            from: pieces[(m - j) % m].from,
            bulge: -pieces[(m + m - 1 - j) % m].bulge,
        })
        .collect()
}

/// Polygon rings known as the lines and arcs they are the flattening of ([`flatten`]), so that a
/// writer handed a polygon can write the very arcs it came from instead of fitting arcs to it a
/// second time (which would add its own error to the fit's and the flattening's).
///
/// A ring is found only when it is exactly (to the bit) a stored flattening, from any of its
/// pieces' starts and in either direction (a cut region's outline is a hole of the material
/// walked the other way): a ring that a later step moved, clipped or offset is not found, and
/// its writer fits it as before.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Curves {
    rings: Vec<CurvedRing>,
    /// Each piece's start (its coordinates' bits): its ring and its index there.
    starts: std::collections::HashMap<[u64; 2], (usize, usize)>,
    /// The tolerance the rings were flattened within (what a ring derived from them, such as
    /// their kerf offset, is flattened within too).
    pub flatten_tol: f64,
}

#[derive(Clone, Debug, PartialEq)]
struct CurvedRing {
    pieces: Vec<Piece>,
    flat: Vec<[f64; 2]>,
    /// Where each piece starts in `flat`.
    at: Vec<usize>,
}

fn key(p: [f64; 2]) -> [u64; 2] {
    [p[0].to_bits(), p[1].to_bits()]
}

impl Curves {
    /// An empty table for rings flattened within `flatten_tol`.
    pub fn new(flatten_tol: f64) -> Self {
        Curves {
            flatten_tol,
            ..Default::default()
        }
    }

    /// How many rings are known.
    pub fn len(&self) -> usize {
        self.rings.len()
    }

    /// Whether no ring is known.
    pub fn is_empty(&self) -> bool {
        self.rings.is_empty()
    }

    /// Remember that the polygon `flat` is the flattening of `pieces`: `flat` starts at
    /// `pieces[0].from` and holds every piece's start, in order. Refused (false) otherwise, or
    /// for no pieces.
    pub fn insert(&mut self, pieces: Vec<Piece>, flat: Vec<[f64; 2]>) -> bool {
        if pieces.is_empty() || flat.first() != Some(&pieces[0].from) {
            return false;
        }
        let mut at = Vec::with_capacity(pieces.len());
        let mut k = 0;
        for p in &pieces {
            while k < flat.len() && flat[k] != p.from {
                k += 1;
            }
            if k == flat.len() {
                return false;
            }
            at.push(k);
            k += 1;
        }
        let r = self.rings.len();
        for (j, p) in pieces.iter().enumerate() {
            self.starts.insert(key(p.from), (r, j));
        }
        self.rings.push(CurvedRing { pieces, flat, at });
        true
    }

    /// Every ring of `other` known here too.
    pub fn extend(&mut self, other: &Curves) {
        for c in &other.rings {
            self.insert(c.pieces.clone(), c.flat.clone());
        }
    }

    /// The pieces `ring` (a polygon, closing point not repeated) is the flattening of, in the
    /// ring's direction, and the index in `ring` where the first of them starts; `None` when
    /// the ring is not exactly a stored flattening.
    pub fn pieces_of(&self, ring: &[[f64; 2]]) -> Option<(usize, Vec<Piece>)> {
        let n = ring.len();
        let (q, &(r, j)) = ring
            .iter()
            .enumerate()
            .find_map(|(q, p)| Some((q, self.starts.get(&key(*p))?)))?;
        let c = &self.rings[r];
        if c.flat.len() != n {
            return None;
        }
        let s = c.at[j];
        let forward = (0..n).all(|i| ring[(q + i) % n] == c.flat[(s + i) % n]);
        if !forward && !(0..n).all(|i| ring[(q + i) % n] == c.flat[(s + n - i) % n]) {
            return None;
        }
        let mut p = c.pieces.clone();
        p.rotate_left(j);
        Some((q, if forward { p } else { reversed(&p) }))
    }
}

/// Arcs of more than `max_sweep` radians cut in two at their middles (until none is), so a
/// writer that takes arcs under a half turn (SVG's large-arc flag 0) can take any.
pub fn split_arcs(pieces: &[Piece], max_sweep: f64) -> Vec<Piece> {
    let n = pieces.len();
    let mut out = Vec::with_capacity(n);
    for (k, p) in pieces.iter().enumerate() {
        let to = pieces[(k + 1) % n].from;
        match arc_of(p.from, to, p.bulge) {
            Some(arc) if arc.sweep.abs() > max_sweep => {
                let parts = (arc.sweep.abs() / max_sweep).ceil().min(16.0) as usize;
                let b = (arc.sweep / parts as f64 / 4.0).tan();
                for s in 0..parts {
                    let from = if s == 0 {
                        p.from
                    } else {
                        let a = arc.start_angle + arc.sweep * s as f64 / parts as f64;
                        [
                            arc.center[0] + arc.radius * a.cos(),
                            arc.center[1] + arc.radius * a.sin(),
                        ]
                    };
                    out.push(Piece { from, bulge: b });
                }
            }
            _ => out.push(*p),
        }
    }
    out
}

mod smooth;

#[cfg(test)]
mod tests;
