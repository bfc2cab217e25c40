//! Stage 4: from the bridged bit grid to cut geometry in millimetres: marching squares
//! (`trace`), simplification (`simplify`), bridge union (`union`), kerf offset ([`kerf`]).
//!
//! The sheet: the frame convention of `islands` (outside the picture is material) means the sheet
//! continues beyond the picture. The physical sheet is the picture plus a margin on every side
//! ([`VectorConfig::margin_mm`]), so that cut regions touching the picture's edge stay holes in one
//! sheet, exactly as the raster stages saw them.

pub(crate) mod simplify;
pub(crate) mod trace;
pub(crate) mod union;

use geo::orient::{Direction, Orient};
use geo::{Coord, LineString, MultiPolygon, Polygon, Rect};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use stencil_gcode::{CutLoops, Pieces};
use stencil_geom::clip;
use stencil_geom::curve::{Curves, Piece};
use stencil_geom::kerf;
use stencil_geom::ring::{bbox, point_in_ring, signed_area2};

use crate::raster::BitGrid;
use crate::units::{Mm, Scale};

pub use simplify::SimplifyStats;

/// The steps of [`vectorize_design`] one by one, so that the `vector` bench can show where the
/// stage's time goes. Not API: built only with the `bench-internals` feature, which the root
/// package's dev-dependency turns on (with the workspace's resolver 1 that holds for every build
/// of the workspace, so nothing outside the benches may use it).
#[cfg(feature = "bench-internals")]
pub mod steps {
    pub use super::simplify::simplify_rings;
    pub use super::trace::{trace, Guard, Ring};
    pub use super::union::{cuts_of, union_bridges};
}

/// The stencil as physical geometry, in millimetres, x right and **y down** with the origin at the
/// image's top-left corner (the raster and SVG convention; G-code flips to y up when it places the
/// job on the bed).
///
/// Contract between `vector` (which fills it) and `check`, `export` and `plan` (which read it).
#[derive(Clone, Debug)]
pub struct CutGeometry {
    /// Size of the picture, in mm (the sheet is this plus `margin_mm` on every side).
    pub width_mm: f64,
    /// Its height, mm.
    pub height_mm: f64,
    /// The sheet's edge: the picture grown by the margin (`-margin .. width + margin`).
    pub outline: Rect<f64>,
    /// Regions cut away (holes through the sheet) as the tool paths: the design cuts with the
    /// kerf applied by [`CutGeometry::apply_kerf`] (until then, the design cuts themselves), one
    /// closed loop (polygon exterior) per cut region. After bridging they have no holes: a hole in
    /// a cut region would be a floating island.
    pub cuts: MultiPolygon<f64>,
    /// The same regions as designed, without kerf (what SVG and DXF carry: CAM software applies
    /// its own kerf).
    pub design_cuts: MultiPolygon<f64>,
    /// The material that stays (the sheet, bridges unioned in), without kerf. Exteriors
    /// counter-clockwise in the numeric (x, y) plane, holes clockwise.
    pub material: MultiPolygon<f64>,
    /// Bridge polygons as placed by the bridge stage, in mm.
    pub bridges: Vec<Polygon<f64>>,
    /// The cut regions as designed before bridging (no kerf), each island a hole in the region
    /// around it: which cuts surround which island, for the planner's cut order (every cut inside
    /// an island before the cuts around it). Empty when not known (read from an SVG) or not asked
    /// for (see [`CutGeometry::set_unbridged`]).
    pub(crate) unbridged_cuts: MultiPolygon<f64>,
    /// The kerf `cuts` were offset for (0 until [`CutGeometry::apply_kerf`]): the planner widens
    /// the gaps it takes for bridges by it.
    pub kerf_mm: f64,
    /// A gobo's rim (`--gobo`): then the sheet's cut edge is this circle, not `outline`
    /// (which becomes the rim's square grown by the margin; `gobo::place` puts it).
    pub(crate) rim: Option<Rim>,
    /// The lines and arcs that rings of `design_cuts` (and of `cuts`, after
    /// [`CutGeometry::apply_kerf`]) are the flattening of: the curves fitted to the traced
    /// outline, which SVG, DXF and G-code write as they are rather than fitting arcs to the
    /// polygons again. Empty without arcs; a ring a later step changes is not found in it (its
    /// writer fits it).
    pub curves: Curves,
}

/// A gobo's rim and image area placed on a stencil, in the picture's millimetres (y down)
/// (see `crate::gobo`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct Rim {
    /// The disc's centre: the picture's centre.
    pub(crate) centre_mm: [f64; 2],
    pub od_mm: f64,
    pub ia_mm: f64,
}

/// Chords of a circle drawn as a polygon are at most this far inside it, mm (the rim's tool
/// path, its mask ring).
const RIM_TOLERANCE_MM: f64 = 0.005;

impl Rim {
    /// A circle of radius `r` about the centre as a closed ring (counter-clockwise in the numeric
    /// plane), its chords within `RIM_TOLERANCE_MM` of the circle.
    pub(crate) fn ring(&self, r: f64) -> LineString<f64> {
        // Sagitta r(1 - cos(π/n)) ≤ tol.
        let n = (std::f64::consts::PI / (1.0 - RIM_TOLERANCE_MM / r).max(-1.0).acos())
            .ceil()
            .clamp(32.0, 8192.0) as usize;
        let [cx, cy] = self.centre_mm;
        LineString::new(
            (0..=n)
                .map(|i| {
                    let a = (i % n) as f64 / n as f64 * std::f64::consts::TAU;
                    Coord {
                        x: cx + r * a.cos(),
                        y: cy + r * a.sin(),
                    }
                })
                .collect(),
        )
    }

    /// The disc's bounding square: what a job cutting the rim places on the bed.
    pub(crate) fn bounds(&self) -> Rect<f64> {
        self.square(self.od_mm / 2.0)
    }

    /// The square around the circle of radius `r` about the centre.
    fn square(&self, r: f64) -> Rect<f64> {
        let [cx, cy] = self.centre_mm;
        Rect::new((cx - r, cy - r), (cx + r, cy + r))
    }
}

/// Options of the vector stage, in millimetres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VectorConfig {
    /// Millimetres per working pixel.
    pub scale: Scale,
    /// Largest distance simplification may move an edge.
    pub tolerance_mm: f64,
    /// The tool's kerf (from the material).
    pub kerf_mm: f64,
    /// Sheet beyond the picture on every side.
    pub margin_mm: f64,
    /// Place crossings by the blurred bits (sub-pixel edges); off = pixel-boundary midpoints.
    pub smooth: bool,
    /// Fit the traced outlines with lines and arcs within the tolerance (corners kept, the
    /// pixels on their sides), instead of leaving simplification's chords; the geometry holds
    /// the curves flattened within `VectorConfig::flatten_mm`, which is what the check judges,
    /// and the curves themselves ([`CutGeometry::curves`]), which the writers carry.
    pub curves: bool,
    /// Whether the files will carry arcs. Off (`--no-arcs`, a machine profile with `arcs =
    /// false`, a drag knife) the fitted curves only place the corners of straight outlines within
    /// the tolerance of the traced points (`simplify::FitCurves::straight`), which every file
    /// carries as they are and the check judges as they are: no finer flattening for arcs that
    /// no file holds.
    pub arcs: bool,
}

impl Default for VectorConfig {
    fn default() -> Self {
        VectorConfig {
            scale: Scale::default(),
            tolerance_mm: 0.05,
            kerf_mm: 0.0,
            margin_mm: 5.0,
            smooth: true,
            curves: true,
            arcs: true,
        }
    }
}

impl VectorConfig {
    /// How far the flattened curves' chords may stray from the arcs: a fifth of the tolerance.
    /// Why so fine: with arcs, this polygon is only what the check judges, never what a file
    /// carries (the files carry the fitted arcs, [`CutGeometry::curves`]). Without arcs it is
    /// not used for the outline ([`VectorConfig::arcs`]).
    pub(crate) fn flatten_mm(&self) -> f64 {
        self.tolerance_mm / 5.0
    }

    /// How far the fitted curves keep the pixel centres beside the traced outline from them: a
    /// fiftieth of the tolerance, at least 0.001 mm (ten times the SVG's 0.1 µm numbers, which
    /// move a near-half-turn arc's middle by up to about six times their rounding), at most the
    /// flattening's. The curves, and every file that carries them, then fill the very pixels
    /// they were traced from; the flattening keeps them too by a vertex wherever a chord would
    /// cross one (`stencil_geom::curve::flatten_clear`).
    ///
    /// Why not a clearance as wide as the flattening's sagitta (round 3's rule): a traced
    /// circle's pixel centres come within a fifth of the tolerance of the true circle somewhere
    /// on every turn, so that clearance cut a large smooth circle into dozens of short arcs.
    pub(crate) fn clear_mm(&self) -> f64 {
        (self.tolerance_mm / 50.0).max(0.001).min(self.flatten_mm())
    }

    /// How far SVG, DXF and G-code arcs may stray from a polygon whose curves the geometry does
    /// not know ([`CutGeometry::curves`]; a ring a later step changed): a quarter of the
    /// tolerance, more than `VectorConfig::flatten_mm`, so that flattened arcs are found again
    /// whole. 0 when the files carry no arcs ([`VectorConfig::arcs`]): they write the polygons
    /// as they are.
    pub fn arc_tolerance_mm(&self) -> f64 {
        if self.arcs {
            self.tolerance_mm / 4.0
        } else {
            0.0
        }
    }
}

/// What the vector stage produced, for the report.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct VectorStats {
    /// What simplification did.
    pub simplify: SimplifyStats,
    /// Cut regions as designed (the kerf can only remove ones narrower than itself, which the
    /// check flags as thin holes) and pieces of material.
    pub(crate) cut_loops: usize,
    pub(crate) material_pieces: usize,
}

/// Why the outlines could not be made.
#[derive(Debug, thiserror::Error)]
pub enum VectorError {
    /// The simplification tolerance ([`VectorConfig::tolerance_mm`]) given.
    #[error("the simplification tolerance must be a finite number >= 0 mm, got {0}")]
    Tolerance(f64),
    /// The sheet's margin ([`VectorConfig::margin_mm`]) given.
    #[error(
        "the margin must be a finite number > 0 mm (the sheet continues beyond the picture), got {0}"
    )]
    Margin(f64),
    /// A stencil of 0 pixels.
    #[error("the stencil image is empty (0 pixels)")]
    Empty,
    /// The geometry cannot go through the polygon clipper (see [`clip`]).
    #[error("{what}: {cause}")]
    Clip {
        /// What was being computed, e.g. "the kerf offset".
        what: &'static str,
        /// What the clipper said.
        cause: clip::ClipError,
    },
}

/// Vectorise a (bridged) stencil, kerf applied. `bridges` are bridge outlines in pixel
/// coordinates, as the bridge stage gives them.
pub fn vectorize(
    bits: &BitGrid,
    bridges: &[Vec<[f64; 2]>],
    cfg: &VectorConfig,
) -> Result<(CutGeometry, VectorStats), VectorError> {
    let (mut geom, stats) = vectorize_design(bits, bridges, cfg)?;
    geom.apply_kerf(cfg.kerf_mm)?;
    Ok((geom, stats))
}

/// [`vectorize`] without the kerf offset: `cuts` holds the design cuts until
/// [`CutGeometry::apply_kerf`]. Why: only tool paths need the kerf; SVG, DXF, masks and the width
/// check all read the design line, so `make` offsets only when it writes G-code (at 2000² px with
/// 1,024 regions the offset is about 15 ms).
pub fn vectorize_design(
    bits: &BitGrid,
    bridges: &[Vec<[f64; 2]>],
    cfg: &VectorConfig,
) -> Result<(CutGeometry, VectorStats), VectorError> {
    if !cfg.tolerance_mm.is_finite() || cfg.tolerance_mm < 0.0 {
        return Err(VectorError::Tolerance(cfg.tolerance_mm));
    }
    if !cfg.margin_mm.is_finite() || cfg.margin_mm <= 0.0 {
        return Err(VectorError::Margin(cfg.margin_mm));
    }
    if bits.is_empty() {
        return Err(VectorError::Empty);
    }
    let mm = cfg.scale.mm_per_px;
    // Points and guards are moved out of the traced rings, not copied.
    let (mut rings, guards): (Vec<Vec<[f64; 2]>>, Vec<Vec<trace::Guard>>) =
        trace::trace(bits, cfg.smooth)
            .into_iter()
            .map(|r| (r.pts, r.guards))
            .unzip();
    let tol_px = cfg.scale.to_px(Mm(cfg.tolerance_mm)).0;
    let curves = cfg.curves.then(|| simplify::FitCurves {
        flatten: cfg.scale.to_px(Mm(cfg.flatten_mm())).0,
        clear: cfg.scale.to_px(Mm(cfg.clear_mm())).0,
        straight: !cfg.arcs,
    });
    let (simplify, pieces) = simplify::simplify_and_fit(&mut rings, Some(&guards), tol_px, curves);
    // The curves in mm, each point scaled as `to_ring` scales the polygon's, so that the
    // polygons are found in the table to the bit.
    let mut curves = Curves::new(cfg.flatten_mm());
    for (r, p) in rings.iter().zip(pieces) {
        if let Some(p) = p {
            let pieces = p
                .iter()
                .map(|q| Piece {
                    from: [q.from[0] * mm, q.from[1] * mm],
                    bulge: q.bulge,
                })
                .collect();
            curves.insert(pieces, r.iter().map(|p| [p[0] * mm, p[1] * mm]).collect());
        }
    }
    let (w, h) = (bits.width as f64 * mm, bits.height as f64 * mm);
    let m = cfg.margin_mm;
    let outline = Rect::new(Coord { x: -m, y: -m }, Coord { x: w + m, y: h + m });
    let material = assemble(&rings, mm, outline);
    // A bridge outline with no area (a bent searched path is drawn as its pixels and outlined as a
    // line) adds nothing to the material but a zero-width spike to the union: left out.
    let bridges: Vec<Polygon<f64>> = bridges
        .iter()
        .filter(|b| b.len() >= 3 && signed_area2(b).abs() >= 1.0)
        .map(|b| to_polygon(b, mm).orient(Direction::Default))
        .collect();
    // The bridges are in the raster already, as drawn and then settled where they meet the picture;
    // their outlines (the end points of their outer strips) are kept to tell bridge necks apart in
    // the check and for the SVG's BRIDGES layer, not unioned in: an outline that strays from the
    // pixels it was drawn as (a fan's corner, an outline the settle has since widened around)
    // would add a sliver of material no pixel holds.
    let (material, design_cuts) =
        union::union_bridges(material, &[]).map_err(|cause| VectorError::Clip {
            what: "the bridges' union",
            cause,
        })?;
    let geom = CutGeometry {
        width_mm: w,
        height_mm: h,
        outline,
        cuts: design_cuts.clone(),
        design_cuts,
        material,
        bridges,
        unbridged_cuts: MultiPolygon::new(Vec::new()),
        kerf_mm: 0.0,
        rim: None,
        curves,
    };
    let stats = VectorStats {
        simplify,
        cut_loops: geom.design_cuts.0.len(),
        material_pieces: geom.material.0.len(),
    };
    Ok((geom, stats))
}

impl CutGeometry {
    /// Which of [`CutGeometry::material`]'s pieces is the sheet (the one whose outline encloses
    /// the most); the others float. `None` when there is no material.
    pub(crate) fn sheet_index(&self) -> Option<usize> {
        union::sheet_of(&self.material)
    }

    /// Record the cut regions of `unbridged`, the bit grid before bridging (the same size and
    /// scale), as [`CutGeometry::unbridged_cuts`]. Why a second trace: after bridging the cuts
    /// around an island are arcs with nothing to say they belong together; before it, the island
    /// is a hole in one region.
    pub(crate) fn set_unbridged(
        &mut self,
        unbridged: &BitGrid,
        cfg: &VectorConfig,
    ) -> Result<(), VectorError> {
        self.unbridged_cuts = vectorize_design(unbridged, &[], cfg)?.0.design_cuts;
        Ok(())
    }

    /// The planner's input: the tool paths and what is known of the pieces they free (the cut
    /// regions before bridging when recorded; none freed when the sheet has material but no
    /// islands were recorded; unknown for a sheet known only by its cuts).
    pub(crate) fn loops(&self) -> CutLoops {
        let pieces = if !self.unbridged_cuts.0.is_empty() {
            Pieces::Regions(self.unbridged_cuts.clone())
        } else if !self.material.0.is_empty() {
            Pieces::NoIslands
        } else {
            Pieces::Unknown
        };
        // A gobo is cut on its rim, the tool half the kerf outside it so the disc keeps its
        // diameter; the job's box is the rim's square (what is cut), not the mask's margin.
        let (outline, outline_ring) = match self.rim {
            Some(rim) => {
                let r = rim.od_mm / 2.0 + self.kerf_mm.max(0.0) / 2.0;
                (rim.square(r), Some(rim.ring(r)))
            }
            None => (self.outline, None),
        };
        CutLoops {
            outline,
            cuts: self.cuts.clone(),
            kerf_mm: self.kerf_mm,
            pieces,
            lines: Vec::new(),
            outline_ring,
            curves: self.curves.clone(),
        }
    }

    /// Set the tool paths: the design cuts offset by half of `kerf_mm` (see [`kerf`]); a cut
    /// region known as curves is offset as its lines and arcs ([`kerf::offset_cuts_curved`]),
    /// and its tool path joins [`CutGeometry::curves`].
    pub fn apply_kerf(&mut self, kerf_mm: f64) -> Result<(), VectorError> {
        let (cuts, tool) = kerf::offset_cuts_curved(&self.design_cuts, kerf_mm, &self.curves)
            .map_err(|cause| VectorError::Clip {
                what: "the kerf offset",
                cause,
            })?;
        self.cuts = cuts;
        if kerf_mm > 0.0 {
            self.curves.extend(&tool);
        }
        self.kerf_mm = kerf_mm.max(0.0);
        Ok(())
    }
}

fn to_ring(pts: &[[f64; 2]], mm: f64) -> LineString<f64> {
    let mut v: Vec<Coord<f64>> = pts
        .iter()
        .map(|p| Coord {
            x: p[0] * mm,
            y: p[1] * mm,
        })
        .collect();
    if let Some(&f) = v.first() {
        v.push(f);
    }
    LineString::new(v)
}

fn to_polygon(pts: &[[f64; 2]], mm: f64) -> Polygon<f64> {
    Polygon::new(to_ring(pts, mm), vec![])
}

/// Group rings into material pieces. Rings never touch, so they nest as a tree: a positive ring
/// (material on its left, counter-clockwise) is an island's outline, and each negative ring (the
/// outline of a cut region) is a hole of the innermost island outline around it, or of the sheet
/// (whose outline is the sheet's edge). After bridging there are no island outlines at all.
fn assemble(rings: &[Vec<[f64; 2]>], mm: f64, outline: Rect<f64>) -> MultiPolygon<f64> {
    let area: Vec<f64> = rings.par_iter().map(|r| signed_area2(r)).collect();
    let outlines: Vec<usize> = (0..rings.len()).filter(|&i| area[i] > 0.0).collect();
    let boxes: Vec<[f64; 4]> = outlines.iter().map(|&i| bbox(&rings[i])).collect();
    // Each cut outline's owner (0: the sheet; k + 1: the island with outline `outlines[k]`), and
    // the outline in mm, in parallel.
    let owned: Vec<(usize, LineString<f64>)> = (0..rings.len())
        .into_par_iter()
        .filter(|&i| area[i] <= 0.0)
        .map(|i| {
            let r = &rings[i];
            let b = bbox(r);
            let p = r[0];
            let owner = outlines
                .iter()
                .zip(&boxes)
                .enumerate()
                .filter(|(_, (_, ob))| {
                    ob[0] <= b[0] && ob[1] <= b[1] && ob[2] >= b[2] && ob[3] >= b[3]
                })
                .filter(|(_, (&o, _))| point_in_ring(p, &rings[o]))
                .min_by(|a, b| area[*a.1 .0].total_cmp(&area[*b.1 .0]))
                .map_or(0, |(k, _)| k + 1);
            (owner, to_ring(r, mm))
        })
        .collect();
    let mut holes: Vec<Vec<LineString<f64>>> = vec![Vec::new(); outlines.len() + 1];
    for (owner, ring) in owned {
        holes[owner].push(ring);
    }
    let island_outlines: Vec<LineString<f64>> = outlines
        .par_iter()
        .map(|&o| to_ring(&rings[o], mm))
        .collect();
    // The traced rings are already oriented as geo's default wants (material on the left:
    // outlines counter-clockwise, holes clockwise); only the sheet's edge is oriented here.
    let sheet_edge = outline
        .to_polygon()
        .orient(Direction::Default)
        .exterior()
        .clone();
    let mut holes = holes.into_iter();
    let mut polys = vec![Polygon::new(sheet_edge, holes.next().unwrap_or_default())];
    for (o, h) in island_outlines.into_iter().zip(holes) {
        polys.push(Polygon::new(o, h));
    }
    debug_assert_eq!(
        MultiPolygon::new(polys.clone()).orient(Direction::Default),
        MultiPolygon::new(polys.clone())
    );
    MultiPolygon::new(polys)
}

#[cfg(test)]
mod tests {
    use super::*;
    use geo::{Area, BoundingRect};

    /// Every pixel centre lies in a design cut region exactly when the pixel is cut.
    fn samples_back_to(geo: &CutGeometry, g: &BitGrid, mm: f64) {
        use geo::Contains;
        for y in 0..g.height {
            for x in 0..g.width {
                let p = geo::Point::new((x as f64 + 0.5) * mm, (y as f64 + 0.5) * mm);
                assert_eq!(
                    geo.design_cuts.contains(&p),
                    !g.get(x, y),
                    "pixel ({x}, {y})"
                );
            }
        }
    }

    #[test]
    fn a_square_hole_becomes_one_cut_loop_in_mm() {
        let g = BitGrid::from_fn(20, 20, |x, y| {
            !((5..15).contains(&x) && (5..15).contains(&y))
        });
        for (smooth, curves) in [(false, false), (true, false), (false, true), (true, true)] {
            let cfg = VectorConfig {
                smooth,
                curves,
                ..Default::default()
            };
            let (geo, st) = vectorize(&g, &[], &cfg).unwrap();
            assert_eq!(st.cut_loops, 1);
            assert_eq!(st.material_pieces, 1);
            if !curves {
                // Simplification alone leaves the square's corners (and their chamfers).
                assert!(st.simplify.points_out < st.simplify.points_in / 4, "{st:?}");
            }
            // 10 x 10 px at 0.1 mm: 1 mm², within the tolerance (0.5 px) along the perimeter.
            let a = geo.design_cuts.unsigned_area();
            assert!((a - 1.0).abs() < 4.0 * 1.0 * 0.05, "{a}");
            assert!((geo.width_mm - 2.0).abs() < 1e-12);
            // Lines or arcs, the cut stays within the tolerance of the square's edge
            // (0.5..1.5 mm); the fit may bow a side into a shallow arc, never past it.
            for c in geo.design_cuts.0[0].exterior().0.iter() {
                let off = (c.x - 1.0).abs().max((c.y - 1.0).abs()) - 0.5;
                assert!(off.abs() <= 0.05 + 1e-9, "{c:?}: {off}");
            }
            samples_back_to(&geo, &g, 0.1);
        }
    }

    #[test]
    fn simplified_blobs_sample_back_to_the_same_raster() {
        let g = BitGrid::from_fn(120, 90, |x, y| {
            let (x, y) = (x as f64, y as f64);
            let a = ((x - 40.0).powi(2) / 600.0 + (y - 40.0).powi(2) / 200.0) > 1.0;
            let b = ((x - 90.0) * 0.6 + (y - 50.0) * 0.8).abs() > 3.0 || (x - 90.0).abs() > 25.0;
            a && b
        });
        for arcs in [true, false] {
            let cfg = VectorConfig {
                arcs,
                ..Default::default()
            };
            let (geo, st) = vectorize(&g, &[], &cfg).unwrap();
            assert!(st.simplify.points_out < st.simplify.points_in / 2, "{st:?}");
            assert!(st.simplify.curved_rings > 0, "{st:?}");
            samples_back_to(&geo, &g, 0.1);
        }
    }

    #[test]
    fn an_island_is_a_second_piece_and_a_hole_in_its_cut() {
        let g = BitGrid::from_fn(30, 30, |x, y| {
            let ring = (5..25).contains(&x) && (5..25).contains(&y);
            let island = (12..18).contains(&x) && (12..18).contains(&y);
            !ring || island
        });
        let (geo, _) = vectorize(&g, &[], &VectorConfig::default()).unwrap();
        assert_eq!(geo.material.0.len(), 2);
        assert_eq!(geo.design_cuts.0.len(), 1);
        assert_eq!(geo.design_cuts.0[0].interiors().len(), 1);
    }

    #[test]
    fn bridges_joining_two_islands_only_make_one_floating_piece_around_a_new_hole() {
        // One cut square with two islands; two bridges join the islands to each other (not to
        // the sheet) and close off the cut between them.
        let g = BitGrid::from_fn(50, 50, |x, y| {
            let cut = (5..45).contains(&x) && (5..45).contains(&y);
            let a = (10..18).contains(&x) && (12..38).contains(&y);
            let b = (30..38).contains(&x) && (12..38).contains(&y);
            // The bridges, drawn as the bridge stage draws them.
            let bridges = (18..30).contains(&x) && ((13..17).contains(&y) || (33..37).contains(&y));
            !cut || a || b || bridges
        });
        let top = vec![[17.0, 13.0], [31.0, 13.0], [31.0, 17.0], [17.0, 17.0]];
        let bottom = vec![[17.0, 33.0], [31.0, 33.0], [31.0, 37.0], [17.0, 37.0]];
        let (geo, st) = vectorize(&g, &[top, bottom], &VectorConfig::default()).unwrap();
        assert_eq!(st.material_pieces, 2, "{:?}", geo.material);
        let sheet = union::sheet_of(&geo.material).unwrap();
        let group = 1 - sheet;
        // The sheet has the big cut as its hole; the joined islands hold the cut between them.
        assert_eq!(geo.material.0[sheet].interiors().len(), 1);
        assert_eq!(geo.material.0[group].interiors().len(), 1);
        let inner = &geo.material.0[group].interiors()[0];
        let b = inner.bounding_rect().unwrap();
        assert!(
            (b.min().x - 1.8).abs() < 0.06 && (b.max().x - 3.0).abs() < 0.06,
            "{b:?}"
        );
        assert_eq!(geo.design_cuts.0.len(), 2);
        // Material + cuts fill the picture's 5 x 5 mm exactly once.
        let outline = geo.outline.to_polygon().unsigned_area();
        let total = geo.material.unsigned_area() + geo.design_cuts.unsigned_area();
        assert!((total - outline).abs() < 1e-9, "{total} vs {outline}");
    }

    #[test]
    fn the_sheet_is_the_outermost_piece_not_the_largest() {
        // A thin cut ring close to the picture's edge: the island inside it has more material
        // than the sheet (margin and picture edge) around it.
        let g = BitGrid::from_fn(200, 200, |x, y| {
            let outer = (2..198).contains(&x) && (2..198).contains(&y);
            let inner = (4..196).contains(&x) && (4..196).contains(&y);
            !outer || inner
        });
        let cfg = VectorConfig {
            margin_mm: 0.5,
            ..Default::default()
        };
        let (geo, _) = vectorize(&g, &[], &cfg).unwrap();
        assert_eq!(geo.material.0.len(), 2);
        let sheet = union::sheet_of(&geo.material).unwrap();
        let island = 1 - sheet;
        assert!(geo.material.0[island].unsigned_area() > geo.material.0[sheet].unsigned_area());
        assert_eq!(
            geo.material.0[sheet].exterior(),
            geo.outline.to_polygon().exterior()
        );
        // The one cut region holds the island as its hole.
        assert_eq!(geo.design_cuts.0.len(), 1);
        assert_eq!(geo.design_cuts.0[0].interiors().len(), 1);
    }

    #[test]
    fn a_drawn_bridge_joins_the_island_and_an_outline_alone_adds_nothing() {
        let with = |drawn: bool| {
            BitGrid::from_fn(30, 30, move |x, y| {
                let ring = (5..25).contains(&x) && (5..25).contains(&y);
                let island = (12..18).contains(&x) && (12..18).contains(&y);
                let bridge = drawn && (13..17).contains(&x) && (5..12).contains(&y);
                !ring || island || bridge
            })
        };
        let outline = vec![[13.0, 4.0], [17.0, 4.0], [17.0, 13.0], [13.0, 13.0]];
        let (geo, _) = vectorize(
            &with(true),
            std::slice::from_ref(&outline),
            &VectorConfig::default(),
        )
        .unwrap();
        assert_eq!(geo.material.0.len(), 1, "{:?}", geo.material);
        assert_eq!(geo.design_cuts.0.len(), 1);
        assert!(geo.design_cuts.0[0].interiors().is_empty());
        assert_eq!(
            geo.bridges.len(),
            1,
            "the outline is kept for the check and the SVG"
        );
        // The raster is the truth: an outline with no pixels under it joins nothing.
        let (geo, _) = vectorize(&with(false), &[outline], &VectorConfig::default()).unwrap();
        assert_eq!(geo.material.0.len(), 2);
    }
}
