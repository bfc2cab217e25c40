//! Boolean operations on the traced geometry, with Clipper (through [`stencil_geom::clip`]):
//! integer coordinates (0.1 µm) make unions of thousands of touching edges exact, it is faster
//! than geo's `BooleanOps`, and it gives the kerf's polygon offset.

use geo::orient::{Direction, Orient};
use geo::{Area, BoundingRect, Contains, LineString, MultiPolygon, Point, Polygon, Rect};
use rayon::prelude::*;

use stencil_geom::clip::{self, ClipError};

/// Union the bridge polygons into the material; returns the material and its cut regions (as
/// [`cuts_of`] gives them), or why Clipper cannot take them. Each cut region loses what the
/// bridges over it cover, in parallel, and the material is reassembled by containment: the same
/// set as one union of the whole sheet, in a fraction of the time.
pub fn union_bridges(
    material: MultiPolygon<f64>,
    bridges: &[Polygon<f64>],
) -> Result<(MultiPolygon<f64>, MultiPolygon<f64>), ClipError> {
    let cuts = cuts_of(&material);
    if bridges.is_empty() {
        return Ok((material, cuts));
    }
    // Every bridge, also those the boxes below would skip (a NaN box overlaps nothing).
    clip::check_rings(
        bridges
            .iter()
            .flat_map(|b| std::iter::once(b.exterior()).chain(b.interiors())),
    )?;
    let Some(sheet) = sheet_of(&material).map(|i| material.0[i].exterior().clone()) else {
        return Ok((material, cuts));
    };
    let boxes: Vec<Option<Rect<f64>>> = bridges.iter().map(|b| b.bounding_rect()).collect();
    let overlap = |a: &Rect<f64>, b: &Rect<f64>| {
        a.min().x <= b.max().x
            && b.min().x <= a.max().x
            && a.min().y <= b.max().y
            && b.min().y <= a.max().y
    };
    // Each cut region with the bridges over it (by bounding box); regions no bridge reaches stay.
    let over: Vec<Option<MultiPolygon<f64>>> = cuts
        .0
        .par_iter()
        .map(|cut| {
            let cb = cut.bounding_rect()?;
            let over: Vec<Polygon<f64>> = bridges
                .iter()
                .zip(&boxes)
                .filter(|(_, b)| b.is_some_and(|b| overlap(&b, &cb)))
                .map(|(p, _)| p.clone())
                .collect();
            (!over.is_empty()).then(|| MultiPolygon::new(over).orient(Direction::Default))
        })
        .collect();
    let pairs: Vec<(&Polygon<f64>, MultiPolygon<f64>)> = cuts
        .0
        .iter()
        .zip(&over)
        .filter_map(|(c, o)| Some((c, o.clone()?)))
        .collect();
    let mut clipped = clip::difference_each(&pairs)?.into_iter();
    let mut pieces: Vec<Polygon<f64>> = Vec::with_capacity(cuts.0.len());
    for (cut, o) in cuts.0.iter().zip(&over) {
        match o {
            None => pieces.push(cut.clone()),
            Some(_) => {
                if let Some(m) = clipped.next() {
                    pieces.extend(m.orient(Direction::Default).0);
                }
            }
        }
    }
    let cuts = MultiPolygon::new(pieces);
    Ok((material_around(sheet, &cuts), cuts))
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
        .map(|r| Polygon::new(reversed(r), vec![]))
        .collect();
    let owners = innermost(&outlines, cuts.0.iter().map(|c| c.exterior()));
    let mut holes: Vec<Vec<LineString<f64>>> = vec![Vec::new(); outlines.len() + 1];
    for (c, owner) in cuts.0.iter().zip(owners) {
        if !c.exterior().0.is_empty() {
            holes[owner.map_or(0, |i| i + 1)].push(reversed(c.exterior()));
        }
    }
    let mut holes = holes.into_iter();
    let mut polys = vec![Polygon::new(sheet, holes.next().unwrap_or_default())];
    for (o, h) in outlines.into_iter().zip(holes) {
        polys.push(Polygon::new(o.into_inner().0, h));
    }
    // Already oriented (cut exteriors counter-clockwise, reversed into clockwise holes, and the
    // other way round): no copy through `orient`.
    let m = MultiPolygon::new(polys);
    debug_assert_eq!(m.clone().orient(Direction::Default), m);
    m
}

/// A ring walked the other way (a hole of a cut region is the outline of a material piece, and
/// the other way round).
fn reversed(r: &LineString<f64>) -> LineString<f64> {
    let mut r = r.clone();
    r.0.reverse();
    r
}

/// For each of `rings`, the smallest of `containers` holding its first point (rings never cross
/// the containers, so one point decides), if any.
fn innermost<'a>(
    containers: &[Polygon<f64>],
    rings: impl Iterator<Item = &'a LineString<f64>>,
) -> Vec<Option<usize>> {
    let boxes: Vec<Option<Rect<f64>>> = containers.iter().map(|c| c.bounding_rect()).collect();
    let areas: Vec<f64> = containers.iter().map(|c| c.unsigned_area()).collect();
    rings
        .map(|r| {
            let pt = Point::from(*r.0.first()?);
            (0..containers.len())
                .filter(|&c| {
                    boxes[c].is_some_and(|b| b.contains(&pt)) && containers[c].contains(&pt)
                })
                .min_by(|&a, &b| areas[a].total_cmp(&areas[b]))
        })
        .collect()
}

/// Which material piece is the sheet: the one whose outline encloses the largest area. (Not the
/// largest piece: a big island inside a thin cut ring can have more material than the sheet
/// around it.)
pub(crate) fn sheet_of(material: &MultiPolygon<f64>) -> Option<usize> {
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
    let cuts: Vec<Polygon<f64>> = material
        .0
        .iter()
        .flat_map(|p| p.interiors())
        .map(|h| Polygon::new(reversed(h), vec![]))
        .collect();
    let sheet = sheet_of(material);
    let islands: Vec<&Polygon<f64>> = (0..material.0.len())
        .filter(|&i| Some(i) != sheet)
        .map(|i| &material.0[i])
        .collect();
    let owners = innermost(&cuts, islands.iter().map(|p| p.exterior()));
    let mut holes: Vec<Vec<LineString<f64>>> = vec![Vec::new(); cuts.len()];
    for (p, owner) in islands.iter().zip(owners) {
        if let Some(c) = owner {
            holes[c].push(reversed(p.exterior()));
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bridges_far_outside_clipper_range_are_an_error_not_an_abort() {
        let sheet = Polygon::new(
            Rect::new((0.0, 0.0), (100.0, 100.0))
                .to_polygon()
                .into_inner()
                .0,
            vec![LineString::from(vec![
                (10.0, 10.0),
                (10.0, 90.0),
                (90.0, 90.0),
                (90.0, 10.0),
                (10.0, 10.0),
            ])],
        );
        for far in [1e30, f64::NAN, f64::INFINITY] {
            let bridge = Rect::new((5.0, 40.0), (far, 60.0)).to_polygon();
            let e = union_bridges(MultiPolygon::new(vec![sheet.clone()]), &[bridge]).unwrap_err();
            assert!(
                matches!(
                    e,
                    ClipError::OutOfRange { .. } | ClipError::NotFinite { .. }
                ),
                "{far}: {e}"
            );
        }
    }
}
