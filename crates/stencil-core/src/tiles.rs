//! Tiles: a stencil larger than the bed or the sheet, cut as tiles that are each a whole stencil
//! (one piece, bridged, width-checked, its own files) and register on the wall.
//!
//! ## Seams
//! The whole picture is rendered and cleaned once (the driver's stages up to the clean-up). On
//! its cleaned two-tone, each seam between two tiles is the least-cost path within a band around
//! its straight line (see `seams`): through light, quiet material where it can, across the cut
//! where it must, straight and at the cut's widest.
//!
//! ## A tile
//! Tile (r, c) owns the pixels the seams put in its row and column (its *region*). Its sheet is
//! the box of its region grown by the overlap, on whole input pixels; in it, the tile's two-tone
//! is the whole cleaned two-tone in its region, material in the *strip* within the overlap past
//! its seams (what holds the tile together along them, and what paint cannot pass where the two
//! tiles lie on each other), and cut beyond the strip (the *window*, where the neighbour's part
//! shows through; its bridges cost there as over black, so none is put in it). That two-tone
//! goes through `make`'s stages as any stencil's (islands, bridges, trace, check, repair), its
//! registration marks cut into it.
//!
//! So, laid back at their places, the tiles paint what the whole stencil paints outside the
//! overlaps around the seams (up to their own bridges, each tile bridging its own islands), and
//! nothing inside them: where a seam crosses the cut, the two strips are the seam's bridge.
//!
//! ## Registration
//! The layers' marks (`layers::Marks`), one set for the whole tiled stencil: the picture grows by
//! their band of material on every side, its corner crosses on the corner tiles, and the pin
//! holes sit on the seams, each centred on a seam so that both tiles of it carry it at the same
//! place on the wall (one half in its own picture, the other in its strip): push a pin through
//! both, or tape over them. Every pair of tiles a seam parts gets two at least (see `seams`):
//! in the band where the seam reaches it, where the picture is material around, or else on a
//! pad of material put into the picture. With layers, every layer of a tile carries them.

use std::sync::Arc;

use serde::Serialize;

use crate::driver::{self, Start, Tweaks};
use crate::export::{self, png};
use crate::fit::Stock;
use crate::layers::{grown_bits, grown_gray, Marks};
use crate::limits::{MAX_TILES_PER_SIDE, MAX_TILE_OVERLAP_MM, MIN_TILE_OVERLAP_MM};
use crate::pipeline::{self, files, source, Error, Made, MakeConfig, Source, StageParams};
use crate::raster::{squared_distance, squared_distance_to, BitGrid, Gray, TwoTone};
use crate::tone::Threshold;
use crate::units::Size;

mod edge;
mod layout;
mod map;
mod seams;

pub use crate::error::TilesError;
pub use layout::{Grid, MAX_BAND_MM, MIN_BAND_MM};
pub use map::MAP_MAX_PX;
pub use seams::{Crossing, MarkPlace, Seams, CROSS_CUT, DIAGONAL, NEAR_EDGE};

/// The overlap past each seam when none is given, mm.
pub const DEFAULT_OVERLAP_MM: f64 = 2.0;

/// What a tiled run is asked.
#[derive(Clone, Debug)]
pub struct TilesConfig {
    /// How many tiles.
    pub grid: Grid,
    /// How far each tile's strip of material reaches past its seams, mm (at least the material's
    /// narrowest bridge: the strip holds the tile together along its seams).
    pub overlap_mm: f64,
    /// What each tile must fit, margin included (a sheet, or the machine's bed).
    pub stock: Option<Stock>,
    /// The vertical seams' straight lines, mm from the picture's left edge (empty: evenly).
    pub seam_x_mm: Vec<f64>,
    /// The horizontal seams' straight lines, mm from the picture's top edge (empty: evenly).
    pub seam_y_mm: Vec<f64>,
    /// Layers (two or more) of a picture, each tiled along the same seams; `None`: one stencil.
    pub layers: Option<crate::layers::LayersConfig>,
}

impl Default for TilesConfig {
    fn default() -> Self {
        TilesConfig {
            grid: Grid::Auto,
            overlap_mm: DEFAULT_OVERLAP_MM,
            stock: None,
            seam_x_mm: Vec::new(),
            seam_y_mm: Vec::new(),
            layers: None,
        }
    }
}

/// A seam's report.
#[derive(Clone, Debug, Serialize)]
pub struct SeamReport {
    /// "vertical" or "horizontal".
    pub axis: &'static str,
    /// Its straight line, mm from the picture's left (vertical) or top edge (what the seam
    /// options take).
    pub at_mm: f64,
    /// How far it could wander each way, mm.
    pub band_mm: f64,
    /// Its path, mm in the whole grown picture (the picture and the marks' band around it, as
    /// the tiles' places): a point where its direction changes, and its ends.
    pub points_mm: Vec<[f64; 2]>,
    /// The same in working pixels: `[across, along]`... as `[x, y]`.
    pub points_px: Vec<[u32; 2]>,
    /// Its length through the cut, mm (where the two strips are its bridge).
    pub through_cut_mm: f64,
    /// Its length through cut narrower than the material's smallest feature, mm.
    pub through_thin_mm: f64,
    /// Its length, mm.
    pub length_mm: f64,
    /// Where it runs through the cut (its bridges: the earlier tile's strip, one overlap wide,
    /// stays unpainted there), each as the seam's first and last point in the run, mm in the
    /// whole grown picture.
    pub bridges_mm: Vec<[[f64; 2]; 2]>,
    /// Its registration pin holes, each cut into both tiles of its segment.
    pub marks: Vec<SeamMarkReport>,
    /// Its segments (one per pair of tiles it parts) with fewer than two marks: none, unless
    /// the picture left no place at all (a segment too short, or thin features all along it).
    pub unregistered_segments: usize,
}

/// A registration pin hole on a seam.
#[derive(Clone, Debug, Serialize)]
pub struct SeamMarkReport {
    /// Which pair of tiles along the seam (from 1: the first row's or column's).
    pub segment: usize,
    /// Its centre, mm in the whole grown picture.
    pub at_mm: [f64; 2],
    /// `clear` (the picture is material around it), `band` (in the band around the picture) or
    /// `pad` (a ring of material put into the picture for it, where it changes the fewest
    /// pixels).
    pub place: MarkPlace,
}

/// One tile's report.
#[derive(Clone, Debug, Serialize)]
pub struct TileReport {
    /// Its place in the cutting order, from 1.
    pub number: usize,
    /// Its row, from 1.
    pub row: u32,
    /// Its column, from 1.
    pub col: u32,
    /// Its folder.
    pub folder: String,
    /// Where its picture's top-left corner lies in the whole picture, mm.
    pub x_mm: f64,
    /// As above, y.
    pub y_mm: f64,
    /// Its picture's width, mm.
    pub width_mm: f64,
    /// Its picture's height, mm.
    pub height_mm: f64,
    /// Its sheet (picture and margin), mm.
    pub sheet_mm: [f64; 2],
    /// Its picture's place and size in working pixels of the whole picture: x, y, w, h.
    pub box_px: [u32; 4],
    /// Its pin holes' centres, mm from its picture's top-left corner.
    pub pins_mm: Vec<[f64; 2]>,
    /// Its registration crosses' centres (in the band, on a corner tile), mm from the same.
    pub crosses_mm: Vec<[f64; 2]>,
    /// Islands before bridging (of every layer).
    pub islands: usize,
    /// Bridges made (in every layer).
    pub bridges: usize,
    /// Whether its stencil (every layer's) passed the check.
    pub check_passed: bool,
    /// Its layers, light to dark, when the picture is cut in layers (one layer: its stencil is
    /// the tile's folder itself).
    pub layers: Vec<TileLayerReport>,
    /// Its fill-in stencil (which paints what its bridges hide), when one was asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fill_in: Option<TileLayerReport>,
}

/// One layer of a tile, or its fill-in.
#[derive(Clone, Debug, Serialize)]
pub struct TileLayerReport {
    /// 1 = the first sprayed (lightest paint); a fill-in is sprayed second, in the first's paint.
    pub layer: u32,
    /// Its folder, in the output folder.
    pub folder: String,
    /// It cuts where the picture's gray is below this 8-bit level.
    pub level: u8,
    /// Its paint colour, `#rrggbb` (the untiled set's layer's).
    pub color: String,
    /// Islands before bridging.
    pub islands: usize,
    /// Bridges made.
    pub bridges: usize,
    /// Whether its stencil passed the check.
    pub check_passed: bool,
}

/// A tiled stencil's report.json.
#[derive(Clone, Debug, Serialize)]
pub struct TilesReport {
    /// The input's path.
    pub input: String,
    /// Tiles across and down.
    pub grid: [u32; 2],
    /// The whole grown picture (the picture and the marks' band around it), mm.
    pub width_mm: f64,
    /// As above.
    pub height_mm: f64,
    /// Millimetres per working pixel.
    pub mm_per_px: f64,
    /// The whole grown picture in working pixels.
    pub size_px: [u32; 2],
    /// The band of material around the picture holding the registration marks, mm: the
    /// picture's top-left corner lies this far right and down in the grown picture.
    pub marks_band_mm: f64,
    /// The same in working pixels.
    pub marks_band_px: u32,
    /// Each tile's strip past its seams, mm.
    pub overlap_mm: f64,
    /// The stock each tile fits (name, width, height), when there is one.
    pub stock: Option<(String, f64, f64)>,
    /// The sheet's margin around each tile's picture, mm.
    pub margin_mm: f64,
    /// Diameter of the registration pin holes, mm (0: none: the overlap is too narrow to hold
    /// them).
    pub pin_mm: f64,
    /// The registration marks, mm in the whole grown picture: the corner crosses in the band,
    /// the pin holes on the seams (see the seams' marks).
    pub marks: Marks,
    /// The surface's colour, `#rrggbb`, when the picture is cut in layers.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub surface_color: Option<String>,
    /// The seams.
    pub seams: Vec<SeamReport>,
    /// The tiles, in cutting order.
    pub tiles: Vec<TileReport>,
    /// The tiles' folders in cutting order.
    pub cutting_order: Vec<String>,
    /// The files written.
    pub files: Vec<String>,
}

/// What a tiled run made, before anything is written.
pub struct Tiled {
    /// Each tile's stencils (one, or one per layer light to dark), in cutting order.
    pub tiles: Vec<Vec<Made>>,
    /// The map, RGB, with its size.
    pub map: (u32, u32, Vec<u8>),
    /// The report.
    pub report: TilesReport,
}

/// The folder of the tile in row `r` and column `c` (from 1).
pub fn tile_folder(r: u32, c: u32) -> String {
    format!("tile-{r}-{c}")
}

/// The stencil folders of a tiled `make` output folder, in cutting order (each tile's layers
/// in painting order): empty when it holds no tiles.
pub fn tile_folders(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let most = MAX_TILES_PER_SIDE;
    let mut v = Vec::new();
    for f in (1..=most).flat_map(|r| (1..=most).map(move |c| tile_folder(r, c))) {
        let t = dir.join(f);
        if t.join("report.json").is_file() {
            v.extend(crate::layers::stencil_folders(&t));
        } else if t.is_dir() {
            v.extend(
                crate::layers::stencil_folders(&t)
                    .into_iter()
                    .filter(|p| p != &t),
            );
        }
    }
    v
}

/// The stencil folders of any `make` output folder: a tiled one's tiles (see [`tile_folders`]),
/// else a set's or the folder itself (see `layers::stencil_folders`).
pub fn stencil_folders(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let v = tile_folders(dir);
    if v.is_empty() {
        crate::layers::stencil_folders(dir)
    } else {
        v
    }
}

/// What a tile's pixel is, in its box.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Part {
    /// The tile's own: the whole stencil's two-tone.
    Region,
    /// Within the overlap past a seam: material.
    Strip,
    /// Beyond: cut (the neighbour shows through).
    Window,
    /// Within the overlap past a seam to an earlier tile (left or above), deep in a dark part
    /// of the picture: the whole stencil's two-tone (cut), so that spraying this tile paints
    /// the overlap (the earlier tile's strip holds that one there).
    Open,
}

/// A tile: its box in working pixels of the whole picture, what each pixel is, its marks.
struct Tile {
    row: u32,
    col: u32,
    /// The grid's rows and columns (a tile on its last row or column has an outer side there).
    rows: u32,
    cols: u32,
    /// x, y, w, h in working px (on whole input pixels).
    bx: [u32; 4],
    parts: Vec<Part>,
    /// Its share of the registration marks (in the whole grown picture's mm).
    marks: Marks,
    /// Its box's top-left corner in the marks' mm.
    origin_mm: [f64; 2],
    /// Millimetres per working pixel.
    mm: f64,
}

impl Tile {
    /// Its two-tone from the whole one: region as it is, strip material, window cut, marks cut.
    fn impose(&self, bits: &mut BitGrid, whole: &BitGrid) {
        let [x0, y0, w, _] = self.bx;
        for (i, p) in self.parts.iter().enumerate() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            bits.data[i] = match p {
                Part::Region | Part::Open => whole.get(x0 + x, y0 + y),
                Part::Strip => true,
                Part::Window => false,
            };
        }
        self.marks.cut(bits, self.origin_mm, self.mm);
    }
}

/// Tile (r, c)'s box and parts, from the seams: the box of its region (bounded by its seams'
/// extremes) grown by the overlap and a window, rounded out to whole input pixels.
fn tile(
    (r, c): (usize, usize),
    seams: &Seams,
    (w, h): (u32, u32),
    (ov, window): (u32, u32),
    factor: u32,
    (whole, min_px): (&BitGrid, f64),
) -> Tile {
    let lo = |s: Option<&Vec<u32>>| s.map_or(0, |s| *s.iter().min().unwrap_or(&0));
    let hi = |s: Option<&Vec<u32>>, end: u32| s.map_or(end, |s| *s.iter().max().unwrap_or(&end));
    let left = if c == 0 { None } else { seams.xs.get(c - 1) };
    let top = if r == 0 { None } else { seams.ys.get(r - 1) };
    let x0 = lo(left).saturating_sub(ov + window) / factor * factor;
    let y0 = lo(top).saturating_sub(ov + window) / factor * factor;
    let x1 = ((hi(seams.xs.get(c), w) + ov + window).min(w)).div_ceil(factor) * factor;
    let y1 = ((hi(seams.ys.get(r), h) + ov + window).min(h)).div_ceil(factor) * factor;
    let (x1, y1) = (x1.min(w), y1.min(h));
    let (bw, bh) = (x1 - x0, y1 - y0);
    let region = BitGrid::from_fn(bw, bh, |x, y| {
        let (gx, gy) = (x0 + x, y0 + y);
        seams.col(gx, gy) == c && seams.row(gx, gy) == r
    });
    // Outside the box is no one's: the strip reaches only from the region.
    let d2 = squared_distance(&region, true, false);
    let reach = (ov * ov) as f32;
    // How far the whole stencil's material is (outside the box counts as material).
    let material = BitGrid::from_fn(bw, bh, |x, y| whole.get(x0 + x, y0 + y));
    let to_material = squared_distance_to(&material, true);
    let dark = (min_px * min_px) as f32;
    let parts = region
        .data
        .iter()
        .zip(&d2)
        .enumerate()
        .map(|(i, (&own, &d))| {
            if own {
                Part::Region
            } else if d <= reach {
                let (gx, gy) = (x0 + i as u32 % bw, y0 + i as u32 / bw);
                let earlier = seams.col(gx, gy) < c || seams.row(gx, gy) < r;
                if earlier && to_material[i] >= dark {
                    Part::Open
                } else {
                    Part::Strip
                }
            } else {
                Part::Window
            }
        })
        .collect();
    Tile {
        row: r as u32 + 1,
        col: c as u32 + 1,
        rows: seams.ys.len() as u32 + 1,
        cols: seams.xs.len() as u32 + 1,
        bx: [x0, y0, bw, bh],
        parts,
        marks: Marks::new(1, 1, 1.0, 1.0).with_pins(0.0, Vec::new()),
        origin_mm: [0.0; 2],
        mm: 1.0,
    }
}

/// The points of a seam where its direction changes, and its ends, as `[x, y]` working px.
fn corners(path: &[u32], vertical: bool) -> Vec<[u32; 2]> {
    let at = |s: usize| {
        if vertical {
            [path[s], s as u32]
        } else {
            [s as u32, path[s]]
        }
    };
    let mut out = vec![at(0)];
    for s in 1..path.len().saturating_sub(1) {
        let (a, b) = (
            path[s] as i64 - path[s - 1] as i64,
            path[s + 1] as i64 - path[s] as i64,
        );
        if a != b {
            out.push(at(s));
        }
    }
    if path.len() > 1 {
        out.push(at(path.len() - 1));
    }
    out
}

/// `make` for tiles, in memory: the whole picture rendered and cleaned once, its seams found,
/// then each tile through `make`'s stages.
pub fn run(cfg: &MakeConfig, tc: &TilesConfig) -> Result<Tiled, Error> {
    if cfg.physical.gobo.is_some() {
        return Err(TilesError::Unsupported("a gobo (a disc that fits its gate)").into());
    }
    if cfg.keep_out.is_some() {
        return Err(TilesError::Unsupported("a keep-out picture (use keep-out discs)").into());
    }
    if !(MIN_TILE_OVERLAP_MM..=MAX_TILE_OVERLAP_MM).contains(&tc.overlap_mm) {
        return Err(TilesError::Overlap(tc.overlap_mm).into());
    }
    if let Grid::Fixed { cols, rows } = tc.grid {
        if cols == 0 || rows == 0 || cols > MAX_TILES_PER_SIDE || rows > MAX_TILES_PER_SIDE {
            return Err(TilesError::TooMany {
                cols,
                rows,
                max: MAX_TILES_PER_SIDE,
            }
            .into());
        }
    }
    // The whole picture, rendered once: a mesh drawn and lit, a picture adjusted; a set's
    // posterised as the untiled set's (its colours clustered), one cleaned two-tone per layer.
    let (src, tones) = match &tc.layers {
        Some(lc) => {
            let tones = crate::layers::tones_of(cfg, lc)?;
            let g = Arc::new(tones.gray.clone());
            (Source::Picture(g), Some(tones))
        }
        None => {
            let sp = pipeline::SourceParams::of(cfg)?;
            let input = source::load(&cfg.input, &sp)?;
            let drawn = source::draw(&input, &sp)?;
            (source::light(&input, drawn.as_deref(), &sp)?, None)
        }
    };
    let levels: Vec<u8> = tones.as_ref().map_or(Vec::new(), |t| t.levels.clone());
    let runs: Vec<Option<u8>> = if levels.is_empty() {
        vec![None]
    } else {
        levels.iter().copied().map(Some).collect()
    };
    // Darkest first, each lighter layer nested in the darker one's cut (as an untiled set's).
    let mut wholes: Vec<pipeline::Cleaned> = Vec::with_capacity(runs.len());
    let mut params = None;
    for l in runs.iter().rev() {
        let mut lcfg = cfg.clone();
        if let Some(l) = l {
            lcfg.tone.threshold = Threshold::Level(*l);
        }
        let (mut w, p) = driver::cleaned_from(&lcfg, &Start::Source(src.clone()))?;
        if let Some(darker) = wholes.last() {
            crate::layers::nest(&mut w.twotone.bits, &darker.twotone.bits);
        }
        wholes.push(w);
        params = Some(p);
    }
    wholes.reverse();
    let params = params.expect("one run at least");
    let src_gray = match &src {
        Source::Picture(g) => Arc::clone(g),
        Source::Mesh(r) => Arc::new(r.gray.clone()),
    };
    drop(src);
    let factor = params.working.factor;
    let mm = params.working.scale.mm_per_px;
    let min_feature = cfg.physical.material.min_feature_mm;
    // The registration marks' band of material around the whole picture (the layers' band, its
    // corner crosses on the corner tiles): every tile's picture is drawn from the grown one.
    let frame = Marks::new(
        src_gray.width,
        src_gray.height,
        mm * factor as f64,
        min_feature,
    );
    let band = frame.band_px * factor;
    let band_mm = band as f64 * mm;
    let src_gray = Arc::new(grown_gray(&src_gray, frame.band_px));
    for w in &mut wholes {
        w.twotone.bits = grown_bits(&w.twotone.bits, band);
        w.twotone.gray = Arc::new(grown_gray(&w.twotone.gray, band));
    }
    // The seams are chosen on the first layer's, which cuts the most (every later layer cuts
    // part of what it cuts): through its material, they go through every layer's.
    let (w, h) = (wholes[0].twotone.bits.width, wholes[0].twotone.bits.height);
    let margin = cfg.physical.vector.margin_mm;
    let stock = tc.stock.as_ref().map(layout::stock_size);
    // The strip is the tile's frame along its seams: never narrower than a bridge may be.
    let m = &cfg.physical.material;
    let tc = &TilesConfig {
        overlap_mm: tc.overlap_mm.max(m.min_bridge_mm).max(m.min_feature_mm),
        ..tc.clone()
    };
    let ov_px = (tc.overlap_mm / mm).ceil() as u32;
    // A window is never narrower than the smallest feature (with two pixels to spare): a tile's
    // box reaches that far past its strip on a seam's side.
    let window_px = (min_feature / mm).ceil() as u32 + 2;
    let side = |axis, len_px, stock_mm: Option<f64>, count, seams_mm: &[f64]| {
        layout::side(&layout::SideRequest {
            axis,
            len_px,
            mm_per_px: mm,
            stock_mm,
            count,
            seams_mm,
            overlap_mm: tc.overlap_mm,
            margin_mm: margin,
            factor,
            window_mm: window_px as f64 * mm,
        })
    };
    let (count_x, count_y) = match tc.grid {
        Grid::Auto => (None, None),
        Grid::Fixed { cols, rows } => (Some(cols), Some(rows)),
    };
    // Seam places asked for are on the picture: the grown one's are a band further.
    let shift = |v: &[f64]| v.iter().map(|x| x + band_mm).collect::<Vec<f64>>();
    let cols = side(
        "vertical",
        w,
        stock.map(|s| s.0),
        count_x,
        &shift(&tc.seam_x_mm),
    )?;
    let rows = side(
        "horizontal",
        h,
        stock.map(|s| s.1),
        count_y,
        &shift(&tc.seam_y_mm),
    )?;
    // Pin holes: the layers' where the overlap holds them with the smallest feature to spare on
    // each side (a pin hole on a seam is in both tiles: its far half in the strip).
    let (line, _, layers_pin) = crate::layers::mark_sizes(min_feature);
    let pin_mm = layers_pin.min(2.0 * (tc.overlap_mm - min_feature));
    let pin_mm = if pin_mm >= line { pin_mm } else { 0.0 };
    let pin_r = pin_mm / 2.0 / mm;
    let request = seams::SeamRequest {
        bits: &wholes[0].twotone.bits,
        gray: &wholes[0].twotone.gray,
        cols: &cols,
        rows: &rows,
        overlap_px: ov_px as f64,
        min_px: min_feature / mm,
        pin_clear_px: if pin_mm > 0.0 {
            pin_r + min_feature / mm + 1.0
        } else {
            0.0
        },
        band_px: band,
    };
    let (seams, crossings, alongs) = seams::find(&request);
    let seam_marks = seams::place_marks(&seams, &alongs, &request);
    let pad_px = request.pin_clear_px;
    for w in &mut wholes {
        seams::put_pads(&mut w.twotone.bits, &seam_marks, pad_px);
    }
    let at_mm = |(x, y): (u32, u32)| [(x as f64 + 0.5) * mm, (y as f64 + 0.5) * mm];
    let marks = frame.with_pins(pin_mm, seam_marks.iter().map(|m| at_mm(m.at)).collect());
    let mut tiles: Vec<Tile> = Vec::new();
    for r in 0..rows.count as usize {
        for c in 0..cols.count as usize {
            let dark = (&wholes[0].twotone.bits, min_feature / mm);
            let mut t = tile((r, c), &seams, (w, h), (ov_px, window_px), factor, dark);
            let [x0, y0, bw, bh] = t.bx;
            let (sw_mm, sh_mm) = (bw as f64 * mm + 2.0 * margin, bh as f64 * mm + 2.0 * margin);
            if let Some((stock_w, stock_h)) = stock {
                if sw_mm > stock_w + 1e-6 || sh_mm > stock_h + 1e-6 {
                    return Err(TilesError::TileTooLarge {
                        row: t.row,
                        col: t.col,
                        w_mm: sw_mm,
                        h_mm: sh_mm,
                        stock_w_mm: stock_w,
                        stock_h_mm: stock_h,
                    }
                    .into());
                }
            }
            // Its marks: the pins centred on its material, the crosses on its own picture.
            let part = |[x, y]: [f64; 2]| {
                let (px, py) = ((x / mm).floor(), (y / mm).floor());
                let inside = px >= x0 as f64
                    && py >= y0 as f64
                    && px < (x0 + bw) as f64
                    && py < (y0 + bh) as f64;
                inside.then(|| t.parts[((py as u32 - y0) * bw + (px as u32 - x0)) as usize])
            };
            let pins = marks.pins_mm.iter().copied();
            let pins = pins.filter(|&p| part(p).is_some_and(|p| p != Part::Window));
            let crosses = marks.crosses_mm.iter().copied();
            let crosses = crosses.filter(|&p| part(p) == Some(Part::Region));
            t.marks = Marks {
                pins_mm: pins.collect(),
                crosses_mm: crosses.collect(),
                ..marks.clone()
            };
            t.origin_mm = [x0 as f64 * mm, y0 as f64 * mm];
            t.mm = mm;
            tiles.push(t);
        }
    }
    let fill_in = tc.layers.as_ref().is_some_and(|lc| lc.fill_in) && wholes.len() == 1;
    let mut made = Vec::with_capacity(tiles.len());
    for t in &tiles {
        let mut layers = Vec::with_capacity(wholes.len() + 1);
        for whole in &wholes {
            let sheets = one_tile(cfg, t, whole, &src_gray, (factor, band_mm), fill_in)?;
            layers.extend(sheets);
        }
        made.push(layers);
    }
    let report = assess(
        cfg,
        tc,
        &tiles,
        &made,
        Seamed {
            seams: &seams,
            crossings: &crossings,
            marks: &seam_marks,
            all_marks: &marks,
        },
        (w, h, mm, band),
        (&cols, &rows),
        tones.as_ref(),
    );
    let labels: Vec<(usize, (u32, u32))> = tiles
        .iter()
        .enumerate()
        .map(|(i, t)| {
            // The middle of its region's box, without the overlap.
            let [x0, y0, bw, bh] = t.bx;
            (i + 1, (x0 + bw / 2, y0 + bh / 2))
        })
        .collect();
    let pins: Vec<(u32, u32)> = seam_marks.iter().map(|m| m.at).collect();
    let map = map::draw(&map::MapRequest {
        bits: &wholes[0].twotone.bits,
        seams: &seams,
        overlap_px: ov_px,
        pins: &pins,
        labels: &labels,
    });
    Ok(Tiled {
        tiles: made,
        map,
        report,
    })
}

/// One tile through `make`'s stages: its picture the whole one's in its box (it sizes the
/// stencil and shows in its preview), its two-tone drawn from the whole cleaned one (so every
/// tile agrees along the seams), cleaned again as any stencil's and imposed once more, bridged
/// with the window as over black; with `fill_in`, followed by its fill-in stencil (the layers'
/// fill-in of its bridges, its window and marks as the tile's).
fn one_tile(
    cfg: &MakeConfig,
    t: &Tile,
    whole: &pipeline::Cleaned,
    src_gray: &Gray,
    (factor, band_mm): (u32, f64),
    fill_in: bool,
) -> Result<Vec<Made>, Error> {
    let mm = t.mm;
    let [x0, y0, bw, bh] = t.bx;
    let (ix0, iy0, iw, ih) = (x0 / factor, y0 / factor, bw / factor, bh / factor);
    let mut crop = Gray::new(iw, ih, 1.0);
    for y in 0..ih {
        let src = ((iy0 + y) * src_gray.width + ix0) as usize;
        let dst = (y * iw) as usize;
        crop.data[dst..dst + iw as usize].copy_from_slice(&src_gray.data[src..src + iw as usize]);
    }
    let mut tcfg = cfg.clone();
    tcfg.physical.size = Size::Dpi(25.4 / (mm * factor as f64));
    tcfg.tone.scale = Some(factor);
    tcfg.tone.threshold = Threshold::Level(whole.level);
    tcfg.tone.adjust = Default::default();
    // The user's places, from the picture's corner to the tile's.
    let (ox, oy) = (x0 as f64 * mm - band_mm, y0 as f64 * mm - band_mm);
    for p in &mut tcfg.places.at_mm {
        p[0] -= ox;
        p[1] -= oy;
    }
    for p in &mut tcfg.places.no_bridge_near_mm {
        p[0] -= ox;
        p[1] -= oy;
    }
    let wbits = &whole.twotone.bits;
    let wgray = &whole.twotone.gray;
    let draw = |_: &mut (), p: &StageParams| -> TwoTone {
        debug_assert_eq!(p.working.factor, factor);
        let mut bits = BitGrid::new(bw, bh, true);
        t.impose(&mut bits, wbits);
        let mut g = Gray::new(bw, bh, 1.0);
        for y in 0..bh {
            let s = ((y0 + y) * wgray.width + x0) as usize;
            let d = (y * bw) as usize;
            g.data[d..d + bw as usize].copy_from_slice(&wgray.data[s..s + bw as usize]);
        }
        TwoTone {
            bits,
            gray: Arc::new(g),
        }
    };
    let again = |tt: &mut TwoTone, _: &StageParams| t.impose(&mut tt.bits, wbits);
    let cost = |g: &Gray| {
        let mut g = g.clone();
        for (v, p) in g.data.iter_mut().zip(&t.parts) {
            if *p == Part::Window {
                *v = 0.0;
            }
        }
        g
    };
    // Its edge along its seams (see `edge`).
    let outer = [t.col == 1, t.row == 1, t.col == t.cols, t.row == t.rows];
    let trim = |g: &mut crate::vector::CutGeometry| -> Result<(), Error> {
        Ok(edge::trim(g, outer, mm / 2.0)?)
    };
    let tweaks = Tweaks {
        two_tone: Some(&draw),
        after_threshold: None,
        after_clean: Some(&again),
        cost_gray: Some(&cost),
        keep_all_islands: cfg.places.keep_all_islands,
        geometry: Some(&trim),
    };
    let start = Start::Source(Source::Picture(Arc::new(crop)));
    let (made, cut) = driver::made_once(&tcfg, &start, &tweaks)?;
    if !fill_in {
        return Ok(vec![made]);
    }
    let stamp = |bits: &mut BitGrid, _: &StageParams| {
        for (b, p) in bits.data.iter_mut().zip(&t.parts) {
            if *p == Part::Window {
                *b = false;
            }
        }
        t.marks.cut(bits, t.origin_mm, t.mm);
    };
    let first = (made, cut);
    let (fill, _) = crate::layers::fill_in_with(&tcfg, &start, &first, &stamp, Some(&trim))?;
    Ok(vec![first.0, fill])
}

/// The seams and their marks, for the report.
struct Seamed<'a> {
    seams: &'a Seams,
    crossings: &'a [Crossing],
    marks: &'a [seams::SeamMark],
    all_marks: &'a Marks,
}

/// The report: the seams, and each tile's place, size and result.
#[allow(clippy::too_many_arguments)]
fn assess(
    cfg: &MakeConfig,
    tc: &TilesConfig,
    tiles: &[Tile],
    made: &[Vec<Made>],
    seamed: Seamed,
    (w, h, mm, band): (u32, u32, f64, u32),
    (cols, rows): (&layout::Side, &layout::Side),
    tones: Option<&crate::layers::Tones>,
) -> TilesReport {
    let margin = cfg.physical.vector.margin_mm;
    let band_mm = band as f64 * mm;
    let seams = seamed.seams;
    let mut seam_reports = Vec::new();
    let all = seams
        .xs
        .iter()
        .zip(&cols.centres_px)
        .map(|(p, &c)| (true, p, c, cols.band_px, rows.count))
        .chain(
            seams
                .ys
                .iter()
                .zip(&rows.centres_px)
                .map(|(p, &c)| (false, p, c, rows.band_px, cols.count)),
        );
    for (k, ((vertical, path, centre, wander, segments), cr)) in
        all.zip(seamed.crossings).enumerate()
    {
        let points_px = corners(path, vertical);
        let marks: Vec<SeamMarkReport> = seamed
            .marks
            .iter()
            .filter(|m| m.seam == k)
            .map(|m| SeamMarkReport {
                segment: m.segment + 1,
                at_mm: [(m.at.0 as f64 + 0.5) * mm, (m.at.1 as f64 + 0.5) * mm],
                place: m.place,
            })
            .collect();
        let unregistered = (1..=segments as usize)
            .filter(|&s| marks.iter().filter(|m| m.segment == s).count() < 2)
            .count();
        seam_reports.push(SeamReport {
            axis: if vertical { "vertical" } else { "horizontal" },
            // On the picture, as the seam options take it (whole pixels first: no rounding).
            at_mm: centre.saturating_sub(band) as f64 * mm,
            band_mm: wander as f64 * mm,
            points_mm: points_px
                .iter()
                .map(|&[x, y]| [x as f64 * mm, y as f64 * mm])
                .collect(),
            points_px,
            through_cut_mm: cr.cut_px as f64 * mm,
            through_thin_mm: cr.thin_px as f64 * mm,
            length_mm: cr.len_px as f64 * mm,
            bridges_mm: cr
                .runs
                .iter()
                .map(|&(a, b)| {
                    let at = |st: u32| {
                        let across = path[st as usize] as f64 + 0.5;
                        let along = st as f64 + 0.5;
                        if vertical {
                            [across * mm, along * mm]
                        } else {
                            [along * mm, across * mm]
                        }
                    };
                    [at(a), at(b)]
                })
                .collect(),
            marks,
            unregistered_segments: if seamed.all_marks.pin_mm > 0.0 {
                unregistered
            } else {
                segments as usize
            },
        });
    }
    let levels: &[u8] = tones.map_or(&[], |t| &t.levels);
    let tile_reports: Vec<TileReport> = tiles
        .iter()
        .zip(made)
        .enumerate()
        .map(|(i, (t, m))| {
            let [x0, y0, bw, bh] = t.bx;
            let rel = |v: &Vec<[f64; 2]>| {
                v.iter()
                    .map(|&[x, y]| [x - t.origin_mm[0], y - t.origin_mm[1]])
                    .collect()
            };
            TileReport {
                number: i + 1,
                row: t.row,
                col: t.col,
                folder: tile_folder(t.row, t.col),
                x_mm: x0 as f64 * mm,
                y_mm: y0 as f64 * mm,
                width_mm: bw as f64 * mm,
                height_mm: bh as f64 * mm,
                sheet_mm: [bw as f64 * mm + 2.0 * margin, bh as f64 * mm + 2.0 * margin],
                box_px: t.bx,
                pins_mm: rel(&t.marks.pins_mm),
                crosses_mm: rel(&t.marks.crosses_mm),
                islands: m.iter().map(|m| m.report.islands).sum(),
                bridges: m.iter().map(|m| m.bridged.bridges.len()).sum(),
                check_passed: m.iter().all(|m| m.check.passed()),
                fill_in: (m.len() > levels.len().max(1)).then(|| {
                    let f = &m[m.len() - 1];
                    TileLayerReport {
                        layer: 2,
                        folder: format!("{}/fill-in", tile_folder(t.row, t.col)),
                        level: 128,
                        color: tones.map_or(String::new(), |t| crate::layers::hex(t.colors[1])),
                        islands: f.report.islands,
                        bridges: f.bridged.bridges.len(),
                        check_passed: f.check.passed(),
                    }
                }),
                layers: levels
                    .iter()
                    .zip(m)
                    .enumerate()
                    .map(|(k, (&level, m))| TileLayerReport {
                        layer: k as u32 + 1,
                        folder: match crate::layers::layer_folder(k + 1, levels.len()) {
                            f if f.is_empty() => tile_folder(t.row, t.col),
                            f => format!("{}/{f}", tile_folder(t.row, t.col)),
                        },
                        level,
                        color: tones.map_or(String::new(), |t| crate::layers::hex(t.colors[k + 1])),
                        islands: m.report.islands,
                        bridges: m.bridged.bridges.len(),
                        check_passed: m.check.passed(),
                    })
                    .collect(),
            }
        })
        .collect();
    TilesReport {
        input: cfg.input.display().to_string(),
        grid: [cols.count, rows.count],
        width_mm: w as f64 * mm,
        height_mm: h as f64 * mm,
        mm_per_px: mm,
        size_px: [w, h],
        marks_band_mm: band_mm,
        marks_band_px: band,
        overlap_mm: tc.overlap_mm,
        stock: tc.stock.as_ref().map(|s| {
            let (sw, sh) = layout::stock_size(s);
            (s.to_string(), sw, sh)
        }),
        margin_mm: margin,
        pin_mm: seamed.all_marks.pin_mm,
        marks: seamed.all_marks.clone(),
        surface_color: tones.map(|t| crate::layers::hex(t.colors[0])),
        seams: seam_reports,
        cutting_order: tile_reports.iter().map(|t| t.folder.clone()).collect(),
        tiles: tile_reports,
        files: Vec::new(),
    }
}

/// The files of a tiled stencil, by name: each tile's files as `make` writes them in its
/// folder, tiles.png and report.json.
pub fn encode(t: &mut Tiled, cfg: &MakeConfig) -> Result<Vec<(String, Vec<u8>)>, Error> {
    // Every tile cuts the registration marks: a mask's own corner marks would be a second set.
    let mut phys = cfg.physical.clone();
    phys.mask.marks = false;
    let mut files = Vec::new();
    for (ms, r) in t.tiles.iter_mut().zip(&t.report.tiles) {
        for (k, m) in ms.iter_mut().enumerate() {
            let folder = match (r.layers.get(k), &r.fill_in) {
                (Some(l), _) => &l.folder,
                (None, Some(f)) if k > 0 => &f.folder,
                _ => &r.folder,
            };
            for (name, bytes) in files::encode_outputs(m, &phys)? {
                files.push((format!("{folder}/{name}"), bytes));
            }
        }
    }
    let (mw, mh, rgb) = &t.map;
    files.push(("tiles.png".into(), png::encode_rgb(*mw, *mh, rgb)));
    let mut report = t.report.clone();
    report.files = files.iter().map(|(n, _)| n.clone()).collect();
    report.files.push("report.json".into());
    let json = serde_json::to_vec_pretty(&report).map_err(|e| export::ExportError::Encode {
        path: std::path::PathBuf::from("report.json"),
        msg: e.to_string(),
    })?;
    files.push(("report.json".into(), json));
    t.report = report;
    Ok(files)
}

/// `stencil make` in tiles: run them all and write them into `cfg.out_dir` as one transaction,
/// every owned name this run does not write removed.
pub fn make(cfg: &MakeConfig, tc: &TilesConfig) -> Result<(Tiled, export::Replaced), Error> {
    files::write_with(cfg, || run(cfg, tc), |t| encode(t, cfg))
}
