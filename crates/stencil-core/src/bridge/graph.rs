//! The candidates with their strips, costs and scores, and the candidates by the pair of nodes
//! they join: what the spanning tree, the strength rules and the user's places choose from.

use std::borrow::Cow;
use std::collections::HashMap;

use super::{candidates, cost, strips};
use crate::islands::{self, IslandMap};

/// Everything computed about the candidates before the tree: strips, their costs and scores.
/// The candidates and their strips are borrowed from the [`Walks`] (the studio keeps those while
/// a person tries weights, and copying them cost more than choosing the bridges saved); only the
/// fallback search, which adds a candidate, makes its own copy.
pub(super) struct Graph<'w> {
    pub(super) cands: Cow<'w, candidates::Candidates>,
    pub(super) strips: Cow<'w, [Option<strips::Strip>]>,
    pub(super) costs: Vec<Option<cost::StripCost>>,
    pub(super) scores: Vec<Option<cost::Scored>>,
    pub(super) norm: cost::Norm,
    /// Candidates by the (sorted) pair of nodes their strip joins.
    pub(super) by_pair: HashMap<(u32, u32), Vec<usize>>,
    /// Candidates from this id on were added by the fallback search ([`add_found_strip`]).
    pub(super) walked: usize,
}

pub(super) fn pair(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// Area of the smaller of two nodes, the frame counting as infinite.
pub(super) fn smaller_area(map: &IslandMap, a: u32, b: u32) -> usize {
    let area = |n: u32| {
        if n == islands::FRAME {
            usize::MAX
        } else {
            map.nodes[n as usize].area
        }
    };
    area(a).min(area(b))
}
