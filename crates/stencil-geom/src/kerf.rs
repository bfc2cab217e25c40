//! Kerf compensation: the tool removes a strip `kerf` wide centred on its path, so each cut loop is
//! moved half a kerf into the region it removes; the edge of the removed strip then lands on the
//! design line. Round joins, because the beam (or blade) is round.

use geo::orient::{Direction, Orient};
use geo::{Coord, LineString, MultiPolygon, Polygon};
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
                            let first = flat[0];
                            flat.push(first);
                            Polygon::new(
                                LineString::new(
                                    flat.into_iter().map(|[x, y]| Coord { x, y }).collect(),
                                ),
                                vec![],
                            )
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
/// several loops (a neck narrower than `2 d` parts) or none. Arcs over a quarter turn are cut in
/// two (writers take arcs under a half turn), and pieces shorter than a nanometre dropped.
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
            curve::split_arcs(&kept, std::f64::consts::FRAC_PI_2)
        })
        .filter(|p| p.len() >= 2 && signed_area2(&curve::flatten(p, 1e-3)) > 0.0)
        .collect()
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
}
