//! Every integration test of the `stencil` package, gathered into ONE test program.
//!
//! Why one: each file under `tests/` used to be its own test program, linked against the whole
//! workspace and its dependencies (26 programs, 706 MB, 23 minutes on a busy 2-core machine;
//! issue 25 item 8). One program links once.
//!
//! The layout, kept flat on purpose:
//! - `tests/it/main.rs` (this file) declares one module per former test file, in alphabetical
//!   order; `tests/it/NAME.rs` is what `tests/NAME.rs` was, except that it reaches the helpers
//!   through `use crate::common::…` instead of declaring `mod common;` itself.
//! - `tests/common/` holds the shared helpers, declared once here as `crate::common` and
//!   `crate::common_job` (`tests/common/job.rs`; a file may be a module only once).
//! - A proptest regressions file sits beside its module (`tests/it/NAME.proptest-regressions`).
//! - Fixtures are found from `CARGO_MANIFEST_DIR` (`tests/fixtures/...`), not relative to a file.
//!
//! To add a test file: put it in `tests/it/`, add `mod NAME;` below, and `use crate::common;` if
//! it uses the helpers. Run one file's tests with `cargo test --test it NAME::` (module path as a
//! filter). The browser test (`studio_browser`) still skips unless chromedriver is on the PATH, or
//! fails without it when `STENCIL_BROWSER_TEST=required`.

#[path = "../common/mod.rs"]
mod common;
#[path = "../common/job.rs"]
mod common_job;
/// Meshes shared with stencil-core's own tests (one declaration: clippy's `duplicate_mod`).
#[path = "../../crates/stencil-core/tests/support/shapes.rs"]
mod shapes;
// shapes.rs names the mesh type as `super::Mesh`.
use stencil_core::tone::mesh::Mesh;

mod architecture;
mod bad_input;
mod bridge_light;
mod bridge_report;
mod bridge_search;
mod bridge_stability;
mod bridge_user;
mod bridge_weights;
mod bridge_width;
mod busy_host;
mod check;
mod crop_keep_out;
mod curve_budget;
mod curves;
mod cut_settings;
mod doc_paths;
mod fit;
mod frame;
mod gcode;
mod gobo;
mod grbl_motion;
mod grbl_parity;
mod grbl_sim_reference;
mod grblhal_sim;
mod grid;
mod help_headings;
mod hostile_options;
mod hostile_parsers;
mod hpgl;
mod hpgl_send;
mod hpgl_weed;
mod jog;
mod layers;
mod machine;
mod machine_safety;
mod make;
mod masks;
mod mesh;
mod mesh_light;
mod photo;
mod photo_tone;
mod plan;
mod profiles;
mod property;
mod regularize;
mod resolution;
mod send_card;
mod send_dialects;
mod send_safety;
mod start_from;
mod starve;
mod strength;
mod studio;
mod studio_browser;
mod studio_tiles;
mod third_party;
mod tiles;
mod trust;
mod vector;
