//! `stencil`: turn a picture or a 3D mesh into a stencil that holds together as one sheet, and drive
//! the machine that cuts it.
//!
//! The crate reads as the pipeline (Bronson, Rheingans & Olano, "Semi-Automatic Stencil Creation
//! through Error Minimization", NPAR 2008). Data flows one way, stage to stage, as plain types:
//!
//! `tone` (picture or mesh → [`raster::TwoTone`]) → `islands` ([`islands::IslandMap`]) →
//! `bridge` ([`bridge::Bridged`]) → `vector` (cut geometry in mm) → `check`; `export` writes files,
//! `plan` makes toolpaths and G-code, `machine` streams G-code to Grbl.
//!
//! Stages before `vector` work in pixels; millimetres appear only through [`units::Scale`]. Only
//! `export` and `machine` touch files and devices (plus input loading in `tone`).

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
pub mod tone;
pub mod units;
pub mod vector;

pub use pipeline::{make, Error, MakeConfig};
