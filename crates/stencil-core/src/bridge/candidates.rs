//! Bridge candidates: every island border pixel, chained along the island's contours (the cost
//! windows run along the border): from a border pixel to an unvisited one of the same node among
//! its 8 neighbours, edge neighbours first, forwards then backwards from the seed. An island with a
//! hole gets at least two chains; a chain whose ends touch is closed and its windows wrap.

use rayon::prelude::*;

use crate::islands::{IslandMap, FRAME};

/// One run of candidates along a contour of one node.
#[derive(Clone, Debug)]
pub(crate) struct Chain {
    pub(crate) node: u32,
    /// First candidate id of the chain in [`Candidates::pixels`].
    pub(crate) start: usize,
    pub(crate) len: usize,
    /// The last candidate touches the first: windows wrap around.
    pub(crate) closed: bool,
}

/// All candidates of all islands, chain after chain. A candidate id is an index into `pixels`.
#[derive(Clone, Debug, Default)]
pub(crate) struct Candidates {
    pub(crate) pixels: Vec<(u32, u32)>,
    /// Chain index of each candidate.
    pub(crate) chain_of: Vec<u32>,
    pub(crate) chains: Vec<Chain>,
    /// Per node, the candidate id of each pixel of `IslandMap::nodes[n].border` (same order), so a
    /// border pixel found by a search maps back to its candidate. Empty for the frame.
    pub(crate) id_of_border: Vec<Vec<u32>>,
    /// Prefix sums of (1, x, y, x², y², xy) over candidates in id order (one more entry than
    /// candidates): the coordinate covariance of any run along a chain in O(1).
    moments: Vec<[f64; 6]>,
    /// Ids `twins.0..twins.1` are twins ([`Candidates::add_twins`]): the candidate at `id` sits on
    /// the same pixel, in the same place of a copy of the same chain, as `id - twins.0`.
    pub(crate) twins: (usize, usize),
}

impl Candidates {
    pub(crate) fn len(&self) -> usize {
        self.pixels.len()
    }

    pub(crate) fn node(&self, id: usize) -> u32 {
        self.chains[self.chain_of[id] as usize].node
    }

    /// Position of `id` within its chain.
    pub(crate) fn pos(&self, id: usize) -> usize {
        id - self.chains[self.chain_of[id] as usize].start
    }

    /// The candidate `offset` steps along the chain from `id`, wrapping on closed chains, `None`
    /// past the ends of an open chain.
    pub(crate) fn along(&self, id: usize, offset: isize) -> Option<usize> {
        let c = &self.chains[self.chain_of[id] as usize];
        let p = (id - c.start) as isize + offset;
        let n = c.len as isize;
        if c.closed {
            Some(c.start + p.rem_euclid(n) as usize)
        } else if (0..n).contains(&p) {
            Some(c.start + p as usize)
        } else {
            None
        }
    }

    fn push_moment(&mut self, (x, y): (u32, u32)) {
        let (x, y) = (x as f64, y as f64);
        let last = *self.moments.last().unwrap_or(&[0.0; 6]);
        let add = [1.0, x, y, x * x, y * y, x * y];
        self.moments.push(std::array::from_fn(|k| last[k] + add[k]));
    }

    /// Sums of (1, x, y, x², y², xy) over the candidates at offsets `lo..=hi` from `id` along its
    /// chain (wrapping on a closed chain; the run must not be longer than the chain).
    pub(crate) fn moments(&self, id: usize, lo: isize, hi: isize) -> [f64; 6] {
        let c = &self.chains[self.chain_of[id] as usize];
        let n = c.len as isize;
        let pos = (id - c.start) as isize;
        let range = |a: isize, b: isize| -> [f64; 6] {
            let (p, q) = (
                &self.moments[c.start + a as usize],
                &self.moments[c.start + b as usize + 1],
            );
            std::array::from_fn(|k| q[k] - p[k])
        };
        let (a, b) = (pos + lo, pos + hi);
        if !c.closed {
            return range(a.clamp(0, n - 1), b.clamp(0, n - 1));
        }
        let (a, b) = (a.rem_euclid(n), b.rem_euclid(n));
        if a <= b && hi - lo < n {
            range(a, b)
        } else {
            let (u, v) = (range(a, n - 1), range(0, b));
            std::array::from_fn(|k| u[k] + v[k])
        }
    }

    /// Add a candidate on a chain of its own (for a strip found by search rather than a walk).
    pub(crate) fn push_single(&mut self, node: u32, pixel: (u32, u32)) -> usize {
        let id = self.pixels.len();
        self.push_moment(pixel);
        self.chain_of.push(self.chains.len() as u32);
        self.chains.push(Chain {
            node,
            start: id,
            len: 1,
            closed: false,
        });
        self.pixels.push(pixel);
        id
    }

    /// Append a copy of every chain (same pixels, same order, same closure) and return the range
    /// of the copies' ids. The copies carry another kind of strip from the same border pixels
    /// (the shortest gaps, [`super::gaps`]); as chains of their own, their windows and growth run
    /// along the border exactly as the originals', over strips of their own kind.
    pub(crate) fn add_twins(&mut self) -> (usize, usize) {
        let n = self.pixels.len();
        let chains = self.chains.len() as u32;
        for id in 0..n {
            let p = self.pixels[id];
            self.push_moment(p);
            self.pixels.push(p);
            self.chain_of.push(self.chain_of[id] + chains);
        }
        for c in 0..chains as usize {
            let mut twin = self.chains[c].clone();
            twin.start += n;
            self.chains.push(twin);
        }
        self.twins = (n, 2 * n);
        self.twins
    }

    /// How many candidates are originals (one per island border pixel, before any twins).
    pub(crate) fn originals(&self) -> usize {
        if self.twins.1 > 0 {
            self.twins.0
        } else {
            self.id_of_border.iter().map(Vec::len).sum()
        }
    }

    /// The original of a twin, or `id` itself: the same border pixel has one `base` whichever
    /// kind of strip leaves it.
    pub(crate) fn base(&self, id: usize) -> usize {
        if (self.twins.0..self.twins.1).contains(&id) {
            id - self.twins.0
        } else {
            id
        }
    }

    /// The candidate id of a border pixel of `node`, if it is one (tests place candidates by pixel).
    #[cfg(test)]
    pub(crate) fn id_at(&self, map: &IslandMap, node: u32, x: u32, y: u32) -> Option<usize> {
        let border = &map.nodes.get(node as usize)?.border;
        let k = border
            .binary_search_by(|&(bx, by)| (by, bx).cmp(&(y, x)))
            .ok()?;
        self.id_of_border
            .get(node as usize)
            .and_then(|v| v.get(k))
            .map(|&i| i as usize)
    }
}

/// Chain every island's border pixels (the frame's are not candidates: bridges start on islands).
/// O(total island perimeter); islands are chained in parallel.
pub(crate) fn collect(map: &IslandMap) -> Candidates {
    let per_node: Vec<Vec<Vec<u32>>> = map
        .nodes
        .par_iter()
        .enumerate()
        .map(|(n, node)| {
            if n as u32 == FRAME {
                Vec::new()
            } else {
                chain_node(map, n as u32, &node.border)
            }
        })
        .collect();

    // Every island border pixel becomes one candidate: size the per-candidate arrays once.
    let total: usize = per_node.iter().flatten().map(Vec::len).sum();
    let mut moments = Vec::with_capacity(total + 1);
    moments.push([0.0; 6]);
    let mut out = Candidates {
        pixels: Vec::with_capacity(total),
        chain_of: Vec::with_capacity(total),
        id_of_border: vec![Vec::new(); map.nodes.len()],
        moments,
        ..Default::default()
    };
    for (n, chains) in per_node.into_iter().enumerate() {
        let border = &map.nodes[n].border;
        if !chains.is_empty() {
            out.id_of_border[n] = vec![u32::MAX; border.len()];
        }
        for chain in chains {
            let start = out.pixels.len();
            let ci = out.chains.len() as u32;
            for &k in &chain {
                out.id_of_border[n][k as usize] = out.pixels.len() as u32;
                out.push_moment(border[k as usize]);
                out.pixels.push(border[k as usize]);
                out.chain_of.push(ci);
            }
            let first = border[chain[0] as usize];
            let last = border[*chain.last().unwrap_or(&chain[0]) as usize];
            let closed = chain.len() >= 3 && touches8(first, last);
            out.chains.push(Chain {
                node: n as u32,
                start,
                len: chain.len(),
                closed,
            });
        }
    }
    out
}

fn touches8(a: (u32, u32), b: (u32, u32)) -> bool {
    a.0.abs_diff(b.0) <= 1 && a.1.abs_diff(b.1) <= 1
}

/// Edge neighbours first, then corners, in a fixed turning order so chains follow the contour.
const STEPS: [(i64, i64); 8] = [
    (1, 0),
    (0, 1),
    (-1, 0),
    (0, -1),
    (1, 1),
    (-1, 1),
    (-1, -1),
    (1, -1),
];

/// Chains of one node as lists of indices into its (scan-ordered) border list.
fn chain_node(map: &IslandMap, node: u32, border: &[(u32, u32)]) -> Vec<Vec<u32>> {
    // Where each row of the (scan-ordered) border starts, so a lookup searches only its row:
    // every chain step tries up to eight neighbours.
    let y0 = border.first().map_or(0, |p| p.1);
    let rows = border.last().map_or(0, |p| p.1 - y0 + 1) as usize;
    let mut row_start = vec![0usize; rows + 1];
    for &(_, y) in border {
        row_start[(y - y0) as usize + 1] += 1;
    }
    for r in 0..rows {
        row_start[r + 1] += row_start[r];
    }
    let find = |x: i64, y: i64| -> Option<usize> {
        if x < 0 || y < 0 || x >= map.width as i64 || y >= map.height as i64 {
            return None;
        }
        let (x, y) = (x as u32, y as u32);
        if map.label(x, y) != node || y < y0 || (y - y0) as usize >= rows {
            return None;
        }
        let (a, b) = (
            row_start[(y - y0) as usize],
            row_start[(y - y0) as usize + 1],
        );
        border[a..b]
            .binary_search_by(|&(bx, _)| bx.cmp(&x))
            .ok()
            .map(|k| a + k)
    };
    let mut visited = vec![false; border.len()];
    let mut chains = Vec::new();
    for seed in 0..border.len() {
        if visited[seed] {
            continue;
        }
        visited[seed] = true;
        let mut forward = vec![seed as u32];
        extend(&mut forward, border, &mut visited, &find);
        let mut backward = vec![seed as u32];
        extend(&mut backward, border, &mut visited, &find);
        backward.reverse();
        backward.pop(); // the seed, already first in `forward`
        backward.extend(forward);
        chains.push(backward);
    }
    chains
}

fn extend(
    chain: &mut Vec<u32>,
    border: &[(u32, u32)],
    visited: &mut [bool],
    find: &impl Fn(i64, i64) -> Option<usize>,
) {
    loop {
        let (x, y) = border[*chain.last().unwrap_or(&0) as usize];
        let next = STEPS
            .iter()
            .find_map(|&(dx, dy)| find(x as i64 + dx, y as i64 + dy).filter(|&k| !visited[k]));
        match next {
            Some(k) => {
                visited[k] = true;
                chain.push(k as u32);
            }
            None => return,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::islands::label;
    use crate::raster::BitGrid;

    #[test]
    fn square_island_is_one_closed_chain_in_contour_order() {
        let g = BitGrid::from_rows(&[
            "........", "........", "..####..", "..####..", "..####..", "..####..", "........",
            "........",
        ]);
        let m = label(&g);
        let c = collect(&m);
        assert_eq!(c.chains.len(), 1);
        assert!(c.chains[0].closed);
        assert_eq!(c.len(), 12);
        // Consecutive candidates are 8-neighbours: the chain follows the contour.
        for i in 0..c.len() {
            let j = c.along(i, 1).unwrap();
            assert!(touches8(c.pixels[i], c.pixels[j]), "{i} -> {j}");
        }
    }

    #[test]
    fn ring_island_has_outer_and_inner_chains_and_lookup_works() {
        let g = BitGrid::from_rows(&[
            ".........",
            ".#######.",
            ".#.....#.",
            ".#.....#.",
            ".#.....#.",
            ".#######.",
            ".........",
        ]);
        let m = label(&g);
        let c = collect(&m);
        // A one-pixel ring: every pixel is a border pixel of both sides; one chain covers it.
        assert_eq!(c.len(), m.nodes[1].border.len());
        for (k, &(x, y)) in m.nodes[1].border.iter().enumerate() {
            let id = c.id_at(&m, 1, x, y).unwrap();
            assert_eq!(c.pixels[id], (x, y));
            assert_eq!(c.id_of_border[1][k] as usize, id);
        }
        assert_eq!(c.id_at(&m, 1, 0, 0), None);
    }

    #[test]
    fn window_moments_match_a_direct_sum_including_wrap_around() {
        let g = BitGrid::from_rows(&[
            "........", "........", "..####..", "..####..", "..####..", "..####..", "........",
            "........",
        ]);
        let c = collect(&label(&g));
        for id in 0..c.len() {
            for (lo, hi) in [(-4isize, 0isize), (-2, 2), (0, 4), (-11, 0)] {
                let mut want = [0.0; 6];
                for k in lo..=hi {
                    let (x, y) = c.pixels[c.along(id, k).unwrap()];
                    let (x, y) = (x as f64, y as f64);
                    for (w, v) in want.iter_mut().zip([1.0, x, y, x * x, y * y, x * y]) {
                        *w += v;
                    }
                }
                assert_eq!(c.moments(id, lo, hi), want, "id {id} window {lo}..={hi}");
            }
        }
    }

    #[test]
    fn open_chain_stops_at_its_ends() {
        let g = BitGrid::from_rows(&["......", ".####.", "......"]);
        let m = label(&g);
        let c = collect(&m);
        assert_eq!(c.chains.len(), 1);
        assert!(!c.chains[0].closed);
        let first = c.chains[0].start;
        assert_eq!(c.along(first, -1), None);
        assert_eq!(
            c.along(first, 3)
                .map(|i| c.pixels[i].0.abs_diff(c.pixels[first].0)),
            Some(3)
        );
    }
}
