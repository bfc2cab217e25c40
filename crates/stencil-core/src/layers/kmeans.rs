//! A colour picture's tones by k-means in CIELAB: `k` clusters on a sample of at most
//! [`KMEANS_SAMPLES`] pixels, started from the pixels at evenly spaced quantiles of lightness
//! (deterministic), at most [`KMEANS_ROUNDS`] rounds of Lloyd's algorithm; clusters ordered by
//! their lightness L*. Each pixel then carries its cluster's L* as its gray, and each layer's
//! level sits between two clusters' L*, so thresholding that gray gives exactly the union of the
//! clusters at the layer's tone or darker.

use rayon::prelude::*;

use super::lab::{dist2, lab, srgb};
use crate::raster::Gray;

/// Most pixels k-means clusters (a sample of the picture, evenly spread).
pub const KMEANS_SAMPLES: usize = 40_000;

/// Rounds of Lloyd's algorithm.
pub const KMEANS_ROUNDS: usize = 30;

fn nearest(c: [f32; 3], centres: &[[f32; 3]]) -> usize {
    let mut best = (f32::INFINITY, 0);
    for (i, &m) in centres.iter().enumerate() {
        let d = dist2(c, m);
        if d < best.0 {
            best = (d, i);
        }
    }
    best.1
}

/// k-means in CIELAB (see the module notes and [`super`]): the tone gray, the levels (descending) and the
/// colours (lightest cluster first).
pub(super) fn kmeans_tones(
    luma: &Gray,
    rgb: &[[f32; 3]],
    k: usize,
) -> (Gray, Vec<u8>, Vec<[u8; 3]>) {
    let labs: Vec<[f32; 3]> = rgb.par_iter().map(|&c| lab(c)).collect();
    let step = labs.len().div_ceil(KMEANS_SAMPLES).max(1);
    let mut sample: Vec<[f32; 3]> = labs.iter().step_by(step).copied().collect();
    sample.sort_by(|a, b| a[0].total_cmp(&b[0]));
    let mut centres: Vec<[f32; 3]> = (0..k)
        .map(|i| sample[((2 * i + 1) * sample.len() / (2 * k)).min(sample.len() - 1)])
        .collect();
    for _ in 0..KMEANS_ROUNDS {
        let mut sum = vec![[0f64; 3]; k];
        let mut count = vec![0usize; k];
        for &c in &sample {
            let i = nearest(c, &centres);
            for j in 0..3 {
                sum[i][j] += c[j] as f64;
            }
            count[i] += 1;
        }
        let mut moved = false;
        for i in 0..k {
            if count[i] > 0 {
                let m = sum[i].map(|v| (v / count[i] as f64) as f32);
                moved |= dist2(m, centres[i]) > 1e-6;
                centres[i] = m;
            }
        }
        if !moved {
            break;
        }
    }
    // Lightest first.
    centres.sort_by(|a, b| b[0].total_cmp(&a[0]));
    // Each cluster's L* on the 8-bit scale, strictly falling by at least 2 so that a level fits
    // between any two (evenly spread when the clusters' lightness is too close for that).
    let mut q: Vec<i32> = centres
        .iter()
        .map(|c| (c[0] * 2.55).round() as i32)
        .collect();
    for i in 1..k {
        q[i] = q[i].min(q[i - 1] - 2);
    }
    if q[k - 1] < 0 {
        q = (0..k)
            .map(|i| (255 * (k - 1 - i) / (k - 1).max(1)) as i32)
            .collect();
    }
    let levels: Vec<u8> = (1..k)
        .map(|i| (q[i] + (q[i - 1] - q[i] + 1) / 2) as u8)
        .collect();
    let data: Vec<f32> = labs
        .par_iter()
        .map(|&c| q[nearest(c, &centres)] as f32 / 255.0)
        .collect();
    let colors = centres.iter().map(|&c| srgb(c)).collect();
    (
        Gray::from_data(luma.width, luma.height, data),
        levels,
        colors,
    )
}
