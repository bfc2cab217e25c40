//! Marching squares on the stencil bits: closed rings with material on their left.
//!
//! The samples are the pixel centres, padded with one ring of material (the frame, as in
//! `islands`), so the rings separate material from cut exactly as the raster does. Each crossing
//! sits where a 3×3 box blur of the bits crosses one half, clamped to `[0.35, 0.65]` of the way
//! between the centres: a straight edge stays on the pixel boundary (a neck N pixels wide measures
//! N), staircases are smoothed, and no pixel's coverage passes one half. Saddles separate the two
//! material corners (material is 4-connected, as in `islands::label`). Material outlines have
//! positive shoelace area in the (x, y) plane, holes negative.

use rayon::prelude::*;

use crate::raster::BitGrid;

/// A closed ring in pixel coordinates (x right, y down; pixel (i, j) covers `[i, i+1] × [j, j+1]`),
/// without a repeated closing point.
#[derive(Clone, Debug)]
pub struct Ring {
    /// Its points, in order.
    pub pts: Vec<[f64; 2]>,
    /// Per point, the centres of the material and the cut pixel it lies between: simplification
    /// keeps each on its own side, so the outline still samples to the same raster.
    pub guards: Vec<Guard>,
    /// A material pixel just left of the ring (outside the image = the frame): which material
    /// piece the ring bounds. Only the tests read it, to check the tracing's orientation.
    #[cfg(test)]
    pub(crate) material_px: (i64, i64),
}

/// The two pixel centres (material, cut) on either side of a ring point, in pixel coordinates.
pub type Guard = [[f64; 2]; 2];

/// Smallest and largest fraction of the way from the material centre to the cut centre.
const CLAMP: (f64, f64) = (0.35, 0.65);

struct Padded<'a> {
    bits: &'a BitGrid,
    wp: usize,
    hp: usize,
}

impl Padded<'_> {
    #[inline]
    fn at(&self, px: usize, py: usize) -> bool {
        if px == 0 || py == 0 || px + 1 == self.wp || py + 1 == self.hp {
            true
        } else {
            self.bits.data[(py - 1) * self.bits.width as usize + px - 1]
        }
    }

    fn inside(&self, px: usize, py: usize) -> bool {
        !(px == 0 || py == 0 || px + 1 == self.wp || py + 1 == self.hp)
    }

    /// 3×3 box blur of the bits at a padded centre (outside the image counts as material).
    fn blur(&self, px: usize, py: usize) -> f64 {
        let (w, h) = (self.bits.width as usize, self.bits.height as usize);
        if px >= 2 && py >= 2 && px < w && py < h {
            // Wholly inside the image: index the rows directly.
            let d = &self.bits.data;
            let n: u32 = (py - 2..=py)
                .map(|y| {
                    d[y * w + px - 2..=y * w + px]
                        .iter()
                        .map(|&b| b as u32)
                        .sum::<u32>()
                })
                .sum();
            return n as f64 / 9.0;
        }
        let (x, y) = (px as i64 - 1, py as i64 - 1);
        let mut n = 0;
        for dy in -1..=1 {
            for dx in -1..=1 {
                if self.bits.get_or_frame(x + dx, y + dy) {
                    n += 1;
                }
            }
        }
        n as f64 / 9.0
    }

    /// The crossing on edge `id` in pixel coordinates, the material centre (padded coords), and
    /// the material and cut centres in pixel coordinates.
    fn crossing(&self, id: usize, smooth: bool) -> ([f64; 2], (usize, usize), Guard) {
        let n = self.wp * self.hp;
        let (a, b) = if id < n {
            let (px, py) = (id % self.wp, id / self.wp);
            ((px, py), (px + 1, py))
        } else {
            let id = id - n;
            let (px, py) = (id % self.wp, id / self.wp);
            ((px, py), (px, py + 1))
        };
        let a_mat = self.at(a.0, a.1);
        let (m, c) = if a_mat { (a, b) } else { (b, a) };
        let mut s = 0.5;
        if smooth && self.inside(m.0, m.1) && self.inside(c.0, c.1) {
            let (fm, fc) = (self.blur(m.0, m.1), self.blur(c.0, c.1));
            if fm > fc {
                s = ((fm - 0.5) / (fm - fc)).clamp(CLAMP.0, CLAMP.1);
            }
        }
        let t = if a_mat { s } else { 1.0 - s };
        let ca = [a.0 as f64 - 0.5, a.1 as f64 - 0.5];
        let cb = [b.0 as f64 - 0.5, b.1 as f64 - 0.5];
        let guard = if a_mat { [ca, cb] } else { [cb, ca] };
        (
            [ca[0] + t * (cb[0] - ca[0]), ca[1] + t * (cb[1] - ca[1])],
            m,
            guard,
        )
    }
}

/// Trace every boundary between material and cut. `smooth` places crossings by the blurred bits
/// (see the module doc); without it every crossing is at the midpoint between centres. Cells are
/// classified in parallel bands, chained into rings in one sequential walk, then placed in
/// parallel: the same rings, order and starts as one row-major pass.
pub fn trace(bits: &BitGrid, smooth: bool) -> Vec<Ring> {
    // Rows of cells per band: a few bands per thread, so uneven bands still balance.
    let band = (bits.height as usize + 1)
        .div_ceil(4 * rayon::current_num_threads())
        .max(16);
    trace_in_bands(bits, smooth, band)
}

/// [`trace`] with the cells classified in bands of `band` rows (any size gives the same rings).
fn trace_in_bands(bits: &BitGrid, smooth: bool, band: usize) -> Vec<Ring> {
    let (wp, hp) = (bits.width as usize + 2, bits.height as usize + 2);
    let g = Padded { bits, wp, hp };
    let n = wp * hp;
    let band = band.max(1);
    let links: Vec<Vec<(u32, u32)>> = (0..hp - 1)
        .into_par_iter()
        .step_by(band)
        .map(|py0| g.links(py0..(py0 + band).min(hp - 1)))
        .collect();
    // The crossings, numbered densely: every crossing is the exit of exactly one link, so the
    // exits number them all; next[k] is the crossing the contour goes to from crossing k.
    let index = CrossingIndex::new(2 * n, links.iter().flatten().map(|&(exit, _)| exit));
    // Per link, in parallel: the dense numbers of its exit and entry (the walk then reads plain
    // arrays only), in row-major order.
    let numbered: Vec<(u32, u32, u32)> = links
        .par_iter()
        .flat_map_iter(|band| {
            band.iter()
                .map(|&(exit, entry)| (index.of(exit) as u32, index.of(entry) as u32, exit))
        })
        .collect();
    let mut next = vec![u32::MAX; index.len()];
    let mut edge = vec![0u32; index.len()];
    for &(kx, ke, exit) in &numbered {
        next[kx as usize] = ke;
        edge[kx as usize] = exit;
    }
    let mut chains: Vec<Vec<u32>> = Vec::new();
    for &(ks, _, _) in &numbered {
        if next[ks as usize] == u32::MAX {
            continue;
        }
        let mut chain = Vec::new();
        let mut k = ks as usize;
        while next[k] != u32::MAX {
            let nk = next[k];
            next[k] = u32::MAX;
            chain.push(edge[k]);
            k = nk as usize;
        }
        chains.push(chain);
    }
    chains
        .par_iter()
        .map(|chain| {
            #[cfg(test)]
            let (_, m, _) = g.crossing(chain[0] as usize, smooth);
            let mut pts = Vec::with_capacity(chain.len());
            let mut guards = Vec::with_capacity(chain.len());
            for &e in chain {
                let (p, _, guard) = g.crossing(e as usize, smooth);
                pts.push(p);
                guards.push(guard);
            }
            Ring {
                pts,
                guards,
                #[cfg(test)]
                material_px: (m.0 as i64 - 1, m.1 as i64 - 1),
            }
        })
        .collect()
}

impl Padded<'_> {
    /// Padded row `py` of the bits into `row`.
    fn row(&self, py: usize, row: &mut [bool]) {
        if py == 0 || py + 1 == self.hp {
            row.fill(true);
        } else {
            // An image row framed by material on both sides.
            let w = self.bits.width as usize;
            row[0] = true;
            row[w + 1] = true;
            row[1..=w].copy_from_slice(&self.bits.data[(py - 1) * w..py * w]);
        }
    }

    /// The contour links (exit crossing, entry crossing it goes to) of the cells in rows `rows`,
    /// in row-major order and, within a cell, in edge order.
    fn links(&self, rows: std::ops::Range<usize>) -> Vec<(u32, u32)> {
        let (wp, n) = (self.wp, self.wp * self.hp);
        let h = |px: usize, py: usize| py * wp + px;
        let v = |px: usize, py: usize| n + py * wp + px;
        let mut out = Vec::new();
        let mut row_a = vec![true; wp];
        let mut row_b = vec![true; wp];
        self.row(rows.start, &mut row_a);
        for py in rows {
            self.row(py + 1, &mut row_b);
            let mut px = 0;
            while px < wp - 1 {
                // Skip runs of cells whose four corners are all alike (most of a stencil), eight
                // cells at a time: corners px ..= px + 8 of both rows equal one value.
                if px + 9 <= wp {
                    let a = u64::from_ne_bytes(bool_bytes(&row_a[px..px + 8]));
                    let b = u64::from_ne_bytes(bool_bytes(&row_b[px..px + 8]));
                    let same = if row_a[px] { 0x0101_0101_0101_0101 } else { 0 };
                    if a == same
                        && b == same
                        && row_a[px + 8] == row_a[px]
                        && row_b[px + 8] == row_a[px]
                    {
                        px += 8;
                        continue;
                    }
                }
                let code = row_a[px] as u8
                    | (row_a[px + 1] as u8) << 1
                    | (row_b[px + 1] as u8) << 2
                    | (row_b[px] as u8) << 3;
                if code == 0 || code == 15 {
                    px += 1;
                    continue;
                }
                let c = [row_a[px], row_a[px + 1], row_b[px + 1], row_b[px]];
                // Cell edges in counter-clockwise order (numerically): top, right, bottom, left;
                // edge k runs from corner k to corner k+1.
                let ids = [h(px, py), v(px + 1, py), h(px, py + 1), v(px, py)];
                for k in 0..4 {
                    let exit = c[k] && !c[(k + 1) % 4];
                    if !exit {
                        continue;
                    }
                    // The entry that opens this exit's material arc: walk back to it. Pairing each
                    // exit with its own arc separates diagonal material corners in a saddle.
                    for back in 1..4 {
                        let j = (k + 4 - back) % 4;
                        if !c[j] && c[(j + 1) % 4] {
                            out.push((ids[k] as u32, ids[j] as u32));
                            break;
                        }
                    }
                }
                px += 1;
            }
            std::mem::swap(&mut row_a, &mut row_b);
        }
        out
    }
}

/// Dense numbers for a sparse set of edge ids: a bitmap over all ids with a running count per
/// 64-bit word (rank). Why: a contour touches few of the grid's 2·(w+2)·(h+2) edges, and an array
/// over all of them costs page faults on every call; this costs one bit per edge.
struct CrossingIndex {
    bits: Vec<u64>,
    rank: Vec<u32>,
}

impl CrossingIndex {
    fn new(ids: usize, members: impl Iterator<Item = u32>) -> Self {
        let mut bits = vec![0u64; ids.div_ceil(64)];
        for m in members {
            bits[m as usize / 64] |= 1 << (m % 64);
        }
        let mut rank = Vec::with_capacity(bits.len() + 1);
        let mut total = 0u32;
        for w in &bits {
            rank.push(total);
            total += w.count_ones();
        }
        rank.push(total);
        CrossingIndex { bits, rank }
    }

    fn len(&self) -> usize {
        *self.rank.last().unwrap_or(&0) as usize
    }

    /// The dense number of member `id`.
    #[inline]
    fn of(&self, id: u32) -> usize {
        let (w, b) = (id as usize / 64, id % 64);
        debug_assert!(self.bits[w] >> b & 1 == 1, "edge {id} is not a crossing");
        (self.rank[w] + (self.bits[w] & ((1u64 << b) - 1)).count_ones()) as usize
    }
}

/// Eight bools as their bytes (a bool is one byte, 0 or 1).
#[inline]
fn bool_bytes(b: &[bool]) -> [u8; 8] {
    let mut out = [0u8; 8];
    for (o, &v) in out.iter_mut().zip(b) {
        *o = v as u8;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use stencil_geom::ring::signed_area2;

    #[test]
    fn a_square_hole_is_one_negative_ring_on_pixel_boundaries() {
        let g = BitGrid::from_rows(&["#####", "#...#", "#...#", "#...#", "#####"]);
        let rings = trace(&g, false);
        assert_eq!(rings.len(), 1);
        let a = signed_area2(&rings[0].pts) / 2.0;
        // Midpoint crossings chamfer each of the 4 corners by 1/8 px: 9 - 4/8.
        assert!((a + 8.5).abs() < 1e-9, "area {a}");
        let xs: Vec<f64> = rings[0].pts.iter().map(|p| p[0]).collect();
        assert!(xs.iter().all(|&x| (1.0 - 1e-9..=4.0 + 1e-9).contains(&x)));
        // Smoothing rounds the corners more but keeps straight runs on the pixel boundary.
        let smooth = trace(&g, true);
        let a = signed_area2(&smooth[0].pts) / 2.0;
        assert!(a > -8.5 && a < -7.0, "area {a}");
        assert!(smooth[0]
            .pts
            .iter()
            .any(|p| (p[0] - 1.0).abs() < 1e-9 && p[1] == 2.5));
    }

    #[test]
    fn an_island_gives_a_positive_ring_inside_a_negative_one() {
        let g = BitGrid::from_rows(&[
            "#######", "#.....#", "#.###.#", "#.###.#", "#.###.#", "#.....#", "#######",
        ]);
        let rings = trace(&g, false);
        assert_eq!(rings.len(), 2);
        let mut areas: Vec<f64> = rings.iter().map(|r| signed_area2(&r.pts) / 2.0).collect();
        areas.sort_by(f64::total_cmp);
        assert!(areas[0] < 0.0 && areas[1] > 0.0, "{areas:?}");
        let island = rings.iter().find(|r| signed_area2(&r.pts) > 0.0).unwrap();
        assert_eq!(island.material_px.0.clamp(2, 4), island.material_px.0);
    }

    #[test]
    fn diagonal_material_stays_two_pieces() {
        // Two material pixels touching at a corner inside a cut region.
        let g = BitGrid::from_rows(&["######", "#....#", "#.#..#", "#..#.#", "#....#", "######"]);
        let rings = trace(&g, true);
        let pos = rings.iter().filter(|r| signed_area2(&r.pts) > 0.0).count();
        assert_eq!(
            pos, 2,
            "corner-touching material must trace as two outlines"
        );
        // And the cut around them is one region (cut joins through the saddle).
        assert_eq!(
            rings.iter().filter(|r| signed_area2(&r.pts) < 0.0).count(),
            1
        );
    }

    #[test]
    fn the_band_size_does_not_change_the_rings() {
        // Rings crossing many band boundaries, saddles included.
        let g = BitGrid::from_fn(37, 41, |x, y| (x * 7 + y * 3) % 11 < 6 || (x + y) % 5 == 0);
        let whole = trace_in_bands(&g, true, 1000);
        for band in [1, 2, 3, 16] {
            let banded = trace_in_bands(&g, true, band);
            assert_eq!(banded.len(), whole.len(), "band {band}");
            for (a, b) in banded.iter().zip(&whole) {
                assert_eq!(a.pts, b.pts, "band {band}");
                assert_eq!(a.guards, b.guards, "band {band}");
                assert_eq!(a.material_px, b.material_px, "band {band}");
            }
        }
    }

    #[test]
    fn cut_touching_the_image_border_closes_along_it() {
        let g = BitGrid::from_rows(&["..##", "..##", "####"]);
        let rings = trace(&g, false);
        assert_eq!(rings.len(), 1);
        let a = signed_area2(&rings[0].pts) / 2.0;
        // 2x2 cut block at the corner: its four convex corners are chamfered by 1/8 px each.
        assert!((a + 3.5).abs() < 1e-9, "area {a}");
    }
}
