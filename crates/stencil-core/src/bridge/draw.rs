//! Rasterising a bridge: the cut pixels its strips, its outline and a brush turn into material,
//! with the pockets of cut that closes off (the paper's stage 5: "the bridge polygon ... drawn
//! as material"), priced by the picture under them, and committed to the two-tone.

use super::strips::Strip;
use crate::raster::{self, BitGrid, Gray};
use stencil_geom::ring::{point_in_ring, seg_dist, signed_area2};

/// What drawing a bridge would change, computed before committing it.
#[derive(Clone, Debug, Default)]
pub(crate) struct Plan {
    /// Cut pixels (linear indices) it turns into material.
    pub(crate) pixels: Vec<u32>,
    /// Outline: start and end points of the outer strips (or the corners of the straight band it
    /// was drawn as), in pixel coordinates where pixel (x, y) covers [x, x+1) × [y, y+1) (points
    /// are pixel centres).
    pub(crate) polygon: Vec<[f64; 2]>,
    /// Real intensity error: Σ (1 − gray)² over `pixels`.
    pub(crate) real: f64,
    /// Width at right angles to the bridge at its narrowest, in pixels: what the strips span, the
    /// minimum width when they had to be thickened, the band's width when drawn as a band, and no
    /// more than the narrowest run of material measured across the drawn bridge plus one pixel
    /// (the staircase pixel the check's allowance counts too).
    pub(crate) width: u32,
    /// Mean strip length, px.
    pub(crate) length: f64,
}

/// The cut pixels a bridge turns into material, in raster order, and Σ (1 − gray)² over them:
/// every pixel of `seeds`, the cut pixels whose centres lie inside `polygon` (kept only where
/// 4-connected to a seed; all of them when there are no seeds, for a convex band), the seeds
/// thickened by a square brush of radius `brush`, and any pocket of the cut of at most `seal`
/// pixels that this closes off (an outer strip that bulges out of the outline, or an outline that
/// meets a hollow edge, would otherwise leave a hole in or beside the bridge, a sliver no material
/// holds).
pub(super) fn draw(
    bits: &BitGrid,
    gray: &Gray,
    polygon: &[[f64; 2]],
    seeds: &[&Strip],
    brush: i64,
    seal: usize,
) -> (Vec<u32>, f64) {
    draw_brushed(bits, gray, polygon, seeds, Brush::Square(brush), seal)
}

/// How [`draw_brushed`] thickens its seeds.
#[derive(Clone, Copy)]
pub(super) enum Brush<'a> {
    /// A square of this radius around every seed pixel.
    Square(i64),
    /// Every pixel whose centre lies within `half` of the polyline `line` (round ends): a
    /// slanted run is as wide at right angles as a straight one, where a square brush on its
    /// staircase covers up to √2 times the area.
    Round(&'a [[f64; 2]], f64),
}

/// [`draw`] with either brush.
pub(super) fn draw_brushed(
    bits: &BitGrid,
    gray: &Gray,
    polygon: &[[f64; 2]],
    seeds: &[&Strip],
    brush: Brush,
    seal: usize,
) -> (Vec<u32>, f64) {
    let w = bits.width as i64;
    let reach = match brush {
        Brush::Square(r) => r,
        Brush::Round(_, half) => half.ceil() as i64 + 1,
    };
    let Some(win) = Window::around(bits, polygon, seeds, reach) else {
        return (Vec::new(), 0.0);
    };
    // 0 = untouched, 1 = fill candidate, 2 = taken.
    let mut state = vec![0u8; win.lw * win.lh];
    let mut stack = Vec::new();
    for s in seeds {
        for &p in &s.pixels {
            let (x, y) = (p as i64 % w, p as i64 / w);
            let l = win.local(x, y);
            if state[l] != 2 {
                state[l] = 2;
                stack.push((x, y));
            }
        }
    }
    let fill = if seeds.is_empty() { 2 } else { 1 };
    if signed_area2(polygon).abs() > 0.0 {
        fill_polygon(&mut state, &win, bits, polygon, fill, stack);
    }
    if let Brush::Round(line, half) = brush {
        for seg in line.windows(2) {
            let (a, b) = (seg[0], seg[1]);
            let (xa, ya) = pixel_of([a[0].min(b[0]) - half, a[1].min(b[1]) - half]);
            let (xb, yb) = pixel_of([a[0].max(b[0]) + half, a[1].max(b[1]) + half]);
            for y in ya.max(win.y0)..=yb.min(win.y1) {
                for x in xa.max(win.x0)..=xb.min(win.x1) {
                    if seg_dist([x as f64 + 0.5, y as f64 + 0.5], a, b) <= half {
                        state[win.local(x, y)] = 2;
                    }
                }
            }
        }
    }
    if let Brush::Square(brush) = brush {
        for s in seeds.iter().filter(|_| brush > 0) {
            for &p in &s.pixels {
                let (x, y) = (p as i64 % w, p as i64 / w);
                for yy in (y - brush).max(win.y0)..=(y + brush).min(win.y1) {
                    for xx in (x - brush).max(win.x0)..=(x + brush).min(win.x1) {
                        state[win.local(xx, yy)] = 2;
                    }
                }
            }
        }
    }
    let (x0, y0, lw) = (win.x0, win.y0, win.lw);
    let cut = |l: usize| !bits.data[((y0 + (l / lw) as i64) * w + x0 + (l % lw) as i64) as usize];
    seal_pockets(&mut state, win.lw, win.lh, seal, cut);
    let mut pixels = Vec::new();
    let mut real = 0.0;
    for y in win.y0..=win.y1 {
        for x in win.x0..=win.x1 {
            if state[win.local(x, y)] == 2 && !bits.get(x as u32, y as u32) {
                let i = (y * w + x) as u32;
                pixels.push(i);
                let d = 1.0 - gray.data[i as usize] as f64;
                real += d * d;
            }
        }
    }
    (pixels, real)
}

/// The box of the image [`draw`] works in: pixels `x0..=x1` × `y0..=y1`, `lw` × `lh`, with
/// local indices row by row.
struct Window {
    x0: i64,
    y0: i64,
    x1: i64,
    y1: i64,
    lw: usize,
    lh: usize,
}

impl Window {
    /// The bounding box of `polygon` and the `seeds`' pixels, widened by the `brush` radius and
    /// clipped to the image; `None` when nothing of it lies in the image.
    fn around(
        bits: &BitGrid,
        polygon: &[[f64; 2]],
        seeds: &[&Strip],
        brush: i64,
    ) -> Option<Window> {
        let w = bits.width as i64;
        let h = bits.height as i64;
        let (mut x0, mut y0, mut x1, mut y1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
        let mut include = |x: i64, y: i64| {
            x0 = x0.min(x);
            y0 = y0.min(y);
            x1 = x1.max(x);
            y1 = y1.max(y);
        };
        for p in polygon {
            let (x, y) = pixel_of(*p);
            include(x, y);
        }
        for s in seeds {
            for &p in &s.pixels {
                include(p as i64 % w, p as i64 / w);
            }
        }
        let (x0, y0) = ((x0 - brush).max(0), (y0 - brush).max(0));
        let (x1, y1) = ((x1 + brush).min(w - 1), (y1 + brush).min(h - 1));
        if x0 > x1 || y0 > y1 {
            return None;
        }
        Some(Window {
            x0,
            y0,
            x1,
            y1,
            lw: (x1 - x0 + 1) as usize,
            lh: (y1 - y0 + 1) as usize,
        })
    }

    /// The local index of image pixel (x, y), which must lie in the box.
    #[inline]
    fn local(&self, x: i64, y: i64) -> usize {
        (y - self.y0) as usize * self.lw + (x - self.x0) as usize
    }
}

/// Mark the cut pixels whose centres lie inside `polygon` as `fill` (1, a candidate, when there
/// are seeds; 2, taken, for a seedless band), then take the candidates 4-connected to the seeds
/// on `stack` (already taken): a fill pixel no strip reaches would be a loose speck.
fn fill_polygon(
    state: &mut [u8],
    win: &Window,
    bits: &BitGrid,
    polygon: &[[f64; 2]],
    fill: u8,
    mut stack: Vec<(i64, i64)>,
) {
    for y in win.y0..=win.y1 {
        for x in win.x0..=win.x1 {
            let l = win.local(x, y);
            if state[l] == 0
                && !bits.get(x as u32, y as u32)
                && point_in_ring([x as f64 + 0.5, y as f64 + 0.5], polygon)
            {
                state[l] = fill;
            }
        }
    }
    // Keep fill pixels 4-connected to a strip.
    while let Some((x, y)) = stack.pop() {
        for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            let (nx, ny) = (x + dx, y + dy);
            if nx < win.x0 || ny < win.y0 || nx > win.x1 || ny > win.y1 {
                continue;
            }
            let l = win.local(nx, ny);
            if state[l] == 1 {
                state[l] = 2;
                stack.push((nx, ny));
            }
        }
    }
}

/// Mark as taken (`state` 2) every pocket of at most `seal` cut pixels that the taken pixels close
/// off inside the `lw` × `lh` box: cut that no longer reaches the box's edge but did before.
/// (A hole of the picture itself never reached it and is left alone.)
fn seal_pockets(state: &mut [u8], lw: usize, lh: usize, seal: usize, cut: impl Fn(usize) -> bool) {
    let (w, h) = (lw as u32, lh as u32);
    let grid = |f: &dyn Fn(usize) -> bool| BitGrid::from_data(w, h, (0..lw * lh).map(f).collect());
    let after = grid(&|l| cut(l) && state[l] != 2);
    let (labels, areas) = raster::components(&after, true);
    let open = raster::touches_border(&labels, w, h, areas.len());
    if open.iter().all(|&o| o) {
        return;
    }
    let (was, was_areas) = raster::components(&grid(&cut), true);
    let was_open = raster::touches_border(&was, w, h, was_areas.len());
    for l in 0..lw * lh {
        let k = labels[l];
        if k != raster::NOT_LABELLED
            && !open[k as usize]
            && areas[k as usize] <= seal
            && was_open[was[l] as usize]
        {
            state[l] = 2;
        }
    }
}

/// The pixel holding point `p`: its coordinates rounded down. Written out rather than with
/// `f64::floor`, which on the baseline x86-64 target is a library call:
/// [`super::across::measure`] asks it for hundreds of samples a bridge, and it was a fifth of
/// that function's time.
#[inline]
pub(super) fn pixel_of(p: [f64; 2]) -> (i64, i64) {
    let down = |v: f64| {
        let t = v as i64;
        t - ((v < t as f64) as i64)
    };
    (down(p[0]), down(p[1]))
}

/// Whether the pixel holding point `p` is material (outside the image: the frame).
#[inline]
pub(super) fn material_at(bits: &BitGrid, p: [f64; 2]) -> bool {
    let (x, y) = pixel_of(p);
    bits.get_or_frame(x, y)
}

/// Turn the planned pixels into material; returns those that were still cut (a pixel an earlier
/// bridge already took counts for that one).
pub(crate) fn commit(bits: &mut BitGrid, pixels: &[u32]) -> Vec<u32> {
    let mut turned = Vec::new();
    for &p in pixels {
        let cell = &mut bits.data[p as usize];
        if !*cell {
            *cell = true;
            turned.push(p);
        }
    }
    turned
}
