//! The tree's edges priced by the error their bridges really make.
//!
//! A candidate's score estimates its bridge's intensity error from its window of one-pixel strips
//! (mean ΣI × width). The bridge drawn from it is another shape: the strips grown to the width,
//! the polygon of the outer strips filled, thickened where too few grew, pockets sealed. Where
//! the walks fan out or the edge is ragged the two differ widely, and a tree chosen on the
//! estimate picks bridges that cost more than their neighbours once drawn. So each pair of nodes
//! is priced by drawing (planning, not committing) its few cheapest candidates, spread along the
//! border, and the intensity term of each is replaced by the real error in the same units: the
//! edge is the cheapest of those, and the spanning tree minimises what the bridges cost drawn
//! (pairs far dearer by score than their islands' cheapest are left at their score, for time).
//! The other terms (length, curvature, variance) keep their weights.

use rayon::prelude::*;

use super::config::BridgeConfig;
use super::graph::Graph;
use super::{grow, outline};
use crate::islands::FRAME;
use crate::raster::TwoTone;

/// How many candidates of each pair of nodes are drawn to price it: the cheapest by score, each
/// farther along the border from the others than the bridge is wide.
pub(crate) const DRAWN_PER_PAIR: usize = 6;

/// Candidate `id`'s total cost with its intensity term measured on its drawn bridge
/// ([`outline::plan`] of its grown strips) instead of estimated from its strips. Infinite
/// without a score.
pub(crate) fn drawn_total(two: &TwoTone, g: &Graph, cfg: &BridgeConfig, id: usize) -> f64 {
    let Some(score) = g.scores[id] else {
        return f64::INFINITY;
    };
    let members = grow::grow(&g.cands, &g.strips, &g.costs, id, score.width, cfg);
    let plan = outline::plan(
        &two.bits,
        &two.gray,
        &g.cands,
        &g.strips,
        &members,
        cfg,
        score.width,
    );
    // The estimate is the window's mean strip ΣI times the width, and the intensity term that
    // mean over the typical length: the real error goes through the same steps backwards.
    let per_strip = plan.real / score.width.max(1) as f64;
    let intensity = cfg.w_intensity * per_strip / g.norm.typical_len;
    score.terms.total - score.terms.intensity + intensity
}

/// Per pair of nodes (sorted, in ascending order; `nodes` of them, the frame 0), the candidate
/// whose drawn bridge costs least among the pair's [`DRAWN_PER_PAIR`] cheapest by score, and that
/// cost ([`drawn_total`]). A pair whose cheapest score is more than [`SCREEN`] times the cheapest
/// score of every pair its islands have keeps that score and its candidate undrawn: such a pair
/// is a long way round for both of its islands, and drawing it cost as much as drawing the pairs
/// the tree can use.
pub(crate) fn cheapest_drawn(
    two: &TwoTone,
    g: &Graph,
    cfg: &BridgeConfig,
    nodes: usize,
) -> Vec<((u32, u32), usize, f64)> {
    let total = |id: usize| g.scores[id].map_or(f64::INFINITY, |s| s.terms.total);
    let mut pairs: Vec<((u32, u32), &Vec<usize>, usize)> = g
        .by_pair
        .iter()
        .filter_map(|(&p, ids)| {
            let best = ids
                .iter()
                .copied()
                .min_by(|&a, &b| total(a).total_cmp(&total(b)).then(a.cmp(&b)))?;
            Some((p, ids, best))
        })
        .collect();
    pairs.sort_unstable_by_key(|(p, _, _)| *p);
    let mut cheapest = vec![f64::INFINITY; nodes];
    for &((a, b), _, best) in &pairs {
        for n in [a, b] {
            cheapest[n as usize] = cheapest[n as usize].min(total(best));
        }
    }
    let worth = |(a, b): (u32, u32), best: usize| {
        [a, b]
            .iter()
            .any(|&n| n != FRAME && total(best) <= SCREEN * cheapest[n as usize])
    };
    pairs
        .par_iter()
        .with_min_len(8)
        .map(|&(p, ids, best)| {
            if !worth(p, best) {
                return (p, best, total(best));
            }
            spread_cheapest(g, ids, DRAWN_PER_PAIR)
                .into_iter()
                .map(|id| (id, drawn_total(two, g, cfg, id)))
                .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
                .map_or((p, best, total(best)), |(id, cost)| (p, id, cost))
        })
        .collect()
}

/// A pair is drawn only where its cheapest score is at most this many times the cheapest of
/// either island's pairs (see [`cheapest_drawn`]). Drawing every pair's candidates cost the
/// bridge stage 2.5× its time on a 1 MP photo; this screen brings it back near its old time for
/// 0.844 instead of 0.830 of the shortest-gap yardstick's error on the shared photos (3 kept
/// 0.842, 6 0.841).
pub(crate) const SCREEN: f64 = 2.0;

/// Up to `k` of `ids`, cheapest score first, none within its bridge's width of another along the
/// same chain (neighbouring candidates grow into nearly the same bridge).
fn spread_cheapest(g: &Graph, ids: &[usize], k: usize) -> Vec<usize> {
    let total = |id: usize| g.scores[id].map_or(f64::INFINITY, |s| s.terms.total);
    let mut order: Vec<usize> = ids.to_vec();
    order.sort_by(|&a, &b| total(a).total_cmp(&total(b)).then(a.cmp(&b)));
    let mut picked: Vec<usize> = Vec::with_capacity(k);
    for id in order {
        if picked.len() == k {
            break;
        }
        let Some(score) = g.scores[id] else { continue };
        let chain = g.cands.chain_of[id];
        let c = &g.cands.chains[chain as usize];
        let near = picked.iter().any(|&q| {
            g.cands.chain_of[q] == chain && {
                let d = g.cands.pos(id).abs_diff(g.cands.pos(q));
                let d = if c.closed { d.min(c.len - d) } else { d };
                d <= score.width as usize
            }
        });
        if !near {
            picked.push(id);
        }
    }
    picked
}
