//! Every error the pipeline returns, as data (values and ranges, no option names): the stages'
//! errors, the pipeline's own findings, a set's. A leaf beside the stages, so the stage functions
//! (`pipeline`), the driver and the set code (`layers`) all return it without using each other.

use crate::limits::MAX_LAYERS;

/// Every error `make` returns (the stages' errors, and the pipeline's own findings),
/// as data: the `stencil` binary words them with the options to change.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or thresholding the picture, or rendering the mesh.
    #[error(transparent)]
    Tone(#[from] crate::tone::ToneError),
    /// The keep-out picture could not be read (read once, shared by every run of the request).
    #[error(transparent)]
    KeepOut(std::sync::Arc<crate::tone::ToneError>),
    /// The size asked for does not fit, or cannot be decided.
    #[error(transparent)]
    Sizing(#[from] crate::fit::SizingError),
    /// Joining the islands.
    #[error(transparent)]
    Bridge(#[from] crate::bridge::BridgeError),
    /// Writing the output files.
    #[error(transparent)]
    Export(#[from] crate::export::ExportError),
    /// Planning the toolpaths and G-code.
    #[error(transparent)]
    Plan(#[from] stencil_gcode::PlanError),
    /// Writing the HP-GL job (its planning refusals are [`Error::Plan`]).
    #[error(transparent)]
    Hpgl(stencil_hpgl::HpglError),
    /// A material or machine profile, or kept settings.
    #[error(transparent)]
    Profile(#[from] stencil_io::profile::ProfileError),
    /// Tracing the outlines.
    #[error(transparent)]
    Vector(#[from] crate::vector::VectorError),
    /// Checking the cut geometry.
    #[error(transparent)]
    Check(#[from] crate::check::CheckError),
    /// A size stencil cannot work at.
    #[error(transparent)]
    Limit(#[from] crate::limits::SizeError),
    /// A layered set's request.
    #[error(transparent)]
    Layers(#[from] LayersError),
    /// A tiled stencil's request.
    #[error(transparent)]
    Tiles(#[from] TilesError),
    /// The check found violations and the caller did not allow them
    /// (`PhysicalConfig::allow_thin`); nothing was written.
    #[error(
        "{} width or connectivity violation(s) for material '{material}': {}",
        violations.len(), list_violations(violations)
    )]
    Thin {
        /// The material profile's name.
        material: String,
        /// All of them, as the check reported them.
        violations: Vec<crate::check::Violation>,
    },
    /// Islands left after bridging (a bug).
    #[error(
        "{count} material piece(s) still float after bridging; the first, {area} px, is at pixel ({x}, {y}) \
         (every island should have been joined: this is a bug, please report it with the picture)"
    )]
    Floating {
        /// How many pieces float.
        count: usize,
        /// The first piece's pixel column.
        x: u32,
        /// Its pixel row.
        y: u32,
        /// Its area, pixels.
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
        /// The limit, % of the picture.
        limit_pct: f64,
    },
}

impl Error {
    /// The picture or mesh read that this error is about, when its message names it (a
    /// caller naming the input itself does so only for the others).
    pub fn subject(&self) -> Option<&std::path::Path> {
        match self {
            Error::Tone(e) => e.subject(),
            Error::Layers(LayersError::Colour { path, .. }) => Some(path),
            _ => None,
        }
    }
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
    /// A layer count outside 1 to `MAX_LAYERS`.
    #[error("{0} layers: a set has 1 to {MAX_LAYERS}")]
    Count(u32),
    #[error("{given} level(s) for {count} layer(s): give one level per layer")]
    /// Not one level per layer.
    Levels {
        /// Levels given.
        given: usize,
        /// Layers asked for.
        count: u32,
    },
    /// A level given twice.
    #[error("the level {0} is given twice: each layer needs its own level")]
    SameLevel(u8),
    #[error("{given} colour(s) for {count} layer(s): give one per layer (light to dark), or one more with the surface's first")]
    /// Not one colour per layer (or one more for the surface).
    Colors {
        /// Colours given.
        given: usize,
        /// Layers asked for.
        count: u32,
    },
    /// A mesh given for a layered set.
    #[error("layers are cut from a picture, not a mesh")]
    Mesh,
    /// Swapped tones asked for a layered set.
    #[error("layers paint the picture's dark tones through the cuts; swapping the tones does not apply to them")]
    Invert,
    /// A keep-out picture with layers or registration marks.
    #[error("a keep-out picture is not supported with layers or registration marks (the sheet grows around the picture); use keep-out discs")]
    KeepOut,
    /// The picture's colours could not be read.
    #[error("{path}: cannot read the picture's colours: {msg}")]
    Colour {
        /// The picture.
        path: std::path::PathBuf,
        /// What the decoder said.
        msg: String,
    },
}

/// A tiled run's errors, as data (the `stencil` binary words them with its options).
#[derive(Debug, thiserror::Error)]
pub enum TilesError {
    /// Automatic tiles with nothing to fit them to.
    #[error("automatic tiles need a bed or a sheet to fit")]
    NoStock,
    /// The stock leaves no room for a tile after its margins and overlaps.
    #[error(
        "a {w_mm} x {h_mm} mm stock leaves no room for a tile: its {margin_mm} mm margins and \
         {overlap_mm} mm overlaps take it all"
    )]
    StockTooSmall {
        /// Stock width, mm.
        w_mm: f64,
        /// Stock height, mm.
        h_mm: f64,
        /// The sheet's margin, mm.
        margin_mm: f64,
        /// The overlap past each seam, mm.
        overlap_mm: f64,
    },
    /// More tiles along a side than the limit.
    #[error("{cols} x {rows} tiles: at most {max} along each side")]
    TooMany {
        /// Columns.
        cols: u32,
        /// Rows.
        rows: u32,
        /// The limit per side.
        max: u32,
    },
    /// A tile comes out larger than the stock it must fit.
    #[error(
        "tile {row}-{col} is {w_mm:.1} x {h_mm:.1} mm with its margin, larger than the \
         {stock_w_mm} x {stock_h_mm} mm stock"
    )]
    TileTooLarge {
        /// Its row, from 1.
        row: u32,
        /// Its column, from 1.
        col: u32,
        /// Its sheet's width, mm.
        w_mm: f64,
        /// Its sheet's height, mm.
        h_mm: f64,
        /// The stock's width, mm.
        stock_w_mm: f64,
        /// The stock's height, mm.
        stock_h_mm: f64,
    },
    /// Seam places given that do not match the tiles.
    #[error(
        "{given} {axis} seam place(s) for {want}: give one per seam, in order, each inside the \
         picture (0 to {size_mm:.1} mm) and at least {gap_mm:.1} mm from the next"
    )]
    Seams {
        /// "vertical" or "horizontal".
        axis: &'static str,
        /// How many were given.
        given: usize,
        /// How many seams there are.
        want: usize,
        /// The picture's size along that axis, mm.
        size_mm: f64,
        /// The least distance between seams, mm.
        gap_mm: f64,
    },
    /// An overlap that is not a finite number in range.
    #[error("an overlap of {0} mm: it must be from {min} to {max} mm", min = crate::limits::MIN_TILE_OVERLAP_MM, max = crate::limits::MAX_TILE_OVERLAP_MM)]
    Overlap(f64),
    /// A request tiles do not support.
    #[error("tiles are not made for {0}")]
    Unsupported(&'static str),
}
