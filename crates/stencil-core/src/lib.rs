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
//! ## Public API (the stages after the two-tone)
//! - The facade: [`make`] (run and write, all or nothing), [`pipeline::run`] (in memory), their
//!   [`MakeConfig`] / [`pipeline::PhysicalConfig`] / [`pipeline::Emit`], the result
//!   [`pipeline::Made`], and [`Error`] (every error they return, as data: values and ranges,
//!   no option names; the `stencil` binary words them).
//! - Stage functions the binary, tests and benches call: [`pipeline::two_tone`],
//!   [`pipeline::vectorize_and_check`] (what `stencil check` runs), [`pipeline::encode_outputs`],
//!   [`vector::vectorize`] / [`vector::vectorize_design`], [`check::check`] /
//!   [`check::cross_check`], the encoders in [`export`] ([`export::svg::encode`],
//!   [`export::dxf::encode`], [`export::png`], [`export::mask`]).
//! - Plain types between stages: [`vector::CutGeometry`], [`vector::VectorConfig`],
//!   [`check::CheckReport`] / [`check::Violation`], [`report::Report`], [`units::Scale`] /
//!   [`units::Size`], [`material::Material`].
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
