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
//! How: greedy, from the ring's first point, each piece runs from one polygon vertex to a later
//! one, as far as an arc (or a line) stays within the tolerance of every vertex and every edge it
//! replaces. The pieces' ends are polygon vertices, so corners are kept: no arc can round a corner
//! by more than the tolerance. An arc's radius is chosen as the middle of the range the vertices
//! allow (the circle through both ends and each vertex gives one bulge; the middle of their spread
//! halves the worst deviation), then every vertex and edge is measured against it. Arcs sweep less
//! than a half turn (their vertices project monotonically onto the chord, so the order along the
//! arc is the polygon's).
//!
//! The bulge is DXF's: `tan(sweep / 4)`, positive counter-clockwise in the numeric (x, y) plane.

use crate::ring::dist;

/// One piece of a closed outline: from `from` to the next piece's `from` (the first piece's after
/// the last), straight when `bulge` is 0, else a circular arc that sweeps `4 atan(bulge)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    pub from: [f64; 2],
    pub bulge: f64,
}

/// An arc's circle and sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArcGeom {
    pub center: [f64; 2],
    pub radius: f64,
    /// Angle of `from` about the centre, radians.
    pub start_angle: f64,
    /// Signed sweep, radians: positive counter-clockwise in the numeric (x, y) plane.
    pub sweep: f64,
}

/// The arc from `a` to `b` with `bulge`; `None` for a line (bulge 0) or a chord of length 0.
pub fn arc_of(a: [f64; 2], b: [f64; 2], bulge: f64) -> Option<ArcGeom> {
    let l = dist(a, b);
    if bulge == 0.0 || l == 0.0 || !bulge.is_finite() {
        return None;
    }
    let sweep = 4.0 * bulge.atan();
    let radius = l / (2.0 * (sweep.abs() / 2.0).sin());
    // Centre: from the chord's midpoint along its left normal by d, where the arc's midpoint is
    // at h = -bulge·L/2 along the same normal (a counter-clockwise arc bulges to the right).
    let h = -bulge * l / 2.0;
    let d = (h * h - l * l / 4.0) / (2.0 * h);
    let t = [(b[0] - a[0]) / l, (b[1] - a[1]) / l];
    let nrm = [-t[1], t[0]];
    let m = [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
    let center = [m[0] + d * nrm[0], m[1] + d * nrm[1]];
    let start_angle = (a[1] - center[1]).atan2(a[0] - center[0]);
    Some(ArcGeom {
        center,
        radius,
        start_angle,
        sweep,
    })
}

/// Longest run of polygon vertices one piece may replace: bounds the fit's work (quadratic in
/// the run) on long smooth stretches.
const MAX_RUN: usize = 400;

/// Fit a closed ring (closing point not repeated) with lines and arcs, every vertex and edge of
/// the ring within `tol` of the pieces and the pieces within `tol` of the ring. The first piece
/// starts at `ring[0]`. A ring of fewer than 3 points, or `tol` ≤ 0, comes back as its lines.
pub fn fit_ring(ring: &[[f64; 2]], tol: f64) -> Vec<Piece> {
    let n = ring.len();
    let lines = || {
        ring.iter()
            .map(|&from| Piece { from, bulge: 0.0 })
            .collect::<Vec<_>>()
    };
    if n < 3 || tol.is_nan() || tol <= 0.0 {
        return lines();
    }
    let at = |i: usize| ring[i % n];
    let mut out = Vec::new();
    let mut i = 0;
    while i < n {
        // Galloping, then halving: spans of 2, 4, 8, ... vertices until one fails, then the
        // longest that fits between the last that fitted and the first that failed (a span that
        // fits usually means every shorter one does), so a long arc costs a few passes over its
        // vertices, not one per vertex.
        let mut best = (i + 1, 0.0);
        let last = (i + MAX_RUN).min(n);
        let mut step = 2;
        let mut fail = last + 1;
        while i + step <= last {
            match fit_span(&at, i, i + step, tol) {
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
            match fit_span(&at, i, last, tol) {
                Some(b) => best = (last, b),
                None => fail = last,
            }
        }
        let (mut lo, mut hi) = (best.0, fail.min(last + 1));
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            match fit_span(&at, i, mid, tol) {
                Some(b) => {
                    best = (mid, b);
                    lo = mid;
                }
                None => hi = mid,
            }
        }
        out.push(Piece {
            from: ring[i],
            bulge: best.1,
        });
        i = best.0;
    }
    out
}

/// The bulge of one piece from vertex `i` to vertex `j` (indices into the ring, `j` may be the
/// ring's length: its first point again) within `tol` of every vertex and edge between, or `None`
/// when no line or half-turn arc fits.
fn fit_span(at: &impl Fn(usize) -> [f64; 2], i: usize, j: usize, tol: f64) -> Option<f64> {
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
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
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
        // The circle through a, b and this vertex: its centre at d on the normal, and the
        // sagitta h of its minor arc; a vertex outside the circle on the chord as diameter
        // would need more than a half turn.
        let w = u * u + v * v - half * half;
        let bulge = if v == 0.0 {
            0.0
        } else {
            if w > 0.0 {
                return None;
            }
            let d = w / (2.0 * v);
            let r = (d * d + half * half).sqrt();
            let h = -(half * half) / (d + d.signum() * r);
            -h / half
        };
        lo = lo.min(bulge);
        hi = hi.max(bulge);
    }
    if straight {
        return Some(0.0);
    }
    let bulge = ((lo + hi) / 2.0).clamp(-0.999, 0.999);
    let arc = arc_of(a, b, bulge)?;
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
    Some(bulge)
}

/// Distance from `p` to the segment `a`–`b`.
fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    dist(p, [a[0] + t * d[0], a[1] + t * d[1]])
}

/// The pieces as a polygon (closing point not repeated): lines as they are, arcs cut into chords
/// no farther than `tol` from the arc, every chord end on the arc.
pub fn flatten(pieces: &[Piece], tol: f64) -> Vec<[f64; 2]> {
    let n = pieces.len();
    let mut out = Vec::with_capacity(n);
    for (k, p) in pieces.iter().enumerate() {
        out.push(p.from);
        let to = pieces[(k + 1) % n].from;
        if let Some(arc) = arc_of(p.from, to, p.bulge) {
            let step = if tol > 0.0 && tol < arc.radius {
                2.0 * (1.0 - tol / arc.radius).acos()
            } else {
                std::f64::consts::FRAC_PI_2
            };
            let count = (arc.sweep.abs() / step).ceil().clamp(1.0, 1e5) as usize;
            for s in 1..count {
                let a = arc.start_angle + arc.sweep * s as f64 / count as f64;
                out.push([
                    arc.center[0] + arc.radius * a.cos(),
                    arc.center[1] + arc.radius * a.sin(),
                ]);
            }
        }
    }
    out
}

/// How many of the pieces are arcs.
pub fn arc_count(pieces: &[Piece]) -> usize {
    pieces.iter().filter(|p| p.bulge != 0.0).count()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest distance from any point of `a` (dense) to the polygon `b`, both closed.
    fn one_way(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
        let n = b.len();
        a.iter()
            .map(|&p| {
                (0..n)
                    .map(|i| seg_dist(p, b[i], b[(i + 1) % n]))
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max)
    }

    fn densify(r: &[[f64; 2]], step: f64) -> Vec<[f64; 2]> {
        let n = r.len();
        let mut out = Vec::new();
        for i in 0..n {
            let (a, b) = (r[i], r[(i + 1) % n]);
            let k = (dist(a, b) / step).ceil().max(1.0) as usize;
            for s in 0..k {
                let t = s as f64 / k as f64;
                out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
            }
        }
        out
    }

    fn hausdorff(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
        one_way(&densify(a, 0.01), b).max(one_way(&densify(b, 0.01), a))
    }

    fn circle(r: f64, n: usize, ccw: bool) -> Vec<[f64; 2]> {
        (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64 * if ccw { 1.0 } else { -1.0 };
                [5.0 + r * a.cos(), 3.0 + r * a.sin()]
            })
            .collect()
    }

    #[test]
    fn a_polygon_circle_becomes_a_few_arcs_on_the_circle() {
        for ccw in [true, false] {
            let ring = circle(4.0, 360, ccw);
            let pieces = fit_ring(&ring, 0.01);
            assert!(pieces.len() <= 4, "{}", pieces.len());
            // The greedy's last piece may be whatever is left over.
            assert!(arc_count(&pieces) + 1 >= pieces.len(), "{pieces:?}");
            assert_eq!(pieces[0].from, ring[0]);
            for (k, p) in pieces.iter().enumerate() {
                let Some(arc) = arc_of(p.from, pieces[(k + 1) % pieces.len()].from, p.bulge) else {
                    continue;
                };
                assert!((arc.radius - 4.0).abs() < 0.01, "{arc:?}");
                assert!(dist(arc.center, [5.0, 3.0]) < 0.01, "{arc:?}");
                assert_eq!(arc.sweep > 0.0, ccw);
            }
            let flat = flatten(&pieces, 0.001);
            assert!(hausdorff(&flat, &ring) < 0.01 + 1e-3);
        }
    }

    #[test]
    fn corners_stay_corners_and_lines_stay_lines() {
        // A square with one rounded corner (radius 2), as a polygon.
        let mut ring = vec![[0.0, 0.0], [10.0, 0.0], [10.0, 8.0]];
        for i in 0..=30 {
            let a = std::f64::consts::FRAC_PI_2 * i as f64 / 30.0;
            ring.push([8.0 + 2.0 * a.cos(), 8.0 + 2.0 * a.sin()]);
        }
        ring.push([0.0, 10.0]);
        let pieces = fit_ring(&ring, 0.02);
        let froms: Vec<[f64; 2]> = pieces.iter().map(|p| p.from).collect();
        for corner in [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]] {
            assert!(froms.contains(&corner), "{froms:?}");
        }
        assert_eq!(arc_count(&pieces), 1, "{pieces:?}");
        let flat = flatten(&pieces, 0.002);
        assert!(hausdorff(&flat, &ring) <= 0.02 + 2e-3);
    }

    #[test]
    fn a_staircase_is_smoothed_within_the_tolerance_both_ways() {
        // A pixel staircase around a disc of radius 30 px: marching squares' worst case.
        let mut ring = Vec::new();
        for i in 0..720 {
            let a = std::f64::consts::TAU * i as f64 / 720.0;
            let p = [(30.0 * a.cos()).round(), (30.0 * a.sin()).round()];
            if ring.last() != Some(&p) {
                ring.push(p);
            }
        }
        if ring.first() == ring.last() {
            ring.pop();
        }
        for tol in [0.3, 0.5, 1.0] {
            let pieces = fit_ring(&ring, tol);
            // Within 0.3 px no curve passes every step's corner (they stray ±0.35 px from the
            // disc); from half a pixel on, most steps go.
            if tol >= 0.5 {
                assert!(
                    pieces.len() * 3 < ring.len(),
                    "tol {tol}: {} of {}",
                    pieces.len(),
                    ring.len()
                );
            }
            let h = hausdorff(&flatten(&pieces, tol / 20.0), &ring);
            assert!(h <= tol * 1.05 + 0.01, "tol {tol}: {h}");
        }
    }

    #[test]
    fn no_tolerance_or_a_tiny_ring_gives_lines() {
        let tri = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        assert_eq!(arc_count(&fit_ring(&tri, 0.0)), 0);
        assert_eq!(fit_ring(&tri[..2], 1.0).len(), 2);
        assert_eq!(flatten(&fit_ring(&tri, 0.1), 0.1), tri.to_vec());
    }
}
