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
pub(crate) const DROPPED_RGB: [u8; 3] = [255, 220, 0];

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
    let rgb = preview_rgb(gray, picture, twotone, stencil, dropped, f);
    encode_rgb(stencil.width * f, stencil.height * f, &rgb)
}

/// The preview's colours by index ([`preview_indexed`]): the four colours above, then the
/// material's grays (`140 + 115 g`, 116 levels), then the cut's blue-grays (`20 + 50 g`, 51
/// levels), then black (a gray that is not a number). Fewer than 256, so the preview is a
/// palette image, a byte a pixel: the studio sends it a third the size of RGB.
const BRIDGE_INDEX: u8 = 0;
const ADDED_INDEX: u8 = 1;
const REMOVED_INDEX: u8 = 2;
const DROPPED_INDEX: u8 = 3;
const MATERIAL_FROM: u8 = 4;
const CUT_FROM: u8 = MATERIAL_FROM + 116;
const BLACK_INDEX: u8 = CUT_FROM + 51;

/// The RGB triples of the preview's palette, index by index (see [`preview_indexed`]).
pub fn preview_palette() -> Vec<u8> {
    let mut p = Vec::with_capacity(3 * (BLACK_INDEX as usize + 1));
    p.extend_from_slice(&BRIDGE_RGB);
    p.extend_from_slice(&ADDED_RGB);
    p.extend_from_slice(&REMOVED_RGB);
    p.extend_from_slice(&DROPPED_RGB);
    for v in 140..=255u8 {
        p.extend_from_slice(&[v, v, v]);
    }
    for v in 20..=70u8 {
        p.extend_from_slice(&[v, v, (v as f32 * 1.3) as u8]);
    }
    p.extend_from_slice(&[0, 0, 0]);
    p
}

/// The palette index of one preview pixel: gray `g` (0..1), thresholded picture, two-tone and
/// stencil.
#[inline]
fn preview_index(g: f32, picture: bool, twotone: bool, stencil: bool) -> u8 {
    let g = g.clamp(0.0, 1.0);
    match (picture, twotone, stencil) {
        (_, false, true) => BRIDGE_INDEX,
        (false, true, true) => ADDED_INDEX,
        (true, _, false) => REMOVED_INDEX,
        (_, _, true) => {
            let v = (140.0 + 115.0 * g) as u8;
            if v >= 140 {
                MATERIAL_FROM + (v - 140)
            } else {
                BLACK_INDEX
            }
        }
        (_, _, false) => {
            let v = (20.0 + 50.0 * g) as u8;
            if (20..=70).contains(&v) {
                CUT_FROM + (v - 20)
            } else {
                BLACK_INDEX
            }
        }
    }
}

/// The preview as palette indices ([`preview_palette`]), one per working pixel, row by row
/// (rows in parallel); the `dropped` islands' pixels (indices into the grid) that `stencil`
/// cuts are `DROPPED_RGB`'s.
pub fn preview_indexed(
    gray: &Gray,
    picture: &BitGrid,
    twotone: &BitGrid,
    stencil: &BitGrid,
    dropped: &[u32],
) -> Vec<u8> {
    use rayon::prelude::*;
    let w = stencil.width as usize;
    let mut out = vec![0u8; stencil.data.len()];
    out.par_chunks_mut(w.max(1))
        .with_min_len(64)
        .enumerate()
        .for_each(|(y, row)| {
            let r = y * w..y * w + row.len();
            let cells = gray.data[r.clone()]
                .iter()
                .zip(&picture.data[r.clone()])
                .zip(&twotone.data[r.clone()])
                .zip(&stencil.data[r]);
            for (o, (((&g, &p), &t), &s)) in row.iter_mut().zip(cells) {
                *o = preview_index(g, p, t, s);
            }
        });
    for &i in dropped {
        if !stencil.data[i as usize] {
            out[i as usize] = DROPPED_INDEX;
        }
    }
    out
}

/// The preview's RGB pixels, each working pixel an `f` × `f` square: [`preview_indexed`]'s
/// colours.
pub fn preview_rgb(
    gray: &Gray,
    picture: &BitGrid,
    twotone: &BitGrid,
    stencil: &BitGrid,
    dropped: &[u32],
    f: u32,
) -> Vec<u8> {
    let (w, h) = (stencil.width as usize, stencil.height as usize);
    let f = f as usize;
    let palette = preview_palette();
    let index = preview_indexed(gray, picture, twotone, stencil, dropped);
    let row_len = w * f * 3;
    let mut rgb = Vec::with_capacity(row_len * h * f);
    for y in 0..h {
        let start = rgb.len();
        for &k in &index[y * w..(y + 1) * w] {
            let c = &palette[3 * k as usize..3 * k as usize + 3];
            for _ in 0..f {
                rgb.extend_from_slice(c);
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
    fn palette_colours_are_the_formulas() {
        let pal = preview_palette();
        assert!(pal.len() <= 3 * 256);
        let at = |k: u8| {
            [
                pal[3 * k as usize],
                pal[3 * k as usize + 1],
                pal[3 * k as usize + 2],
            ]
        };
        for i in 0..=1000 {
            let g = i as f32 / 1000.0;
            let v = (140.0 + 115.0 * g) as u8;
            assert_eq!(at(preview_index(g, true, true, true)), [v, v, v]);
            let v = (20.0 + 50.0 * g) as u8;
            assert_eq!(
                at(preview_index(g, false, false, false)),
                [v, v, (v as f32 * 1.3) as u8]
            );
        }
        assert_eq!(at(preview_index(0.5, false, false, true)), BRIDGE_RGB);
        assert_eq!(at(preview_index(0.5, false, true, true)), ADDED_RGB);
        assert_eq!(at(preview_index(0.5, true, true, false)), REMOVED_RGB);
        assert_eq!(at(preview_index(f32::NAN, true, true, true)), [0, 0, 0]);
    }

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
