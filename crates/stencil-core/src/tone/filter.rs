//! The topological filter: morphological opening and closing by a disc, then removal of specks.
//!
//! Lone pixels and thin spurs would each become an island needing its own bridge; the paper removes
//! them with dilation and erosion before bridging. Morphology extends the image by repeating its edge
//! pixels; speck removal treats material touching the border as the frame (never a speck).

use serde::{Deserialize, Serialize};

use crate::raster::{close, components, open, touches_border, BitGrid, NOT_LABELLED};

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
    pub opened_px: usize,
    /// Cut pixels the closing turned to material.
    pub closed_px: usize,
    /// Material specks (pieces not joined to the frame) removed, and their pixels.
    pub material_specks: usize,
    pub material_speck_px: usize,
    /// Cut specks filled, and their pixels.
    pub cut_specks: usize,
    pub cut_speck_px: usize,
}

/// Apply opening, closing and speck removal. O(pixels) whatever the radius.
pub fn filter(bits: &BitGrid, cfg: &FilterConfig) -> (BitGrid, FilterStats) {
    let mut stats = FilterStats::default();
    let mut out = bits.clone();
    if cfg.radius > 0 {
        let opened = open(&out, cfg.radius);
        stats.opened_px = diff(&out, &opened);
        let closed = close(&opened, cfg.radius);
        stats.closed_px = diff(&opened, &closed);
        out = closed;
    }
    if cfg.min_speck_px > 1 {
        // Material specks: pieces not tied to the frame.
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
        // Cut specks: any small cut piece, at the border or not.
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

fn diff(a: &BitGrid, b: &BitGrid) -> usize {
    a.data.iter().zip(&b.data).filter(|(x, y)| x != y).count()
}

#[cfg(test)]
mod tests {
    use super::*;

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
