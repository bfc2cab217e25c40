//! Physical checks on the cut geometry against a [`Material`]: the material is one piece, every
//! bridge is at least `min_bridge_mm` at its narrowest, every web (material) and hole (cut) at least
//! `min_feature_mm`.
//!
//! ## How widths are measured
//! A constrained Delaunay triangulation of every ring of the sheet (module `cdt`) splits it into
//! triangles wholly in material or in a cut (material is left of every ring). A region's *chords*
//! are its triangles' inner edges and the perpendiculars from a vertex to the opposite boundary
//! edge. A chord is a *neck* when its ends lie on two rings, or on one ring with more than
//! `NECK_RATIO` times its length of boundary between them either way (so a corner is not a neck,
//! a bridge or a long spur is). A material neck is a *bridge* when its midpoint lies in a bridge
//! polygon; without the bridge list (a bare PNG), every material neck with both ends on one ring.
//! Other material necks are webs; cut necks are holes.
//!
//! ## Discretisation
//! A raster neck N pixels wide measures exactly N × mm_per_px; diagonal ones within about ±0.7 px,
//! and simplification may move each side by `--tolerance-mm`. A width passes at the requirement
//! exactly; the pipeline asks the earlier stages for `allowance_px` more, so what it makes passes.
//!
//! ## Cross-check
//! Each violation is confirmed on the raster by an opening (material) or closing (holes) with a
//! disc of half the required width: it must remove the neck at the reported position.

use geo::{BoundingRect, Contains, Coord, MultiPolygon, Point, Polygon, Rect};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

mod cdt;
mod error;

pub use error::CheckError;

use cdt::{Method, RingSizes, Tri, V};

use crate::islands;
use crate::material::Material;
use crate::raster::{self, BitGrid};
use crate::units::{Mm, Scale};
use crate::vector::CutGeometry;
use stencil_geom::ring::{dist, signed_area2};

/// Boundary length between a same-ring chord's ends, in chord lengths, above which it is a neck.
/// Cutting a right-angle corner gives at most √2, a semicircular end π/2; a spike sharper than
/// about 39° (cot(θ/2) > 3) counts as thin near its tip.
pub(crate) const NECK_RATIO: f64 = 3.0;

/// Extra pixels the pipeline adds to the material's minimum widths: one pixel for a diagonal
/// staircase, plus twice the simplification tolerance (each side may move by that much).
pub(crate) fn allowance_px(tolerance_px: f64) -> f64 {
    1.0 + 2.0 * tolerance_px
}

/// The most pieces (of material and of cut, 4-connected) a picture may break into for `check` to
/// measure it. The check's cost grows with the rings it traces and triangulates: 160,000 pieces (a
/// 400 x 400 one-pixel checkerboard) took about 3 s, 1,000,000 (1000 x 1000) about 30 s and 1 GB;
/// a sheet that breaks into more than 100,000 pieces cannot be a stencil that holds together.
pub const MAX_CHECK_PIECES: usize = 100_000;

/// Refuse, before any tracing, a picture that breaks into more than [`MAX_CHECK_PIECES`] pieces:
/// the check would take minutes to say what this says at once. O(pixels).
pub fn bound_pieces(bits: &BitGrid) -> Result<(), CheckError> {
    let material = raster::components(bits, true).1.len();
    let cut = raster::components(bits, false).1.len();
    if material + cut > MAX_CHECK_PIECES {
        return Err(CheckError::TooManyPieces {
            material,
            cut,
            limit: MAX_CHECK_PIECES,
        });
    }
    Ok(())
}

/// What is wrong.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ViolationKind {
    /// A piece of material not joined to the sheet.
    Floating,
    /// A bridge narrower than `min_bridge_mm`.
    ThinBridge,
    /// A web of material narrower than `min_feature_mm`.
    ThinWeb,
    /// A hole (cut) narrower than `min_feature_mm`.
    ThinHole,
}

impl std::fmt::Display for ViolationKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ViolationKind::Floating => "floating piece",
            ViolationKind::ThinBridge => "thin bridge",
            ViolationKind::ThinWeb => "thin web",
            ViolationKind::ThinHole => "thin hole",
        })
    }
}

/// One violation: where (mm, y down from the picture's top-left) and how wide.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Violation {
    /// What is too narrow (or floats).
    pub kind: ViolationKind,
    /// Where, mm right.
    pub x_mm: f64,
    /// Mm down.
    pub y_mm: f64,
    /// The measured width (none for a floating piece).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width_mm: Option<f64>,
    /// The width the material needs there.
    pub required_mm: f64,
    /// Whether the raster cross-check (opening/closing by half the required width) removes it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub confirmed_by_opening: Option<bool>,
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.width_mm {
            Some(w) => write!(
                f,
                "{} at ({:.2}, {:.2}) mm: {:.3} mm wide, needs {:.3} mm",
                self.kind, self.x_mm, self.y_mm, w, self.required_mm
            ),
            None => write!(
                f,
                "{} at ({:.2}, {:.2}) mm: not joined to the sheet",
                self.kind, self.x_mm, self.y_mm
            ),
        }
    }
}

/// The result of the check, as recorded in `report.json`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CheckReport {
    /// The material profile's name.
    pub material: String,
    /// The narrowest bridge the material holds, mm.
    pub min_bridge_mm: f64,
    /// The narrowest web or hole it holds, mm.
    pub min_feature_mm: f64,
    /// Pieces of material (1 for a valid stencil).
    pub pieces: usize,
    /// Narrowest neck measured per kind (bridges are only told apart when the bridges are known).
    pub narrowest_bridge_mm: Option<f64>,
    /// Narrowest web of material, mm.
    pub narrowest_web_mm: Option<f64>,
    /// Narrowest hole, mm.
    pub narrowest_hole_mm: Option<f64>,
    /// Every neck narrower than required, and every floating piece.
    pub violations: Vec<Violation>,
    /// Size of the triangulation, for the curious.
    pub triangles: usize,
}

impl CheckReport {
    /// No violations.
    pub fn passed(&self) -> bool {
        self.violations.is_empty()
    }
}

struct Rings {
    pts: Vec<Vec<[f64; 2]>>,
    /// Boundary length from vertex 0 to each vertex, and the ring's total length.
    cum: Vec<Vec<f64>>,
    len: Vec<f64>,
}

/// The rings of the material, with edges longer than two `spacing`s split into pieces of at most
/// one, so that long straight sides carry vertices in their middle (a chord across the middle of
/// a long thin slot needs them). Shorter edges already have a vertex within a spacing of every
/// point; splitting them too added 13 % more vertices to a 2000² px sheet for nothing.
fn rings_of(material: &MultiPolygon<f64>, spacing: f64) -> Rings {
    let mut pts = Vec::new();
    for p in &material.0 {
        for ls in std::iter::once(p.exterior()).chain(p.interiors()) {
            let mut r: Vec<[f64; 2]> = Vec::with_capacity(ls.0.len());
            for c in &ls.0 {
                let q = [c.x, c.y];
                if r.last() != Some(&q) {
                    r.push(q);
                }
            }
            while r.len() > 1 && r.first() == r.last() {
                r.pop();
            }
            if r.len() >= 3 {
                // Material left of every ring: outlines counter-clockwise, holes clockwise
                // (the vector stage builds them so; this keeps the check right whatever it is given).
                let outline = std::ptr::eq(ls, p.exterior());
                if (signed_area2(&r) > 0.0) != outline {
                    r.reverse();
                }
                pts.push(densify(&r, spacing));
            }
        }
    }
    let mut cum = Vec::with_capacity(pts.len());
    let mut len = Vec::with_capacity(pts.len());
    for r in &pts {
        let mut c = Vec::with_capacity(r.len());
        let mut s = 0.0;
        for i in 0..r.len() {
            c.push(s);
            s += dist(r[i], r[(i + 1) % r.len()]);
        }
        cum.push(c);
        len.push(s);
    }
    Rings { pts, cum, len }
}

fn densify(r: &[[f64; 2]], spacing: f64) -> Vec<[f64; 2]> {
    let n = r.len();
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let (a, b) = (r[i], r[(i + 1) % n]);
        out.push(a);
        let d = dist(a, b);
        // Only long sides: an edge under two spacings has a vertex within a spacing of any point
        // on it already.
        if d <= 2.0 * spacing {
            continue;
        }
        let k = (d / spacing).ceil() as usize;
        for j in 1..k.min(10_000) {
            let t = j as f64 / k as f64;
            out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }
    out
}

/// A chord found: its two ends, their points and its length.
type Chord = (End, End, [f64; 2], [f64; 2], f64);

/// A chord end: which ring, and how far along it.
#[derive(Clone, Copy)]
struct End {
    ring: u32,
    arc: f64,
}

fn is_neck(r: &Rings, a: End, b: End, d: f64) -> bool {
    if a.ring != b.ring {
        return true;
    }
    let l = r.len[a.ring as usize];
    let along = (a.arc - b.arc).abs();
    along.min(l - along) > NECK_RATIO * d
}

struct Candidate {
    kind: ViolationKind,
    d: f64,
    mid: [f64; 2],
}

/// Bridge polygons bucketed on a uniform grid, so that "is this point in a bridge" costs O(1).
struct BridgeIndex<'a> {
    polys: &'a [Polygon<f64>],
    origin: [f64; 2],
    cell: f64,
    cols: usize,
    rows: usize,
    buckets: Vec<Vec<u32>>,
}

impl<'a> BridgeIndex<'a> {
    fn new(polys: &'a [Polygon<f64>]) -> Self {
        let boxes: Vec<Option<Rect<f64>>> = polys.iter().map(|b| b.bounding_rect()).collect();
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        let mut size = 0.0f64;
        for b in boxes.iter().flatten() {
            lo = [lo[0].min(b.min().x), lo[1].min(b.min().y)];
            hi = [hi[0].max(b.max().x), hi[1].max(b.max().y)];
            size = size.max(b.width()).max(b.height());
        }
        if !lo[0].is_finite() {
            return BridgeIndex {
                polys,
                origin: [0.0; 2],
                cell: 1.0,
                cols: 0,
                rows: 0,
                buckets: Vec::new(),
            };
        }
        let cell = size
            .max((hi[0] - lo[0]).max(hi[1] - lo[1]) / 256.0)
            .max(1e-6);
        let cols = ((hi[0] - lo[0]) / cell).floor() as usize + 1;
        let rows = ((hi[1] - lo[1]) / cell).floor() as usize + 1;
        let mut buckets = vec![Vec::new(); cols * rows];
        for (i, b) in boxes.iter().enumerate() {
            let Some(b) = b else { continue };
            let (x0, y0) = (
                ((b.min().x - lo[0]) / cell) as usize,
                ((b.min().y - lo[1]) / cell) as usize,
            );
            let (x1, y1) = (
                ((b.max().x - lo[0]) / cell) as usize,
                ((b.max().y - lo[1]) / cell) as usize,
            );
            for y in y0..=y1.min(rows - 1) {
                for x in x0..=x1.min(cols - 1) {
                    buckets[y * cols + x].push(i as u32);
                }
            }
        }
        BridgeIndex {
            polys,
            origin: lo,
            cell,
            cols,
            rows,
            buckets,
        }
    }

    fn contains(&self, m: [f64; 2]) -> bool {
        let (fx, fy) = (
            (m[0] - self.origin[0]) / self.cell,
            (m[1] - self.origin[1]) / self.cell,
        );
        if fx < 0.0 || fy < 0.0 || fx as usize >= self.cols || fy as usize >= self.rows {
            return false;
        }
        let p = Point::new(m[0], m[1]);
        self.buckets[fy as usize * self.cols + fx as usize]
            .iter()
            .any(|&i| self.polys[i as usize].contains(&p))
    }
}

/// From vertex `w` straight across to ring edge `i → i+1` of `ring`, when the foot falls strictly
/// inside the edge and the chord is shorter than `bound`: the two chord ends, their points, and
/// the length.
/// `material_side`: which region the chord must cross (material lies left of every ring edge, as
/// the rings are oriented: exteriors counter-clockwise, holes clockwise).
fn perpendicular(
    r: &Rings,
    w: V,
    ring: u32,
    i: u32,
    material_side: bool,
    bound: f64,
) -> Option<Chord> {
    let pts = &r.pts[ring as usize];
    let n = pts.len() as u32;
    if w.ring == ring && (w.idx == i || w.idx == (i + 1) % n) {
        return None;
    }
    let (pu, pv) = (pts[i as usize], pts[((i + 1) % n) as usize]);
    let pw = [w.p.x, w.p.y];
    let (ex, ey) = (pv[0] - pu[0], pv[1] - pu[1]);
    let l2 = ex * ex + ey * ey;
    if l2 == 0.0 {
        return None;
    }
    let cross = ex * (pw[1] - pu[1]) - ey * (pw[0] - pu[0]);
    if (cross > 0.0) != material_side {
        return None;
    }
    // Too long to matter (the slack keeps rounding from dropping a chord at the bound itself).
    if cross * cross >= bound * bound * l2 * (1.0 + 1e-9) {
        return None;
    }
    let t = ((pw[0] - pu[0]) * ex + (pw[1] - pu[1]) * ey) / l2;
    if t <= 1e-9 || t >= 1.0 - 1e-9 {
        return None;
    }
    let foot = [pu[0] + t * ex, pu[1] + t * ey];
    let a = End {
        ring: w.ring,
        arc: r.cum[w.ring as usize][w.idx as usize],
    };
    let b = End {
        ring,
        arc: r.cum[ring as usize][i as usize] + t * l2.sqrt(),
    };
    Some((a, b, pw, foot, dist(pw, foot)))
}

/// What the neck search needs to know besides the triangulation.
struct Search<'a> {
    rings: &'a Rings,
    /// Every vertex, by global index.
    verts: &'a [V],
    material: &'a Material,
    bridges_known: bool,
    any_bridges: bool,
    bridge_index: &'a BridgeIndex<'a>,
    /// The widest requirement: wider chords matter only as a region's narrowest.
    max_required: f64,
}

/// What the neck search found in some faces: the narrowest neck per kind (bridge, web, hole) and
/// the violations, in the order found.
struct Found {
    narrowest: [f64; 3],
    cands: Vec<Candidate>,
}

impl Default for Found {
    fn default() -> Self {
        Found {
            narrowest: [f64::INFINITY; 3],
            cands: Vec::new(),
        }
    }
}

impl Search<'_> {
    /// Measure a chord and record it when it is a neck.
    fn consider(
        &self,
        out: &mut Found,
        material_side: bool,
        (a, b): (End, End),
        (pa, pb): ([f64; 2], [f64; 2]),
        d: f64,
    ) {
        let could_be_bridge = if self.bridges_known {
            self.any_bridges
        } else {
            a.ring == b.ring
        };
        if d >= self.skip_from(&out.narrowest, material_side, could_be_bridge) {
            return;
        }
        let narrowest = &mut out.narrowest;
        if !is_neck(self.rings, a, b, d) {
            return;
        }
        let mid = [(pa[0] + pb[0]) / 2.0, (pa[1] + pb[1]) / 2.0];
        let kind = if !material_side {
            ViolationKind::ThinHole
        } else if (self.bridges_known && self.bridge_index.contains(mid))
            || (!self.bridges_known && a.ring == b.ring)
        {
            ViolationKind::ThinBridge
        } else {
            ViolationKind::ThinWeb
        };
        let (slot, req) = match kind {
            ViolationKind::ThinBridge => (0, self.material.min_bridge_mm),
            ViolationKind::ThinWeb => (1, self.material.min_feature_mm),
            _ => (2, self.material.min_feature_mm),
        };
        narrowest[slot] = narrowest[slot].min(d);
        if d < req {
            out.cands.push(Candidate { kind, d, mid });
        }
    }

    /// Chords at least this long are too wide to matter: for a violation, or for the narrowest
    /// of their kind so far. `could_be_bridge`: whether a material chord may be a bridge (then it
    /// may count as either kind).
    fn skip_from(&self, narrowest: &[f64; 3], material_side: bool, could_be_bridge: bool) -> f64 {
        let here = if !material_side {
            narrowest[2]
        } else if could_be_bridge {
            narrowest[0].max(narrowest[1])
        } else {
            narrowest[1]
        };
        self.max_required.max(here)
    }

    /// The chords of one triangle of the sheet (see the module doc).
    fn face(&self, t: &Tri, out: &mut Found) {
        let rings = self.rings;
        let material_side = t.material;
        // Before a perpendicular's ends are looked up: whatever kind its chord turns out to be.
        let bound = self.skip_from(&out.narrowest, material_side, true);
        let c = t.v.map(|g| self.verts[g as usize]);
        for k in 0..3 {
            let (du, dv, w) = (c[k], c[(k + 1) % 3], c[(k + 2) % 3]);
            if t.ring_edges & (1 << k) != 0 {
                // The vertex opposite a boundary edge, straight across to it. (A ring edge that
                // is not between consecutive vertices, where rings touch, has no place on a ring
                // to measure from: the chords around it still are measured.)
                if let Some((i, _)) = du.ring_edge(dv) {
                    if let Some((a, b, pa, pb, d)) =
                        perpendicular(rings, w, du.ring, i, material_side, bound)
                    {
                        self.consider(out, material_side, (a, b), (pa, pb), d);
                    }
                }
            } else if du.gid < dv.gid {
                // A chord between two vertices (once: the triangle across it sees it reversed),
                // and from each end straight across to the boundary edges at the other end
                // (where two long sides run parallel, these are the width).
                let (pu, pv) = ([du.p.x, du.p.y], [dv.p.x, dv.p.y]);
                let a = End {
                    ring: du.ring,
                    arc: rings.cum[du.ring as usize][du.idx as usize],
                };
                let b = End {
                    ring: dv.ring,
                    arc: rings.cum[dv.ring as usize][dv.idx as usize],
                };
                self.consider(out, material_side, (a, b), (pu, pv), dist(pu, pv));
                for (x, y) in [(du, dv), (dv, du)] {
                    let n = rings.pts[y.ring as usize].len() as u32;
                    for start in [y.idx, (y.idx + n - 1) % n] {
                        if let Some((a, b, pa, pb, d)) =
                            perpendicular(rings, x, y.ring, start, material_side, bound)
                        {
                            self.consider(out, material_side, (a, b), (pa, pb), d);
                        }
                    }
                }
            }
        }
    }
}

/// Check a stencil's geometry against a material. `bridges_known`: whether `geom.bridges` lists
/// every bridge (false for a bare PNG: then same-ring material necks count as bridges).
///
/// ```
/// use stencil_core::{check, material::Material, raster::BitGrid, vector};
/// // Two holes in a sheet (0.1 mm pixels), 2 px apart: a web narrower than cardstock holds.
/// let bits = BitGrid::from_fn(60, 60, |x, y| !((10..50).contains(&y) && (10..29).contains(&x) | (31..50).contains(&x)));
/// let (geom, _) = vector::vectorize(&bits, &[], &Default::default()).unwrap();
/// let report = check::check(&geom, &Material::default(), false).unwrap();
/// assert!(!report.passed() && report.narrowest_web_mm.unwrap() < 0.5);
/// ```
pub fn check(
    geom: &CutGeometry,
    material: &Material,
    bridges_known: bool,
) -> Result<CheckReport, CheckError> {
    check_tuned(geom, material, bridges_known, Tuning::default()).map(|(r, _)| r)
}

/// Below this many vertices the sheet is triangulated at once (slabs would not pay).
const SLAB_MIN_VERTICES: usize = 20_000;

/// How the work is split; any choice gives a valid report (and tests check that they agree).
#[derive(Clone, Copy, Debug, Default)]
struct Tuning {
    /// Triangles per parallel chunk of the neck search (None: a few chunks per thread).
    chunk: Option<usize>,
    /// Slabs to triangulate in parallel (None: one per thread on a large sheet).
    slabs: Option<usize>,
}

fn check_tuned(
    geom: &CutGeometry,
    material: &Material,
    bridges_known: bool,
    tuning: Tuning,
) -> Result<(CheckReport, Method), CheckError> {
    let spacing = material.min_bridge_mm.max(material.min_feature_mm);
    let rings = rings_of(&geom.material, spacing);
    let (verts, sizes) = ring_vertices(&rings);
    let threads = rayon::current_num_threads();
    let slabs = tuning.slabs.unwrap_or(if verts.len() >= SLAB_MIN_VERTICES {
        threads.clamp(1, 8)
    } else {
        1
    });
    // Reach of a slab into its neighbours: wide enough for the empty circles of a sheet's open
    // areas (its margin, blank parts of the picture); a circle wider than that sends the whole
    // sheet to one triangulation, which is slower but the same check.
    let guard = (0.05 * geom.outline.width()).max(8.0 * spacing);
    let (tris, method) = cdt::triangulate(&sizes, &verts, slabs, guard)?;

    let bridge_index = BridgeIndex::new(&geom.bridges);
    let ctx = Search {
        rings: &rings,
        verts: &verts,
        material,
        bridges_known,
        any_bridges: !geom.bridges.is_empty(),
        bridge_index: &bridge_index,
        max_required: spacing,
    };
    let triangles = tris.iter().map(Vec::len).sum::<usize>();
    let chunk = tuning
        .chunk
        .unwrap_or_else(|| triangles.div_ceil(4 * threads).max(256))
        .max(1);
    let (narrowest, cands) = search_necks(&ctx, &tris, chunk);
    let mut violations = cluster(cands, material);
    let pieces = geom.material.0.len();
    add_floating(&mut violations, geom);
    let fin = |v: f64| v.is_finite().then_some(v);
    let report = CheckReport {
        material: material.name.clone(),
        min_bridge_mm: material.min_bridge_mm,
        min_feature_mm: material.min_feature_mm,
        pieces,
        narrowest_bridge_mm: fin(narrowest[0]),
        narrowest_web_mm: fin(narrowest[1]),
        narrowest_hole_mm: fin(narrowest[2]),
        violations,
        triangles,
    };
    Ok((report, method))
}

/// Every ring's vertices in one list, and the ring sizes; the outline is the ring holding the
/// leftmost (then lowest) vertex.
fn ring_vertices(rings: &Rings) -> (Vec<V>, RingSizes) {
    let mut verts = Vec::new();
    let mut sizes = RingSizes {
        len: Vec::with_capacity(rings.pts.len()),
        outline: 0,
    };
    let mut leftmost = [f64::INFINITY; 2];
    for (ri, r) in rings.pts.iter().enumerate() {
        for p in r {
            if (p[0], p[1]) < (leftmost[0], leftmost[1]) {
                leftmost = *p;
                sizes.outline = ri as u32;
            }
        }
        sizes.push_ring(&mut verts, r);
    }
    (verts, sizes)
}

/// The narrowest bridge, web and hole, and every chord narrower than the material allows.
/// Each triangle's chords are measured independently of the others, so the triangles are searched
/// in parallel chunks of `chunk`. The narrowest per kind is a minimum, the early skip in
/// `consider` only drops chords that could change neither that minimum nor the violations, and
/// `cluster` orders the candidates completely: the report does not depend on the order.
fn search_necks(ctx: &Search, tris: &[Vec<Tri>], chunk: usize) -> ([f64; 3], Vec<Candidate>) {
    let found: Vec<Found> = tris
        .par_iter()
        .flat_map(|slab| slab.par_chunks(chunk))
        .map(|part| {
            let mut out = Found::default();
            for t in part {
                ctx.face(t, &mut out);
            }
            out
        })
        .collect();
    let mut narrowest = [f64::INFINITY; 3];
    let mut cands: Vec<Candidate> = Vec::new();
    for f in found {
        for (n, m) in narrowest.iter_mut().zip(f.narrowest) {
            *n = n.min(m);
        }
        cands.extend(f.cands);
    }
    (narrowest, cands)
}

/// Every material polygon but the sheet floats: a violation each, at its first outline point,
/// put before the others (the last piece first).
fn add_floating(violations: &mut Vec<Violation>, geom: &CutGeometry) {
    let sheet = geom.sheet_index();
    // Spliced in at once: inserting each at the front was quadratic (a 1-px checkerboard has
    // hundreds of thousands of floating pieces).
    let floating: Vec<Violation> = (0..geom.material.0.len())
        .rev()
        .filter(|&i| Some(i) != sheet)
        .map(|i| {
            let c = geom.material.0[i]
                .exterior()
                .0
                .first()
                .copied()
                .unwrap_or(Coord { x: 0.0, y: 0.0 });
            Violation {
                kind: ViolationKind::Floating,
                x_mm: c.x,
                y_mm: c.y,
                width_mm: None,
                required_mm: 0.0,
                confirmed_by_opening: None,
            }
        })
        .collect();
    violations.splice(0..0, floating);
}

/// Many chords cross one thin neck: report the narrowest per place (one per `2 × required` radius).
fn cluster(mut cands: Vec<Candidate>, material: &Material) -> Vec<Violation> {
    // A total order (width, then place, then kind), so the result does not depend on the order
    // the triangles were searched in.
    cands.sort_by(|a, b| {
        a.d.total_cmp(&b.d)
            .then(a.mid[0].total_cmp(&b.mid[0]))
            .then(a.mid[1].total_cmp(&b.mid[1]))
            .then((a.kind as u8).cmp(&(b.kind as u8)))
    });
    let mut out: Vec<Violation> = Vec::new();
    // The violations kept, binned per kind in cells of `2 × required`: a kept one nearer than
    // that lies in one of the 3 × 3 cells around (a scan of all kept ones was quadratic).
    let mut bins: std::collections::HashMap<(u8, i64, i64), Vec<usize>> = Default::default();
    for c in cands {
        let req = match c.kind {
            ViolationKind::ThinBridge => material.min_bridge_mm,
            _ => material.min_feature_mm,
        };
        let cell = (2.0 * req).max(1e-9);
        let (cx, cy) = (
            (c.mid[0] / cell).floor() as i64,
            (c.mid[1] / cell).floor() as i64,
        );
        let k = c.kind as u8;
        let near = (-1..=1).any(|dx| {
            (-1..=1).any(|dy| {
                bins.get(&(k, cx + dx, cy + dy)).is_some_and(|v| {
                    v.iter()
                        .any(|&i| dist([out[i].x_mm, out[i].y_mm], c.mid) < 2.0 * req)
                })
            })
        });
        if !near {
            bins.entry((k, cx, cy)).or_default().push(out.len());
            out.push(Violation {
                kind: c.kind,
                x_mm: c.mid[0],
                y_mm: c.mid[1],
                width_mm: Some(c.d),
                required_mm: req,
                confirmed_by_opening: None,
            });
        }
    }
    out
}

/// The raster cross-check: for every width violation, open (material) or close (holes) the raster
/// with a disc of half the required width; the violation is confirmed when that removes the neck's
/// pixels at the reported position. Confirmed violations of one kind lying in the same connected
/// piece of removed pixels are one neck: only the narrowest is kept. Returns the raster's pieces
/// (4-connected, frame included).
pub(crate) fn cross_check(report: &mut CheckReport, bits: &BitGrid, scale: Scale) -> usize {
    // Per (radius, material side): the removed pixels' component labels.
    let mut cache: Vec<(u32, bool, Vec<u32>)> = Vec::new();
    let mut neck_of: Vec<Option<(usize, u32)>> = Vec::new();
    for v in &mut report.violations {
        if v.width_mm.is_none() {
            neck_of.push(None);
            continue;
        }
        let r = (scale.to_px(Mm(v.required_mm)).0 / 2.0).ceil().max(1.0) as u32;
        let material_side = v.kind != ViolationKind::ThinHole;
        let idx = match cache
            .iter()
            .position(|(cr, cm, _)| *cr == r && *cm == material_side)
        {
            Some(i) => i,
            None => {
                let g = if material_side {
                    raster::open(bits, r)
                } else {
                    raster::close(bits, r)
                };
                // Pixels the operation flipped: material it removed, or cut it filled.
                let changed = BitGrid {
                    width: bits.width,
                    height: bits.height,
                    data: bits.data.iter().zip(&g.data).map(|(a, b)| a != b).collect(),
                };
                cache.push((r, material_side, raster::components(&changed, true).0));
                cache.len() - 1
            }
        };
        let labels = &cache[idx].2;
        let (cx, cy) = (
            (scale.to_px(Mm(v.x_mm)).0).floor() as i64,
            (scale.to_px(Mm(v.y_mm)).0).floor() as i64,
        );
        let mut found = None;
        'search: for dy in [0, -1, 1] {
            for dx in [0, -1, 1] {
                let (x, y) = (cx + dx, cy + dy);
                if x < 0 || y < 0 || x >= bits.width as i64 || y >= bits.height as i64 {
                    continue;
                }
                let l = labels[y as usize * bits.width as usize + x as usize];
                if l != islands::CUT {
                    found = Some(l);
                    break 'search;
                }
            }
        }
        v.confirmed_by_opening = Some(found.is_some());
        neck_of.push(found.map(|l| (idx, l)));
    }
    // Keep the narrowest violation per (kind, neck); report order is narrowest first already.
    let mut seen: Vec<(ViolationKind, usize, u32)> = Vec::new();
    let mut keep = Vec::with_capacity(report.violations.len());
    for (v, n) in report.violations.iter().zip(&neck_of) {
        match n {
            Some((i, l)) if seen.contains(&(v.kind, *i, *l)) => keep.push(false),
            Some((i, l)) => {
                seen.push((v.kind, *i, *l));
                keep.push(true);
            }
            None => keep.push(true),
        }
    }
    let mut k = keep.into_iter();
    report.violations.retain(|_| k.next().unwrap_or(true));
    1 + islands::label(bits).island_count()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ring_of(pts: &[[f64; 2]]) -> Rings {
        let mp = MultiPolygon::new(vec![Polygon::new(
            geo::LineString::from(pts.iter().map(|p| (p[0], p[1])).collect::<Vec<_>>()),
            vec![],
        )]);
        rings_of(&mp, 1e9)
    }

    #[test]
    fn a_corner_chord_is_not_a_neck_but_a_waist_is() {
        // An hourglass: 10 wide at top and bottom, 1 wide at the waist (y = 5).
        let r = ring_of(&[
            [0.0, 0.0],
            [10.0, 0.0],
            [5.5, 5.0],
            [10.0, 10.0],
            [0.0, 10.0],
            [4.5, 5.0],
        ]);
        let cum = &r.cum[0];
        // Across the waist: vertex 2 (5.5, 5) to vertex 5 (4.5, 5).
        let a = End {
            ring: 0,
            arc: cum[2],
        };
        let b = End {
            ring: 0,
            arc: cum[5],
        };
        assert!(is_neck(&r, a, b, 1.0));
        // Across the corner at (10, 0): vertex 0 to vertex 2 is not a neck.
        let c = End {
            ring: 0,
            arc: cum[0],
        };
        assert!(!is_neck(&r, c, a, dist([0.0, 0.0], [5.5, 5.0])));
    }

    #[test]
    fn the_chunk_size_does_not_change_the_report() {
        use crate::vector::{vectorize, VectorConfig};
        // Holes and islands of many widths: thin and wide webs, holes and (unknown) bridges.
        let g = BitGrid::from_fn(120, 80, |x, y| {
            let (cx, cy) = (x % 20, y % 20);
            let w = 1 + (x / 20 + y / 20) % 4;
            !((3..3 + 3 * w).contains(&cx) && (4..16).contains(&cy)) || (cx == 4 + w && cy % 5 != 0)
        });
        let (geom, _) = vectorize(&g, &[], &VectorConfig::default()).unwrap();
        let material = Material::default();
        let tuned = |chunk| Tuning {
            chunk: Some(chunk),
            slabs: Some(1),
        };
        let (whole, _) = check_tuned(&geom, &material, false, tuned(usize::MAX)).unwrap();
        assert!(!whole.violations.is_empty() && whole.triangles > 100);
        for chunk in [1, 7, 64] {
            let (parts, _) = check_tuned(&geom, &material, false, tuned(chunk)).unwrap();
            assert_eq!(parts, whole, "chunk {chunk}");
        }
    }

    /// Holes and islands of many widths, round and slanted, over a whole sheet, outlined by
    /// simplification's chords: since the fitted curves' pieces grew longer (issue 43), this
    /// sheet's curves leave one empty circle wider than five slabs reach, so the check there
    /// runs at once (the same report, found by the fallback) and would not test the slabs.
    fn busy_sheet(w: u32, h: u32) -> CutGeometry {
        use crate::vector::{vectorize, VectorConfig};
        let g = BitGrid::from_fn(w, h, |x, y| {
            let (cx, cy) = (x % 23, y % 19);
            let r2 = (cx as i32 - 11).pow(2) + (cy as i32 - 9).pow(2);
            let slant = (x + 2 * y) % 37 < 2 + (x / 40) % 3;
            (r2 >= 40 + ((x / 23 + y / 19) % 5) as i32 * 12) && !slant || r2 < 6
        });
        let cfg = VectorConfig {
            curves: false,
            ..VectorConfig::default()
        };
        vectorize(&g, &[], &cfg).unwrap().0
    }

    #[test]
    fn slabs_tile_the_sheet_and_give_the_same_report_as_one_triangulation() {
        let geom = busy_sheet(420, 260);
        let material = Material::default();
        let one = |slabs| Tuning {
            chunk: None,
            slabs: Some(slabs),
        };
        let (whole, m) = check_tuned(&geom, &material, false, one(1)).unwrap();
        assert_eq!(m, Method::Whole);
        assert!(
            !whole.violations.is_empty() && whole.triangles > 5_000,
            "{}",
            whole.triangles
        );
        for slabs in [2, 3, 5] {
            let (r, m) = check_tuned(&geom, &material, false, one(slabs)).unwrap();
            assert_eq!(m, Method::Slabs(slabs));
            assert_eq!(r, whole, "{slabs} slabs");
        }
    }

    #[test]
    fn an_open_sheet_too_wide_for_its_slabs_is_triangulated_at_once() {
        use crate::vector::{vectorize, VectorConfig};
        // 60 × 60 mm of material with one small hole: the empty circles are far wider than the
        // slabs' reach into each other.
        let g = BitGrid::from_fn(600, 600, |x, y| {
            !((20..40).contains(&x) && (20..40).contains(&y))
        });
        let (geom, _) = vectorize(&g, &[], &VectorConfig::default()).unwrap();
        let material = Material::default();
        let tuned = |slabs| Tuning {
            chunk: None,
            slabs: Some(slabs),
        };
        let (whole, _) = check_tuned(&geom, &material, false, tuned(1)).unwrap();
        let (r, m) = check_tuned(&geom, &material, false, tuned(3)).unwrap();
        assert_eq!(m, Method::WholeAfterSlabs);
        assert_eq!(r, whole);
        assert!(r.passed(), "{:?}", r.violations);
    }

    #[test]
    fn densify_splits_long_edges_evenly() {
        let d = densify(&[[0.0, 0.0], [10.0, 0.0], [10.0, 1.0]], 2.5);
        // 10 → 4 pieces, 1 → 1, hypotenuse ≈ 10.05 → 5 pieces.
        assert_eq!(d.len(), 4 + 1 + 5);
        assert_eq!(d[1], [2.5, 0.0]);
    }
}
