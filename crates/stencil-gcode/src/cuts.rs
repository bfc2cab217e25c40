//! The planner's input: closed cut loops in sheet millimetres (x right, y down), from `make`'s
//! stencil or from a drawing, and what is known of the pieces the cuts free.

use geo::{LineString, MultiPolygon, Rect};
use stencil_geom::curve::Curves;
use stencil_geom::{kerf, ClipError};

/// Closed loops to cut on a sheet.
#[derive(Clone, Debug, PartialEq)]
pub struct CutLoops {
    /// The sheet's edge: where the job is placed on the bed and what the bed must hold.
    pub outline: Rect<f64>,
    /// The tool paths: every ring of every polygon is one closed loop (holes, which bridged
    /// stencils do not have, are cut before their exterior).
    pub cuts: MultiPolygon<f64>,
    /// The kerf `cuts` were offset for (0 when not offset): the planner widens the gaps it takes
    /// for bridges by it.
    pub kerf_mm: f64,
    /// What is known of the pieces of material the cuts free, for the cut order.
    pub pieces: Pieces,
    /// Open paths of a drawing (lines, polylines, paths without `Z`), sheet mm: a pen draws them
    /// as they are, which is what plotter drawings are made of. A cutting tool refuses them
    /// unless told to cut them open ([`PlanConfig::cut_open_paths`](crate::PlanConfig)): a cut
    /// that does not close frees nothing, and an open path in a stencil design is usually a
    /// shape whose closing segment was lost. Cut or drawn before every closed loop, while the
    /// sheet is still whole. `make` has none.
    pub lines: Vec<LineString<f64>>,
    /// The sheet's edge as it is cut when that is not `outline`'s rectangle: a gobo's rim, a
    /// closed ring inside `outline` (already offset for the kerf). Cut last, as the outline is.
    pub outline_ring: Option<LineString<f64>>,
    /// The lines and arcs that rings of `cuts` are the flattening of (`make`'s fitted curves
    /// and their kerf offset): a job with arcs writes these, not arcs fitted to the polygons
    /// again. Empty for a drawing.
    pub curves: Curves,
}

/// What the planner knows of the pieces of material the cuts free (every cut inside a piece must
/// come before the cuts that free it, or the piece moves while it is cut).
#[derive(Clone, Debug, PartialEq)]
pub enum Pieces {
    /// The cut regions as designed before bridging: each island is a hole in the region around
    /// it, so which cuts surround which island is exact (`make` passes these).
    Regions(MultiPolygon<f64>),
    /// The design has no islands: nothing is freed but the outline's inside (`make` on a picture
    /// without islands).
    NoIslands,
    /// Not known (a drawing read from a file): bridge-wide gaps between cuts are closed
    /// geometrically to find the pieces.
    Unknown,
}

impl CutLoops {
    /// A drawing's cut regions as drawn, nothing known of its pieces.
    pub fn drawn(outline: Rect<f64>, cuts: MultiPolygon<f64>) -> Self {
        CutLoops {
            outline,
            cuts,
            kerf_mm: 0.0,
            pieces: Pieces::Unknown,
            lines: Vec::new(),
            outline_ring: None,
            curves: Curves::default(),
        }
    }

    /// Offset the cuts for a tool that removes a strip `kerf_mm` wide ([`kerf::offset_cuts`]).
    pub fn apply_kerf(&mut self, kerf_mm: f64) -> Result<(), ClipError> {
        self.cuts = kerf::offset_cuts(&self.cuts, kerf_mm)?;
        self.kerf_mm = kerf_mm.max(0.0);
        Ok(())
    }
}
