//! G-code for GRBL machines from closed cut loops in millimetres: machine profiles, toolpaths, cut
//! order and travel, the G-code writer, the G-code interpreter and the time estimate. Knows
//! nothing of pictures or stencils: its input is [`CutLoops`].
//!
//! Modules: `machine` (machine profiles), `cuts` (the input), `toolpath` places the loops on the
//! bed and builds the [`Job`]; `order` says what must be cut before what; `travel` orders loops
//! and picks start points; `write` writes the text; `interpret` reads any G-code program the way
//! Grbl does; `estimate` times it; `simulate` draws it; `read_svg` reads a drawing's cut loops;
//! `grid` makes a test grid of power and speed.

#![forbid(unsafe_code)]

pub mod cuts;
mod error;
pub mod estimate;
pub mod grid;
pub mod interpret;
pub mod limits;
pub mod machine;
pub mod order;
pub mod read_svg;
pub mod simulate;
pub mod toolpath;
pub mod travel;
pub mod write;

pub use cuts::{CutLoops, Pieces};
pub use error::{Fit, PlanError, SettingsError};
pub use estimate::{estimate, Estimate};
pub use toolpath::{
    plan, Anchor, CutSettings, Job, Loop, PathStats, PlanConfig, MAX_BLADE_OFFSET_MM,
    MAX_PASSES,
};

use crate::interpret::interpret;
use crate::machine::Machine;

/// What `make --emit gcode` needs besides the geometry: the machine and where and how to cut.
#[derive(Clone, Debug, PartialEq)]
pub struct GcodeConfig {
    pub machine: Machine,
    pub plan: PlanConfig,
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
    geom: &CutLoops,
    machine: &Machine,
    cfg: &PlanConfig,
    notes: &[String],
) -> Result<(String, GcodeSummary), PlanError> {
    let job = plan(geom, machine, cfg)?;
    let text = write::write(&job, machine, notes);
    let moves = interpret(&text).map_err(PlanError::Internal)?;
    let est = estimate::estimate_with(&moves, &machine.motion, machine.cut_rule(&moves));
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
