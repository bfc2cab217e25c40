//! The request ([`MakeConfig`]) and its resolution into each stage's parameters ([`resolve`]);
//! the stages themselves, one file each, in order: [`source`] → [`two_tone`] → [`clean_up`] →
//! [`bridges`] → [`vectors`] → [`outputs`], then [`files`] (all or nothing). The driver runs them.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::bridge::{self, BridgeConfig};
use crate::check;
use crate::export::mask::MaskConfig;
use crate::material::Material;
use crate::raster::{BitGrid, Gray};
use crate::tone::filter::FilterConfig;
use crate::tone::mesh::MeshConfig;
use crate::tone::{self, ToneConfig};
use crate::units::{Mm, Scale};
use crate::vector::VectorConfig;

pub mod bridges;
pub mod clean_up;
pub mod files;
pub mod outputs;
pub mod source;
pub mod two_tone;
pub mod vectors;

pub use bridges::{bridge_prepared, prepare, Joined, Prepared};
pub use clean_up::{clean, clean_unmeasured, measure, Cleaned};
pub use files::{default_out_dir, write, OUTPUT_NAMES};
pub use outputs::{finish, gcode, report, report_joined, Made};
pub use source::{draw, is_mesh_path, light, load, Input, Source};
pub use two_tone::{look, threshold, working_gray};
pub use vectors::{refuse, trace, vectorize_and_check, Traced};

pub use crate::error::Error;

/// Everything `stencil make` needs, as plain data (the CLI builds it; tests build it by hand).
#[derive(Clone, Debug, Default)]
pub struct MakeConfig {
    pub input: PathBuf,
    pub out_dir: PathBuf,
    pub tone: ToneConfig,
    pub mesh: MeshConfig,
    pub filter: FilterConfig,
    pub bridge: BridgeConfig,
    pub physical: PhysicalConfig,
    /// Also plan the G-code job (`--emit gcode`): written as stencil.gcode, summarised in the
    /// report. A job that does not fit the machine's bed fails the run before anything is written.
    pub gcode: Option<stencil_gcode::GcodeConfig>,
    /// Told each stage as it starts (see [`Progress`]).
    pub progress: Option<Arc<dyn Progress>>,
}

pub use crate::timing::{Progress, Timings};
pub use crate::units::Size;

/// Which files `make` writes (report.json always). Default: `png,svg`: the images to look at and
/// the one vector file every laser and plotter program opens; DXF and masks on request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Emit {
    /// twotone.png, stencil.png, preview.png.
    pub png: bool,
    pub svg: bool,
    pub dxf: bool,
    /// mask.png and mask.svg.
    pub mask: bool,
}

impl Default for Emit {
    fn default() -> Self {
        Emit {
            png: true,
            svg: true,
            dxf: false,
            mask: false,
        }
    }
}

/// Physical size, material, vectors, check and export options.
#[derive(Clone, Debug)]
pub struct PhysicalConfig {
    pub size: Size,
    pub material: Material,
    /// Where the material profile came from (for the report).
    pub material_source: String,
    pub vector: VectorConfig,
    /// Write the outputs even when the check finds violations.
    pub allow_thin: bool,
    /// Fail (and write nothing) when the stencil differs from the thresholded picture in more
    /// than this percentage of its pixels (`--max-change`; finite, 0..=100). See
    /// [`crate::report::Fidelity`].
    pub max_change_pct: Option<f64>,
    pub emit: Emit,
    pub mask: MaskConfig,
    pub dxf_r12: bool,
    /// A gobo (`--gobo`): a round sheet, the picture at its centre (`size` is set to fit its
    /// image area), the rim cut (see [`crate::gobo`]).
    pub gobo: Option<crate::gobo::Gobo>,
}

impl Default for PhysicalConfig {
    fn default() -> Self {
        PhysicalConfig {
            size: Size::Default,
            material: Material::default(),
            material_source: format!(
                "<embedded>/materials/{}.toml",
                crate::material::DEFAULT_MATERIAL
            ),
            vector: VectorConfig::default(),
            allow_thin: false,
            max_change_pct: None,
            emit: Emit::default(),
            mask: MaskConfig::default(),
            dxf_r12: false,
            gobo: None,
        }
    }
}

impl PhysicalConfig {
    /// Millimetres per pixel of a `width_px` × `height_px` picture, before supersampling (a
    /// working pixel of a picture supersampled K times is this divided by K; see `Working`).
    /// Refused outside `crate::limits::picture_scale`'s bounds.
    pub fn scale(&self, width_px: u32, height_px: u32) -> Result<Scale, Error> {
        Ok(crate::limits::picture_scale(
            self.size, width_px, height_px,
        )?)
    }

    /// The coarsest working pixel, in mm, that the material and the tolerance accept (the
    /// automatic supersampling's target, `tone::resolution::target_mm_per_px`).
    pub fn target_mm_per_px(&self) -> f64 {
        tone::resolution::target_mm_per_px(self.material.min_feature_mm, self.vector.tolerance_mm)
    }

    /// The check's allowance in pixels (see [`check::allowance_px`]).
    fn allowance_px(&self, scale: Scale) -> f64 {
        check::allowance_px(scale.to_px(Mm(self.vector.tolerance_mm)).0)
    }

    /// The bridge stage's options in pixels from the material's millimetres: never narrower than
    /// `min_bridge_mm` (plus the check's allowance) or the user's `min_width_px` if wider, never
    /// wider than `max_bridge_mm` unless the user set `max_width_px`. The width rule itself,
    /// `⌈√A / 4⌉` px for the smaller island's area A in px², is `√A / 4` mm for its area in mm²
    /// whatever the scale, so with both bounds in millimetres the same design gets bridges of the
    /// same physical width at any size.
    ///
    /// With `allow_thin` and an explicit `max_width_px`, the user's pixel widths are taken as
    /// given: they have asked for bridges of that width and to keep a stencil the check finds
    /// thin (a measurement at fixed pixel widths, such as the corpus's quality comparison).
    ///
    /// The strength rules get the material's stiffness, weight and limits and the scale, keeping
    /// the user's bridges per island.
    pub fn bridge_for(&self, user: &BridgeConfig, scale: Scale) -> BridgeConfig {
        let m = &self.material;
        let strength = bridge::StrengthConfig {
            per_island: user.strength.per_island,
            mm_per_px: scale.mm_per_px,
            thickness_mm: m.thickness_mm,
            youngs_modulus_gpa: m.strength.youngs_modulus_gpa,
            density_kg_m3: m.strength.density_kg_m3,
            max_sag_mm: m.strength.max_sag_mm,
            two_bridges_above_mm: m.strength.two_bridges_above_mm,
        };
        if user.max_width_given && self.allow_thin {
            return BridgeConfig {
                strength,
                ..user.clone()
            };
        }
        let px = (scale.to_px(Mm(self.material.min_bridge_mm)).0 + self.allowance_px(scale)).ceil()
            as u32;
        let min = user.min_width_px.max(px);
        let max = if user.max_width_given {
            user.max_width_px
        } else {
            // A hair under a whole pixel counts as one (1.2 mm / 0.1 mm is 11.99... in floating
            // point).
            (scale.to_px(Mm(self.material.max_bridge_mm)).0 + 1e-6)
                .floor()
                .min(u32::MAX as f64 / 2.0) as u32
        };
        BridgeConfig {
            min_width_px: min,
            max_width_px: max.max(min),
            strength,
            ..user.clone()
        }
    }

    /// The narrowest web or hole the regularisation keeps, in working pixels: the material's
    /// `min_feature_mm` plus one pixel. The raster rule holds exactly, but the traced outline of
    /// a diagonal neck measures up to about a pixel less than its pixels (see `check`'s
    /// discretisation notes); a line already at the minimum is widened by at most that pixel.
    pub fn feature_px(&self, scale: Scale) -> f64 {
        scale.to_px(Mm(self.material.min_feature_mm)).0 + 1.0
    }

    /// The topological filter's options with the material's smallest feature: unless the user set
    /// the radius explicitly, the opening and closing radius is at least half of `min_feature_mm` (plus the allowance) in pixels, so webs
    /// and holes the material cannot hold are removed before bridging instead of failing the
    /// check later (an opening by radius r keeps features at least 2r + 1 pixels wide).
    pub fn filter_for(&self, user: &FilterConfig, scale: Scale) -> FilterConfig {
        let f = scale.to_px(Mm(self.material.min_feature_mm)).0 + self.allowance_px(scale);
        FilterConfig {
            radius: if user.auto_radius {
                user.radius.max((f / 2.0).ceil() as u32)
            } else {
                user.radius
            },
            ..*user
        }
    }
}

/// What loading and rendering the input need, known before its size: a picture's pixel limit, or
/// a mesh's view, light, lines and size (the lines widened to survive the clean-up).
#[derive(Clone, Debug, PartialEq)]
pub enum SourceParams {
    Picture {
        max_pixels: u64,
        /// The adjustments made to the picture as it is rendered (see [`tone::Adjust`]).
        adjust: tone::Adjust,
    },
    Mesh(MeshConfig),
}

impl SourceParams {
    /// Checked as `make` always checked them, before the input is opened: a mesh's settings,
    /// a picture's `--scale` factor.
    pub fn of(cfg: &MakeConfig) -> Result<Self, Error> {
        if is_mesh_path(&cfg.input) {
            let m = mesh_lines_for(cfg);
            m.validate().map_err(tone::ToneError::from)?;
            return Ok(SourceParams::Mesh(m));
        }
        if let Some(k) = cfg.tone.scale {
            if !(1..=tone::resolution::MAX_FACTOR).contains(&k) {
                return Err(tone::ToneError::BadScale(k).into());
            }
        }
        Ok(SourceParams::Picture {
            max_pixels: cfg.tone.max_pixels,
            adjust: cfg.tone.adjust,
        })
    }
}

/// The working resolution: how many times the picture was supersampled, and what a working pixel
/// measures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Working {
    /// Working pixels per input pixel along each axis (1 for a mesh, which renders at its own size).
    pub factor: u32,
    /// How the factor was chosen, when it was automatic (no `--scale`).
    pub auto: Option<tone::resolution::AutoScale>,
    /// Millimetres per working pixel.
    pub scale: Scale,
}

/// The threshold stage's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneParams {
    pub threshold: tone::Threshold,
    pub invert: bool,
    /// A cropped gobo's image area in working pixels (cx, cy, r): outside it, metal.
    pub keep_circle_px: Option<[f64; 3]>,
}

impl ToneParams {
    /// What of these parameters changes the gray the two-tone carries (not only its bits): the
    /// gobo's circle, outside which the gray is set to the metal's tone, and with it `invert`,
    /// which says what that tone is (see [`threshold`]). While this and the working gray stay,
    /// so does the two-tone's gray, and what is made of it alone ([`look`]).
    pub fn gray_key(&self) -> Option<([f64; 3], bool)> {
        self.keep_circle_px.map(|c| (c, self.invert))
    }
}

/// The clean-up's parameters: the design-rule regularisation to `min_width_px`, or (with an
/// explicit radius) the morphological filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CleanParams {
    pub filter: FilterConfig,
    /// The regularisation's narrowest web or hole, px, when it runs (the automatic radius).
    pub regularize_px: Option<f64>,
    pub invert: bool,
    /// `--threshold auto` on a picture: the clean-up searches the level (see [`clean`]).
    pub auto: bool,
}

/// The user's bridge places and keep-out areas in working pixels (see `bridge::constraints`).
#[derive(Clone, Debug, PartialEq)]
pub struct UserParams {
    /// `min_island_mm2` and the scale it is measured at.
    pub min_island_mm2: f64,
    pub mm_per_px: f64,
}

/// The bridge stage's parameters: the bridge options in pixels for this material and scale (the
/// user's places and keep-out grid included), and the clean-up around the bridges.
#[derive(Clone, Debug, PartialEq)]
pub struct JoinParams {
    pub bridge: BridgeConfig,
    /// Set when any of the user's bridge options was given (they are reported).
    pub user: Option<UserParams>,
    /// Pixels a keep-out option forbids (reported).
    pub kept_out_px: usize,
    /// After the regularisation: settle to this width and fill sealed pockets; else tidy with
    /// `tidy_radius`.
    pub settle_px: Option<f64>,
    pub tidy_radius: u32,
    /// Millimetres per working pixel (the dropped islands are reported in mm).
    pub mm_per_px: f64,
    /// Drop an island when that changes the picture less than its cheapest bridge (see
    /// `bridge::drop`); false with `--keep-all-islands`.
    pub drop_islands: bool,
}

/// The vector stage's and the check's parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceParams {
    pub vector: VectorConfig,
    pub material: Material,
    /// Widen the necks the check finds and trace again (after the regularisation).
    pub repair: bool,
}

/// Every stage's parameters after the source, from one [`resolve`]: pixels, not millimetres
/// (the scale is carried for the stages that write millimetres), no paths, nothing left to decide.
#[derive(Clone, Debug, PartialEq)]
pub struct StageParams {
    pub working: Working,
    pub tone: ToneParams,
    pub clean: CleanParams,
    pub join: JoinParams,
    pub trace: TraceParams,
}

/// Resolve the request against the rendered input: the working resolution (the automatic
/// supersampling reads the material), the clean-up's widths, the bridges' widths and the user's
/// places in pixels (the keep-out picture, when given, is read here), the vector settings. The
/// checks `make` makes against the working image are made here, in the same order.
pub fn resolve(cfg: &MakeConfig, source: &Source) -> Result<StageParams, Error> {
    let phys = &cfg.physical;
    let (sw, sh) = source.size();
    let working = match source {
        Source::Mesh(_) => Working {
            factor: 1,
            auto: None,
            scale: phys.scale(sw, sh)?,
        },
        Source::Picture(_) => working_resolution(cfg, sw, sh)?,
    };
    let scale = working.scale;
    let (w, h) = (sw * working.factor, sh * working.factor);
    let filter_cfg = phys.filter_for(&cfg.filter, scale);
    // Options that only make sense against the working image (see `crate::limits`).
    if filter_cfg.auto_radius {
        crate::limits::check_working_pixel(
            phys.size,
            sw,
            scale,
            working.factor,
            cfg.tone.scale.is_some(),
            phys.material.min_feature_mm,
        )?;
    } else {
        crate::limits::check_filter_radius(filter_cfg.radius, w, h)?;
    }
    let regularize_px = filter_cfg.auto_radius.then(|| phys.feature_px(scale));
    let mut bridge_cfg = phys.bridge_for(&cfg.bridge, scale);
    let frame = KeepOutFrame {
        input: &cfg.input,
        adjust: &cfg.tone.adjust,
        stencil_px: (sw, sh),
    };
    let (user, kept_out_px) =
        user_bridges(&mut bridge_cfg, w, h, scale, cfg.tone.max_pixels, &frame)?;
    Ok(StageParams {
        working,
        tone: ToneParams {
            threshold: cfg.tone.threshold,
            invert: cfg.tone.invert,
            keep_circle_px: phys
                .gobo
                .as_ref()
                .filter(|g| g.crop)
                .map(|g| g.image_circle_px(w, h)),
        },
        clean: CleanParams {
            filter: filter_cfg,
            regularize_px,
            invert: cfg.tone.invert,
            auto: cfg.tone.threshold == tone::Threshold::Auto
                && matches!(source, Source::Picture(_)),
        },
        join: JoinParams {
            bridge: bridge_cfg,
            user,
            kept_out_px,
            settle_px: regularize_px,
            tidy_radius: filter_cfg.radius,
            drop_islands: !cfg.bridge.user.keep_all_islands,
            mm_per_px: scale.mm_per_px,
        },
        trace: TraceParams {
            vector: VectorConfig {
                scale,
                kerf_mm: phys.material.kerf_mm,
                ..phys.vector
            },
            material: phys.material.clone(),
            repair: regularize_px.is_some(),
        },
    })
}

/// A picture's working resolution: supersampled by `tone.scale`, or when that is `None` by the
/// smallest factor that makes a working pixel fine enough for the material and the tolerance
/// ([`tone::resolution::auto`]), within the memory budget and `tone.max_pixels`.
fn working_resolution(cfg: &MakeConfig, width: u32, height: u32) -> Result<Working, Error> {
    let (phys, tone) = (&cfg.physical, &cfg.tone);
    let per_input = phys.scale(width, height)?;
    let pixels = u64::from(width) * u64::from(height);
    let (factor, auto) = match tone.scale {
        Some(k) => {
            let (w, h) = (
                u64::from(width) * u64::from(k),
                u64::from(height) * u64::from(k),
            );
            if w * h > tone.max_pixels {
                return Err(tone::ToneError::ScaleTooLarge {
                    path: cfg.input.to_path_buf(),
                    factor: k,
                    width: w,
                    height: h,
                    mp: (w * h) as f64 / 1e6,
                    limit_mp: tone.max_pixels as f64 / 1e6,
                }
                .into());
            }
            (k, None)
        }
        None => {
            let (k, a) = tone::resolution::auto(
                per_input.mm_per_px,
                phys.target_mm_per_px(),
                pixels,
                tone.max_pixels,
            );
            (k, Some(a))
        }
    };
    Ok(Working {
        factor,
        auto,
        scale: Scale {
            mm_per_px: per_input.mm_per_px / f64::from(factor),
        },
    })
}

/// What decides the keep-out picture's frame: the picture it belongs to, its crop and turns, and
/// the stencil's frame in picture pixels (after them, before any supersampling).
struct KeepOutFrame<'a> {
    input: &'a Path,
    adjust: &'a tone::Adjust,
    stencil_px: (u32, u32),
}

impl KeepOutFrame<'_> {
    /// The keep-out picture in the stencil's frame. Two frames are possible once the picture is
    /// cropped or turned: a person painting over the original photo works in the whole picture's
    /// frame, the studio paints over the stencil. The size tells them apart: a keep-out picture
    /// of the whole picture's size (as shown, after its EXIF orientation), when the stencil's
    /// frame has another size, is in the whole picture's frame and is cropped and turned exactly
    /// as the picture is; any other is taken as the stencil's frame (when both frames have one
    /// size, a half turn without a crop, the stencil's). Either is then stretched over the working
    /// image.
    fn place(&self, mask: Gray) -> Gray {
        let a = self.adjust;
        if a.crop_px.is_none() && a.quarter_turns.is_multiple_of(4) {
            return mask;
        }
        let whole = tone::picture_size(self.input).ok();
        let size = (mask.width, mask.height);
        if whole == Some(size) && size != self.stencil_px {
            let frame_only = tone::Adjust {
                crop_px: a.crop_px,
                quarter_turns: a.quarter_turns,
                ..Default::default()
            };
            return frame_only.apply(&mask);
        }
        mask
    }
}

/// The user's bridge options on the working image (see `bridge::constraints`): the keep-out
/// mask and discs made a grid of forbidden pixels, `--bridge-at` points made pixels. Returns what
/// the report needs (`None` when no option was given) and the pixels kept out.
fn user_bridges(
    bridge: &mut BridgeConfig,
    w: u32,
    h: u32,
    scale: Scale,
    max_pixels: u64,
    frame: &KeepOutFrame,
) -> Result<(Option<UserParams>, usize), Error> {
    let u = &mut bridge.user;
    if u.keep_out_mask.is_none()
        && u.no_bridge_near_mm.is_empty()
        && u.at_mm.is_empty()
        && u.min_island_mm2 <= 0.0
    {
        return Ok((None, 0));
    }
    let mm = scale.mm_per_px;
    let mut kept_out = 0;
    if u.keep_out_mask.is_some() || !u.no_bridge_near_mm.is_empty() {
        let mut grid = BitGrid::new(w, h, false);
        if let Some(path) = &u.keep_out_mask {
            let mask = frame.place(crate::tone::image::load_gray(path, max_pixels)?);
            // Nearest sample of the mask at each working pixel's centre.
            for y in 0..h {
                let my = (((y as f64 + 0.5) / h as f64) * mask.height as f64) as u32;
                for x in 0..w {
                    let mx = (((x as f64 + 0.5) / w as f64) * mask.width as f64) as u32;
                    if mask.get(mx.min(mask.width - 1), my.min(mask.height - 1)) < 0.5 {
                        grid.set(x, y, true);
                    }
                }
            }
        }
        for &[cx, cy, r] in &u.no_bridge_near_mm {
            let (cx, cy, r) = (cx / mm, cy / mm, r / mm);
            let y0 = (cy - r).floor().max(0.0) as u32;
            let y1 = ((cy + r).ceil().max(0.0) as u32).min(h);
            let x0 = (cx - r).floor().max(0.0) as u32;
            let x1 = ((cx + r).ceil().max(0.0) as u32).min(w);
            for y in y0..y1 {
                for x in x0..x1 {
                    if (x as f64 + 0.5 - cx).hypot(y as f64 + 0.5 - cy) <= r {
                        grid.set(x, y, true);
                    }
                }
            }
        }
        kept_out = grid.count_material();
        u.keep_out = Some(Arc::new(grid));
    }
    u.at = u.at_mm.iter().map(|p| [p[0] / mm, p[1] / mm]).collect();
    // What the stages read is in pixels now: the paths and millimetres stay out of the params.
    u.keep_out_mask = None;
    u.no_bridge_near_mm.clear();
    u.at_mm.clear();
    let user = UserParams {
        min_island_mm2: u.min_island_mm2,
        mm_per_px: mm,
    };
    Ok((Some(user), kept_out))
}

/// The mesh options with lines wide enough to survive the topological filter (a cut narrower than
/// the material's smallest feature would be filtered away). The scale is taken at the widest
/// image the mesh can render to, which can only over-estimate the pixels needed.
fn mesh_lines_for(cfg: &MakeConfig) -> MeshConfig {
    let mut m = cfg.mesh.clone();
    if let Ok(scale) = cfg.physical.scale(m.max_width_px(), 1) {
        let r = cfg.physical.filter_for(&cfg.filter, scale).radius;
        if r > 0 {
            m.min_line_px = m.min_line_px.max((2 * r + 2) as f32);
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn material_widths_become_pixel_minimums() {
        // Cardstock: bridges 1.0 mm, features 0.5 mm; 0.1 mm/px; tolerance 0.05 mm = 0.5 px, so
        // the allowance is 1 + 2 × 0.5 = 2 px.
        let phys = PhysicalConfig::default();
        let s = Scale::default();
        // Widest: max_bridge_mm, 4 × 1.0 mm by default, rounded down.
        let b = phys.bridge_for(&BridgeConfig::default(), s);
        assert_eq!((b.min_width_px, b.max_width_px), (12, 40));
        let wide = BridgeConfig {
            min_width_px: 20,
            max_width_px: 30,
            max_width_given: true,
            ..Default::default()
        };
        let b = phys.bridge_for(&wide, s);
        assert_eq!(
            (b.min_width_px, b.max_width_px),
            (20, 30),
            "user pixels win"
        );
        let narrow = BridgeConfig {
            min_width_px: 3,
            max_width_px: 3,
            max_width_given: true,
            ..Default::default()
        };
        let b = phys.bridge_for(&narrow, s);
        assert_eq!(
            (b.min_width_px, b.max_width_px),
            (12, 12),
            "never below the material's minimum"
        );
        let thin = PhysicalConfig {
            allow_thin: true,
            ..phys.clone()
        };
        let b = thin.bridge_for(&narrow, s);
        assert_eq!(
            (b.min_width_px, b.max_width_px),
            (3, 3),
            "explicit pixels with --allow-thin are taken as given"
        );
        let b = thin.bridge_for(&BridgeConfig::default(), s);
        assert_eq!(
            (b.min_width_px, b.max_width_px),
            (12, 40),
            "--allow-thin alone keeps the material's widths"
        );
        // At 0.05 mm/px the same millimetres are twice the pixels.
        let fine = Scale { mm_per_px: 0.05 };
        let b = phys.bridge_for(&BridgeConfig::default(), fine);
        assert_eq!((b.min_width_px, b.max_width_px), (20 + 3, 80));
        // At 0.625 mm/px (320 px at 200 mm): ⌈1.6 + 1.16⌉ = 3 px .. ⌊6.4⌋ = 6 px.
        let coarse = Scale { mm_per_px: 0.625 };
        let b = phys.bridge_for(&BridgeConfig::default(), coarse);
        assert_eq!((b.min_width_px, b.max_width_px), (3, 6));
        // A maximum that is a whole number of pixels is not lost to rounding (1.2 / 0.1 is
        // 11.99... in floating point).
        let mut m = phys.clone();
        m.material.max_bridge_mm = 1.2;
        assert_eq!(m.bridge_for(&BridgeConfig::default(), s).max_width_px, 12);
        // Filter: ceil((5 + 2) / 2) = 4 px, unless the user set a radius explicitly.
        assert_eq!(phys.filter_for(&FilterConfig::default(), s).radius, 4);
        let explicit = FilterConfig {
            radius: 1,
            auto_radius: false,
            ..Default::default()
        };
        assert_eq!(phys.filter_for(&explicit, s).radius, 1);
    }

    #[test]
    fn size_options_give_the_scale() {
        let mut phys = PhysicalConfig::default();
        assert_eq!(phys.scale(400, 300).unwrap().mm_per_px, 0.1);
        phys.size = Size::WidthMm(200.0);
        assert!((phys.scale(400, 300).unwrap().mm_per_px - 0.5).abs() < 1e-12);
        phys.size = Size::Dpi(254.0);
        assert!((phys.scale(400, 300).unwrap().mm_per_px - 0.1).abs() < 1e-12);
        phys.size = Size::WidthMm(-3.0);
        assert!(matches!(
            phys.scale(400, 300),
            Err(Error::Limit(crate::limits::SizeError::NotPositive {
                size: Size::WidthMm(_)
            }))
        ));
    }
}
