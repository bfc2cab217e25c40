//! The pieces themselves: a line or a circular arc by its bulge, the arc's circle, its box, and
//! the points a fit must keep on either side. What both fits of the parent module and its
//! writers' helpers use (a leaf, so the fits' files use it without using each other).

use crate::ring::{dist, point_box, union_box};

/// One piece of a closed outline: from `from` to the next piece's `from` (the first piece's after
/// the last), straight when `bulge` is 0, else a circular arc that sweeps `4 atan(bulge)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    /// Where the piece starts.
    pub from: [f64; 2],
    /// 0 for a line, else `tan(sweep / 4)`.
    pub bulge: f64,
}

/// An arc's circle and sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArcGeom {
    /// The circle's centre.
    pub center: [f64; 2],
    /// The circle's radius.
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

/// Points that must stay on either side of a fitted outline: for ring vertex `k`, `points[k]` is
/// `[left, right]` (as the ring runs), and each must be at least `margin` from the piece that
/// replaces the vertex. The vector stage passes the two pixel centres beside each traced point, so
/// that the curves sample to the same raster as the pixels they were traced from, and a small
/// margin that the rounding of the numbers written cannot cross (its flattening keeps the same
/// points on their sides by vertices of its own: the parent module's `flatten_clear`).
#[derive(Clone, Copy, Debug)]
pub struct Sides<'a> {
    /// `[left, right]` per ring vertex.
    pub points: &'a [[[f64; 2]; 2]],
    /// The least distance from each point to the fitted outline.
    pub margin: f64,
}

/// The points where an arc passes 0, 90, 180 or 270 degrees about its centre (strictly inside
/// its sweep), in the order it passes them, with their angles: each the centre plus the radius
/// along an axis (exact unit vectors, not cos/sin).
pub(super) fn quarter_points(arc: &ArcGeom) -> Vec<(f64, [f64; 2])> {
    use std::f64::consts::FRAC_PI_2;
    let (a0, a1) = if arc.sweep > 0.0 {
        (arc.start_angle, arc.start_angle + arc.sweep)
    } else {
        (arc.start_angle + arc.sweep, arc.start_angle)
    };
    let mut out = Vec::new();
    let mut q = (a0 / FRAC_PI_2).floor() + 1.0;
    while q * FRAC_PI_2 < a1 {
        let [dx, dy] = match q.rem_euclid(4.0) as u8 {
            0 => [1.0, 0.0],
            1 => [0.0, 1.0],
            2 => [-1.0, 0.0],
            _ => [0.0, -1.0],
        };
        out.push((
            q * FRAC_PI_2,
            [
                arc.center[0] + arc.radius * dx,
                arc.center[1] + arc.radius * dy,
            ],
        ));
        q += 1.0;
    }
    if arc.sweep < 0.0 {
        out.reverse();
    }
    out
}

/// The exact box of one arc from `p` to `q`: its ends, and its points at the quarter-turn
/// angles its sweep passes.
pub(super) fn arc_box(arc: &ArcGeom, p: [f64; 2], q: [f64; 2]) -> [f64; 4] {
    let ends = union_box(point_box(p), point_box(q));
    (quarter_points(arc).into_iter()).fold(ends, |b, (_, e)| union_box(b, point_box(e)))
}
