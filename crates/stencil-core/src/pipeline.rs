//! The whole job, stage by stage: input → two-tone → filter → islands → bridges → vectors → check
//! → outputs.
//!
//! Stages are pure functions on plain data; this module times them, gathers the report and hands
//! the results to `export` at the very end, so a failure anywhere leaves no output behind.

use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::bridge::{self, Bridged};
use crate::check::{self, CheckReport};
use crate::export::{self, dxf, mask, png, svg};
use crate::islands;
use crate::material::Material;
use crate::raster::{BitGrid, Gray, TwoTone};
use crate::report::{BridgeReport, Fidelity, Report};
use crate::tone::filter::{self, FilterConfig, FilterStats};
use crate::tone::mesh::{self, MeshConfig};
use crate::tone::regularize::{
    fill_sealed_pockets, regularize, settle_all, settle_near, RegularizeConfig,
};
use crate::tone::{self, image::load_gray};

use crate::units::{Mm, Scale};
use crate::vector::{self, CutGeometry, VectorConfig};

pub use crate::error::Error;

/// How many times `make` widens the necks the vector check still finds and traces again.
const REPAIR_ROUNDS: usize = 3;

/// How far (in disc spans past the neck) a repair may change the stencil.
const REPAIR_SPREAD: u32 = 1;
/// How many disc spans around the bridges the settle after bridging may change (see
/// [`bridge_prepared`]).
const JOIN_SPREAD: u32 = 2;

pub use crate::plan::{
    CleanParams, JoinParams, SourceParams, StageParams, ToneParams, TraceParams, UserParams,
    Working,
};
pub use crate::request::{Emit, MakeConfig, PhysicalConfig};
pub use crate::timing::{Progress, Timings};
pub use crate::units::Size;

/// Widen, in `bits`, each neck the check found, with a disc `round` pixels larger than the
/// pipeline's own (only adding material, so the sheet stays one piece), then settle what that
/// left thin at the edges of the change. Returns whether anything changed.
fn widen_necks(
    bits: &mut BitGrid,
    chk: &CheckReport,
    material: &Material,
    scale: Scale,
    round: usize,
) -> bool {
    let before = bits.count_material();
    let (w, h) = (bits.width, bits.height);
    // Boxes around the necks, by the width they need: one settle per width.
    let mut by_width: Vec<(f64, Vec<[u32; 4]>)> = Vec::new();
    for v in &chk.violations {
        let need_mm = match v.kind {
            check::ViolationKind::Floating => continue,
            check::ViolationKind::ThinBridge => material.min_bridge_mm,
            _ => material.min_feature_mm,
        };
        let px = scale.to_px(Mm(need_mm)).0 + 1.0 + round as f64;
        let (x, y) = (
            (scale.to_px(Mm(v.x_mm)).0.max(0.0) as u32).min(w - 1),
            (scale.to_px(Mm(v.y_mm)).0.max(0.0) as u32).min(h - 1),
        );
        let r = px.ceil() as u32;
        let bx = [
            x.saturating_sub(r),
            y.saturating_sub(r),
            x + r + 1,
            y + r + 1,
        ];
        match by_width.iter_mut().find(|(p, _)| *p == px) {
            Some((_, boxes)) => boxes.push(bx),
            None => by_width.push((px, vec![bx])),
        }
    }
    for (px, boxes) in &by_width {
        settle_near(bits, boxes, *px, REPAIR_SPREAD);
    }
    // The regularisation's width (see [`PhysicalConfig::feature_px`]).
    settle_all(bits, scale.to_px(Mm(material.min_feature_mm)).0 + 1.0);
    bits.count_material() != before
}

/// Whether a path is a mesh (by extension) rather than a picture (for the front ends).
pub fn is_mesh_path(path: &Path) -> bool {
    is_mesh(path)
}

/// Whether a path is a mesh (by extension) rather than a picture.
pub(crate) fn is_mesh(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"))
}

/// The input as read: a picture's gray at its own resolution, or a mesh with what every view
/// of it shares (its normals and curvature, see [`mesh::Prepared`]). Shared (`Arc`) so that the
/// studio keeps it once and each run borrows it.
#[derive(Clone, Debug)]
pub enum Input {
    Picture(Arc<Gray>),
    Mesh(Arc<mesh::Prepared>),
}

/// The input rendered: a picture is its own rendering; a mesh is drawn from its view and light.
#[derive(Clone, Debug)]
pub enum Source {
    Picture(Arc<Gray>),
    Mesh(Arc<mesh::Rendering>),
}

impl Source {
    /// Width and height in pixels (before supersampling).
    pub fn size(&self) -> (u32, u32) {
        match self {
            Source::Picture(g) => (g.width, g.height),
            Source::Mesh(r) => (r.gray.width, r.gray.height),
        }
    }
}

/// Stage 0: read the input (bounded: a picture's header is checked against the pixel limit
/// before decoding).
pub fn load(input: &Path, p: &SourceParams) -> Result<Input, Error> {
    Ok(match p {
        SourceParams::Picture { max_pixels, .. } => {
            Input::Picture(Arc::new(load_gray(input, *max_pixels)?))
        }
        SourceParams::Mesh(_) => Input::Mesh(Arc::new(mesh::Prepared::new(
            mesh::load(input).map_err(tone::ToneError::from)?,
        ))),
    })
}

/// Stage 1: the mesh drawn from its view and light ([`draw`] then [`light`]); a picture adjusted
/// (cropped, turned, its tones and detail changed; see [`tone::Adjust`]), or passed through when
/// no adjustment was asked.
pub fn render(input: &Input, p: &SourceParams) -> Result<Source, Error> {
    let drawn = draw(input, p)?;
    light(input, drawn.as_deref(), p)
}

/// Stage 1a: a mesh's view before it is lit (raster, surfaces, lines); `None` for a picture.
pub fn draw(input: &Input, p: &SourceParams) -> Result<Option<Arc<mesh::Drawn>>, Error> {
    Ok(match (input, p) {
        (Input::Mesh(m), SourceParams::Mesh(cfg)) => {
            Some(Arc::new(mesh::draw(m, cfg).map_err(tone::ToneError::from)?))
        }
        (Input::Picture(_), _) => None,
        (Input::Mesh(_), SourceParams::Picture { .. }) => {
            unreachable!("SourceParams::of gives a mesh its mesh settings")
        }
    })
}

/// Stage 1b: the drawn view lit (a picture passes through).
pub fn light(
    input: &Input,
    drawn: Option<&mesh::Drawn>,
    p: &SourceParams,
) -> Result<Source, Error> {
    Ok(match (input, drawn, p) {
        (Input::Picture(g), _, SourceParams::Picture { adjust, .. }) if !adjust.is_identity() => {
            Source::Picture(Arc::new(adjust.apply(g)))
        }
        (Input::Picture(g), _, _) => Source::Picture(g.clone()),
        (Input::Mesh(_), Some(d), SourceParams::Mesh(cfg)) => {
            Source::Mesh(Arc::new(mesh::light(d, cfg)))
        }
        (Input::Mesh(_), _, _) => {
            unreachable!("a mesh is drawn with its mesh settings before it is lit")
        }
    })
}

impl SourceParams {
    /// The part of a mesh's settings its [`draw`] reads: everything but the light (`None` for
    /// a picture). Equal keys draw the same view, so the studio re-lights a kept one.
    pub fn view_key(&self) -> Option<MeshConfig> {
        match self {
            SourceParams::Picture { .. } => None,
            SourceParams::Mesh(m) => Some(MeshConfig {
                light: [0.0; 3],
                ambient: 0.0,
                fill: 0.0,
                specular: 0.0,
                shininess: 1.0,
                ..m.clone()
            }),
        }
    }
}

/// What `make` computed, before anything is written.
pub struct Made {
    /// The picture thresholded, before the clean-up (what fidelity is measured against).
    pub picture: BitGrid,
    /// After the topological filter, before bridges.
    pub twotone: TwoTone,
    pub filter: FilterStats,
    pub bridged: Bridged,
    pub scale: Scale,
    /// The stencil in millimetres (cut loops for G-code, material, bridges).
    pub geometry: CutGeometry,
    pub check: CheckReport,
    pub report: Report,
    /// The G-code text, when asked for.
    pub gcode: Option<String>,
    /// Pixels of the islands dropped instead of bridged (the preview colours them).
    pub dropped_px: Vec<u32>,
}

/// Vectorise a stencil and check it against a material (shared by `make` and `stencil check`).
/// `bridges_px`: bridge outlines in pixels, or `None` when unknown (a bare PNG). The kerf is not
/// applied (see [`vector::vectorize_design`]).
pub fn vectorize_and_check(
    bits: &BitGrid,
    bridges_px: Option<&[Vec<[f64; 2]>]>,
    vcfg: &VectorConfig,
    material: &Material,
    timer: &mut Timings,
) -> Result<(CutGeometry, vector::VectorStats, CheckReport), Error> {
    let (geom, vstats, mut chk) = vectorize_and_measure(bits, bridges_px, vcfg, material, timer)?;
    confirm(&mut chk, bits, vcfg, timer);
    Ok((geom, vstats, chk))
}

/// [`vectorize_and_check`] without the raster cross-check of the violations (see [`confirm`]).
fn vectorize_and_measure(
    bits: &BitGrid,
    bridges_px: Option<&[Vec<[f64; 2]>]>,
    vcfg: &VectorConfig,
    material: &Material,
    timer: &mut Timings,
) -> Result<(CutGeometry, vector::VectorStats, CheckReport), Error> {
    let (geom, vstats) = timer.time("vector", || {
        vector::vectorize_design(bits, bridges_px.unwrap_or(&[]), vcfg)
    })?;
    // The check runs on the geometry as designed (before kerf).
    let chk = timer.time("check", || {
        check::check(&geom, material, bridges_px.is_some())
    });
    Ok((geom, vstats, chk?))
}

/// Confirm each violation on the raster (for the report), when there are any.
fn confirm(chk: &mut CheckReport, bits: &BitGrid, vcfg: &VectorConfig, timer: &mut Timings) {
    if !chk.passed() {
        timer.time("check_opening", || {
            check::cross_check(chk, bits, vcfg.scale)
        });
    }
}

// ---- the stages ---------------------------------------------------------------------------------

/// Stage 2: the gray at the working resolution (a picture upsampled by the factor; a mesh's
/// rendering as drawn). Shared: every two-tone made of it carries it (see [`TwoTone`]).
pub fn working_gray(source: Source, factor: u32) -> Arc<Gray> {
    match source {
        // Upsampling by 1 would only copy the picture.
        Source::Picture(g) if factor > 1 => Arc::new(tone::image::upsample(&g, factor)),
        Source::Picture(g) => g,
        Source::Mesh(r) => Arc::new(r.gray.clone()),
    }
}

/// Stage 3: the two-tone and the level used (Otsu's, when asked for). A mesh's lines are cut
/// and its background material whatever the level (see [`mesh::two_tone`]).
pub fn threshold(source: &Source, gray: Arc<Gray>, p: &ToneParams) -> (TwoTone, u8) {
    let (mut two, level) = match source {
        Source::Picture(_) => tone::threshold(gray, p.threshold, p.invert),
        Source::Mesh(r) => mesh::two_tone_with(r, gray, p.threshold, p.invert),
    };
    if let Some(c) = p.keep_circle_px {
        keep_circle(&mut two, c, p.invert);
    }
    (two, level)
}

/// Outside the circle (cx, cy, r) in pixels, metal: a cropped gobo's image area is all the
/// fixture projects, so the picture beyond it goes. The gray is set to the tone that thresholds
/// as material too, so the clean-up (which rereads it) keeps it so.
fn keep_circle(two: &mut TwoTone, [cx, cy, r]: [f64; 3], invert: bool) {
    let metal_gray = if invert { 0.0 } else { 1.0 };
    let w = two.bits.width;
    // A copy only when the gray is shared (the studio keeps it for other levels).
    let gray = Arc::make_mut(&mut two.gray);
    for y in 0..two.bits.height {
        for x in 0..w {
            if (x as f64 + 0.5 - cx).hypot(y as f64 + 0.5 - cy) > r {
                two.bits.set(x, y, true);
                gray.set(x, y, metal_gray);
            }
        }
    }
}

/// Stage 3b: the picture's side of the likeness measure ([`tone::Likeness`]), of the gray the
/// two-tone carries (`raw.gray`, see [`ToneParams::gray_key`]): the clean-up measures every
/// two-tone it makes of that gray against it, so it is made once per gray, not per level.
pub fn look(raw: &TwoTone) -> tone::Likeness {
    tone::Likeness::of(&raw.gray)
}

/// The two-tone after the clean-up, and what the clean-up measured.
#[derive(Clone, Debug)]
pub struct Cleaned {
    /// The picture thresholded, before the clean-up (what fidelity is measured against).
    pub picture: BitGrid,
    pub twotone: TwoTone,
    pub level: u8,
    pub filter_stats: FilterStats,
    pub reg_stats: Option<crate::tone::regularize::RegularizeStats>,
    /// How much the cleaned two-tone looks like the gray picture ([`tone::likeness()`]).
    pub likeness: f64,
    /// How `--threshold auto` chose the level.
    pub choice: Option<tone::LevelChoice>,
}

/// The clean-up of `bits` (the gray thresholded at `level`): the regularisation, or the filter.
fn clean_bits(
    bits: &BitGrid,
    gray: &Gray,
    level: u8,
    p: &CleanParams,
) -> (
    BitGrid,
    FilterStats,
    Option<crate::tone::regularize::RegularizeStats>,
) {
    match p.regularize_px {
        Some(min_width_px) => {
            let rcfg = RegularizeConfig {
                min_width_px,
                threshold: level as f32 / 255.0,
                invert: p.invert,
            };
            let (bits, stats) = regularize(bits, gray, &rcfg);
            (bits, FilterStats::default(), Some(stats))
        }
        None => {
            let (bits, stats) = filter::filter(bits, &p.filter);
            (bits, stats, None)
        }
    }
}

/// Above this many working pixels, `--threshold auto` searches on the gray box-averaged to about
/// this size (the clean-up's widths scaled alike), then measures the finalists at full size.
pub const AUTO_SEARCH_PIXELS: u64 = 1_000_000;

/// `--threshold auto`: the level whose cleaned-up two-tone is likeliest ([`tone::likeness`]).
/// Every eighth level from 16 to 240, 128 and Otsu's level are tried through the clean-up, then
/// the levels within 6 of the best in steps of 2. On a picture above [`AUTO_SEARCH_PIXELS`] the
/// search runs on a reduced copy and the two best, 128 and Otsu's level are measured again at
/// full size; the full-size measure decides. 128 and Otsu's level are always among those
/// measured, so the level chosen is at least as likely as either by the same measure.
fn choose_level(gray: &Gray, look: &tone::Likeness, p: &CleanParams) -> (u8, tone::LevelChoice) {
    let otsu = tone::otsu_level(gray);
    let pixels = gray.width as u64 * gray.height as u64;
    let d = if pixels > AUTO_SEARCH_PIXELS {
        ((pixels as f64 / AUTO_SEARCH_PIXELS as f64).sqrt().ceil()) as u32
    } else {
        1
    };
    let (small, small_look, sp) = if d > 1 {
        let g = crate::raster::box_average(gray.width, gray.height, d, |i| gray.data[i]);
        let l = tone::Likeness::of(&g);
        let sp = CleanParams {
            regularize_px: p.regularize_px.map(|w| (w / d as f64).max(1.0)),
            filter: FilterConfig {
                radius: p.filter.radius.div_ceil(d),
                min_speck_px: (p.filter.min_speck_px / (d * d) as usize).max(1),
                ..p.filter
            },
            ..*p
        };
        (Cow::Owned(g), Cow::Owned(l), sp)
    } else {
        (Cow::Borrowed(gray), Cow::Borrowed(look), *p)
    };
    let measure = |g: &Gray, look: &tone::Likeness, cp: &CleanParams, level: u8| -> f64 {
        let raw = tone::bits_at(g, level, cp.invert);
        let (bits, _, _) = clean_bits(&raw, g, level, cp);
        look.of_bits(&bits, cp.invert)
    };
    let mut tried: Vec<(u8, f64)> = Vec::new();
    let mut levels: Vec<u8> = (16..=240).step_by(8).collect();
    levels.extend([128, otsu]);
    let try_all = |levels: &[u8], tried: &mut Vec<(u8, f64)>| {
        for &l in levels {
            if !tried.iter().any(|t| t.0 == l) {
                tried.push((l, measure(&small, &small_look, &sp, l)));
            }
        }
    };
    try_all(&levels, &mut tried);
    let best = |t: &[(u8, f64)]| {
        t.iter()
            .copied()
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
            .unwrap_or((128, 0.0))
    };
    let b = best(&tried).0;
    let near: Vec<u8> = [-6i32, -4, -2, 2, 4, 6]
        .iter()
        .map(|k| (b as i32 + k).clamp(1, 255) as u8)
        .collect();
    try_all(&near, &mut tried);
    let mut at_full = tried.clone();
    if d > 1 {
        let mut order = tried.clone();
        order.sort_by(|a, b| b.1.total_cmp(&a.1));
        let mut finalists: Vec<u8> = order.iter().take(2).map(|t| t.0).collect();
        finalists.extend([128, otsu]);
        finalists.dedup();
        at_full = Vec::new();
        for l in finalists {
            if !at_full.iter().any(|t: &(u8, f64)| t.0 == l) {
                at_full.push((l, measure(gray, look, p, l)));
                tried.push((l, at_full.last().map_or(0.0, |t| t.1)));
            }
        }
    }
    let (level, like) = best(&at_full);
    let at = |l: u8| at_full.iter().find(|t| t.0 == l).map_or(0.0, |t| t.1);
    (
        level,
        tone::LevelChoice {
            level,
            likeness: like,
            likeness_128: at(128),
            otsu_level: otsu,
            likeness_otsu: at(otsu),
            tried,
        },
    )
}

/// Stage 4: the clean-up the material needs: the design-rule regularisation to its smallest
/// feature, or the morphological filter with an explicit radius. With `--threshold auto` (a
/// picture), the level is chosen here, judged on the cleaned-up result (`choose_level`), and
/// `raw` is thresholded again at it. `look` is [`look`] of `raw`.
pub fn clean(raw: TwoTone, level: u8, p: &CleanParams, look: &tone::Likeness) -> Cleaned {
    let mut cleaned = clean_unmeasured(raw, level, p, look);
    cleaned.likeness = measure(&cleaned, p, look);
    cleaned
}

/// [`clean`] but for the likeness of its result, left NaN: [`measure`] gives it. Nothing after
/// the clean-up reads the likeness (the report only shows it), so the studio measures it beside
/// the walks that follow rather than before them.
pub fn clean_unmeasured(
    raw: TwoTone,
    level: u8,
    p: &CleanParams,
    look: &tone::Likeness,
) -> Cleaned {
    let (picture, level, choice) = if p.auto {
        let (l, choice) = choose_level(&raw.gray, look, p);
        (tone::bits_at(&raw.gray, l, p.invert), l, Some(choice))
    } else {
        (raw.bits, level, None)
    };
    let (bits, filter_stats, reg_stats) = clean_bits(&picture, &raw.gray, level, p);
    Cleaned {
        picture,
        twotone: TwoTone {
            bits,
            gray: raw.gray,
        },
        level,
        filter_stats,
        reg_stats,
        likeness: f64::NAN,
        choice,
    }
}

/// The likeness of a [`clean_unmeasured`] result (`look` is the one it was cleaned with): what
/// [`clean`] puts in [`Cleaned::likeness`].
pub fn measure(cleaned: &Cleaned, p: &CleanParams, look: &tone::Likeness) -> f64 {
    look.of_bits(&cleaned.twotone.bits, p.invert)
}

/// The islands of the cleaned two-tone joined to the frame, and what went into it.
#[derive(Clone, Debug)]
///
/// The two-tone, the islands and the dropped pixels are [`Prepared`]'s, shared rather than
/// copied: the studio keeps the prepared stage while a person tries weights, and copying them
/// (a 1-megapixel gray, two-tone and label grid) cost a bridge-weight change more than drawing
/// the bridges did.
pub struct Joined {
    /// The two-tone the bridges were drawn into (the islands under `min_island_mm2` cut away).
    pub twotone: Arc<TwoTone>,
    /// What the user's `--bridge-at` / keep-out requests became, when there were any.
    pub user: Option<crate::report::UserBridgesReport>,
    /// The islands before bridging.
    pub map: Arc<islands::IslandMap>,
    pub bridged: Bridged,
    /// Islands dropped instead of bridged (see `bridge::drop`), in mm, and their pixels (cut in
    /// `twotone`; the preview shows them in their own colour).
    pub dropped: Vec<bridge::drop::Dropped>,
    pub dropped_px: Arc<Vec<u32>>,
}

/// Stage 5: islands under `min_island_mm2` cut away (they become cut in the two-tone, so the
/// report and the preview count them as material the picture lost), label the islands, bridge
/// them (with the user's places and keep-out areas), then the clean-up around the bridges (the
/// settle and the sealed-pocket fill after the regularisation, else the tidy pass); material the
/// clean-up put in a keep-out area goes again. Refused if anything floats afterwards (a bug, said
/// as such, rather than a stencil in pieces).
///
/// Before bridging, islands whose dropping changes the picture less than their cheapest bridge
/// are dropped (they become cut, as `--min-island-mm2`'s do) unless `p.drop_islands` is off;
/// `level` is the threshold the two-tone was cut at (what the change is priced against).
pub fn join(
    twotone: TwoTone,
    level: u8,
    p: &JoinParams,
    timer: &mut Timings,
) -> Result<Joined, Error> {
    let prepared = prepare(twotone, level, p, timer)?;
    let bridged = bridge_drawn(&prepared, p, timer)?;
    let Prepared {
        twotone,
        user,
        map,
        dropped,
        dropped_px,
        walks: _,
    } = prepared;
    Ok(Joined {
        twotone,
        user,
        map,
        bridged,
        dropped,
        dropped_px,
    })
}

/// What [`join`] chooses its bridges from: the two-tone with the small and the dropped islands
/// cut away, its islands and their walks. None of it reads the bridge weights, the support
/// margin or the strength rules, so the studio keeps it while a person tries weights (see
/// [`Prepared::key`]).
#[derive(Clone, Debug)]
pub struct Prepared {
    pub twotone: Arc<TwoTone>,
    pub user: Option<crate::report::UserBridgesReport>,
    pub map: Arc<islands::IslandMap>,
    pub dropped: Vec<bridge::drop::Dropped>,
    pub dropped_px: Arc<Vec<u32>>,
    pub walks: bridge::Walks,
}

impl Prepared {
    /// The parameters a [`Prepared`] depends on: `p` with what only the choice of bridges
    /// reads (the weights, the support margin, the strength rules) set to their defaults.
    pub fn key(p: &JoinParams) -> JoinParams {
        JoinParams {
            bridge: bridge::Walks::key(&p.bridge),
            ..p.clone()
        }
    }
}

/// [`join`]'s first half: islands under `min_island_mm2` cut away, the islands cheaper to drop
/// than to bridge dropped, the islands labelled and walked from.
pub fn prepare(
    mut twotone: TwoTone,
    level: u8,
    p: &JoinParams,
    timer: &mut Timings,
) -> Result<Prepared, Error> {
    let user = timer.time("user_bridges", || cut_small_islands(&mut twotone, p));
    let (dropped, dropped_px, map) = if p.drop_islands {
        let (dropped, px, map, gone) = timer.time("drop", || drop_islands(&mut twotone, level, p));
        // The map after the drop, from the one the drop chose by (no second labelling).
        let map = timer.time("islands", || islands::without(map, &gone));
        (dropped, px, map)
    } else {
        let map = timer.time("islands", || islands::label(&twotone.bits));
        (Vec::new(), Vec::new(), map)
    };
    let walks = timer.time("bridge", || {
        let mut t = Timings::default();
        bridge::walk(&twotone, &map, &p.bridge, &mut t)
    })?;
    Ok(Prepared {
        twotone: Arc::new(twotone),
        user,
        map: Arc::new(map),
        dropped,
        dropped_px: Arc::new(dropped_px),
        walks,
    })
}

/// [`join`]'s second half: the bridges chosen from `prepared` (made by [`prepare`] for the same
/// [`Prepared::key`]) and drawn, the clean-up around them, and the check that nothing floats.
/// `prepared` is only read (the studio keeps it for the next weights): the result shares its
/// two-tone, islands and dropped pixels (and copies the few dropped islands' descriptions), and
/// its walks are lent, not copied.
pub fn bridge_prepared(
    prepared: &Prepared,
    p: &JoinParams,
    timer: &mut Timings,
) -> Result<Joined, Error> {
    let bridged = bridge_drawn(prepared, p, timer)?;
    Ok(Joined {
        twotone: Arc::clone(&prepared.twotone),
        user: prepared.user.clone(),
        map: Arc::clone(&prepared.map),
        bridged,
        dropped: prepared.dropped.clone(),
        dropped_px: Arc::clone(&prepared.dropped_px),
    })
}

/// [`bridge_prepared`]'s work: the bridges chosen and drawn, the clean-up, the check.
fn bridge_drawn(
    prepared: &Prepared,
    p: &JoinParams,
    timer: &mut Timings,
) -> Result<Bridged, Error> {
    let (twotone, map) = (&prepared.twotone, &prepared.map);
    let mut bridged = timer.time("bridge", || {
        let mut t = Timings::default();
        bridge::connect_walked(twotone, map, &p.bridge, &prepared.walks, &mut t)
    })?;
    timer.time("tidy", || match p.settle_px {
        Some(px) => {
            // The regularised two-tone has nothing thin: what is thin now, a bridge made, within
            // a disc span of what it drew. So the settle runs around the bridges only (a span
            // past what they drew, changing up to two spans farther), not over the picture.
            let span = px.ceil() as u32 + 1;
            let (w, h) = (bridged.bits.width, bridged.bits.height);
            let boxes: Vec<[u32; 4]> = bridged
                .drawn_boxes()
                .into_iter()
                .map(|b| {
                    [
                        b[0].saturating_sub(span),
                        b[1].saturating_sub(span),
                        (b[2] + span).min(w),
                        (b[3] + span).min(h),
                    ]
                })
                .collect();
            settle_near(&mut bridged.bits, &boxes, px, JOIN_SPREAD);
            fill_sealed_pockets(&twotone.bits, &mut bridged.bits);
        }
        None => {
            bridged.bits = bridge::tidy::tidy(&twotone.bits, &bridged.bits, p.tidy_radius);
        }
    });
    // The clean-up may round a bridge's corners into a keep-out area: what it added there goes.
    if let Some(f) = &p.bridge.user.keep_out {
        for (i, b) in bridged.bits.data.iter_mut().enumerate() {
            if *b && f.data[i] && !twotone.bits.data[i] {
                *b = false;
            }
        }
    }
    // Counted from what the bridges and the clean-up added (they only add), labelled only when
    // something floats (to say where).
    let floating = timer.time("verify", || {
        islands::floating_after_adding(map, &twotone.bits, &bridged.bits)
    });
    if floating > 0 {
        let after = islands::label(&bridged.bits);
        let node = &after.nodes[1];
        let (x, y) = node.border.first().copied().unwrap_or((0, 0));
        return Err(Error::Floating {
            count: after.island_count(),
            x,
            y,
            area: node.area,
        });
    }
    Ok(bridged)
}

/// Drop the islands that are cheaper to drop than to bridge (`bridge::drop::choose`), never one
/// a `--bridge-at` point asks for (the island under the point, or the nearest). Returns them in
/// mm, their pixels, the island map of the bits before the drop and which of its nodes went
/// (for [`islands::without`]).
#[allow(clippy::type_complexity)]
fn drop_islands(
    two: &mut TwoTone,
    level: u8,
    p: &JoinParams,
) -> (
    Vec<bridge::drop::Dropped>,
    Vec<u32>,
    islands::IslandMap,
    Vec<bool>,
) {
    let map = islands::label(&two.bits);
    if map.island_count() == 0 {
        return (Vec::new(), Vec::new(), map, Vec::new());
    }
    let mut protected = vec![false; map.nodes.len()];
    for &[ax, ay] in &p.bridge.user.at {
        // The island under the point, else the one with the nearest border pixel.
        let (x, y) = (ax.max(0.0) as u32, ay.max(0.0) as u32);
        let under = (x < map.width && y < map.height)
            .then(|| map.label(x, y))
            .filter(|&l| l != islands::CUT && l != islands::FRAME);
        let nearest = under.or_else(|| {
            map.nodes
                .iter()
                .enumerate()
                .skip(1)
                .flat_map(|(n, node)| node.border.iter().map(move |&b| (n, b)))
                .min_by(|a, b| {
                    let d =
                        |(bx, by): (u32, u32)| (bx as f64 + 0.5 - ax).hypot(by as f64 + 0.5 - ay);
                    d(a.1).total_cmp(&d(b.1))
                })
                .map(|(n, _)| n as u32)
        });
        if let Some(n) = nearest {
            protected[n as usize] = true;
        }
    }
    let (lo, hi) = (
        p.bridge.min_width_px,
        p.bridge.max_width_px.max(p.bridge.min_width_px),
    );
    let chosen = bridge::drop::choose(&map, &two.gray, level, &protected, |area| {
        ((area as f64).sqrt() / 4.0)
            .ceil()
            .clamp(lo as f64, hi as f64) as u32
    });
    let mm = p.mm_per_px;
    let mut gone = vec![false; map.nodes.len()];
    let mut out = Vec::with_capacity(chosen.len());
    for (n, mut d) in chosen {
        gone[n as usize] = true;
        d.at_mm = [d.at_mm[0] * mm, d.at_mm[1] * mm];
        d.area_mm2 *= mm * mm;
        out.push(d);
    }
    // The dropped islands' pixels become cut, found from their runs (their area, not a pass over
    // the picture), listed in pixel order.
    let w = map.width as usize;
    let mut px: Vec<u32> = Vec::new();
    for n in (0..gone.len()).filter(|&n| gone[n]) {
        for (y, x0, x1) in map.island_runs(n) {
            let row = y as usize * w;
            two.bits.data[row + x0 as usize..=row + x1 as usize].fill(false);
            px.extend(row as u32 + x0..=row as u32 + x1);
        }
    }
    px.sort_unstable();
    (out, px, map, gone)
}

/// Islands under `min_island_mm2` cut away, and the report of the user's bridge options.
fn cut_small_islands(
    two: &mut TwoTone,
    p: &JoinParams,
) -> Option<crate::report::UserBridgesReport> {
    let u = p.user.as_ref()?;
    let mm = u.mm_per_px;
    let mut report = crate::report::UserBridgesReport {
        min_island_mm2: u.min_island_mm2,
        kept_out_px: p.kept_out_px,
        ..Default::default()
    };
    if u.min_island_mm2 > 0.0 {
        let map = islands::label(&two.bits);
        let small: Vec<bool> = map
            .nodes
            .iter()
            .enumerate()
            .map(|(n, node)| {
                n as u32 != islands::FRAME && (node.area as f64) * mm * mm < u.min_island_mm2
            })
            .collect();
        for (i, &l) in map.labels.iter().enumerate() {
            if l != islands::CUT && small[l as usize] {
                two.bits.data[i] = false;
                report.cut_away_mm2 += mm * mm;
            }
        }
        report.islands_cut_away = small.iter().filter(|&&s| s).count();
    }
    Some(report)
}

/// What the vector stage and the check made.
#[derive(Clone, Debug)]
pub struct Traced {
    /// The stencil in millimetres, before the kerf.
    pub geometry: CutGeometry,
    pub vstats: vector::VectorStats,
    pub check: CheckReport,
    pub fidelity: Fidelity,
}

/// Stage 6: trace and check (see `trace_and_repair`), recount each bridge's pixels and measure
/// the fidelity on the stencil as it will be written. `bridged` becomes the stencil as it will be
/// written (the neck repairs, each bridge's pixels recounted); `twotone` is what the bridges were
/// drawn into, `picture` the thresholded picture before the clean-up.
pub fn trace(
    bridged: &mut Bridged,
    twotone: &BitGrid,
    picture: &BitGrid,
    p: &TraceParams,
    timer: &mut Timings,
) -> Result<Traced, Error> {
    let (geometry, vstats, check) = trace_and_repair(bridged, p, timer)?;
    let apart = timer.time("recount", || bridged.recount(twotone));
    let fidelity = timer.time("fidelity", || {
        Fidelity::measure(picture, twotone, &bridged.bits).with_apart_from_bridges(apart)
    });
    Ok(Traced {
        geometry,
        vstats,
        check,
        fidelity,
    })
}

/// `make`'s end from the stage outputs it made and holds alone (shared ones are copied): the
/// trace and check, the refusal, the G-code and the report (`driver::run`).
pub(crate) fn finish_owned(
    cfg: &MakeConfig,
    params: &StageParams,
    cleaned: Arc<Cleaned>,
    joined: Arc<Joined>,
    timer: Timings,
) -> Result<Made, Error> {
    let cleaned = Arc::unwrap_or_clone(cleaned);
    finish(cfg, params, cleaned, Arc::unwrap_or_clone(joined), timer)
}

/// From the bridges on to the report: trace and check, refuse what `make` refuses, the G-code.
fn finish(
    cfg: &MakeConfig,
    params: &StageParams,
    cleaned: Cleaned,
    mut joined: Joined,
    mut timer: Timings,
) -> Result<Made, Error> {
    let mut traced = trace(
        &mut joined.bridged,
        &joined.twotone.bits,
        &cleaned.picture,
        &params.trace,
        &mut timer,
    )?;
    refuse(&cfg.physical, traced.fidelity, &traced.check)?;
    if let Some(g) = &cfg.physical.gobo {
        crate::gobo::place(&mut traced.geometry, g, params.trace.vector.margin_mm);
    }
    let gcode = match &cfg.gcode {
        Some(g) => Some(gcode(
            cfg,
            g,
            &mut traced.geometry,
            &joined,
            &params.trace,
            &mut timer,
        )?),
        None => None,
    };
    let (gcode, gcode_summary) = gcode.unzip();
    let report = report(
        cfg,
        params,
        &cleaned,
        &joined,
        &traced,
        gcode_summary,
        timer,
    );
    Ok(Made {
        picture: cleaned.picture,
        // `make`'s own join is the only holder (no copy); the studio's kept one is copied.
        twotone: Arc::unwrap_or_clone(joined.twotone),
        filter: cleaned.filter_stats,
        bridged: joined.bridged,
        scale: params.working.scale,
        geometry: traced.geometry,
        check: traced.check,
        report,
        gcode,
        dropped_px: Arc::unwrap_or_clone(joined.dropped_px),
    })
}

/// `make`'s end from stage outputs a caller kept (the studio): the same trace, refusal, G-code
/// and report as [`run`](crate::driver::run), so the files are the same.
pub fn finish_from(
    cfg: &MakeConfig,
    params: &StageParams,
    cleaned: &Cleaned,
    joined: &Joined,
) -> Result<Made, Error> {
    let timer = Timings::new(cfg.progress.clone());
    finish(cfg, params, cleaned.clone(), joined.clone(), timer)
}

/// Vectorise and check, widening the necks the check still finds (see [`widen_necks`]). The raster rule holds exactly; the traced and simplified
/// outline may still measure a neck up to about a pixel narrower (a diagonal staircase,
/// simplification within the tolerance). After the regularisation (`repair`), such necks are
/// widened where the check found them and the stencil traced again, up to [`REPAIR_ROUNDS`]
/// times; then the check's findings are confirmed on the raster.
fn trace_and_repair(
    bridged: &mut Bridged,
    p: &TraceParams,
    timer: &mut Timings,
) -> Result<(CutGeometry, vector::VectorStats, CheckReport), Error> {
    let polys: Vec<Vec<[f64; 2]>> = bridged.bridges.iter().map(|b| b.polygon.clone()).collect();
    let mut repairs = 0;
    let (geometry, vstats, mut chk) = loop {
        let measured =
            vectorize_and_measure(&bridged.bits, Some(&polys), &p.vector, &p.material, timer)?;
        if !p.repair || measured.2.passed() || repairs == REPAIR_ROUNDS {
            break measured;
        }
        repairs += 1;
        if !timer.time("repair", || {
            widen_necks(
                &mut bridged.bits,
                &measured.2,
                &p.material,
                p.vector.scale,
                repairs,
            )
        }) {
            break measured;
        }
    };
    confirm(&mut chk, &bridged.bits, &p.vector, timer);
    Ok((geometry, vstats, chk))
}

/// Refuse a stencil that strays from the picture more than `--max-change` allows, or that the
/// material cannot hold (unless thin features are allowed).
pub fn refuse(phys: &PhysicalConfig, fidelity: Fidelity, chk: &CheckReport) -> Result<(), Error> {
    if let Some(limit_pct) = phys.max_change_pct {
        if fidelity.changed_pct > limit_pct {
            return Err(Error::TooMuchChange {
                fidelity,
                limit_pct,
            });
        }
    }
    if !chk.passed() && !phys.allow_thin {
        return Err(Error::Thin {
            material: phys.material.name.clone(),
            violations: chk.violations.clone(),
        });
    }
    Ok(())
}

/// The G-code and its summary: the pieces that stay unbridged cut out whole (when there were
/// islands), the kerf applied, then the G-code crate's planner and writer on the cut loops.
pub fn gcode(
    cfg: &MakeConfig,
    g: &stencil_gcode::GcodeConfig,
    geometry: &mut CutGeometry,
    joined: &Joined,
    p: &TraceParams,
    timer: &mut Timings,
) -> Result<(String, stencil_gcode::GcodeSummary), Error> {
    let mut notes = vec![
        format!("from {}", cfg.input.display()),
        format!("material {}", p.material.name),
    ];
    if !g.settings_from.is_empty() {
        notes.push(format!("cut settings from {}", g.settings_from));
    }
    if joined.map.island_count() > 0 {
        timer.time("pieces", || {
            geometry.set_unbridged(&joined.twotone.bits, &p.vector)
        })?;
    }
    timer.time("kerf", || geometry.apply_kerf(p.material.kerf_mm))?;
    let (text, mut summary) = timer.time("gcode", || {
        stencil_gcode::gcode_for(&geometry.loops(), &g.machine, &g.plan, &notes)
    })?;
    summary.settings_from = (!g.settings_from.is_empty()).then(|| g.settings_from.clone());
    Ok((text, summary))
}

/// report.json's contents (the files written are added by [`make`](crate::driver::make)).
pub fn report(
    cfg: &MakeConfig,
    params: &StageParams,
    cleaned: &Cleaned,
    joined: &Joined,
    traced: &Traced,
    gcode: Option<stencil_gcode::GcodeSummary>,
    timer: Timings,
) -> Report {
    let phys = &cfg.physical;
    Report {
        gcode,
        gobo: phys
            .gobo
            .as_ref()
            .map(|g| crate::gobo::report(&traced.geometry, g, cfg.tone.invert)),
        width_mm: Some(traced.geometry.width_mm),
        height_mm: Some(traced.geometry.height_mm),
        vector: Some(traced.vstats),
        check: Some(traced.check.clone()),
        fidelity: Some(traced.fidelity),
        ..report_joined(cfg, params, cleaned, joined, timer)
    }
}

/// The part of [`report`] known before the trace: everything but the size in mm, the vector
/// statistics, the check, the fidelity, the gobo's and the job time (the studio shows it with
/// the preview, and the rest a moment later).
pub fn report_joined(
    cfg: &MakeConfig,
    params: &StageParams,
    cleaned: &Cleaned,
    joined: &Joined,
    timer: Timings,
) -> Report {
    let phys = &cfg.physical;
    let working = &params.working;
    let scale = working.scale;
    let (bridged, bridge_cfg) = (&joined.bridged, &params.join.bridge);
    let vcfg = &params.trace.vector;
    Report {
        gcode: None,
        // Filled when the masks are encoded (`encode_outputs`).
        mask: None,
        gobo: None,
        material: Some(phys.material.name.clone()),
        material_source: Some(phys.material_source.clone()),
        material_values: Some(phys.material.values()),
        mm_per_px: Some(scale.mm_per_px),
        scale_factor: Some(working.factor),
        scale_auto: working.auto,
        width_mm: None,
        height_mm: None,
        margin_mm: Some(vcfg.margin_mm),
        tolerance_mm: Some(vcfg.tolerance_mm),
        arcs: Some(vcfg.arcs),
        min_bridge_px: Some(bridge_cfg.min_width_px),
        max_bridge_px: Some(bridge_cfg.max_width_px),
        filter_radius_px: Some(params.clean.filter.radius),
        vector: None,
        check: None,
        files: Vec::new(),
        input: cfg.input.display().to_string(),
        width_px: joined.twotone.bits.width,
        height_px: joined.twotone.bits.height,
        threshold_level: Some(cleaned.level),
        likeness: Some(cleaned.likeness),
        threshold_choice: cleaned.choice.clone(),
        dropped_islands: (!joined.dropped.is_empty()).then(|| joined.dropped.clone()),
        filter: cleaned.filter_stats,
        regularize: cleaned.reg_stats,
        islands: joined.map.island_count(),
        bridges: bridged
            .bridges
            .iter()
            .map(|b| BridgeReport {
                width_mm: Some(b.width_px as f64 * scale.mm_per_px),
                ..b.into()
            })
            .collect(),
        strength: Some(bridge::strength::StrengthReport::new(
            bridged.strength.clone(),
            &bridge_cfg.strength,
        )),
        user_bridges: joined.user.clone().map(|mut u| {
            let mm = scale.mm_per_px;
            u.bridge_at = bridged
                .requests
                .iter()
                .map(|r| crate::report::BridgeAtReport {
                    at_mm: [r.at_px[0] * mm, r.at_px[1] * mm],
                    island: r.island,
                    start_mm: r.start_px.map(|p| [p[0] * mm, p[1] * mm]),
                    distance_mm: r.distance_px.map(|d| d * mm),
                })
                .collect();
            u
        }),
        // `join` refuses a stencil with anything floating.
        floating_after: 0,
        fidelity: None,
        timings_ms: timer.into_map(),
    }
}

/// Files `make` writes, by name, encoded in memory: the ones `emit` asks for, then report.json
/// (which lists them). The masks' description goes into `made.report` as they are encoded.
pub(crate) fn encode_outputs(
    made: &mut Made,
    phys: &PhysicalConfig,
) -> Result<Vec<(String, Vec<u8>)>, Error> {
    let tt = &made.twotone;
    let geom = &made.geometry;
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    if phys.emit.png && is_mesh(Path::new(&made.report.input)) {
        // The grayscale rendering: what the bridge cost's intensity term reads.
        files.push((
            "gray.png".into(),
            png::encode_gray(tt.gray.width, tt.gray.height, &tt.gray.to_u8()),
        ));
    }
    if phys.emit.png {
        files.push(("twotone.png".into(), png::encode_bits(&tt.bits)));
        files.push(("stencil.png".into(), png::encode_bits(&made.bridged.bits)));
        files.push((
            "preview.png".into(),
            png::preview(
                &tt.gray,
                &made.picture,
                &tt.bits,
                &made.bridged.bits,
                &made.dropped_px,
            ),
        ));
    }
    if phys.emit.svg {
        files.push((
            "stencil.svg".into(),
            svg::encode(geom, phys.vector.arc_tolerance_mm()),
        ));
    }
    if phys.emit.dxf {
        files.push((
            "stencil.dxf".into(),
            dxf::encode(geom, phys.dxf_r12, phys.vector.arc_tolerance_mm())?,
        ));
    }
    let mut mask_report = None;
    if phys.emit.mask {
        let mut m = phys.mask;
        m.mirror |= phys.material.etch().is_some_and(|e| e.mirror);
        let etch = mask::Etch::of(&phys.material);
        let (masks, r) = mask::mask_files(geom, &m, etch)?;
        files.extend(masks);
        mask_report = Some(r);
    }
    if let Some(text) = &made.gcode {
        files.push(("stencil.gcode".into(), text.as_bytes().to_vec()));
    }
    made.report.mask = mask_report;
    let mut report = made.report.clone();
    report.files = files.iter().map(|(n, _)| n.clone()).collect();
    report.files.push("report.json".into());
    let json = serde_json::to_vec_pretty(&report).map_err(|e| export::ExportError::Encode {
        path: PathBuf::from("report.json"),
        msg: e.to_string(),
    })?;
    files.push(("report.json".into(), json));
    Ok(files)
}

pub use crate::export::OUTPUT_NAMES;

/// What `make` writes for a result computed elsewhere (the studio's kept stages), by `make`'s
/// own rules: the same files, all or nothing, [`OUTPUT_NAMES`] it did not write removed.
pub fn write(cfg: &MakeConfig, made: Made) -> Result<(Made, export::Replaced), Error> {
    write_with(cfg, || Ok(made))
}

/// Write what `compute` makes into `cfg.out_dir` by `make`'s rules: the folder made first (so a
/// run fails before its work), all or nothing, [`OUTPUT_NAMES`] it did not write removed.
pub(crate) fn write_with(
    cfg: &MakeConfig,
    compute: impl FnOnce() -> Result<Made, Error>,
) -> Result<(Made, export::Replaced), Error> {
    let existed = cfg.out_dir.is_dir();
    export::prepare_dir(&cfg.out_dir)?;
    let result = compute().and_then(|mut made| {
        if let Some(p) = &cfg.progress {
            p.stage("write");
        }
        let files = encode_outputs(&mut made, &cfg.physical)?;
        // Every name make owns, a set's layer folders included: a one-layer run leaves none.
        let replaced = export::write_files(&cfg.out_dir, &files, export::owned_names())?;
        Ok((made, replaced))
    });
    if result.is_err() && !existed {
        // Leave no trace of a failed run: the folder we made is empty (remove_dir refuses otherwise).
        let _ = std::fs::remove_dir(&cfg.out_dir);
    }
    result
}

/// The default output folder for an input: `out/<input stem>/`.
pub fn default_out_dir(input: &Path) -> PathBuf {
    let stem = input
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "stencil".into());
    PathBuf::from("out").join(stem)
}
