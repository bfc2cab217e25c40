//! Kerf compensation: the tool removes a strip `kerf` wide centred on its path, so each cut loop is
//! moved half a kerf into the region it removes; the edge of the removed strip then lands on the
//! design line. Round joins, because the beam (or blade) is round.

use geo::orient::{Direction, Orient};
use geo::MultiPolygon;

use crate::clip::{self, ClipError};

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
