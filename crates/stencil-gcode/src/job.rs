//! What the planner hands the writer: a job's loops in cut order, its settings and its travel.

use stencil_geom::curve::{self, Piece};
use stencil_geom::ring::dist;

/// How the material is cut: the planner's view of a material profile (the CLI maps a `Material`
/// onto it, or the user gives `--power/--speed/--passes`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CutSettings {
    /// Laser power in percent of full (`$30`); ignored by pens and knives.
    pub power_pct: f64,
    /// Cutting feed, mm/min.
    pub speed_mm_min: f64,
    /// How many times each loop is cut.
    pub passes: u32,
    /// Drag knife only: how far the blade tip trails the knife's axis, mm (0 = no compensation).
    /// The writer then overshoots each corner by this much and swivels the blade around it.
    #[serde(default)]
    pub blade_offset_mm: f64,
    /// Laser only: air assist on with the beam (`M8` before the first cut, `M9` at the end).
    #[serde(default)]
    pub air_assist: bool,
}

/// One closed loop in machine mm, rotated so that `points[0]` is where the cut starts and ends.
/// The closing segment back to `points[0]` is implied.
#[derive(Clone, Debug, PartialEq)]
pub struct Loop {
    /// The loop's corners, machine mm.
    pub points: Vec<[f64; 2]>,
    /// The sheet's outline (the frame cut), not a cut region.
    pub outline: bool,
    /// Enclosed area, mm².
    pub area_mm2: f64,
    /// The loop as the head follows it when the job writes arcs: lines and arcs fitted to
    /// `points` within [`Job::arc_tolerance_mm`], in machine mm, from `points[0]` (every piece
    /// starts at one of the points). Empty: the points' straight segments. Fitted by the
    /// planner, not the writer: on the sheet from the ring's first point, as the SVG and DXF
    /// carry it, and inside the job's box ([`curve::fit_ring_inside`]), so that the job lands
    /// where its polygons put it and the bed check sees every arc's true extent.
    pub curve: Vec<Piece>,
}

impl Loop {
    /// The length the head cuts in one pass: the arcs' when the loop has them.
    pub(crate) fn perimeter_mm(&self) -> f64 {
        if !self.curve.is_empty() {
            return curve::length(&self.curve);
        }
        let n = self.points.len();
        (0..n)
            .map(|i| dist(self.points[i], self.points[(i + 1) % n]))
            .sum()
    }
}

/// Travel of a job, compared with cutting the loops in input order from their first vertex.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PathStats {
    /// Loops cut.
    pub loops: usize,
    /// Open paths drawn (or cut open), besides the loops.
    #[serde(default)]
    pub lines: usize,
    /// Length cut, all passes, mm.
    pub cut_mm: f64,
    /// Tool-off travel of the optimised order, from the start point, back to it, mm.
    pub travel_mm: f64,
    /// The same for the input order with each loop started at its first vertex, mm.
    pub naive_travel_mm: f64,
}

/// A planned job: loops in cut order, ready for the G-code writer.
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    /// Open paths in machine mm, in the order drawn, each from its first point to its last:
    /// drawn before the loops, while the sheet is whole.
    pub lines: Vec<Vec<[f64; 2]>>,
    /// The loops, in cut order.
    pub loops: Vec<Loop>,
    /// Where the head starts and returns to (machine 0, 0).
    pub home: [f64; 2],
    /// How every loop is cut.
    pub settings: CutSettings,
    /// The sheet's size and its placed lower-left / upper-right corners in machine mm.
    pub sheet_mm: [f64; 2],
    /// The placed sheet's lower-left corner.
    pub min: [f64; 2],
    /// The placed sheet's upper-right corner.
    pub max: [f64; 2],
    /// Loops, lengths and travel.
    pub stats: PathStats,
    /// Loops are written as arcs fitted within this many mm (0: straight segments), as
    /// [`PlanConfig::arc_tolerance_on`](crate::PlanConfig::arc_tolerance_on) says; each loop's
    /// [`Loop::curve`] holds them.
    pub arc_tolerance_mm: f64,
}
