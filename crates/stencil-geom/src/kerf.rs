//! Kerf compensation: the tool removes a strip `kerf` wide centred on its path, so each cut loop is
//! moved half a kerf into the region it removes; the edge of the removed strip then lands on the
//! design line. Round joins, because the beam (or blade) is round.

use geo::orient::{Direction, Orient};
use geo::{LineString, MultiPolygon, Polygon};
use rayon::prelude::*;

use crate::clip::{self, ClipError};
use crate::curve::{self, Curves, Piece};
use crate::ring::{dist, signed_area2};

/// Arc tolerance of the round joins, in mm (a tenth of the default pixel: far below any kerf's
/// own variation).
const ARC_TOLERANCE_MM: f64 = 0.01;

/// The tool paths for the design cut regions `design`: each region shrunk by `kerf_mm / 2`.
/// A region narrower than the kerf disappears (the material's `min_feature_mm` is larger than its
/// kerf, and `check` flags holes narrower than that). Fails when Clipper cannot take the geometry
/// (see [`clip`]).
pub fn offset_cuts(
    design: &MultiPolygon<f64>,
    kerf_mm: f64,
) -> Result<MultiPolygon<f64>, ClipError> {
    if kerf_mm <= 0.0 {
        return Ok(design.clone());
    }
    // Cut regions are disjoint and only shrink, so each is offset on its own, in parallel.
    let parts = clip::offset_each(&design.0, -kerf_mm / 2.0, ARC_TOLERANCE_MM)?;
    Ok(MultiPolygon::new(parts.into_iter().flat_map(|m| m.0).collect()).orient(Direction::Default))
}

/// [`offset_cuts`], keeping curves: each cut region that is one outline known to `curves` (its
/// lines and arcs, [`Curves::pieces_of`]) is offset as those lines and arcs
/// ([`offset_pieces`]: each line moved parallel, each arc about its own centre, round joins),
/// so the tool path is the exact offset of the very curves the files carry, and comes back with
/// its pieces in the returned table (flattened within `curves.flatten_tol`, as the design's
/// were). Every other region (holes, no curves) is Clipper's polygon offset, as in
/// [`offset_cuts`], and so is a curved one whose curve offset does not split into as many loops
/// as Clipper's (a safeguard: the two offsets of one region agree on what survives).
pub fn offset_cuts_curved(
    design: &MultiPolygon<f64>,
    kerf_mm: f64,
    curves: &Curves,
) -> Result<(MultiPolygon<f64>, Curves), ClipError> {
    if kerf_mm <= 0.0 || curves.is_empty() {
        return Ok((offset_cuts(design, kerf_mm)?, curves.clone()));
    }
    let parts = clip::offset_each(&design.0, -kerf_mm / 2.0, ARC_TOLERANCE_MM)?;
    let tol = curves.flatten_tol;
    let regions: Vec<(MultiPolygon<f64>, Vec<Vec<Piece>>)> = design
        .0
        .par_iter()
        .zip(parts)
        .map(|(poly, clipped)| {
            let curved = poly
                .interiors()
                .is_empty()
                .then(|| curves.pieces_of(&open_ring(poly.exterior())))
                .flatten()
                .map(|(_, pieces)| offset_pieces(&pieces, kerf_mm / 2.0))
                .filter(|loops| loops.len() == clipped.0.len());
            match curved {
                Some(loops) => {
                    let polys = loops
                        .iter()
                        .map(|pieces| {
                            let mut flat = curve::flatten(pieces, tol);
                            flat.push(flat[0]);
                            Polygon::new(LineString::from(flat), vec![])
                        })
                        .collect();
                    (MultiPolygon::new(polys), loops)
                }
                None => (clipped.orient(Direction::Default), Vec::new()),
            }
        })
        .collect();
    let mut out = Curves::new(tol);
    let mut polys = Vec::new();
    for (m, loops) in regions {
        for (poly, pieces) in m.0.iter().zip(&loops) {
            let flat = open_ring(poly.exterior());
            out.insert(pieces.clone(), flat);
        }
        polys.extend(m.0);
    }
    Ok((MultiPolygon::new(polys), out))
}

/// A closed ring's points without the closing repeat.
fn open_ring(r: &LineString<f64>) -> Vec<[f64; 2]> {
    let mut pts: Vec<[f64; 2]> = r.0.iter().map(|c| [c.x, c.y]).collect();
    if pts.len() > 1 && pts.first() == pts.last() {
        pts.pop();
    }
    pts
}

/// A closed outline of lines and arcs (counter-clockwise in the numeric plane: the inside on
/// its left) shrunk by `d` (grown when negative): cavalier_contours' parallel offset, which
/// moves each line parallel and each arc about its own centre, joins them with round arcs, and
/// removes what crosses itself, so the result is exact, not a polygon's approximation. It may be
/// several loops (a neck narrower than `2 d` parts) or none. Arcs over 0.95 of a half turn are
/// cut in equal parts (writers take arcs under a half turn), and pieces shorter than a nanometre
/// dropped.
pub fn offset_pieces(pieces: &[Piece], d: f64) -> Vec<Vec<Piece>> {
    use cavalier_contours::polyline::{PlineSource, PlineSourceMut, Polyline};
    let mut pl: Polyline<f64> = Polyline::new_closed();
    for p in pieces {
        pl.add(p.from[0], p.from[1], p.bulge);
    }
    pl.parallel_offset(d)
        .into_iter()
        .filter(|o| o.is_closed())
        .map(|o| {
            let raw: Vec<Piece> = o
                .iter_vertexes()
                .map(|v| Piece {
                    from: [v.x, v.y],
                    bulge: v.bulge,
                })
                .collect();
            let n = raw.len();
            let kept: Vec<Piece> = (0..n)
                .filter(|&k| dist(raw[k].from, raw[(k + 1) % n].from) > 1e-9)
                .map(|k| raw[k])
                .collect();
            curve::split_arcs(&mitred(&kept, d.abs()), MAX_SWEEP)
        })
        .filter(|p| p.len() >= 2 && signed_area2(&curve::flatten(p, 1e-3)) > 0.0)
        .collect()
}

/// The largest sweep of an offset's arc, radians: under a half turn (SVG's small-arc flag), with
/// room for rounding. Why not a quarter turn: each cut adds a G-code line, and the fitted arcs
/// sweep up to this much.
const MAX_SWEEP: f64 = 0.95 * std::f64::consts::PI;

/// How far a mitred join may reach past the round join it replaces, mm: under the G-code's
/// written resolution (0.001 mm) and far under any tolerance.
const MITRE_MM: f64 = 0.001;

/// The offset's round joins of radius `d` (arcs of that radius about a corner of the outline
/// being offset) replaced by the point where the pieces on either side meet when extended, where
/// that point is within [`MITRE_MM`] of the round join: at a slight kink of a fitted outline the
/// join is a tiny arc that would cost a G-code line of its own; the mitre costs none and moves
/// the path by under the written resolution.
fn mitred(pieces: &[Piece], d: f64) -> Vec<Piece> {
    let n = pieces.len();
    if n < 3 || d <= 0.0 {
        return pieces.to_vec();
    }
    let to = |k: usize| pieces[(k + 1) % n].from;
    // A piece's carrier: its circle (centre, radius) or its line (a point, a direction).
    let carrier = |k: usize| -> Carrier {
        match curve::arc_of(pieces[k].from, to(k), pieces[k].bulge) {
            Some(a) => Carrier::Circle(a.center, a.radius),
            None => Carrier::Line(pieces[k].from, to(k)),
        }
    };
    let mut out: Vec<Piece> = pieces.to_vec();
    let mut drop = vec![false; n];
    for j in 0..n {
        let Some(join) = curve::arc_of(pieces[j].from, to(j), pieces[j].bulge) else {
            continue;
        };
        let (a, b) = ((j + n - 1) % n, (j + 1) % n);
        if (join.radius - d).abs() > 1e-6 * d.max(1.0) || drop[a] || drop[b] || a == b {
            continue;
        }
        let Some(x) = meet(carrier(a), carrier(b), pieces[j].from, to(j)) else {
            continue;
        };
        if (dist(x, join.center) - d).abs() > MITRE_MM || dist(x, pieces[j].from) > 4.0 * d {
            continue;
        }
        // The piece before ends at x (an arc keeps its circle: its bulge from its new sweep);
        // the piece after starts there.
        let pa = out[a];
        out[a].bulge = match carrier(a) {
            Carrier::Circle(c, _) => {
                let ang = |p: [f64; 2]| (p[1] - c[1]).atan2(p[0] - c[0]);
                let old = 4.0 * pa.bulge.atan();
                let mut sweep = ang(x) - ang(pa.from);
                // The same turning direction, the nearest to the old sweep.
                while sweep - old > std::f64::consts::PI {
                    sweep -= std::f64::consts::TAU;
                }
                while old - sweep > std::f64::consts::PI {
                    sweep += std::f64::consts::TAU;
                }
                (sweep / 4.0).tan()
            }
            Carrier::Line(..) => 0.0,
        };
        out[b].from = x;
        drop[j] = true;
    }
    out.into_iter()
        .zip(drop)
        .filter(|(_, d)| !d)
        .map(|(p, _)| p)
        .collect()
}

#[derive(Clone, Copy)]
enum Carrier {
    Circle([f64; 2], f64),
    Line([f64; 2], [f64; 2]),
}

/// Where two carriers meet nearest the join from `p` to `q` (`None` when they do not meet).
fn meet(a: Carrier, b: Carrier, p: [f64; 2], q: [f64; 2]) -> Option<[f64; 2]> {
    let m = [(p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0];
    let pts: Vec<[f64; 2]> = match (a, b) {
        (Carrier::Line(a0, a1), Carrier::Line(b0, b1)) => {
            let (da, db) = (
                [a1[0] - a0[0], a1[1] - a0[1]],
                [b1[0] - b0[0], b1[1] - b0[1]],
            );
            let den = da[0] * db[1] - da[1] * db[0];
            if den.abs() < 1e-15 {
                return None;
            }
            let t = ((b0[0] - a0[0]) * db[1] - (b0[1] - a0[1]) * db[0]) / den;
            vec![[a0[0] + t * da[0], a0[1] + t * da[1]]]
        }
        (Carrier::Line(l0, l1), Carrier::Circle(c, r))
        | (Carrier::Circle(c, r), Carrier::Line(l0, l1)) => {
            let dl = [l1[0] - l0[0], l1[1] - l0[1]];
            let ll = dl[0] * dl[0] + dl[1] * dl[1];
            if ll == 0.0 {
                return None;
            }
            let f = [l0[0] - c[0], l0[1] - c[1]];
            let bq = 2.0 * (f[0] * dl[0] + f[1] * dl[1]);
            let cq = f[0] * f[0] + f[1] * f[1] - r * r;
            let disc = bq * bq - 4.0 * ll * cq;
            if disc < 0.0 {
                return None;
            }
            let sq = disc.sqrt();
            [(-bq - sq) / (2.0 * ll), (-bq + sq) / (2.0 * ll)]
                .iter()
                .map(|t| [l0[0] + t * dl[0], l0[1] + t * dl[1]])
                .collect()
        }
        (Carrier::Circle(c0, r0), Carrier::Circle(c1, r1)) => {
            let dd = dist(c0, c1);
            if dd == 0.0 || dd > r0 + r1 || dd < (r0 - r1).abs() {
                return None;
            }
            let a = (r0 * r0 - r1 * r1 + dd * dd) / (2.0 * dd);
            let h = (r0 * r0 - a * a).max(0.0).sqrt();
            let u = [(c1[0] - c0[0]) / dd, (c1[1] - c0[1]) / dd];
            let base = [c0[0] + a * u[0], c0[1] + a * u[1]];
            vec![
                [base[0] - h * u[1], base[1] + h * u[0]],
                [base[0] + h * u[1], base[1] - h * u[0]],
            ]
        }
    };
    pts.into_iter()
        .filter(|x| x[0].is_finite() && x[1].is_finite())
        .min_by(|x, y| dist(*x, m).total_cmp(&dist(*y, m)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use geo::{Area, BoundingRect, Polygon, Rect};

    #[test]
    fn a_square_hole_shrinks_by_half_the_kerf_on_each_side() {
        let sq: Polygon<f64> = Rect::new((0.0, 0.0), (10.0, 10.0)).to_polygon();
        let out = offset_cuts(&MultiPolygon::new(vec![sq]), 0.2).unwrap();
        let b = out.bounding_rect().unwrap();
        assert!(
            (b.min().x - 0.1).abs() < 1e-3 && (b.max().x - 9.9).abs() < 1e-3,
            "{b:?}"
        );
        assert!((out.unsigned_area() - 9.8 * 9.8).abs() < 1e-2);
    }

    #[test]
    fn a_curved_outline_is_offset_exactly() {
        use crate::curve::{arc_of, Piece};
        // A disc of radius 2 as four quarter arcs, counter-clockwise: shrunk by 0.5, it is the
        // disc of radius 1.5, arcs on the same centre.
        let q = (std::f64::consts::PI / 8.0).tan();
        let disc: Vec<Piece> = [[2.0, 0.0], [0.0, 2.0], [-2.0, 0.0], [0.0, -2.0]]
            .iter()
            .map(|&from| Piece { from, bulge: q })
            .collect();
        let out = offset_pieces(&disc, 0.5);
        assert_eq!(out.len(), 1);
        let p = &out[0];
        for k in 0..p.len() {
            let a = arc_of(p[k].from, p[(k + 1) % p.len()].from, p[k].bulge).unwrap();
            assert!(
                (a.radius - 1.5).abs() < 1e-9 && a.center[0].abs() < 1e-9,
                "{a:?}"
            );
        }
        // A square with a slightly kinked side: the kink's round join is mitred (within
        // 0.001 mm); the square's own corners keep theirs (a quarter turn is no slight kink).
        let sq: Vec<Piece> = [
            [0.0, 0.0],
            [5.0, -0.01],
            [10.0, 0.0],
            [10.0, 10.0],
            [0.0, 10.0],
        ]
        .iter()
        .map(|&from| Piece { from, bulge: 0.0 })
        .collect();
        let out = offset_pieces(&sq, -0.1);
        assert_eq!(out.len(), 1);
        let turn: f64 = out[0].iter().map(|p| 4.0 * p.bulge.atan().abs()).sum();
        assert!(
            (turn - std::f64::consts::TAU).abs() < 0.01,
            "the corners' joins turn once: {turn}"
        );
        let at_kink: Vec<&Piece> = out[0]
            .iter()
            .filter(|p| (p.from[0] - 5.0).abs() < 1.0)
            .collect();
        assert_eq!(at_kink.len(), 1, "{:?}", out[0]);
        assert!((at_kink[0].from[1] + 0.11).abs() < 1e-3, "{at_kink:?}");
        // A region narrower than twice the offset is gone.
        assert!(offset_pieces(&disc, 2.5).is_empty());
    }
}
