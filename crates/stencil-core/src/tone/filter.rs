//! The topological filter: morphological opening and closing by a disc, then removal of specks.
//!
//! Lone pixels and thin spurs would each become an island needing its own bridge; the paper removes
//! them with dilation and erosion before bridging. Morphology extends the image by repeating its edge
//! pixels; speck removal treats material touching the border as the frame (never a speck).

use serde::{Deserialize, Serialize};

use crate::raster::packed::{close, open, Packed};
use crate::raster::{join_runs, push_runs, BitGrid, Run};

/// Options of the topological filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterConfig {
    /// Disc radius in pixels of the opening and closing; 0 turns them off. An opening removes
    /// material thinner than about 2·r, a closing fills cuts thinner than about 2·r.
    pub radius: u32,
    /// Connected pieces (material or cut) smaller than this many pixels flip to the other tone.
    pub min_speck_px: usize,
    /// Whether the pipeline may raise `radius` to what the material's smallest feature needs.
    /// False when the user set the radius explicitly: their value is used as given.
    pub auto_radius: bool,
}

impl Default for FilterConfig {
    fn default() -> Self {
        FilterConfig {
            radius: 1,
            min_speck_px: 8,
            auto_radius: true,
        }
    }
}

/// What the filter changed, for the report.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub struct FilterStats {
    /// Material pixels the opening turned to cut.
    pub(crate) opened_px: usize,
    /// Cut pixels the closing turned to material.
    pub(crate) closed_px: usize,
    /// Material specks (pieces not joined to the frame) removed, and their pixels.
    pub(crate) material_specks: usize,
    pub(crate) material_speck_px: usize,
    /// Cut specks filled, and their pixels.
    pub(crate) cut_specks: usize,
    pub(crate) cut_speck_px: usize,
}

/// Apply opening, closing and speck removal. O(pixels) whatever the radius: on packed bits (64
/// pixels a word), the specks found as runs along rows joined into pieces, with no label image.
pub(crate) fn filter(bits: &BitGrid, cfg: &FilterConfig) -> (BitGrid, FilterStats) {
    let mut stats = FilterStats::default();
    if bits.is_empty() {
        return (bits.clone(), stats);
    }
    let mut out = Packed::from_grid(bits);
    if cfg.radius > 0 {
        let opened = open(&out, cfg.radius);
        stats.opened_px = out.count_diff(&opened);
        let closed = close(&opened, cfg.radius);
        stats.closed_px = opened.count_diff(&closed);
        out = closed;
    }
    if cfg.min_speck_px > 1 {
        // Material specks: pieces not tied to the frame.
        (stats.material_specks, stats.material_speck_px) =
            flip_small(&mut out, true, cfg.min_speck_px, true);
        // Cut specks: any small cut piece, at the border or not.
        (stats.cut_specks, stats.cut_speck_px) =
            flip_small(&mut out, false, cfg.min_speck_px, false);
    }
    (out.to_grid(), stats)
}

/// Flip the 4-connected pieces of pixels equal to `value` smaller than `min_px` (and, when
/// `spare_border`, not touching the image border) to the other tone. Returns how many pieces
/// and pixels flipped.
fn flip_small(bits: &mut Packed, value: bool, min_px: usize, spare_border: bool) -> (usize, usize) {
    let (w, h) = (bits.width, bits.height);
    let mut runs: Vec<Run> = Vec::new();
    let mut row_first = Vec::with_capacity(h + 1);
    for y in 0..h {
        row_first.push(runs.len());
        push_runs(y as u32, bits.row_where(y, value), &mut runs);
    }
    row_first.push(runs.len());
    let (piece, count) = join_runs(&runs, &row_first, false);
    let mut area = vec![0usize; count];
    let mut border = vec![false; count];
    for (r, &p) in runs.iter().zip(&piece) {
        area[p as usize] += (r.x1 - r.x0 + 1) as usize;
        border[p as usize] |=
            r.y == 0 || r.y as usize == h - 1 || r.x0 == 0 || r.x1 as usize == w - 1;
    }
    let small: Vec<bool> = area
        .iter()
        .zip(&border)
        .map(|(&a, &b)| a < min_px && !(spare_border && b))
        .collect();
    let stride = bits.stride;
    for (r, &p) in runs.iter().zip(&piece) {
        if small[p as usize] {
            let row = &mut bits.words[r.y as usize * stride..][..stride];
            for x in r.x0 as usize..=r.x1 as usize {
                row[x / 64] ^= 1 << (x % 64);
            }
        }
    }
    let pieces = small.iter().filter(|&&s| s).count();
    let px = area
        .iter()
        .zip(&small)
        .filter(|(_, &s)| s)
        .map(|(a, _)| a)
        .sum();
    (pieces, px)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::morph::tests::{close_edt, open_edt};
    use crate::raster::{components, touches_border, NOT_LABELLED};
    use crate::test_rng::Lcg;

    /// The filter as it was: distance-transform morphology and a label image per tone.
    fn filter_ref(bits: &BitGrid, cfg: &FilterConfig) -> (BitGrid, FilterStats) {
        let diff =
            |a: &BitGrid, b: &BitGrid| a.data.iter().zip(&b.data).filter(|(x, y)| x != y).count();
        let mut stats = FilterStats::default();
        let mut out = bits.clone();
        if cfg.radius > 0 {
            let opened = open_edt(&out, cfg.radius);
            stats.opened_px = diff(&out, &opened);
            let closed = close_edt(&opened, cfg.radius);
            stats.closed_px = diff(&opened, &closed);
            out = closed;
        }
        if cfg.min_speck_px > 1 {
            let (labels, areas) = components(&out, true);
            let border = touches_border(&labels, out.width, out.height, areas.len());
            let small: Vec<bool> = areas
                .iter()
                .zip(&border)
                .map(|(&a, &b)| !b && a < cfg.min_speck_px)
                .collect();
            for (i, l) in labels.iter().enumerate() {
                if *l != NOT_LABELLED && small[*l as usize] {
                    out.data[i] = false;
                    stats.material_speck_px += 1;
                }
            }
            stats.material_specks = small.iter().filter(|&&s| s).count();
            let (labels, areas) = components(&out, false);
            let small: Vec<bool> = areas.iter().map(|&a| a < cfg.min_speck_px).collect();
            for (i, l) in labels.iter().enumerate() {
                if *l != NOT_LABELLED && small[*l as usize] {
                    out.data[i] = true;
                    stats.cut_speck_px += 1;
                }
            }
            stats.cut_specks = small.iter().filter(|&&s| s).count();
        }
        (out, stats)
    }

    #[test]
    fn equals_the_distance_transform_and_label_form() {
        let mut rng = Lcg(99u64);
        let mut next = move || (rng.next_u64() >> 33) as u32;
        for (w, h) in [(1, 1), (7, 3), (64, 40), (65, 65), (150, 90)] {
            for density in [5, 40, 50, 60, 95] {
                // Noise, and blocky noise (pieces of many sizes).
                for block in [1, 3, 8] {
                    let cells: Vec<bool> = (0..w * h).map(|_| next() % 100 < density).collect();
                    let g = BitGrid::from_fn(w, h, |x, y| {
                        cells[((y / block) * w + x / block) as usize]
                    });
                    for (radius, min_speck_px) in [(0, 8), (1, 8), (2, 1), (3, 30), (5, 4)] {
                        let cfg = FilterConfig {
                            radius,
                            min_speck_px,
                            auto_radius: false,
                        };
                        assert_eq!(
                            filter(&g, &cfg),
                            filter_ref(&g, &cfg),
                            "{w}x{h} {density}% block {block} {cfg:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn specks_flip_and_are_counted() {
        let g = BitGrid::from_rows(&[
            "##########",
            "#........#",
            "#.#......#",
            "#........#",
            "#....#####",
            "#....#.###",
            "##########",
        ]);
        let (f, s) = filter(
            &g,
            &FilterConfig {
                radius: 0,
                min_speck_px: 4,
                auto_radius: false,
            },
        );
        assert_eq!(s.material_specks, 1);
        assert_eq!(s.cut_specks, 1);
        assert!(!f.get(2, 2));
        assert!(f.get(6, 5));
    }
}
