//! How near another node's material a walk can still arrive, block by block: a lower bound that
//! stops a walk as soon as no other node lies within its remaining length (and, by the
//! chessboard distance, where the shortest gaps look for partners).

use crate::islands::{IslandMap, CUT, FRAME};

/// Side of the square blocks of the walks' [`Reach`]: 2^3 = 8 pixels. (4-pixel blocks bound the
/// walks tighter, but on the stages bench the walks' CPU did not measurably drop while the
/// build's rose by half again: 8 stays. The tests cover both sizes.)
const WALK_SHIFT: u32 = 3;
/// Side of the square blocks of the gaps' [`Reach::chebyshev`]: 2^3 = 8 pixels.
const GAP_SHIFT: u32 = 3;
/// A label [`Reach`] gives a block holding the shores of two or more nodes besides the first one
/// it saw: "some node other than that one", never a walk's own.
const MANY: u32 = u32::MAX - 1;

/// A lower bound on how far (in 4-connected steps, L1) a pixel is from material of another node:
/// most failed walks ran their whole length through open cut (60 % of walk steps on the 1 MP
/// photo), and this stops them when no other node is within what is left.
///
/// The shores (the nodes' border lists and the image's edge) are gathered per square block of `B`
/// pixels; a distance transform over the blocks keeps per block the two nearest *distinct* labels
/// (a block with several nodes' shores counts as its first node and [`MANY`]). The nearest other
/// node of `own` is the first label's distance unless that is `own`, else the second's. Blocks `D`
/// apart hold pixels at least `(D − 2)·B + 2` apart. O(blocks + shore pixels).
///
/// The transform is the classic exact two-pass city-block (or chessboard) one; keeping two labels
/// stays exact, since a dropped label is beaten by two others that follow it onward. About a third
/// cheaper than the breadth-first search it replaced (the tests keep that, to compare).
#[derive(Clone, Debug)]
pub(crate) struct Reach {
    /// Blocks are 2^shift pixels square.
    shift: u32,
    /// Blocks per row.
    across: usize,
    /// Per block: the nearest label, the bound to it, the bound to the nearest other label, in
    /// pixels (`u32::MAX`: none).
    cells: Vec<(u32, u32, u32)>,
}

/// Per block, while building: up to two (label, distance in blocks), nearest first; `CUT`: none.
type Slots = [(u32, u32); 2];

/// Offers `label` at `d` blocks to a block's two nearest distinct labels.
#[inline(always)]
fn offer(s: &mut Slots, label: u32, d: u32) {
    if s[0].0 == label {
        s[0].1 = s[0].1.min(d);
    } else if s[1].0 == label {
        if d < s[1].1 {
            s[1].1 = d;
            if d < s[0].1 {
                s.swap(0, 1);
            }
        }
    } else if d < s[1].1 {
        s[1] = (label, d);
        if d < s[0].1 {
            s.swap(0, 1);
        }
    }
}

/// Offers block `from`'s labels, one block farther, to block `to`.
#[inline(always)]
fn pull(slots: &mut [Slots], to: usize, from: usize) {
    let f = slots[from];
    if f[0].0 != CUT {
        offer(&mut slots[to], f[0].0, f[0].1 + 1);
        if f[1].0 != CUT {
            offer(&mut slots[to], f[1].0, f[1].1 + 1);
        }
    }
}

impl Reach {
    /// The bound on the L1 distance, for the walks (4-connected steps).
    pub(crate) fn new(map: &IslandMap) -> Reach {
        Reach::build(map, WALK_SHIFT, false)
    }

    /// The bound on the Chebyshev distance (and so on the Euclidean one), for the shortest gaps
    /// (`gaps`): the same search over blocks 8-connected, where blocks `D` apart hold pixels at
    /// least `(D − 1)·B + 1` apart along one axis.
    pub(crate) fn chebyshev(map: &IslandMap) -> Reach {
        Reach::build(map, GAP_SHIFT, true)
    }

    /// The blocks' shores: per block, its first label at distance 0 and [`MANY`] if it has more.
    fn sources(map: &IslandMap, shift: u32) -> (usize, usize, Vec<Slots>) {
        let (w, h) = (map.width as usize, map.height as usize);
        let b = 1usize << shift;
        let (across, down) = (w.div_ceil(b), h.div_ceil(b));
        let n = across * down;
        let mut slots = vec![[(CUT, u32::MAX); 2]; n];
        let mut seen = |k: usize, l: u32| {
            let s = &mut slots[k];
            if s[0].0 == CUT {
                s[0] = (l, 0);
            } else if s[0].0 != l {
                s[1] = (MANY, 0);
            }
        };
        let s = shift;
        for (node, nd) in map.nodes.iter().enumerate() {
            for &(x, y) in &nd.border {
                seen((y >> s) as usize * across + (x >> s) as usize, node as u32);
            }
        }
        if n > 0 {
            for bx in 0..across {
                seen(bx, FRAME);
                seen((down - 1) * across + bx, FRAME);
            }
            for by in 0..down {
                seen(by * across, FRAME);
                seen(by * across + across - 1, FRAME);
            }
        }
        (across, down, slots)
    }

    pub(super) fn build(map: &IslandMap, shift: u32, corners: bool) -> Reach {
        let (across, down, mut slots) = Reach::sources(map, shift);
        for by in 0..down {
            for bx in 0..across {
                let k = by * across + bx;
                if bx > 0 {
                    pull(&mut slots, k, k - 1);
                }
                if by > 0 {
                    pull(&mut slots, k, k - across);
                    if corners {
                        if bx > 0 {
                            pull(&mut slots, k, k - across - 1);
                        }
                        if bx + 1 < across {
                            pull(&mut slots, k, k - across + 1);
                        }
                    }
                }
            }
        }
        for by in (0..down).rev() {
            for bx in (0..across).rev() {
                let k = by * across + bx;
                if bx + 1 < across {
                    pull(&mut slots, k, k + 1);
                }
                if by + 1 < down {
                    pull(&mut slots, k, k + across);
                    if corners {
                        if bx + 1 < across {
                            pull(&mut slots, k, k + across + 1);
                        }
                        if bx > 0 {
                            pull(&mut slots, k, k + across - 1);
                        }
                    }
                }
            }
        }
        Reach::finish(&slots, across, shift, corners)
    }

    /// The blocks' distances in pixels.
    fn finish(slots: &[Slots], across: usize, shift: u32, corners: bool) -> Reach {
        let b = 1u32 << shift;
        let px = |d: u32| match d {
            0 => 0,
            u32::MAX => u32::MAX,
            d if corners => (d - 1) * b + 1,
            1 => 1,
            d => (d - 2) * b + 2,
        };
        Reach {
            shift,
            across,
            cells: slots
                .iter()
                .map(|s| (s[0].0, px(s[0].1), px(s[1].1)))
                .collect(),
        }
    }

    /// The breadth-first build the two passes replaced, to compare against in the tests.
    #[cfg(test)]
    fn build_bfs(map: &IslandMap, shift: u32, corners: bool) -> Reach {
        let (across, down, seeds) = Reach::sources(map, shift);
        let n = across * down;
        // Breadth first over the blocks: (block, label) in order of distance.
        let mut slots = vec![[(CUT, u32::MAX); 2]; n];
        let mut queue = std::collections::VecDeque::new();
        for k in 0..n {
            for &(l, d) in &seeds[k] {
                if l != CUT {
                    slots[k][if l == MANY { 1 } else { 0 }] = (l, d);
                    queue.push_back((k as u32, l));
                }
            }
        }
        while let Some((k, l)) = queue.pop_front() {
            let k = k as usize;
            let d = if slots[k][0].0 == l {
                slots[k][0].1
            } else {
                slots[k][1].1
            };
            let (bx, by) = (k % across, k / across);
            let mut visit = |j: usize| {
                let s = &mut slots[j];
                if s[0].0 == l || s[1].0 == l {
                    return;
                }
                let slot = if s[0].0 == CUT {
                    &mut s[0]
                } else if s[1].0 == CUT {
                    &mut s[1]
                } else {
                    return;
                };
                *slot = (l, d + 1);
                queue.push_back((j as u32, l));
            };
            if bx > 0 {
                visit(k - 1);
            }
            if bx + 1 < across {
                visit(k + 1);
            }
            if by > 0 {
                visit(k - across);
            }
            if by + 1 < down {
                visit(k + across);
            }
            if corners {
                if bx > 0 && by > 0 {
                    visit(k - across - 1);
                }
                if bx + 1 < across && by > 0 {
                    visit(k - across + 1);
                }
                if bx > 0 && by + 1 < down {
                    visit(k + across - 1);
                }
                if bx + 1 < across && by + 1 < down {
                    visit(k + across + 1);
                }
            }
        }
        Reach::finish(&slots, across, shift, corners)
    }

    /// At least this many 4-connected steps (the L1 distance; for [`Reach::chebyshev`], the
    /// Chebyshev distance) lead from pixel (x, y) (inside the image) to any border pixel of a node
    /// other than `own`, or to the frame beyond the image.
    #[inline]
    pub(crate) fn bound(&self, x: i64, y: i64, own: u32) -> u32 {
        let k = (y as usize >> self.shift) * self.across + (x as usize >> self.shift);
        let (near, first, second) = self.cells[k];
        if near != own {
            first
        } else {
            second
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bridge::tests::{random_picture, rng};
    use crate::islands::label;

    /// [`Reach`] never claims more steps to another node's shore than there are (brute force
    /// over every shore pixel and the points beyond the image's edge).
    #[test]
    fn reach_is_a_lower_bound_on_the_distance_to_another_nodes_shore() {
        let mut next = rng(0x5eed_0f1a_b0b0_u64);
        let mut positive = 0;
        for k in 0..12u32 {
            let (w, h) = (30 + k * 7 % 41, 25 + k * 11 % 37);
            let t = random_picture(w, h, &mut next);
            let m = label(&t.bits);
            for shift in [2, 3] {
                let r = Reach::build(&m, shift, false);
                let rc = Reach::build(&m, shift, true);
                let (wi, hi) = (w as i64, h as i64);
                let mut shores: Vec<(i64, i64, u32)> = Vec::new();
                for (n, node) in m.nodes.iter().enumerate() {
                    shores.extend(
                        node.border
                            .iter()
                            .map(|&(x, y)| (x as i64, y as i64, n as u32)),
                    );
                }
                for x in 0..wi {
                    shores.extend([(x, -1, FRAME), (x, hi, FRAME)]);
                }
                for y in 0..hi {
                    shores.extend([(-1, y, FRAME), (wi, y, FRAME)]);
                }
                for y in 0..hi {
                    for x in 0..wi {
                        for own in 0..m.nodes.len() as u32 {
                            let truth = shores
                                .iter()
                                .filter(|s| s.2 != own)
                                .map(|s| ((s.0 - x).abs() + (s.1 - y).abs()) as u32)
                                .min()
                                .unwrap_or(u32::MAX);
                            let b = r.bound(x, y, own);
                            assert!(
                                b <= truth,
                                "picture {k} ({x}, {y}) own {own}: {b} > {truth}"
                            );
                            positive += (b > 0) as usize;
                            let cheb = shores
                                .iter()
                                .filter(|s| s.2 != own)
                                .map(|s| (s.0 - x).abs().max((s.1 - y).abs()) as u32)
                                .min()
                                .unwrap_or(u32::MAX);
                            let b = rc.bound(x, y, own);
                            assert!(b <= cheb, "picture {k} ({x}, {y}) own {own}: {b} > {cheb}");
                            positive += (b > 0) as usize;
                        }
                    }
                }
            }
        }
        assert!(positive > 0, "the bound is not always 0");
    }

    /// The two-pass build bounds every block as the breadth-first search does (the same two
    /// least distances, and the same nearest label where it is unique: so the same bound for
    /// every `own`), on random pictures, both block sizes, with and without corners.
    #[test]
    fn reach_two_passes_are_the_breadth_first_search() {
        let mut next = rng(0x2_9a55_u64);
        let mut checked = 0;
        for k in 0..40u32 {
            let (w, h) = (1 + (next() % 150) as u32, 1 + (next() % 150) as u32);
            let t = random_picture(w, h, &mut next);
            let m = label(&t.bits);
            for shift in [2, 3] {
                for corners in [false, true] {
                    let a = Reach::build(&m, shift, corners);
                    let b = Reach::build_bfs(&m, shift, corners);
                    assert_eq!(a.across, b.across);
                    assert_eq!(a.cells.len(), b.cells.len());
                    for (i, (p, q)) in a.cells.iter().zip(&b.cells).enumerate() {
                        assert_eq!((p.1, p.2), (q.1, q.2), "picture {k} block {i}");
                        if p.1 < p.2 {
                            assert_eq!(p.0, q.0, "picture {k} block {i}");
                        }
                        checked += (p.2 < u32::MAX && p.2 > 0) as usize;
                    }
                }
            }
        }
        assert!(
            checked > 100,
            "some blocks have two labels at a distance ({checked})"
        );
    }
}
