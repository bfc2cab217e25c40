//! G-code for GRBL machines from closed cut loops in millimetres: machine profiles, toolpaths, cut
//! order and travel, the G-code writer, the G-code interpreter and the time estimate. Knows
//! nothing of pictures or stencils: its input is [`CutLoops`].
//!
//! Public API:
//! - [`gcode_for`] ([`GcodeConfig`], [`GcodeSummary`]): plan and write a job, and time it;
//!   [`plan`] alone gives the [`Job`] ([`Loop`]s in cut order, [`PathStats`]) from [`CutLoops`]
//!   ([`Pieces`]) under a [`PlanConfig`] ([`CutSettings`], [`Anchor`], [`MAX_PASSES`],
//!   [`MAX_BLADE_OFFSET_MM`]). Refusals are [`PlanError`] ([`SettingsError`], [`Fit`]): data that
//!   the command line words with its option names.
//! - [`machine`]: machine profiles (bed, [`machine::Motion`] limits, tool) loaded and validated
//!   from TOML, and the bed check of a program's moves.
//! - [`interpret`](mod@interpret): reads any G-code program the way Grbl 1.1h does (its parser's
//!   `ok`/`error:N` for every line, arcs cut into Grbl's chords, work offsets, moves in machine
//!   coordinates) and says which moves cut ([`interpret::CutRule`]).
//! - [`estimate`](mod@estimate) ([`Estimate`]): a program's run time as Grbl plans its motion
//!   (`estimate_program`: with Grbl's stops and dwells; checked against grbl-sim); also
//!   `estimate_with`, `length_over_feed_s`, `format_duration`.
//! - [`simulate`]: a picture of a program's moves, cut and travel in two colours.
//! - [`read_svg`]: the cut loops of an SVG drawing (ours or anyone's).
//! - [`grid`]: a test grid of squares over power or depth and speed.
//! - [`limits`]: Grbl 1.1's fixed sizes (line length, planner blocks, receive buffer).
//! - [`num`]: a number as the writer prints it (at most 3 decimals, no `-0`).
//!
//! Inside: `grbl` is Grbl 1.1h's `gc_execute_line` rewritten, `arc` its `mc_arc`; `toolpath` places the loops on the bed; `order` says what must be cut before what;
//! `travel` orders the loops and picks start points; `write` writes the text.

#![forbid(unsafe_code)]

mod arc;
mod cuts;
mod error;
pub mod estimate;
mod grbl;
pub mod grid;
pub mod interpret;
pub mod limits;
pub mod machine;
mod order;
pub mod read_svg;
pub mod simulate;
mod toolpath;
mod travel;
mod write;

pub use cuts::{CutLoops, Pieces};
pub use error::{Fit, PlanError, SettingsError};
pub use estimate::{estimate, Estimate};
pub use toolpath::{
    plan, Anchor, CutSettings, Job, Loop, PathStats, PlanConfig, MAX_BLADE_OFFSET_MM, MAX_PASSES,
};
pub use write::num;

use crate::machine::Machine;

/// What `make --emit gcode` needs besides the geometry: the machine and where and how to cut.
#[derive(Clone, Debug, PartialEq)]
pub struct GcodeConfig {
    pub machine: Machine,
    pub plan: PlanConfig,
    /// Where the cut settings came from (a kept settings file, a material profile's entry and
    /// its published source, the command line): written in the G-code's header and report.json,
    /// so the job can be made again with the same numbers. Empty when unknown.
    pub settings_from: String,
}

/// What a G-code job costs, as recorded in report.json and printed by `make` and `gcode`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GcodeSummary {
    pub machine: String,
    pub tool: String,
    pub settings: Option<CutSettings>,
    /// Where `settings` came from (see [`GcodeConfig::settings_from`]); absent in reports written
    /// before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settings_from: Option<String>,
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
    let program = interpret::interpret_program(&text).map_err(PlanError::Internal)?;
    let rule = machine.cut_rule(&program.moves);
    let est = estimate::estimate_program(&program, &machine.motion, rule);
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
