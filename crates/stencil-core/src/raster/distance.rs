//! Exact Euclidean distance transforms of a bit grid.

use super::grid::BitGrid;

/// Squared Euclidean distance from every pixel to the nearest pixel whose bit equals `target` (0
/// on such pixels); outside the grid is material (the frame). Exact, O(pixels) (Felzenszwalb &
/// Huttenlocher's lower envelope of parabolas, row then column).
pub(crate) fn squared_distance_to(bits: &BitGrid, target: bool) -> Vec<f32> {
    squared_distance(bits, target, target)
}

/// [`squared_distance_to`] with the outside of the grid chosen explicitly: `frame_is_target` makes
/// a virtual target row and column one step outside every border, `false` makes the outside count
/// as nothing (distances are measured to targets inside the grid only; `INF`-like 1e20 where there
/// is none).
pub(crate) fn squared_distance(bits: &BitGrid, target: bool, frame_is_target: bool) -> Vec<f32> {
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
    for (q, dq_out) in d.iter_mut().enumerate().take(n) {
        while z[k + 1] < q as f32 {
            k += 1;
        }
        let p = v[k];
        let dq = q as f32 - p as f32;
        *dq_out = dq * dq + f[p];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::BitGrid;
    use crate::test_rng::Lcg;

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
        let mut rng = Lcg(12345);
        for _ in 0..20 {
            let bits = BitGrid::from_fn(13, 9, |_, _| rng.below(5) == 0);
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
}
