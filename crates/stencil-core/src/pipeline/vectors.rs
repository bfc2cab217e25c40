//! Vectors and the check (ours: the paper cut by hand): the stencil traced into millimetres,
//! checked against the material, its thin necks widened and traced again, the fidelity
//! measured; and what `make` refuses to write.

use crate::bridge::Bridged;
use crate::check::{self, CheckReport};
use crate::error::Error;
use crate::material::Material;
use crate::plan::TraceParams;
use crate::raster::BitGrid;
use crate::report::Fidelity;
use crate::request::PhysicalConfig;
use crate::timing::Timings;
use crate::tone::regularize::{settle_all, settle_near};
use crate::units::{Mm, Scale};
use crate::vector::{self, CutGeometry, VectorConfig};

/// How many times `make` widens the necks the vector check still finds and traces again.
const REPAIR_ROUNDS: usize = 3;

/// How far (in disc spans past the neck) a repair may change the stencil.
const REPAIR_SPREAD: u32 = 1;

/// What the vector stage and the check made.
#[derive(Clone, Debug)]
pub struct Traced {
    /// The stencil in millimetres, before the kerf.
    pub geometry: CutGeometry,
    /// What the tracing measured.
    pub(crate) vstats: vector::VectorStats,
    /// The check's findings.
    pub check: CheckReport,
    /// How far the stencil is from the thresholded picture.
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
