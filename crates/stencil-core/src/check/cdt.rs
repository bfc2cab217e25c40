//! The sheet's constrained Delaunay triangulation (spade) as plain triangles, each marked material
//! or cut, built in parallel vertical slabs when the sheet is large.
//!
//! ## Why slabs give a true CDT
//! spade triangulates on one thread. The vertices are cut into `k` slabs by x; slab `s`
//! triangulates every vertex within a guard band either side (ring edges between them as
//! constraints) and keeps a triangle only when its circumcentre is in `[x_s, x_{s+1})` and its
//! circumcircle lies at least one ring edge's length inside the band. Every vertex and ring edge
//! that could affect that circle is then in the slab, so the triangle belongs to a CDT of the whole
//! sheet. Kept triangles tile the sheet when (a) every edge a slab leaves unmatched is matched once
//! by the reversed edge from another slab (the outline apart) and (b) there are `2V − h − 2` of
//! them (h vertices on the outline, the convex hull). If either fails, the whole sheet is
//! triangulated at once. With cocircular vertices every triangle kept is one of a valid CDT.
//!
//! ## How spade is asked
//! With the bare points in Z order, about a third faster than its constrained bulk load (see
//! [`build`]); the ring edges the Delaunay triangulation lacks (counted by ring indices) are then
//! added as constraints. Where rings touch or cross or a vertex repeats, the constrained bulk load
//! is used.

use rayon::prelude::*;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

use super::error::CheckError;

/// A vertex of the sheet: where, which ring, its index on the ring, its index over all rings, and
/// the index over all rings of the next vertex on its ring (ring edges are told without looking
/// anything up).
#[derive(Clone, Copy, Debug)]
pub(super) struct V {
    pub(crate) p: Point2<f64>,
    pub(crate) ring: u32,
    pub(crate) idx: u32,
    pub(crate) gid: u32,
    pub(crate) next: u32,
}

impl V {
    /// If `self → b` is an edge of a ring: the index of its first vertex along the ring, and
    /// whether `self → b` runs along the ring's direction.
    #[inline]
    pub(crate) fn ring_edge(self, b: V) -> Option<(u32, bool)> {
        if self.next == b.gid {
            Some((self.idx, true))
        } else if b.next == self.gid {
            Some((b.idx, false))
        } else {
            None
        }
    }
}

/// A triangle inside the sheet: its corners' global indices, counter-clockwise (numerically), and
/// whether it lies in material (else in a cut). Indices, not vertices: a sixth of the bytes to
/// write and read for each of the ~100,000 triangles of a large sheet.
#[derive(Clone, Copy, Debug)]
pub(super) struct Tri {
    pub(crate) v: [u32; 3],
    pub material: bool,
    /// Bit k: edge k (corner k to corner k + 1) is a ring edge (a constraint of the CDT).
    pub(crate) ring_edges: u8,
}

/// How the triangles were made (for tests and the curious).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Method {
    Whole,
    Slabs(usize),
    /// Slabs were tried and did not tile the sheet.
    WholeAfterSlabs,
}

/// The rings, as the triangulation needs them: each ring's vertex count.
pub(super) struct RingSizes {
    pub(crate) len: Vec<u32>,
    /// The ring of the sheet's outline (the convex hull of everything).
    pub outline: u32,
}

impl RingSizes {
    /// Append a ring (at least three points) as the next ring, its vertices to `verts`.
    pub(crate) fn push_ring(&mut self, verts: &mut Vec<V>, pts: &[[f64; 2]]) {
        let (ring, start, n) = (self.len.len() as u32, verts.len() as u32, pts.len() as u32);
        self.len.push(n);
        verts.extend(pts.iter().zip(0..).map(|(p, i)| V {
            p: Point2::new(p[0], p[1]),
            ring,
            idx: i,
            gid: start + i,
            next: start + (i + 1) % n,
        }));
    }
}

/// Triangulate the sheet whose vertices are `verts` (in global index order) and whose ring edges
/// are the constraints: the triangles, in one list per slab. `slabs`: how many slabs to try (1:
/// the whole sheet at once); `guard`: how far each slab reaches into its neighbours, in the
/// vertices' unit.
pub(super) fn triangulate(
    sizes: &RingSizes,
    verts: &[V],
    slabs: usize,
    guard: f64,
) -> Result<(Vec<Vec<Tri>>, Method), CheckError> {
    if slabs > 1 && verts.len() >= 3 * slabs {
        if let Some(tris) = in_slabs(sizes, verts, slabs, guard)? {
            return Ok((tris, Method::Slabs(slabs)));
        }
        let part = triangulate_part(sizes, verts, verts, None)?;
        return Ok((vec![part.tris], Method::WholeAfterSlabs));
    }
    Ok((
        vec![triangulate_part(sizes, verts, verts, None)?.tris],
        Method::Whole,
    ))
}

/// Which triangles a slab keeps: circumcentre x in `[x0, x1)`, circle inside `(lo, hi)`.
#[derive(Clone, Copy, Debug)]
struct Window {
    x0: f64,
    x1: f64,
    lo: f64,
    hi: f64,
}

struct Part {
    tris: Vec<Tri>,
    /// Edges (global indices, from → to) of kept triangles whose other side this part did not
    /// keep, the outline excepted.
    open: Vec<(u32, u32)>,
    /// Every kept triangle got its side (material or cut).
    labelled: bool,
}

/// Triangulate in `slabs` vertical slabs in parallel, each reaching `guard` into its
/// neighbours. `None` when the slabs do not add up to the whole sheet's triangulation (see
/// [`slabs_agree`]): the caller triangulates the whole sheet instead.
fn in_slabs(
    sizes: &RingSizes,
    verts: &[V],
    slabs: usize,
    guard: f64,
) -> Result<Option<Vec<Vec<Tri>>>, CheckError> {
    let (windows, margin) = slab_windows(verts, slabs, guard);
    let parts: Vec<Part> = windows
        .par_iter()
        .map(|w| {
            let mine: Vec<V> = verts
                .iter()
                .filter(|v| v.p.x >= w.lo && v.p.x <= w.hi)
                .copied()
                .collect();
            let keep = Window {
                lo: w.lo + margin,
                hi: w.hi - margin,
                ..*w
            };
            triangulate_part(sizes, verts, &mine, Some(keep))
        })
        .collect::<Result<_, _>>()?;
    if !slabs_agree(sizes, verts.len(), &parts) {
        return Ok(None);
    }
    Ok(Some(parts.into_iter().map(|p| p.tris).collect()))
}

/// The slabs' windows, split at x quantiles of the vertices (selected, not sorted), each reaching
/// `guard` beyond its own range; and the margin a kept triangle's circle must stay inside its
/// window by (the longest ring edge: a ring edge crossing a circle has both ends within this of
/// it, plus a rounding allowance).
fn slab_windows(verts: &[V], slabs: usize, guard: f64) -> (Vec<Window>, f64) {
    let mut xs: Vec<f64> = verts.iter().map(|v| v.p.x).collect();
    let n = xs.len();
    let cuts: Vec<f64> = (1..slabs)
        .map(|s| *xs.select_nth_unstable_by(s * n / slabs, f64::total_cmp).1)
        .collect();
    let (lo_x, hi_x) = verts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v.p.x), hi.max(v.p.x))
        });
    let reach = verts
        .iter()
        .map(|&v| {
            let w = verts[v.next as usize];
            ((v.p.x - w.p.x).powi(2) + (v.p.y - w.p.y).powi(2)).sqrt()
        })
        .fold(0.0f64, f64::max);
    let margin = reach + 1e-9 * (hi_x - lo_x).abs().max(1.0);
    let cut = |s: usize| cuts[s - 1];
    let windows = (0..slabs)
        .map(|s| {
            let x0 = if s == 0 { f64::NEG_INFINITY } else { cut(s) };
            let x1 = if s + 1 == slabs {
                f64::INFINITY
            } else {
                cut(s + 1)
            };
            Window {
                x0,
                x1,
                lo: x0 - guard,
                hi: x1 + guard,
            }
        })
        .collect();
    (windows, margin)
}

/// Whether the slabs' triangles are exactly the whole sheet's: (a) the count (V vertices, h on
/// the hull, the outline ring, give 2V − h − 2 triangles), every triangle with its side; (b) the
/// seams, each open edge met once each way.
fn slabs_agree(sizes: &RingSizes, vertices: usize, parts: &[Part]) -> bool {
    let h = sizes.len[sizes.outline as usize] as usize;
    let expected = (2 * vertices).checked_sub(h + 2);
    let kept: usize = parts.iter().map(|p| p.tris.len()).sum();
    if Some(kept) != expected || parts.iter().any(|p| !p.labelled) {
        return false;
    }
    let mut open: Vec<(u32, u32, bool)> = parts
        .iter()
        .flat_map(|p| p.open.iter())
        .map(|&(a, b)| (a.min(b), a.max(b), a < b))
        .collect();
    open.sort_unstable();
    open.len().is_multiple_of(2)
        && open
            .chunks_exact(2)
            .all(|c| (c[0].0, c[0].1) == (c[1].0, c[1].1) && c[0].2 != c[1].2)
}

/// Circumcentre x and radius of a triangle.
fn circle(a: Point2<f64>, b: Point2<f64>, c: Point2<f64>) -> (f64, f64) {
    let (bx, by) = (b.x - a.x, b.y - a.y);
    let (cx, cy) = (c.x - a.x, c.y - a.y);
    let d = 2.0 * (bx * cy - by * cx);
    let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
    let ux = (cy * b2 - by * c2) / d;
    let uy = (bx * c2 - cx * b2) / d;
    // sqrt, not hypot: glibc's careful hypot was a tenth of this function's time.
    (a.x + ux, (ux * ux + uy * uy).sqrt())
}

const UNKEPT: u8 = 0;
const MATERIAL: u8 = 1;
const CUT: u8 = 2;
const PENDING: u8 = 3;

type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

/// spade's triangulation of some vertices, and how its vertices map back to them.
struct Built {
    cdt: Cdt,
    /// spade's vertex j is `verts[of[j]]`.
    of: Vec<u32>,
    /// No vertex repeated and no ring edge split: the ring edges in the triangulation are exactly
    /// its edges between consecutive vertices of a ring, and their direction gives each side.
    /// (Rings never touch, so normally.)
    clean: bool,
    /// Every ring edge is known to be in the triangulation (spade was given them as constraints).
    /// Otherwise they are counted while the faces are read.
    constrained: bool,
}

/// Triangulate `verts`, usually without the ring edges `edges` (indices into `verts`): the bare
/// points one by one in Z order ([`spatial_order`]), which normally holds every ring edge already;
/// [`complete`] adds any it lacks. A repeated vertex: spade's constrained bulk load. On a 2000² px
/// sheet: constrained bulk load 26 ms, plain bulk load 20 ms, Z order 17 ms.
fn build(verts: &[V], edges: &[[usize; 2]]) -> Result<Built, CheckError> {
    let of = spatial_order(verts);
    let mut cdt = Cdt::new();
    for &i in &of {
        let p = verts[i as usize].p;
        cdt.insert(p).map_err(|e| coordinate_error(p, e))?;
    }
    if cdt.num_vertices() != verts.len() {
        return build_constrained(verts, edges);
    }
    Ok(Built {
        cdt,
        of,
        clean: true,
        constrained: false,
    })
}

/// A triangulation from [`build`] lacks some ring edges: add them as constraints. A
/// triangulation holding every ring edge whose other edges are all locally Delaunay is the
/// constrained Delaunay triangulation. If they cannot all be there, whole (rings crossing or
/// touching, a vertex on a ring edge), spade's constrained bulk load instead.
fn complete(mut b: Built, verts: &[V], edges: &[[usize; 2]]) -> Result<Built, CheckError> {
    use spade::handles::FixedVertexHandle as H;
    let mut inv = vec![0u32; verts.len()];
    for (j, &i) in b.of.iter().enumerate() {
        inv[i as usize] = j as u32;
    }
    let handle = |[i, j]: [usize; 2]| {
        [
            H::from_index(inv[i] as usize),
            H::from_index(inv[j] as usize),
        ]
    };
    let missing: Vec<[H; 2]> = edges
        .iter()
        .map(|&e| handle(e))
        .filter(|&[u, v]| b.cdt.get_edge_from_neighbors(u, v).is_none())
        .collect();
    for &[u, v] in &missing {
        // Empty: it would cross a constraint added before (rings crossing).
        if b.cdt.try_add_constraint(u, v).is_empty() {
            return build_constrained(verts, edges);
        }
    }
    // Adding one may flip away a ring edge that was there but not marked as a constraint (only
    // where rings touch or cross): every ring edge must be there, whole.
    let whole = edges.iter().all(|&e| {
        let [u, v] = handle(e);
        b.cdt.get_edge_from_neighbors(u, v).is_some()
    });
    if !whole {
        return build_constrained(verts, edges);
    }
    b.constrained = true;
    Ok(b)
}

/// The check's error for a point the triangulation refuses.
fn coordinate_error(p: Point2<f64>, e: spade::InsertionError) -> CheckError {
    CheckError::Coordinate {
        x_mm: p.x,
        y_mm: p.y,
        problem: match e {
            spade::InsertionError::TooSmall => "too close to zero but not zero",
            spade::InsertionError::TooLarge => "too large",
            spade::InsertionError::NAN => "not a number",
        },
    }
}

/// spade's constrained bulk load, which drops repeated vertices and splits constraints at
/// vertices lying on them.
fn build_constrained(verts: &[V], edges: &[[usize; 2]]) -> Result<Built, CheckError> {
    let cdt = Cdt::try_bulk_load_cdt(verts.iter().map(|v| v.p).collect(), edges.to_vec(), |_| {})
        .map_err(|e| {
        // The point spade refused (the first one that fails its test).
        let p = verts
            .iter()
            .map(|v| v.p)
            .find(|p| spade::validate_vertex(p).is_err())
            .unwrap_or(Point2::new(f64::NAN, f64::NAN));
        coordinate_error(p, e)
    })?;
    // spade keeps the points' order, dropping repeats: spade's vertex j is `verts[of[j]]`, found
    // by walking both in order.
    let of: Vec<u32> = if cdt.num_vertices() == verts.len() {
        (0..verts.len() as u32).collect()
    } else {
        let mut i = 0;
        cdt.vertices()
            .map(|v| {
                while verts[i].p != *v.data() {
                    i += 1;
                }
                i += 1;
                (i - 1) as u32
            })
            .collect()
    };
    let clean = cdt.num_vertices() == verts.len() && cdt.num_constraints() == edges.len();
    Ok(Built {
        cdt,
        of,
        clean,
        constrained: true,
    })
}

/// The vertices (indices) in Z order (Morton order of their positions quantised to 16 bits a
/// coordinate), ties by index.
fn spatial_order(verts: &[V]) -> Vec<u32> {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for v in verts {
        lo = [lo[0].min(v.p.x), lo[1].min(v.p.y)];
        hi = [hi[0].max(v.p.x), hi[1].max(v.p.y)];
    }
    let scale = 65535.0 / (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-9);
    // The bits of a 16-bit number spread to the even bits of a 32-bit one.
    let spread = |v: f64| {
        let mut x = (v * scale) as u64 & 0xffff;
        x = (x | x << 8) & 0x00ff_00ff;
        x = (x | x << 4) & 0x0f0f_0f0f;
        x = (x | x << 2) & 0x3333_3333;
        (x | x << 1) & 0x5555_5555
    };
    let mut keyed: Vec<(u64, u32)> = verts
        .iter()
        .enumerate()
        .map(|(i, v)| (spread(v.p.x - lo[0]) | spread(v.p.y - lo[1]) << 1, i as u32))
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// spade's faces read into plain arrays.
struct Faces {
    tris: Vec<Tri>,
    /// The face across each edge k (corner k to corner k + 1), as spade numbers faces (0: outside).
    across: Vec<[u32; 3]>,
    /// Each face's side so far: UNKEPT, PENDING, or (in a slab, on a ring edge) MATERIAL / CUT.
    label: Vec<u8>,
    /// The faces labelled so far.
    queue: Vec<usize>,
    /// How many ring edges the triangulation holds (only counted when it is clean).
    ring_edges: usize,
}

/// One pass over spade's faces: each face's corners, its ring edges, the faces across, whether
/// the window keeps it, and (in a slab) its side when it lies on a ring. Walking spade's handles
/// face by face costs a cache miss per step; everything after walks these arrays.
fn read_faces(b: &Built, verts: &[V], window: Option<Window>) -> Faces {
    let n = b.cdt.num_inner_faces();
    let mut tris: Vec<Tri> = Vec::with_capacity(n);
    let mut across: Vec<[u32; 3]> = Vec::with_capacity(n);
    let mut label = Vec::with_capacity(n);
    let mut queue = Vec::new();
    // Ring edges seen, by their first vertex.
    let mut seen = vec![false; if b.clean { verts.len() } else { 0 }];
    let mut ring_edges = 0;
    for f in b.cdt.inner_faces() {
        // spade numbers its inner faces 1.., in this order.
        debug_assert_eq!(f.fix().index(), tris.len() + 1);
        let es = f.adjacent_edges();
        let li = es.map(|e| b.of[e.from().fix().index()] as usize);
        let c = li.map(|i| verts[i]);
        // Clean: the ring edges are the pairs of consecutive ring vertices (cheaper to tell than
        // asking spade). Otherwise they are spade's constraint edges.
        let mut ring = [false; 3];
        let mut seed = None;
        for k in 0..3 {
            if b.clean {
                if let Some((_, forward)) = c[k].ring_edge(c[(k + 1) % 3]) {
                    ring[k] = true;
                    seed = seed.or(Some(forward));
                    let first = if forward { li[k] } else { li[(k + 1) % 3] };
                    if !seen[first] {
                        seen[first] = true;
                        ring_edges += 1;
                    }
                }
            } else {
                ring[k] = b.cdt.is_constraint_edge(es[k].fix().as_undirected());
                if ring[k] {
                    seed = seed.or(c[k].ring_edge(c[(k + 1) % 3]).map(|(_, f)| f));
                }
            }
        }
        tris.push(Tri {
            v: c.map(|v| v.gid),
            material: false,
            ring_edges: (ring[0] as u8) | (ring[1] as u8) << 1 | (ring[2] as u8) << 2,
        });
        across.push(es.map(|e| e.rev().face().fix().index() as u32));
        let kept = window.is_none_or(|w| {
            let (cx, r) = circle(c[0].p, c[1].p, c[2].p);
            cx >= w.x0 && cx < w.x1 && cx - r > w.lo && cx + r < w.hi
        });
        let mut side = if kept { PENDING } else { UNKEPT };
        if kept && window.is_some() {
            if let Some(forward) = seed {
                side = if forward { MATERIAL } else { CUT };
                queue.push(label.len());
            }
        }
        label.push(side);
    }
    Faces {
        tris,
        across,
        label,
        queue,
        ring_edges,
    }
}

/// Triangulate `verts` with the ring edges among them as constraints; keep the triangles the
/// window allows (all when none), each marked material or cut: a triangle on a ring edge lies
/// left of the ring's direction (material) or right (cut); the others take the side of a kept
/// neighbour across an edge that is not a ring edge.
fn triangulate_part(
    sizes: &RingSizes,
    all: &[V],
    verts: &[V],
    window: Option<Window>,
) -> Result<Part, CheckError> {
    let edges = part_edges(verts, window.is_none());
    let mut built = build(verts, &edges)?;
    let Faces {
        mut tris,
        across,
        mut label,
        mut queue,
        ..
    } = loop {
        if window.is_some() && !built.clean {
            return Ok(Part {
                tris: Vec::new(),
                open: Vec::new(),
                labelled: false,
            });
        }
        let faces = read_faces(&built, verts, window);
        if built.constrained || faces.ring_edges == edges.len() {
            break faces;
        }
        built = complete(built, verts, &edges)?;
    };
    drop(built);
    if window.is_some() {
        spread_sides(&tris, &across, &mut label, &mut queue);
    } else {
        label_by_parity(&tris, &across, &mut label, &mut queue);
    }
    let (open, labelled) = keep_labelled(&mut tris, &across, &label, all, sizes, window);
    Ok(Part {
        tris,
        open,
        labelled,
    })
}

/// The ring edges among `verts` in local indices (vertex i to its ring's next vertex). A slab's
/// `verts` are a subset (not `dense`): an edge whose next vertex lies outside it is left out.
fn part_edges(verts: &[V], dense: bool) -> Vec<[usize; 2]> {
    // Local indices by global index (verts are in global order, so the last is the largest).
    let mut local = Vec::new();
    if !dense {
        local = vec![u32::MAX; verts.last().map_or(0, |v| v.gid as usize + 1)];
        for (i, v) in verts.iter().enumerate() {
            local[v.gid as usize] = i as u32;
        }
    }
    let mut edges = Vec::with_capacity(verts.len());
    for (i, &v) in verts.iter().enumerate() {
        let next = v.next as usize;
        let j = if dense {
            Some(next)
        } else {
            local
                .get(next)
                .filter(|&&j| j != u32::MAX)
                .map(|&j| j as usize)
        };
        if let Some(j) = j {
            edges.push([i, j]);
        }
    }
    edges
}

/// A slab: sides spread from the seeded triangles (`queue`, labelled on a ring edge) across
/// edges that are not ring edges.
fn spread_sides(tris: &[Tri], across: &[[u32; 3]], label: &mut [u8], queue: &mut Vec<usize>) {
    while let Some(i) = queue.pop() {
        for (k, &g) in across[i].iter().enumerate() {
            let g = g as usize;
            if g == 0 || tris[i].ring_edges & (1 << k) != 0 {
                continue;
            }
            if label[g - 1] == PENDING {
                label[g - 1] = label[i];
                queue.push(g - 1);
            }
        }
    }
}

/// The whole sheet: each triangle's side from the parity of ring edges crossed from outside
/// (odd: material, even: a cut, none: outside the sheet). Needs no ring direction.
fn label_by_parity(tris: &[Tri], across: &[[u32; 3]], label: &mut [u8], queue: &mut Vec<usize>) {
    let mut depth = vec![u32::MAX; tris.len()];
    for i in 0..tris.len() {
        for (k, &g) in across[i].iter().enumerate() {
            if g == 0 && depth[i] == u32::MAX {
                depth[i] = u32::from(tris[i].ring_edges & (1 << k) != 0);
                queue.push(i);
            }
        }
    }
    let mut head = 0;
    while head < queue.len() {
        let i = queue[head];
        head += 1;
        for (k, &g) in across[i].iter().enumerate() {
            let g = g as usize;
            if g != 0 && depth[g - 1] == u32::MAX {
                depth[g - 1] = depth[i] + u32::from(tris[i].ring_edges & (1 << k) != 0);
                queue.push(g - 1);
            }
        }
    }
    for (l, d) in label.iter_mut().zip(&depth) {
        *l = match *d {
            u32::MAX => PENDING,
            0 => UNKEPT,
            d if d % 2 == 1 => MATERIAL,
            _ => CUT,
        };
    }
}

/// Keep the labelled triangles, in place, each marked material or cut. In a slab, also the edges
/// of kept triangles that face neither another kept triangle nor the outline (where the slab
/// meets its neighbours). Returns those edges (global vertex numbers) and whether every
/// triangle got a side.
fn keep_labelled(
    tris: &mut Vec<Tri>,
    across: &[[u32; 3]],
    label: &[u8],
    all: &[V],
    sizes: &RingSizes,
    window: Option<Window>,
) -> (Vec<(u32, u32)>, bool) {
    let corners = |t: &Tri| t.v.map(|g| all[g as usize]);
    let mut open = Vec::new();
    let mut labelled = true;
    let mut w = 0;
    for i in 0..tris.len() {
        match label[i] {
            UNKEPT => continue,
            PENDING => {
                labelled = false;
                continue;
            }
            _ => {}
        }
        tris[w] = Tri {
            material: label[i] == MATERIAL,
            ..tris[i]
        };
        w += 1;
        if window.is_some() {
            let c = corners(&tris[i]);
            for k in 0..3 {
                let (u, v) = (c[k], c[(k + 1) % 3]);
                let g = across[i][k] as usize;
                let other_kept = g != 0 && label[g - 1] != UNKEPT;
                let on_outline = u.ring == sizes.outline && tris[w - 1].ring_edges & (1 << k) != 0;
                if !other_kept && !on_outline {
                    open.push((u.gid, v.gid));
                }
            }
        }
    }
    tris.truncate(w);
    (open, labelled)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sheet(rings: &[&[[f64; 2]]]) -> (RingSizes, Vec<V>) {
        let mut sizes = RingSizes {
            len: Vec::new(),
            outline: 0,
        };
        let mut verts = Vec::new();
        for r in rings {
            sizes.push_ring(&mut verts, r);
        }
        (sizes, verts)
    }

    /// The outline of a 10 × 10 sheet, counter-clockwise.
    const SQUARE: &[[f64; 2]] = &[[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];

    /// Every ring edge, by global index.
    fn ring_edges(verts: &[V]) -> Vec<[usize; 2]> {
        verts
            .iter()
            .map(|&v| [v.gid as usize, v.next as usize])
            .collect()
    }

    /// The area the triangles cover, and the part of it marked cut.
    fn areas<'a>(verts: &[V], tris: impl IntoIterator<Item = &'a Tri>) -> (f64, f64) {
        tris.into_iter().fold((0.0, 0.0), |(all, cut), t| {
            let a = area(verts, t);
            (all + a, if t.material { cut } else { cut + a })
        })
    }

    fn area(verts: &[V], t: &Tri) -> f64 {
        let [a, b, c] = t.v.map(|g| verts[g as usize].p);
        ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)) / 2.0
    }

    #[test]
    fn holes_touching_at_a_corner_are_read_back_by_position() {
        // Two square holes (clockwise) sharing the vertex (4, 4): spade keeps one of the two.
        let a: &[[f64; 2]] = &[[2.0, 2.0], [2.0, 4.0], [4.0, 4.0], [4.0, 2.0]];
        let b: &[[f64; 2]] = &[[4.0, 4.0], [4.0, 6.0], [6.0, 6.0], [6.0, 4.0]];
        let (sizes, verts) = sheet(&[SQUARE, a, b]);
        let (parts, m) = triangulate(&sizes, &verts, 1, 1.0).unwrap();
        assert_eq!(m, Method::Whole);
        let tris: Vec<&Tri> = parts.iter().flatten().collect();
        // Every triangle counter-clockwise, the sheet covered once, the holes' area cut.
        assert!(tris.iter().all(|t| area(&verts, t) > 0.0));
        let (total, cut) = areas(&verts, tris.iter().copied());
        assert!((total - 100.0).abs() < 1e-9, "{total}");
        assert!((cut - 8.0).abs() < 1e-9, "{cut}");
    }

    #[test]
    fn sides_are_right_where_a_ring_loses_its_corner_to_another() {
        // Hole b shares the corner (4, 4) with hole a; spade keeps a's vertex, so b's edges at
        // that corner are no pair of consecutive b vertices (found in review: sides were then
        // taken from ring order and could spread across b's edge).
        let a: &[[f64; 2]] = &[[2.0, 2.0], [2.0, 4.0], [4.0, 4.0], [4.0, 2.0]];
        let b: &[[f64; 2]] = &[[4.0, 4.0], [4.0, 6.0], [7.0, 7.0], [6.0, 4.0]];
        let (sizes, verts) = sheet(&[SQUARE, a, b]);
        for slabs in [1, 2] {
            let (parts, _) = triangulate(&sizes, &verts, slabs, 3.0).unwrap();
            let (total, cut) = areas(&verts, parts.iter().flatten());
            assert!((total - 100.0).abs() < 1e-9, "{total}");
            assert!((cut - 10.0).abs() < 1e-9, "{slabs} slabs: cut {cut}");
        }
    }

    #[test]
    fn a_ring_edge_the_delaunay_triangulation_lacks_is_added() {
        // A long slot whose lower side (1, 4) -> (9, 4) passes just above the tip of a triangle
        // hole: the plain Delaunay triangulation joins the tip to the slot's corners across it.
        let slot: &[[f64; 2]] = &[[1.0, 4.0], [1.0, 4.5], [9.0, 4.5], [9.0, 4.0]];
        let tip: &[[f64; 2]] = &[[4.0, 1.0], [5.0, 3.9], [6.0, 1.0]];
        let (sizes, verts) = sheet(&[SQUARE, slot, tip]);
        let edges = ring_edges(&verts);
        let built = build(&verts, &edges).unwrap();
        assert!(!built.constrained && built.clean);
        let seen = read_faces(&built, &verts, None).ring_edges;
        assert!(seen < edges.len(), "test premise: ring edges missing");
        let built = complete(built, &verts, &edges).unwrap();
        assert!(built.constrained && built.clean);
        assert_eq!(read_faces(&built, &verts, None).ring_edges, edges.len());
        for slabs in [1, 2] {
            let (parts, _) = triangulate(&sizes, &verts, slabs, 5.0).unwrap();
            let (total, cut) = areas(&verts, parts.iter().flatten());
            assert!((total - 100.0).abs() < 1e-9, "{total}");
            assert!((cut - (4.0 + 2.9)).abs() < 1e-9, "{slabs} slabs: cut {cut}");
        }
    }

    #[test]
    fn crossing_rings_fall_back_to_spades_constrained_bulk_load() {
        // Two holes crossing (bad input): the ring edges cannot all be whole; the sheet is still
        // triangulated, by spade's constrained bulk load, which splits them.
        let a: &[[f64; 2]] = &[[2.0, 2.0], [2.0, 6.0], [6.0, 6.0], [6.0, 2.0]];
        let b: &[[f64; 2]] = &[[4.0, 4.0], [4.0, 8.0], [8.0, 8.0], [8.0, 4.0]];
        let (sizes, verts) = sheet(&[SQUARE, a, b]);
        let edges = ring_edges(&verts);
        let built = build(&verts, &edges).unwrap();
        assert!(read_faces(&built, &verts, None).ring_edges < edges.len());
        let built = complete(built, &verts, &edges).unwrap();
        assert!(built.constrained && !built.clean);
        let (parts, _) = triangulate(&sizes, &verts, 1, 1.0).unwrap();
        let (total, _) = areas(&verts, parts.iter().flatten());
        assert!((total - 100.0).abs() < 1e-9, "{total}");
    }

    #[test]
    fn slabs_of_a_grid_of_holes_tile_it_exactly() {
        // A 12 x 6 grid of small square holes in a 60 x 30 sheet, in three slabs.
        // The outline carries a vertex every unit, as the check densifies it.
        let outline: Vec<[f64; 2]> = (0..60)
            .map(|i| [i as f64, 0.0])
            .chain((0..30).map(|j| [60.0, j as f64]))
            .chain((0..60).map(|i| [60.0 - i as f64, 30.0]))
            .chain((0..30).map(|j| [0.0, 30.0 - j as f64]))
            .collect();
        let holes: Vec<Vec<[f64; 2]>> = (0..12)
            .flat_map(|i| (0..6).map(move |j| (i as f64 * 5.0 + 1.5, j as f64 * 5.0 + 1.5)))
            .map(|(x, y)| vec![[x, y], [x, y + 2.0], [x + 2.0, y + 2.0], [x + 2.0, y]])
            .collect();
        let mut rings: Vec<&[[f64; 2]]> = vec![&outline];
        rings.extend(holes.iter().map(|h| h.as_slice()));
        let (sizes, verts) = sheet(&rings);
        let (parts, m) = triangulate(&sizes, &verts, 3, 12.0).unwrap();
        assert_eq!(m, Method::Slabs(3));
        let (total, cut) = areas(&verts, parts.iter().flatten());
        assert!((total - 1800.0).abs() < 1e-9, "{total}");
        assert!((cut - 72.0 * 4.0).abs() < 1e-9, "{cut}");
        // With a reach too short for the sheet's open margin, the slabs don't tile: at once.
        let (parts, m) = triangulate(&sizes, &verts, 3, 0.5).unwrap();
        assert_eq!(m, Method::WholeAfterSlabs);
        let (total, _) = areas(&verts, parts.iter().flatten());
        assert!((total - 1800.0).abs() < 1e-9, "{total}");
    }
}
