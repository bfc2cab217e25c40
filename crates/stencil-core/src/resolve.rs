//! Every decision `make` makes, pure (no file, no printing, no clock; files come in [`Inputs`],
//! notes go out as [`Note`]s): [`resolve`] before any work, [`stage_params`] once the input is
//! rendered (a mesh's size is only known then).

use std::sync::Arc;

use crate::bridge::{self, BridgeConfig};
use crate::check;
use crate::error::Error;
use crate::fit::{self, FitRequest, Fitted, SizingError, Stock};
use crate::inputs::Inputs;
use crate::pipeline::source::{is_mesh_path as is_mesh, Source};
use crate::plan::{
    CleanParams, JoinParams, SourceParams, StageParams, ToneParams, TraceParams, UserParams,
    Working,
};
use crate::raster::{BitGrid, Gray};
use crate::request::{BridgePlaces, KeepOut, MakeConfig, PhysicalConfig, Request};
use crate::tone::filter::FilterConfig;
use crate::tone::{self, mesh::MeshConfig};
use crate::units::{Mm, Scale, Size};
use crate::vector::VectorConfig;

/// A decision a person should be told of (the caller words it).
#[derive(Clone, Debug, PartialEq)]
pub enum Note {
    /// An etched material's smallest feature raised (see `etched_widths`).
    Etched {
        /// The material's name.
        material: String,
        /// The smallest feature asked for, mm.
        given_mm: f64,
        /// Rounded up to a micrometre.
        need_mm: f64,
        /// The etch's undercut under each mask edge, mm.
        undercut_mm: f64,
    },
    /// The picture made `width_mm` wide to fit `stock` (it would have been `from_mm`).
    Fitted {
        /// The width made, mm.
        width_mm: f64,
        /// The height made, mm.
        height_mm: f64,
        /// The width and height it would have been, mm.
        from_mm: [f64; 2],
        /// The stock fitted to.
        stock: Stock,
        /// Whether the picture lies a quarter turn on the stock.
        turned: bool,
    },
}

/// The decisions before any work, in `make`'s order: etched widths, gobo size, fit to the sheet or
/// bed, picture adjustments in pixels. The notes come back up to a failure too (told before it).
pub fn resolve(r: &Request, inputs: &Inputs) -> (Vec<Note>, Result<MakeConfig, Error>) {
    let mut notes = Vec::new();
    let mut cfg = r.make.clone();
    etched_widths(&mut cfg.physical, &mut notes);
    let sized = fit_gobo(r, inputs, &mut cfg.physical)
        .and_then(|()| fit_size(r, inputs, &mut cfg.physical, &mut notes))
        .and_then(|()| adjust_picture(r, inputs, &mut cfg));
    cfg.keep_out = inputs.keep_out.clone().map(|picture| KeepOut {
        picture,
        whole_px: inputs.picture_px,
    });
    (notes, sized.map(|()| cfg))
}

/// The picture's adjustments alone (`stencil tone`: the size asked for, the material as is).
pub fn resolve_picture(r: &Request, inputs: &Inputs) -> Result<MakeConfig, Error> {
    let mut cfg = r.make.clone();
    adjust_picture(r, inputs, &mut cfg)?;
    Ok(cfg)
}

/// An etched material's smallest feature raised to the narrowest opening that etches at its
/// designed size (twice the masks' undercut plus a mask's narrowest line), so the clean-up and
/// the width check judge the etched part.
fn etched_widths(physical: &mut PhysicalConfig, notes: &mut Vec<Note>) {
    let Some(e) = crate::export::Etch::of(&physical.material) else {
        return;
    };
    // Rounded up to a micrometre, as printed.
    let need = (e.min_opening_mm() * 1000.0).ceil() / 1000.0;
    let m = &mut physical.material;
    if m.min_feature_mm < need {
        notes.push(Note::Etched {
            material: m.name.clone(),
            given_mm: m.min_feature_mm,
            need_mm: need,
            undercut_mm: e.undercut_mm(),
        });
        m.min_feature_mm = need;
    }
}

/// A gobo's size, from the picture's header: the picture inscribed in the image area (or filling
/// it, cropped). Refused for a mesh (it is drawn at its own size) and, for a machine, when the
/// disc is larger than its bed.
fn fit_gobo(r: &Request, inputs: &Inputs, physical: &mut PhysicalConfig) -> Result<(), Error> {
    let Some(g) = &physical.gobo else {
        return Ok(());
    };
    if is_mesh(&r.make.input) {
        return Err(SizingError::GoboMesh.into());
    }
    if let Some(bed @ Stock::Bed { w_mm, h_mm, .. }) = &r.bed {
        if g.od_mm > w_mm.min(*h_mm) {
            let (gobo, od_mm, bed) = (g.name(), g.od_mm, bed.clone());
            return Err(SizingError::GoboBed { gobo, od_mm, bed }.into());
        }
    }
    // A header that cannot be read is left for loading the picture to name.
    if let Some((w, h)) = inputs.picture_px {
        physical.size = Size::WidthMm(g.picture_width_mm(w, h));
    }
    Ok(())
}

/// The size on the sheet, decided from the picture's header before any work: scaled down to the
/// machine's bed when no size was asked for and the default 0.1 mm per pixel would not fit it,
/// fitted to a sheet, or refused (with the largest width that fits) when the size asked for
/// cannot fit. A mesh, or a picture whose header cannot be read, is left alone.
fn fit_size(
    r: &Request,
    inputs: &Inputs,
    physical: &mut PhysicalConfig,
    notes: &mut Vec<Note>,
) -> Result<(), Error> {
    // A gobo is sized by its disc, checked against the bed in `fit_gobo`.
    let (None, Some(stock), Some(px)) = (
        &physical.gobo,
        r.sheet.as_ref().or(r.bed.as_ref()),
        inputs.picture_px,
    ) else {
        return Ok(());
    };
    let req = FitRequest {
        picture_px: px,
        size: physical.size,
        margin_mm: physical.vector.margin_mm,
        margin_counts: r.margin_counts,
        stock: stock.clone(),
    };
    if let Fitted::Scaled {
        from_mm,
        width_mm,
        height_mm,
        turned,
    } = fit::fit(&req).map_err(SizingError::Fit)?
    {
        physical.size = Size::WidthMm(width_mm);
        notes.push(Note::Fitted {
            width_mm,
            height_mm,
            from_mm,
            stock: stock.clone(),
            turned,
        });
    }
    Ok(())
}

/// The picture adjustments given in mm made pixels of the picture: the crop, the smoothing and
/// the local threshold's neighbourhood. The scale is that of the whole picture as shown (its
/// header); with a crop the size is then pinned to that scale (as dpi), so the cropped part keeps
/// the size it had in the whole picture. A mesh, or a picture whose header cannot be read
/// (loading it then says why), is left alone.
fn adjust_picture(r: &Request, inputs: &Inputs, cfg: &mut MakeConfig) -> Result<(), Error> {
    let Some((w, h)) = inputs.picture_px else {
        return Ok(());
    };
    let (physical, adj) = (&mut cfg.physical, &mut cfg.tone.adjust);
    let mm = match r.crop_mm {
        Some(crop_mm @ [x, y, cw, ch]) => {
            let mm = physical.scale(w, h)?.mm_per_px;
            let px = |v: f64| (v / mm).round();
            if px(x + cw) > w as f64 || px(y + ch) > h as f64 || px(cw) < 1.0 || px(ch) < 1.0 {
                let picture_mm = [w as f64 * mm, h as f64 * mm];
                return Err(SizingError::CropOutside {
                    crop_mm,
                    picture_mm,
                    mm_per_px: mm,
                }
                .into());
            }
            adj.crop_px = Some([px(x) as u32, px(y) as u32, px(cw) as u32, px(ch) as u32]);
            physical.size = Size::Dpi(25.4 / mm);
            mm
        }
        None if adj.quarter_turns % 2 == 1 => physical.scale(h, w)?.mm_per_px,
        None => physical.scale(w, h)?.mm_per_px,
    };
    adj.smooth_px = (r.smooth_mm / mm) as f32;
    adj.local_px = (r.local_threshold_mm / mm) as f32;
    Ok(())
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
    /// With `allow_thin` and a widest bridge asked for (`max_px`), the user's pixel widths are taken as
    /// given: they have asked for bridges of that width and to keep a stencil the check finds
    /// thin (a measurement at fixed pixel widths, such as the corpus's quality comparison).
    ///
    /// The strength rules get the material's stiffness, weight and limits and the scale, keeping
    /// the user's bridges per island.
    pub fn bridge_for(
        &self,
        user: &BridgeConfig,
        max_px: Option<u32>,
        scale: Scale,
    ) -> BridgeConfig {
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
        if let (Some(max_width_px), true) = (max_px, self.allow_thin) {
            return BridgeConfig {
                max_width_px,
                strength,
                ..user.clone()
            };
        }
        let px = (scale.to_px(Mm(self.material.min_bridge_mm)).0 + self.allowance_px(scale)).ceil()
            as u32;
        let min = user.min_width_px.max(px);
        // A hair under a whole pixel counts as one (1.2 mm / 0.1 mm is 11.99... in floating point).
        let max = max_px.unwrap_or_else(|| {
            (scale.to_px(Mm(self.material.max_bridge_mm)).0 + 1e-6)
                .floor()
                .min(u32::MAX as f64 / 2.0) as u32
        });
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

impl SourceParams {
    /// Checked as `make` always checked them, before the input is opened: a mesh's settings,
    /// a picture's `--scale` factor.
    pub fn of(cfg: &MakeConfig) -> Result<Self, Error> {
        if is_mesh(&cfg.input) {
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

/// The second step, once the input is rendered (its size known): the working resolution (the
/// automatic supersampling reads the material), the clean-up's widths, the bridges' widths and
/// the user's places in pixels (the keep-out picture placed), the vector settings. The checks
/// `make` makes against the working image are made here, in the same order. Pure, like
/// [`resolve`].
pub fn stage_params(cfg: &MakeConfig, source: &Source) -> Result<StageParams, Error> {
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
    let threshold = match (cfg.tone.threshold, source) {
        (tone::Threshold::ByPicture, Source::Picture(g)) if cfg.tone.adjust.local_px <= 0.0 => {
            tone::by_picture(g)
        }
        (tone::Threshold::ByPicture, _) => tone::Threshold::Level(128),
        (t, _) => t,
    };
    let mut bridge_cfg = phys.bridge_for(&cfg.bridge, cfg.max_bridge_width_px, scale);
    let keep_out = cfg
        .keep_out
        .as_ref()
        .map(|k| place_keep_out(k, &cfg.tone.adjust, (sw, sh)))
        .transpose()?;
    let (user, kept_out_px) = user_bridges(
        &mut bridge_cfg,
        &cfg.places,
        w,
        h,
        scale,
        keep_out.as_deref(),
    );
    Ok(StageParams {
        working,
        tone: ToneParams {
            threshold,
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
            auto: threshold == tone::Threshold::Auto && matches!(source, Source::Picture(_)),
        },
        join: JoinParams {
            bridge: bridge_cfg,
            user,
            kept_out_px,
            settle_px: regularize_px,
            tidy_radius: filter_cfg.radius,
            drop_islands: !cfg.places.keep_all_islands,
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
        mesh_parts: match source {
            Source::Mesh(r) => Some(r.parts),
            Source::Picture(_) => None,
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

/// The keep-out picture in the stencil's frame (`stencil_px`: the picture's size after its crop
/// and turns, before any supersampling). Two frames are possible once the picture is cropped or
/// turned: a person painting over the original photo works in the whole picture's frame, the
/// studio paints over the stencil. The size tells them apart: a keep-out picture of the whole
/// picture's size (as shown, after its EXIF orientation), when the stencil's frame has another
/// size, is in the whole picture's frame and is cropped and turned exactly as the picture is;
/// any other is taken as the stencil's frame (when both frames have one size, a half turn
/// without a crop, the stencil's). Either is then stretched over the working image.
fn place_keep_out(
    k: &KeepOut,
    a: &tone::Adjust,
    stencil_px: (u32, u32),
) -> Result<Arc<Gray>, Error> {
    let mask = k.picture.clone().map_err(Error::KeepOut)?;
    let size = (mask.width, mask.height);
    if (a.crop_px.is_some() || !a.quarter_turns.is_multiple_of(4))
        && k.whole_px == Some(size)
        && size != stencil_px
    {
        let frame_only = tone::Adjust {
            crop_px: a.crop_px,
            quarter_turns: a.quarter_turns,
            ..Default::default()
        };
        return Ok(Arc::new(frame_only.apply(&mask)));
    }
    Ok(mask)
}

/// The user's bridge options on the working image (see `bridge::constraints`): the keep-out
/// picture and discs made a grid of forbidden pixels, the requested places made pixels. Returns
/// what the report needs (`None` when no option was given) and the pixels kept out.
fn user_bridges(
    bridge: &mut BridgeConfig,
    u: &BridgePlaces,
    w: u32,
    h: u32,
    scale: Scale,
    keep_out: Option<&Gray>,
) -> (Option<UserParams>, usize) {
    if keep_out.is_none()
        && u.no_bridge_near_mm.is_empty()
        && u.at_mm.is_empty()
        && u.min_island_mm2 <= 0.0
    {
        return (None, 0);
    }
    let mm = scale.mm_per_px;
    let mut kept_out = 0;
    if keep_out.is_some() || !u.no_bridge_near_mm.is_empty() {
        let mut grid = BitGrid::new(w, h, false);
        if let Some(mask) = keep_out {
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
        bridge.user.keep_out = Some(Arc::new(grid));
    }
    bridge.user.at = u.at_mm.iter().map(|p| [p[0] / mm, p[1] / mm]).collect();
    let user = UserParams {
        min_island_mm2: u.min_island_mm2,
        mm_per_px: mm,
    };
    (Some(user), kept_out)
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
        let b = phys.bridge_for(&BridgeConfig::default(), None, s);
        assert_eq!((b.min_width_px, b.max_width_px), (12, 40));
        let wide = BridgeConfig {
            min_width_px: 20,
            ..Default::default()
        };
        let b = phys.bridge_for(&wide, Some(30), s);
        assert_eq!(
            (b.min_width_px, b.max_width_px),
            (20, 30),
            "user pixels win"
        );
        let narrow = BridgeConfig {
            min_width_px: 3,
            ..Default::default()
        };
        let b = phys.bridge_for(&narrow, Some(3), s);
        assert_eq!(
            (b.min_width_px, b.max_width_px),
            (12, 12),
            "never below the material's minimum"
        );
        let thin = PhysicalConfig {
            allow_thin: true,
            ..phys.clone()
        };
        let b = thin.bridge_for(&narrow, Some(3), s);
        assert_eq!(
            (b.min_width_px, b.max_width_px),
            (3, 3),
            "explicit pixels with --allow-thin are taken as given"
        );
        let b = thin.bridge_for(&BridgeConfig::default(), None, s);
        assert_eq!(
            (b.min_width_px, b.max_width_px),
            (12, 40),
            "--allow-thin alone keeps the material's widths"
        );
        // At 0.05 mm/px the same millimetres are twice the pixels.
        let fine = Scale { mm_per_px: 0.05 };
        let b = phys.bridge_for(&BridgeConfig::default(), None, fine);
        assert_eq!((b.min_width_px, b.max_width_px), (20 + 3, 80));
        // At 0.625 mm/px (320 px at 200 mm): ⌈1.6 + 1.16⌉ = 3 px .. ⌊6.4⌋ = 6 px.
        let coarse = Scale { mm_per_px: 0.625 };
        let b = phys.bridge_for(&BridgeConfig::default(), None, coarse);
        assert_eq!((b.min_width_px, b.max_width_px), (3, 6));
        // A maximum that is a whole number of pixels is not lost to rounding (1.2 / 0.1 is
        // 11.99... in floating point).
        let mut m = phys.clone();
        m.material.max_bridge_mm = 1.2;
        assert_eq!(
            m.bridge_for(&BridgeConfig::default(), None, s).max_width_px,
            12
        );
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
