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
//! ## Sheets a person can handle
//! A sheet of a set (of two layers or more) is lifted, laid, sprayed and cleaned: what it costs
//! counts beside the picture. So each layer chooses, island by island, whether to bridge it or to
//! drop it (cut it, so this layer paints it) with the sheet's costs added to the bridge's:
//! [`SHEET_BRIDGE_MM2`] for the bridge itself, [`SHEET_CUT_MM2_PER_MM`] per millimetre of the
//! island's outline, and another bridge's worth when its bridge would end on another island rather
//! than on the main sheet (`bridge::drop`'s sheet choice). A bridge a later layer paints over is
//! cheap for the picture ([`COVERED_COST`]) but costs the sheet the same. Then the bridges' chains
//! are measured (`bridge::tree`: island `a` hangs on island `b` when every way from `a` to the
//! main sheet along the bridges passes `b`; a chain is a run of islands each hanging directly on
//! the next, its length the number of islands): where one is longer than [`MAX_CHAIN`], the
//! smallest island of its links is dropped too and the layer made again (at most
//! [`CHAIN_ROUNDS`] times, then every island deeper than the limit goes). The report gives each
//! layer's longest chain and the islands it dropped.
//!
//! ## Registration
//! Every sheet of a set grows by a band of material around the picture ([`Marks`]) holding four
//! corner crosses and two pin holes, cut into every layer's raster before the clean-up, so every
//! output drawn from it (PNG, SVG, DXF, mask, G-code) carries them at the same sheet coordinates.

use std::path::Path;
use std::sync::Arc;

use serde::Serialize;

use crate::bridge::drop::{choose_for_sheet, Dropped, SheetCost};
use crate::bridge::grow;
use crate::bridge::tree::Chains;
use crate::driver::{self, Edit, Start, Tweaks};
use crate::export::{self, png};
use crate::islands;
use crate::pipeline::{self, files, source, Error, Made, MakeConfig, Source, StageParams};
use crate::raster::{edge_neighbours, BitGrid, Gray, TwoTone};
use crate::report::share_pct as pct;
use crate::tone::likeness::ssim;
use crate::tone::Threshold;
use crate::units::Size;

mod config;
mod kmeans;
mod lab;
mod marks;
mod posterise;

use lab::dist2;

pub use crate::error::LayersError;
pub use crate::limits::MAX_LAYERS;
pub use config::LayersConfig;
pub use kmeans::{KMEANS_ROUNDS, KMEANS_SAMPLES};
pub use lab::{lab, srgb};
pub use marks::{grown_bits, grown_gray, mark_sizes, Marks};
pub use posterise::{
    multi_otsu, posterise, worth_a_sheet, Method, Tones, MIN_STEP_DELTA_E, MIN_STEP_L, MIN_TONE_PCT,
};

/// Share of the intensity cost a bridge pixel keeps where a later layer paints over it: a
/// covered pixel is twenty times cheaper to bridge than the same pixel left visible.
pub const COVERED_COST: f32 = 0.05;

/// What a bridge costs a layered set's sheet, as a change to the picture: as much as this many
/// mm² of picture each changed at full price (the drop's `0.1 + |gray − threshold|` per pixel;
/// between two neighbouring tones of a photo it is about 0.17, so this is a third of a mm² of
/// speck). A 1.2 mm bridge 5 mm long that a later layer paints over costs the picture about as
/// much again, and the sheet this: the sheet's cost counts where the picture's does not. (On the
/// cat of issue 42, a tenth of a mm² lost more likeness than it saved bridges; this, with
/// [`SHEET_CUT_MM2_PER_MM`], holds its lightest sheet with 20 bridges instead of 120.)
pub const SHEET_BRIDGE_MM2: f64 = 0.05;

/// What a millimetre of cut around an island costs a layered set's sheet, in the same mm² of
/// picture: the cut a speck's outline adds (a 1 mm speck's 3 mm of outline cost about a bridge).
pub const SHEET_CUT_MM2_PER_MM: f64 = 0.02;

/// What a chain is, in a set's report.
pub const CHAIN: &str = "island a hangs on island b when every way from a to the main sheet \
along the bridges passes through b; a chain is a run of islands each hanging directly on the \
next, the last held by the main sheet without another island between; its length is the \
number of islands in it (an island bridged straight to the main sheet is a chain of one)";

/// The longest chain of islands (each hanging only on the next) a layered set's sheet keeps.
pub const MAX_CHAIN: u32 = 3;

/// How many times a layer is made again with the links of its too long chains dropped, before
/// every island deeper than [`MAX_CHAIN`] is.
pub const CHAIN_ROUNDS: usize = 4;

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
    /// Islands of its two-tone it cut (painted) rather than held, for the sheet's sake (see
    /// the module notes, "Sheets a person can handle"); in its own report's dropped islands.
    pub dropped_islands: usize,
    /// Its longest chain of islands, each hanging on the next (see [`SetReport::chain`]).
    pub longest_chain: u32,
    /// Times it was made again to shorten its chains.
    pub chain_rounds: usize,
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
    /// What a chain is, as [`LayerReport::longest_chain`] counts it.
    pub chain: &'static str,
    /// The longest chain a sheet keeps ([`MAX_CHAIN`]).
    pub max_chain: u32,
    /// Layers asked for, when the picture has fewer tones a sheet would show (see
    /// [`Tones::asked`]); absent when every layer asked for was cut.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub layers_asked: Option<u32>,
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

/// A colour as `#rrggbb`.
pub(crate) fn hex(c: [u8; 3]) -> String {
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
/// by a later layer) is cheap, its cut forced to include `darker`'s cleaned cut. The driver drops
/// no island: the layers' nesting (what a darker layer cuts, a lighter one cuts too) is taken from
/// the cleaned cut, so a layer's own drops are made in it, after the clean-up: with `sheet`, the
/// islands [`sheet_drops`] chooses and those under `forced` (pixels to cut: the links of chains an
/// earlier try made too long). Returns the result, the layer's two-tone after the clean-up (what
/// its bridges were drawn into) and the islands dropped for the sheet.
fn one_layer(
    f: &Frame,
    level: u8,
    covered: Option<&BitGrid>,
    darker: Option<&BitGrid>,
    sheet: Option<&[u32]>,
) -> Result<(Made, BitGrid, SheetDrops), Error> {
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
    let drops = std::sync::Mutex::new(SheetDrops::default());
    let also = |tt: &mut TwoTone, p: &StageParams| {
        if let Some(d) = darker {
            nest(&mut tt.bits, d);
        }
        if let Some(forced) = sheet {
            for &i in forced {
                tt.bits.data[i as usize] = false;
            }
            let found = sheet_drops(tt, level, covered, p);
            if let Ok(mut d) = drops.lock() {
                *d = found;
            }
        }
    };
    let tweaks = Tweaks {
        after_threshold: Some(&stamp),
        after_clean: (darker.is_some() || sheet.is_some())
            .then_some(&also as &Edit<'_, TwoTone, ()>),
        cost_gray: covered
            .is_some()
            .then_some(&cost as &(dyn Fn(&Gray) -> Gray + Sync)),
        keep_all_islands: true,
        two_tone: None,
        geometry: None,
    };
    let start = Start::Source(Source::Picture(f.source_gray.clone()));
    let (mut made, cut) = driver::made_once(&cfg, &start, &tweaks)?;
    let mut drops = drops.into_inner().unwrap_or_default();
    if let Some(forced) = sheet {
        // The forced pixels were islands of an earlier try: they count as dropped here too.
        drops.px.extend_from_slice(forced);
        drops.px.sort_unstable();
        drops.px.dedup();
    }
    if !drops.islands.is_empty() || !drops.px.is_empty() {
        made.dropped_px.extend_from_slice(&drops.px);
        made.dropped_px.sort_unstable();
        made.dropped_px.dedup();
        made.report
            .dropped_islands
            .get_or_insert_with(Vec::new)
            .extend(drops.islands.iter().cloned());
    }
    Ok((made, cut, drops))
}

/// The islands a layer dropped for its sheet: their descriptions (mm) and their pixels.
#[derive(Clone, Debug, Default)]
struct SheetDrops {
    islands: Vec<Dropped>,
    px: Vec<u32>,
}

/// The islands of a layer's cleaned two-tone that cost the sheet more than dropping them costs
/// the picture (`bridge::drop`'s sheet choice, see the module notes), cut. A dropped pixel's
/// price is the drop's (`0.1 + |gray − level|`, from the layer's own gray); a bridge pixel's the
/// same, times [`COVERED_COST`] where `covered` (a later layer's stencil) is cut.
fn sheet_drops(
    tt: &mut TwoTone,
    level: u8,
    covered: Option<&BitGrid>,
    p: &StageParams,
) -> SheetDrops {
    let map = islands::label(&tt.bits);
    if map.island_count() == 0 {
        return SheetDrops::default();
    }
    let mm = p.join.mm_per_px;
    let t = level as f32 / 255.0;
    let gray = &tt.gray;
    let drop_price = |i: usize| 0.1 + (gray.data[i] - t).abs() as f64;
    let bridge_price = |i: usize| {
        let hidden = covered.is_some_and(|c| !c.data[i]);
        drop_price(i) * if hidden { COVERED_COST as f64 } else { 1.0 }
    };
    let per_bridge = SHEET_BRIDGE_MM2 / (mm * mm);
    let sheet = SheetCost {
        per_bridge,
        per_border_px: SHEET_CUT_MM2_PER_MM / mm,
        per_hop: per_bridge,
    };
    let bc = &p.join.bridge;
    let width = |area: usize| grow::width_for(area, bc);
    let chosen = choose_for_sheet(&map, &drop_price, &bridge_price, sheet, &width);
    let mut out = SheetDrops::default();
    let w = map.width as usize;
    for (n, mut d) in chosen {
        for (y, x0, x1) in map.island_runs(n as usize) {
            let row = y as usize * w;
            tt.bits.data[row + x0 as usize..=row + x1 as usize].fill(false);
            out.px.extend(row as u32 + x0..=row as u32 + x1);
        }
        d.at_mm = [d.at_mm[0] * mm, d.at_mm[1] * mm];
        d.area_mm2 *= mm * mm;
        out.islands.push(d);
    }
    out.px.sort_unstable();
    out
}

/// A made layer's chains (see the module notes), from its bridges.
fn chains_of(m: &Made) -> Chains {
    Chains::of(
        m.report.islands + 1,
        m.bridged.bridges.iter().map(|b| b.nodes),
    )
}

/// The pixels of the islands to drop to shorten the chains of `m` longer than [`MAX_CHAIN`]: of
/// each such chain, its smallest island but the one the main sheet holds (a speck in the middle
/// of a lace, whose islands find another way when it goes), or, with `all`, every island deeper
/// than the limit.
fn chain_links(m: &Made, chains: &Chains, all: bool) -> (Vec<u32>, usize) {
    let map = islands::label(&m.twotone.bits);
    let nodes = map.nodes.len().min(chains.depth.len());
    let mut gone = vec![false; nodes];
    for v in (1..nodes).filter(|&v| chains.depth[v] > MAX_CHAIN) {
        if all {
            gone[v] = true;
            continue;
        }
        let chain = chains.chain(v as u32);
        let links = &chain[..chain.len().saturating_sub(1)];
        if let Some(&s) = links.iter().min_by_key(|&&i| map.nodes[i as usize].area) {
            gone[s as usize] = true;
        }
    }
    let w = map.width;
    let mut px = Vec::new();
    for n in (1..nodes).filter(|&n| gone[n]) {
        for (y, x0, x1) in map.island_runs(n) {
            px.extend(y * w + x0..=y * w + x1);
        }
    }
    (px, gone.iter().filter(|&&g| g).count())
}

/// One layer made for a set of `n` layers: with two or more, for its sheet (see the module notes):
/// made again with the links of chains longer than [`MAX_CHAIN`] dropped, at most
/// [`CHAIN_ROUNDS`] times and then once with every island deeper than it dropped. Returns the
/// layer and its cleaned cut (as [`one_layer`]) and what its report says of its sheet.
fn sheet_layer(
    f: &Frame,
    level: u8,
    covered: Option<&BitGrid>,
    darker: Option<&BitGrid>,
    n: usize,
) -> Result<(Made, BitGrid, SheetSummary), Error> {
    if n < 2 {
        let (m, cut, _) = one_layer(f, level, covered, darker, None)?;
        let summary = SheetSummary {
            longest_chain: chains_of(&m).longest(),
            ..Default::default()
        };
        return Ok((m, cut, summary));
    }
    let (mut forced, mut links) = (Vec::new(), 0);
    let mut rounds = 0;
    loop {
        let (m, cut, d) = one_layer(f, level, covered, darker, Some(&forced))?;
        let chains = chains_of(&m);
        if chains.longest() <= MAX_CHAIN || rounds > CHAIN_ROUNDS {
            let summary = SheetSummary {
                dropped: d.islands.len() + links,
                longest_chain: chains.longest(),
                rounds,
            };
            return Ok((m, cut, summary));
        }
        rounds += 1;
        let (px, count) = chain_links(&m, &chains, rounds > CHAIN_ROUNDS);
        forced.extend(px);
        forced.sort_unstable();
        forced.dedup();
        links += count;
    }
}

/// What a layer's report says of its sheet.
#[derive(Clone, Copy, Debug, Default)]
struct SheetSummary {
    /// Islands dropped for the sheet: by the sheet's choice and as links of long chains.
    dropped: usize,
    longest_chain: u32,
    /// Times the layer was made again.
    rounds: usize,
}

/// The gray the bridge cost reads for a layer: where a later layer paints (`covered` is cut),
/// the intensity cost `(1 − gray)²` is scaled by [`COVERED_COST`].
fn cost_gray(gray: &Gray, covered: &BitGrid) -> Gray {
    let k = COVERED_COST.sqrt();
    let data = gray.data.iter().zip(&covered.data);
    let data = data.map(|(&g, &material)| if material { g } else { 1.0 - (1.0 - g) * k });
    Gray::from_data(gray.width, gray.height, data.collect())
}

/// A set's tones: the picture read (a mesh or an inverted picture refused), its colours
/// clustered when it has any and no levels were given, posterised (see the module notes). Every
/// set's, tiled or not, so a tiled set's layers are the untiled set's.
pub(crate) fn tones_of(cfg: &MakeConfig, lc: &LayersConfig) -> Result<Tones, Error> {
    if source::is_mesh_path(&cfg.input) {
        return Err(LayersError::Mesh.into());
    }
    if cfg.tone.invert {
        return Err(LayersError::Invert.into());
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
    // The picture adjusted as any stencil's (crop, turns, tones: the layers start from it, past
    // the stage that adjusts), its colours cropped and turned with it.
    let pic = source::Input::Picture(luma.clone());
    let Source::Picture(adjusted) = source::light(&pic, None, &sp)? else {
        return Err(LayersError::Mesh.into());
    };
    let rgb = match (&sp, rgb) {
        (pipeline::SourceParams::Picture { adjust, .. }, Some(rgb)) => {
            let shape = crate::tone::Adjust {
                crop_px: adjust.crop_px,
                quarter_turns: adjust.quarter_turns,
                ..Default::default()
            };
            if shape.is_identity() {
                Some(rgb)
            } else {
                let channel = |k: usize| {
                    let g = Gray::from_data(
                        luma.width,
                        luma.height,
                        rgb.iter().map(|c| c[k]).collect(),
                    );
                    shape.apply(&g)
                };
                let [r, g, b] = [0, 1, 2].map(channel);
                Some(
                    (0..r.data.len())
                        .map(|i| [r.data[i], g.data[i], b.data[i]])
                        .collect(),
                )
            }
        }
        (_, rgb) => rgb,
    };
    Ok(posterise(&adjusted, rgb.as_deref(), lc)?)
}

/// The layers' nesting: what a darker layer cuts, a lighter one cuts too (`bits` keeps material
/// only where `darker`, the darker layer's cleaned two-tone, has it), so a small
/// misregistration leaves no unpainted gap between tones.
pub(crate) fn nest(bits: &mut BitGrid, darker: &BitGrid) {
    for (b, &m) in bits.data.iter_mut().zip(&darker.data) {
        *b &= m;
    }
}

/// `make` for a set (`lc.count` layers, or one layer with registration marks and perhaps a
/// fill-in), in memory.
pub fn run(cfg: &MakeConfig, lc: &LayersConfig) -> Result<Layered, Error> {
    if cfg.keep_out.is_some() {
        return Err(LayersError::KeepOut.into());
    }
    let tones = tones_of(cfg, lc)?;
    let (w, h) = (tones.luma.width, tones.luma.height);
    let scale = cfg.physical.scale(w, h)?;
    let marks = Marks::new(w, h, scale.mm_per_px, cfg.physical.material.min_feature_mm);
    // The layers' gray, grown by the band (white: material).
    let padded = grown_gray(&tones.gray, marks.band_px);
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
    let mut sheets = vec![SheetSummary::default(); n];
    for k in (0..n).rev() {
        let later = made.get(k + 1).and_then(|m| m.as_ref());
        let covered = later.map(|(m, _)| &m.bridged.bits);
        let darker = later.map(|(_, cut)| cut);
        let (m, cut, summary) = sheet_layer(&frame, tones.levels[k], covered, darker, n)?;
        sheets[k] = summary;
        made[k] = Some((m, cut));
    }
    let made: Vec<(Made, BitGrid)> = made.into_iter().map(|m| m.expect("made")).collect();
    let fill_in = if lc.fill_in && n == 1 {
        Some(fill_in(&frame, &made[0])?)
    } else {
        None
    };
    let (report, composite) = assess(cfg, &frame, &tones, &made, &sheets, fill_in.as_ref());
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
    let stamp = |bits: &mut BitGrid, p: &StageParams| {
        f.marks.stamp(
            bits,
            f.marks.band_px * p.working.factor,
            p.working.scale.mm_per_px,
        )
    };
    let start = Start::Source(Source::Picture(f.source_gray.clone()));
    fill_in_with(&f.cfg, &start, first, &stamp, None)
}

/// The fill-in of a first stencil `first` (with its two-tone after the clean-up), made by
/// `cfg` from `start` (which sizes it) with `stamp` putting the sheet's own parts into its
/// two-tone (an untiled set's band and marks, a tile's window and marks) and `geometry` changing
/// its traced geometry (a tile's edge): see [`fill_in`].
pub(crate) fn fill_in_with(
    cfg: &MakeConfig,
    start: &Start,
    first: &(Made, BitGrid),
    stamp: &Edit<'_, BitGrid, ()>,
    geometry: Option<&driver::GeometryEdit<'_>>,
) -> Result<(Made, BitGrid), Error> {
    let (m, cut) = first;
    let stencil = &m.bridged.bits;
    let (w, h) = (stencil.width, stencil.height);
    let mut hidden = stencil.clone();
    for (s, &c) in hidden.data.iter_mut().zip(&cut.data) {
        *s &= !c;
    }
    let mut cfg = cfg.clone();
    cfg.tone.threshold = Threshold::Level(128);
    let min_feature = cfg.physical.material.min_feature_mm;
    let draw = |_: &mut (), p: &StageParams| -> TwoTone {
        let mm = p.working.scale.mm_per_px;
        // Grown into the first stencil's cut, 4-neighbour steps.
        let mut grown = hidden.clone();
        let reach = FILL_IN_OVERLAP_MM.max(min_feature);
        for _ in 0..(reach / mm).round() as u32 {
            let prev = grown.clone();
            for (i, g) in grown.data.iter_mut().enumerate() {
                let near = edge_neighbours(i, w as usize, h as usize);
                *g |= !cut.data[i] && near.into_iter().flatten().any(|j| prev.data[j]);
            }
        }
        let mut bits = grown;
        bits.data.iter_mut().for_each(|b| *b = !*b);
        stamp(&mut bits, p);
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
        geometry,
    };
    let (made, _) = driver::made_once(&cfg, start, &tweaks)?;
    Ok((made, hidden))
}

/// The report and the composite: hidden bridging per layer, the fill-in's cover, the painted
/// result in the layers' colours at the picture's own size, and its fidelity.
fn assess(
    cfg: &MakeConfig,
    f: &Frame,
    tones: &Tones,
    made: &[(Made, BitGrid)],
    sheets: &[SheetSummary],
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
            dropped_islands: sheets[k].dropped,
            longest_chain: sheets[k].longest_chain,
            chain_rounds: sheets[k].rounds,
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
        chain: CHAIN,
        max_chain: MAX_CHAIN,
        layers_asked: tones.asked,
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
