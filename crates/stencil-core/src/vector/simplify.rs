//! Ring simplification (Douglas–Peucker) that never creates self-intersections and never lets two
//! rings touch or cross (which would merge separate regions).
//!
//! Douglas–Peucker keeps a chord when every point it replaces is within the tolerance *and*, when
//! guards are given, every replaced point's two pixel centres (material, cut) stay on their own
//! sides of the chord: the simplified outline then samples to exactly the same raster at pixel
//! centres, so simplification never changes which pixels are cut.
//!
//! Every ring is simplified on its own; then all segments go into a uniform grid and every pair that
//! shares a cell is tested (touching counts as a conflict). A ring involved in a conflict falls back
//! to its lossless form (only exactly collinear points removed), and the test repeats until a
//! round reverts nothing, for at most 8 rounds. Each round can only revert rings, and the traced
//! rings never touch each other, so conflicts run out; but a conflict first found in a ninth round
//! would stay (the bound keeps the time bounded on adversarial input).

use geo::kernels::{Kernel, Orientation, RobustKernel};
use geo::Coord;
use rayon::prelude::*;

use stencil_geom::curve::Piece;
use stencil_geom::ring::signed_area2;

use super::trace::Guard;

/// What simplification did, for the report.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct SimplifyStats {
    /// Rings simplified.
    pub rings: usize,
    /// Points before.
    pub points_in: usize,
    /// Points after.
    pub points_out: usize,
    /// Rings kept at full detail because simplifying them would have crossed or touched a ring.
    pub(crate) fallbacks: usize,
    /// Rings replaced by lines and arcs fitted to the traced points
    /// ([`stencil_geom::curve::fit_ring_within`]), and how many arcs they hold; absent from
    /// reports written before curves were fitted.
    #[serde(default)]
    pub(crate) curved_rings: usize,
    #[serde(default)]
    pub(crate) arcs: usize,
}

/// Fitting the traced rings with lines and arcs (see [`simplify_and_fit`]): within `tol`, like
/// simplification, then flattened back into polygon rings within `flatten`, or, when
/// `straight`, made straight within `tol` of the traced points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FitCurves {
    pub(crate) flatten: f64,
    /// How far the curves keep the pixel centres beside the traced outline from them (the
    /// flattening then adds a vertex where a chord would cross one:
    /// [`stencil_geom::curve::flatten_clear`]).
    pub(crate) clear: f64,
    /// No file will carry arcs (`--no-arcs`, a machine without them): each ring becomes the polygon
    /// with the fewest corners Douglas–Peucker finds on the fitted curves within `tol` of the traced
    /// points, guards kept ([`straighten`]), unless simplification's own has fewer points.
    pub(crate) straight: bool,
}

/// Simplify closed rings (no repeated closing point) in place, within `tol` (same unit as the
/// points). `guards`: per ring, per point, the pixel centres to keep on their sides (or none).
/// Simplification alone: the `vector` bench's step (`bench-internals`) and the tests.
#[cfg_attr(not(any(test, feature = "bench-internals")), allow(dead_code))]
pub fn simplify_rings(
    rings: &mut [Vec<[f64; 2]>],
    guards: Option<&[Vec<Guard>]>,
    tol: f64,
) -> SimplifyStats {
    simplify_and_fit(rings, guards, tol, None).0
}

/// [`simplify_rings`], then, with `curves`, each ring replaced by lines and arcs fitted to its
/// traced points within `tol` ([`stencil_geom::curve::fit_ring_within`]), flattened within
/// `curves.flatten`, guards kept; a ring whose curves would cross or touch another keeps its
/// simplified form. Also returns, per ring, the lines and arcs its polygon flattens (when fitted
/// and kept), so the files can carry those arcs.
pub(crate) fn simplify_and_fit(
    rings: &mut [Vec<[f64; 2]>],
    guards: Option<&[Vec<Guard>]>,
    tol: f64,
    curves: Option<FitCurves>,
) -> (SimplifyStats, Vec<Option<Vec<Piece>>>) {
    let mut stats = SimplifyStats {
        rings: rings.len(),
        points_in: rings.iter().map(Vec::len).sum(),
        ..Default::default()
    };
    // The rings as traced are kept (moved, not copied): a ring that must fall back to full detail
    // is made from its original then, so the lossless version is built for those rings only.
    let originals: Vec<Vec<[f64; 2]>> = rings.iter_mut().map(std::mem::take).collect();
    // Each ring on its own, in parallel.
    let mut simplified: Vec<bool> = rings
        .par_iter_mut()
        .zip(originals.par_iter())
        .enumerate()
        .map(|(i, (r, orig))| {
            if tol > 0.0 {
                let s = drop_collinear(&dp_ring(
                    orig,
                    guards.and_then(|g| g.get(i)).map(Vec::as_slice),
                    tol,
                ));
                // Dropping collinear points changes no area, so the original's sign is the
                // lossless one.
                let a1 = signed_area2(&s);
                if s.len() >= 3
                    && signed_area2(orig).signum() == a1.signum()
                    && a1 != 0.0
                    && s.len() < kept_by_drop_collinear(orig)
                {
                    *r = s;
                    return true;
                }
            }
            *r = drop_collinear(orig);
            false
        })
        .collect();
    // Grid cells of 16 px (or 8 tolerances): few cells per segment, few segments per cell.
    let cell = (8.0 * tol).max(16.0);
    for _ in 0..8 {
        let bad = conflicts(rings, cell);
        let mut changed = false;
        for i in bad {
            if simplified[i] {
                rings[i] = drop_collinear(&originals[i]);
                simplified[i] = false;
                stats.fallbacks += 1;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let mut pieces = vec![None; rings.len()];
    if let (Some(c), true) = (curves, tol > 0.0) {
        pieces = fit_curves(
            rings,
            &originals,
            &simplified,
            guards,
            tol,
            c,
            cell,
            &mut stats,
        );
    }
    stats.points_out = rings.iter().map(Vec::len).sum();
    (stats, pieces)
}

/// The curve step of [`simplify_and_fit`]: rings that simplified (`simplified[i]`) are fitted
/// from their traced points; any that then conflict go back to their simplified form. Returns
/// the pieces of each ring kept as flattened curves.
#[allow(clippy::too_many_arguments)]
fn fit_curves(
    rings: &mut [Vec<[f64; 2]>],
    originals: &[Vec<[f64; 2]>],
    simplified: &[bool],
    guards: Option<&[Vec<Guard>]>,
    tol: f64,
    c: FitCurves,
    cell: f64,
    stats: &mut SimplifyStats,
) -> Vec<Option<Vec<Piece>>> {
    use stencil_geom::curve;
    let rings_len: Vec<usize> = rings.iter().map(Vec::len).collect();
    type Fitted = (Vec<[f64; 2]>, usize, Option<Vec<Piece>>);
    let fitted: Vec<Option<Fitted>> = (0..rings.len())
        .into_par_iter()
        .map(|i| {
            if !simplified[i] {
                return None;
            }
            let orig = &originals[i];
            let g = guards.and_then(|g| g.get(i));
            let fit = |margin: f64| {
                let sides = g.map(|g| curve::Sides {
                    points: g.as_slice(),
                    margin,
                });
                let pieces = curve::fit_ring_within(orig, tol, sides);
                let arcs = curve::arc_count(&pieces);
                (arcs > 0).then_some((pieces, arcs))
            };
            let (flat, arcs, pieces) = if c.straight {
                // The straight outline from the curves kept clear by either margin, whichever
                // has fewer corners: the curves closer to the pixel centres reach farther, but
                // the chords between their points must keep the centres on their sides too.
                let margins = if c.flatten > c.clear {
                    vec![c.clear, c.flatten]
                } else {
                    vec![c.clear]
                };
                let (s, arcs) = margins
                    .into_iter()
                    .filter_map(|m| {
                        let (pieces, arcs) = fit(m)?;
                        Some((straighten(orig, &pieces, g.map(Vec::as_slice), tol)?, arcs))
                    })
                    .min_by_key(|(s, _)| s.len())?;
                // Simplification's polygon (in `rings[i]` until now) when it has fewer points.
                if s.len() >= rings_len[i] {
                    return None;
                }
                (s, arcs, None)
            } else {
                let (pieces, arcs) = fit(c.clear)?;
                let keep: &[[f64; 2]] = g.map_or(&[], |g| g.as_flattened());
                (
                    curve::flatten_clear(&pieces, c.flatten, keep),
                    arcs,
                    Some(pieces),
                )
            };
            let a = signed_area2(&flat);
            (flat.len() >= 3 && a != 0.0 && a.signum() == signed_area2(orig).signum())
                .then_some((flat, arcs, pieces))
        })
        .collect();
    let mut kept: Vec<Option<(Vec<[f64; 2]>, usize)>> = vec![None; rings.len()];
    let mut pieces: Vec<Option<Vec<Piece>>> = vec![None; rings.len()];
    for (i, f) in fitted.into_iter().enumerate() {
        if let Some((flat, arcs, p)) = f {
            let dp = std::mem::replace(&mut rings[i], flat);
            kept[i] = Some((dp, arcs));
            pieces[i] = p;
        }
    }
    for _ in 0..8 {
        let mut changed = false;
        for i in conflicts(rings, cell) {
            if let Some((dp, _)) = kept[i].take() {
                rings[i] = dp;
                pieces[i] = None;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    for (_, arcs) in kept.iter().flatten() {
        stats.curved_rings += 1;
        stats.arcs += arcs;
    }
    pieces
}

/// The straight outline of [`FitCurves::straight`]: the traced ring `orig`'s points moved onto the
/// `pieces` fitted to it ([`stencil_geom::curve::onto_pieces`]), then Douglas–Peucker between them
/// against every traced point ([`dp_kept`]). Within `tol` both ways: every traced point is within
/// `tol` of its chord, each corner of its traced point, and the distance to a segment is convex.
/// Guards are kept on their sides, so the raster is the same. `None` when the pieces are not
/// `orig`'s.
fn straighten(
    orig: &[[f64; 2]],
    pieces: &[stencil_geom::curve::Piece],
    guards: Option<&[Guard]>,
    tol: f64,
) -> Option<Vec<[f64; 2]>> {
    let on = stencil_geom::curve::onto_pieces(orig, pieces)?;
    Some(drop_collinear(
        &dp_kept(orig, &on, guards, tol)
            .into_iter()
            .map(|i| on[i])
            .collect::<Vec<_>>(),
    ))
}

/// How many points [`drop_collinear`] keeps, without building the ring.
fn kept_by_drop_collinear(r: &[[f64; 2]]) -> usize {
    let n = r.len();
    if n < 4 {
        return n;
    }
    let kept = (0..n)
        .filter(|&i| !collinear_between(r[(i + n - 1) % n], r[i], r[(i + 1) % n]))
        .count();
    if kept < 3 {
        n
    } else {
        kept
    }
}

/// Whether `q` lies on the segment from `p` to `s` (exactly), so dropping it loses nothing.
fn collinear_between(p: [f64; 2], q: [f64; 2], s: [f64; 2]) -> bool {
    let cross = (q[0] - p[0]) * (s[1] - q[1]) - (q[1] - p[1]) * (s[0] - q[0]);
    let dot = (q[0] - p[0]) * (s[0] - q[0]) + (q[1] - p[1]) * (s[1] - q[1]);
    cross == 0.0 && dot >= 0.0
}

/// Remove points lying exactly on the line through their neighbours (lossless).
pub(crate) fn drop_collinear(r: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let n = r.len();
    if n < 4 {
        return r.to_vec();
    }
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        if !collinear_between(r[(i + n - 1) % n], r[i], r[(i + 1) % n]) {
            out.push(r[i]);
        }
    }
    if out.len() < 3 {
        r.to_vec()
    } else {
        out
    }
}

#[cfg(test)]
fn seg_dist2(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    Span::new(a, b).dist2(p)
}

/// A chord, ready for many squared-distance queries (no division each).
struct Span {
    a: [f64; 2],
    d: [f64; 2],
    /// 1 / |d|², or 0 for a chord of length 0.
    inv: f64,
}

impl Span {
    fn new(a: [f64; 2], b: [f64; 2]) -> Self {
        let d = [b[0] - a[0], b[1] - a[1]];
        let l2 = d[0] * d[0] + d[1] * d[1];
        Span {
            a,
            d,
            inv: if l2 > 0.0 { 1.0 / l2 } else { 0.0 },
        }
    }

    /// Squared distance from `p` to the chord.
    #[inline]
    fn dist2(&self, p: [f64; 2]) -> f64 {
        let (px, py) = (p[0] - self.a[0], p[1] - self.a[1]);
        let t = ((px * self.d[0] + py * self.d[1]) * self.inv).clamp(0.0, 1.0);
        let (ex, ey) = (t * self.d[0] - px, t * self.d[1] - py);
        ex * ex + ey * ey
    }
}

/// Whether a guard's material centre is left of chord a→b and its cut centre right of it.
fn guard_ok(a: [f64; 2], b: [f64; 2], g: &Guard) -> bool {
    let side = |p: [f64; 2]| (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
    side(g[0]) > 0.0 && side(g[1]) < 0.0
}

/// Douglas–Peucker on a closed ring: split at point 0 and the point farthest from it.
fn dp_ring(r: &[[f64; 2]], guards: Option<&[Guard]>, tol: f64) -> Vec<[f64; 2]> {
    if r.len() < 4 {
        return r.to_vec();
    }
    dp_kept(r, r, guards, tol)
        .into_iter()
        .map(|i| r[i])
        .collect()
}

/// Which points Douglas–Peucker keeps when the chords run between `at`'s points (one per point
/// of `r`) while every replaced point of `r` (and its guards) is measured against them: `at`
/// is `r` itself for plain simplification, or `r`'s points moved onto the fitted curves for
/// [`FitCurves::straight`]. Indices, in order.
fn dp_kept(r: &[[f64; 2]], at: &[[f64; 2]], guards: Option<&[Guard]>, tol: f64) -> Vec<usize> {
    let n = r.len();
    if n < 4 || at.len() != n {
        return (0..n).collect();
    }
    let guards = guards.filter(|g| g.len() == n);
    let far = (1..n)
        .max_by(|&i, &j| {
            let di = (at[i][0] - at[0][0]).powi(2) + (at[i][1] - at[0][1]).powi(2);
            let dj = (at[j][0] - at[0][0]).powi(2) + (at[j][1] - at[0][1]).powi(2);
            di.total_cmp(&dj)
        })
        .unwrap_or(n / 2);
    let mut keep = vec![false; n + 1];
    keep[0] = true;
    keep[far] = true;
    keep[n] = true;
    let at = |i: usize| at[i % n];
    let tol2 = tol * tol;
    let mut stack = vec![(0usize, far), (far, n)];
    while let Some((a, b)) = stack.pop() {
        if b <= a + 1 {
            continue;
        }
        let (pa, pb) = (at(a), at(b));
        let mut best = (0.0, a);
        // b <= n, so every i here is below n and indexes the ring directly.
        let span = Span::new(pa, pb);
        for (i, &p) in r[a + 1..b].iter().enumerate() {
            let d = span.dist2(p);
            if d > best.0 {
                best = (d, a + 1 + i);
            }
        }
        if best.0 <= tol2 {
            // Within tolerance: the guards are only read now (a split needs no guard test).
            let bad_guard = guards.and_then(|g| (a + 1..b).find(|&i| !guard_ok(pa, pb, &g[i])));
            if let Some(i) = bad_guard {
                // A pixel centre would change sides: split at the worst point.
                best.1 = if best.1 > a { best.1 } else { i };
                best.0 = f64::INFINITY;
            }
        }
        if best.0 > tol2 {
            keep[best.1] = true;
            stack.push((a, best.1));
            stack.push((best.1, b));
        }
    }
    (0..n).filter(|&i| keep[i]).collect()
}

fn c(p: [f64; 2]) -> Coord<f64> {
    Coord { x: p[0], y: p[1] }
}

/// Whether closed segments ab and cd share any point (robust orientation tests).
pub(crate) fn segments_touch(a: [f64; 2], b: [f64; 2], cc: [f64; 2], d: [f64; 2]) -> bool {
    let o1 = RobustKernel::orient2d(c(a), c(b), c(cc));
    let o2 = RobustKernel::orient2d(c(a), c(b), c(d));
    let o3 = RobustKernel::orient2d(c(cc), c(d), c(a));
    let o4 = RobustKernel::orient2d(c(cc), c(d), c(b));
    let on = |p: [f64; 2], q: [f64; 2], r: [f64; 2]| {
        r[0] >= p[0].min(q[0])
            && r[0] <= p[0].max(q[0])
            && r[1] >= p[1].min(q[1])
            && r[1] <= p[1].max(q[1])
    };
    use Orientation::Collinear as C;
    if o1 != o2 && o3 != o4 && o1 != C && o2 != C && o3 != C && o4 != C {
        return true;
    }
    (o1 == C && on(a, b, cc))
        || (o2 == C && on(a, b, d))
        || (o3 == C && on(cc, d, a))
        || (o4 == C && on(cc, d, b))
}

/// Rings that cross or touch themselves or another ring.
fn conflicts(rings: &[Vec<[f64; 2]>], cell: f64) -> Vec<usize> {
    // (cell key, ring, segment) for every grid cell a segment's bounding box covers.
    let entries: Vec<(u64, u32, u32)> = rings
        .par_iter()
        .enumerate()
        .flat_map_iter(|(ri, r)| {
            let n = r.len();
            (0..n).flat_map(move |i| {
                let (a, b) = (r[i], r[(i + 1) % n]);
                let x0 = (a[0].min(b[0]) / cell).floor() as i64;
                let x1 = (a[0].max(b[0]) / cell).floor() as i64;
                let y0 = (a[1].min(b[1]) / cell).floor() as i64;
                let y1 = (a[1].max(b[1]) / cell).floor() as i64;
                (y0..=y1).flat_map(move |y| {
                    (x0..=x1).map(move |x| {
                        let key = (((y + (1 << 30)) as u64) << 32) | (x + (1 << 30)) as u64;
                        (key, ri as u32, i as u32)
                    })
                })
            })
        })
        .collect();
    let Cells { slots, runs } = by_cell(entries);
    let bad_rings: Vec<u32> = runs
        .par_iter()
        .flat_map_iter(|&(s, e)| {
            let mut bad = Vec::new();
            let cell = &slots[s..e];
            for (k, &(ra, ia)) in cell.iter().enumerate() {
                for &(rb, ib) in &cell[k + 1..] {
                    if let Some(pair) = conflict(rings, (ra, ia), (rb, ib)) {
                        bad.extend_from_slice(&pair);
                    }
                }
            }
            bad
        })
        .collect();
    let mut bad = vec![false; rings.len()];
    for r in bad_rings {
        bad[r as usize] = true;
    }
    (0..rings.len()).filter(|&i| bad[i]).collect()
}

/// Conflict-grid entries grouped by cell: (ring, segment) per entry, cell by cell, and the
/// ranges of the cells holding more than one.
struct Cells {
    slots: Vec<(u32, u32)>,
    runs: Vec<(usize, usize)>,
}

/// Group (cell key, ring, segment) entries by cell.
fn by_cell(mut entries: Vec<(u64, u32, u32)>) -> Cells {
    // A counting sort over the cells the entries span (linear; a comparison sort of the entries
    // was a third of the conflict search), or a sort when the cells would be many more than the
    // entries.
    let (mut lo, mut hi) = ([u64::MAX; 2], [0u64; 2]);
    for &(key, _, _) in &entries {
        let (x, y) = (key & 0xffff_ffff, key >> 32);
        lo = [lo[0].min(x), lo[1].min(y)];
        hi = [hi[0].max(x), hi[1].max(y)];
    }
    let cols = hi[0].saturating_sub(lo[0]) + 1;
    let cells = cols.saturating_mul(hi[1].saturating_sub(lo[1]) + 1);
    let (slots, runs) = if !entries.is_empty() && cells <= 4 * entries.len() as u64 + (1 << 16) {
        let cell = |key: u64| (((key >> 32) - lo[1]) * cols + (key & 0xffff_ffff) - lo[0]) as usize;
        let mut start = vec![0u32; cells as usize + 1];
        for &(key, _, _) in &entries {
            start[cell(key) + 1] += 1;
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let mut fill = start.clone();
        let mut slots = vec![(0u32, 0u32); entries.len()];
        for &(key, ring, seg) in &entries {
            let c = cell(key);
            slots[fill[c] as usize] = (ring, seg);
            fill[c] += 1;
        }
        let runs = start
            .windows(2)
            .filter(|w| w[1] - w[0] > 1)
            .map(|w| (w[0] as usize, w[1] as usize))
            .collect();
        (slots, runs)
    } else {
        entries.par_sort_unstable();
        let mut runs = Vec::new();
        let mut s = 0;
        while s < entries.len() {
            let mut e = s + 1;
            while e < entries.len() && entries[e].0 == entries[s].0 {
                e += 1;
            }
            if e - s > 1 {
                runs.push((s, e));
            }
            s = e;
        }
        (entries.iter().map(|&(_, r, i)| (r, i)).collect(), runs)
    };
    Cells { slots, runs }
}

/// Whether segment `ia` of ring `ra` and segment `ib` of ring `rb` conflict (cross, touch, or
/// fold back on each other), and which rings are to blame.
fn conflict(
    rings: &[Vec<[f64; 2]>],
    (ra, ia): (u32, u32),
    (rb, ib): (u32, u32),
) -> Option<[u32; 2]> {
    let (ra_, rb_, ia, ib) = (ra as usize, rb as usize, ia as usize, ib as usize);
    let r1 = &rings[ra_];
    let r2 = &rings[rb_];
    let (a, b) = (r1[ia], r1[(ia + 1) % r1.len()]);
    let (p, q) = (r2[ib], r2[(ib + 1) % r2.len()]);
    if ra == rb {
        let n = r1.len();
        if ia == ib {
            return None;
        }
        let adjacent = (ia + 1) % n == ib || (ib + 1) % n == ia;
        if adjacent {
            // Neighbouring segments share one end; they conflict only if they fold back.
            let (shared, x, y) = if (ia + 1) % n == ib {
                (b, a, q)
            } else {
                (a, b, p)
            };
            let o = RobustKernel::orient2d(c(x), c(shared), c(y));
            let back =
                (x[0] - shared[0]) * (y[0] - shared[0]) + (x[1] - shared[1]) * (y[1] - shared[1]);
            return (o == Orientation::Collinear && back > 0.0).then_some([ra, ra]);
        }
    }
    // Disjoint bounding boxes cannot touch: the cheap test first.
    if a[0].max(b[0]) < p[0].min(q[0])
        || p[0].max(q[0]) < a[0].min(b[0])
        || a[1].max(b[1]) < p[1].min(q[1])
        || p[1].max(q[1]) < a[1].min(b[1])
    {
        return None;
    }
    segments_touch(a, b, p, q).then_some([ra, rb])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::BitGrid;
    use crate::vector::trace;

    /// Largest distance from a point of `a` (densified) to the closed polygon `b`.
    fn one_way(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
        let (n, m) = (a.len(), b.len());
        let mut worst: f64 = 0.0;
        for i in 0..n {
            let (p, q) = (a[i], a[(i + 1) % n]);
            for s in 0..8 {
                let t = s as f64 / 8.0;
                let x = [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])];
                let d = (0..m)
                    .map(|j| seg_dist2(x, b[j], b[(j + 1) % m]))
                    .fold(f64::INFINITY, f64::min);
                worst = worst.max(d.sqrt());
            }
        }
        worst
    }

    /// Tilted ellipses and discs, as `make` traces them (sub-pixel crossings): smooth outlines
    /// with marching squares' staircase on them.
    fn blobs() -> Vec<trace::Ring> {
        let shapes = [
            (60.0, 55.0, 40.0, 25.0, 0.3),
            (170.0, 60.0, 30.0, 30.0, 0.0),
            (250.0, 140.0, 35.0, 18.0, 1.2),
            (90.0, 150.0, 22.0, 45.0, 2.0),
            (185.0, 160.0, 12.0, 12.0, 0.0),
        ];
        let bits = BitGrid::from_fn(300, 220, |x, y| {
            let (x, y) = (x as f64 + 0.5, y as f64 + 0.5);
            !shapes
                .iter()
                .any(|&(cx, cy, a, b, t): &(f64, f64, f64, f64, f64)| {
                    let (dx, dy) = (x - cx, y - cy);
                    let u = dx * t.cos() + dy * t.sin();
                    let v = -dx * t.sin() + dy * t.cos();
                    (u / a).powi(2) + (v / b).powi(2) <= 1.0
                })
        });
        trace::trace(&bits, true)
    }

    #[test]
    fn straight_outlines_spend_the_whole_tolerance_once() {
        let traced = blobs();
        let rings: Vec<Vec<[f64; 2]>> = traced.iter().map(|r| r.pts.clone()).collect();
        let guards: Vec<Vec<Guard>> = traced.iter().map(|r| r.guards.clone()).collect();
        for tol in [0.5, 1.0] {
            let run = |curves: Option<FitCurves>| {
                let mut r = rings.clone();
                let st = simplify_and_fit(&mut r, Some(&guards), tol, curves).0;
                (r, st)
            };
            let (dp, dp_st) = run(None);
            let (fine, _) = run(Some(FitCurves {
                flatten: tol / 5.0,
                clear: tol / 50.0,
                straight: false,
            }));
            let (straight, st) = run(Some(FitCurves {
                flatten: tol / 5.0,
                clear: tol / 50.0,
                straight: true,
            }));
            let count = |r: &[Vec<[f64; 2]>]| r.iter().map(Vec::len).sum::<usize>();
            let (n_dp, n_fine, n_straight) = (count(&dp), count(&fine), count(&straight));
            // The straight outlines have fewer corners than simplification alone leaves (a
            // ring keeps simplification's polygon where that has fewer: 2 of the 5 at 1 px),
            // and about half the fine flattening the arcs are found in again, which was the
            // straight output before (346 points at 1 px, against 177 simplified, 167 now).
            assert!(
                n_straight * 100 <= n_dp * 97 && n_straight * 3 < n_fine * 2,
                "tol {tol}: straight {n_straight}, simplified {n_dp}, flattened {n_fine}"
            );
            assert!(st.curved_rings >= 3, "{st:?} vs {dp_st:?}");
            for (k, (s, t)) in straight.iter().zip(&rings).enumerate() {
                // Within the tolerance of the traced ring both ways, all of it (not the fit's
                // error plus a flattening's).
                let (st_, ts) = (one_way(s, t), one_way(t, s));
                assert!(
                    st_ <= tol + 1e-9 && ts <= tol + 1e-9,
                    "tol {tol}, ring {k}: {st_} / {ts}"
                );
                // Every pixel centre beside the traced ring stays on its side: inside the
                // straight ring exactly when it is inside the traced one.
                for g in guards[k].iter().flatten() {
                    assert_eq!(
                        stencil_geom::ring::point_in_ring(*g, s),
                        stencil_geom::ring::point_in_ring(*g, t),
                        "tol {tol}, ring {k}: {g:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_staircase_becomes_a_line_within_tolerance() {
        // A ring with a staircase side.
        let mut r = vec![[0.0, 0.0]];
        for i in 0..20 {
            r.push([i as f64 + 1.0, i as f64]);
            r.push([i as f64 + 1.0, i as f64 + 1.0]);
        }
        r.push([0.0, 20.0]);
        let mut rings = vec![r.clone()];
        let s = simplify_rings(&mut rings, None, 1.0);
        assert!(rings[0].len() < 8, "{:?}", rings[0]);
        for p in &r {
            let n = rings[0].len();
            let d = (0..n)
                .map(|i| seg_dist2(*p, rings[0][i], rings[0][(i + 1) % n]))
                .fold(f64::MAX, f64::min);
            assert!(d <= 1.0 + 1e-9);
        }
        assert_eq!(s.fallbacks, 0);
    }

    #[test]
    fn rings_that_would_cross_keep_their_detail() {
        // Dropping a's notch vertex (10, 0) (0.9 from the chord, under tolerance 1.0) would put
        // a's edge at y = 0.9 across b's tip at (10, 0.5).
        let a = vec![
            [0.0, -10.0],
            [20.0, -10.0],
            [20.0, 0.9],
            [10.0, 0.0],
            [0.0, 0.9],
        ];
        let b = vec![
            [0.0, 2.0],
            [10.0, 0.5],
            [20.0, 2.0],
            [20.0, 12.0],
            [0.0, 12.0],
        ];
        assert!(conflicts(&[a.clone(), b.clone()], 4.0).is_empty());
        let mut rings = vec![a.clone(), b.clone()];
        let s = simplify_rings(&mut rings, None, 1.0);
        assert!(conflicts(&rings, 4.0).is_empty());
        assert_eq!(s.fallbacks, 1, "{s:?}");
        assert_eq!(rings[0], a);
        // The same with a ring far away (cells too many to count: the entries are sorted).
        let far = vec![[1e6, 1e6], [1e6 + 1.0, 1e6], [1e6, 1e6 + 1.0]];
        let mut rings = vec![a.clone(), b.clone(), far];
        let s = simplify_rings(&mut rings, None, 1.0);
        assert_eq!(s.fallbacks, 1, "{s:?}");
        assert_eq!(rings[0], a);
        // Without the notch, a crosses b: found either way.
        let cut = vec![[0.0, -10.0], [20.0, -10.0], [20.0, 0.9], [0.0, 0.9]];
        assert_eq!(conflicts(&[cut.clone(), b.clone()], 4.0), vec![0, 1]);
        assert_eq!(conflicts(&[cut, b, rings[2].clone()], 4.0), vec![0, 1]);
    }

    #[test]
    fn touching_segments_are_detected() {
        assert!(segments_touch(
            [0.0, 0.0],
            [2.0, 0.0],
            [1.0, 0.0],
            [1.0, 5.0]
        ));
        assert!(!segments_touch(
            [0.0, 0.0],
            [2.0, 0.0],
            [1.0, 0.1],
            [1.0, 5.0]
        ));
        assert!(segments_touch(
            [0.0, 0.0],
            [2.0, 2.0],
            [0.0, 2.0],
            [2.0, 0.0]
        ));
    }
}
