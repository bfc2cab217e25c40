//! The tangent-continuous fit behind the parent module's `fit_ring`: an arc spline whose pieces
//! meet with the same tangent wherever the outline is smooth, and at an angle only where it has a
//! corner.
//!
//! Why: pieces fitted one by one (each its own best bulge) meet at angles; a machine slows at
//! every such joint, and a kerf offset adds a round join there (a G-code line of its own). Pieces
//! that share their tangents are what potrace-based tools give (Béziers, then biarcs); fitting the
//! arcs directly keeps one geometry for every file (see the parent module).
//!
//! How: greedy, from the ring's first vertex (a piece with its own bulge, through vertices, as the
//! parent fits them), each next piece is one arc leaving the last piece's end along its end
//! tangent, so the two meet smoothly. Its curvature is bounded by the vertices it must pass
//! within the tolerance and by the [`Sides`]; within those bounds it is the one that arrives
//! along the outline's own tangent at its last vertex (the chord between the vertices a few
//! tolerances either side), so the piece after it leaves along the outline rather than across
//! it. It ends where that last vertex is nearest it (within the tolerance of the vertex, not on
//! it). The ring closes with a biarc (two arcs meeting with a common tangent, joint chosen among
//! a few ratios) arriving along the first piece's start tangent, or one arc (a corner there).
//! Where no smooth piece reaches past a few vertices and a piece with its own bulge reaches
//! twice as far, that one is taken: a corner. Every candidate is measured, not assumed: every
//! vertex and edge of the ring it replaces within the tolerance of it, and it within the
//! tolerance of them (sampled finely enough that the steps between samples cannot hide an
//! excess), the sides kept, the box kept.
//!
//! What it costs: the [`Sides`] (pixel centres kept on their sides) and the staircase of a traced
//! outline leave a smooth arc little room, and the arcs that keep their tangents sometimes reach
//! less far than arcs that each choose their own; the parent keeps whichever fit of a ring costs
//! less ([`kinks`] counted as pieces).

use super::arc::{arc_box, arc_of, ArcGeom, Piece, Sides};
use crate::ring::{dist, seg_closest, seg_dist, wrap};

/// How far, in tolerances, the chord giving a vertex's tangent reaches on either side, and at
/// most how many vertices.
const REACH_TOLS: f64 = 4.0;
const MAX_REACH: usize = 8;

/// Largest sweep of one arc, radians: under a half turn (SVG's small-arc flag, the parent's
/// flattening), with room for the rounding of the written numbers.
const MAX_SWEEP: f64 = 0.9 * std::f64::consts::PI;

/// Joint ratios (the second tangent's length over the first's) a biarc is tried with.
const RATIOS: [f64; 3] = [1.0, 0.5, 2.0];

fn unit(v: [f64; 2]) -> Option<[f64; 2]> {
    let l = v[0].hypot(v[1]);
    (l > 0.0 && l.is_finite()).then(|| [v[0] / l, v[1] / l])
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

fn rotate(v: [f64; 2], a: f64) -> [f64; 2] {
    let (s, c) = a.sin_cos();
    [v[0] * c - v[1] * s, v[0] * s + v[1] * c]
}

/// One piece under test: a line or an arc from `a` to `b`.
#[derive(Clone, Copy, Debug)]
struct Part {
    a: [f64; 2],
    b: [f64; 2],
    bulge: f64,
    arc: Option<ArcGeom>,
}

impl Part {
    fn new(a: [f64; 2], b: [f64; 2], bulge: f64) -> Part {
        let arc = if bulge.abs() < 1e-12 {
            None
        } else {
            arc_of(a, b, bulge)
        };
        Part {
            a,
            b,
            bulge: if arc.is_some() { bulge } else { 0.0 },
            arc,
        }
    }

    /// The arc leaving `a` along the unit tangent `t` and ending at `b` (a line when `t` runs
    /// along the chord); `None` when it would sweep more than [`MAX_SWEEP`].
    fn leaving(a: [f64; 2], t: [f64; 2], b: [f64; 2]) -> Option<Part> {
        let c = sub(b, a);
        if c == [0.0, 0.0] {
            return None;
        }
        // The tangent turns by half the sweep from the chord's direction.
        let half = cross(t, c).atan2(dot(t, c));
        (2.0 * half.abs() <= MAX_SWEEP).then(|| Part::new(a, b, (half / 2.0).tan()))
    }

    /// The unit tangent at `b`.
    fn end_tangent(&self) -> [f64; 2] {
        let c = unit(sub(self.b, self.a)).unwrap_or([1.0, 0.0]);
        match self.arc {
            Some(arc) => rotate(c, arc.sweep / 2.0),
            None => c,
        }
    }

    fn start_tangent(&self) -> [f64; 2] {
        let c = unit(sub(self.b, self.a)).unwrap_or([1.0, 0.0]);
        match self.arc {
            Some(arc) => rotate(c, -arc.sweep / 2.0),
            None => c,
        }
    }

    /// Whether `p`'s direction from the centre is within the arc's sweep.
    fn spans(&self, arc: &ArcGeom, p: [f64; 2]) -> bool {
        use std::f64::consts::TAU;
        // A sweep under a half turn is where the direction is left of the start's and right of
        // the end's (counter-clockwise; the other way round clockwise). Where both sides are
        // clear by a billionth of a radian, far more than the angles' rounding, that answers
        // as the angles below would, without an arctangent; nearer an end (where a piece's
        // last vertex often is), the angles decide, as they always did.
        if arc.sweep.abs() < std::f64::consts::PI {
            let v = sub(p, arc.center);
            let (s0, e0) = (sub(self.a, arc.center), sub(self.b, arc.center));
            let (c1, c2) = if arc.sweep > 0.0 {
                (cross(s0, v), cross(v, e0))
            } else {
                (cross(v, s0), cross(e0, v))
            };
            // Squared: c > 1e-9 r |v| with no square root.
            let e2 = 1e-18 * arc.radius * arc.radius * dot(v, v);
            let clear = |c: f64| c * c > e2;
            if c1 > 0.0 && c2 > 0.0 && clear(c1) && clear(c2) {
                return true;
            }
            if (c1 < 0.0 && clear(c1)) || (c2 < 0.0 && clear(c2)) {
                return false;
            }
        }
        let ang = (p[1] - arc.center[1]).atan2(p[0] - arc.center[0]);
        if arc.sweep > 0.0 {
            (ang - arc.start_angle).rem_euclid(TAU) <= arc.sweep
        } else {
            (arc.start_angle - ang).rem_euclid(TAU) <= -arc.sweep
        }
    }

    /// Distance from `p` to the piece.
    fn dist(&self, p: [f64; 2]) -> f64 {
        self.dist_spans(p).0
    }

    /// [`Part::dist`], and whether `p` is within an arc's sweep (false for a line): what
    /// [`Part::left_of`] needs, so that the sweep is asked once.
    fn dist_spans(&self, p: [f64; 2]) -> (f64, bool) {
        match self.arc {
            Some(arc) if self.spans(&arc, p) => ((dist(p, arc.center) - arc.radius).abs(), true),
            Some(_) => (dist(p, self.a).min(dist(p, self.b)), false),
            None => (seg_dist(p, self.a, self.b), false),
        }
    }

    /// Signed distance, positive on the piece's left (beyond its ends, by the tangent there),
    /// given whether `p` is within the arc's sweep ([`Part::dist_spans`]).
    fn left_of(&self, p: [f64; 2], spans: bool) -> f64 {
        match self.arc {
            Some(arc) if spans => self.bulge.signum() * (arc.radius - dist(p, arc.center)),
            _ => {
                let (e, t) = if dist(p, self.a) <= dist(p, self.b) {
                    (self.a, self.start_tangent())
                } else {
                    (self.b, self.end_tangent())
                };
                match self.arc {
                    None => {
                        let c = unit(sub(self.b, self.a)).unwrap_or(t);
                        cross(c, sub(p, self.a))
                    }
                    Some(_) => cross(t, sub(p, e)),
                }
            }
        }
    }

    fn length(&self) -> f64 {
        match self.arc {
            Some(a) => a.radius * a.sweep.abs(),
            None => dist(self.a, self.b),
        }
    }

    /// The point a fraction `s` of the way along.
    fn point(&self, s: f64) -> [f64; 2] {
        match self.arc {
            Some(a) => {
                let ang = a.start_angle + a.sweep * s;
                [
                    a.center[0] + a.radius * ang.cos(),
                    a.center[1] + a.radius * ang.sin(),
                ]
            }
            None => [
                self.a[0] + s * (self.b[0] - self.a[0]),
                self.a[1] + s * (self.b[1] - self.a[1]),
            ],
        }
    }
}

/// The biarc from `a` leaving along `ta` to `b` arriving along `tb`, its second tangent `ratio`
/// times as long as its first; `None` when there is none with both sweeps under [`MAX_SWEEP`].
fn biarc(a: [f64; 2], ta: [f64; 2], b: [f64; 2], tb: [f64; 2], ratio: f64) -> Option<[Part; 2]> {
    let v = sub(b, a);
    let w = [ta[0] + ratio * tb[0], ta[1] + ratio * tb[1]];
    let vw = dot(v, w);
    let vv = dot(v, v);
    let k = 2.0 * ratio * (1.0 - dot(ta, tb));
    // k α² + 2 (v·w) α - v·v = 0: the tangents' lengths α and ratio·α meet where the joint's
    // two tangent segments add up to the distance between their far ends.
    let alpha = if k.abs() < 1e-12 {
        if vw <= 0.0 {
            return None;
        }
        vv / (2.0 * vw)
    } else {
        (-vw + (vw * vw + k * vv).sqrt()) / k
    };
    if !(alpha.is_finite() && alpha > 0.0) {
        return None;
    }
    let beta = ratio * alpha;
    let qa = [a[0] + alpha * ta[0], a[1] + alpha * ta[1]];
    let qb = [b[0] - beta * tb[0], b[1] - beta * tb[1]];
    let j = [
        (beta * qa[0] + alpha * qb[0]) / (alpha + beta),
        (beta * qa[1] + alpha * qb[1]) / (alpha + beta),
    ];
    let tj = unit(sub(qb, qa))?;
    let first = Part::leaving(a, ta, j)?;
    let second = Part::leaving(j, tj, b)?;
    Some([first, second])
}

/// What the greedy measures candidates against: the ring, its sides, the box, the tolerance.
struct Fit<'a> {
    ring: &'a [[f64; 2]],
    sides: Option<Sides<'a>>,
    bounds: Option<[f64; 4]>,
    tol: f64,
}

impl Fit<'_> {
    fn at(&self, k: usize) -> [f64; 2] {
        self.ring[wrap(k, self.ring.len())]
    }

    /// Whether `parts`, running from `prev`'s end (within the tolerance of vertex `i`; vertex
    /// `i` itself without `prev`) to vertex `j` (which may be the ring's length: its first
    /// vertex again) or within the tolerance of it, replace the vertices and edges between
    /// within the tolerance both ways, keep the sides and stay in the box. `prev`, the piece
    /// before, holds what of the ring around vertex `i` these parts do not.
    fn holds(&self, parts: &[Part], prev: Option<&Part>, i: usize, j: usize) -> bool {
        let tol = self.tol;
        let n = self.ring.len();
        // Sample spacing: a distance grows by at most the step between samples, so a sample
        // within tol - h/2 leaves every point between within tol.
        let h = tol / 8.0;
        let all = || parts.iter().chain(prev);
        if parts.iter().any(|p| p.length() <= 0.0) {
            return false;
        }
        // The cheap conditions first (the answer is the same whatever their order): the sides,
        // the box, then the sampled distances both ways.
        if let Some(sd) = self.sides {
            let m = sd.points.len();
            // The left distance by the nearest part (the first of equals).
            let side = |p: [f64; 2]| {
                let mut near: Option<(&Part, f64, bool)> = None;
                for q in all() {
                    let (d, spans) = q.dist_spans(p);
                    if near.is_none_or(|n| d.total_cmp(&n.1).is_lt()) {
                        near = Some((q, d, spans));
                    }
                }
                near.map_or(0.0, |(q, _, spans)| q.left_of(p, spans))
            };
            for k in i..=j {
                let [l, r] = sd.points[wrap(k, m)];
                if side(l) < sd.margin || side(r) > -sd.margin {
                    return false;
                }
            }
        }
        if let Some(bx) = self.bounds {
            for part in parts {
                if let Some(arc) = part.arc {
                    let e = arc_box(&arc, part.a, part.b);
                    if e[0] < bx[0] - 1e-9
                        || e[1] < bx[1] - 1e-9
                        || e[2] > bx[2] + 1e-9
                        || e[3] > bx[3] + 1e-9
                    {
                        return false;
                    }
                }
            }
        }
        // The distance from `p` to the nearest of the parts (a NaN one skipped; infinity for
        // none).
        let nearest = |p: [f64; 2]| {
            all()
                .map(|q| q.dist(p))
                .filter(|d| !d.is_nan())
                .fold(f64::INFINITY, f64::min)
        };
        let lim = tol - h / 2.0;
        // The ring to the parts: each edge, exactly where one arc or line holds both its ends
        // (a line's distance is convex; an arc's outward distance is too, and its inward one is
        // largest where the edge comes closest to the centre), else sampled.
        for k in i..j {
            let (p, q) = (self.at(k), self.at(k + 1));
            let exact = parts.iter().any(|part| match part.arc {
                None => part.dist(p) <= tol && part.dist(q) <= tol,
                // Within the sweep, `dist` is the distance to the circle (not asked again).
                Some(arc) => {
                    part.spans(&arc, p)
                        && part.spans(&arc, q)
                        && (dist(p, arc.center) - arc.radius).abs() <= tol
                        && (dist(q, arc.center) - arc.radius).abs() <= tol
                        && arc.radius - seg_dist(arc.center, p, q) <= tol
                }
            });
            if exact {
                continue;
            }
            let len = dist(p, q);
            let steps = (len / h).ceil().max(1.0) as usize;
            let gap = len / steps as f64;
            // A distance to fixed pieces changes no faster than the point moves, so the samples
            // within `lim - d` of one at distance `d` are within `lim` too: not measured (less a
            // nanometre, for the arithmetic's rounding).
            let mut s = 0;
            while s <= steps {
                let t = s as f64 / steps as f64;
                let x = [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])];
                let d = nearest(x);
                if d > lim {
                    return false;
                }
                let room = lim - 1e-9 - d;
                let skip = if gap > 0.0 && room > 0.0 {
                    (room / gap).floor().min(steps as f64) as usize
                } else {
                    0
                };
                s += 1 + skip;
            }
        }
        // The parts to the ring: samples against the edges near where the last one was nearest
        // (the distance to a few edges bounds the distance to all of them from above), from
        // the edge before vertex i (the parts may start before it).
        let first = if prev.is_some() { i + n - 1 } else { i + n };
        let end = j + n - 1;
        let mut e = first;
        for part in parts {
            let steps = (part.length() / h).ceil().max(1.0) as usize;
            // Samples closer to one measured than its room under `lim` are skipped, as above
            // (the step between samples along the part is at least the distance between them).
            let gap = part.length() / steps as f64;
            let mut s = 0;
            while s <= steps {
                let x = part.point(s as f64 / steps as f64);
                let (lo, hi) = (e.saturating_sub(2).max(first), (e + 12).min(end));
                // Squared distances compared (one square root per sample, not one per edge).
                let (mut best, mut at) = (f64::INFINITY, e);
                for k in lo..=hi {
                    let c = seg_closest(x, self.at(k), self.at(k + 1));
                    let d = (x[0] - c[0]).powi(2) + (x[1] - c[1]).powi(2);
                    if d < best {
                        best = d;
                        at = k;
                    }
                }
                let best = best.sqrt();
                if best > lim {
                    return false;
                }
                e = at;
                let room = lim - 1e-9 - best;
                let skip = if gap > 0.0 && room > 0.0 {
                    (room / gap).floor().min(steps as f64) as usize
                } else {
                    0
                };
                s += 1 + skip;
            }
        }
        true
    }
}

/// The longest `j` in `i + 1 ..= last` for which `try_at` gives something, galloping then
/// halving (a span that fits usually means every shorter one does), with what it gave.
fn farthest<T>(i: usize, last: usize, try_at: impl Fn(usize) -> Option<T>) -> Option<(usize, T)> {
    let mut best = None;
    let mut step = 1;
    let mut fail = last + 1;
    while i + step <= last {
        match try_at(i + step) {
            Some(t) => best = Some((i + step, t)),
            None => {
                fail = i + step;
                break;
            }
        }
        step *= 2;
    }
    if fail > last && best.as_ref().is_none_or(|b| b.0 < last) {
        match try_at(last) {
            Some(t) => return Some((last, t)),
            None => fail = last,
        }
    }
    let mut lo = best.as_ref().map_or(i, |b| b.0);
    let mut hi = fail.min(last + 1);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        match try_at(mid) {
            Some(t) => {
                best = Some((mid, t));
                lo = mid;
            }
            None => hi = mid,
        }
    }
    best
}

impl Fit<'_> {
    /// The outline's tangent at vertex `k`: the chord between the vertices a few tolerances
    /// before and after it (at most [`MAX_REACH`] vertices away), so the traced steps average
    /// out.
    fn tangent(&self, k: usize) -> Option<[f64; 2]> {
        let n = self.ring.len();
        let step = |dir: isize| {
            let mut j = k as isize;
            let mut len = 0.0;
            for _ in 0..MAX_REACH {
                let next = j + dir;
                len += dist(
                    self.at(j.rem_euclid(n as isize) as usize),
                    self.at(next.rem_euclid(n as isize) as usize),
                );
                j = next;
                if len >= REACH_TOLS * self.tol {
                    break;
                }
            }
            self.at(j.rem_euclid(n as isize) as usize)
        };
        unit(sub(step(1), step(-1)))
    }

    /// The arc leaving `s` along `t` that follows the vertices after `i` up to `j` within the
    /// tolerance, ending where vertex `j` is nearest it: its curvature is the middle of what
    /// the vertices (a circle tangent at `s` through each, give or take the tolerance) and the
    /// sides allow, then measured ([`Fit::holds`]).
    fn follow(&self, prev: &Part, i: usize, j: usize) -> Option<Part> {
        let (s, t) = (prev.b, prev.end_tangent());
        let tol = self.tol;
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        // The curvature of the circle tangent to t at s through p, and how much it changes for
        // p moved by one unit across: 2 h / L², h the offset across t, L the distance.
        let kappa = |p: [f64; 2]| -> Option<(f64, f64)> {
            let d = sub(p, s);
            let l2 = dot(d, d);
            (l2 > tol * tol && dot(d, t) > 0.0).then(|| (2.0 * cross(t, d) / l2, 2.0 / l2))
        };
        for k in i + 1..=j {
            if let Some((c, w)) = kappa(self.at(k)) {
                lo = lo.max(c - w * tol);
                hi = hi.min(c + w * tol);
            }
        }
        if let Some(sd) = self.sides {
            let n = sd.points.len();
            for k in i..=j {
                let [l, r] = sd.points[wrap(k, n)];
                // Left points must stay left: the curve turns left less than through them.
                if let Some((c, w)) = kappa(l) {
                    hi = hi.min(c - w * sd.margin);
                }
                if let Some((c, w)) = kappa(r) {
                    lo = lo.max(c + w * sd.margin);
                }
            }
        }
        // The curvature that arrives along the outline's own tangent at vertex j, within what
        // the vertices allow: the next piece then leaves along the outline, not across it.
        let want = self.tangent(j).map(|tj| {
            let d = sub(self.at(j), s);
            let turn = cross(t, tj).atan2(dot(t, tj));
            2.0 * (turn / 2.0).sin() / dot(d, d).sqrt()
        });
        let k = match (lo.is_finite(), hi.is_finite()) {
            (true, true) if lo <= hi => want.map_or((lo + hi) / 2.0, |w| w.clamp(lo, hi)),
            (true, true) => return None,
            (true, false) => lo,
            (false, true) => hi,
            (false, false) => 0.0,
        };
        let p = self.at(j);
        let part = if (k * dist(p, s)).abs() < 1e-9 {
            let along = dot(sub(p, s), t);
            if along <= 0.0 {
                return None;
            }
            Part::new(s, [s[0] + along * t[0], s[1] + along * t[1]], 0.0)
        } else {
            let nrm = [-t[1], t[0]];
            let c = [s[0] + nrm[0] / k, s[1] + nrm[1] / k];
            let r = 1.0 / k.abs();
            let u = unit(sub(p, c))?;
            let e = [c[0] + r * u[0], c[1] + r * u[1]];
            let (cs, ce) = (sub(s, c), sub(e, c));
            let mut sweep = cross(cs, ce).atan2(dot(cs, ce));
            if k > 0.0 && sweep < 0.0 {
                sweep += std::f64::consts::TAU;
            } else if k < 0.0 && sweep > 0.0 {
                sweep -= std::f64::consts::TAU;
            }
            if sweep.abs() > MAX_SWEEP || sweep == 0.0 {
                return None;
            }
            Part::new(s, e, (sweep / 4.0).tan())
        };
        self.holds(&[part], Some(prev), i, j).then_some(part)
    }

    /// The pieces from `s` (leaving along `t`) that close the ring at its first vertex,
    /// arriving along `t0` (the first piece's start tangent): a biarc, else one arc (a corner
    /// at the close).
    fn close(&self, prev: &Part, i: usize, t0: [f64; 2]) -> Option<Vec<Part>> {
        let n = self.ring.len();
        let (s, t) = (prev.b, prev.end_tangent());
        let end = self.ring[0];
        RATIOS
            .iter()
            .find_map(|&r| {
                let parts = biarc(s, t, end, t0, r)?;
                self.holds(&parts, Some(prev), i, n).then(|| parts.to_vec())
            })
            .or_else(|| {
                let p = Part::leaving(s, t, end)?;
                self.holds(&[p], Some(prev), i, n).then(|| vec![p])
            })
    }
}

/// The tangent-continuous fit (see the module's notes). `free(i, s)` fits one piece from the
/// point `s` (vertex `i` or a point the last piece ended at, within the tolerance of it) with
/// its own start tangent (the parent's fit, through the vertices): the end vertex, and the
/// bulge.
pub(super) fn fit(
    ring: &[[f64; 2]],
    tol: f64,
    sides: Option<Sides>,
    bounds: Option<[f64; 4]>,
    max_run: usize,
    free: impl Fn(usize, [f64; 2]) -> (usize, f64),
) -> Vec<Piece> {
    let n = ring.len();
    let f = Fit {
        ring,
        sides,
        bounds,
        tol,
    };
    let mut out: Vec<Part> = Vec::new();
    let mut i = 0;
    // The first piece's start tangent: the last arrives along it.
    let mut t0: Option<[f64; 2]> = None;
    while i < n {
        let last = (i + max_run).min(n);
        let s = out.last().map_or(ring[0], |p| p.b);
        let smooth = out.last().copied().and_then(|prev| {
            farthest(i, last, |j| {
                if j == n {
                    f.close(&prev, i, t0.unwrap_or(prev.end_tangent()))
                } else {
                    f.follow(&prev, i, j).map(|p| vec![p])
                }
            })
        });
        let rs = smooth.as_ref().map_or(0, |(j, _)| j - i);
        // A corner: where no smooth piece reaches past a few vertices and one with its own
        // tangent reaches twice as far (or at the ring's start).
        let corner = (rs < 4)
            .then(|| {
                let (j, bulge) = free(i, s);
                (rs == 0 || j - i >= 2 * rs).then(|| (j, vec![Part::new(s, f.at(j), bulge)]))
            })
            .flatten();
        let Some((j, parts)) = corner.or(smooth) else {
            unreachable!("a corner is fitted where no smooth piece is");
        };
        if out.is_empty() {
            t0 = Some(parts[0].start_tangent());
        }
        out.extend(parts);
        i = j;
    }
    // A piece of no length (a ring's repeated vertex) is no piece.
    out.into_iter()
        .filter(|p| p.a != p.b)
        .map(|p| Piece {
            from: p.a,
            bulge: p.bulge,
        })
        .collect()
}

/// How far a joint's tangents may turn and still cost nothing, radians: 15 degrees, where a
/// 0.2 mm kerf's offset mitres the joint within a micrometre instead of adding a round join, and
/// a machine's junction deviation keeps most of its speed.
const SHARP_JOINT: f64 = 15.0 * std::f64::consts::PI / 180.0;

/// How many joints of the closed pieces turn by more than [`SHARP_JOINT`]: the corners a machine
/// slows at.
pub(super) fn kinks(pieces: &[Piece]) -> usize {
    let m = pieces.len();
    // Each piece's tangents at both ends, worked out once.
    let ends: Vec<([f64; 2], [f64; 2])> = (0..m)
        .map(|k| {
            let part = Part::new(pieces[k].from, pieces[(k + 1) % m].from, pieces[k].bulge);
            (part.start_tangent(), part.end_tangent())
        })
        .collect();
    (0..m)
        .filter(|&k| {
            let (a, b) = (ends[(k + m - 1) % m].1, ends[k].0);
            cross(a, b).atan2(dot(a, b)).abs() > SHARP_JOINT
        })
        .count()
}

impl Fit<'_> {
    /// The arc (or line) from `s` that follows the vertices after `i` up to `j` best, its
    /// tangent at `s` free: the least-squares circle through `s` and those vertices, moved until
    /// the sides' points are on their sides, ending where vertex `j` is nearest it, then
    /// measured ([`Fit::holds`]).
    /// The sums [`Fit::through`] fits a circle by, of the vertices after `i` from `s`: for each
    /// `j` in `i + 1 ..= to`, those of the vertices up to `j`. Running sums, so each is what
    /// summing its vertices alone gives, to the bit (the same additions in the same order), and
    /// a search over shorter and shorter spans sums its vertices once.
    fn moments(&self, s: [f64; 2], i: usize, to: usize) -> Vec<[f64; 6]> {
        let mut m = [0.0; 6];
        (i + 1..=to)
            .map(|k| {
                let q = sub(self.at(k), s);
                let r2 = dot(q, q);
                m[0] += q[0] * q[0];
                m[1] += q[0] * q[1];
                m[2] += q[1] * q[1];
                m[3] += r2 * q[0];
                m[4] += r2 * q[1];
                m[5] += r2 * r2;
                m
            })
            .collect()
    }

    /// `sums`: [`Fit::moments`] of the vertices after `i` up to `j`.
    fn through(
        &self,
        s: [f64; 2],
        prev: Option<&Part>,
        i: usize,
        j: usize,
        sums: [f64; 6],
    ) -> Option<Part> {
        let p = self.at(j);
        // The circle (or line) through the origin (s): c |q|² + a qx + b qy = 0 with a² + b² = 1,
        // by least squares. With that normalisation the left side's gradient has length 1 all
        // along the circle, so it is the distance to the circle near it (Pratt's fit held through
        // s; Kåsa's, normalised by c, shrinks the circles of short noisy arcs).
        let [sxx, sxy, syy, bx, by, s4] = sums;
        if s4 <= 0.0 {
            return None;
        }
        // c eliminated: (a, b) is the smaller eigenvector of S - v vᵀ / s4.
        let (m11, m12, m22) = (sxx - bx * bx / s4, sxy - bx * by / s4, syy - by * by / s4);
        let th = 0.5 * (2.0 * m12).atan2(m11 - m22);
        let (a, b) = (-th.sin(), th.cos());
        let c = -(a * bx + b * by) / s4;
        let q = sub(p, s);
        let mut centre = (c != 0.0).then(|| [s[0] - a / (2.0 * c), s[1] - b / (2.0 * c)]);
        // A circle that misses the vertices by much more than the tolerance will not hold
        // after the small moves below: not measured.
        if let Some(c0) = centre {
            let r0 = dist(c0, s);
            // From the far end, where a span too long misses first (the answer is the same).
            if (i + 1..=j)
                .rev()
                .any(|k| (dist(self.at(k), c0) - r0).abs() > 1.5 * self.tol)
            {
                return None;
            }
        }
        // The sides' points on their sides: the circles through s are |q|² = w·q (w twice the
        // centre, from s), inside where |q|² < w·q, linear in w; the least-squares w is moved
        // onto each violated side in turn (Kaczmarz's projections) until none is, for a few
        // rounds (what is left is measured). A point's margin is about 2 r times its distance
        // from the circle; half as much again, for the radius the moves change.
        if let (Some(c0), Some(sd)) = (centre, self.sides) {
            let mut w = [2.0 * (c0[0] - s[0]), 2.0 * (c0[1] - s[1])];
            let r0 = dist(c0, s);
            let ccw = cross(sub(s, c0), sub(self.at((i + 1 + j) / 2), c0)) > 0.0;
            let m = 2.0 * r0 * sd.margin * 1.5;
            let np = sd.points.len();
            // Each point from s, its square length and its side, in order: the same every round.
            let points: Vec<([f64; 2], f64, bool)> = (i..=j)
                .flat_map(|k| {
                    let [l, r] = sd.points[wrap(k, np)];
                    let (inner, outer) = if ccw { (l, r) } else { (r, l) };
                    [(inner, true), (outer, false)]
                })
                .filter_map(|(pt, inside)| {
                    let q = sub(pt, s);
                    let q2 = dot(q, q);
                    (q2 != 0.0).then_some((q, q2, inside))
                })
                .collect();
            for _ in 0..12 {
                let mut moved = false;
                for &(q, q2, inside) in &points {
                    // inside: q2 + m - w·q <= 0; outside: w·q - q2 + m <= 0.
                    let v = if inside {
                        q2 + m - dot(w, q)
                    } else {
                        dot(w, q) - q2 + m
                    };
                    if v > 0.0 {
                        let f = if inside { v / q2 } else { -v / q2 };
                        w = [w[0] + f * q[0], w[1] + f * q[1]];
                        moved = true;
                    }
                }
                if !moved {
                    break;
                }
            }
            centre = Some([s[0] + w[0] / 2.0, s[1] + w[1] / 2.0]);
        }
        let part = match centre {
            Some(c) if dist(c, s) < 1e4 * dist(p, s) => {
                let r = dist(c, s);
                let e = {
                    let u = unit(sub(p, c))?;
                    [c[0] + r * u[0], c[1] + r * u[1]]
                };
                // Which way round: the way that passes the middle vertex first.
                let (cs, ce) = (sub(s, c), sub(e, c));
                let mid = sub(self.at((i + 1 + j) / 2), c);
                let ccw = cross(cs, mid) > 0.0;
                let mut sweep = cross(cs, ce).atan2(dot(cs, ce));
                if ccw && sweep < 0.0 {
                    sweep += std::f64::consts::TAU;
                } else if !ccw && sweep > 0.0 {
                    sweep -= std::f64::consts::TAU;
                }
                if sweep.abs() > MAX_SWEEP || sweep == 0.0 {
                    return None;
                }
                Part::new(s, e, (sweep / 4.0).tan())
            }
            _ => {
                // A line: along the vertices' principal direction from s.
                let d = [b, -a];
                let along = dot(q, d);
                if along == 0.0 {
                    return None;
                }
                Part::new(s, [s[0] + along * d[0], s[1] + along * d[1]], 0.0)
            }
        };
        self.holds(&[part], prev, i, j).then_some(part)
    }
}

/// A third fit: pieces meeting end to end, each the least-squares arc through the last one's end
/// and the vertices it replaces, its pixel centres kept on their sides ([`Fit::through`]), ending
/// within the tolerance of a vertex, not on it. A piece through the vertices with its own bulge
/// (`free`, as in [`fit`]) takes over where it reaches twice as far, and closes the ring on its
/// first vertex.
///
/// Why: a traced outline's vertices stray from the smooth curve it was traced from by up to
/// three quarters of the default tolerance (the staircase's steps), so a piece whose ends are
/// vertices (round 3's fit) or whose start tangent is the last piece's (the smooth fit) has
/// little room left; a piece that chooses its own circle through the middle of the steps
/// reaches farther. Its joints mostly turn by a few degrees, fewer of them sharply than the
/// other fits' (samples/rings.png: 204 joints, 44 of them over 15 degrees, against 268 and 69).
pub(super) fn fit_loose(
    ring: &[[f64; 2]],
    tol: f64,
    sides: Option<Sides>,
    bounds: Option<[f64; 4]>,
    max_run: usize,
    free: impl Fn(usize, [f64; 2]) -> (usize, f64),
) -> Vec<Piece> {
    let n = ring.len();
    let f = Fit {
        ring,
        sides,
        bounds,
        tol,
    };
    let mut out: Vec<Part> = Vec::new();
    let mut i = 0;
    // The last piece's span: the next one is tried from twice that down.
    let mut long = 0;
    while i < n {
        let s = out.last().map_or(ring[0], |p| p.b);
        let (jf, bulge) = free(i, s);
        let reach = if jf == n {
            None
        } else {
            // Longest first (from twice the last piece's span): a least-squares circle over a
            // short stretch follows the staircase's steps, over a long one the curve they were
            // traced from, so a longer span can hold where a shorter one does not.
            let last = (i + max_run).min(n - 1);
            let mut span = (last - i).min(2 * long.max(32));
            let sums = f.moments(s, i, i + span);
            let mut found = None;
            while span >= 1 {
                if let Some(p) = f.through(s, out.last(), i, i + span, sums[span - 1]) {
                    found = Some((i + span, p));
                    break;
                }
                span = span * 3 / 4;
            }
            found
        };
        match reach {
            Some((j, part)) if jf - i < 2 * (j - i) => {
                long = j - i;
                out.push(part);
                i = j;
            }
            _ => {
                out.push(Part::new(s, f.at(jf), bulge));
                i = jf;
            }
        }
    }
    out.into_iter()
        .filter(|p| p.a != p.b)
        .map(|p| Piece {
            from: p.a,
            bulge: p.bulge,
        })
        .collect()
}
