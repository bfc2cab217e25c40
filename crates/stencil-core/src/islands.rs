//! Stage 2: label the material into the frame and islands; find each island's border pixels.
//!
//! Connectivity is 4-connected: two material pixels that touch only at a corner are *not* joined,
//! because a corner has no width and would tear. The sheet continues beyond the image, so every
//! material region that touches the image border belongs to the frame (node 0).

use rayon::prelude::*;

use crate::raster::{join, join_runs, root, runs_of, BitGrid, NOT_LABELLED};

/// Label of a cut pixel in [`IslandMap::labels`]: the pixels `components` of the material leaves
/// unlabelled.
pub const CUT: u32 = NOT_LABELLED;
/// The frame's node id.
pub(crate) const FRAME: u32 = 0;

/// One node of the bridge graph: the frame (id 0) or an island.
#[derive(Clone, Debug, Default)]
pub struct Node {
    /// Material pixels in this node.
    pub(crate) area: usize,
    /// Material pixels of this node with a 4-neighbour cut pixel inside the image, in scan order.
    /// These are the bridge candidates. Ordering along the contour is the bridge stage's business.
    pub border: Vec<(u32, u32)>,
}

/// A label per pixel (frame = 0, islands 1..=n, cut = [`CUT`]) and per node its area and border.
#[derive(Clone, Debug)]
pub struct IslandMap {
    pub(crate) width: u32,
    pub(crate) height: u32,
    /// Per pixel, row by row: its node, or [`CUT`].
    pub labels: Vec<u32>,
    /// `nodes[0]` is the frame (possibly of area 0 when no material touches the image border).
    pub nodes: Vec<Node>,
}

impl IslandMap {
    /// Number of islands (nodes other than the frame).
    pub fn island_count(&self) -> usize {
        self.nodes.len() - 1
    }

    #[inline]
    pub(crate) fn label(&self, x: u32, y: u32) -> u32 {
        self.labels[y as usize * self.width as usize + x as usize]
    }

    /// The pixels of island `node` (not the frame) as runs along rows, `(y, x0, x1)` with `x0..=x1`
    /// inclusive, in scan order, from its border alone. An island never touches the image's edge, so
    /// both ends of each run are border pixels, and between two of its border pixels that follow each
    /// other along a row the pixels are all its own or none: the label right of the first says which.
    pub(crate) fn island_runs(&self, node: usize) -> Vec<(u32, u32, u32)> {
        let b = &self.nodes[node].border;
        let w = self.width as usize;
        let mut runs = Vec::new();
        let mut k = 0;
        while k < b.len() {
            let (x0, y) = b[k];
            let mut x1 = x0;
            while k + 1 < b.len()
                && b[k + 1].1 == y
                && (b[k + 1].0 == x1 + 1
                    || self.labels[y as usize * w + x1 as usize + 1] == node as u32)
            {
                x1 = b[k + 1].0;
                k += 1;
            }
            runs.push((y, x0, x1));
            k += 1;
        }
        runs
    }
}

/// Label material pixels 4-connected into the frame (everything touching the image border) and
/// islands numbered from 1 in scan order. O(pixels): the material's runs joined into pieces
/// (`join_runs`, as `components` does), each piece's node found from its runs (a piece is the
/// frame when one of its runs touches the image's edge), then the labels written and the border
/// pixels found row by row, in parallel bands: the labels once, straight as nodes (labelling the
/// pieces, then renumbering them, wrote every label twice).
///
/// ```
/// use stencil_core::{islands, raster::BitGrid};
/// // `#` is material: the frame, a ring of cut, and an island in it.
/// let bits = BitGrid::from_rows(&["#####", "#...#", "#.#.#", "#...#", "#####"]);
/// assert_eq!(islands::label(&bits).nodes.len(), 2); // the frame and the island
/// assert_eq!(islands::floating_count(&bits), 1);
/// ```
pub fn label(bits: &BitGrid) -> IslandMap {
    let (w, h) = (bits.width as usize, bits.height as usize);
    let mut nodes = vec![Node::default()];
    if w == 0 || h == 0 {
        return IslandMap {
            width: bits.width,
            height: bits.height,
            labels: Vec::new(),
            nodes,
        };
    }
    let (runs, row_first) = runs_of(bits, true);
    let (piece, count) = join_runs(&runs, &row_first, false);
    let mut areas = vec![0usize; count];
    let mut edge = vec![false; count];
    for (r, &p) in runs.iter().zip(&piece) {
        areas[p as usize] += (r.x1 - r.x0 + 1) as usize;
        if r.y == 0 || r.y as usize + 1 == h || r.x0 == 0 || r.x1 as usize + 1 == w {
            edge[p as usize] = true;
        }
    }
    // Piece -> node id: pieces touching the edge merge into the frame, the others are islands in
    // the order of their first pixel.
    let mut remap = vec![FRAME; count];
    for (c, &area) in areas.iter().enumerate() {
        if edge[c] {
            nodes[0].area += area;
        } else {
            remap[c] = nodes.len() as u32;
            nodes.push(Node {
                area,
                border: Vec::new(),
            });
        }
    }

    // Labels and border pixels (material with a cut 4-neighbour inside the image, read from the
    // bits, a quarter of the labels' bytes), a band of rows at a time; the border pixels are
    // handed to their nodes band after band, so each node's stay in scan order.
    const BAND: usize = 64;
    let d = &bits.data;
    // Filled with CUT by both threads as it is made (a zeroed vector was a serial 4 MB memset
    // on the 1 MP photo, then written again band by band); the bands write the runs' labels.
    let mut labels: Vec<u32> = rayon::iter::repeat_n(CUT, w * h).collect();
    let found: Vec<Vec<(u32, u32, u32)>> = labels
        .par_chunks_mut(w * BAND)
        .enumerate()
        .map(|(band, rows)| {
            let mut found = Vec::new();
            for (k, lab) in rows.chunks_mut(w).enumerate() {
                let y = band * BAND + k;
                for r in row_first[y]..row_first[y + 1] {
                    let (x0, x1) = (runs[r].x0 as usize, runs[r].x1 as usize);
                    lab[x0..=x1].fill(remap[piece[r] as usize]);
                }
                let row = &d[y * w..(y + 1) * w];
                let up = (y > 0).then(|| &d[(y - 1) * w..y * w]);
                let down = (y + 1 < h).then(|| &d[(y + 1) * w..(y + 2) * w]);
                for run in &runs[row_first[y]..row_first[y + 1]] {
                    for x in run.x0 as usize..=run.x1 as usize {
                        let cut_next = (x > 0 && !row[x - 1])
                            || (x + 1 < w && !row[x + 1])
                            || up.is_some_and(|u| !u[x])
                            || down.is_some_and(|dn| !dn[x]);
                        if cut_next {
                            found.push((x as u32, y as u32, lab[x]));
                        }
                    }
                }
            }
            found
        })
        .collect();
    for (x, y, n) in found.into_iter().flatten() {
        nodes[n as usize].border.push((x, y));
    }

    IslandMap {
        width: bits.width,
        height: bits.height,
        labels,
        nodes,
    }
}

/// [`label`] as first written (label the pieces, mark those touching the edge, renumber, then
/// a pass for the border pixels): the reference the tests compare it with.
#[cfg(test)]
fn label_reference(bits: &BitGrid) -> IslandMap {
    use crate::raster::{components, touches_border};
    let (w, h) = (bits.width as usize, bits.height as usize);
    let (mut labels, areas) = components(bits, true);
    let mut nodes = vec![Node::default()];
    if w > 0 && h > 0 {
        let border = touches_border(&labels, bits.width, bits.height, areas.len());
        let mut remap = vec![FRAME; areas.len()];
        for (c, &area) in areas.iter().enumerate() {
            if border[c] {
                nodes[0].area += area;
            } else {
                remap[c] = nodes.len() as u32;
                nodes.push(Node {
                    area,
                    border: Vec::new(),
                });
            }
        }
        for l in labels.iter_mut() {
            if *l != CUT {
                *l = remap[*l as usize];
            }
        }
    }
    let d = &bits.data;
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !d[i] {
                continue;
            }
            let cut_next = (x > 0 && !d[i - 1])
                || (x + 1 < w && !d[i + 1])
                || (y > 0 && !d[i - w])
                || (y + 1 < h && !d[i + w]);
            if cut_next {
                nodes[labels[i] as usize].border.push((x as u32, y as u32));
            }
        }
    }
    IslandMap {
        width: bits.width,
        height: bits.height,
        labels,
        nodes,
    }
}

/// The map of the same bits with the islands `gone[n]` turned into cut: their pixels become
/// [`CUT`] and the islands left are numbered anew in the same order. What [`label`] of those bits
/// gives, without labelling again: an island's pixels have no material 4-neighbour but its own
/// (else it would be part of that piece), so removing it changes no other node's area or border,
/// and the islands left keep their order (that of their first pixels). The frame is never gone.
pub(crate) fn without(mut map: IslandMap, gone: &[bool]) -> IslandMap {
    let is_gone = |n: usize| n != FRAME as usize && gone.get(n).copied().unwrap_or(false);
    let Some(first) = (0..map.nodes.len()).find(|&n| is_gone(n)) else {
        return map;
    };
    // Only the islands from the first one gone on change number (or go): their labels are
    // rewritten over their runs, so the cost is their area, not the picture's (the frame and the
    // islands before keep theirs). The runs are found before any label changes.
    let runs: Vec<Vec<(u32, u32, u32)>> = (first..map.nodes.len())
        .map(|n| map.island_runs(n))
        .collect();
    let mut renumber = vec![CUT; map.nodes.len()];
    let mut nodes = Vec::with_capacity(map.nodes.len());
    for (n, node) in std::mem::take(&mut map.nodes).into_iter().enumerate() {
        if !is_gone(n) {
            renumber[n] = nodes.len() as u32;
            nodes.push(node);
        }
    }
    let w = map.width as usize;
    for (rs, &l) in runs.iter().zip(&renumber[first..]) {
        for &(y, x0, x1) in rs {
            let row = y as usize * w;
            map.labels[row + x0 as usize..=row + x1 as usize].fill(l);
        }
    }
    map.nodes = nodes;
    map
}

/// Material pieces not joined to the frame: the number that must be 0 for a valid stencil.
/// Counted from the material's runs and their pieces alone, without a label per pixel (the pieces
/// `components` would label): a piece is joined when one of its runs touches the image border.
pub fn floating_count(bits: &BitGrid) -> usize {
    if bits.width == 0 || bits.height == 0 {
        return 0;
    }
    let (runs, row_first) = runs_of(bits, true);
    let (piece, count) = join_runs(&runs, &row_first, false);
    let (w, h) = (bits.width, bits.height);
    let mut joined = vec![false; count];
    for (r, &p) in runs.iter().zip(&piece) {
        if r.y == 0 || r.y + 1 == h || r.x0 == 0 || r.x1 + 1 == w {
            joined[p as usize] = true;
        }
    }
    joined.iter().filter(|&&t| !t).count()
}

/// [`floating_count`] of `after`, a grid that only added material to `before` (`map` being
/// [`label`] of `before`), from the added pixels alone: a union-find over `map`'s nodes and the
/// added pixels, a piece being joined when it holds the frame or an added pixel on the border.
/// O(pixels) for one comparison, then O(added pixels). When `after` lacks a pixel of `before`'s
/// material, the whole grid is counted.
pub(crate) fn floating_after_adding(map: &IslandMap, before: &BitGrid, after: &BitGrid) -> usize {
    let n = before.data.len();
    let (w, h) = (after.width as usize, after.height as usize);
    if after.data.len() != n || map.labels.len() != n || w == 0 || h == 0 {
        return floating_count(after);
    }
    // The added pixels in raster order; runs of 64 pixels where the grids agree are skipped by
    // one test.
    const RUN: usize = 64;
    let mut added: Vec<u32> = Vec::new();
    for run in (0..n).step_by(RUN) {
        let end = (run + RUN).min(n);
        let (a, b) = (&after.data[run..end], &before.data[run..end]);
        if a == b {
            continue;
        }
        for (k, (&a, &b)) in a.iter().zip(b).enumerate() {
            if b && !a {
                return floating_count(after);
            }
            if a && !b {
                added.push((run + k) as u32);
            }
        }
    }
    let nodes = map.nodes.len();
    let mut parent: Vec<u32> = (0..(nodes + added.len()) as u32).collect();
    // The added pixel above the current one, if added, is found by a cursor that follows a row
    // behind (the pixels above rise with the current one).
    let mut up = 0;
    for (k, &i) in added.iter().enumerate() {
        let i = i as usize;
        let id = nodes + k;
        if i >= w {
            while (added[up] as usize) < i - w {
                up += 1;
            }
        }
        let (x, y) = (i % w, i / w);
        if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
            join(&mut parent, id, FRAME as usize);
        }
        for j in crate::raster::edge_neighbours(i, w, h)
            .into_iter()
            .flatten()
        {
            if before.data[j] {
                let l = map.labels[j];
                if l == CUT || l as usize >= nodes {
                    // The map does not describe `before`.
                    return floating_count(after);
                }
                join(&mut parent, id, l as usize);
            } else if after.data[j] {
                // An added pixel: joined once, from the later of the two (the one to the left
                // is the previous added pixel, the one above is at the cursor).
                if j + 1 == i {
                    join(&mut parent, id, id - 1);
                } else if j + w == i {
                    join(&mut parent, id, nodes + up);
                }
            }
        }
    }
    let frame = root(&mut parent, FRAME as usize);
    let mut seen = vec![false; parent.len()];
    let mut count = 0;
    // Every island node (the frame's pieces are joined by definition) and every added pixel.
    for id in 1..parent.len() {
        let r = root(&mut parent, id);
        if r != frame && !seen[r] {
            seen[r] = true;
            count += 1;
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Lcg;

    /// A cut ring around an island, and a horizontal bridge `w` px wide from the island's right
    /// side (x = 130) to the cut's right edge (x = 160), centred on y = 80.
    fn bridged(w: u32) -> BitGrid {
        let rect = |x0, y0, x1, y1| move |x, y| x >= x0 && x < x1 && y >= y0 && y < y1;
        let cut = rect(40, 30, 160, 130);
        let island = rect(70, 60, 130, 100);
        let bridge = rect(130, 80 - w / 2, 160, 80 - w / 2 + w);
        BitGrid::from_fn(200, 160, |x, y| !cut(x, y) || island(x, y) || bridge(x, y))
    }

    #[test]
    fn opening_by_half_the_width_floats_the_island_of_a_thinner_bridge() {
        // Opening by half a 10 px width removes the 6 px bridge, keeps the 12 px one.
        for (w, floats) in [(6, true), (12, false)] {
            let opened = crate::raster::open(&bridged(w), 5);
            assert_eq!(label(&opened).island_count() > 0, floats, "bridge {w} px");
        }
    }

    #[test]
    fn frame_and_one_island() {
        let g = BitGrid::from_rows(&["#####", "#...#", "#.#.#", "#...#", "#####"]);
        let m = label(&g);
        assert_eq!(m.island_count(), 1);
        assert_eq!(m.nodes[0].area, 16);
        assert_eq!(m.nodes[1].area, 1);
        assert_eq!(m.label(2, 2), 1);
        assert_eq!(m.label(1, 1), CUT);
    }

    #[test]
    fn corner_touch_is_not_joined() {
        // The two inner pixels touch only at a corner: two islands, not one.
        let g = BitGrid::from_rows(&["######", "#....#", "#.#..#", "#..#.#", "#....#", "######"]);
        assert_eq!(label(&g).island_count(), 2);
    }

    #[test]
    fn material_touching_border_is_frame_even_if_split() {
        // Two separate pieces touch the border: both are the frame (the sheet continues outside).
        let g = BitGrid::from_rows(&["#...#", ".....", "#...#"]);
        let m = label(&g);
        assert_eq!(m.island_count(), 0);
        assert_eq!(m.nodes[0].area, 4);
    }

    #[test]
    fn border_pixels_are_material_next_to_cut() {
        let g = BitGrid::from_rows(&[
            "#######", "#.....#", "#.###.#", "#.###.#", "#.###.#", "#.....#", "#######",
        ]);
        let m = label(&g);
        assert_eq!(m.island_count(), 1);
        // 3x3 island: 8 border pixels, the centre is interior.
        assert_eq!(m.nodes[1].border.len(), 8);
        assert!(!m.nodes[1].border.contains(&(3, 3)));
    }

    #[test]
    fn all_cut_and_all_material() {
        assert_eq!(label(&BitGrid::new(4, 3, false)).island_count(), 0);
        let m = label(&BitGrid::new(4, 3, true));
        assert_eq!(m.island_count(), 0);
        assert_eq!(m.nodes[0].area, 12);
    }

    /// A random grid: material with probability `p` %.
    fn random(w: u32, h: u32, p: u32, rng: &mut Lcg) -> BitGrid {
        BitGrid::from_fn(w, h, |_, _| rng.below(100) < p as u64)
    }

    /// The count from runs agrees with the labelling's on random grids.
    #[test]
    fn floating_count_is_the_labelled_island_count() {
        let mut seed = Lcg(0x9e37_79b9_7f4a_7c15);
        for k in 0..200 {
            let g = random(1 + k % 37, 1 + (k * 7) % 29, 30 + k % 50, &mut seed);
            assert_eq!(floating_count(&g), label(&g).island_count(), "grid {k}");
        }
    }

    /// The labelling agrees with the one first written (labels, areas, borders in order) on
    /// random grids, thin and tall ones included (bands of rows end mid-grid).
    #[test]
    fn label_is_the_reference_labelling() {
        let mut seed = Lcg(0x0bad_cafe_dead_beef);
        for k in 0..120u32 {
            let (w, h) = (1 + k % 47, 1 + (k * 13) % 151);
            let g = random(w, h, 20 + k % 60, &mut seed);
            let (a, b) = (label(&g), label_reference(&g));
            assert_eq!(a.labels, b.labels, "grid {k}");
            assert_eq!(a.nodes.len(), b.nodes.len(), "grid {k}");
            for (na, nb) in a.nodes.iter().zip(&b.nodes) {
                assert_eq!((na.area, &na.border), (nb.area, &nb.border), "grid {k}");
            }
        }
        let empty = label(&BitGrid::new(0, 0, false));
        assert_eq!((empty.labels.len(), empty.nodes.len()), (0, 1));
    }

    /// An island's runs found from its border are the runs of its label in the labels, on
    /// random grids of every density.
    #[test]
    fn island_runs_are_the_runs_of_its_label() {
        let mut seed = Lcg(0x5151_7e57_0f0f_1234);
        let mut islands = 0;
        for k in 0..200u32 {
            let g = random(3 + k % 43, 3 + (k * 7) % 37, 25 + k % 50, &mut seed);
            let map = label(&g);
            let w = map.width as usize;
            for n in 1..map.nodes.len() {
                let mut plain = Vec::new();
                for (y, row) in map.labels.chunks(w).enumerate() {
                    let mut x = 0;
                    while x < w {
                        if row[x] != n as u32 {
                            x += 1;
                            continue;
                        }
                        let x0 = x;
                        while x < w && row[x] == n as u32 {
                            x += 1;
                        }
                        plain.push((y as u32, x0 as u32, x as u32 - 1));
                    }
                }
                assert_eq!(map.island_runs(n), plain, "grid {k} island {n}");
                islands += 1;
            }
        }
        assert!(islands > 500, "the grids have islands ({islands})");
    }

    /// Removing islands from a map gives the map of the bits without them, labels, areas and
    /// borders alike.
    #[test]
    fn without_is_labelling_the_bits_without_the_islands() {
        let mut seed = Lcg(0x1234_5678_9abc_def1);
        for k in 0..200 {
            let mut g = random(2 + k % 41, 2 + (k * 5) % 31, 35 + k % 40, &mut seed);
            let map = label(&g);
            let gone: Vec<bool> = (0..map.nodes.len())
                .map(|n| n > 0 && (n * 7 + k as usize).is_multiple_of(3))
                .collect();
            for (i, &l) in map.labels.iter().enumerate() {
                if l != CUT && gone[l as usize] {
                    g.data[i] = false;
                }
            }
            let (a, b) = (without(map, &gone), label(&g));
            assert_eq!(a.labels, b.labels, "grid {k}");
            assert_eq!(a.nodes.len(), b.nodes.len(), "grid {k}");
            for (na, nb) in a.nodes.iter().zip(&b.nodes) {
                assert_eq!((na.area, &na.border), (nb.area, &nb.border), "grid {k}");
            }
        }
    }
    /// The count from the added pixels is the count of the whole grid: random pictures, random
    /// material added (blobs and scattered pixels, some on the border, some joining islands),
    /// and a grid that lost material (counted whole).
    #[test]
    fn floating_after_adding_is_floating_count() {
        let mut rng = Lcg(0x9e3779b97f4a7c15);
        let mut rnd = move || rng.next_u64() >> 33;
        for case in 0..300 {
            let (w, h) = (1 + rnd() % 40, 1 + rnd() % 40);
            let density = rnd() % 100;
            let before = BitGrid::from_fn(w as u32, h as u32, |_, _| rnd() % 100 < density);
            let map = label(&before);
            let mut after = before.clone();
            let adds = rnd() % (1 + w * h / 3);
            for _ in 0..adds {
                let (x, y) = (rnd() % w, rnd() % h);
                let (bw, bh) = (1 + rnd() % 4, 1 + rnd() % 4);
                for yy in y..(y + bh).min(h) {
                    for xx in x..(x + bw).min(w) {
                        after.set(xx as u32, yy as u32, true);
                    }
                }
            }
            if case % 10 == 9 {
                let i = (rnd() % (w * h)) as usize;
                after.data[i] = false;
            }
            assert_eq!(
                floating_after_adding(&map, &before, &after),
                floating_count(&after),
                "case {case}: {w}x{h}"
            );
        }
    }
}
