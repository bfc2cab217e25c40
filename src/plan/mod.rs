//! Toolpaths: cut order, travel optimisation, passes, time estimate, G-code text.
//! OWNER: the G-code issue.
//!
//! `toolpath` places the cut geometry on the bed and builds the [`Job`]; `order` says what must be
//! cut before what; `travel` orders loops and picks start points; `gcode` writes the text;
//! `estimate` times any G-code program the shared interpreter runs.

pub mod estimate;
pub mod gcode;
pub mod order;
pub mod svg;
pub mod toolpath;
pub mod travel;

pub use estimate::{estimate, Estimate, MotionLimits};
pub use toolpath::{plan, Anchor, CutSettings, Job, Loop, PathStats, PlanConfig, PlanError};

use crate::machine::gcode::interpret;
use crate::profile::machine::Machine;
use crate::vector::CutGeometry;

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
    let moves = interpret(&text).map_err(|e| {
        PlanError::Settings(format!(
            "internal error: the written G-code does not run ({e}); please report this"
        ))
    })?;
    let est = estimate(&moves, &machine.limits());
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
