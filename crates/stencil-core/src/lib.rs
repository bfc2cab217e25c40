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

pub use pipeline::{make, MakeConfig};

/// Every error the library returns. Each message names the file, line or setting and what to do.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Tone(#[from] tone::ToneError),
    #[error(transparent)]
    Bridge(#[from] bridge::BridgeError),
    #[error(transparent)]
    Export(#[from] export::ExportError),
    #[error(transparent)]
    Plan(#[from] stencil_gcode::PlanError),
    #[error(transparent)]
    Profile(#[from] stencil_io::profile::ProfileError),
    #[error(transparent)]
    Vector(#[from] vector::VectorError),
    #[error(transparent)]
    Check(#[from] check::CheckError),
    #[error(transparent)]
    Limit(#[from] limits::SizeError),
    #[error(
        "{count} width or connectivity violation(s) for material '{material}': {list}; \
         widen the design, choose another --material, or pass --allow-thin to write the outputs anyway"
    )]
    Thin {
        count: usize,
        material: String,
        list: String,
    },
    #[error(
        "{count} material piece(s) still float after bridging; the first, {area} px, is at pixel ({x}, {y}) \
         (every island should have been joined: this is a bug, please report it with the picture)"
    )]
    Floating {
        count: usize,
        x: u32,
        y: u32,
        area: usize,
    },
    /// The stencil differs from the thresholded picture by more than the limit the caller set
    /// ([`pipeline::PhysicalConfig::max_change_pct`]); nothing was written.
    #[error(
        "the clean-up and the bridges changed {:.2} % of the picture, more than the limit of {limit_pct} %",
        fidelity.changed_pct
    )]
    TooMuchChange {
        /// What was measured (all of it, so a caller can say what changed most).
        fidelity: report::Fidelity,
        limit_pct: f64,
    },
}
