//! A tile's edge along its seams: the sheet is a rectangle (its picture and the margin), but a
//! tile's picture ends at its strip past each seam, so the cut that frees it must follow the
//! strip, not leave a frame of margin to trim by hand. The window beyond the strip (already a cut
//! region reaching the box's seam sides) grows into a *scrap*: the window, the margin on the
//! seam sides, and the margin across the outer sides where the window meets them. Cutting the
//! scrap's loop before the sheet's outline (the planner cuts the outline last) leaves the tile
//! with its outer edge along the strip and its margin on the picture's own outer sides only:
//! it comes off the machine ready to tape.

use geo::orient::{Direction, Orient};
use geo::{Coord, LineString, MultiPolygon, Polygon};
use stencil_geom::clip::{self, Op};
use stencil_geom::ring::signed_area2;

use crate::vector::{CutGeometry, VectorError};

/// A tile's sides, in the order left, top, right, bottom: `true` where the side is the whole
/// picture's outer edge (it keeps its margin), `false` where it faces a seam.
pub(crate) type Outer = [bool; 4];

fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Polygon<f64> {
    Polygon::new(
        LineString::from(vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)]),
        vec![],
    )
}

/// Trim `geom` (a tile's, its picture `0..width_mm` by `0..height_mm`, no kerf yet) along its
/// seams: its window cuts replaced by their scrap (see the module notes). `eps_mm`: how near a
/// side a point lies on it (half a working pixel).
pub(crate) fn trim(geom: &mut CutGeometry, outer: Outer, eps_mm: f64) -> Result<(), VectorError> {
    if outer.iter().all(|&o| o) {
        return Ok(());
    }
    let (w, h) = (geom.width_mm, geom.height_mm);
    let o = geom.outline;
    let (ox0, oy0, ox1, oy1) = (o.min().x, o.min().y, o.max().x, o.max().y);
    // On side k: a point's place along the line, if it lies on it.
    let on = |k: usize, c: &Coord<f64>| -> Option<f64> {
        match k {
            0 => (c.x <= eps_mm).then_some(c.y),
            1 => (c.y <= eps_mm).then_some(c.x),
            2 => (c.x >= w - eps_mm).then_some(c.y),
            _ => (c.y >= h - eps_mm).then_some(c.x),
        }
    };
    let seam_sides: Vec<usize> = (0..4).filter(|&k| !outer[k]).collect();
    let is_window = |p: &Polygon<f64>| {
        p.exterior()
            .coords()
            .any(|c| seam_sides.iter().any(|&k| on(k, c).is_some()))
    };
    let (windows, kept): (Vec<Polygon<f64>>, Vec<Polygon<f64>>) = geom
        .design_cuts
        .0
        .iter()
        .cloned()
        .partition(|p| is_window(p));
    if windows.is_empty() {
        return Ok(());
    }
    // The margin on the seam sides, and across the outer sides where a window meets them.
    let mut more = Vec::new();
    for k in seam_sides.iter().copied() {
        more.push(match k {
            0 => rect(ox0, oy0, eps_mm, oy1),
            1 => rect(ox0, oy0, ox1, eps_mm),
            2 => rect(w - eps_mm, oy0, ox1, oy1),
            _ => rect(ox0, h - eps_mm, ox1, oy1),
        });
    }
    for p in &windows {
        for k in (0..4).filter(|&k| outer[k]) {
            let along: Vec<f64> = p.exterior().coords().filter_map(|c| on(k, c)).collect();
            let (Some(lo), Some(hi)) = (
                along.iter().copied().reduce(f64::min),
                along.iter().copied().reduce(f64::max),
            ) else {
                continue;
            };
            if hi - lo <= eps_mm {
                continue;
            }
            more.push(match k {
                0 => rect(ox0, lo, eps_mm, hi),
                1 => rect(lo, oy0, hi, eps_mm),
                2 => rect(w - eps_mm, lo, ox1, hi),
                _ => rect(lo, h - eps_mm, hi, oy1),
            });
        }
    }
    let orient = |v: Vec<Polygon<f64>>| {
        MultiPolygon(
            v.into_iter()
                .map(|p| p.orient(Direction::Default))
                .collect(),
        )
    };
    let scrap =
        clip::boolean(&orient(windows.clone()), &orient(more), Op::Union).map_err(|cause| {
            VectorError::Clip {
                what: "a tile's edge along its seams",
                cause,
            }
        })?;
    // The scraps turn as the cuts they replace.
    let ring = |p: &Polygon<f64>| {
        let pts: Vec<[f64; 2]> = p.exterior().coords().map(|c| [c.x, c.y]).collect();
        signed_area2(&pts) > 0.0
    };
    let ccw = ring(&windows[0]);
    let mut cuts = kept;
    for p in scrap.0 {
        let p = p.orient(Direction::Default);
        cuts.push(if ring(&p) == ccw {
            p
        } else {
            p.orient(Direction::Reversed)
        });
    }
    geom.design_cuts = MultiPolygon(cuts);
    geom.cuts = geom.design_cuts.clone();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::BitGrid;
    use crate::units::Scale;
    use crate::vector::{vectorize_design, VectorConfig};
    use geo::Area;

    #[test]
    fn a_window_on_the_right_takes_the_margin_with_it() {
        // A 10 x 8 mm tile at 0.1 mm a pixel, its right side a seam: the window from x = 8 mm
        // to the box's edge; a hole in its picture.
        let bits = BitGrid::from_fn(100, 80, |x, y| {
            x < 80 && !((20..40).contains(&x) && (20..40).contains(&y))
        });
        let cfg = VectorConfig {
            scale: Scale { mm_per_px: 0.1 },
            margin_mm: 2.0,
            ..VectorConfig::default()
        };
        let (mut geom, _) = vectorize_design(&bits, &[], &cfg).unwrap();
        assert_eq!(geom.design_cuts.0.len(), 2);
        trim(&mut geom, [true, true, false, true], 0.05).unwrap();
        assert_eq!(geom.design_cuts.0.len(), 2);
        let mut areas: Vec<f64> = geom
            .design_cuts
            .0
            .iter()
            .map(|p| p.unsigned_area())
            .collect();
        areas.sort_by(f64::total_cmp);
        // The hole as it was (2 x 2 mm); the scrap: x 8..12 mm (the window and the right
        // margin) over the whole height with the margin above and below it (12 mm); their
        // corners rounded by the trace's smoothing.
        assert!((areas[0] - 4.0).abs() < 0.3, "{areas:?}");
        assert!((areas[1] - 4.0 * 12.0).abs() < 0.3, "{areas:?}");
        assert_eq!(geom.cuts, geom.design_cuts);
        // A tile with no seam side is left alone.
        let (mut whole, _) = vectorize_design(&bits, &[], &cfg).unwrap();
        let before = whole.design_cuts.clone();
        trim(&mut whole, [true; 4], 0.05).unwrap();
        assert_eq!(whole.design_cuts, before);
    }
}
