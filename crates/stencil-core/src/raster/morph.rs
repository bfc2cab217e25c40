//! Morphology by a disc: opening and closing, on packed bits (`packed`): the same pixels as
//! through the exact distance transform (the form kept in the tests, which check that the two
//! agree), a few word operations per 64 pixels. The image is extended by repeating its edge
//! pixels. Used by the topological filter, the bridge clean-up and the material checks.

use super::grid::BitGrid;
use super::packed::{self, Packed};

/// Opening: removes material features thinner than the disc.
pub(crate) fn open(bits: &BitGrid, r: u32) -> BitGrid {
    if bits.is_empty() {
        return bits.clone();
    }
    packed::open(&Packed::from_grid(bits), r).to_grid()
}

/// Closing: fills cut features thinner than the disc.
pub(crate) fn close(bits: &BitGrid, r: u32) -> BitGrid {
    if bits.is_empty() {
        return bits.clone();
    }
    packed::close(&Packed::from_grid(bits), r).to_grid()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::raster::squared_distance_to;

    // The distance-transform forms, the reference the packed ones are checked against.
    /// Pad by `pad` pixels on every side, repeating the edge pixels, so erosion and dilation neither
    /// eat into nor grow out of the image border: an all-cut picture stays all cut, and a region running
    /// off the edge keeps its width there.
    fn padded(bits: &BitGrid, pad: u32) -> BitGrid {
        let (w, h) = (bits.width + 2 * pad, bits.height + 2 * pad);
        let clamp = |v: u32, n: u32| v.saturating_sub(pad).min(n - 1);
        BitGrid::from_fn(w, h, |x, y| {
            bits.get(clamp(x, bits.width), clamp(y, bits.height))
        })
    }

    fn crop(bits: &BitGrid, pad: u32, w: u32, h: u32) -> BitGrid {
        BitGrid::from_fn(w, h, |x, y| bits.get(x + pad, y + pad))
    }

    /// Dilate material by a disc of radius r.
    fn dilate(bits: &BitGrid, r: u32) -> BitGrid {
        let d = squared_distance_to(bits, true);
        let r2 = (r * r) as f32;
        BitGrid::from_data(
            bits.width,
            bits.height,
            d.iter().map(|&v| v <= r2).collect(),
        )
    }

    /// Erode material by a disc of radius r (dilate the cut).
    fn erode(bits: &BitGrid, r: u32) -> BitGrid {
        let d = squared_distance_to(bits, false);
        let r2 = (r * r) as f32;
        BitGrid::from_data(bits.width, bits.height, d.iter().map(|&v| v > r2).collect())
    }

    /// Opening: removes material features thinner than the disc.
    pub(crate) fn open_edt(bits: &BitGrid, r: u32) -> BitGrid {
        let pad = r + 2;
        let p = padded(bits, pad);
        crop(&dilate(&erode(&p, r), r), pad, bits.width, bits.height)
    }

    /// Closing: fills cut features thinner than the disc.
    pub(crate) fn close_edt(bits: &BitGrid, r: u32) -> BitGrid {
        let pad = r + 2;
        let p = padded(bits, pad);
        crop(&erode(&dilate(&p, r), r), pad, bits.width, bits.height)
    }

    #[test]
    fn opening_removes_a_lone_pixel_and_keeps_a_block() {
        let mut g = BitGrid::new(20, 20, false);
        g.set(3, 3, true);
        for y in 8..16 {
            for x in 8..16 {
                g.set(x, y, true);
            }
        }
        let o = open(&g, 1);
        assert!(!o.get(3, 3));
        assert!(o.get(10, 10) && o.get(8, 10));
        // Opening never adds material, even at the image border.
        assert!(o.data.iter().zip(&g.data).all(|(a, b)| !a || *b));
    }

    #[test]
    fn closing_fills_a_pinhole_and_never_removes_material() {
        let mut g = BitGrid::new(12, 12, true);
        g.set(5, 5, false);
        let c = close(&g, 1);
        assert!(c.get(5, 5));
        assert!(c.data.iter().zip(&g.data).all(|(a, b)| *a || !*b));
    }

    #[test]
    fn uniform_images_are_left_alone() {
        for fill in [true, false] {
            let g = BitGrid::new(9, 7, fill);
            for r in 1..4 {
                assert_eq!(open(&g, r), g);
                assert_eq!(close(&g, r), g);
            }
        }
    }
}
