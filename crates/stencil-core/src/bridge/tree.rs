//! The spanning tree over island groups: Prim from the frame. An edge's cost is the cheapest
//! window among the strips between two nodes; the group grows by the cheapest edge leaving it.
//! When none leaves, the caller searches a connection from the stranded nodes
//! ([`Prim::stranded`]), adds it as an edge and grows on.

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

#[cfg(test)]
mod tests {
    use super::*;

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
