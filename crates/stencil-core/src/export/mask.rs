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
//!
//! With an etch material ([`Etch`]), [`mask_files`] draws every opening smaller by the undercut
//! (depth ÷ etch factor, each side of a two-sided etch etching half the depth), so the etched
//! opening comes out at the designed size, and reports openings the compensation closes; a
//! two-sided etch gets a front and a back mask, the back the front's mirror image. What each
//! mask is (side, mirroring, dpi, polarity) goes into report.json ([`MaskReport`]).

use std::fmt::Write;

use geo::{Area, LineString};

use super::error::ExportError;
use super::svg::{num, path_data, rings};
use crate::vector::CutGeometry;

/// Mask options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaskConfig {
    /// Resolution of `mask.png`, dots per inch.
    pub dpi: f64,
    /// Clear (white) where metal stays instead of black.
    pub invert: bool,
    /// Mirror left-right.
    pub mirror: bool,
    /// Registration marks in the corners of the margin.
    pub marks: bool,
    /// The picture's tones were swapped (`--invert`): then a mostly clear mask is what was asked
    /// for, and [`MaskReport::warning`] stays quiet.
    pub tone_inverted: bool,
}

impl Default for MaskConfig {
    fn default() -> Self {
        MaskConfig {
            dpi: 1200.0,
            invert: false,
            mirror: false,
            marks: false,
            tone_inverted: false,
        }
    }
}

/// How the metal is etched (from the material's `[etch]` section and thickness): what the
/// undercut compensation and two-sided art need.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Etch {
    pub(crate) thickness_mm: f64,
    /// Depth etched per unit of sideways undercut.
    pub etch_factor: f64,
    /// Etched from both sides at once: front and back masks, each side etching half the depth.
    pub two_sided: bool,
}

/// The narrowest opening a mask is drawn with, mm: about two pixels at 1200 dpi, the narrowest
/// line a film plotter draws reliably. An opening whose compensated mask would be narrower is
/// not etched as designed.
pub(crate) const MIN_MASK_OPENING_MM: f64 = 0.05;

impl Etch {
    /// The undercut under each mask edge, mm: each side etches its depth (the thickness, or half
    /// of it from both sides) and the etchant eats sideways depth ÷ etch factor under the resist.
    /// The mask's openings are drawn this much smaller on every side, so the etched opening comes
    /// out at the designed size.
    pub fn undercut_mm(&self) -> f64 {
        let depth = if self.two_sided {
            self.thickness_mm / 2.0
        } else {
            self.thickness_mm
        };
        depth / self.etch_factor
    }

    /// The narrowest opening that etches at its designed size: twice the undercut (what the
    /// compensation takes off both sides) plus `MIN_MASK_OPENING_MM` left in the mask. `make`
    /// raises the material's smallest feature to it, so the clean-up and the width check judge
    /// what is etched rather than a design the mask cannot carry.
    pub fn min_opening_mm(&self) -> f64 {
        2.0 * self.undercut_mm() + MIN_MASK_OPENING_MM
    }

    /// The etch of a material with an `[etch]` section.
    pub fn of(material: &crate::material::Material) -> Option<Etch> {
        material.etch().map(|e| Etch {
            thickness_mm: material.thickness_mm,
            etch_factor: e.etch_factor,
            two_sided: e.two_sided,
        })
    }
}

/// What the masks are, for report.json and the console: which files, their dpi, polarity and
/// mirroring, the undercut compensation and what it closed, and how much of the picture is clear.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MaskReport {
    /// Each mask: its files, the side it is for and whether it is mirrored.
    pub masks: Vec<MaskSide>,
    /// Resolution of the PNG masks, dots per inch.
    pub dpi: f64,
    /// Where metal stays, in words: "black where metal stays (positive resist)" or "clear where
    /// metal stays (negative resist)"; light passes where the stencil is cut.
    pub polarity: String,
    /// Each opening drawn this much smaller on every side for the etch's undercut, mm (0: none).
    pub undercut_compensation_mm: f64,
    /// Openings narrower than twice the compensation: the mask closes them, so they would not be
    /// etched at all.
    pub openings_closed: usize,
    /// The share of the picture etched clear, percent.
    pub clear_pct: f64,
    /// Set when most of the picture is clear with its light parts left as metal: a gobo projects
    /// the clear parts as light, so a bright subject usually wants the tones swapped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
}

/// One mask of a set.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MaskSide {
    /// "single", "front" or "back".
    pub side: String,
    /// The PNG mask's file name.
    pub png: String,
    /// The SVG mask's file name.
    pub svg: String,
    /// Drawn mirrored (for the back, or the emulsion side down).
    pub mirrored: bool,
}

/// The masks' files and what they are. One mask (`mask.png`, `mask.svg`), or with a two-sided
/// etch a front (`mask-front.*`, as configured) and a back (`mask-back.*`, mirrored against the
/// front: laid on the other face, it registers with it through the sheet). With `etch`, the
/// openings are compensated for the undercut ([`Etch::undercut_mm`]); the width check judges
/// the design, which is what the compensated mask etches (`make` raises an etch material's
/// smallest feature to [`Etch::min_opening_mm`], so no opening it passes is closed here; those
/// that are, with other widths, are counted in [`MaskReport::openings_closed`]). A gobo's rim
/// ([`CutGeometry::rim`]) is etched as a groove outside the disc ([`rim_groove_mm`]).
#[allow(clippy::type_complexity)]
pub(crate) fn mask_files(
    geom: &CutGeometry,
    cfg: &MaskConfig,
    etch: Option<Etch>,
) -> Result<(Vec<(String, Vec<u8>)>, MaskReport), ExportError> {
    let u = etch.map_or(0.0, |e| e.undercut_mm());
    let mut g = geom.clone();
    let mut closed = 0;
    if u > 0.0 {
        let err = |e: stencil_geom::clip::ClipError| ExportError::Encode {
            path: "mask.png".into(),
            msg: format!("the undercut compensation: {e}"),
        };
        let shrunk = stencil_geom::kerf::offset_cuts(&geom.design_cuts, 2.0 * u).map_err(err)?;
        // An opening is closed when nothing of it is left (each is offset on its own).
        for p in &geom.design_cuts.0 {
            let one = geo::MultiPolygon::new(vec![p.clone()]);
            if stencil_geom::kerf::offset_cuts(&one, 2.0 * u)
                .map_err(err)?
                .0
                .is_empty()
            {
                closed += 1;
            }
        }
        g.design_cuts = shrunk;
    }
    if let Some(rim) = geom.rim {
        // The rim etched through as a groove outside the disc, its inner edge at the outside
        // diameter after the undercut (drawn `u` further out, as every opening is drawn `u`
        // smaller).
        let t = etch.map_or(0.0, |e| e.thickness_mm);
        let groove = rim_groove_mm(t, u);
        let (r_in, r_out) = (rim.od_mm / 2.0 + u, rim.od_mm / 2.0 + groove - u);
        if r_out > r_in {
            g.design_cuts
                .0
                .push(geo::Polygon::new(rim.ring(r_out), vec![rim.ring(r_in)]));
        } else {
            closed += 1;
        }
    }
    let two = etch.is_some_and(|e| e.two_sided);
    let sides: Vec<(&str, &str, bool)> = if two {
        vec![
            ("front", "mask-front", cfg.mirror),
            ("back", "mask-back", !cfg.mirror),
        ]
    } else {
        vec![("single", "mask", cfg.mirror)]
    };
    let mut files = Vec::new();
    let mut masks = Vec::new();
    let polarity = polarity(cfg.invert);
    for (side, stem, mirror) in sides {
        let c = MaskConfig { mirror, ..*cfg };
        // Each file says what it is, for whoever opens it without the report.
        let desc = format!(
            "stencil photo-etch mask, {side}: {polarity}; {}; {} dpi",
            if mirror {
                "mirrored left-right"
            } else {
                "right-reading"
            },
            cfg.dpi
        );
        files.push((format!("{stem}.png"), encode_png(&g, &c, &desc)?));
        files.push((format!("{stem}.svg"), encode_svg(&g, &c, &desc)));
        masks.push(MaskSide {
            side: side.into(),
            png: format!("{stem}.png"),
            svg: format!("{stem}.svg"),
            mirrored: mirror,
        });
    }
    let picture = geom.width_mm * geom.height_mm;
    let clear_pct = if picture > 0.0 {
        100.0 * geom.design_cuts.unsigned_area() / picture
    } else {
        0.0
    };
    let warning = (clear_pct > 50.0 && !cfg.tone_inverted).then(|| {
        format!(
            "{clear_pct:.0} % of the picture is etched clear and its light parts stay as metal; \
             light passes where the mask is etched, so a bright subject on a dark ground usually \
             wants its tones swapped"
        )
    });
    Ok((
        files,
        MaskReport {
            masks,
            dpi: cfg.dpi,
            polarity,
            undercut_compensation_mm: u,
            openings_closed: closed,
            clear_pct,
            warning,
        },
    ))
}

/// How a stencil's polarity reads, for every output that has one (masks, gobos).
pub const POLARITY: &str =
    "metal stays where the stencil is material; light passes where it is cut";

/// The polarity in words: the mask's tones, and what they mean for the part (metal stays where
/// the stencil is material; light passes where it is cut).
fn polarity(invert: bool) -> String {
    format!(
        "{}; {}",
        if invert {
            "clear where metal stays (negative resist), black where it is etched away"
        } else {
            "black where metal stays (positive resist), clear where it is etched away"
        },
        POLARITY
    )
}

/// The groove a gobo's rim is etched as, mm: an etched line comes through a sheet only when it
/// is about as wide as the sheet is thick (photo-etching shops give 1 to 1.5 × the thickness as
/// the narrowest slot), so 1.5 × the thickness, never under 0.3 mm, and wide enough that its
/// mask, drawn `undercut_mm` narrower on each side, keeps [`MIN_MASK_OPENING_MM`].
pub(crate) fn rim_groove_mm(thickness_mm: f64, undercut_mm: f64) -> f64 {
    (1.5 * thickness_mm)
        .max(0.3)
        .max(2.0 * undercut_mm + MIN_MASK_OPENING_MM)
}

/// Largest mask accepted, in pixels (a 1200 dpi A3 sheet is ~ 2.6e8).
pub(crate) const MAX_MASK_PIXELS: f64 = 1.0e9;

/// Pixel size of the mask for a geometry.
pub(crate) fn mask_size(geom: &CutGeometry, dpi: f64) -> (u32, u32) {
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
    // The margin: around the picture, or around a gobo's rim (its corners lie outside the disc).
    let m = match geom.rim {
        Some(rim) => (o.width() - rim.od_mm) / 2.0,
        None => -o.min().x,
    };
    let r = (0.35 * m).min(4.0);
    let t = (r / 8.0).max(0.05);
    let centres = [
        (o.min().x + m / 2.0, o.min().y + m / 2.0),
        (o.max().x - m / 2.0, o.min().y + m / 2.0),
        (o.min().x + m / 2.0, o.max().y - m / 2.0),
        (o.max().x - m / 2.0, o.max().y - m / 2.0),
    ];
    let circle = |cx: f64, cy: f64, rad: f64| {
        let at = |i| (i as f64 / 64.0 * std::f64::consts::TAU).sin_cos();
        LineString::from_iter((0..=64).map(at).map(|(s, c)| (cx + rad * c, cy + rad * s)))
    };
    let rect = |x0: f64, y0: f64, x1: f64, y1: f64| {
        LineString::from(vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)])
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

/// Encode `mask.png`: 1-bit grayscale (1 = white), with `desc` in a tEXt `Description` chunk
/// (when not empty).
pub(crate) fn encode_png(
    geom: &CutGeometry,
    cfg: &MaskConfig,
    desc: &str,
) -> Result<Vec<u8>, ExportError> {
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
    write_png(&data, w, h, cfg.dpi, desc)
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
fn write_png(data: &[u8], w: u32, h: u32, dpi: f64, desc: &str) -> Result<Vec<u8>, ExportError> {
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
        if !desc.is_empty() {
            enc.add_text_chunk("Description".into(), desc.into())
                .map_err(|e| err(e.to_string()))?;
        }
        let mut wr = enc.write_header().map_err(|e| err(e.to_string()))?;
        wr.write_image_data(data).map_err(|e| err(e.to_string()))?;
    }
    Ok(out)
}

/// Encode `mask.svg`: the same mask as vectors at real size, with `desc` as the drawing's
/// `<desc>` (when not empty).
pub(crate) fn encode_svg(geom: &CutGeometry, cfg: &MaskConfig, desc: &str) -> Vec<u8> {
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
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}mm\" height=\"{h}mm\" viewBox=\"{x} {y} {w} {h}\">{desc}\
         <rect x=\"{x}\" y=\"{y}\" width=\"{w}\" height=\"{h}\" fill=\"{metal}\"/>\
         <g{transform}><path d=\"{d}\" fill=\"{etched}\" fill-rule=\"evenodd\"/></g></svg>",
        w = num(w),
        h = num(h),
        x = num(o.min().x),
        y = num(o.min().y),
        desc = if desc.is_empty() {
            String::new()
        } else {
            format!("<desc>{}</desc>", desc.replace('&', "&amp;").replace('<', "&lt;"))
        },
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
        let png = encode_png(&geom, &cfg, "").unwrap();
        let img = image::load_from_memory(&png).unwrap().to_luma8();
        assert_eq!((img.width(), img.height()), (300, 200)); // (20 + 10) mm x (10 + 10) mm
        let white = img.pixels().filter(|p| p.0[0] > 127).count() as f64;
        assert!((white - 6000.0).abs() < 6000.0 * 0.01, "{white}");
    }

    /// A picture of vertical slots `widths` px wide (cut), 100 px apart, at 0.1 mm/px.
    fn slots(widths: &[usize]) -> CutGeometry {
        let w = 100 * (widths.len() + 1);
        let g = BitGrid::from_fn(w as u32, 300, |x, y| {
            let x = x as usize;
            let in_slot = widths.iter().enumerate().any(|(k, &sw)| {
                let x0 = 100 * (k + 1);
                (x0..x0 + sw).contains(&x)
            });
            !(in_slot && (50..250).contains(&y))
        });
        vectorize(
            &g,
            &[],
            &VectorConfig {
                smooth: false,
                ..Default::default()
            },
        )
        .unwrap()
        .0
    }

    /// Etched (white) runs along the mask's middle row, in mm.
    fn runs_mm(png: &[u8], dpi: f64) -> Vec<f64> {
        let img = image::load_from_memory(png).unwrap().to_luma8();
        let y = img.height() / 2;
        let mut runs = Vec::new();
        let mut run = 0;
        for x in 0..img.width() {
            if img.get_pixel(x, y).0[0] > 127 {
                run += 1;
            } else if run > 0 {
                runs.push(run as f64 * 25.4 / dpi);
                run = 0;
            }
        }
        runs
    }

    #[test]
    fn the_undercut_compensation_narrows_a_line_of_known_width_by_twice_the_undercut() {
        // A 2.0 mm slot (20 px at 0.1 mm/px) in 0.5 mm metal with etch factor 2.5, one side:
        // undercut 0.5 / 2.5 = 0.2 mm per side, so the mask opening is 2.0 - 0.4 = 1.6 mm wide;
        // the etchant then widens it back to 2.0 mm through the sheet.
        let geom = slots(&[20]);
        let dpi = 2540.0; // 100 px per mm: 0.01 mm pixels
        let cfg = MaskConfig {
            dpi,
            ..Default::default()
        };
        let plain = mask_files(&geom, &cfg, None).unwrap();
        // The traced slot (marching squares through pixel centres' midpoints): 2.0 mm within a
        // few mask pixels.
        let plain = runs_mm(&plain.0[0].1, dpi);
        assert_eq!(plain.len(), 1);
        assert!((plain[0] - 2.0).abs() <= 0.05, "{plain:?}");
        let etch = Etch {
            thickness_mm: 0.5,
            etch_factor: 2.5,
            two_sided: false,
        };
        let (files, r) = mask_files(&geom, &cfg, Some(etch)).unwrap();
        assert!((r.undercut_compensation_mm - 0.2).abs() < 1e-12);
        let runs = runs_mm(&files[0].1, dpi);
        assert_eq!(runs.len(), 1);
        assert!(
            (plain[0] - runs[0] - 0.4).abs() <= 0.011,
            "{plain:?} -> {runs:?}"
        );
        // Two-sided: each side etches half the depth, 0.1 mm undercut: a 1.8 mm opening.
        let (files, r) = mask_files(
            &geom,
            &cfg,
            Some(Etch {
                two_sided: true,
                ..etch
            }),
        )
        .unwrap();
        assert!((r.undercut_compensation_mm - 0.1).abs() < 1e-12);
        assert!((plain[0] - runs_mm(&files[0].1, dpi)[0] - 0.2).abs() <= 0.011);
    }

    #[test]
    fn an_opening_the_compensation_would_close_is_reported() {
        // Slots of 0.3 mm and 2 mm; 0.2 mm undercut per side closes the first (0.3 < 0.4).
        let geom = slots(&[3, 20]);
        let etch = Etch {
            thickness_mm: 0.5,
            etch_factor: 2.5,
            two_sided: false,
        };
        let (_, r) = mask_files(&geom, &MaskConfig::default(), Some(etch)).unwrap();
        assert_eq!(r.openings_closed, 1);
    }

    #[test]
    fn two_sided_art_is_a_front_and_its_mirror_image() {
        // An asymmetric picture: slots of 1 mm and 3 mm.
        let geom = slots(&[10, 30]);
        let etch = Etch {
            thickness_mm: 0.3,
            etch_factor: 2.5,
            two_sided: true,
        };
        let cfg = MaskConfig {
            dpi: 254.0,
            ..Default::default()
        };
        let (files, r) = mask_files(&geom, &cfg, Some(etch)).unwrap();
        let names: Vec<&str> = files.iter().map(|f| f.0.as_str()).collect();
        assert_eq!(
            names,
            [
                "mask-front.png",
                "mask-front.svg",
                "mask-back.png",
                "mask-back.svg"
            ]
        );
        assert_eq!(
            r.masks.iter().map(|m| m.mirrored).collect::<Vec<_>>(),
            [false, true]
        );
        let front = image::load_from_memory(&files[0].1).unwrap().to_luma8();
        let back = image::load_from_memory(&files[2].1).unwrap().to_luma8();
        let flipped = image::imageops::flip_horizontal(&back);
        assert_eq!(
            front.as_raw(),
            flipped.as_raw(),
            "registered: the back is the mirror"
        );
        assert!(r.polarity.starts_with("black where metal stays"));
        assert_eq!(r.dpi, 254.0);
    }

    #[test]
    fn a_mostly_clear_mask_warns_unless_the_tones_were_swapped() {
        // Nearly the whole picture cut (a wide slot).
        let geom = slots(&[95]);
        let (_, r) = mask_files(&geom, &MaskConfig::default(), None).unwrap();
        assert!(r.clear_pct < 50.0 && r.warning.is_none(), "{r:?}");
        let g = BitGrid::from_fn(200, 200, |x, y| {
            !((10..190).contains(&x) && (10..190).contains(&y))
        });
        let (geom, _) = vectorize(&g, &[], &VectorConfig::default()).unwrap();
        let (_, r) = mask_files(&geom, &MaskConfig::default(), None).unwrap();
        assert!(r.clear_pct > 75.0 && r.warning.is_some(), "{r:?}");
        let swapped = MaskConfig {
            tone_inverted: true,
            ..Default::default()
        };
        assert!(mask_files(&geom, &swapped, None)
            .unwrap()
            .1
            .warning
            .is_none());
    }
}
