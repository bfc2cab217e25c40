//! PNG encoding of grids and previews (in memory; [`super::write_files`] puts them on disk).

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};

use crate::raster::{BitGrid, Gray};

/// Encode 8-bit gray pixels.
pub fn encode_gray(width: u32, height: u32, data: &[u8]) -> Vec<u8> {
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

/// Bridge colour in the preview: a saturated orange that no gray can be mistaken for.
pub const BRIDGE_RGB: [u8; 3] = [255, 110, 0];

/// The preview for a person: the source dimmed, cut regions dark, bridges bright.
pub fn preview(gray: &Gray, before: &BitGrid, after: &BitGrid) -> Vec<u8> {
    let mut rgb = Vec::with_capacity(before.len() * 3);
    for i in 0..before.len() {
        let g = gray.data[i].clamp(0.0, 1.0);
        let px = if after.data[i] && !before.data[i] {
            BRIDGE_RGB
        } else if after.data[i] {
            let v = (140.0 + 115.0 * g) as u8;
            [v, v, v]
        } else {
            let v = (20.0 + 50.0 * g) as u8;
            [v, v, (v as f32 * 1.3) as u8]
        };
        rgb.extend_from_slice(&px);
    }
    encode_rgb(before.width, before.height, &rgb)
}
