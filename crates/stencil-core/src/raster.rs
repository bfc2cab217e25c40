//! Pixel grids shared by every stage before `vector`: the grayscale rendering and the two-tone bit grid.
//!
//! Row-major, origin top-left, Y down (image convention). Stages before `vector` work in pixels only;
//! millimetres appear through [`crate::units::Scale`].

/// Luma at working resolution, 0.0 = black .. 1.0 = white.
///
/// Kept beside the two-tone image because the bridge cost's intensity term reads it: a bridge over a
/// dark area of the source picture hurts the picture more than one over a light area.
#[derive(Clone, Debug, PartialEq)]
pub struct Gray {
    pub width: u32,
    pub height: u32,
    pub data: Vec<f32>,
}

impl Gray {
    pub fn new(width: u32, height: u32, fill: f32) -> Self {
        Gray {
            width,
            height,
            data: vec![fill; width as usize * height as usize],
        }
    }

    #[inline]
    pub fn idx(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    #[inline]
    pub fn get(&self, x: u32, y: u32) -> f32 {
        self.data[self.idx(x, y)]
    }

    #[inline]
    pub fn set(&mut self, x: u32, y: u32, v: f32) {
        let i = self.idx(x, y);
        self.data[i] = v;
    }

    /// Bilinear sample at a real-valued position, clamped to the grid.
    pub fn sample(&self, x: f32, y: f32) -> f32 {
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
    pub width: u32,
    pub height: u32,
    pub data: Vec<bool>,
}

impl BitGrid {
    pub fn new(width: u32, height: u32, fill: bool) -> Self {
        BitGrid {
            width,
            height,
            data: vec![fill; width as usize * height as usize],
        }
    }

    /// Build from a predicate on (x, y).
    pub fn from_fn(width: u32, height: u32, mut f: impl FnMut(u32, u32) -> bool) -> Self {
        let mut data = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                data.push(f(x, y));
            }
        }
        BitGrid {
            width,
            height,
            data,
        }
    }

    /// Build from text rows, `#` = material, anything else = cut: a grid a reader can see, for
    /// tests and examples. All rows must have the same length.
    pub fn from_rows(rows: &[&str]) -> Self {
        let w = rows.first().map_or(0, |r| r.len()) as u32;
        BitGrid::from_fn(w, rows.len() as u32, |x, y| {
            rows[y as usize].as_bytes()[x as usize] == b'#'
        })
    }

    #[inline]
    pub fn idx(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    #[inline]
    pub fn get(&self, x: u32, y: u32) -> bool {
        self.data[self.idx(x, y)]
    }

    /// Material test that treats everything outside the grid as material: the sheet continues
    /// beyond the image (the frame).
    #[inline]
    pub fn get_or_frame(&self, x: i64, y: i64) -> bool {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            true
        } else {
            self.data[y as usize * self.width as usize + x as usize]
        }
    }

    #[inline]
    pub fn set(&mut self, x: u32, y: u32, v: bool) {
        let i = self.idx(x, y);
        self.data[i] = v;
    }

    pub fn len(&self) -> usize {
        self.data.len()
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    pub fn count_material(&self) -> usize {
        self.data.iter().filter(|&&b| b).count()
    }

    /// 8-bit image: 255 = material, 0 = cut (the format of `twotone.png` and `stencil.png`).
    pub fn to_u8(&self) -> Vec<u8> {
        self.data.iter().map(|&b| if b { 255 } else { 0 }).collect()
    }

    /// Inverse of [`BitGrid::to_u8`]: a pixel at or above 128 is material.
    pub fn from_u8(width: u32, height: u32, data: &[u8]) -> Self {
        BitGrid {
            width,
            height,
            data: data.iter().map(|&v| v >= 128).collect(),
        }
    }
}

/// The two-tone image: which pixels are material, plus the grayscale it came from.
#[derive(Clone, Debug)]
pub struct TwoTone {
    pub bits: BitGrid,
    pub gray: Gray,
}

/// Squared Euclidean distance from every pixel to the nearest pixel whose bit equals `target`
/// (0 on such pixels). Pixels outside the grid count as material (the frame), so with
/// `target = true` the distance never exceeds the distance to the image border plus one.
///
/// Exact, O(pixels) (Felzenszwalb & Huttenlocher's lower envelope of parabolas, row then column).
/// Used by the topological filter (dilation and erosion by a disc) and by the bridge stage, whose
/// walks follow the distance field's gradient where the grayscale source is flat.
pub fn squared_distance_to(bits: &BitGrid, target: bool) -> Vec<f32> {
    squared_distance(bits, target, target)
}

/// [`squared_distance_to`] with the outside of the grid chosen explicitly: `frame_is_target` makes
/// a virtual target row and column one step outside every border, `false` makes the outside count
/// as nothing (distances are measured to targets inside the grid only; `INF`-like 1e20 where there
/// is none).
pub fn squared_distance(bits: &BitGrid, target: bool, frame_is_target: bool) -> Vec<f32> {
    let (w, h) = (bits.width as usize, bits.height as usize);
    const INF: f32 = 1e20;
    let mut d: Vec<f32> = bits
        .data
        .iter()
        .map(|&b| if b == target { 0.0 } else { INF })
        .collect();
    // The frame outside the image: a virtual target row/column one step outside.
    let frame = frame_is_target;
    let mut f = vec![0f32; w.max(h) + 2];
    let mut out = vec![0f32; w.max(h) + 2];
    let mut v = vec![0usize; w.max(h) + 2];
    let mut z = vec![0f32; w.max(h) + 3];
    // Columns.
    for x in 0..w {
        let n = h + if frame { 2 } else { 0 };
        let off = if frame { 1 } else { 0 };
        for i in 0..n {
            f[i] = if frame && (i == 0 || i == n - 1) {
                0.0
            } else {
                d[(i - off) * w + x]
            };
        }
        dt1d(&f[..n], &mut out[..n], &mut v, &mut z);
        for y in 0..h {
            d[y * w + x] = out[y + off];
        }
    }
    // Rows.
    for y in 0..h {
        let n = w + if frame { 2 } else { 0 };
        let off = if frame { 1 } else { 0 };
        for i in 0..n {
            f[i] = if frame && (i == 0 || i == n - 1) {
                0.0
            } else {
                d[y * w + i - off]
            };
        }
        dt1d(&f[..n], &mut out[..n], &mut v, &mut z);
        for x in 0..w {
            d[y * w + x] = out[x + off];
        }
    }
    d
}

/// One-dimensional squared distance transform of sampled function `f` into `d`.
fn dt1d(f: &[f32], d: &mut [f32], v: &mut [usize], z: &mut [f32]) {
    let n = f.len();
    if n == 0 {
        return;
    }
    let mut k = 0usize;
    v[0] = 0;
    z[0] = f32::NEG_INFINITY;
    z[1] = f32::INFINITY;
    for q in 1..n {
        let fq = f[q] + (q * q) as f32;
        let mut s;
        loop {
            let p = v[k];
            s = (fq - (f[p] + (p * p) as f32)) / (2.0 * (q as f32 - p as f32));
            if s <= z[k] && k > 0 {
                k -= 1;
            } else {
                break;
            }
        }
        if s <= z[k] {
            // k == 0 and the new parabola dominates everywhere.
            v[0] = q;
            z[0] = f32::NEG_INFINITY;
            z[1] = f32::INFINITY;
            continue;
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f32::INFINITY;
    }
    k = 0;
    for q in 0..n {
        while z[k + 1] < q as f32 {
            k += 1;
        }
        let p = v[k];
        let dq = q as f32 - p as f32;
        d[q] = dq * dq + f[p];
    }
}

/// A run of pixels along row `y`, columns `x0..=x1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Run {
    pub y: u32,
    pub x0: u32,
    pub x1: u32,
}

/// The connected pieces of runs listed row by row, left to right (`row_first[y]` is the index of
/// row `y`'s first run, with one entry past the last row): runs in neighbouring rows join where
/// they overlap, and also where they touch only at a corner when `corners` (8-connectivity).
/// Returns each run's piece and the number of pieces, numbered in the order of their first run,
/// which is the order of their first pixel in raster order. Union-find over the runs: a pass over
/// the runs, not a stack push per pixel.
pub fn join_runs(runs: &[Run], row_first: &[usize], corners: bool) -> (Vec<u32>, usize) {
    let mut parent: Vec<u32> = (0..runs.len() as u32).collect();
    fn root(parent: &mut [u32], mut r: usize) -> usize {
        while parent[r] as usize != r {
            let p = parent[r] as usize;
            parent[r] = parent[p];
            r = p;
        }
        r
    }
    let slack = corners as i64;
    for y in 1..row_first.len().saturating_sub(1) {
        let (mut a, a_end) = (row_first[y - 1], row_first[y]);
        let (mut b, b_end) = (row_first[y], row_first[y + 1]);
        while a < a_end && b < b_end {
            let (ra, rb) = (runs[a], runs[b]);
            if ra.x0 as i64 <= rb.x1 as i64 + slack && rb.x0 as i64 <= ra.x1 as i64 + slack {
                let (pa, pb) = (root(&mut parent, a), root(&mut parent, b));
                if pa != pb {
                    // The earlier run stays the root, so roots are first runs in scan order.
                    parent[pa.max(pb)] = pa.min(pb) as u32;
                }
            }
            if ra.x1 <= rb.x1 {
                a += 1;
            } else {
                b += 1;
            }
        }
    }
    let mut piece = vec![u32::MAX; runs.len()];
    let mut count = 0;
    for r in 0..runs.len() {
        let root = root(&mut parent, r);
        if piece[root] == u32::MAX {
            piece[root] = count;
            count += 1;
        }
        piece[r] = piece[root];
    }
    (piece, count as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(bits: &BitGrid, target: bool) -> Vec<f32> {
        let (w, h) = (bits.width as i64, bits.height as i64);
        let mut out = vec![0f32; (w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                let mut best = f32::INFINITY;
                for yy in -1..=h {
                    for xx in -1..=w {
                        let inside = xx >= 0 && yy >= 0 && xx < w && yy < h;
                        let b = if inside {
                            bits.get(xx as u32, yy as u32)
                        } else {
                            true
                        };
                        if b == target {
                            let d = ((xx - x).pow(2) + (yy - y).pow(2)) as f32;
                            best = best.min(d);
                        }
                    }
                }
                out[(y * w + x) as usize] = best;
            }
        }
        out
    }

    #[test]
    fn distance_transform_matches_brute_force() {
        let mut seed = 12345u64;
        for _ in 0..20 {
            let bits = BitGrid::from_fn(13, 9, |_, _| {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (seed >> 33) % 5 == 0
            });
            for target in [true, false] {
                let fast = squared_distance_to(&bits, target);
                let slow = brute(&bits, target);
                for (a, b) in fast.iter().zip(&slow) {
                    if b.is_finite() {
                        assert!((a - b).abs() < 1e-3, "{a} vs {b}");
                    } else {
                        assert!(*a > 1e10);
                    }
                }
            }
        }
    }

    #[test]
    fn gray_sample_is_bilinear() {
        let mut g = Gray::new(2, 1, 0.0);
        g.set(1, 0, 1.0);
        assert!((g.sample(0.25, 0.0) - 0.25).abs() < 1e-6);
    }
}
