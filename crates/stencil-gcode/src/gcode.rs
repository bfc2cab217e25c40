//! A job from cut loops to G-code text and its cost, the way `make` and `gcode` run it: plan,
//! write, then time what was written.

use crate::cuts::CutLoops;
use crate::error::PlanError;
use crate::estimate::{estimate_program, Estimate};
use crate::interpret::interpret_program;
use crate::job::{CutSettings, PathStats};
use crate::machine::Machine;
use crate::toolpath::{plan, PlanConfig};
use crate::write::write;

/// What `make --emit gcode` needs besides the geometry: the machine and where and how to cut.
#[derive(Clone, Debug, PartialEq)]
pub struct GcodeConfig {
    /// The machine the job is for.
    pub machine: Machine,
    /// Where and how to cut.
    pub plan: PlanConfig,
    /// Where the cut settings came from (a kept settings file, a material profile's entry and
    /// its published source, the command line): written in the G-code's header and report.json,
    /// so the job can be made again with the same numbers. Empty when unknown.
    pub settings_from: String,
}

/// What a G-code job costs, as recorded in report.json and printed by `make` and `gcode`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GcodeSummary {
    /// The machine's name.
    pub machine: String,
    /// Its tool (laser, pen, knife).
    pub tool: String,
    /// The cut settings used.
    pub settings: Option<CutSettings>,
    /// Where `settings` came from (see [`GcodeConfig::settings_from`]); absent in reports written
    /// before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settings_from: Option<String>,
    #[serde(flatten)]
    /// Loops, lengths and travel.
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
    let text = write(&job, machine, notes);
    let program = interpret_program(&text).map_err(PlanError::Internal)?;
    let rule = machine.cut_rule(&program.moves);
    let est = estimate_program(&program, &machine.motion, rule);
    Ok((
        text,
        GcodeSummary {
            machine: machine.name.clone(),
            tool: machine.tool.kind().into(),
            settings: Some(cfg.settings),
            settings_from: None,
            path: job.stats,
            estimate: est,
        },
    ))
}
