//! Boolean operations on the traced geometry, with Clipper (geo-clipper).
//!
//! Why Clipper rather than geo's `BooleanOps`: it works on integer coordinates (here 0.1 µm), so
//! unions of thousands of touching bridge and outline edges are exact and cannot fail on
//! near-degenerate input, it is several times faster on large inputs, and the same library gives
//! the polygon offset that the kerf needs (geo 0.33 has no robust offset).

use geo::orient::{Direction, Orient};
use geo::{Area, BoundingRect, Contains, LineString, MultiPolygon, Point, Polygon, Rect};
use geo_clipper::Clipper;
use rayon::prelude::*;

/// Clipper's integer scale: coordinates in mm are multiplied by this (1 unit = 0.1 µm).
pub const CLIPPER_FACTOR: f64 = 1e4;

/// Union the bridge polygons into the material; returns the material and its cut regions (as
/// [`cuts_of`] gives them).
///
/// Why region by region: a bridge only changes the cut regions it crosses, so each cut region
/// loses what the bridges over it cover (a small Clipper difference), all regions in parallel, and
/// the material is then reassembled from the regions left by containment. One Clipper union of the
/// whole sheet with every bridge gives the same set, on one thread, in several times the time.
pub fn union_bridges(
    material: MultiPolygon<f64>,
    bridges: &[Polygon<f64>],
) -> (MultiPolygon<f64>, MultiPolygon<f64>) {
    let cuts = cuts_of(&material);
    if bridges.is_empty() {
        return (material, cuts);
    }
    let Some(sheet) = sheet_of(&material).map(|i| material.0[i].exterior().clone()) else {
        return (material, cuts);
    };
    let boxes: Vec<Option<Rect<f64>>> = bridges.iter().map(|b| b.bounding_rect()).collect();
    let overlap = |a: &Rect<f64>, b: &Rect<f64>| {
        a.min().x <= b.max().x
            && b.min().x <= a.max().x
            && a.min().y <= b.max().y
            && b.min().y <= a.max().y
    };
    let pieces: Vec<Vec<Polygon<f64>>> = cuts
        .0
        .par_iter()
        .map(|cut| {
            let Some(cb) = cut.bounding_rect() else {
                return Vec::new();
            };
            let over: Vec<Polygon<f64>> = bridges
                .iter()
                .zip(&boxes)
                .filter(|(_, b)| b.is_some_and(|b| overlap(&b, &cb)))
                .map(|(p, _)| p.clone())
                .collect();
            if over.is_empty() {
                return vec![cut.clone()];
            }
            let over = MultiPolygon::new(over).orient(Direction::Default);
            Clipper::difference(cut, &over, CLIPPER_FACTOR)
                .orient(Direction::Default)
                .0
        })
        .collect();
    let cuts = MultiPolygon::new(pieces.into_iter().flatten().collect());
    (material_around(sheet, &cuts), cuts)
}

/// The material of a sheet with outline `sheet` from which the disjoint regions `cuts` are cut
/// (exteriors counter-clockwise, holes clockwise): each region's exterior is a hole of the
/// smallest material outline around it, and each hole of a region is the outline of a material
/// piece inside it.
fn material_around(sheet: LineString<f64>, cuts: &MultiPolygon<f64>) -> MultiPolygon<f64> {
    // Material pieces other than the sheet: the holes of the cut regions, turned outward.
    let outlines: Vec<Polygon<f64>> = cuts
        .0
        .iter()
        .flat_map(|c| c.interiors())
        .map(|r| {
            let mut r = r.clone();
            r.0.reverse();
            Polygon::new(r, vec![])
        })
        .collect();
    let areas: Vec<f64> = outlines.iter().map(|p| p.unsigned_area()).collect();
    let boxes: Vec<Option<Rect<f64>>> = outlines.iter().map(|p| p.bounding_rect()).collect();
    let mut holes: Vec<Vec<LineString<f64>>> = vec![Vec::new(); outlines.len() + 1];
    for c in &cuts.0 {
        let Some(&first) = c.exterior().0.first() else {
            continue;
        };
        let pt = Point::from(first);
        let owner = (0..outlines.len())
            .filter(|&i| boxes[i].is_some_and(|b| b.contains(&pt)) && outlines[i].contains(&pt))
            .min_by(|&a, &b| areas[a].total_cmp(&areas[b]))
            .map_or(0, |i| i + 1);
        let mut ring = c.exterior().clone();
        ring.0.reverse();
        holes[owner].push(ring);
    }
    let mut holes = holes.into_iter();
    let mut polys = vec![Polygon::new(sheet, holes.next().unwrap_or_default())];
    for (o, h) in outlines.into_iter().zip(holes) {
        polys.push(Polygon::new(o.exterior().clone(), h));
    }
    // Already oriented (cut exteriors counter-clockwise, reversed into clockwise holes, and the
    // other way round): no copy through `orient`.
    let m = MultiPolygon::new(polys);
    debug_assert_eq!(m.clone().orient(Direction::Default), m);
    m
}

/// Which material piece is the sheet: the one whose outline encloses the largest area. (Not the
/// largest piece: a big island inside a thin cut ring can have more material than the sheet
/// around it.)
pub fn sheet_of(material: &MultiPolygon<f64>) -> Option<usize> {
    let enclosed = |p: &Polygon<f64>| Polygon::new(p.exterior().clone(), vec![]).unsigned_area();
    material
        .0
        .iter()
        .enumerate()
        .max_by(|a, b| enclosed(a.1).total_cmp(&enclosed(b.1)))
        .map(|(i, _)| i)
}

/// The cut regions of a sheet whose material is `material` (as designed, without kerf): every hole
/// of a material piece is a cut region; a piece that is not the sheet itself (an island, before
/// bridging) becomes a hole in the cut region around it.
pub fn cuts_of(material: &MultiPolygon<f64>) -> MultiPolygon<f64> {
    let mut cuts: Vec<Polygon<f64>> = Vec::new();
    for p in &material.0 {
        for h in p.interiors() {
            let mut ring: LineString<f64> = h.clone();
            ring.0.reverse();
            cuts.push(Polygon::new(ring, vec![]));
        }
    }
    let sheet = sheet_of(material);
    let boxes: Vec<Option<Rect<f64>>> = cuts.iter().map(|c| c.bounding_rect()).collect();
    let areas: Vec<f64> = cuts.iter().map(|c| c.unsigned_area()).collect();
    let mut holes: Vec<Vec<LineString<f64>>> = vec![Vec::new(); cuts.len()];
    for (i, p) in material.0.iter().enumerate() {
        if Some(i) == sheet {
            continue;
        }
        let Some(first) = p.exterior().0.first() else {
            continue;
        };
        let pt = Point::from(*first);
        let best = (0..cuts.len())
            .filter(|&c| boxes[c].is_some_and(|b| b.contains(&pt)) && cuts[c].contains(&pt))
            .min_by(|&a, &b| areas[a].total_cmp(&areas[b]));
        if let Some(c) = best {
            let mut ring = p.exterior().clone();
            ring.0.reverse();
            holes[c].push(ring);
        }
    }
    let polys = cuts
        .into_iter()
        .zip(holes)
        .map(|(c, hs)| Polygon::new(c.exterior().clone(), hs))
        .collect();
    // Already oriented when `material` is (its holes reversed are counter-clockwise exteriors,
    // its islands' outlines reversed clockwise holes): no copy through `orient`.
    let m = MultiPolygon::new(polys);
    debug_assert_eq!(m.clone().orient(Direction::Default), m);
    m
}
