//! Why a job cannot be planned, as data: each variant holds the numbers and names its message
//! needs. The messages say what to change in words; the command line adds its option names
//! (`stencil`'s `cli/gcode.rs`), so this crate knows nothing of flags.

use crate::bounds::{MAX_BLADE_OFFSET_MM, MAX_PASSES};
use crate::num::num;

/// Why [`plan`](crate::plan), [`gcode_for`](crate::gcode_for) or
/// [`grid::plan_grid`](crate::grid::plan_grid) refused a job.
#[allow(missing_docs)] // Each variant's message says what its fields are.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    #[error(
        "the job ({w:.1} x {h:.1} mm) does not fit on the bed of '{machine}' ({bw:.1} x {bh:.1} mm): \
         at this placement it spans X {x0:.1}..{x1:.1}, Y {y0:.1}..{y1:.1} mm; {fix}"
    )]
    /// The job leaves the bed at this placement.
    DoesNotFit {
        machine: String,
        w: f64,
        h: f64,
        bw: f64,
        bh: f64,
        x0: f64,
        x1: f64,
        y0: f64,
        y1: f64,
        fix: Fit,
    },
    /// No loop to cut, and the sheet's outline is not cut either.
    #[error(
        "nothing to cut: the geometry has no cut regions (and the sheet's outline is not cut)"
    )]
    Empty,
    /// A drawing's open paths on a tool that cuts (a pen draws them).
    #[error(
        "the drawing has {count} open path(s) (lines, or shapes not closed with Z), and '{machine}' \
         has a {tool}: an open cut frees nothing, and an open path is often a shape whose closing \
         segment was lost. Close them in the drawing, or cut them open on purpose"
    )]
    OpenPaths {
        count: usize,
        machine: String,
        tool: &'static str,
    },
    #[error(transparent)]
    /// Cut settings the machine cannot run.
    Settings(#[from] SettingsError),
    /// A square of a test grid whose settings the machine refuses: `row` and `col` counted from
    /// 1, as printed; `label` is the square's caption (its power or depth and speed).
    #[error("square at row {row} column {col} ({label}): {cause}")]
    GridSquare {
        row: usize,
        col: usize,
        label: String,
        cause: Box<SettingsError>,
    },
    /// Our own output failed our own interpreter: a bug, reported rather than written.
    #[error("internal error: the written G-code does not run ({0}); please report this")]
    Internal(GcodeError),
}

/// What would make a job that leaves the bed fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fit {
    /// The job is larger than the bed.
    ScaleDown,
    /// The job would fit, placed elsewhere.
    Move,
    /// A test grid: fewer or smaller squares, or placed elsewhere.
    ShrinkGrid,
}

impl std::fmt::Display for Fit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Fit::ScaleDown => "scale the stencil down or use a larger machine",
            Fit::Move => "move it on the bed",
            Fit::ShrinkGrid => "use fewer steps, smaller squares or gaps, or move it",
        })
    }
}

/// Cut settings the machine cannot run, or a test grid that cannot be laid out.
#[allow(missing_docs)] // Each variant's message says what its fields are.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SettingsError {
    #[error("cutting speed must be at least {min} mm/min, got {got}")]
    /// A speed below the least feed.
    SpeedTooLow { min: f64, got: f64 },
    #[error(
        "cutting speed {speed} mm/min is above the max feed of '{machine}' ({max} mm/min); lower the speed"
    )]
    /// A speed above the machine's max feed.
    AboveMaxFeed {
        speed: f64,
        machine: String,
        max: f64,
    },
    #[error("blade offset must be 0..{MAX_BLADE_OFFSET_MM} mm, got {0}")]
    /// A blade offset out of range, mm.
    BladeOffset(f64),
    #[error("passes must be 1..{MAX_PASSES}, got {0}")]
    /// A number of passes out of range.
    Passes(u32),
    #[error("air assist is for a laser; '{machine}' has a {tool}: turn it off")]
    /// Air assist asked of a tool that is not a laser.
    AirAssistNotLaser { machine: String, tool: &'static str },
    #[error("laser power must be in (0, 100] %, got {0}")]
    /// A laser power out of range, %.
    LaserPower(f64),
    #[error(
        "laser power {power} % gives S0 on '{machine}' ($30={s_max}): the laser would not fire; \
         raise the power"
    )]
    /// A power so low that the S word is 0.
    LaserDark {
        power: f64,
        machine: String,
        s_max: f64,
    },
    #[error(
        "laser power {power} % gives S{s}, below the minimum S of '{machine}' ($31={s_min}); raise the power"
    )]
    /// A power whose S is under the machine's `$31`.
    BelowSMin {
        power: f64,
        s: f64,
        machine: String,
        s_min: f64,
    },
    #[error("the squares need a size > 0 and a gap >= 0")]
    /// A test grid's square size or gap out of range.
    GridSquares,
    #[error("the grid needs at least one speed")]
    /// A test grid without speeds.
    GridNoSpeed,
    #[error("depth Z{} is not below the blade's up height Z{} of '{machine}'", num(*depth), num(*up))]
    /// A knife depth not below its up height.
    DepthAboveBlade {
        depth: f64,
        up: f64,
        machine: String,
    },
    #[error("a grid over {kind:?} does not apply to the {tool} of '{machine}'")]
    /// A test grid's rows that do not suit the tool.
    GridKind {
        kind: RowKind,
        tool: &'static str,
        machine: String,
    },
}

/// A line the interpreter cannot run, with Grbl's error code where Grbl has one.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("line {line}: {msg}{}", if *out_of_range { String::new() } else { format!(" (Grbl error:{code})") })]
pub struct GcodeError {
    /// The line, from 1.
    pub line: usize,
    /// Grbl's `error:N` code.
    pub code: u8,
    /// What is wrong, in words.
    pub msg: String,
    /// A number beyond what any machine can do ([`MAX_COORD_MM`](crate::interpret::MAX_COORD_MM), [`MAX_FEED_MM_MIN`](crate::interpret::MAX_FEED_MM_MIN),
    /// [`MAX_S`](crate::interpret::MAX_S)), or not finite: the program is refused whole, not passed on to Grbl.
    pub out_of_range: bool,
}

impl GcodeError {
    /// A number (or a program) beyond what any machine does: refused whole, with Grbl's
    /// `error:2` (bad number format) as the nearest code.
    pub fn out_of_range(line: usize, msg: String) -> GcodeError {
        GcodeError {
            line,
            code: 2,
            msg,
            out_of_range: true,
        }
    }
}

/// A refusal with Grbl's error code.
pub(crate) fn fail(line: usize, code: u8, msg: impl Into<String>) -> GcodeError {
    GcodeError {
        line,
        code,
        msg: msg.into(),
        out_of_range: false,
    }
}

/// What the rows vary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RowKind {
    /// Laser power, %.
    Power,
    /// Knife (or pen on Z) depth: the Z the tool is lowered to, mm.
    Depth,
    /// One row: only the speed varies (a pen).
    None,
}
