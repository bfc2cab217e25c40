//! Toolpaths: cut order, travel optimisation, passes, time estimate, G-code text.
//! OWNER: the G-code issue.
//!
//! `toolpath` places the cut geometry on the bed and builds the [`Job`]; `order` says what must be
//! cut before what; `travel` orders loops and picks start points; `gcode` writes the text;
//! `estimate` times any G-code program the shared interpreter runs.

pub mod estimate;
pub mod gcode;
pub mod grid;
pub mod order;
pub mod svg;
pub mod toolpath;
pub mod travel;

pub use estimate::{estimate, Estimate, MotionLimits};
pub use toolpath::{
    plan, Anchor, CutSettings, Job, Loop, PathStats, PlanConfig, PlanError, MAX_BLADE_OFFSET_MM,
    MAX_PASSES,
};

use crate::machine::gcode::interpret;
use crate::profile::machine::{Machine, Tool};
use crate::profile::{Material, Process};
use crate::vector::CutGeometry;

/// What `make --emit gcode` needs besides the geometry: the machine and where and how to cut.
#[derive(Clone, Debug, PartialEq)]
pub struct GcodeConfig {
    pub machine: Machine,
    pub plan: PlanConfig,
}

/// A material's cut settings for a machine. The material's process must match the machine's tool:
/// a laser material's power means nothing to a knife, and an etch material has no cut settings.
pub fn settings_for(material: &Material, machine: &Machine) -> Result<CutSettings, PlanError> {
    let s = match (&material.process, &machine.tool) {
        (Process::Laser(l), Tool::Laser { .. }) => CutSettings {
            power_pct: l.power_pct,
            speed_mm_min: l.speed_mm_min,
            passes: l.passes,
            blade_offset_mm: 0.0,
            air_assist: l.air_assist.unwrap_or(machine.air_assist),
        },
        (Process::Knife(k), Tool::Knife { .. }) => CutSettings {
            power_pct: 100.0,
            speed_mm_min: k.speed_mm_s * 60.0,
            passes: k.passes,
            blade_offset_mm: k.blade_offset_mm,
            air_assist: false,
        },
        (Process::Pen(p), Tool::Pen(_)) => CutSettings {
            power_pct: 100.0,
            speed_mm_min: p.speed_mm_min,
            passes: 1,
            blade_offset_mm: 0.0,
            air_assist: false,
        },
        (Process::Etch(_), _) => {
            return Err(PlanError::Settings(format!(
                "material '{}' is for photo-etching and has no cut settings for G-code; \
                 use --emit mask, or choose a laser, knife or pen material",
                material.name
            )))
        }
        (p, t) => {
            return Err(PlanError::Settings(format!(
                "material '{}' is set up for a {} but machine '{}' has a {}; choose a matching \
                 --material (for a {}: {}, or see `stencil profiles`) or --machine, or give \
                 --power, --speed and --passes",
                material.name,
                p.kind(),
                machine.name,
                t.kind(),
                t.kind(),
                machine.default_material()
            )))
        }
    };
    Ok(s)
}

/// What a G-code job costs, as recorded in report.json and printed by `make` and `gcode`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GcodeSummary {
    pub machine: String,
    pub tool: String,
    pub settings: Option<CutSettings>,
    #[serde(flatten)]
    pub path: PathStats,
    /// Time and lengths from the written G-code, as Grbl would plan it.
    pub estimate: Estimate,
}

/// Plan and write a job: the G-code text and its summary. The estimate runs the written text
/// through the shared interpreter, so it times exactly what the machine will get.
pub fn gcode_for(
    geom: &CutGeometry,
    machine: &Machine,
    cfg: &PlanConfig,
    notes: &[String],
) -> Result<(String, GcodeSummary), PlanError> {
    let job = plan(geom, machine, cfg)?;
    let text = gcode::write(&job, machine, notes);
    let moves = interpret(&text).map_err(|e| PlanError::Internal(e.to_string()))?;
    let est = estimate::estimate_with(&moves, &machine.limits(), machine.cut_rule(&moves));
    Ok((
        text,
        GcodeSummary {
            machine: machine.name.clone(),
            tool: machine.tool.kind().into(),
            settings: Some(cfg.settings),
            path: job.stats,
            estimate: est,
        },
    ))
}
