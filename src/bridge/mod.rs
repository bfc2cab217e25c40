//! Stages 3–5: bridge strips, their cost, the spanning tree over island groups, growing bridges.
//!
//! [`connect`] runs the paper's method (Bronson, Rheingans & Olano, NPAR 2008; see paper.md):
//! 1. [`candidates`]: every island border pixel, chained along the island's contours;
//! 2. [`strips`]: from each, a walk through the cut along the grayscale gradient (the smoothed
//!    two-tone's where the gray is flat) to material of another node;
//! 3. [`cost`]: `C = w0·ΣI + w1·L^α + w2·κ + w3·σ²` over leftward, centred and rightward windows
//!    as wide as the bridge needs, cheapest kept;
//! 4. [`tree`]: Prim from the frame over island groups, edge cost = cheapest window between them,
//!    with a breadth-first search as the fallback when no walk leaves a group;
//! 5. [`grow`]: each chosen strip grown to its width (cheaper neighbour first), drawn as the
//!    polygon of its outer strips, halved plus a support bridge when its real error exceeds the
//!    estimate by more than the margin.
//!
//! Work is in proportion to the islands' total perimeter times the walk length, plus one O(pixels)
//! pass for the summed-area table the walks steer by.
//!
//! The public contract below is used by `pipeline.rs`, `report.rs` and the CLI: fields may be
//! added, names kept.

pub mod candidates;
pub mod cost;
pub mod grow;
pub mod strips;
pub mod tree;

use std::collections::{HashMap, HashSet};

use rayon::prelude::*;

use crate::islands::{self, IslandMap};
use crate::raster::{BitGrid, TwoTone};

/// User weights and limits of the bridge optimizer, all in pixels (the pipeline converts mm).
///
/// The terms are normalised so that each is about 1 for a typical strip of the image (see
/// [`cost`]): ΣI and L^α are divided by the median strip's length (to the power α for L^α), κ lies
/// in 0 (straight) .. 1 (round), σ² is the variance of strip costs over the window divided by
/// their squared mean. The defaults therefore weigh them about equally, with curvature doubled so
/// a bridge on a tight bend costs about as much as one typical strip more.
#[derive(Clone, Debug)]
pub struct BridgeConfig {
    /// w0, default 1: intensity error ΣI (a typical-length strip over black = 1).
    pub w_intensity: f64,
    /// w1, default 1: length penalty L^α (a typical strip = 1).
    pub w_length: f64,
    /// w2, default 2: border curvature κ at the bridge (0 straight .. 1 round).
    pub w_curvature: f64,
    /// w3, default 1: relative variance σ² of the strip costs across the bridge's window.
    pub w_variance: f64,
    /// Exponent of the length penalty, 1 < α < 2; default 1.5.
    pub alpha: f64,
    /// Walks longer than this are dropped; default 200 px.
    pub max_length_px: u32,
    /// Narrowest bridge, default 3 px: never thinner, even after halving.
    pub min_width_px: u32,
    /// Widest bridge, default 40 px.
    pub max_width_px: u32,
    /// Support trigger, default 0.5. The *estimate* of a bridge is the intensity error the tree
    /// expected: the mean ΣI of the strips in its chosen window times its width. The *real* error is
    /// Σ (1 − gray)² over every cut pixel the grown bridge actually turns into material (strips,
    /// polygon fill, thickening). If real > (1 + margin) × estimate, the bridge is halved (not
    /// below `min_width_px`) and a support bridge of the same halved width is added at the next
    /// cheapest place between the same two nodes.
    pub support_margin: f64,
}

impl Default for BridgeConfig {
    fn default() -> Self {
        BridgeConfig {
            w_intensity: 1.0,
            w_length: 1.0,
            w_curvature: 2.0,
            w_variance: 1.0,
            alpha: 1.5,
            max_length_px: 200,
            min_width_px: 3,
            max_width_px: 40,
            support_margin: 0.5,
        }
    }
}

/// The four terms of `C = w0·ΣI + w1·L^α + w2·κ + w3·σ²` (already weighted) and their sum.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct CostTerms {
    pub intensity: f64,
    pub length: f64,
    pub curvature: f64,
    pub variance: f64,
    pub total: f64,
}

/// One bridge: a run of neighbouring strips, drawn as material.
#[derive(Clone, Debug)]
pub struct Bridge {
    /// The two nodes it joins (0 = frame).
    pub nodes: [u32; 2],
    pub width_px: u32,
    pub length_px: f64,
    /// Cut pixels it turns into material.
    pub pixels: usize,
    pub cost: CostTerms,
    /// A second bridge added because the first one's real error exceeded its estimate.
    pub support: bool,
    /// Outline in pixel coordinates (x right, y down; pixel (x, y) covers [x, x+1) × [y, y+1), so
    /// points are pixel centres), from the end points of its outer strips: start of the first
    /// strip, its end, end of the last strip, its start.
    pub polygon: Vec<[f64; 2]>,
}

/// The bridged bit grid and its bridges.
#[derive(Clone, Debug)]
pub struct Bridged {
    pub bits: BitGrid,
    pub bridges: Vec<Bridge>,
}

#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    #[error("island {island} at pixel ({x}, {y}) could not be joined: {reason}")]
    Unreachable {
        island: u32,
        x: u32,
        y: u32,
        reason: String,
    },
    #[error("bridge setting {name} = {value} is invalid: {why}")]
    BadSetting {
        name: &'static str,
        value: String,
        why: &'static str,
    },
}

impl BridgeConfig {
    /// Check the settings a library caller (not only the CLI) may get wrong.
    pub fn validate(&self) -> Result<(), BridgeError> {
        let bad = |name, value: String, why| Err(BridgeError::BadSetting { name, value, why });
        for (name, w) in [
            ("w_intensity", self.w_intensity),
            ("w_length", self.w_length),
            ("w_curvature", self.w_curvature),
            ("w_variance", self.w_variance),
        ] {
            if !(w.is_finite() && w >= 0.0) {
                return bad(name, w.to_string(), "weights must be finite and >= 0");
            }
        }
        if !(self.alpha > 1.0 && self.alpha < 2.0) {
            return bad(
                "alpha",
                self.alpha.to_string(),
                "it must lie strictly between 1 and 2",
            );
        }
        if self.min_width_px < 1 || self.min_width_px > self.max_width_px {
            return bad(
                "min_width_px",
                self.min_width_px.to_string(),
                "it must be at least 1 and at most max_width_px",
            );
        }
        if self.max_length_px < 1 {
            return bad("max_length_px", "0".into(), "it must be at least 1 px");
        }
        if !(self.support_margin.is_finite() && self.support_margin >= 0.0) {
            return bad(
                "support_margin",
                self.support_margin.to_string(),
                "it must be a finite fraction >= 0",
            );
        }
        Ok(())
    }
}

/// Everything computed about the candidates before the tree: strips, their costs and scores.
struct Graph {
    cands: candidates::Candidates,
    strips: Vec<Option<strips::Strip>>,
    costs: Vec<Option<cost::StripCost>>,
    scores: Vec<Option<cost::Scored>>,
    norm: cost::Norm,
    /// Candidates by the (sorted) pair of nodes their strip joins.
    by_pair: HashMap<(u32, u32), Vec<usize>>,
}

fn pair(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// Area of the smaller of two nodes, the frame counting as infinite.
fn smaller_area(map: &IslandMap, a: u32, b: u32) -> usize {
    let area = |n: u32| {
        if n == islands::FRAME {
            usize::MAX
        } else {
            map.nodes[n as usize].area
        }
    };
    area(a).min(area(b))
}

/// Join every island to the frame with bridges.
pub fn connect(two: &TwoTone, map: &IslandMap, cfg: &BridgeConfig) -> Result<Bridged, BridgeError> {
    cfg.validate()?;
    if map.island_count() == 0 {
        return Ok(Bridged {
            bits: two.bits.clone(),
            bridges: Vec::new(),
        });
    }
    let fields = strips::Fields::new(two, map);
    let mut g = build_graph(&fields, map, cfg);

    // Stage 4: Prim from the frame, with the search as fallback for stranded groups.
    let mut prim = tree::Prim::new(map.nodes.len());
    let mut best: HashMap<(u32, u32), usize> = HashMap::new();
    for (&p, ids) in &g.by_pair {
        if let Some(&id) = ids
            .iter()
            .min_by(|&&a, &&b| total(&g, a).total_cmp(&total(&g, b)))
        {
            best.insert(p, id);
        }
    }
    let mut best: Vec<_> = best.into_iter().collect();
    best.sort_unstable();
    for ((a, b), id) in best {
        prim.add(tree::Edge {
            a,
            b,
            cost: total(&g, id),
            candidate: id,
        });
    }
    prim.grow();
    while let Some(group) = prim.stranded() {
        let found = strips::search(&fields, map, &group, cfg.max_length_px as usize);
        let Some(((sx, sy), strip)) = found else {
            let island = group.iter().position(|&m| m).unwrap_or(1) as u32;
            let (x, y) = map.nodes[island as usize]
                .border
                .first()
                .copied()
                .unwrap_or((0, 0));
            let others = group.iter().filter(|&&m| m).count() - 1;
            let with = if others > 0 {
                format!(" (nor from the {others} island(s) it can already reach)")
            } else {
                String::new()
            };
            return Err(BridgeError::Unreachable {
                island,
                x,
                y,
                reason: format!(
                    "no path through the cut of at most {} px from its border{with} reaches the frame \
                     or another island; raise --max-bridge-length-px",
                    cfg.max_length_px
                ),
            });
        };
        let Some(id) = g.cands.id_at(map, strip.from, sx, sy) else {
            return Err(BridgeError::Unreachable {
                island: strip.from,
                x: sx,
                y: sy,
                reason:
                    "the fallback search started from a pixel that is not on the island's border \
                         (internal error; please report it)"
                        .into(),
            });
        };
        let (a, b) = (strip.from, strip.to);
        set_strip(&mut g, map, cfg, id, strip);
        prim.add(tree::Edge {
            a,
            b,
            cost: total(&g, id),
            candidate: id,
        });
        prim.grow();
    }

    // Stage 5: grow and draw the chosen bridges in tree order.
    let mut bits = two.bits.clone();
    let mut bridges = Vec::new();
    for &(edge, _) in &prim.chosen {
        grow_bridge(two, &g, cfg, edge.candidate, &mut bits, &mut bridges);
    }
    Ok(Bridged { bits, bridges })
}

fn total(g: &Graph, id: usize) -> f64 {
    g.scores[id].map_or(f64::INFINITY, |s| s.terms.total)
}

/// Candidates, walks, normalisation and window scores: the parallel, perimeter-bound part.
fn build_graph(fields: &strips::Fields, map: &IslandMap, cfg: &BridgeConfig) -> Graph {
    let cands = candidates::collect(map);
    let max_len = cfg.max_length_px as usize;
    let strips: Vec<Option<strips::Strip>> = (0..cands.len())
        .into_par_iter()
        .with_min_len(256)
        .map(|id| strips::walk_candidate(fields, &cands, id, max_len).ok())
        .collect();
    let norm = cost::Norm::new(strips.iter().flatten().map(|s| s.len()).collect(), cfg);
    let costs: Vec<_> = strips
        .iter()
        .map(|s| s.as_ref().map(|s| norm.strip(s)))
        .collect();
    let mut g = Graph {
        cands,
        strips,
        costs,
        scores: Vec::new(),
        norm,
        by_pair: HashMap::new(),
    };
    g.scores = (0..g.cands.len())
        .into_par_iter()
        .with_min_len(256)
        .map(|id| score_one(&g, map, cfg, id))
        .collect();
    for (id, s) in g.strips.iter().enumerate() {
        if let (Some(s), Some(_)) = (s, g.scores[id]) {
            g.by_pair.entry(pair(s.from, s.to)).or_default().push(id);
        }
    }
    g
}

fn score_one(g: &Graph, map: &IslandMap, cfg: &BridgeConfig, id: usize) -> Option<cost::Scored> {
    let s = g.strips[id].as_ref()?;
    let width = grow::width_for(smaller_area(map, s.from, s.to), cfg);
    cost::score(&g.cands, &g.strips, &g.costs, id, width, cfg, &g.norm)
}

/// Put a strip found by the fallback search on its candidate and score it.
fn set_strip(g: &mut Graph, map: &IslandMap, cfg: &BridgeConfig, id: usize, strip: strips::Strip) {
    g.costs[id] = Some(g.norm.strip(&strip));
    let p = pair(strip.from, strip.to);
    g.strips[id] = Some(strip);
    g.scores[id] = score_one(g, map, cfg, id);
    g.by_pair.entry(p).or_default().push(id);
}

/// Grow the bridge at candidate `id`, halve it and add a support bridge if its real error
/// exceeds the estimate by more than the margin, and draw the result into `bits`.
fn grow_bridge(
    two: &TwoTone,
    g: &Graph,
    cfg: &BridgeConfig,
    id: usize,
    bits: &mut BitGrid,
    out: &mut Vec<Bridge>,
) {
    let (Some(strip), Some(score)) = (g.strips[id].as_ref(), g.scores[id]) else {
        return;
    };
    let nodes = {
        let (a, b) = pair(strip.from, strip.to);
        [a, b]
    };
    let make = |members: &[usize], bits: &BitGrid| {
        grow::plan(
            bits,
            &two.gray,
            &g.cands,
            &g.strips,
            members,
            cfg.min_width_px,
        )
    };
    let members = grow::grow(&g.cands, &g.strips, &g.costs, id, score.width, cfg);
    let mut plan = make(&members, bits);
    let half = (score.width / 2).max(cfg.min_width_px);
    let over = plan.real > (1.0 + cfg.support_margin) * score.estimate + 1e-9;
    let mut support_at = None;
    if over && half < score.width {
        let members = grow::grow(&g.cands, &g.strips, &g.costs, id, half, cfg);
        plan = make(&members, bits);
        support_at = next_cheapest(g, id, &members, &plan, half);
    }
    grow::commit(bits, &plan);
    out.push(to_bridge(nodes, score, plan, false));
    if let Some(sid) = support_at {
        let members = grow::grow(&g.cands, &g.strips, &g.costs, sid, half, cfg);
        let plan = make(&members, bits);
        grow::commit(bits, &plan);
        if let Some(s) = g.scores[sid] {
            out.push(to_bridge(nodes, s, plan, true));
        }
    }
}

fn to_bridge(nodes: [u32; 2], score: cost::Scored, plan: grow::Plan, support: bool) -> Bridge {
    Bridge {
        nodes,
        width_px: plan.width,
        length_px: plan.length,
        pixels: plan.pixels.len(),
        cost: score.terms,
        support,
        polygon: plan.polygon,
    }
}

/// The next cheapest place for a support bridge between the same two nodes as candidate `id`:
/// the cheapest scored candidate of that pair whose strip neither shares a pixel with the first
/// bridge nor starts within `width` candidates of it along the same contour.
fn next_cheapest(
    g: &Graph,
    id: usize,
    members: &[usize],
    first: &grow::Plan,
    width: u32,
) -> Option<usize> {
    let s = g.strips[id].as_ref()?;
    let taken: HashSet<u32> = first.pixels.iter().copied().collect();
    let chain = g.cands.chain_of[id];
    let c = &g.cands.chains[chain as usize];
    let near = |j: usize| {
        g.cands.chain_of[j] == chain
            && members.iter().any(|&m| {
                let d = g.cands.pos(j).abs_diff(g.cands.pos(m));
                let d = if c.closed { d.min(c.len - d) } else { d };
                d <= width as usize
            })
    };
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
