//! The registration marks ([`Marks`]): corner crosses and pin holes cut at the same sheet
//! coordinates in every sheet that must register: every layer of a set, and (the same shapes,
//! the pins on the seams) every tile of a tiled stencil where two tiles meet.

use serde::Serialize;

use crate::raster::{BitGrid, Gray};

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
        let (line, arm, pin) = mark_sizes(min_feature_mm);
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

    /// The same marks with pin holes `pin_mm` across at `pins_mm` (a tiled stencil's: on its
    /// seams, where both tiles of a seam carry them, as small as the overlap holds) in place of
    /// the band's middle ones.
    pub fn with_pins(self, pin_mm: f64, pins_mm: Vec<[f64; 2]>) -> Marks {
        Marks {
            pin_mm,
            pins_mm,
            ..self
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

impl Marks {
    /// Cut every mark into a grid (anywhere in it, band or not) whose top-left corner lies at
    /// `origin_mm` in the marks' coordinates, `mm_per_px` per pixel: a tile's share of them.
    pub fn cut(&self, bits: &mut BitGrid, origin_mm: [f64; 2], mm_per_px: f64) {
        let reach = self.arm_mm.max(self.pin_mm / 2.0) + mm_per_px;
        let centres = self.crosses_mm.iter().chain(&self.pins_mm);
        for &[cx, cy] in centres {
            let px = |v: f64, o: f64, n: u32| ((v - o) / mm_per_px).floor().clamp(0.0, n as f64);
            let (x0, x1) = (
                px(cx - reach, origin_mm[0], bits.width) as u32,
                px(cx + reach, origin_mm[0], bits.width) as u32 + 1,
            );
            let (y0, y1) = (
                px(cy - reach, origin_mm[1], bits.height) as u32,
                px(cy + reach, origin_mm[1], bits.height) as u32 + 1,
            );
            for y in y0..y1.min(bits.height) {
                for x in x0..x1.min(bits.width) {
                    let mx = origin_mm[0] + (x as f64 + 0.5) * mm_per_px;
                    let my = origin_mm[1] + (y as f64 + 0.5) * mm_per_px;
                    if self.inside(mx, my) {
                        bits.set(x, y, false);
                    }
                }
            }
        }
    }
}

/// A gray picture grown by `band` pixels on every side, white (material): the band the marks
/// are cut in.
pub fn grown_gray(g: &Gray, band: u32) -> Gray {
    let (w, h) = (g.width, g.height);
    let pw = w + 2 * band;
    let mut out = Gray::new(pw, h + 2 * band, 1.0);
    for y in 0..h {
        let src = &g.data[(y * w) as usize..((y + 1) * w) as usize];
        let at = ((y + band) * pw + band) as usize;
        out.data[at..at + w as usize].copy_from_slice(src);
    }
    out
}

/// A two-tone grown by `band` pixels of material on every side (see [`grown_gray`]).
pub fn grown_bits(b: &BitGrid, band: u32) -> BitGrid {
    let (w, h) = (b.width, b.height);
    BitGrid::from_fn(w + 2 * band, h + 2 * band, |x, y| {
        x < band || y < band || x >= w + band || y >= h + band || b.get(x - band, y - band)
    })
}

/// The marks' sizes for a material whose smallest feature is `min_feature_mm`: a cross's line
/// (twice the smallest feature, at least 1 mm, so it cuts cleanly and shows), half its arm, and
/// a pin hole's diameter (three lines: a drawing pin or a 3 mm dowel goes through), mm.
pub fn mark_sizes(min_feature_mm: f64) -> (f64, f64, f64) {
    let line = (2.0 * min_feature_mm).max(1.0);
    (line, 3.5 * line, 3.0 * line)
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

    #[test]
    fn a_tiles_share_of_the_marks_is_cut_where_the_marks_are() {
        let m = Marks::new(400, 300, 0.1, 0.5).with_pins(3.0, vec![[20.0, 15.0]]);
        // A grid whose corner is 10 mm right and 5 mm down: the pin lands at 100, 100 px.
        let mut bits = BitGrid::new(200, 200, true);
        m.cut(&mut bits, [10.0, 5.0], 0.1);
        assert!(!bits.get(100, 100));
        assert!(bits.get(100, 120), "only the pin's 3 mm");
        assert!(bits.get(199, 199));
    }
}
