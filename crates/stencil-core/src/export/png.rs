//! PNG encoding of grids and previews (in memory; `super::write_files` puts them on disk).

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};

use crate::raster::{BitGrid, Gray};

/// Encode 8-bit gray pixels.
pub(crate) fn encode_gray(width: u32, height: u32, data: &[u8]) -> Vec<u8> {
    encode(width, height, data, ExtendedColorType::L8)
}

/// Encode 8-bit RGB pixels.
pub fn encode_rgb(width: u32, height: u32, data: &[u8]) -> Vec<u8> {
    encode(width, height, data, ExtendedColorType::Rgb8)
}

fn encode(width: u32, height: u32, data: &[u8], color: ExtendedColorType) -> Vec<u8> {
    let mut out = Vec::new();
    // Writing into a Vec with a buffer of the right length cannot fail.
    PngEncoder::new(&mut out)
        .write_image(data, width, height, color)
        .expect("in-memory PNG encoding of a correctly sized buffer");
    out
}

/// A bit grid as `twotone.png`/`stencil.png`: 255 = material, 0 = cut.
pub fn encode_bits(bits: &BitGrid) -> Vec<u8> {
    encode_gray(bits.width, bits.height, &bits.to_u8())
}

/// Preview colours (documented in the README's table of outputs). Bridges: a saturated orange
/// that no gray can be mistaken for.
pub const BRIDGE_RGB: [u8; 3] = [255, 110, 0];
/// Material of the picture that the stencil cuts away (the clean-up removed it): magenta.
pub const REMOVED_RGB: [u8; 3] = [230, 0, 160];
/// Cut of the picture that the clean-up filled with material: bright blue.
pub const ADDED_RGB: [u8; 3] = [0, 150, 255];
/// Islands dropped instead of bridged (`bridge::drop`): yellow, so they are not taken for what
/// the clean-up removed.
pub const DROPPED_RGB: [u8; 3] = [255, 220, 0];

/// The preview's long side is at least this many pixels: a small picture is enlarged by a whole
/// factor, nearest-neighbour, so every working pixel stays a visible square.
pub(crate) const PREVIEW_MIN_LONG_SIDE: u32 = 1000;

/// The whole factor by which the preview enlarges a `width` × `height` picture: the smallest that
/// brings its long side to [`PREVIEW_MIN_LONG_SIDE`], 1 for a picture already that large. The
/// preview's long side is then under `PREVIEW_MIN_LONG_SIDE + long side`.
pub(crate) fn preview_factor(width: u32, height: u32) -> u32 {
    PREVIEW_MIN_LONG_SIDE.div_ceil(width.max(height).max(1))
}

/// The preview for a person, at working size times [`preview_factor`]: the source picture dimmed,
/// light where the stencil has material and dark where it is cut, and in colour what the stencil
/// changed: [`BRIDGE_RGB`] for bridges (material in `stencil` that is cut in `twotone`),
/// [`ADDED_RGB`] for material the clean-up added (cut in `picture`, material in `twotone`), and
/// [`REMOVED_RGB`] for material of the picture the stencil cuts away. `picture` is the thresholded
/// picture, `twotone` the same after the clean-up, `stencil` after bridges.
pub(crate) fn preview(
    gray: &Gray,
    picture: &BitGrid,
    twotone: &BitGrid,
    stencil: &BitGrid,
    dropped: &[u32],
) -> Vec<u8> {
    let f = preview_factor(stencil.width, stencil.height);
    let mut rgb = preview_rgb(gray, picture, twotone, stencil, f);
    paint_dropped(&mut rgb, stencil, dropped, f);
    encode_rgb(stencil.width * f, stencil.height * f, &rgb)
}

/// Colour the dropped islands' pixels (cut in `stencil`) [`DROPPED_RGB`] in a preview made by
/// [`preview_rgb`] with the same `f` (the studio's page shows them as `preview.png` does).
pub fn paint_dropped(rgb: &mut [u8], stencil: &BitGrid, dropped: &[u32], f: u32) {
    let (w, f) = (stencil.width as usize, f as usize);
    for &i in dropped {
        let (x, y) = (i as usize % w, i as usize / w);
        if stencil.data[i as usize] {
            continue;
        }
        for dy in 0..f {
            let row = (y * f + dy) * w * f * 3;
            for dx in 0..f {
                let k = row + (x * f + dx) * 3;
                rgb[k..k + 3].copy_from_slice(&DROPPED_RGB);
            }
        }
    }
}

/// The preview's RGB pixels, each working pixel an `f` × `f` square (the studio sends them at
/// `f` = 1 and lets the page enlarge them).
pub fn preview_rgb(
    gray: &Gray,
    picture: &BitGrid,
    twotone: &BitGrid,
    stencil: &BitGrid,
    f: u32,
) -> Vec<u8> {
    let (w, h) = (stencil.width as usize, stencil.height as usize);
    let f = f as usize;
    let colour = |i: usize| -> [u8; 3] {
        let g = gray.data[i].clamp(0.0, 1.0);
        match (picture.data[i], twotone.data[i], stencil.data[i]) {
            (_, false, true) => BRIDGE_RGB,
            (false, true, true) => ADDED_RGB,
            (true, _, false) => REMOVED_RGB,
            (_, _, true) => {
                let v = (140.0 + 115.0 * g) as u8;
                [v, v, v]
            }
            (_, _, false) => {
                let v = (20.0 + 50.0 * g) as u8;
                [v, v, (v as f32 * 1.3) as u8]
            }
        }
    };
    let row_len = w * f * 3;
    let mut rgb = Vec::with_capacity(row_len * h * f);
    for y in 0..h {
        let start = rgb.len();
        for i in y * w..(y + 1) * w {
            let c = colour(i);
            for _ in 0..f {
                rgb.extend_from_slice(&c);
            }
        }
        for _ in 1..f {
            rgb.extend_from_within(start..start + row_len);
        }
    }
    rgb
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn preview_factor_reaches_the_minimum_without_overshooting() {
        assert_eq!(preview_factor(100, 40), 10);
        assert_eq!(preview_factor(40, 101), 10, "1010 px");
        assert_eq!(preview_factor(999, 10), 2);
        assert_eq!(preview_factor(1000, 10), 1);
        assert_eq!(
            preview_factor(5000, 4000),
            1,
            "a large picture is not enlarged"
        );
        assert_eq!(preview_factor(0, 0), PREVIEW_MIN_LONG_SIDE);
        for long in 1..3000 {
            let side = long * preview_factor(long, 1);
            assert!(side >= PREVIEW_MIN_LONG_SIDE && side < PREVIEW_MIN_LONG_SIDE + long);
        }
    }

    #[test]
    fn preview_paints_each_change_in_its_colour() {
        // Columns: unchanged material, unchanged cut, bridge, added by the clean-up, removed.
        let picture = BitGrid::from_rows(&["#...#"]);
        let twotone = BitGrid::from_rows(&["#..#."]);
        let stencil = BitGrid::from_rows(&["#.##."]);
        let gray = Gray::new(5, 1, 1.0);
        let png = preview(&gray, &picture, &twotone, &stencil, &[]);
        let img = image::load_from_memory(&png).unwrap().to_rgb8();
        assert_eq!((img.width(), img.height()), (1000, 200));
        let at = |col: u32| img.get_pixel(col * 200 + 199, 199).0;
        assert_eq!(at(0), [255, 255, 255]);
        assert!(at(1)[0] < 80, "cut is dark: {:?}", at(1));
        assert_eq!(at(2), BRIDGE_RGB);
        assert_eq!(at(3), ADDED_RGB);
        assert_eq!(at(4), REMOVED_RGB);
    }
}
