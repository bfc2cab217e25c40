//! G-code for GRBL machines from closed cut loops in millimetres: machine profiles, toolpaths, cut
//! order and travel, the G-code writer, the G-code interpreter and the time estimate. Knows
//! nothing of pictures or stencils: its input is [`CutLoops`].
//!
//! - [`gcode_for`]: plan and write a job, and time it; [`plan`] alone gives the [`Job`]. Refusals
//!   are [`PlanError`]: data that the command line words with its option names.
//! - [`machine`]: machine profiles loaded and validated from TOML; [`bounds`]: the ranges their
//!   numbers and cut settings must lie in.
//! - [`interpret`](mod@interpret): reads any G-code program the way Grbl 1.1h does (`ok` or
//!   `error:N` for every line, arcs cut into Grbl's chords, work offsets).
//! - [`estimate_program`]: a program's run time as Grbl plans its motion.
//! - [`simulate`]: a picture of a program's moves; [`read_svg`]: the cut loops of an SVG drawing;
//!   [`plan_grid`]: a test grid; [`limits`]: Grbl 1.1's fixed sizes; [`num`]: a number as
//!   written.
//!
//! Inside, each file uses only those below it: `grbl` is Grbl 1.1h's `gc_execute_line`, `arc` its
//! `mc_arc`; `toolpath` places the loops, `order` says what is cut before what, `travel` picks the
//! order and start points, `write` writes the text.
//!
//! ```
//! use geo::{LineString, MultiPolygon, Polygon, Rect};
//! use stencil_gcode::{gcode_for, machine, CutLoops, CutSettings, PlanConfig};
//!
//! // A 20 mm square hole in a 40 mm sheet, cut on the default machine.
//! let square = LineString::from(vec![(10., 10.), (30., 10.), (30., 30.), (10., 30.), (10., 10.)]);
//! let sheet = Rect::new((0., 0.), (40., 40.));
//! let loops = CutLoops::drawn(sheet, MultiPolygon(vec![Polygon::new(square, vec![])]));
//! let m = machine::load(None).unwrap();
//! let (power_pct, speed_mm_min, passes) = (80.0, 600.0, 1);
//! let settings = CutSettings { power_pct, speed_mm_min, passes, blade_offset_mm: 0.0, air_assist: false };
//! let (text, summary) = gcode_for(&loops, &m, &PlanConfig::new(settings), &[]).unwrap();
//! assert!(text.contains("\nG1 "));
//! assert!(text.trim_end().ends_with("M2") && text.rfind("M5") > text.rfind("\nG1 "));
//! assert!(summary.estimate.total_s > 0.0);
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod arc;
pub mod blade;
pub mod bounds;
mod cuts;
mod error;
mod estimate;
mod gcode;
mod grbl;
mod grid;
pub mod interpret;
mod job;
mod keep_fed;
pub mod limits;
pub mod machine;
mod modal;
mod num;
mod order;
mod read_svg;
pub mod simulate;
mod starve;
mod toolpath;
mod travel;
mod word;
mod write;

pub use cuts::{CutLoops, Pieces};
pub use error::{Fit, PlanError, RowKind, SettingsError};
pub use estimate::{
    estimate, estimate_program, estimate_program_from, estimate_with, format_duration,
    length_over_feed_s, Estimate,
};
pub use gcode::{gcode_for, GcodeConfig, GcodeSummary};
pub use grid::{grid_gcode, grid_svg, plan_grid, Cell, Grid, GridSpec, Steps};
pub use job::{CutSettings, Job, Loop, PathStats};
pub use keep_fed::{Feeding, Slowed};
pub use num::num;
pub use read_svg::{
    cut_loops_from_svg, read as read_svg, SvgDrawing, SvgError, FLATTEN_TOLERANCE_MM,
};
pub use starve::{estimate_streamed, Starve, Streamed, MIN_LOST_S};
pub use toolpath::{plan, Anchor, PlanConfig};
pub use write::unwrap_comment;
