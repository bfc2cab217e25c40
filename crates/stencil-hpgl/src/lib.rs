//! HP-GL for plotter cutters and pen plotters: a vinyl cutter (generic HP-GL), a Roland CAMM-GL
//! cutter, a Graphtec in HP-GL mode, an HP 7475A-style pen plotter. Knows nothing of pictures:
//! its input is the G-code crate's cut loops, placed, ordered and routed by that crate's planner,
//! so an HP-GL job cuts the same outlines in the same order as the G-code job.
//!
//! - [`profile`]: plotter profiles (TOML with an `[hpgl]` table), validated at load.
//! - [`hpgl_for`]: plan and write a job, with a drag knife's blade physics (the G-code crate's
//!   blade module: corner swivels, the orientation move, the overcut) and small features slowed.
//! - [`command`]: the instructions as data, written and parsed.
//! - [`cutter`]: the virtual plotter cutter (buffer, flow control, dialect, tool state, drawing).
//! - [`stream`]: sending a program with the plotter's flow control, pause, resume and abort.
//! - [`weed`]: weeding aids (a box around the job, lines across large cut-out areas only).

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod command;
pub mod cutter;
pub mod profile;
pub mod stream;
pub mod weed;
mod write;

pub use write::{hpgl_for, HpglConfig, HpglError, HpglSummary, PARK_PAST_MM, POINTS_PER_COMMAND};
