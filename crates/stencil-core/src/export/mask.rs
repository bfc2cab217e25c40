//! Photo-etch masks: `mask.png` (1-bit, `--mask-dpi`, default 1200) and `mask.svg`.
//!
//! Polarity: by default black where metal stays and clear where it is etched away (what a
//! positive-acting resist needs); `--mask-invert` gives clear where metal stays, for
//! negative-acting resist (dry-film photoresists are usually negative-acting: check with the shop). `--mask-mirror` flips left-right for film
//! laid emulsion side down (and for the back of two-sided art). Optional registration marks (a
//! ring and a cross in each corner of the margin, drawn in the etched tone) line up front and back
//! films.
//!
//! The mask covers the whole sheet (picture plus margin), so its size is the sheet's size in mm
//! times the dpi: `round(width_mm / 25.4 × dpi)` pixels.

use std::fmt::Write;

use geo::{Coord, LineString};

use super::svg::{num, path_data, rings};
use super::ExportError;
use crate::vector::CutGeometry;

/// Mask options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaskConfig {
    pub dpi: f64,
    /// Clear (white) where metal stays instead of black.
    pub invert: bool,
    /// Mirror left-right.
    pub mirror: bool,
    /// Registration marks in the corners of the margin.
    pub marks: bool,
}

impl Default for MaskConfig {
    fn default() -> Self {
        MaskConfig {
            dpi: 1200.0,
            invert: false,
            mirror: false,
            marks: false,
        }
    }
}

/// Largest mask accepted, in pixels (a 1200 dpi A3 sheet is ~ 2.6e8).
pub const MAX_MASK_PIXELS: f64 = 1.0e9;

/// Pixel size of the mask for a geometry.
pub fn mask_size(geom: &CutGeometry, dpi: f64) -> (u32, u32) {
    let o = geom.outline;
    let f = dpi / 25.4;
    (
        (o.width() * f).round().max(1.0) as u32,
        (o.height() * f).round().max(1.0) as u32,
    )
}

/// The rings to fill with the etched tone (even-odd): the cut regions and the marks.
fn etched_rings(geom: &CutGeometry, marks: bool) -> Vec<LineString<f64>> {
    let mut out: Vec<LineString<f64>> = rings(&geom.design_cuts).cloned().collect();
    if marks {
        out.extend(mark_rings(geom));
    }
    out
}

/// A ring and a cross at the middle of each corner square of the margin.
fn mark_rings(geom: &CutGeometry) -> Vec<LineString<f64>> {
    let o = geom.outline;
    let m = -o.min().x; // the margin
    let r = (0.35 * m).min(4.0);
    let t = (r / 8.0).max(0.05);
    let centres = [
        (o.min().x + m / 2.0, o.min().y + m / 2.0),
        (o.max().x - m / 2.0, o.min().y + m / 2.0),
        (o.min().x + m / 2.0, o.max().y - m / 2.0),
        (o.max().x - m / 2.0, o.max().y - m / 2.0),
    ];
    let circle = |cx: f64, cy: f64, rad: f64| {
        LineString::new(
            (0..=64)
                .map(|i| {
                    let a = i as f64 / 64.0 * std::f64::consts::TAU;
                    Coord {
                        x: cx + rad * a.cos(),
                        y: cy + rad * a.sin(),
                    }
                })
                .collect(),
        )
    };
    let rect = |x0: f64, y0: f64, x1: f64, y1: f64| {
        LineString::new(vec![
            Coord { x: x0, y: y0 },
            Coord { x: x1, y: y0 },
            Coord { x: x1, y: y1 },
            Coord { x: x0, y: y1 },
            Coord { x: x0, y: y0 },
        ])
    };
    let mut out = Vec::new();
    for (cx, cy) in centres {
        out.push(circle(cx, cy, r));
        out.push(circle(cx, cy, r - t));
        let a = r - 2.0 * t;
        out.push(rect(cx - a, cy - t / 2.0, cx + a, cy + t / 2.0));
        out.push(rect(cx - t / 2.0, cy - a, cx + t / 2.0, cy - t / 2.0));
        out.push(rect(cx - t / 2.0, cy + t / 2.0, cx + t / 2.0, cy + a));
    }
    out
}

/// Encode `mask.png`: 1-bit grayscale (1 = white).
pub fn encode_png(geom: &CutGeometry, cfg: &MaskConfig) -> Result<Vec<u8>, ExportError> {
    if !cfg.dpi.is_finite() || cfg.dpi <= 0.0 {
        return Err(ExportError::MaskDpi(cfg.dpi));
    }
    let (w, h) = mask_size(geom, cfg.dpi);
    if w as f64 * h as f64 > MAX_MASK_PIXELS {
        return Err(ExportError::MaskTooLarge {
            width: w,
            height: h,
            dpi: cfg.dpi,
        });
    }
    let data = scan_fill(&pixel_edges(geom, cfg, w), w, h, cfg.invert);
    write_png(&data, w, h, cfg.dpi)
}

/// The etched rings' edges in pixel space, (x0, y0, x1, y1) with y0 < y1 (horizontal ones
/// dropped, mirrored when asked), sorted by y0 for the scan.
fn pixel_edges(geom: &CutGeometry, cfg: &MaskConfig, w: u32) -> Vec<[f64; 4]> {
    let f = cfg.dpi / 25.4;
    let (ox, oy) = (geom.outline.min().x, geom.outline.min().y);
    let mut edges: Vec<[f64; 4]> = Vec::new();
    for r in etched_rings(geom, cfg.marks) {
        for s in r.0.windows(2) {
            let mut a = [(s[0].x - ox) * f, (s[0].y - oy) * f];
            let mut b = [(s[1].x - ox) * f, (s[1].y - oy) * f];
            if cfg.mirror {
                a[0] = w as f64 - a[0];
                b[0] = w as f64 - b[0];
            }
            if a[1] == b[1] {
                continue;
            }
            if a[1] > b[1] {
                std::mem::swap(&mut a, &mut b);
            }
            edges.push([a[0], a[1], b[0], b[1]]);
        }
    }
    edges.sort_by(|p, q| p[1].total_cmp(&q[1]));
    edges
}

/// Even-odd scan fill of `edges` into 1-bit rows (`w` × `h`, each row padded to whole bytes):
/// a pixel is etched when its centre lies inside. Metal stays black (0) unless `invert`; etched
/// regions get the other tone.
fn scan_fill(edges: &[[f64; 4]], w: u32, h: u32, invert: bool) -> Vec<u8> {
    let stride = (w as usize).div_ceil(8);
    let mut data = vec![if invert { 0xffu8 } else { 0 }; stride * h as usize];
    let mut active: Vec<usize> = Vec::new();
    let mut next = 0;
    let mut xs: Vec<f64> = Vec::new();
    for row in 0..h as usize {
        let yc = row as f64 + 0.5;
        while next < edges.len() && edges[next][1] <= yc {
            active.push(next);
            next += 1;
        }
        active.retain(|&i| edges[i][3] > yc);
        xs.clear();
        for &i in &active {
            let e = edges[i];
            if e[1] <= yc {
                xs.push(e[0] + (yc - e[1]) / (e[3] - e[1]) * (e[2] - e[0]));
            }
        }
        xs.sort_by(f64::total_cmp);
        let line = &mut data[row * stride..(row + 1) * stride];
        for pair in xs.chunks_exact(2) {
            // Pixels whose centre lies in [x0, x1).
            let x0 = (pair[0] - 0.5).ceil().max(0.0) as usize;
            let x1 = ((pair[1] - 0.5).ceil().max(0.0) as usize).min(w as usize);
            for x in x0..x1 {
                line[x / 8] ^= 0x80 >> (x % 8);
            }
        }
    }
    data
}

/// The 1-bit grayscale PNG, with its resolution in pixels per metre so the film plotter sees the
/// intended dpi.
fn write_png(data: &[u8], w: u32, h: u32, dpi: f64) -> Result<Vec<u8>, ExportError> {
    let err = |msg: String| ExportError::Encode {
        path: "mask.png".into(),
        msg,
    };
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::One);
        let ppm = (dpi / 0.0254).round() as u32;
        enc.set_pixel_dims(Some(png::PixelDimensions {
            xppu: ppm,
            yppu: ppm,
            unit: png::Unit::Meter,
        }));
        let mut wr = enc.write_header().map_err(|e| err(e.to_string()))?;
        wr.write_image_data(data).map_err(|e| err(e.to_string()))?;
    }
    Ok(out)
}

/// Encode `mask.svg`: the same mask as vectors at real size.
pub fn encode_svg(geom: &CutGeometry, cfg: &MaskConfig) -> Vec<u8> {
    let o = geom.outline;
    let (w, h) = (o.width(), o.height());
    let (metal, etched) = if cfg.invert {
        ("#ffffff", "#000000")
    } else {
        ("#000000", "#ffffff")
    };
    let transform = if cfg.mirror {
        format!(
            " transform=\"translate({} 0) scale(-1 1)\"",
            num(2.0 * o.min().x + w)
        )
    } else {
        String::new()
    };
    let d = path_data(etched_rings(geom, cfg.marks).iter());
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}mm\" height=\"{h}mm\" viewBox=\"{x} {y} {w} {h}\">\
         <rect x=\"{x}\" y=\"{y}\" width=\"{w}\" height=\"{h}\" fill=\"{metal}\"/>\
         <g{transform}><path d=\"{d}\" fill=\"{etched}\" fill-rule=\"evenodd\"/></g></svg>",
        w = num(w),
        h = num(h),
        x = num(o.min().x),
        y = num(o.min().y),
    );
    s.into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::BitGrid;
    use crate::vector::{vectorize, VectorConfig};

    #[test]
    fn the_etched_area_matches_the_cut_area() {
        // A 100 x 60 px cut rectangle at 0.1 mm/px: 10 x 6 mm = 60 mm².
        let g = BitGrid::from_fn(200, 100, |x, y| {
            !((50..150).contains(&x) && (20..80).contains(&y))
        });
        let (geom, _) = vectorize(
            &g,
            &[],
            &VectorConfig {
                smooth: false,
                ..Default::default()
            },
        )
        .unwrap();
        let cfg = MaskConfig {
            dpi: 254.0,
            ..Default::default()
        }; // 10 px per mm
        let png = encode_png(&geom, &cfg).unwrap();
        let img = image::load_from_memory(&png).unwrap().to_luma8();
        assert_eq!((img.width(), img.height()), (300, 200)); // (20 + 10) mm x (10 + 10) mm
        let white = img.pixels().filter(|p| p.0[0] > 127).count() as f64;
        assert!((white - 6000.0).abs() < 6000.0 * 0.01, "{white}");
    }
}
