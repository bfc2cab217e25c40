//! Layers: a picture posterised into tones, one stencil per tone, sprayed light to dark and
//! registered by marks cut at the same sheet coordinates in every layer; and the paper's fill-in
//! layer, which paints what the first stencil's bridges hide.
//!
//! ## Tones
//! `N` layers paint `N` tones over the surface, which is the picture's lightest tone (so the
//! picture is posterised into `N + 1` tones, and the one-layer `make` is the case `N = 1`: white
//! paper and one paint). Layer `k` (1 = lightest paint) cuts every part of the picture at its
//! tone or darker, so layers are cumulative: a later, darker layer paints over part of what an
//! earlier one painted, and a small misregistration leaves no unpainted gap.
//! - A gray picture, or any picture with `levels` given: multi-level thresholds on its luma
//!   ([`multi_otsu`] without levels). Layer `k` cuts where the gray is below its level, exactly
//!   as a one-layer `--threshold` does.
//! - A colour picture: k-means with `N + 1` clusters in CIELAB, where distances follow what a
//!   person sees as different (`kmeans`: its cluster's L* becomes each pixel's gray, and the
//!   levels sit between the clusters', so each layer cuts the clusters at its tone or darker).
//!
//! Each layer is then one ordinary stencil through `make`'s stages (clean-up for the material,
//! islands, bridges, trace, check, repair): one 4-connected sheet, bridged, width-checked.
//!
//! ## Hidden bridges
//! Layers are made darkest first. A layer's bridge over a pixel that a later (darker) layer cuts
//! is painted over by that layer: it is hidden. The bridge cost's intensity term is
//! `w0 · (1 − gray)²` per pixel (`bridge::cost`), read from the two-tone's gray and nothing else;
//! so a layer is bridged on a *cost gray* in which a covered pixel keeps only [`COVERED_COST`] of
//! its intensity cost, and its real gray is put back afterwards (the report and the preview read
//! the picture). The report says, per layer, how many of its bridge pixels (cut in its two-tone,
//! material in its stencil) a later layer paints over.
//!
//! ## Registration
//! Every sheet of a set grows by a band of material around the picture ([`Marks`]) holding four
//! corner crosses and two pin holes, cut into every layer's raster before the clean-up, so every
//! output drawn from it (PNG, SVG, DXF, mask, G-code) carries them at the same sheet coordinates.

use std::path::Path;
use std::sync::Arc;

use serde::Serialize;

use crate::driver::{self, Edit, Start, Tweaks};
use crate::export::{self, png};
use crate::pipeline::{self, files, source, Error, Made, MakeConfig, Source, StageParams};
use crate::raster::{edge_neighbours, BitGrid, Gray, TwoTone};
use crate::report::share_pct as pct;
use crate::tone::likeness::ssim;
use crate::tone::Threshold;
use crate::units::Size;

mod config;
mod kmeans;
mod lab;
mod posterise;

use lab::dist2;

pub use crate::error::LayersError;
pub use crate::limits::MAX_LAYERS;
pub use config::LayersConfig;
pub use kmeans::{KMEANS_ROUNDS, KMEANS_SAMPLES};
pub use lab::{lab, srgb};
pub use posterise::{multi_otsu, posterise, Method, Tones};

/// Share of the intensity cost a bridge pixel keeps where a later layer paints over it: a
/// covered pixel is twenty times cheaper to bridge than the same pixel left visible.
pub const COVERED_COST: f32 = 0.05;

/// The fill-in's cut reaches this far (mm) past each hidden bridge pixel, inside what the first
/// stencil paints anyway, so that a small misregistration of the two sheets leaves no gap.
pub const FILL_IN_OVERLAP_MM: f64 = 0.3;

/// The picture's colours (sRGB 0..1, alpha over white) as shown, or `None` when it has none worth
/// clustering (gray, or colour in fewer than 2 % of its pixels). The picture was already read and
/// checked by `tone::load_gray` (size, memory, truncation), which gave `luma`; this decodes it
/// again in colour, under the same memory cap, and turns it by its EXIF orientation the same way.
fn load_colours(path: &Path, luma: &Gray) -> Result<Option<Vec<[f32; 3]>>, LayersError> {
    let err = |msg: String| LayersError::Colour {
        path: path.to_path_buf(),
        msg,
    };
    use image::ImageDecoder;
    let mut reader = image::ImageReader::open(path)
        .map_err(|e| err(e.to_string()))?
        .with_guessed_format()
        .map_err(|e| err(e.to_string()))?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(crate::limits::MAX_DECODE_BYTES);
    reader.limits(limits);
    let mut decoder = reader.into_decoder().map_err(|e| err(e.to_string()))?;
    let orientation = decoder
        .orientation()
        .unwrap_or(image::metadata::Orientation::NoTransforms);
    let mut img = image::DynamicImage::from_decoder(decoder).map_err(|e| err(e.to_string()))?;
    img.apply_orientation(orientation);
    if !img.color().has_color() {
        return Ok(None);
    }
    let rgba = img.to_rgba8();
    if rgba.width() != luma.width || rgba.height() != luma.height {
        return Err(err(format!(
            "decoded as {}x{} pixels, read as {}x{} (did the file change?)",
            rgba.width(),
            rgba.height(),
            luma.width,
            luma.height
        )));
    }
    let rgb: Vec<[f32; 3]> = rgba
        .pixels()
        .map(|p| {
            let a = p[3] as f32 / 255.0;
            [0, 1, 2].map(|i| (p[i] as f32 / 255.0) * a + (1.0 - a))
        })
        .collect();
    let coloured = rgb
        .iter()
        .filter(|c| {
            let (lo, hi) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
            hi - lo > 0.06
        })
        .count();
    Ok((coloured * 50 > rgb.len()).then_some(rgb))
}

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

/// One layer's report.
#[derive(Clone, Debug, Serialize)]
pub struct LayerReport {
    /// 1 = the first sprayed (lightest paint).
    pub layer: u32,
    /// Its folder's name.
    pub folder: String,
    /// Cuts where the gray is below this 8-bit level.
    pub level: u8,
    /// Its paint colour, `#rrggbb`.
    pub color: String,
    /// Share of the picture painted last by this layer in the posterised picture, %.
    pub tone_pct: f64,
    /// Share of the picture this layer's stencil cuts, %.
    pub cut_pct: f64,
    /// Islands before bridging.
    pub islands: usize,
    /// Bridges made.
    pub bridges: usize,
    /// Pixels (working) the bridges and the clean-up after them keep out of the paint: cut in
    /// the layer's two-tone, material in its stencil.
    pub bridge_px: usize,
    /// Of those, the pixels a later layer paints over.
    pub hidden_px: usize,
    /// `hidden_px` as a share of `bridge_px`, %.
    pub hidden_pct: f64,
    /// Whether its stencil passed the check.
    pub check_passed: bool,
}

/// How close the painted set comes to the picture.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Composite {
    /// Working pixels whose painted tone is the posterised picture's, %.
    pub tone_agreement_pct: f64,
    /// Mean colour difference (CIE76 ΔE) between the composite and the posterised picture.
    pub mean_delta_e: f64,
    /// Likeness of the composite's lightness to the picture's (see `tone::likeness::ssim`),
    /// 0..1.
    pub likeness: f64,
    /// The same for the posterised picture itself: the most the set can reach.
    pub posterised_likeness: f64,
}

/// The fill-in's report.
#[derive(Clone, Debug, Serialize)]
pub struct FillInReport {
    /// Its folder's name.
    pub folder: String,
    /// The first stencil's bridge pixels (cut in its two-tone, material in its stencil).
    pub bridge_px: usize,
    /// Of those, the pixels the fill-in cuts (paints).
    pub covered_px: usize,
    /// `covered_px` as a share of `bridge_px`, %.
    pub covered_pct: f64,
    /// Pixels the fill-in paints that the first stencil's two-tone keeps unpainted: the specks
    /// it paints over rather than bridging them again, and its clean-up.
    pub overpainted_px: usize,
    /// Whether its stencil passed the check.
    pub check_passed: bool,
}

/// A set's report.json (a layered folder's; `layers.json` beside a one-layer set's stencil).
#[derive(Clone, Debug, Serialize)]
pub struct SetReport {
    /// The input picture's path.
    pub input: String,
    /// How the picture was posterised.
    pub method: Method,
    /// Layers, in painting order.
    pub layers: Vec<LayerReport>,
    /// The surface's colour (the lightest tone).
    pub surface_color: String,
    /// The folders in the order to spray them.
    pub painting_order: Vec<String>,
    /// How close the painted set comes to the picture.
    pub composite: Composite,
    /// Working pixels a darker layer's two-tone cuts but a lighter one's does not (the clean-up
    /// of each layer for the material can break the cumulative order at the edges).
    pub nesting_breaks_px: usize,
    /// The registration marks.
    pub marks: Marks,
    /// Working pixels per input pixel, and mm per working pixel (the same for every layer).
    pub scale_factor: u32,
    /// Millimetres per working pixel.
    pub mm_per_px: f64,
    /// The fill-in's report, when one was made.
    pub fill_in: Option<FillInReport>,
    /// The files written.
    pub files: Vec<String>,
}

/// What a layered run made, before anything is written.
pub struct Layered {
    /// Per layer, light to dark.
    pub layers: Vec<Made>,
    /// The fill-in stencil, when one was made.
    pub fill_in: Option<Made>,
    /// The posterised picture.
    pub tones: Tones,
    /// The composite (picture size), RGB.
    pub composite: Vec<u8>,
    /// The set's report.
    pub report: SetReport,
}

fn hex(c: [u8; 3]) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// The folder of layer `k` (1-based) of `n`: a one-layer set's stencil is the folder itself.
pub fn layer_folder(k: usize, n: usize) -> String {
    if n == 1 {
        String::new()
    } else {
        format!("layer-{k}")
    }
}

pub use crate::export::{owned_names, FOLDERS};

/// The stencil folders of a `make` output folder, in painting order: `layer-1/` … when it is a
/// layered set, else the folder itself; then `fill-in/` when there is one.
pub fn stencil_folders(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut v: Vec<std::path::PathBuf> = FOLDERS[..MAX_LAYERS as usize]
        .iter()
        .map(|f| dir.join(f))
        .filter(|p| p.join("report.json").is_file())
        .collect();
    if v.is_empty() {
        v.push(dir.to_path_buf());
    }
    let fill = dir.join("fill-in");
    if fill.join("report.json").is_file() {
        v.push(fill);
    }
    v
}

/// Everything a layer's stages need that is the same for every layer.
struct Frame {
    source_gray: Arc<Gray>,
    marks: Marks,
    cfg: MakeConfig,
}

/// One layer through `make`'s stages at `level` (the driver's list, from the set's gray), its
/// registration marks stamped into its two-tone, its bridges on a cost gray where `covered` (cut
/// by a later layer) is cheap, its cut forced to include `darker`'s cleaned cut, every island
/// bridged and none dropped: the layers' nesting (what a darker layer cuts, a lighter one cuts
/// too) is taken from the cleaned cut before the join, so an island a layer dropped would be cut
/// there but painted by the lighter layers. Returns the result and the layer's two-tone after
/// the clean-up (what its bridges were drawn into).
fn one_layer(
    f: &Frame,
    level: u8,
    covered: Option<&BitGrid>,
    darker: Option<&BitGrid>,
) -> Result<(Made, BitGrid), Error> {
    let mut cfg = f.cfg.clone();
    cfg.tone.threshold = Threshold::Level(level);
    let stamp = |raw: &mut TwoTone, p: &StageParams| {
        let band = f.marks.band_px * p.working.factor;
        f.marks
            .stamp(&mut raw.bits, band, p.working.scale.mm_per_px);
    };
    let cost = |gray: &Gray| match covered {
        Some(c) => cost_gray(gray, c),
        None => gray.clone(),
    };
    let also = |tt: &mut TwoTone, _: &StageParams| {
        if let Some(d) = darker {
            for (b, &m) in tt.bits.data.iter_mut().zip(&d.data) {
                *b &= m;
            }
        }
    };
    let tweaks = Tweaks {
        after_threshold: Some(&stamp),
        after_clean: darker.is_some().then_some(&also as &Edit<'_, TwoTone, ()>),
        cost_gray: covered
            .is_some()
            .then_some(&cost as &(dyn Fn(&Gray) -> Gray + Sync)),
        keep_all_islands: true,
        two_tone: None,
    };
    let start = Start::Source(Source::Picture(f.source_gray.clone()));
    driver::made_once(&cfg, &start, &tweaks)
}

/// The gray the bridge cost reads for a layer: where a later layer paints (`covered` is cut),
/// the intensity cost `(1 − gray)²` is scaled by [`COVERED_COST`].
fn cost_gray(gray: &Gray, covered: &BitGrid) -> Gray {
    let k = COVERED_COST.sqrt();
    let data = gray.data.iter().zip(&covered.data);
    let data = data.map(|(&g, &material)| if material { g } else { 1.0 - (1.0 - g) * k });
    Gray::from_data(gray.width, gray.height, data.collect())
}

/// `make` for a set (`lc.count` layers, or one layer with registration marks and perhaps a
/// fill-in), in memory.
pub fn run(cfg: &MakeConfig, lc: &LayersConfig) -> Result<Layered, Error> {
    if source::is_mesh_path(&cfg.input) {
        return Err(LayersError::Mesh.into());
    }
    if cfg.tone.invert {
        return Err(LayersError::Invert.into());
    }
    if cfg.keep_out.is_some() {
        return Err(LayersError::KeepOut.into());
    }
    let sp = pipeline::SourceParams::of(cfg)?;
    let source::Input::Picture(luma) = source::load(&cfg.input, &sp)? else {
        return Err(LayersError::Mesh.into());
    };
    let rgb = if lc.levels.is_empty() {
        load_colours(&cfg.input, &luma)?
    } else {
        None
    };
    let tones = posterise(&luma, rgb.as_deref(), lc)?;
    drop(rgb);
    let (w, h) = (luma.width, luma.height);
    let scale = cfg.physical.scale(w, h)?;
    let marks = Marks::new(w, h, scale.mm_per_px, cfg.physical.material.min_feature_mm);
    // The layers' gray, grown by the band (white: material).
    let b = marks.band_px;
    let (pw, ph) = (w + 2 * b, h + 2 * b);
    let mut padded = Gray::new(pw, ph, 1.0);
    for y in 0..h {
        let src = &tones.gray.data[(y * w) as usize..((y + 1) * w) as usize];
        let at = ((y + b) * pw + b) as usize;
        padded.data[at..at + w as usize].copy_from_slice(src);
    }
    let mut lcfg = cfg.clone();
    lcfg.physical.size = Size::Dpi(25.4 / scale.mm_per_px);
    // The registration marks are cut in every layer; the mask's own corner marks would be a
    // second set.
    lcfg.physical.mask.marks = false;
    let u = &mut lcfg.places;
    for p in &mut u.at_mm {
        p[0] += marks.band_mm;
        p[1] += marks.band_mm;
    }
    for p in &mut u.no_bridge_near_mm {
        p[0] += marks.band_mm;
        p[1] += marks.band_mm;
    }
    let frame = Frame {
        source_gray: Arc::new(padded),
        marks,
        cfg: lcfg,
    };
    let n = tones.levels.len();
    // Darkest first: each layer's bridges see the stencils painted after it.
    let mut made: Vec<Option<(Made, BitGrid)>> = (0..n).map(|_| None).collect();
    for k in (0..n).rev() {
        let later = made.get(k + 1).and_then(|m| m.as_ref());
        let covered = later.map(|(m, _)| &m.bridged.bits);
        let darker = later.map(|(_, cut)| cut);
        made[k] = Some(one_layer(&frame, tones.levels[k], covered, darker)?);
    }
    let made: Vec<(Made, BitGrid)> = made.into_iter().map(|m| m.expect("made")).collect();
    let fill_in = if lc.fill_in && n == 1 {
        Some(fill_in(&frame, &made[0])?)
    } else {
        None
    };
    let (report, composite) = assess(cfg, &frame, &tones, &made, fill_in.as_ref());
    Ok(Layered {
        layers: made.into_iter().map(|(m, _)| m).collect(),
        fill_in: fill_in.map(|(m, _)| m),
        tones,
        composite,
        report,
    })
}

/// The fill-in stencil of a one-layer set: it cuts the first stencil's bridge pixels (cut in its
/// two-tone, material in its stencil), grown by [`FILL_IN_OVERLAP_MM`] into what the first one
/// paints, marks and band as every sheet of the set; then the same clean-up, bridges, trace and
/// check as any stencil. Returns it with the bridge pixels it was made for.
fn fill_in(f: &Frame, first: &(Made, BitGrid)) -> Result<(Made, BitGrid), Error> {
    let (m, cut) = first;
    let stencil = &m.bridged.bits;
    let (w, h) = (stencil.width, stencil.height);
    let mut hidden = stencil.clone();
    for (s, &c) in hidden.data.iter_mut().zip(&cut.data) {
        *s &= !c;
    }
    let mut cfg = f.cfg.clone();
    cfg.tone.threshold = Threshold::Level(128);
    let draw = |_: &mut (), p: &StageParams| -> TwoTone {
        let mm = p.working.scale.mm_per_px;
        // Grown into the first stencil's cut, 4-neighbour steps.
        let mut grown = hidden.clone();
        let reach = FILL_IN_OVERLAP_MM.max(f.cfg.physical.material.min_feature_mm);
        for _ in 0..(reach / mm).round() as u32 {
            let prev = grown.clone();
            for (i, g) in grown.data.iter_mut().enumerate() {
                let near = edge_neighbours(i, w as usize, h as usize);
                *g |= !cut.data[i] && near.into_iter().flatten().any(|j| prev.data[j]);
            }
        }
        let mut bits = grown;
        bits.data.iter_mut().for_each(|b| *b = !*b);
        f.marks
            .stamp(&mut bits, f.marks.band_px * p.working.factor, mm);
        let gray = bits
            .data
            .iter()
            .map(|&b| if b { 1.0 } else { 0.0 })
            .collect();
        let gray = Gray::from_data(w, h, gray);
        TwoTone {
            bits,
            gray: Arc::new(gray),
        }
    };
    // A speck of material its cut rings round (a small island the first stencil bridged) is
    // painted rather than bridged again when it is smaller than the least a bridge of the
    // narrowest width would hide (its width squared): the smaller change to the picture.
    let specks = |twotone: &mut TwoTone, p: &StageParams| {
        let map = crate::islands::label(&twotone.bits);
        let floor = (p.join.bridge.min_width_px as usize).pow(2);
        for (i, &l) in map.labels.iter().enumerate() {
            if l != crate::islands::CUT
                && l != crate::islands::FRAME
                && map.nodes[l as usize].area < floor
            {
                twotone.bits.data[i] = false;
            }
        }
    };
    // Its own bridges (where its cut rings round material) are cheap where the first stencil
    // paints anyway: on the overlap, not on the pixels it exists to paint.
    let mut painted = hidden.clone();
    for (p, &c) in painted.data.iter_mut().zip(&cut.data) {
        *p |= c;
    }
    let cost = |gray: &Gray| cost_gray(gray, &painted);
    let tweaks = Tweaks {
        two_tone: Some(&draw),
        after_threshold: None,
        after_clean: Some(&specks),
        cost_gray: Some(&cost),
        keep_all_islands: true,
    };
    let start = Start::Source(Source::Picture(f.source_gray.clone()));
    let (made, _) = driver::made_once(&cfg, &start, &tweaks)?;
    Ok((made, hidden))
}

/// The report and the composite: hidden bridging per layer, the fill-in's cover, the painted
/// result in the layers' colours at the picture's own size, and its fidelity.
fn assess(
    cfg: &MakeConfig,
    f: &Frame,
    tones: &Tones,
    made: &[(Made, BitGrid)],
    fill_in: Option<&(Made, BitGrid)>,
) -> (SetReport, Vec<u8>) {
    let n = made.len();
    let first = &made[0].0;
    let (ww, wh) = (first.bridged.bits.width, first.bridged.bits.height);
    let factor = first.report.scale_factor.unwrap_or(1);
    let band = f.marks.band_px * factor;
    let in_picture = |i: usize| {
        let (x, y) = ((i as u32) % ww, (i as u32) / ww);
        x >= band && y >= band && x < ww - band && y < wh - band
    };
    let len = (ww * wh) as usize;
    // The tone each working pixel ends up painted with: the last layer (or the fill-in) that
    // cuts it.
    let mut painted = vec![0u8; len];
    let mut posterised = vec![0u8; len];
    for (k, (m, _)) in made.iter().enumerate() {
        for i in 0..len {
            if !m.bridged.bits.data[i] {
                painted[i] = k as u8 + 1;
            }
            if !m.picture.data[i] {
                posterised[i] = posterised[i].max(k as u8 + 1);
            }
        }
    }
    let mut fill_report = None;
    if let Some((fm, hidden)) = fill_in {
        let bridge_px = hidden.data.iter().filter(|&&b| b).count();
        let (mut covered, mut over) = (0, 0);
        let first_cut = &made[0].1;
        for (i, p) in painted.iter_mut().enumerate() {
            if !fm.bridged.bits.data[i] && in_picture(i) {
                *p = 1;
                if hidden.data[i] {
                    covered += 1;
                }
                if first_cut.data[i] {
                    over += 1;
                }
            }
        }
        fill_report = Some(FillInReport {
            folder: "fill-in".into(),
            bridge_px,
            covered_px: covered,
            covered_pct: pct(covered, bridge_px),
            overpainted_px: over,
            check_passed: fm.check.passed(),
        });
    }
    let pixels = (0..len).filter(|&i| in_picture(i)).count();
    let mut layers = Vec::with_capacity(n);
    let mut nesting_breaks = 0;
    for (k, (m, cut)) in made.iter().enumerate() {
        let (mut bridge_px, mut hidden_px) = (0, 0);
        for i in 0..len {
            if !cut.data[i] && m.bridged.bits.data[i] {
                bridge_px += 1;
                // Painted over by a later layer: some layer after k cuts it.
                if made[k + 1..].iter().any(|(l, _)| !l.bridged.bits.data[i]) {
                    hidden_px += 1;
                }
            }
        }
        if k + 1 < n {
            let darker = &made[k + 1].1;
            nesting_breaks += (0..len).filter(|&i| !darker.data[i] && cut.data[i]).count();
        }
        let tone_px = (0..len)
            .filter(|&i| in_picture(i) && posterised[i] as usize == k + 1)
            .count();
        let cut_px = (0..len)
            .filter(|&i| in_picture(i) && !m.bridged.bits.data[i])
            .count();
        layers.push(LayerReport {
            layer: k as u32 + 1,
            folder: layer_folder(k + 1, n),
            level: tones.levels[k],
            color: hex(tones.colors[k + 1]),
            tone_pct: pct(tone_px, pixels),
            cut_pct: pct(cut_px, pixels),
            islands: m.report.islands,
            bridges: m.bridged.bridges.len(),
            bridge_px,
            hidden_px,
            hidden_pct: pct(hidden_px, bridge_px),
            check_passed: m.check.passed(),
        });
    }
    let agree = (0..len)
        .filter(|&i| in_picture(i) && painted[i] == posterised[i])
        .count();
    // The composite at the picture's own size: each input pixel takes its centre working pixel.
    let (w, h) = (tones.luma.width, tones.luma.height);
    let mut rgb = Vec::with_capacity((w * h * 3) as usize);
    let mut comp_l = Vec::with_capacity((w * h) as usize);
    let mut post_l = Vec::with_capacity((w * h) as usize);
    let mut de = 0.0;
    let labs: Vec<[f32; 3]> = tones
        .colors
        .iter()
        .map(|c| lab(c.map(|v| v as f32 / 255.0)))
        .collect();
    for y in 0..h {
        for x in 0..w {
            let (wx, wy) = (
                (x + f.marks.band_px) * factor + factor / 2,
                (y + f.marks.band_px) * factor + factor / 2,
            );
            let t = painted[(wy * ww + wx) as usize] as usize;
            let p = tones.tone_of(tones.gray.get(x, y));
            rgb.extend_from_slice(&tones.colors[t]);
            comp_l.push(labs[t][0] / 100.0);
            post_l.push(labs[p][0] / 100.0);
            de += dist2(labs[t], labs[p]).sqrt() as f64;
        }
    }
    let luma_l: Vec<f32> = tones
        .luma
        .data
        .iter()
        .map(|&v| lab([v, v, v])[0] / 100.0)
        .collect();
    let composite = Composite {
        tone_agreement_pct: pct(agree, pixels),
        mean_delta_e: de / (w * h) as f64,
        likeness: ssim(&comp_l, &luma_l, w, h),
        posterised_likeness: ssim(&post_l, &luma_l, w, h),
    };
    let mut order: Vec<String> = layers.iter().map(|l| l.folder.clone()).collect();
    if n == 1 {
        order = vec![".".into()];
    }
    if fill_report.is_some() {
        order.push("fill-in".into());
    }
    let report = SetReport {
        input: cfg.input.display().to_string(),
        method: tones.method,
        layers,
        surface_color: hex(tones.colors[0]),
        painting_order: order,
        composite,
        nesting_breaks_px: nesting_breaks,
        marks: f.marks.clone(),
        scale_factor: factor,
        mm_per_px: first.scale.mm_per_px,
        fill_in: fill_report,
        files: Vec::new(),
    };
    (report, rgb)
}

/// The files of a set, by name (folders included), encoded in memory: each stencil's files as
/// `make` writes them (the layers in `layer-k/`, a one-layer set's in the folder itself, the
/// fill-in's in `fill-in/`), `composite.png`, and the set's report (`report.json` of a layered
/// folder, `layers.json` beside a one-layer set's own report.json).
pub fn encode(set: &mut Layered, cfg: &MakeConfig) -> Result<Vec<(String, Vec<u8>)>, Error> {
    let mut phys = cfg.physical.clone();
    phys.mask.marks = false;
    let n = set.layers.len();
    let mut files = Vec::new();
    let mut put = |folder: &str, made: &mut Made| -> Result<(), Error> {
        for (name, bytes) in files::encode_outputs(made, &phys)? {
            let name = if folder.is_empty() {
                name
            } else {
                format!("{folder}/{name}")
            };
            files.push((name, bytes));
        }
        Ok(())
    };
    for (k, m) in set.layers.iter_mut().enumerate() {
        put(&layer_folder(k + 1, n), m)?;
    }
    if let Some(m) = &mut set.fill_in {
        put("fill-in", m)?;
    }
    let (w, h) = (set.tones.luma.width, set.tones.luma.height);
    files.push((
        "composite.png".into(),
        png::encode_rgb(w, h, &set.composite),
    ));
    let name = if n == 1 { "layers.json" } else { "report.json" };
    let mut report = set.report.clone();
    report.files = files.iter().map(|(n, _)| n.clone()).collect();
    report.files.push(name.into());
    let json = serde_json::to_vec_pretty(&report).map_err(|e| export::ExportError::Encode {
        path: std::path::PathBuf::from(name),
        msg: e.to_string(),
    })?;
    files.push((name.into(), json));
    set.report = report;
    Ok(files)
}

/// `stencil make` for a set: run every layer and write the whole set into `cfg.out_dir` as one
/// transaction (see `stencil_io::swap`): every owned name the set does not write goes, so a
/// set of fewer layers leaves none of a larger one's folders behind.
pub fn make(cfg: &MakeConfig, lc: &LayersConfig) -> Result<(Layered, export::Replaced), Error> {
    files::write_with(cfg, || run(cfg, lc), |set| encode(set, cfg))
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
