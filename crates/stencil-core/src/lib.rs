//! `stencil-core`: turn a picture or a 3D mesh into a stencil that holds together as one sheet.
//!
//! The crate reads as the pipeline (Bronson, Rheingans & Olano, "Semi-Automatic Stencil Creation
//! through Error Minimization", NPAR 2008). Data flows one way, stage to stage, as plain types:
//!
//! `tone` (picture or mesh → [`raster::TwoTone`]) → `islands` ([`islands::IslandMap`]) →
//! `bridge` ([`bridge::Bridged`]) → `vector` ([`vector::CutGeometry`], in mm) → `check`
//! ([`check::CheckReport`]); `export` encodes and writes the files. Toolpaths and G-code are the
//! `stencil-gcode` crate's, fed with `vector::CutGeometry::loops`.
//!
//! Stages before `vector` work in pixels; every conversion to millimetres reads one
//! [`units::Scale`] (the vector stage multiplies by its `mm_per_px`). Only `export` writes files
//! (input loading in `tone` and [`material::Material::find`] read them).
//!
//! ## Public API (the stages after the two-tone)
//! Everything else is `pub(crate)`: the stages' steps (bridge candidates, costs, tree and growth;
//! tracing, simplification and union; morphology and labelling; the mesh renderer's camera,
//! visibility, shading and lines; the SVG, DXF and mask encoders) are reached through the items
//! below.
//! - The facade: [`make`] (run and write, all or nothing), [`driver::run`] (in memory), their
//!   [`MakeConfig`] / [`pipeline::PhysicalConfig`] / [`pipeline::Emit`], the result
//!   [`pipeline::Made`], and [`Error`] (every error they return, as data: values and ranges,
//!   no option names; the `stencil` binary words them). Around them: [`driver::clean_two_tone`]
//!   (`stencil tone`), [`pipeline::default_out_dir`], [`pipeline::OUTPUT_NAMES`].
//! - The driver ([`driver`]): the stages listed once, in order, run by `make` ([`driver::run`]),
//!   by the studio with a [`driver::Cache`] that keeps each stage's output and re-runs from the
//!   first whose inputs changed, and by a layered set per layer ([`driver::Tweaks`]). The stages
//!   are [`pipeline`]'s files, one each, in the order the driver's documentation lists them.
//! - Before any work: a [`Request`] (the user's words) and its [`Inputs`] (the files it names,
//!   read once) go through the pure [`resolve()`] (size, [`fit`] to the bed or stock, gobo,
//!   etched widths, picture adjustments; [`Note`]s back) to the [`MakeConfig`] the driver runs;
//!   once the input is rendered, [`stage_params`] gives each stage's parameters in pixels
//!   ([`pipeline::StageParams`]).
//! - Stage functions the binary, tests and benches call: [`pipeline::vectorize_and_check`] (what
//!   `stencil check` runs), [`tone::load_gray`] / [`tone::picture_size`] /
//!   [`tone::otsu_level`], [`tone::mesh::load`] / [`tone::mesh::render`] /
//!   [`tone::mesh::render_mesh`] (= `tone::mesh::draw` of a [`tone::mesh::Prepared`] mesh,
//!   then `tone::mesh::light`) / [`tone::mesh::two_tone`], [`islands::label`] /
//!   [`islands::floating_count`], [`bridge::connect`] / [`bridge::connect_timed`],
//!   [`vector::vectorize`] / [`vector::vectorize_design`], [`check::check`], and the PNG encoders
//!   in [`export::png`].
//! - Plain types between stages, with the configs and stats they carry: [`raster::BitGrid`] /
//!   [`raster::Gray`] / [`raster::TwoTone`], [`islands::IslandMap`], [`bridge::Bridged`],
//!   [`vector::CutGeometry`], [`check::CheckReport`], [`report::Report`], [`units::Scale`] /
//!   [`units::Size`], [`material::Material`]; each stage's config ([`tone::ToneConfig`],
//!   [`tone::FilterConfig`], [`tone::mesh::MeshConfig`], [`bridge::BridgeConfig`],
//!   [`vector::VectorConfig`], [`export::MaskConfig`]) and error enum.
//! - Limits the CLI's option parsers read: the constants and checks in [`limits`], with
//!   [`limits::SizeError`].
//! - Progress and timing: [`pipeline::Progress`] (told each stage) and [`pipeline::Timings`], the
//!   one timing type of the crate (make's stages, [`bridge::connect_timed`]'s phases, the mesh
//!   renderer's steps).
//! - Not API: `vector::steps`, the vector stage's steps one by one for the `vector` bench, built
//!   only with the `bench-internals` feature.
//!
//! ## Example: a stencil from a picture
//! ```
//! use stencil_core::{driver, islands, MakeConfig};
//!
//! let cfg = MakeConfig {
//!     input: concat!(env!("CARGO_MANIFEST_DIR"), "/../../samples/rings.png").into(),
//!     ..Default::default()
//! };
//! let made = driver::run(&cfg)?; // in memory: nothing is written
//! assert_eq!(islands::floating_count(&made.bridged.bits), 0);
//! assert_eq!(made.check.pieces, 1);
//! assert!(!made.report.bridges.is_empty());
//! # Ok::<(), stencil_core::Error>(())
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod bridge;
pub mod check;
pub mod driver;
mod error;
pub mod export;
pub mod fit;
pub mod gobo;
mod inputs;
pub mod islands;
pub mod layers;
pub mod limits;
pub mod material;
pub mod pipeline;
mod plan;
pub mod raster;
pub mod report;
mod request;
mod resolve;
#[cfg(test)]
mod test_rng;
pub mod tiles;
mod timing;
pub mod tone;
pub mod units;
pub mod vector;

pub use driver::make;
pub use inputs::{stamp, Inputs, KeptInputs, Stamp};
pub use pipeline::Error;
pub use request::{BridgePlaces, Emit, KeepOut, MakeConfig, PhysicalConfig, Request};
pub use resolve::{resolve, resolve_picture, stage_params, Note};
