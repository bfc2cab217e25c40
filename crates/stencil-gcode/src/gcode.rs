//! A job from cut loops to G-code text and its cost, the way `make` and `gcode` run it: plan,
//! write, then time what was written.

use crate::cuts::CutLoops;
use crate::error::PlanError;
use crate::estimate::Estimate;
use crate::job::{CutSettings, PathStats};
use crate::keep_fed::{keep_fed, Feeding};
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
    /// Time and lengths from the written G-code, as Grbl would plan it, with the time lost
    /// where the serial line cannot keep its planner fed.
    pub estimate: Estimate,
    /// Where the job's lines would arrive slower than its feed uses them, and where the feed
    /// was lowered for it; absent when nothing starves.
    #[serde(default, skip_serializing_if = "Feeding::is_quiet")]
    pub feeding: Feeding,
}

/// Plan and write a job: the G-code text and its summary. The estimate runs the written text
/// through the shared interpreter, so it times exactly what the machine will get, over the
/// machine's serial line; where the line cannot keep the planner fed the feed is lowered
/// (unless [`PlanConfig::keep_feed`]).
pub fn gcode_for(
    geom: &CutLoops,
    machine: &Machine,
    cfg: &PlanConfig,
    notes: &[String],
) -> Result<(String, GcodeSummary), PlanError> {
    let job = plan(geom, machine, cfg)?;
    let text = write(&job, machine, notes);
    let (text, est, feeding) = keep_fed(
        text,
        &machine.motion,
        &machine.link,
        |p| machine.cut_rule(&p.moves),
        !cfg.keep_feed,
    )
    .map_err(PlanError::Internal)?;
    Ok((
        text,
        GcodeSummary {
            machine: machine.name.clone(),
            tool: machine.tool.kind().into(),
            settings: Some(cfg.settings),
            settings_from: None,
            path: job.stats,
            estimate: est,
            feeding,
        },
    ))
}
