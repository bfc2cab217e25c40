//! Bridges that hold: after the tree has joined every island, give islands the bridges their
//! size, shape and weight need (issue 13). One bridge is a hinge: an island on it flaps under a
//! spray can. Bridges are added from the island's own scored candidates (see `Graph::by_pair`):
//!
//! 1. **Count**: at least `bridges_per_island`, and two for an island longer than the material's
//!    `two_bridges_above_mm`; each added one at least `min(90°, 360° / count)` round from the
//!    others as seen from the island's centroid, edge to edge (else the farthest round), cheapest
//!    first.
//! 2. **Ends**: a long thin island (length ≥ `THIN_RATIO` × breadth, longer than
//!    `two_bridges_above_mm`) is held within `END_REACH` of its length of each end (a beam's
//!    least-sag supports, the Airy and Bessel points, lie 0.21–0.22 in).
//! 3. **Sag**: while the sag estimate exceeds `max_sag_mm`, of the `TRIALS` cheapest candidates
//!    within half the span of the island's farthest point from its bridges, the one that shortens
//!    the span most; it stops within the limit, when no candidate is within 0.9 of the span of
//!    that point, or at `MAX_FOR_SAG` bridges.
//!
//! **The sag model.** The *span* L is the farthest any material lies from its nearest bridge,
//! measured inside the island (8-neighbour paths, diagonals √2 as 7/5, so a ring's span runs round
//! it). The island is a unit-width strip of span L under its weight q = ρ·g·t, stiffness E·t³/12:
//!
//! ```text
//! δ = 5·q·(2L)⁴ / (384·E·I) = 5·ρ·g·L⁴ / (2·E·t²)
//! ```
//!
//! the middle of a strip on two bridges 2L apart; a cantilever of L sags 3/5 of this, so it errs
//! safe for both. A strip, not a plate; the bridge's own bending, an island hanging from a sagging
//! island and the grow stage's later support bridges are not counted.

use std::cmp::Reverse;
use std::collections::HashMap;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::config::StrengthConfig;
use super::graph::Graph;
use crate::islands::{IslandMap, FRAME};

/// An island is long and thin when its length is at least this many times its breadth.
const THIN_RATIO: f64 = 4.0;

/// How near an end of a long thin island a bridge must touch it, as a fraction of its length.
const END_REACH: f64 = 0.2;

/// The sag rule adds bridges up to this many per island (more bridges than this hide the picture
/// more than they help: a large island's middle is out of reach of any bridge anyway).
const MAX_FOR_SAG: usize = 12;

/// How many candidates near the farthest point the sag rule tries, cheapest first.
const TRIALS: usize = 8;

/// Path lengths inside an island in fifths of a pixel: a side step 5, a diagonal one 7 (√2 ≈ 1.4).
const STEP: u32 = 5;
const DIAG: u32 = 7;

/// Why an island got bridges beyond the tree's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Why {
    /// `--bridges-per-island` asked for more.
    BridgesPerIsland,
    /// Longer than the material's `two_bridges_above_mm`: one bridge is a hinge.
    TwoBridges,
    /// Long and thin: held near both ends.
    Ends,
    /// Its sag exceeded the material's `max_sag_mm`.
    Sag,
}

/// One island's strength, as reported in `report.json`'s `strength.islands`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IslandStrength {
    /// Node id (as in the bridges' `nodes`).
    pub(crate) island: u32,
    /// Centroid of its material, mm from the picture's top left corner (x right, y down).
    pub(crate) centre_mm: [f64; 2],
    pub(crate) area_mm2: f64,
    /// Extent along its main axis and across it, mm.
    pub(crate) length_mm: f64,
    pub(crate) breadth_mm: f64,
    /// Bridges holding it in the estimate: the tree's bridge that brought it in (towards the
    /// frame) and those added here (a tree bridge to an island hanging from it is not counted).
    pub bridges: usize,
    /// Of those, added here for strength.
    pub(crate) extra: usize,
    /// Why they were added (empty when none were).
    pub(crate) why: Vec<Why>,
    /// The farthest its material lies from its nearest bridge, inside the island, mm.
    pub(crate) span_mm: f64,
    /// The sag estimate on all `bridges`, mm.
    pub(crate) sag_mm: f64,
    /// The sag estimate after each bridge: first on the tree's bridges alone, then after each one
    /// added here, in order (so the last is `sag_mm`).
    pub(crate) sag_steps_mm: Vec<f64>,
    /// The material's `max_sag_mm`.
    pub limit_mm: f64,
    /// Whether every rule is met: sag within the limit, the count and both ends.
    pub(crate) held: bool,
    /// When not held: which rule could not be met and what to relax.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// `report.json`'s `strength`: the model's numbers, per island, and totals.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StrengthReport {
    /// The sag model, in words.
    pub model: String,
    /// The longest span within the material's sag limit, mm.
    pub max_span_mm: f64,
    /// Islands longer than this get at least two bridges, mm.
    pub two_bridges_above_mm: f64,
    pub(crate) bridges_per_island: u32,
    /// Islands that got extra bridges for strength, and how many bridges that added in all.
    pub islands_with_extra: usize,
    /// Bridges added for strength.
    pub extra_bridges: usize,
    /// Islands some rule could not be met for (see their `note`).
    pub(crate) not_held: usize,
    /// Per island, in node order.
    pub islands: Vec<IslandStrength>,
}

impl StrengthReport {
    pub(crate) fn new(islands: Vec<IslandStrength>, cfg: &StrengthConfig) -> Self {
        StrengthReport {
            model: "sag = 5·ρ·g·L⁴/(2·E·t²): a strip simply supported on bridges 2L apart, L = \
                    span (farthest material from its nearest bridge, inside the island)"
                .into(),
            max_span_mm: cfg.max_span_mm(),
            two_bridges_above_mm: cfg.two_bridges_above_mm,
            bridges_per_island: cfg.per_island,
            islands_with_extra: islands.iter().filter(|i| i.extra > 0).count(),
            extra_bridges: islands.iter().map(|i| i.extra).sum(),
            not_held: islands.iter().filter(|i| !i.held).count(),
            islands,
        }
    }
}

/// An island's bounding box and pixel moments.
#[derive(Clone, Copy, Default)]
struct Moments {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
    n: f64,
    sx: f64,
    sy: f64,
    sxx: f64,
    syy: f64,
    sxy: f64,
}

fn moments(map: &IslandMap, n: u32) -> Moments {
    // Σ_{x=0}^{m-1} (x + ½) and Σ (x + ½)², pixel centres.
    let s1 = |m: f64| m * m / 2.0;
    let s2 = |m: f64| (m - 1.0) * m * (2.0 * m - 1.0) / 6.0 + (m - 1.0) * m / 2.0 + m / 4.0;
    let mut k = Moments {
        x0: u32::MAX,
        y0: u32::MAX,
        ..Default::default()
    };
    for (y, a, b) in map.island_runs(n as usize) {
        k.x0 = k.x0.min(a);
        k.x1 = k.x1.max(b);
        k.y0 = k.y0.min(y);
        k.y1 = k.y1.max(y);
        let (lo, hi) = (a as f64, b as f64 + 1.0);
        let (c, fy) = (hi - lo, y as f64 + 0.5);
        let sx = s1(hi) - s1(lo);
        k.n += c;
        k.sx += sx;
        k.sy += c * fy;
        k.sxx += s2(hi) - s2(lo);
        k.syy += c * fy * fy;
        k.sxy += sx * fy;
    }
    k
}

/// Most cells of the grid path lengths are measured on (see [`Local`]).
const MAX_CELLS: usize = 1 << 16;

/// One island over its bounding box, in cells of `k` × `k` pixels (a cell is the island's when
/// any of its pixels is), and path lengths over them. `k` is 1 unless the box has more than
/// [`MAX_CELLS`] pixels, then the smallest that brings it under. A margin of one empty cell all
/// round spares the path search its bound tests.
struct Local {
    x0: u32,
    y0: u32,
    k: u32,
    /// Row stride and rows, the margin included.
    w: usize,
    h: usize,
    inside: Vec<bool>,
}

impl Local {
    fn index(&self, x: u32, y: u32) -> Option<usize> {
        let (lx, ly) = (
            (x.checked_sub(self.x0)? / self.k) as usize,
            (y.checked_sub(self.y0)? / self.k) as usize,
        );
        let i = (ly + 1) * self.w + lx + 1;
        (lx + 2 < self.w && ly + 2 < self.h && self.inside[i]).then_some(i)
    }

    /// A path length in pixels.
    fn px(&self, d: u32) -> f64 {
        d as f64 / STEP as f64 * self.k as f64
    }

    /// A cell's centre in pixels.
    fn centre(&self, i: usize) -> (f64, f64) {
        let k = self.k as f64;
        (
            self.x0 as f64 + ((i % self.w) as f64 - 0.5) * k,
            self.y0 as f64 + ((i / self.w) as f64 - 0.5) * k,
        )
    }

    /// Shortest path lengths (fifths of a pixel) from `sources` into `dist`, lowering only what they
    /// shorten (so a source can be added to an earlier result). Dijkstra with a bucket queue: steps
    /// cost [`STEP`] or [`DIAG`], so `DIAG + 1` buckets round-robin hold every pending distance.
    fn relax(&self, dist: &mut [u32], sources: &[usize]) {
        const BUCKETS: usize = DIAG as usize + 1;
        // Cell indices as u32 (a grid has at most a few times `MAX_CELLS` cells): half the
        // bytes a queue entry moves.
        let mut buckets: [Vec<u32>; BUCKETS] = Default::default();
        let mut pending = 0usize;
        for &s in sources {
            dist[s] = 0;
            buckets[0].push(s as u32);
            pending += 1;
        }
        let w = self.w;
        let inside = &self.inside[..];
        let mut d = 0u32;
        while pending > 0 {
            let b = d as usize % BUCKETS;
            while let Some(i) = buckets[b].pop() {
                pending -= 1;
                let i = i as usize;
                // Lowered since it was queued: settled already at its smaller distance.
                if dist[i] != d {
                    continue;
                }
                // The four sides first (the margin keeps every neighbour in the grid), then the
                // corners, each only where both side cells are inside too.
                let side = [i + 1, i - 1, i + w, i - w];
                let ins = side.map(|j| inside[j]);
                let mut reach = |j: usize, step: u32| {
                    let nd = d + step;
                    if nd < dist[j] {
                        dist[j] = nd;
                        buckets[nd as usize % BUCKETS].push(j as u32);
                        pending += 1;
                    }
                };
                for k in 0..4 {
                    if ins[k] {
                        reach(side[k], STEP);
                    }
                }
                // (dx, dy) corners: (1, 1), (1, -1), (-1, 1), (-1, -1).
                for (a, b, j) in [
                    (0, 2, i + 1 + w),
                    (0, 3, i + 1 - w),
                    (1, 2, i - 1 + w),
                    (1, 3, i - 1 - w),
                ] {
                    if ins[a] && ins[b] && inside[j] {
                        reach(j, DIAG);
                    }
                }
            }
            d += 1;
        }
    }

    fn field(&self, sources: &[usize]) -> Vec<u32> {
        let mut d = vec![u32::MAX; self.inside.len()];
        self.relax(&mut d, sources);
        d
    }

    /// The farthest pixel and its distance (ignoring pixels no source reaches).
    fn farthest(&self, dist: &[u32]) -> (usize, u32) {
        dist.iter()
            .enumerate()
            .filter(|&(i, &d)| self.inside[i] && d != u32::MAX)
            .map(|(i, &d)| (i, d))
            .max_by_key(|&(i, d)| (d, Reverse(i)))
            .unwrap_or((0, 0))
    }
}

/// A candidate bridge of one island: where it touches the island, seen from the island's centre.
#[derive(Clone, Copy)]
struct Place {
    id: usize,
    at: usize,
    angle: f64,
    /// Half the angle its width covers seen from the centre, degrees.
    half: f64,
    /// Along the island's main axis, px from its centre.
    along: f64,
    cost: f64,
    width: u32,
}

/// Where candidate `id`'s bridge touches node `n`: at the middle of its scored window along the
/// border (the bridge grows over the window, which may lie to one side of the candidate), that
/// strip's start pixel when it starts on `n`, else the material pixel of `n` where it lands (or
/// one beside it).
fn touch(g: &Graph, map: &IslandMap, id: usize, n: u32) -> Option<(u32, u32)> {
    let s = g.strips[id].as_ref()?;
    let mid = g.scores[id].map_or(0, |sc| (sc.window.0 + sc.window.1) / 2);
    let (id, s) = g
        .cands
        .along(id, mid)
        .and_then(|m| Some((m, g.strips[m].as_ref()?)))
        .filter(|(_, m)| (m.from, m.to) == (s.from, s.to))
        .unwrap_or((id, s));
    if s.from == n {
        return Some(g.cands.pixels[id]);
    }
    if s.to != n {
        return None;
    }
    let (ex, ey) = s.end;
    [(0, 0), (1, 0), (-1, 0), (0, 1), (0, -1)]
        .into_iter()
        .map(|(dx, dy)| (ex + dx, ey + dy))
        .filter(|&(x, y)| x >= 0 && y >= 0 && (x as u32) < map.width && (y as u32) < map.height)
        .map(|(x, y)| (x as u32, y as u32))
        .find(|&(x, y)| map.label(x, y) == n)
}

/// Choose extra bridges (candidate ids, in island order, none twice) for the islands of `map`,
/// given the tree's bridges (candidate, and the island it brought into the tree); and each
/// island's strength as reported.
///
/// An island is held by the tree's bridge that brought it in (towards the frame) and by those
/// added here; a tree bridge to an island that hangs from it loads it rather than holds it, and
/// is not counted.
pub(super) fn reinforce(
    g: &Graph,
    map: &IslandMap,
    chosen: &[(usize, u32)],
    cfg: &StrengthConfig,
) -> (Vec<usize>, Vec<IslandStrength>) {
    let nodes = map.nodes.len();
    // The node pairs each island is in (both ends of each pair); their candidates are listed only
    // for an island that needs more bridges.
    let mut touching: Vec<Vec<(u32, u32)>> = vec![Vec::new(); nodes];
    for &(a, b) in g.by_pair.keys() {
        for n in [a, b] {
            if n != FRAME && (n as usize) < nodes {
                touching[n as usize].push((a, b));
            }
        }
    }
    let mut tree: HashMap<u32, Vec<usize>> = HashMap::new();
    for &(id, n) in chosen {
        if n != FRAME {
            tree.entry(n).or_default().push(id);
        }
    }
    let chosen_ids: std::collections::HashSet<usize> = chosen.iter().map(|c| c.0).collect();
    let results: Vec<(Vec<usize>, IslandStrength)> = (1..nodes as u32)
        .into_par_iter()
        .with_min_len(16)
        .map(|n| {
            let none = Vec::new();
            island(
                g,
                map,
                n,
                &moments(map, n),
                tree.get(&n).unwrap_or(&none),
                &touching[n as usize],
                &chosen_ids,
                cfg,
            )
        })
        .collect();
    let mut extras = Vec::new();
    let mut seen = std::collections::HashSet::new();
    let mut report = Vec::with_capacity(results.len());
    for (ids, s) in results {
        extras.extend(ids.into_iter().filter(|&id| seen.insert(id)));
        report.push(s);
    }
    (extras, report)
}

/// Smallest angle between two directions, degrees.
fn apart(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

/// One island: the rules in order (see the module notes).
#[allow(clippy::too_many_arguments)]
fn island(
    g: &Graph,
    map: &IslandMap,
    n: u32,
    m: &Moments,
    tree_ids: &[usize],
    touching: &[(u32, u32)],
    chosen_ids: &std::collections::HashSet<usize>,
    cfg: &StrengthConfig,
) -> (Vec<usize>, IslandStrength) {
    let mm = cfg.mm_per_px;
    let (f, local) = frame_and_grid(map, n, m);
    let option = |id: usize| place(g, map, n, id, &f, &local);
    let held_by: Vec<Place> = tree_ids.iter().filter_map(|&id| option(id)).collect();
    let sources: Vec<usize> = held_by.iter().map(|o| o.at).collect();
    let dist = local.field(&sources);
    let long = f.length_px * mm > cfg.two_bridges_above_mm;
    let need = (cfg.per_island as usize).max(if long { 2 } else { 1 });
    let centre = [f.cx * mm, f.cy * mm];
    let mut h = Holding {
        local: &local,
        cfg,
        options: Vec::new(),
        held_by,
        steps: Vec::new(),
        dist,
        extra: Vec::new(),
        why: Vec::new(),
        notes: Vec::new(),
        where_: format!("island {n} at ({:.1}, {:.1}) mm", centre[0], centre[1]),
    };
    h.steps.push(cfg.sag_mm(h.span_mm(&h.dist)));
    // The places to add bridges at, only for an island some rule asks more of (most islands are
    // small and held by their one tree bridge: listing and sorting their candidates was most of
    // this stage's time).
    let more = h.held_by.len() < need || long || h.steps[0] > cfg.max_sag_mm;
    if more {
        h.options = touching
            .iter()
            .filter_map(|p| g.by_pair.get(p))
            .flatten()
            .filter(|id| !chosen_ids.contains(id))
            .filter_map(|&id| option(id))
            .collect();
    }
    h.options
        .sort_by(|a, b| a.cost.total_cmp(&b.cost).then(a.id.cmp(&b.id)));

    // 1. Count.
    let reason = if cfg.per_island as usize >= need && cfg.per_island > 1 {
        Why::BridgesPerIsland
    } else {
        Why::TwoBridges
    };
    h.count(need, reason);
    // 2. Ends of a long thin island.
    if long && f.length_px >= THIN_RATIO * f.breadth_px {
        h.ends(&f);
    }
    // 3. Sag.
    let cap = MAX_FOR_SAG.max(need);
    h.sag(cap);

    h.report(n, m.n * mm * mm, &f, centre, cap)
}

/// Where an island lies and how it is shaped, in pixels: its centroid, its main axis (from the
/// pixel covariance) and its extents along and across that axis, which the count and ends rules
/// ask about.
struct Frame {
    cx: f64,
    cy: f64,
    /// Unit vector along the main axis.
    ux: f64,
    uy: f64,
    /// The least and greatest projection of a pixel centre on the axis, px from the centroid.
    lo: f64,
    hi: f64,
    /// Extents along and across the axis (pixel centres span one pixel less than the material).
    length_px: f64,
    breadth_px: f64,
}

/// Island `n`'s [`Frame`] and its cell grid ([`Local`]), from one pass over its runs: the grid
/// marks the cells the runs cover, and since projections are linear along a run its ends hold
/// the extremes.
fn frame_and_grid(map: &IslandMap, n: u32, m: &Moments) -> (Frame, Local) {
    let (cx, cy) = (m.sx / m.n.max(1.0), m.sy / m.n.max(1.0));
    // Main axis from the pixel covariance.
    let (vxx, vyy, vxy) = (
        m.sxx / m.n.max(1.0) - cx * cx,
        m.syy / m.n.max(1.0) - cy * cy,
        m.sxy / m.n.max(1.0) - cx * cy,
    );
    let theta = 0.5 * (2.0 * vxy).atan2(vxx - vyy);
    let (ux, uy) = (theta.cos(), theta.sin());
    let (bw, bh) = ((m.x1 - m.x0 + 1) as usize, (m.y1 - m.y0 + 1) as usize);
    let k = ((bw * bh) as f64 / MAX_CELLS as f64).sqrt().ceil().max(1.0) as usize;
    let (w, h) = (bw.div_ceil(k) + 2, bh.div_ceil(k) + 2);
    let mut inside = vec![false; w * h];
    let (mut lo, mut hi, mut blo, mut bhi) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (y, x0, x1) in map.island_runs(n as usize) {
        let (ly, ca, cb) = (
            (y - m.y0) as usize / k + 1,
            (x0 - m.x0) as usize / k + 1,
            (x1 - m.x0) as usize / k + 1,
        );
        inside[ly * w + ca..=ly * w + cb].fill(true);
        for x in [x0, x1] {
            let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
            let (a, b) = (dx * ux + dy * uy, -dx * uy + dy * ux);
            lo = lo.min(a);
            hi = hi.max(a);
            blo = blo.min(b);
            bhi = bhi.max(b);
        }
    }
    let local = Local {
        x0: m.x0,
        y0: m.y0,
        k: k as u32,
        w,
        h,
        inside,
    };
    let frame = Frame {
        cx,
        cy,
        ux,
        uy,
        lo,
        hi,
        length_px: hi - lo + 1.0,
        breadth_px: bhi - blo + 1.0,
    };
    (frame, local)
}

/// Candidate `id` as a place to hold island `n` by: where it touches the island (a cell of
/// `local`), seen from the island's centre and along its axis, with its cost and width. `None`
/// when it does not touch `n`, touches it outside the grid, or was not scored.
fn place(g: &Graph, map: &IslandMap, n: u32, id: usize, f: &Frame, local: &Local) -> Option<Place> {
    let (x, y) = touch(g, map, id, n)?;
    let at = local.index(x, y)?;
    let (dx, dy) = (x as f64 + 0.5 - f.cx, y as f64 + 0.5 - f.cy);
    let score = g.scores[id]?;
    Some(Place {
        id,
        at,
        angle: dy.atan2(dx).to_degrees(),
        half: (score.width as f64 / 2.0).atan2(dx.hypot(dy)).to_degrees(),
        along: dx * f.ux + dy * f.uy,
        cost: score.terms.total,
        width: score.width,
    })
}

/// One island while the rules add bridges to it: the bridges holding it, the candidates left
/// (cheapest first), the path lengths from its nearest bridge, and the record its report is made
/// of. Each rule is a method; [`Holding::take`] is the one way a bridge is added, so the span,
/// the sag steps and the reasons always agree with the bridges.
struct Holding<'a> {
    local: &'a Local,
    cfg: &'a StrengthConfig,
    /// Candidates not taken, cheapest first (a tie to the lower id).
    options: Vec<Place>,
    held_by: Vec<Place>,
    /// Path lengths inside the island from the nearest holding bridge (see [`Local::relax`]).
    dist: Vec<u32>,
    /// The sag estimate before any bridge was added, then after each.
    steps: Vec<f64>,
    /// Candidate ids added, in order.
    extra: Vec<usize>,
    why: Vec<Why>,
    notes: Vec<String>,
    /// "island N at (x, y) mm", how the notes name the island.
    where_: String,
}

impl Holding<'_> {
    /// The island's report once the rules are done, and the candidates they added. Island `n`
    /// covers `area_mm2` around `centre` (mm); `cap` is the most bridges the sag rule adds, named
    /// in the note when the island still sags with that many.
    fn report(
        mut self,
        n: u32,
        area_mm2: f64,
        f: &Frame,
        centre: [f64; 2],
        cap: usize,
    ) -> (Vec<usize>, IslandStrength) {
        let (limit, mm) = (self.cfg.max_sag_mm, self.cfg.mm_per_px);
        let sag = *self.steps.last().unwrap_or(&0.0);
        if sag > limit && self.held_by.len() >= cap && self.notes.is_empty() {
            self.notes.push(format!(
                "{} sags {sag:.2} mm (limit {limit} mm) on {cap} bridges, the most the sag rule \
                 adds; use a stiffer or thicker material (or raise max_sag_mm in the profile)",
                self.where_
            ));
        }
        let held = self.notes.is_empty() && sag <= limit;
        let report = IslandStrength {
            island: n,
            centre_mm: centre,
            area_mm2,
            length_mm: f.length_px * mm,
            breadth_mm: f.breadth_px * mm,
            bridges: self.held_by.len(),
            extra: self.extra.len(),
            span_mm: self.span_mm(&self.dist),
            why: self.why,
            sag_mm: sag,
            sag_steps_mm: self.steps,
            limit_mm: limit,
            held,
            note: (!self.notes.is_empty()).then(|| self.notes.join("; ")),
        };
        (self.extra, report)
    }

    /// The island's span in millimetres for path lengths `dist`.
    fn span_mm(&self, dist: &[u32]) -> f64 {
        self.local.px(self.local.farthest(dist).1) * self.cfg.mm_per_px
    }

    /// Take option `k` for `reason`: it holds the island from now on.
    fn take(&mut self, k: usize, reason: Why) {
        let o = self.options.remove(k);
        self.local.relax(&mut self.dist, &[o.at]);
        self.held_by.push(o);
        self.extra.push(o.id);
        if !self.why.contains(&reason) {
            self.why.push(reason);
        }
        let sag = self.cfg.sag_mm(self.span_mm(&self.dist));
        self.steps.push(sag);
    }

    /// Whether option `o` is apart from the bridges holding the island: it lies more than its own
    /// width from the nearest of them (inside the island).
    fn clear(&self, o: &Place) -> bool {
        self.local.px(self.dist[o.at]) > o.width as f64
    }

    /// Rule 1: add bridges until `need` hold the island, each at least `min(90°, 360° / need)`
    /// round from the others edge to edge, the cheapest such; else the one farthest round. Notes
    /// when the island has no room for more.
    fn count(&mut self, need: usize, reason: Why) {
        let gap = 90f64.min(360.0 / need as f64);
        while self.held_by.len() < need {
            let round = |o: &Place| {
                self.held_by
                    .iter()
                    .map(|h| apart(o.angle, h.angle) - o.half - h.half)
                    .fold(180.0, f64::min)
            };
            // Cheapest at least `gap` round (options are sorted by cost), else the farthest round.
            let pick = self
                .options
                .iter()
                .position(|o| self.clear(o) && round(o) >= gap - 1e-9)
                .or_else(|| {
                    self.options
                        .iter()
                        .enumerate()
                        .filter(|(_, o)| self.clear(o))
                        .max_by(|a, b| round(a.1).total_cmp(&round(b.1)).then(b.0.cmp(&a.0)))
                        .map(|(k, _)| k)
                });
            let Some(k) = pick else {
                self.notes.push(format!(
                    "{} has room for {} bridge(s), not {need}: lower --bridges-per-island or \
                     widen the cut around it",
                    self.where_,
                    self.held_by.len()
                ));
                break;
            };
            self.take(k, reason);
        }
    }

    /// Rule 2, for a long thin island: a bridge within [`END_REACH`] of its length of each end,
    /// the cheapest clear one there; a note for an end none fits near.
    fn ends(&mut self, f: &Frame) {
        let quarter = END_REACH * f.length_px;
        for end in [-1.0f64, 1.0] {
            let near_end = |o: &Place| {
                if end < 0.0 {
                    o.along <= f.lo + quarter
                } else {
                    o.along >= f.hi - quarter
                }
            };
            if self.held_by.iter().any(near_end) {
                continue;
            }
            match self
                .options
                .iter()
                .position(|o| near_end(o) && self.clear(o))
            {
                Some(k) => self.take(k, Why::Ends),
                None => self.notes.push(format!(
                    "{} is long and thin but no bridge fits near one of its ends: widen \
                     the cut beside that end",
                    self.where_
                )),
            }
        }
    }

    /// Rule 3: while the island sags more than the material allows and fewer than `cap` bridges
    /// hold it, a bridge near its farthest point; a note when that point is out of reach of any.
    fn sag(&mut self, cap: usize) {
        let limit = self.cfg.max_sag_mm;
        let mm = self.cfg.mm_per_px;
        let local = self.local;
        while *self.steps.last().unwrap_or(&0.0) > limit && self.held_by.len() < cap {
            let (far, span) = local.farthest(&self.dist);
            let from_far = local.field(&[far]);
            let nearest = self
                .options
                .iter()
                .enumerate()
                .min_by_key(|(k, o)| (from_far[o.at], *k))
                .map(|(k, o)| (k, from_far[o.at]));
            let Some((k_near, _)) = nearest.filter(|&(_, d)| (d as f64) < 0.9 * span as f64) else {
                self.notes.push(format!(
                    "{} sags {:.2} mm (limit {limit} mm): its farthest material, at ({:.1}, \
                     {:.1}) mm, is out of reach of any bridge; use a stiffer or thicker material \
                     (or raise max_sag_mm in the profile)",
                    self.where_,
                    self.steps.last().unwrap_or(&0.0),
                    local.centre(far).0 * mm,
                    local.centre(far).1 * mm,
                ));
                break;
            };
            // Of the cheapest few within half the span of the farthest point, the one that
            // shortens the span most (a tie to the cheaper); the nearest one if none is that near.
            let mut trial = self.dist.clone();
            let k = self
                .options
                .iter()
                .enumerate()
                .filter(|(_, o)| 2 * from_far[o.at] <= span)
                .take(TRIALS)
                .map(|(k, o)| {
                    trial.copy_from_slice(&self.dist);
                    local.relax(&mut trial, &[o.at]);
                    (local.farthest(&trial).1, k)
                })
                .min()
                .map_or(k_near, |(_, k)| k);
            self.take(k, Why::Sag);
        }
    }
}

#[cfg(test)]
mod tests;
