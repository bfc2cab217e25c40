//! tiles.png: the whole picture's two-tone, faded, with the seams in red, the overlap each tile
//! keeps past them in pink, the pin holes in blue and each tile's number (its cutting order) at
//! its middle, at most [`MAP_MAX_PX`] wide.

use crate::raster::BitGrid;

use super::seams::Seams;

/// The map's widest side, px.
pub const MAP_MAX_PX: u32 = 1600;

/// Digits 0–9, 3 × 5 pixels each, row by row (bit 2 = left).
const DIGITS: [[u8; 5]; 10] = [
    [7, 5, 5, 5, 7],
    [2, 6, 2, 2, 7],
    [7, 1, 7, 4, 7],
    [7, 1, 7, 1, 7],
    [5, 5, 7, 1, 1],
    [7, 4, 7, 1, 7],
    [7, 4, 7, 5, 7],
    [7, 1, 1, 1, 1],
    [7, 5, 7, 5, 7],
    [7, 5, 7, 1, 7],
];

/// What the map shows, in working pixels of the whole picture.
pub(crate) struct MapRequest<'a> {
    /// The whole cleaned two-tone (material true).
    pub bits: &'a BitGrid,
    /// The seams.
    pub seams: &'a Seams,
    /// The overlap past a seam, px.
    pub overlap_px: u32,
    /// Pin holes' centres.
    pub pins: &'a [(u32, u32)],
    /// Each tile's number and the middle of its region.
    pub labels: &'a [(usize, (u32, u32))],
}

/// The map as RGB, with its size.
pub(crate) fn draw(r: &MapRequest) -> (u32, u32, Vec<u8>) {
    let (w, h) = (r.bits.width, r.bits.height);
    let step = w.max(h).div_ceil(MAP_MAX_PX).max(1);
    let (mw, mh) = (w.div_ceil(step), h.div_ceil(step));
    let mut rgb = vec![0u8; (mw * mh * 3) as usize];
    let put = |rgb: &mut Vec<u8>, x: u32, y: u32, c: [u8; 3]| {
        if x < mw && y < mh {
            let i = ((y * mw + x) * 3) as usize;
            rgb[i..i + 3].copy_from_slice(&c);
        }
    };
    let near = r.overlap_px.div_ceil(step);
    for my in 0..mh {
        for mx in 0..mw {
            let (x, y) = ((mx * step).min(w - 1), (my * step).min(h - 1));
            let mut c: [u8; 3] = if r.bits.get(x, y) {
                [235, 235, 235]
            } else {
                [120, 120, 120]
            };
            // Within the overlap of a seam: tinted.
            let vx = r
                .seams
                .xs
                .iter()
                .any(|s| s[y as usize].abs_diff(x) <= near * step);
            let hy = r
                .seams
                .ys
                .iter()
                .any(|s| s[x as usize].abs_diff(y) <= near * step);
            if vx || hy {
                c = [c[0].saturating_add(20), c[1] / 10 * 8, c[2] / 10 * 8];
            }
            put(&mut rgb, mx, my, c);
        }
    }
    let red = [220, 20, 20];
    for s in &r.seams.xs {
        for (y, &x) in s.iter().enumerate() {
            for d in 0..2 {
                put(&mut rgb, x / step + d, y as u32 / step, red);
            }
        }
    }
    for s in &r.seams.ys {
        for (x, &y) in s.iter().enumerate() {
            for d in 0..2 {
                put(&mut rgb, x as u32 / step, y / step + d, red);
            }
        }
    }
    for &(x, y) in r.pins {
        let (cx, cy) = ((x / step) as i64, (y / step) as i64);
        for dy in -3i64..=3 {
            for dx in -3i64..=3 {
                if dx * dx + dy * dy <= 9 && cx + dx >= 0 && cy + dy >= 0 {
                    put(&mut rgb, (cx + dx) as u32, (cy + dy) as u32, [30, 60, 220]);
                }
            }
        }
    }
    // Numbers: 3 × 5 digits scaled to about a twelfth of the smaller side.
    let k = (mw.min(mh) / 60).clamp(2, 12);
    for &(n, (x, y)) in r.labels {
        let text = n.to_string();
        let tw = text.len() as u32 * 4 * k;
        let (x0, y0) = (
            (x / step).saturating_sub(tw / 2),
            (y / step).saturating_sub(5 * k / 2),
        );
        // A white plate under the number.
        for py in y0.saturating_sub(k)..y0 + 6 * k {
            for px in x0.saturating_sub(k)..x0 + tw + k {
                put(&mut rgb, px, py, [255, 255, 255]);
            }
        }
        for (i, ch) in text.bytes().enumerate() {
            let g = DIGITS[(ch - b'0') as usize];
            for (row, bits) in g.iter().enumerate() {
                for col in 0..3u32 {
                    if bits >> (2 - col) & 1 == 1 {
                        for py in 0..k {
                            for px in 0..k {
                                let gx = x0 + (i as u32 * 4 + col) * k + px;
                                put(&mut rgb, gx, y0 + row as u32 * k + py, [0, 0, 0]);
                            }
                        }
                    }
                }
            }
        }
    }
    (mw, mh, rgb)
}
