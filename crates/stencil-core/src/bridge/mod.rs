//! Stages 3–5: bridge strips, their cost, the spanning tree over island groups, growing bridges.
//!
//! [`connect`] runs the method of Bronson, Rheingans & Olano, "Semi-Automatic Stencil Creation
//! through Error Minimization" (NPAR 2008):
//! 1. `candidates`: every island border pixel, chained along the island's contours;
//! 2. `strips`: from each, a walk through the cut along the gray gradient to material of another
//!    node (`reach` stops walks that can no longer arrive);
//! 3. `cost`: `C = w0·ΣI + w1·L^α + w2·κ + w3·σ²` over windows as wide as the bridge needs;
//! 4. `tree`: Prim from the frame over island groups, each pair of nodes priced by its best
//!    candidates' bridges as drawn (`measured`); a group no walk leaves is joined by the
//!    cheapest path through the cut of any length (`search`), so the length limit is a preference;
//!    then `strength`: more bridges, spread apart, for islands whose size or sag asks for them;
//! 5. `grow`: each chosen strip grown to its width; `outline`: drawn (`draw`) as the polygon of
//!    its outer strips or as a band (`band`), measured across (`across`); halved plus a support
//!    bridge when its real error exceeds the estimate by more than the margin.
//!
//! Work is in proportion to the islands' perimeter times the walk length; the only O(pixels) steps
//! are copying the bit grid, the caller's labelling and the fallback search when a group needs it.

mod across;
mod band;
pub(crate) mod candidates;
mod config;
mod constraints;
pub(crate) mod cost;
mod draw;
pub(crate) mod drop;
mod error;
pub(crate) mod gaps;
mod graph;
pub(crate) mod grow;
mod light;
mod measured;
mod outline;
mod reach;
mod search;
pub(crate) mod strength;
pub(crate) mod strips;
pub(crate) mod tidy;
pub(crate) mod tree;

pub use config::{BridgeConfig, CostTerms, StrengthConfig, UserBridges, MAX_PER_ISLAND};
pub use constraints::Request;
pub use error::BridgeError;
use graph::{pair, smaller_area, Graph};
pub use light::Light;
pub use strength::{IslandStrength, StrengthReport, Why};

use std::borrow::Cow;
use std::collections::{HashMap, HashSet};

use rayon::prelude::*;

use crate::islands::IslandMap;
use crate::raster::{BitGrid, TwoTone};
use crate::timing::Timings;

/// How a bridge's strip was found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Via {
    /// A walk along the gradient, under the length limit (the paper's strips).
    #[default]
    Walk,
    /// A straight strip across the shortest gap between two pieces (`gaps`).
    Gap,
    /// The fallback search: no walk under the length limit left the island's group, so it is
    /// joined by the cheapest path through the cut, of any length.
    Search,
}

/// One bridge: a run of neighbouring strips, drawn as material.
#[derive(Clone, Debug)]
pub struct Bridge {
    /// The two nodes it joins (0 = frame).
    pub nodes: [u32; 2],
    /// Width at right angles to it at its narrowest, px (see `draw::Plan::width`).
    pub width_px: u32,
    /// Length along the strips, px.
    pub length_px: f64,
    /// Cut pixels it turns into material: when drawn, then, after [`Bridged::recount`], in the
    /// final stencil (the clean-up around the bridges included).
    pub(crate) pixels: usize,
    /// Its cost, term by term.
    pub cost: CostTerms,
    /// A second bridge added because the first one's real error exceeded its estimate.
    pub support: bool,
    /// Whether its strip is a walk, a shortest gap or the fallback search's path.
    pub via: Via,
    /// Added after the tree for strength (see `strength`), not to join the island.
    pub strength: bool,
    /// Outline in pixel coordinates (x right, y down; pixel (x, y) covers [x, x+1) × [y, y+1), so
    /// points are pixel centres), from the end points of its outer strips: start of the first
    /// strip, its end, end of the last strip, its start (a fan, or a straight searched path, is
    /// outlined as the band of its width instead; see `band::straight_band`).
    pub polygon: Vec<[f64; 2]>,
}

/// The bridged bit grid and its bridges.
#[derive(Clone, Debug)]
pub struct Bridged {
    /// The stencil: material true, bridges drawn in.
    pub bits: BitGrid,
    /// Every bridge, the tree's first.
    pub bridges: Vec<Bridge>,
    /// Per island, in node order: its bridges, span and sag estimate (see `strength`).
    pub strength: Vec<strength::IslandStrength>,
    /// What became of each `--bridge-at` place (see `constraints`).
    pub(crate) requests: Vec<constraints::Request>,
    /// Per bridge, the pixels it turned into material when drawn (disjoint: a pixel two bridges
    /// share is the first one's). [`Bridged::recount`] starts from them.
    drawn: Vec<Vec<u32>>,
    /// Whether the cut the candidates cross had light places for the bridges.
    pub light: Light,
}

/// No bridge owns the pixel (yet), in [`Bridged::recount`].
const UNOWNED: u32 = u32::MAX;

impl Bridged {
    /// Per bridge, the bounding box `[x0, y0, x1, y1)` in pixels of what it turned into
    /// material when drawn (bridges that turned nothing are left out): where the clean-up after
    /// bridging has anything to do.
    pub(crate) fn drawn_boxes(&self) -> Vec<[u32; 4]> {
        let w = self.bits.width.max(1);
        self.drawn
            .iter()
            .filter(|px| !px.is_empty())
            .map(|px| {
                px.iter().fold([u32::MAX, u32::MAX, 0, 0], |b, &i| {
                    let (x, y) = (i % w, i / w);
                    [b[0].min(x), b[1].min(y), b[2].max(x + 1), b[3].max(y + 1)]
                })
            })
            .collect()
    }

    /// Recount each bridge's [`Bridge::pixels`] on the stencil as it is now (`before`: the grid the
    /// bridges were drawn into), since the clean-up after bridging adds and removes material around
    /// them. A pixel added since `before` counts for the bridge that drew it if it still stands, else
    /// for the bridge it joins through such pixels (4-connected, fewest steps first); added material
    /// joined to no bridge is returned, so the counts and it add up to all the material added.
    /// O(added pixels) plus one pass over the picture.
    pub(crate) fn recount(&mut self, before: &BitGrid) -> usize {
        let n = self.bits.data.len();
        let added = |i: usize| self.bits.data[i] && !before.data[i];
        let mut owner = vec![UNOWNED; n];
        let mut queue = std::collections::VecDeque::new();
        for (k, drawn) in self.drawn.iter().enumerate() {
            for &p in drawn {
                if added(p as usize) && owner[p as usize] == UNOWNED {
                    owner[p as usize] = k as u32;
                    queue.push_back(p as usize);
                }
            }
        }
        let (w, h) = (self.bits.width as usize, self.bits.height as usize);
        while let Some(i) = queue.pop_front() {
            for j in crate::raster::edge_neighbours(i, w, h)
                .into_iter()
                .flatten()
            {
                if owner[j] == UNOWNED && added(j) {
                    owner[j] = owner[i];
                    queue.push_back(j);
                }
            }
        }
        for b in &mut self.bridges {
            b.pixels = 0;
        }
        let mut apart = 0;
        for i in (0..n).filter(|&i| added(i)) {
            match self.bridges.get_mut(owner[i] as usize) {
                Some(b) => b.pixels += 1,
                None => apart += 1,
            }
        }
        apart
    }
}

/// Join every island to the frame with bridges.
///
/// ```
/// use stencil_core::{bridge, islands, raster::{BitGrid, Gray, TwoTone}};
/// // A 60 px sheet with a ring of cut 10 px wide around a 20 px island.
/// let bits = BitGrid::from_fn(60, 60, |x, y| {
///     let (lo, hi) = (x.min(y), x.max(y));
///     lo < 10 || hi >= 50 || (lo >= 20 && hi < 40)
/// });
/// let two = TwoTone { gray: Gray::new(60, 60, 0.5).into(), bits };
/// let b = bridge::connect(&two, &islands::label(&two.bits), &Default::default()).unwrap();
/// let floating = |g: &BitGrid| islands::floating_count(g);
/// assert_eq!((floating(&two.bits), floating(&b.bits)), (1, 0));
/// ```
pub fn connect(two: &TwoTone, map: &IslandMap, cfg: &BridgeConfig) -> Result<Bridged, BridgeError> {
    connect_timed(two, map, cfg, &mut Timings::default())
}

/// [`connect`], adding the wall-clock time of each of its phases to `times` (for the benchmark
/// and diagnostics): `candidates` (the walks' fields and the contour chains), `gaps` (shortest-gap directions), `walks`,
/// `scores` (normalisation and windows), `tree` (Prim and fallback searches), `strength` (extra
/// bridges for strength and the user's places), `grow` (growing, support bridges, drawing).
pub fn connect_timed(
    two: &TwoTone,
    map: &IslandMap,
    cfg: &BridgeConfig,
    times: &mut Timings,
) -> Result<Bridged, BridgeError> {
    let walks = walk(two, map, cfg, times)?;
    connect_walked(two, map, cfg, &walks, times)
}

/// The candidates and their walks: what [`connect`] chooses the bridges from. No weight reads
/// them (the walks follow the picture, not the costs), so a caller that keeps them (the
/// studio) re-chooses the bridges for new weights, support margin or strength rules without
/// walking again; they depend on `two`, `map`, the length limit, the narrowest bridge, `gaps`
/// and the keep-out areas (see [`WalkKey`]).
#[derive(Clone, Debug, Default)]
pub struct Walks {
    cands: candidates::Candidates,
    walked: Vec<Option<strips::Strip>>,
    copies: Vec<bool>,
}

/// What the walks read of a [`BridgeConfig`] (not the weights, the support margin or the
/// strength rules): two configurations with the same key, on the same two-tone and islands,
/// give the same walks.
#[derive(Clone, Debug, PartialEq)]
pub struct WalkKey {
    max_length_px: u32,
    min_width_px: u32,
    max_width_px: u32,
    gaps: bool,
    user: UserBridges,
}

impl WalkKey {
    /// The key of `cfg`.
    pub fn of(cfg: &BridgeConfig) -> WalkKey {
        WalkKey {
            max_length_px: cfg.max_length_px,
            min_width_px: cfg.min_width_px,
            max_width_px: cfg.max_width_px,
            gaps: cfg.gaps,
            user: cfg.user.clone(),
        }
    }
}

/// The first half of [`connect_timed`]: candidates, shortest gaps and walks.
pub fn walk(
    two: &TwoTone,
    map: &IslandMap,
    cfg: &BridgeConfig,
    times: &mut Timings,
) -> Result<Walks, BridgeError> {
    cfg.validate()?;
    if map.island_count() == 0 {
        return Ok(Walks::default());
    }
    // The reach bound and the candidates read the map and nothing of each other: side by side.
    let (fields, mut cands) = times.time("candidates", || {
        rayon::join(
            || {
                strips::Fields::new(two, map)
                    .with_forbidden(cfg.user.keep_out.as_deref())
                    .with_reach(map)
            },
            || candidates::collect(map),
        )
    });
    let max_len = cfg.max_length_px as usize;
    // The shortest gaps and the walks read the same candidates and nothing of each other: they
    // run side by side, so the gaps' serial steps (their shores, the borrowing along chains)
    // overlap the walks' parallel ones. Each phase's time is its own, overlapping the other's.
    let ((dirs, gaps_ms), (mut walked, walks_ms)) = rayon::join(
        || {
            let t = std::time::Instant::now();
            let dirs = if cfg.gaps {
                gaps::directions(&two.bits, map, &cands, max_len)
            } else {
                Vec::new()
            };
            (dirs, t.elapsed().as_secs_f64() * 1e3)
        },
        || {
            let t = std::time::Instant::now();
            let walked = walk_all(&fields, &cands, cfg);
            (walked, t.elapsed().as_secs_f64() * 1e3)
        },
    );
    times.add("gaps", gaps_ms);
    times.add("walks", walks_ms);
    if cfg.gaps {
        cands.add_twins();
    }
    let (walked, copies) = times.time("walks", || {
        // Copies are kept a little farther along the contour than a narrow bridge grows: a wide
        // one beside a gap strip runs out of copies sooner and is thickened instead (keeping them
        // as far as the widest bridge grows, 4 × max_width, cost the bench 2 ms and the corpus
        // nothing).
        let keep = 2 * cfg.min_width_px.max(8) as usize;
        let (twins, copies) = gaps::walk_twins(&fields, &cands, &dirs, &walked, max_len, keep);
        walked.extend(twins);
        (walked, copies)
    });
    Ok(Walks {
        cands,
        walked,
        copies,
    })
}

/// The second half of [`connect_timed`]: from `walks` (made by [`walk`] for the same `two`,
/// `map` and [`Walks::key`]) to the bridges drawn. The walks are only read, so a caller that
/// keeps them for the next weights lends them rather than copying them.
pub(crate) fn connect_walked(
    two: &TwoTone,
    map: &IslandMap,
    cfg: &BridgeConfig,
    walks: &Walks,
    times: &mut Timings,
) -> Result<Bridged, BridgeError> {
    cfg.validate()?;
    if map.island_count() == 0 {
        return Ok(Bridged {
            bits: two.bits.clone(),
            bridges: Vec::new(),
            strength: Vec::new(),
            requests: Vec::new(),
            drawn: Vec::new(),
            light: Light::default(),
        });
    }
    let fields = strips::Fields::new(two, map).with_forbidden(cfg.user.keep_out.as_deref());
    let mut g = times.time("scores", || {
        build_graph(&walks.cands, &walks.walked, &walks.copies, map, cfg)
    });
    let prim = times.time("tree", || span(two, &mut g, &fields, map, cfg))?;
    // After the tree, so that the fallback search's paths count: where the bridges could go.
    let light = Light::survey(&two.gray, g.strips.iter().flatten());
    let g = &g;
    // The tree's bridges are planned while the strength rules choose the extra ones (both
    // read the graph only; planning one bridge reads nothing another's plan makes): the
    // strength rules' work per island is uneven, so the two together keep both cores busy where
    // each alone left one idle. The "strength" time includes that planning.
    let tree_jobs: Vec<(usize, bool)> = prim
        .chosen
        .iter()
        .map(|(e, _)| (e.candidate, false))
        .collect();
    let ((tree, extra, strength, requests), mut planned) = times.time("strength", || {
        rayon::join(
            || {
                // Bridges that hold: what each island's size, shape and weight need beyond the
                // tree's.
                let mut tree: Vec<(usize, u32)> =
                    prim.chosen.iter().map(|(e, n)| (e.candidate, *n)).collect();
                // The user's places: a bridge each, holding its island like the tree's.
                let mut requests = Vec::new();
                for (id, req) in constraints::requested(g, map, &cfg.user.at) {
                    if let Some(id) = id.filter(|id| !tree.iter().any(|t| t.0 == *id)) {
                        tree.push((id, req.island));
                    }
                    requests.push(req);
                }
                let (extra, strength) = strength::reinforce(g, map, &tree, &cfg.strength);
                (tree, extra, strength, requests)
            },
            || plan_jobs(two, g, cfg, &tree_jobs),
        )
    });
    let (bits, bridges, drawn) = times.time("grow", || {
        // The rest: the user's places (after the tree's), then the strength bridges.
        let rest: Vec<(usize, bool)> = tree[tree_jobs.len()..]
            .iter()
            .map(|&(id, _)| (id, false))
            .chain(extra.iter().map(|&id| (id, true)))
            .collect();
        planned.extend(plan_jobs(two, g, cfg, &rest));
        draw_planned(two, cfg, planned)
    });
    Ok(Bridged {
        bits,
        bridges,
        strength,
        requests,
        drawn,
        light,
    })
}

/// Stage 4 of the paper: a minimum spanning tree (Prim, from the frame) over every pair of nodes
/// some candidate joins, each priced by the cheapest of its few best candidates once drawn
/// (`measured`); an island group no walk under the length limit left is joined by the fallback
/// search's path, added to the graph as a candidate of its own.
fn span(
    two: &TwoTone,
    g: &mut Graph,
    fields: &strips::Fields,
    map: &IslandMap,
    cfg: &BridgeConfig,
) -> Result<tree::Prim, BridgeError> {
    let mut prim = tree::Prim::new(map.nodes.len());
    for (p, id, cost) in measured::cheapest_drawn(two, g, cfg, map.nodes.len()) {
        prim.add(tree::Edge {
            a: p.0,
            b: p.1,
            cost,
            candidate: id,
        });
    }
    prim.grow();
    let step = g.norm.step_cost(cfg);
    let mut scratch = search::SearchScratch::default();
    while let Some(group) = prim.stranded() {
        let found = search::search(fields, map, &group, &step, &mut scratch);
        let Some(((sx, sy), strip)) = found else {
            return Err(stranded(&group, map, cfg));
        };
        let ends = (strip.from, strip.to);
        let id = add_found_strip(g, map, cfg, (sx, sy), strip);
        let cost = measured::drawn_total(two, g, cfg, id);
        prim.add(tree::Edge {
            a: ends.0,
            b: ends.1,
            cost,
            candidate: id,
        });
        prim.grow();
    }
    Ok(prim)
}

/// Why an island `group` no search could leave is stranded: the user's keep-out areas (when
/// there are any; its position in mm), else a map that does not describe the bits.
fn stranded(group: &[bool], map: &IslandMap, cfg: &BridgeConfig) -> BridgeError {
    let island = group.iter().position(|&m| m).unwrap_or(1) as u32;
    let (x, y) = map.nodes[island as usize]
        .border
        .first()
        .copied()
        .unwrap_or((0, 0));
    if cfg.user.keep_out.is_some() {
        let mm = cfg.strength.mm_per_px;
        return BridgeError::KeptOut {
            island,
            x_mm: (x as f64 + 0.5) * mm,
            y_mm: (y as f64 + 0.5) * mm,
        };
    }
    BridgeError::Unreachable { island, x, y }
}

/// Stage 5, first half: grow and plan each chosen bridge (candidate id, and whether it is a
/// strength bridge) in parallel, against the input bits. Each plan depends on its candidate
/// alone, so the jobs may be planned in any grouping and concatenated in order.
fn plan_jobs(
    two: &TwoTone,
    g: &Graph,
    cfg: &BridgeConfig,
    jobs: &[(usize, bool)],
) -> Vec<Vec<(Bridge, Vec<u32>)>> {
    jobs.par_iter()
        .map(|&(id, strong)| {
            let mut out = plan_bridge(two, g, cfg, id);
            for (b, _) in &mut out {
                b.strength = strong;
            }
            out
        })
        .collect()
}

/// Stage 5, second half: draw the planned bridges in tree order, the strength bridges last (as
/// [`plan_jobs`] lists them); a pixel two bridges share counts for the first. Returns the
/// bridged bits, the bridges and the pixels each turned into material.
fn draw_planned(
    two: &TwoTone,
    cfg: &BridgeConfig,
    planned: Vec<Vec<(Bridge, Vec<u32>)>>,
) -> (BitGrid, Vec<Bridge>, Vec<Vec<u32>>) {
    let mut bits = two.bits.clone();
    let mut bridges = Vec::with_capacity(planned.len());
    let mut drawn = Vec::with_capacity(planned.len());
    for (mut bridge, mut pixels) in planned.into_iter().flatten() {
        // Strips never cross a forbidden pixel, but a fill or a thickening beside one may: those
        // pixels stay cut (the strips themselves still join the two nodes).
        if let Some(f) = &cfg.user.keep_out {
            pixels.retain(|&p| !f.data[p as usize]);
        }
        let turned = draw::commit(&mut bits, &pixels);
        bridge.pixels = turned.len();
        bridges.push(bridge);
        drawn.push(turned);
    }
    (bits, bridges, drawn)
}

fn total(g: &Graph, id: usize) -> f64 {
    g.scores[id].map_or(f64::INFINITY, |s| s.terms.total)
}

/// A walk from every candidate of the original chains (not their twins), in parallel.
fn walk_all(
    fields: &strips::Fields,
    cands: &candidates::Candidates,
    cfg: &BridgeConfig,
) -> Vec<Option<strips::Strip>> {
    let max_len = cfg.max_length_px as usize;
    (0..cands.originals())
        .into_par_iter()
        .with_min_len(256)
        .map_init(Vec::new, |scratch, id| {
            strips::walk_candidate_with(fields, cands, id, max_len, scratch).ok()
        })
        .collect()
}

/// Normalisation, strip costs and window scores, in parallel; candidates grouped by node pair.
fn build_graph<'w>(
    cands: &'w candidates::Candidates,
    strips: &'w [Option<strips::Strip>],
    copies: &[bool],
    map: &IslandMap,
    cfg: &BridgeConfig,
) -> Graph<'w> {
    // The scale of the terms is the walks' (the paper's strips): the shortest gaps are costed in
    // the same units, so they compete with walks on the walks' terms, and a picture's walks cost
    // what they cost without them.
    let walks = &strips[..cands.originals().min(strips.len())];
    let norm = cost::Norm::new(walks.iter().flatten().map(|s| s.len()).collect(), cfg);
    let costs: Vec<_> = strips
        .par_iter()
        .with_min_len(1024)
        .map(|s| s.as_ref().map(|s| norm.strip(s)))
        .collect();
    let walked = cands.len();
    let mut g = Graph {
        cands: Cow::Borrowed(cands),
        strips: Cow::Borrowed(strips),
        costs,
        scores: Vec::new(),
        norm,
        by_pair: HashMap::new(),
        walked,
    };
    g.scores = (0..g.cands.len())
        .into_par_iter()
        .with_min_len(256)
        .map_init(Vec::new, |scratch, id| {
            // A twin that copies its original's walk is no new choice (see `gaps::walk_twins`).
            let copy = id >= g.cands.twins.0 && copies.get(id - g.cands.twins.0) == Some(&true);
            (!copy)
                .then(|| score_one(&g, map, cfg, id, scratch))
                .flatten()
        })
        .collect();
    // Grouped by sorting (pair, id) rather than one hash update per candidate: tens of
    // thousands of candidates share about one pair per island. Ids stay ascending in each group.
    let mut keyed: Vec<((u32, u32), usize)> = g
        .strips
        .iter()
        .enumerate()
        .filter_map(|(id, s)| match (s, g.scores[id]) {
            (Some(s), Some(_)) => Some((pair(s.from, s.to), id)),
            _ => None,
        })
        .collect();
    keyed.par_sort_unstable();
    g.by_pair.reserve(keyed.len().min(map.nodes.len() * 2));
    for group in keyed.chunk_by(|a, b| a.0 == b.0) {
        g.by_pair
            .insert(group[0].0, group.iter().map(|&(_, id)| id).collect());
    }
    g
}

fn score_one(
    g: &Graph,
    map: &IslandMap,
    cfg: &BridgeConfig,
    id: usize,
    scratch: &mut Vec<f64>,
) -> Option<cost::Scored> {
    let s = g.strips[id].as_ref()?;
    let width = grow::width_for(smaller_area(map, s.from, s.to), cfg);
    cost::score_with(
        &g.cands, &g.strips, &g.costs, id, width, cfg, &g.norm, scratch,
    )
}

/// Add a strip found by the fallback search as a candidate of its own (a one-candidate chain at
/// its start pixel), so it never replaces a walked strip another edge may still need, and score
/// it. Such a bridge cannot grow along the border; [`outline::plan`] thickens it to the minimum width
/// instead, whatever its length.
fn add_found_strip(
    g: &mut Graph,
    map: &IslandMap,
    cfg: &BridgeConfig,
    start: (u32, u32),
    strip: strips::Strip,
) -> usize {
    let id = g.cands.to_mut().push_single(strip.from, start);
    let p = pair(strip.from, strip.to);
    g.costs.push(Some(g.norm.strip(&strip)));
    g.strips.to_mut().push(Some(strip));
    g.scores.push(None);
    g.scores[id] = score_one(g, map, cfg, id, &mut Vec::new());
    g.by_pair.entry(p).or_default().push(id);
    id
}

/// Grow the bridge at candidate `id` and plan its pixels; if its real error exceeds the estimate
/// by more than the margin, halve it and add a support bridge. Returns the bridges with the
/// pixels each would turn into material.
fn plan_bridge(two: &TwoTone, g: &Graph, cfg: &BridgeConfig, id: usize) -> Vec<(Bridge, Vec<u32>)> {
    let (Some(strip), Some(score)) = (g.strips[id].as_ref(), g.scores[id]) else {
        return Vec::new();
    };
    let nodes = pair(strip.from, strip.to).into();
    let make = |members: &[usize], want: u32| {
        outline::plan(
            &two.bits, &two.gray, &g.cands, &g.strips, members, cfg, want,
        )
    };
    let members = grow::grow(&g.cands, &g.strips, &g.costs, id, score.width, cfg);
    let mut plan = make(&members, score.width);
    let half = (score.width / 2).max(cfg.min_width_px);
    let over = plan.real > (1.0 + cfg.support_margin) * score.estimate + 1e-9;
    let mut support_at = None;
    if over && half < score.width {
        let members = grow::grow(&g.cands, &g.strips, &g.costs, id, half, cfg);
        plan = make(&members, half);
        support_at = next_cheapest(g, id, &members, &plan, half);
    }
    let via = |id: usize| {
        if id >= g.walked {
            Via::Search
        } else if g.cands.base(id) != id {
            Via::Gap
        } else {
            Via::Walk
        }
    };
    if via(id) == Via::Search {
        let band = band::straight_band(g.cands.pixels[id], strip, plan.width, two.bits.width);
        plan.polygon = band.unwrap_or(plan.polygon);
    }
    let mut out = vec![to_bridge(nodes, score, plan, false, via(id))];
    if let Some(sid) = support_at {
        let members = grow::grow(&g.cands, &g.strips, &g.costs, sid, half, cfg);
        if let Some(s) = g.scores[sid] {
            out.push(to_bridge(nodes, s, make(&members, half), true, via(sid)));
        }
    }
    out
}

fn to_bridge(
    nodes: [u32; 2],
    score: cost::Scored,
    plan: draw::Plan,
    support: bool,
    via: Via,
) -> (Bridge, Vec<u32>) {
    let bridge = Bridge {
        nodes,
        width_px: plan.width,
        length_px: plan.length,
        pixels: plan.pixels.len(),
        cost: score.terms,
        support,
        via,
        strength: false,
        polygon: plan.polygon,
    };
    (bridge, plan.pixels)
}

/// Whether a candidate starts within `width` candidates of `members` along the same contour as
/// `id` (twins count by their original's place).
fn near_members<'a>(
    g: &'a Graph,
    id: usize,
    members: &'a [usize],
    width: u32,
) -> impl Fn(usize) -> bool + 'a {
    let base = |j: usize| g.cands.base(j);
    let chain = g.cands.chain_of[base(id)];
    let c = &g.cands.chains[chain as usize];
    move |j: usize| {
        g.cands.chain_of[base(j)] == chain
            && members.iter().any(|&m| {
                let d = g.cands.pos(base(j)).abs_diff(g.cands.pos(base(m)));
                let d = if c.closed { d.min(c.len - d) } else { d };
                d <= width as usize
            })
    }
}

/// The next cheapest place for a support bridge between the same two nodes as candidate `id`:
/// the cheapest scored candidate of that pair whose strip neither shares a pixel with the first
/// bridge nor starts within `width` candidates of it along the same contour.
fn next_cheapest(
    g: &Graph,
    id: usize,
    members: &[usize],
    first: &draw::Plan,
    width: u32,
) -> Option<usize> {
    let s = g.strips[id].as_ref()?;
    let taken: HashSet<u32> = first.pixels.iter().copied().collect();
    let near = near_members(g, id, members, width);
    g.by_pair
        .get(&pair(s.from, s.to))?
        .iter()
        .copied()
        .filter(|&j| j != id && !near(j))
        .filter(|&j| {
            g.strips[j].as_ref().is_some_and(|sj| {
                pair(sj.from, sj.to) == pair(s.from, s.to)
                    && !sj.pixels.iter().any(|p| taken.contains(p))
            })
        })
        .min_by(|&a, &b| total(g, a).total_cmp(&total(g, b)))
}

#[cfg(test)]
mod tests;
