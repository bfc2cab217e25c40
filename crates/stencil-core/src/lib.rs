//! `stencil-core`: turn a picture or a 3D mesh into a stencil that holds together as one sheet.
//!
//! The crate reads as the pipeline (Bronson, Rheingans & Olano, "Semi-Automatic Stencil Creation
//! through Error Minimization", NPAR 2008). Data flows one way, stage to stage, as plain types:
//!
//! `tone` (picture or mesh → [`raster::TwoTone`]) → `islands` ([`islands::IslandMap`]) →
//! `bridge` ([`bridge::Bridged`]) → `vector` ([`vector::CutGeometry`], in mm) → `check`
//! ([`check::CheckReport`]); `export` encodes and writes the files. Toolpaths and G-code are the
//! `stencil-gcode` crate's, fed with [`vector::CutGeometry::loops`].
//!
//! Stages before `vector` work in pixels; every conversion to millimetres reads one
//! [`units::Scale`] (the vector stage multiplies by its `mm_per_px`). Only `export` writes files
//! (input loading in `tone` and [`material::Material::find`] read them).
//!
//! ## Public API
//! Eighteen public modules, one per stage or shared type; every other module is private and
//! reached through re-exports. What outside callers (the `stencil` binary, the tests and benches)
//! use:
//! - The facade: [`make`] (run and write, all or nothing), [`pipeline::run`] (in memory), their
//!   [`MakeConfig`] / [`pipeline::PhysicalConfig`] / [`pipeline::Emit`], the result
//!   [`pipeline::Made`], and [`Error`] (every error they return, as data: values and ranges,
//!   no option names; the `stencil` binary words them).
//! - Stage functions: [`pipeline::two_tone`] and [`pipeline::clean_two_tone`] (`stencil tone`),
//!   [`tone::load_gray`], [`tone::mesh`] (load and render a mesh), [`islands::label`],
//!   [`bridge::connect`] / [`bridge::connect_timed`] with [`bridge::BridgeConfig`] (its
//!   [`bridge::constraints`] and [`bridge::strength`] settings), [`vector::vectorize`] /
//!   [`vector::vectorize_design`] and the vector stage's phases ([`vector::trace()`],
//!   [`vector::simplify_rings`], [`vector::union_bridges`], [`vector::cuts_of`]),
//!   [`pipeline::vectorize_and_check`] (what `stencil check` runs), [`check::check`] /
//!   [`check::cross_check`], [`pipeline::encode_outputs`] and the encoders in [`export`]
//!   ([`export::svg`], [`export::png`], [`export::mask`]; the DXF is written only through
//!   `encode_outputs`).
//! - Plain types between stages: [`raster::BitGrid`] / [`raster::Gray`] / [`raster::TwoTone`],
//!   [`islands::IslandMap`], [`bridge::Bridged`], [`vector::CutGeometry`],
//!   [`vector::VectorConfig`], [`check::CheckReport`] / [`check::Violation`],
//!   [`report::Report`], [`units::Scale`] / [`units::Size`], [`material::Material`],
//!   [`tone::ToneConfig`] / [`tone::FilterConfig`].
//! - Limits the CLI's option parsers read: the constants and checks in [`limits`], with
//!   [`limits::SizeError`].
//! - Progress and timing: [`pipeline::Progress`] (told each stage) and [`pipeline::Timings`], the
//!   one timing type of the crate (make's stages, [`bridge::connect_timed`]'s phases, the mesh
//!   renderer's steps).

#![forbid(unsafe_code)]

pub mod bridge;
pub mod check;
pub mod export;
pub mod islands;
pub mod limits;
pub mod material;
pub mod pipeline;
pub mod raster;
pub mod report;
mod timing;
pub mod tone;
pub mod units;
pub mod vector;

pub use pipeline::{make, Error, MakeConfig};
