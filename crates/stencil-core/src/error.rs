//! Every error the pipeline returns, as data (values and ranges, no option names): the stages'
//! errors, the pipeline's own findings, a set's. A leaf beside the stages, so the stage functions
//! (`pipeline`), the driver and the set code (`layers`) all return it without using each other.

use crate::limits::MAX_LAYERS;

/// Every error `make` returns (the stages' errors, and the pipeline's own findings),
/// as data: the `stencil` binary words them with the options to change.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Tone(#[from] crate::tone::ToneError),
    /// The keep-out picture could not be read (read once, shared by every run of the request).
    #[error(transparent)]
    KeepOut(std::sync::Arc<crate::tone::ToneError>),
    #[error(transparent)]
    Sizing(#[from] crate::fit::SizingError),
    #[error(transparent)]
    Bridge(#[from] crate::bridge::BridgeError),
    #[error(transparent)]
    Export(#[from] crate::export::ExportError),
    #[error(transparent)]
    Plan(#[from] stencil_gcode::PlanError),
    #[error(transparent)]
    Profile(#[from] stencil_io::profile::ProfileError),
    #[error(transparent)]
    Vector(#[from] crate::vector::VectorError),
    #[error(transparent)]
    Check(#[from] crate::check::CheckError),
    #[error(transparent)]
    Limit(#[from] crate::limits::SizeError),
    #[error(transparent)]
    Layers(#[from] LayersError),
    /// The check found violations and the caller did not allow them
    /// (`PhysicalConfig::allow_thin`); nothing was written.
    #[error(
        "{} width or connectivity violation(s) for material '{material}': {}",
        violations.len(), list_violations(violations)
    )]
    Thin {
        material: String,
        /// All of them, as the check reported them.
        violations: Vec<crate::check::Violation>,
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
    /// (`PhysicalConfig::max_change_pct`); nothing was written.
    #[error(
        "the clean-up and the bridges changed {:.2} % of the picture, more than the limit of {limit_pct} %",
        fidelity.changed_pct
    )]
    TooMuchChange {
        /// What was measured (all of it, so a caller can say what changed most).
        fidelity: crate::report::Fidelity,
        limit_pct: f64,
    },
}

/// How many violations an error message lists.
const LISTED_IN_ERROR: usize = 5;

/// The first [`LISTED_IN_ERROR`] violations, `; ` between them.
fn list_violations(violations: &[crate::check::Violation]) -> String {
    violations
        .iter()
        .take(LISTED_IN_ERROR)
        .map(|v| v.to_string())
        .collect::<Vec<_>>()
        .join("; ")
}

/// A layered run's errors, as data (the `stencil` binary words them with its options).
#[derive(Debug, thiserror::Error)]
pub enum LayersError {
    #[error("{0} layers: a set has 1 to {MAX_LAYERS}")]
    Count(u32),
    #[error("{given} level(s) for {count} layer(s): give one level per layer")]
    Levels { given: usize, count: u32 },
    #[error("the level {0} is given twice: each layer needs its own level")]
    SameLevel(u8),
    #[error("{given} colour(s) for {count} layer(s): give one per layer (light to dark), or one more with the surface's first")]
    Colors { given: usize, count: u32 },
    #[error("layers are cut from a picture, not a mesh")]
    Mesh,
    #[error("layers paint the picture's dark tones through the cuts; swapping the tones does not apply to them")]
    Invert,
    #[error("a keep-out picture is not supported with layers or registration marks (the sheet grows around the picture); use keep-out discs")]
    KeepOut,
    #[error("{path}: cannot read the picture's colours: {msg}")]
    Colour {
        path: std::path::PathBuf,
        msg: String,
    },
}
