//! Loading a picture as grayscale, refusing huge ones before they are decoded, and supersampling.

use std::io::BufReader;
use std::path::Path;

use image::{ImageFormat, ImageReader};

use super::ToneError;
use crate::raster::Gray;

/// Load PNG, JPEG, BMP or TIFF of any colour type as a gray in 0..1 (alpha composited over white,
/// since a transparent pixel of a drawing is paper, not ink).
///
/// The dimensions are read from the header first: an image over `max_pixels` is refused before any
/// pixel buffer is allocated, so a hostile header that claims 100000x100000 costs nothing.
pub fn load_gray(path: &Path, max_pixels: u64) -> Result<Gray, ToneError> {
    let open = || -> Result<ImageReader<BufReader<std::fs::File>>, ToneError> {
        let file = std::fs::File::open(path).map_err(|source| ToneError::Open {
            path: path.to_path_buf(),
            source,
        })?;
        ImageReader::new(BufReader::new(file))
            .with_guessed_format()
            .map_err(|source| ToneError::Open {
                path: path.to_path_buf(),
                source,
            })
    };
    let reader = open()?;
    match reader.format() {
        Some(ImageFormat::Png | ImageFormat::Jpeg | ImageFormat::Bmp | ImageFormat::Tiff) => {}
        other => {
            let detail = match other {
                Some(f) => format!("; it looks like {f:?}, which stencil does not read"),
                None => String::new(),
            };
            return Err(ToneError::UnknownFormat {
                path: path.to_path_buf(),
                detail,
            });
        }
    }
    let (width, height) = reader.into_dimensions().map_err(|e| ToneError::Decode {
        path: path.to_path_buf(),
        msg: e.to_string(),
    })?;
    let pixels = width as u64 * height as u64;
    if pixels == 0 {
        return Err(ToneError::Empty {
            path: path.to_path_buf(),
        });
    }
    if pixels > max_pixels {
        return Err(ToneError::TooLarge {
            path: path.to_path_buf(),
            width,
            height,
            mp: pixels as f64 / 1e6,
            limit_mp: max_pixels as f64 / 1e6,
        });
    }
    let mut reader = open()?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(width);
    limits.max_image_height = Some(height);
    // RGBA16 is the widest layout we decode into; leave room for the decoder's own buffers.
    limits.max_alloc = Some(pixels.saturating_mul(8).saturating_mul(3).max(64 << 20));
    reader.limits(limits);
    let img = reader.decode().map_err(|e| ToneError::Decode {
        path: path.to_path_buf(),
        msg: e.to_string(),
    })?;
    let rgba = img.to_rgba32f();
    let data = rgba
        .pixels()
        .map(|p| {
            let [r, g, b, a] = p.0;
            // Rec. 709 luma, composited over white.
            let l = 0.2126 * r + 0.7152 * g + 0.0722 * b;
            (l * a + (1.0 - a)).clamp(0.0, 1.0)
        })
        .collect();
    Ok(Gray {
        width,
        height,
        data,
    })
}

/// Upsample by an integer factor with bilinear interpolation (the paper's supersampling: thresholding
/// the smooth upsampled gray gives edges that follow the picture, not its pixel staircase).
pub fn upsample(gray: &Gray, k: u32) -> Gray {
    if k <= 1 {
        return gray.clone();
    }
    let (w, h) = (gray.width * k, gray.height * k);
    let mut out = Gray::new(w, h, 0.0);
    let kf = k as f32;
    for y in 0..h {
        // Pixel centres: output centre (y + 0.5)/k maps to input coordinate minus half a pixel.
        let sy = (y as f32 + 0.5) / kf - 0.5;
        for x in 0..w {
            let sx = (x as f32 + 0.5) / kf - 0.5;
            out.set(x, y, gray.sample(sx, sy));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn upsample_keeps_size_and_range() {
        let mut g = Gray::new(3, 2, 0.0);
        g.set(2, 1, 1.0);
        let u = upsample(&g, 4);
        assert_eq!((u.width, u.height), (12, 8));
        assert!(u.data.iter().all(|v| (0.0..=1.0).contains(v)));
        assert_eq!(u.get(11, 7), 1.0);
        assert_eq!(u.get(0, 0), 0.0);
    }
}
