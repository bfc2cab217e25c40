//! `make`'s end from the bridges: the trace and the check, the refusal, the G-code (the kerf and
//! the G-code crate's planner) and report.json's contents, as [`Made`].

use std::sync::Arc;

use super::bridges::Joined;
use super::clean_up::Cleaned;
use super::vectors::{refuse, trace, Traced};
use crate::bridge::{self, Bridged};
use crate::check::CheckReport;
use crate::error::Error;
use crate::plan::{StageParams, TraceParams};
use crate::raster::{BitGrid, TwoTone};
use crate::report::{BridgeReport, Report};
use crate::request::MakeConfig;
use crate::timing::Timings;
use crate::tone::filter::FilterStats;
use crate::units::Scale;
use crate::vector::CutGeometry;

/// What `make` computed, before anything is written.
pub struct Made {
    /// The picture thresholded, before the clean-up (what fidelity is measured against).
    pub picture: BitGrid,
    /// After the topological filter, before bridges.
    pub twotone: TwoTone,
    /// What the clean-up's filter changed.
    pub filter: FilterStats,
    /// The stencil in pixels: the two-tone with its bridges.
    pub bridged: Bridged,
    /// Millimetres per working pixel.
    pub scale: Scale,
    /// The stencil in millimetres (cut loops for G-code, material, bridges).
    pub geometry: CutGeometry,
    /// The check's findings.
    pub check: CheckReport,
    /// The report (report.json).
    pub report: Report,
    /// The G-code text, when asked for.
    pub gcode: Option<String>,
    /// The HP-GL text, when asked for.
    pub hpgl: Option<String>,
    /// Pixels of the islands dropped instead of bridged (the preview colours them).
    pub dropped_px: Vec<u32>,
    /// A mesh's parts, and how many its view draws smaller than a pixel (`None` for a picture).
    pub mesh_parts: Option<crate::tone::mesh::PartSizes>,
}

/// `make`'s end, from the bridges on to the report: trace and check, refuse what `make` refuses,
/// the G-code. The same for `make` and for stage outputs a caller kept (the studio's: shared
/// outputs are copied, owned ones moved), so the files are the same. `timer`: the run's timings
/// so far, or `None` for a fresh one.
pub fn finish(
    cfg: &MakeConfig,
    params: &StageParams,
    cleaned: Arc<Cleaned>,
    joined: Arc<Joined>,
    timer: Option<Timings>,
) -> Result<Made, Error> {
    finish_with(cfg, params, (cleaned, joined), timer, None)
}

/// A change to the traced geometry after the check, before any job is planned from it (a
/// tile's edge along its seams).
pub type GeometryEdit<'a> = dyn Fn(&mut CutGeometry) -> Result<(), Error> + Sync + 'a;

/// [`finish`], the traced geometry changed by `edit` (if any) after the check and before any
/// job is planned from it (a tile's edge along its seams).
pub(crate) fn finish_with(
    cfg: &MakeConfig,
    params: &StageParams,
    (cleaned, joined): (Arc<Cleaned>, Arc<Joined>),
    timer: Option<Timings>,
    edit: Option<&GeometryEdit<'_>>,
) -> Result<Made, Error> {
    let mut timer = timer.unwrap_or_else(|| Timings::new(cfg.progress.clone()));
    let (cleaned, mut joined) = (Arc::unwrap_or_clone(cleaned), Arc::unwrap_or_clone(joined));
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
    if let Some(edit) = edit {
        edit(&mut traced.geometry)?;
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
    let (hpgl, hpgl_summary) = match &cfg.hpgl {
        Some(h) => Some(hpgl(
            h,
            &traced.geometry,
            &joined,
            &params.trace,
            &mut timer,
        )?),
        None => None,
    }
    .unzip();
    let mut report = report(
        cfg,
        params,
        &cleaned,
        &joined,
        &traced,
        gcode_summary,
        timer,
    );
    report.hpgl = hpgl_summary;
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
        hpgl,
        dropped_px: Arc::unwrap_or_clone(joined.dropped_px),
        mesh_parts: params.mesh_parts,
    })
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

/// The HP-GL job and its summary, from the same cut loops as the G-code (the unbridged pieces
/// cut out whole, the kerf applied) on a copy of the geometry, so the G-code's is untouched.
pub fn hpgl(
    h: &stencil_hpgl::HpglConfig,
    geometry: &CutGeometry,
    joined: &Joined,
    p: &TraceParams,
    timer: &mut Timings,
) -> Result<(String, stencil_hpgl::HpglSummary), Error> {
    let mut geometry = geometry.clone();
    if joined.map.island_count() > 0 {
        timer.time("pieces", || {
            geometry.set_unbridged(&joined.twotone.bits, &p.vector)
        })?;
    }
    timer.time("kerf", || geometry.apply_kerf(p.material.kerf_mm))?;
    timer.time("hpgl", || {
        stencil_hpgl::hpgl_for(&geometry.loops(), h).map_err(|e| match e {
            stencil_hpgl::HpglError::Plan(e) => Error::Plan(e),
            e => Error::Hpgl(e),
        })
    })
}

/// report.json's contents (the files written are added by `driver::make`).
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
        material: Some(phys.material.name.clone()),
        material_source: Some(phys.material_source.clone()),
        material_values: Some(phys.material.values()),
        mm_per_px: Some(scale.mm_per_px),
        scale_factor: Some(working.factor),
        scale_auto: working.auto,
        margin_mm: Some(vcfg.margin_mm),
        tolerance_mm: Some(vcfg.tolerance_mm),
        arcs: Some(vcfg.arcs),
        min_bridge_px: Some(bridge_cfg.min_width_px),
        max_bridge_px: Some(bridge_cfg.max_width_px),
        filter_radius_px: Some(params.clean.filter.radius),
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
        bridge_light: (joined.map.island_count() > 0).then_some(bridged.light),
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
        timings_ms: timer.into_map(),
        // The rest is added later: the trace's by `report`, the masks and the files as they are
        // encoded; `floating_after` stays 0 (the join refuses a stencil with anything floating).
        ..Report::default()
    }
}
