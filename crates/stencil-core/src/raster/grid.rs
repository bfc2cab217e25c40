//! The grids themselves: the grayscale rendering, the bit grid and the two-tone that pairs them.

/// Luma at working resolution, 0.0 = black .. 1.0 = white.
///
/// Kept beside the two-tone image because the bridge cost's intensity term reads it: a bridge over a
/// dark area of the source picture hurts the picture more than one over a light area.
#[derive(Clone, Debug, PartialEq)]
pub struct Gray {
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// Row by row, `width × height` values.
    pub data: Vec<f32>,
}

impl Gray {
    /// A grid of `fill`.
    pub fn new(width: u32, height: u32, fill: f32) -> Self {
        Gray::from_data(width, height, vec![fill; width as usize * height as usize])
    }

    /// A grid of `data`, row by row (`width × height` values).
    pub(crate) fn from_data(width: u32, height: u32, data: Vec<f32>) -> Self {
        debug_assert_eq!(data.len(), width as usize * height as usize);
        Gray {
            width,
            height,
            data,
        }
    }

    #[inline]
    pub(crate) fn idx(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    #[inline]
    pub(crate) fn get(&self, x: u32, y: u32) -> f32 {
        self.data[self.idx(x, y)]
    }

    /// Set the pixel at (x, y).
    #[inline]
    pub fn set(&mut self, x: u32, y: u32, v: f32) {
        let i = self.idx(x, y);
        self.data[i] = v;
    }

    /// Bilinear sample at a real-valued position, clamped to the grid.
    pub(crate) fn sample(&self, x: f32, y: f32) -> f32 {
        let maxx = (self.width - 1) as f32;
        let maxy = (self.height - 1) as f32;
        let x = x.clamp(0.0, maxx);
        let y = y.clamp(0.0, maxy);
        let x0 = x.floor() as u32;
        let y0 = y.floor() as u32;
        let x1 = (x0 + 1).min(self.width - 1);
        let y1 = (y0 + 1).min(self.height - 1);
        let fx = x - x0 as f32;
        let fy = y - y0 as f32;
        let a = self.get(x0, y0) * (1.0 - fx) + self.get(x1, y0) * fx;
        let b = self.get(x0, y1) * (1.0 - fx) + self.get(x1, y1) * fx;
        a * (1.0 - fy) + b * fy
    }

    /// As 8-bit luma (0..255), for PNG output.
    pub fn to_u8(&self) -> Vec<u8> {
        self.data
            .iter()
            .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
            .collect()
    }
}

/// A bit per pixel: `true` = material (the sheet that stays, drawn white), `false` = cut (drawn black).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BitGrid {
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// Row by row, `width × height` bits.
    pub data: Vec<bool>,
}

impl BitGrid {
    /// A grid of `fill`.
    pub fn new(width: u32, height: u32, fill: bool) -> Self {
        BitGrid::from_data(width, height, vec![fill; width as usize * height as usize])
    }

    /// A grid of `data`, row by row (`width × height` bits).
    pub(crate) fn from_data(width: u32, height: u32, data: Vec<bool>) -> Self {
        debug_assert_eq!(data.len(), width as usize * height as usize);
        BitGrid {
            width,
            height,
            data,
        }
    }

    /// Build from a predicate on (x, y).
    pub fn from_fn(width: u32, height: u32, mut f: impl FnMut(u32, u32) -> bool) -> Self {
        let data = (0..height).flat_map(|y| (0..width).map(move |x| (x, y)));
        BitGrid::from_data(width, height, data.map(|(x, y)| f(x, y)).collect())
    }

    /// Build from text rows, `#` = material, anything else = cut: a grid a reader can see, for
    /// tests and examples. All rows must have the same length.
    pub fn from_rows(rows: &[&str]) -> Self {
        let w = rows.first().map_or(0, |r| r.len()) as u32;
        BitGrid::from_fn(w, rows.len() as u32, |x, y| {
            rows[y as usize].as_bytes()[x as usize] == b'#'
        })
    }

    /// The index of (x, y) in `data`.
    #[inline]
    pub fn idx(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// Whether (x, y) is material.
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> bool {
        self.data[self.idx(x, y)]
    }

    /// Material test that treats everything outside the grid as material: the sheet continues
    /// beyond the image (the frame).
    #[inline]
    pub(crate) fn get_or_frame(&self, x: i64, y: i64) -> bool {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            true
        } else {
            self.data[y as usize * self.width as usize + x as usize]
        }
    }

    /// Make (x, y) material (`true`) or cut.
    #[inline]
    pub fn set(&mut self, x: u32, y: u32, v: bool) {
        let i = self.idx(x, y);
        self.data[i] = v;
    }

    /// Pixels in all.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// No pixels.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Pixels of material.
    pub fn count_material(&self) -> usize {
        self.data.iter().filter(|&&b| b).count()
    }

    /// 8-bit image: 255 = material, 0 = cut (the format of `twotone.png` and `stencil.png`).
    pub fn to_u8(&self) -> Vec<u8> {
        self.data.iter().map(|&b| if b { 255 } else { 0 }).collect()
    }

    /// Inverse of [`BitGrid::to_u8`]: a pixel at or above 128 is material.
    pub fn from_u8(width: u32, height: u32, data: &[u8]) -> Self {
        BitGrid::from_data(width, height, data.iter().map(|&v| v >= 128).collect())
    }
}

/// The edge neighbours (4-connected) of pixel index `i = y · w + x` on a `w` × `h` grid, in the
/// order left, right, up, down; `None` past the grid's edge.
#[inline]
pub(crate) fn edge_neighbours(i: usize, w: usize, h: usize) -> [Option<usize>; 4] {
    let (x, y) = (i % w, i / w);
    [
        (x > 0).then(|| i - 1),
        (x + 1 < w).then(|| i + 1),
        (y > 0).then(|| i - w),
        (y + 1 < h).then(|| i + w),
    ]
}

/// The two-tone image: which pixels are material, plus the grayscale it came from. The gray is
/// shared: every stage after the threshold carries the same one beside its own bits (the studio
/// keeps each stage's two-tone), and none changes it.
#[derive(Clone, Debug)]
pub struct TwoTone {
    /// The two tones: material true.
    pub bits: BitGrid,
    /// The gray they were thresholded from.
    pub gray: std::sync::Arc<Gray>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gray_sample_is_bilinear() {
        let mut g = Gray::new(2, 1, 0.0);
        g.set(1, 0, 1.0);
        assert!((g.sample(0.25, 0.0) - 0.25).abs() < 1e-6);
    }
}
