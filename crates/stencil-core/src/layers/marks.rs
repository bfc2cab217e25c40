//! The registration marks of a set's sheets ([`Marks`]): cut at the same sheet coordinates in
//! every layer, so the sheets register.

use serde::Serialize;

use crate::raster::BitGrid;

/// The registration marks: a band of material around the picture holding four corner crosses
/// and two pin holes (top and bottom middle), the same on every sheet of a set. Coordinates are
/// in mm from the top-left corner of the picture grown by the band (the SVG's, DXF's and
/// G-code's origin), whose size is the picture's plus twice `band_mm`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Marks {
    /// Width of the band on each side, mm (a whole number of input pixels).
    pub band_mm: f64,
    /// The same in input pixels.
    pub band_px: u32,
    /// Width of a cross's arms, mm: twice the material's smallest feature, at least 1 mm.
    pub line_mm: f64,
    /// Half the length of a cross's arm, mm.
    pub arm_mm: f64,
    /// Diameter of a pin hole, mm.
    pub pin_mm: f64,
    /// Centres of the crosses, mm.
    pub crosses_mm: Vec<[f64; 2]>,
    /// Centres of the pin holes, mm.
    pub pins_mm: Vec<[f64; 2]>,
}

impl Marks {
    /// The marks for a picture of `w` × `h` input pixels at `mm_per_px`, cut in `material`.
    pub fn new(w: u32, h: u32, mm_per_px: f64, min_feature_mm: f64) -> Marks {
        let line = (2.0 * min_feature_mm).max(1.0);
        let arm = 3.5 * line;
        let pin = 3.0 * line;
        let band_px = ((2.0 * arm + 3.0 * line) / mm_per_px).ceil().max(1.0) as u32;
        let band = band_px as f64 * mm_per_px;
        let (sw, sh) = (
            (w + 2 * band_px) as f64 * mm_per_px,
            (h + 2 * band_px) as f64 * mm_per_px,
        );
        let c = band / 2.0;
        Marks {
            band_mm: band,
            band_px,
            line_mm: line,
            arm_mm: arm,
            pin_mm: pin,
            crosses_mm: vec![[c, c], [sw - c, c], [c, sh - c], [sw - c, sh - c]],
            pins_mm: vec![[sw / 2.0, c], [sw / 2.0, sh - c]],
        }
    }

    /// Whether a point (mm) is inside a mark.
    fn inside(&self, x: f64, y: f64) -> bool {
        let half = self.line_mm / 2.0;
        self.crosses_mm.iter().any(|&[cx, cy]| {
            let (dx, dy) = ((x - cx).abs(), (y - cy).abs());
            (dx <= self.arm_mm && dy <= half) || (dy <= self.arm_mm && dx <= half)
        }) || self
            .pins_mm
            .iter()
            .any(|&[cx, cy]| (x - cx).hypot(y - cy) <= self.pin_mm / 2.0)
    }

    /// Set the band of a working grid (band `band` working pixels wide, `mm_per_px` per working
    /// pixel): material, but cut inside the marks.
    pub fn stamp(&self, bits: &mut BitGrid, band: u32, mm_per_px: f64) {
        let (w, h) = (bits.width, bits.height);
        for y in 0..h {
            let in_rows = y < band || y >= h.saturating_sub(band);
            for x in 0..w {
                if in_rows || x < band || x >= w.saturating_sub(band) {
                    let (mx, my) = ((x as f64 + 0.5) * mm_per_px, (y as f64 + 0.5) * mm_per_px);
                    bits.set(x, y, !self.inside(mx, my));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marks_sit_in_the_band() {
        let m = Marks::new(400, 300, 0.1, 0.5);
        assert_eq!(m.line_mm, 1.0);
        assert!(m.band_mm >= 2.0 * m.arm_mm + m.line_mm);
        for &[x, y] in m.crosses_mm.iter().chain(&m.pins_mm) {
            let inner = |v: f64, size: f64| v < m.band_mm || v > size - m.band_mm;
            assert!(inner(x, 40.0 + 2.0 * m.band_mm) || inner(y, 30.0 + 2.0 * m.band_mm));
        }
        let mut bits = BitGrid::new(400 + 2 * m.band_px, 300 + 2 * m.band_px, false);
        m.stamp(&mut bits, m.band_px, 0.1);
        // The picture is untouched; a cross's centre is cut, the band between marks is material.
        assert!(!bits.get(200, 200));
        let c = (m.crosses_mm[0][0] / 0.1) as u32;
        assert!(!bits.get(c, c));
        assert!(bits.get(1, 1));
    }
}
