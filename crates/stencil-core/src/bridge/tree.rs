//! The spanning tree over island groups: Prim from the frame. An edge's cost is the cheapest
//! window among the strips between two nodes; the group grows by the cheapest edge leaving it.
//! When none leaves, the caller searches a connection from the stranded nodes
//! ([`Prim::stranded`]), adds it as an edge and grows on.
//!
//! ## Chains
//! A sheet is lifted by its main piece (the frame). Island `a` *hangs on* island `b` when every
//! way from `a` to the frame along the bridges passes through `b` (`b` holds `a`, whatever other
//! bridges `a` has); the nearest such island is the one it hangs on directly. A *chain* is a run
//! of islands each hanging directly on the next, the last held by the frame without another
//! island between: its length is the number of islands in it ([`Chains`]). An island bridged to
//! the frame is a chain of one; a speck bridged to a speck bridged to the frame, of two. A long
//! chain is a lace: lifting the sheet, each link carries all the ones after it.

use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;

use crate::islands::FRAME;

/// An edge between two nodes, carrying the candidate (strip) that realises it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Edge {
    pub(crate) a: u32,
    pub(crate) b: u32,
    pub(crate) cost: f64,
    pub(crate) candidate: usize,
}

#[derive(Clone, Copy, PartialEq)]
struct Key(f64, usize);
impl Eq for Key {}
impl PartialOrd for Key {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Key {
    fn cmp(&self, o: &Self) -> Ordering {
        self.0.total_cmp(&o.0).then(self.1.cmp(&o.1))
    }
}

/// Prim's algorithm, resumable after adding edges.
pub(crate) struct Prim {
    edges: Vec<Edge>,
    adj: Vec<Vec<usize>>,
    in_tree: Vec<bool>,
    heap: BinaryHeap<Reverse<Key>>,
    /// Chosen edges in the order they joined a node to the group: (edge, the node it brought in).
    pub(crate) chosen: Vec<(Edge, u32)>,
}

impl Prim {
    /// Start with the frame as the group.
    pub(crate) fn new(nodes: usize) -> Self {
        let mut in_tree = vec![false; nodes];
        if nodes > 0 {
            in_tree[FRAME as usize] = true;
        }
        Prim {
            edges: Vec::new(),
            adj: vec![Vec::new(); nodes],
            in_tree,
            heap: BinaryHeap::new(),
            chosen: Vec::new(),
        }
    }

    pub(crate) fn add(&mut self, e: Edge) {
        let k = self.edges.len();
        self.edges.push(e);
        self.adj[e.a as usize].push(k);
        self.adj[e.b as usize].push(k);
        if self.in_tree[e.a as usize] != self.in_tree[e.b as usize] {
            self.heap.push(Reverse(Key(e.cost, k)));
        }
    }

    /// Grow until no edge leaves the group.
    pub(crate) fn grow(&mut self) {
        while let Some(Reverse(Key(_, k))) = self.heap.pop() {
            let e = self.edges[k];
            let v = match (self.in_tree[e.a as usize], self.in_tree[e.b as usize]) {
                (true, false) => e.b,
                (false, true) => e.a,
                _ => continue, // inside the group now
            };
            self.in_tree[v as usize] = true;
            self.chosen.push((e, v));
            for &k2 in &self.adj[v as usize] {
                let e2 = self.edges[k2];
                let other = if e2.a == v { e2.b } else { e2.a };
                if !self.in_tree[other as usize] {
                    self.heap.push(Reverse(Key(e2.cost, k2)));
                }
            }
        }
    }

    #[cfg(test)]
    pub(crate) fn done(&self) -> bool {
        self.in_tree.iter().all(|&t| t)
    }

    /// After a stall: the lowest-numbered node outside the group together with every node it
    /// reaches through known edges (a mask over nodes), or `None` when all are joined. A
    /// connection must leave this whole set.
    pub(crate) fn stranded(&self) -> Option<Vec<bool>> {
        let first = self.in_tree.iter().position(|&t| !t)?;
        let mut mask = vec![false; self.in_tree.len()];
        mask[first] = true;
        let mut stack = vec![first];
        while let Some(v) = stack.pop() {
            for &k in &self.adj[v] {
                let e = self.edges[k];
                let o = if e.a as usize == v { e.b } else { e.a } as usize;
                if !mask[o] && !self.in_tree[o] {
                    mask[o] = true;
                    stack.push(o);
                }
            }
        }
        Some(mask)
    }
}

/// The chains of a sheet (see the module notes), from its bridges' node pairs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Chains {
    /// Per node (0 = the frame, 0): the length of the chain the island ends, itself included
    /// (1 when nothing but the frame holds it); 0 for an island no bridge joins to the frame.
    pub depth: Vec<u32>,
    /// Per node: the island it hangs on directly, `None` when the frame holds it (or nothing).
    pub hangs_on: Vec<Option<u32>>,
}

impl Chains {
    /// The chains of `nodes` nodes (0 = the frame) joined by `links` (a bridge's two nodes;
    /// repeated pairs and links naming no island are allowed). O(nodes + links): the hanging is
    /// read from one depth-first search from the frame, where a node `p` holds the nodes under its
    /// child `c` exactly when nothing under `c` has a bridge to above `p` (the lowest point `c`'s
    /// part of the search reaches is `p`, as for cut vertices).
    pub fn of(nodes: usize, links: impl IntoIterator<Item = [u32; 2]>) -> Chains {
        let mut out = Chains {
            depth: vec![0; nodes],
            hangs_on: vec![None; nodes],
        };
        if nodes == 0 {
            return out;
        }
        let mut adj: Vec<Vec<(usize, usize)>> = vec![Vec::new(); nodes];
        for (k, [a, b]) in links.into_iter().enumerate() {
            let (a, b) = (a as usize, b as usize);
            if a < nodes && b < nodes && a != b {
                adj[a].push((b, k));
                adj[b].push((a, k));
            }
        }
        const UNSEEN: usize = usize::MAX;
        let mut disc = vec![UNSEEN; nodes];
        let mut low = vec![0usize; nodes];
        let mut parent = vec![UNSEEN; nodes];
        let mut order = Vec::with_capacity(nodes);
        // (node, the link it was reached by, its next neighbour to look at)
        let mut stack: Vec<(usize, usize, usize)> = vec![(FRAME as usize, UNSEEN, 0)];
        disc[FRAME as usize] = 0;
        low[FRAME as usize] = 0;
        order.push(FRAME as usize);
        while let Some(top) = stack.last_mut() {
            let (v, via, next) = *top;
            if let Some(&(u, k)) = adj[v].get(next) {
                top.2 += 1;
                if k == via {
                    continue;
                }
                if disc[u] == UNSEEN {
                    disc[u] = order.len();
                    low[u] = disc[u];
                    parent[u] = v;
                    order.push(u);
                    stack.push((u, k, 0));
                } else {
                    low[v] = low[v].min(disc[u]);
                }
            } else {
                stack.pop();
                if parent[v] != UNSEEN {
                    let p = parent[v];
                    low[p] = low[p].min(low[v]);
                }
            }
        }
        // In search order, a node's holder is its parent when the parent is an island that
        // cuts it off from the frame, else its parent's holder.
        for &v in order.iter().skip(1) {
            let p = parent[v];
            let held = if p != FRAME as usize && low[v] >= disc[p] {
                Some(p as u32)
            } else {
                out.hangs_on[p]
            };
            out.hangs_on[v] = held;
            out.depth[v] = held.map_or(1, |h| out.depth[h as usize] + 1);
        }
        out
    }

    /// The longest chain's length (0 without islands).
    pub fn longest(&self) -> u32 {
        self.depth.iter().copied().max().unwrap_or(0)
    }

    /// The islands of the chain `island` ends, from it to the one the frame holds.
    pub fn chain(&self, island: u32) -> Vec<u32> {
        let mut v = vec![island];
        while let Some(h) = self.hangs_on[*v.last().expect("a chain has an island") as usize] {
            v.push(h);
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether every way from `a` to the frame passes `b`: `a` cannot reach the frame with `b`
    /// taken out (the definition, by brute force).
    fn holds(nodes: usize, links: &[[u32; 2]], b: u32, a: u32) -> bool {
        let mut seen = vec![false; nodes];
        seen[b as usize] = true;
        seen[a as usize] = true;
        let mut stack = vec![a];
        while let Some(v) = stack.pop() {
            for &[x, y] in links {
                for (p, q) in [(x, y), (y, x)] {
                    if p == v && !seen[q as usize] {
                        if q == FRAME {
                            return false;
                        }
                        seen[q as usize] = true;
                        stack.push(q);
                    }
                }
            }
        }
        true
    }

    #[test]
    fn a_chain_is_counted_island_by_island() {
        // 0-1-2-3 a chain of three; 4 hangs on 1 but also has a bridge to the frame; 5 twice
        // to 3 (a support bridge); 6 to 2 and 3, both held by 2.
        let links = [
            [0, 1],
            [1, 2],
            [2, 3],
            [1, 4],
            [4, 0],
            [3, 5],
            [5, 3],
            [6, 2],
            [6, 3],
        ];
        let c = Chains::of(8, links);
        assert_eq!(c.depth, vec![0, 1, 2, 3, 1, 4, 3, 0]);
        assert_eq!(c.hangs_on[5], Some(3));
        assert_eq!(c.hangs_on[6], Some(2));
        assert_eq!(c.chain(5), vec![5, 3, 2, 1]);
        assert_eq!(c.longest(), 4);
    }

    #[test]
    fn chains_follow_the_definition_on_random_bridge_graphs() {
        let mut rng = crate::test_rng::Lcg(0x51ee_75ab_0bad_cafe);
        for case in 0..200 {
            let nodes = 2 + rng.below(14) as usize;
            let mut links = Vec::new();
            // A random tree from the frame, then a few extra links.
            for v in 1..nodes as u32 {
                links.push([rng.below(v as u64) as u32, v]);
            }
            for _ in 0..rng.below(4) {
                let (a, b) = (rng.below(nodes as u64), rng.below(nodes as u64));
                links.push([a as u32, b as u32]);
            }
            let c = Chains::of(nodes, links.iter().copied());
            for a in 1..nodes as u32 {
                let holders: Vec<u32> = (1..nodes as u32)
                    .filter(|&b| b != a && holds(nodes, &links, b, a))
                    .collect();
                let chain = c.chain(a);
                assert_eq!(
                    c.depth[a as usize] as usize,
                    holders.len() + 1,
                    "case {case}"
                );
                let mut got = chain[1..].to_vec();
                got.sort_unstable();
                assert_eq!(got, holders, "case {case} island {a}: {links:?}");
            }
        }
    }

    fn e(a: u32, b: u32, cost: f64, candidate: usize) -> Edge {
        Edge {
            a,
            b,
            cost,
            candidate,
        }
    }

    #[test]
    fn prim_on_a_tiny_graph_takes_the_minimum_tree() {
        // 0-1: 5, 0-2: 1, 1-2: 2, 2-3: 7, 1-3: 3  → tree 0-2, 2-1, 1-3 (total 6).
        let mut p = Prim::new(4);
        for (i, (a, b, c)) in [
            (0, 1, 5.0),
            (0, 2, 1.0),
            (1, 2, 2.0),
            (2, 3, 7.0),
            (1, 3, 3.0),
        ]
        .into_iter()
        .enumerate()
        {
            p.add(e(a, b, c, i));
        }
        p.grow();
        assert!(p.done());
        let picked: Vec<_> = p.chosen.iter().map(|(e, v)| (e.candidate, *v)).collect();
        assert_eq!(picked, vec![(1, 2), (2, 1), (4, 3)]);
        let total: f64 = p.chosen.iter().map(|(e, _)| e.cost).sum();
        assert_eq!(total, 6.0);
    }

    #[test]
    fn a_stall_names_the_stranded_pair_and_growth_resumes() {
        // 1 and 2 only reach each other; 3 reaches the frame.
        let mut p = Prim::new(4);
        p.add(e(1, 2, 1.0, 0));
        p.add(e(3, 0, 1.0, 1));
        p.grow();
        assert!(!p.done());
        let s = p.stranded().unwrap();
        assert_eq!(s, vec![false, true, true, false]);
        p.add(e(2, 3, 9.0, 2));
        p.grow();
        assert!(p.done());
        assert_eq!(p.chosen.len(), 3);
        assert!(p.stranded().is_none());
    }

    #[test]
    fn edges_inside_the_group_are_ignored() {
        let mut p = Prim::new(3);
        p.add(e(0, 1, 1.0, 0));
        p.add(e(1, 2, 1.0, 1));
        p.add(e(0, 2, 0.5, 2));
        p.grow();
        // 0-2 (0.5) then 0-1 (1.0); 1-2 lies inside the group by then.
        let picked: Vec<_> = p.chosen.iter().map(|(e, _)| e.candidate).collect();
        assert_eq!(picked, vec![2, 0]);
    }
}
