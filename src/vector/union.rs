//! Boolean operations on the traced geometry, with Clipper (geo-clipper).
//!
//! Why Clipper rather than geo's `BooleanOps`: it works on integer coordinates (here 0.1 µm), so
//! unions of thousands of touching bridge and outline edges are exact and cannot fail on
//! near-degenerate input, it is several times faster on large inputs, and the same library gives
//! the polygon offset that the kerf needs (geo 0.33 has no robust offset).

use geo::orient::{Direction, Orient};
use geo::{Area, BoundingRect, Contains, LineString, MultiPolygon, Point, Polygon, Rect};
use geo_clipper::Clipper;

/// Clipper's integer scale: coordinates in mm are multiplied by this (1 unit = 0.1 µm).
pub const CLIPPER_FACTOR: f64 = 1e4;

/// Union the bridge polygons into the material.
pub fn union_bridges(material: MultiPolygon<f64>, bridges: &[Polygon<f64>]) -> MultiPolygon<f64> {
    if bridges.is_empty() {
        return material;
    }
    let b = MultiPolygon::new(bridges.to_vec()).orient(Direction::Default);
    Clipper::union(&material, &b, CLIPPER_FACTOR).orient(Direction::Default)
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
    let sheet = material
        .0
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.unsigned_area().total_cmp(&b.1.unsigned_area()))
        .map(|(i, _)| i);
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
    MultiPolygon::new(polys).orient(Direction::Default)
}
