//! The stages, one file each, in order: `source` → `two_tone` → `clean_up` → `bridges` →
//! `vectors` → `outputs`, then `files` (all or nothing); their items are re-exported here. The
//! driver runs them; their parameters are the plan's (`plan.rs`), made by the pure resolve
//! (`resolve.rs`) from the request (`request.rs`).

pub(crate) mod bridges;
pub(crate) mod clean_up;
pub(crate) mod files;
pub(crate) mod outputs;
pub(crate) mod source;
pub(crate) mod two_tone;
pub(crate) mod vectors;

pub use bridges::{bridge_prepared, prepare, Joined, Prepared, PreparedKey};
pub use clean_up::{clean, clean_unmeasured, measure, Cleaned};
pub use files::{default_out_dir, OUTPUT_NAMES};
pub use outputs::{finish, gcode, report, report_joined, Made};
pub use source::{draw, is_mesh_path, light, load, Input, Source};
pub use two_tone::{look, threshold, working_gray};
pub use vectors::{refuse, trace, vectorize_and_check, Traced};

pub use crate::error::Error;
pub use crate::plan::{
    CleanParams, JoinParams, SourceParams, StageParams, ToneParams, TraceParams, UserParams,
    Working,
};
pub use crate::request::{Emit, MakeConfig, PhysicalConfig};
pub use crate::timing::{Progress, Timings};
pub use crate::units::Size;
