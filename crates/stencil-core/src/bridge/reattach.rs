//! After the tree: a long bridge moved onto the tree's other bridges where that costs less.
//!
//! The spanning tree joins pieces to pieces; over a wide dark stretch of cut (clothing in a
//! portrait, a night sky) its longest bridges each cross the whole stretch to the nearest piece,
//! though another bridge may run much nearer. A bridge may as well end on that bridge: the sheet
//! is one piece all the same, and the stretch it no longer crosses is picture kept. So, longest
//! bridges first, each is taken out in turn and its island searched a way from (the fallback
//! search's cheapest path, `search`), ending on any piece its side of the tree does not hold or
//! on any other tree bridge as planned; the way replaces the bridge when, drawn, it costs less
//! (a Steiner point, where three ways meet, found one bridge at a time). Only bridges at least
//! [`MIN_LENGTH`] long are tried, at most [`MAX_TRIES`] of them: each search costs what it
//! explores, about the area the bridge's own price reaches.

use super::cost::StepCost;
use super::graph::Graph;
use super::search::{search_with, Landings, SearchScratch};
use super::strips::{Fields, Strip};
use super::tree::Edge;
use crate::islands::{IslandMap, FRAME};

/// Bridges shorter than this (strip length, px) stay: ending on a neighbour saves little there.
pub(crate) const MIN_LENGTH: usize = 24;
/// At most this many bridges are tried, the dearest first.
pub(crate) const MAX_TRIES: usize = 48;

/// What the pass needs of the bridge stage besides the graph: adding a found strip as a
/// candidate (its id), pricing a candidate as drawn, and planning one (`T`, the plan; `pixels`
/// of a plan: the cut pixels it turns into material).
pub(crate) struct Hooks<A, P, Q, X> {
    pub(crate) add: A,
    pub(crate) price: P,
    pub(crate) plan: Q,
    pub(crate) pixels: X,
}

/// Move tree bridges onto the tree (see the module notes). `chosen`: the tree's edges with the
/// node each brought in, in the order they were chosen; `planned`: their plans, in the same
/// order. Replaced edges and plans are rewritten in place; returns how many were.
#[allow(clippy::too_many_arguments)]
pub(crate) fn reattach<T, A, P, Q, X>(
    g: &mut Graph,
    fields: &Fields,
    map: &IslandMap,
    step: &StepCost,
    chosen: &mut [(Edge, u32)],
    planned: &mut [T],
    hooks: Hooks<A, P, Q, X>,
) -> usize
where
    A: Fn(&mut Graph, (u32, u32), Strip) -> usize,
    P: Fn(&Graph, usize) -> f64,
    Q: Fn(&Graph, usize) -> T,
    X: Fn(&T) -> Vec<u32>,
{
    let len_of = |g: &Graph, id: usize| g.strips.get(id).and_then(|s| s.as_ref()).map_or(0, |s| s.len());
    let mut order: Vec<usize> = (0..chosen.len())
        .filter(|&k| len_of(g, chosen[k].0.candidate) >= MIN_LENGTH && chosen[k].1 != FRAME)
        .collect();
    if order.is_empty() {
        return 0;
    }
    order.sort_by(|&a, &b| chosen[b].0.cost.total_cmp(&chosen[a].0.cost).then(a.cmp(&b)));
    order.truncate(MAX_TRIES);
    let nodes = map.nodes.len();
    // Every planned pixel as a landing at its bridge's first node (a pixel two plans share is
    // the first's), and per bridge the pixels it holds there.
    let mut landings = Landings::new();
    let mut held: Vec<Vec<u32>> = vec![Vec::new(); planned.len()];
    for (k, p) in planned.iter().enumerate() {
        let node = chosen[k].0.a;
        for px in (hooks.pixels)(p) {
            let free = !fields.blocked(px as i64 % fields.width, px as i64 / fields.width);
            if free && !landings.contains_key(&px) {
                landings.insert(px, node);
                held[k].push(px);
            }
        }
    }
    // Which bridge holds each landing, and the bridges something now ends on (they stay).
    let mut who: std::collections::HashMap<u32, usize> = held
        .iter()
        .enumerate()
        .flat_map(|(k, px)| px.iter().map(move |&p| (p, k)))
        .collect();
    let mut landed_on = vec![false; planned.len()];
    let dark = |px: &[u32]| -> f64 {
        px.iter()
            .map(|&p| (1.0 - fields.gray.data[p as usize] as f64).powi(2))
            .sum()
    };
    let mut scratch = SearchScratch::default();
    let mut replaced = 0;
    for k in order {
        if landed_on[k] {
            continue;
        }
        let (_, v) = chosen[k];
        // The nodes that hang on this bridge: those reached from `v` without it.
        let mut adj: Vec<Vec<u32>> = vec![Vec::new(); nodes];
        for (j, (e, _)) in chosen.iter().enumerate() {
            if j != k {
                adj[e.a as usize].push(e.b);
                adj[e.b as usize].push(e.a);
            }
        }
        let mut side = vec![false; nodes];
        side[v as usize] = true;
        let mut stack = vec![v];
        while let Some(n) = stack.pop() {
            for &m in &adj[n as usize] {
                if !side[m as usize] {
                    side[m as usize] = true;
                    stack.push(m);
                }
            }
        }
        if side[FRAME as usize] {
            continue; // not a bridge the sheet hangs on (cannot happen: the tree stays a tree)
        }
        // Landings: the other bridges' pixels (this one's taken out while it is searched for).
        for px in &held[k] {
            landings.remove(px);
        }
        let found = search_with(fields, map, &side, Some(v), &landings, step, &mut scratch);
        if let Some((start, strip)) = found {
            let (to, end) = (strip.to, strip.end);
            let onto = fields
                .inside(end.0, end.1)
                .then(|| who.get(&((end.1 * fields.width + end.0) as u32)).copied())
                .flatten();
            let id = (hooks.add)(g, start, strip);
            let plan = (hooks.plan)(g, id);
            // What each adds to the picture: its own pixels (a pixel another bridge draws too
            // costs nothing more).
            let mine: Vec<u32> = (hooks.pixels)(&plan)
                .into_iter()
                .filter(|&px| !fields.blocked(px as i64 % fields.width, px as i64 / fields.width))
                .filter(|px| !landings.contains_key(px))
                .collect();
            if dark(&mine) < dark(&held[k]) && mine.len() <= held[k].len() {
                let cost = (hooks.price)(g, id);
                chosen[k].0 = Edge {
                    a: v.min(to),
                    b: v.max(to),
                    cost,
                    candidate: id,
                };
                for px in &held[k] {
                    who.remove(px);
                }
                for &px in &mine {
                    who.insert(px, k);
                }
                held[k] = mine;
                planned[k] = plan;
                if let Some(j) = onto {
                    landed_on[j] = true;
                }
                replaced += 1;
            }
        }
        let node = chosen[k].0.a;
        for &px in &held[k] {
            landings.insert(px, node);
        }
    }
    replaced
}
