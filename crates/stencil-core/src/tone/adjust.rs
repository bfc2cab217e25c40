//! Picture adjustments before the threshold: crop, quarter turns, brightness, contrast, gamma,
//! edge-preserving smoothing, abstraction and the local (adaptive) threshold.
//!
//! Stencil artists do not cut a photo at one fixed level: they crop it, simplify it and lift or
//! sink its midtones first. These run on the picture at its own resolution, in this order:
//! crop (the rectangle is in pixels of the picture as shown, after its EXIF orientation: the
//! `make` front end converts the person's millimetres), quarter turns, brightness, contrast, gamma,
//! smoothing, abstraction, local threshold. Everything after (supersampling, the threshold, the
//! clean-up, the bridges, `--bridge-at`) sees the adjusted picture, so its coordinates are those of
//! the cropped and turned picture.
//!
//! The filters come from `imageproc` (the bilateral filter, the Gaussian blur and the region
//! labelling), which works on `f32` pixels directly, so nothing is rounded to 8 bits on the way.

use image::{ImageBuffer, Luma};
use imageproc::filter::bilateral::GaussianEuclideanColorDistance;
use imageproc::filter::bilateral_filter;
use imageproc::region_labelling::{connected_components, Connectivity};

use crate::raster::{blur, Gray};

/// The adjustments, all off by default (`Adjust::is_identity`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adjust {
    /// The part of the picture kept: x, y, width, height in pixels of the picture as shown.
    pub crop_px: Option<[u32; 4]>,
    /// Quarter turns clockwise, 0..=3, after the crop.
    pub quarter_turns: u8,
    /// Added to every gray value (-1..1; 0 = none).
    pub brightness: f32,
    /// Contrast about mid-gray: `(v − 0.5)·c + 0.5` (1 = none, 0 = flat gray).
    pub contrast: f32,
    /// `v^(1/γ)`: above 1 lifts the midtones, below 1 sinks them; black and white stay (1 = none).
    pub gamma: f32,
    /// Edge-preserving (bilateral) smoothing: the spatial standard deviation in picture pixels
    /// (0 = off). Tones closer than `SMOOTH_TONE_SIGMA` are averaged, edges between tones kept.
    pub smooth_px: f32,
    /// Abstraction strength 0..=1 (0 = off): see `abstraction`.
    pub abstraction: f32,
    /// Local threshold: each pixel compared with the Gaussian-weighted mean of its neighbourhood
    /// of this standard deviation in picture pixels instead of with one level for the whole
    /// picture (0 = off).
    pub local_px: f32,
}

impl Default for Adjust {
    fn default() -> Self {
        Adjust {
            crop_px: None,
            quarter_turns: 0,
            brightness: 0.0,
            contrast: 1.0,
            gamma: 1.0,
            smooth_px: 0.0,
            abstraction: 0.0,
            local_px: 0.0,
        }
    }
}

/// The bilateral filter's tone standard deviation (on the 0..1 gray scale): differences of about
/// a tenth of full scale count as an edge and are kept.
pub(crate) const SMOOTH_TONE_SIGMA: f32 = 0.1;

impl Adjust {
    /// Whether nothing is asked for (the picture passes through untouched).
    pub(crate) fn is_identity(&self) -> bool {
        *self == Adjust::default()
    }

    /// The picture adjusted. `g` is the picture as shown (after EXIF orientation). The crop is
    /// clamped to the picture (the front end refuses one outside it).
    pub(crate) fn apply(&self, g: &Gray) -> Gray {
        let mut g = match self.crop_px {
            Some(c) => crop(g, c),
            None => g.clone(),
        };
        g = turn(g, self.quarter_turns);
        if self.brightness != 0.0 || self.contrast != 1.0 || self.gamma != 1.0 {
            let inv = 1.0 / self.gamma;
            for v in &mut g.data {
                let x = ((*v + self.brightness - 0.5) * self.contrast + 0.5).clamp(0.0, 1.0);
                *v = if self.gamma == 1.0 { x } else { x.powf(inv) };
            }
        }
        if self.smooth_px > 0.0 {
            g = bilateral(&g, self.smooth_px, SMOOTH_TONE_SIGMA);
        }
        if self.abstraction > 0.0 {
            g = abstraction(&g, self.abstraction);
        }
        if self.local_px > 0.0 {
            let mean = blur(&g, self.local_px);
            for (v, m) in g.data.iter_mut().zip(&mean.data) {
                *v = (*v - m + 0.5).clamp(0.0, 1.0);
            }
        }
        g
    }
}

/// The rectangle `[x, y, w, h]` of `g`, clamped to it (at least one pixel).
fn crop(g: &Gray, [x, y, w, h]: [u32; 4]) -> Gray {
    let x = x.min(g.width - 1);
    let y = y.min(g.height - 1);
    let w = w.clamp(1, g.width - x);
    let h = h.clamp(1, g.height - y);
    let mut data = Vec::with_capacity(w as usize * h as usize);
    for row in y..y + h {
        let s = (row * g.width + x) as usize;
        data.extend_from_slice(&g.data[s..s + w as usize]);
    }
    Gray::from_data(w, h, data)
}

/// `g` turned `q` quarter turns clockwise (as its EXIF orientation would turn it).
fn turn(g: Gray, q: u8) -> Gray {
    use image::metadata::Orientation::{NoTransforms, Rotate180, Rotate270, Rotate90};
    super::image::oriented(
        g,
        [NoTransforms, Rotate90, Rotate180, Rotate270][q as usize % 4],
    )
}

type F32Image = ImageBuffer<Luma<f32>, Vec<f32>>;

fn to_image(g: &Gray) -> F32Image {
    ImageBuffer::from_raw(g.width, g.height, g.data.clone()).expect("a gray's data fits its size")
}

fn from_image(i: F32Image) -> Gray {
    Gray::from_data(i.width(), i.height(), i.into_raw())
}

/// The bilateral filter (Tomasi and Manduchi 1998) with a window of about 2σ each side (at most
/// 255 pixels, as `imageproc` allows).
pub(crate) fn bilateral(g: &Gray, sigma_px: f32, tone_sigma: f32) -> Gray {
    let radius = (2.0 * sigma_px).ceil().clamp(1.0, 255.0) as u8;
    from_image(bilateral_filter(
        &to_image(g),
        radius,
        sigma_px,
        GaussianEuclideanColorDistance::new(tone_sigma),
    ))
}

/// Abstraction after DeCarlo and Santella (2002): a few regions of flat tone, edges kept. Without
/// their eye tracking we keep their core move, merging small regions of similar tone uniformly,
/// by a strength `s` in 0..=1:
/// 1. smooth, keeping edges (bilateral, spatial σ = 1 + 3·s pixels);
/// 2. quantise into `16 − 12·s` bands and label the 8-connected regions of one band;
/// 3. merge every region under `(s · diagonal / 40)²` pixels into the neighbour of nearest mean
///    tone, smallest first (union–find);
/// 4. paint each region its mean smoothed tone.
pub(crate) fn abstraction(g: &Gray, strength: f32) -> Gray {
    let s = strength.clamp(0.0, 1.0);
    if s == 0.0 || g.data.is_empty() {
        return g.clone();
    }
    let smooth = bilateral(g, 1.0 + 3.0 * s, SMOOTH_TONE_SIGMA);
    let bands = (16.0 - 12.0 * s).round().max(2.0);
    let q: ImageBuffer<Luma<u8>, Vec<u8>> = ImageBuffer::from_fn(g.width, g.height, |x, y| {
        let v = smooth.data[(y * g.width + x) as usize];
        // Band 0 is reserved as "background" by the labeller: bands start at 1.
        Luma([1 + ((v.clamp(0.0, 1.0) * bands).floor().min(bands - 1.0)) as u8])
    });
    let labels = connected_components(&q, Connectivity::Eight, Luma([0u8]));
    let n = labels.pixels().map(|p| p[0]).max().unwrap_or(0) as usize + 1;
    let lab: Vec<u32> = labels.into_raw();
    let mut area = vec![0usize; n];
    let mut sum = vec![0f64; n];
    for (i, &l) in lab.iter().enumerate() {
        area[l as usize] += 1;
        sum[l as usize] += smooth.data[i] as f64;
    }
    // Adjacency between regions (4-neighbours), deduplicated.
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
    let (w, h) = (g.width as usize, g.height as usize);
    for y in 0..h {
        for x in 0..w {
            let a = lab[y * w + x];
            for (nx, ny) in [(x + 1, y), (x, y + 1)] {
                if nx < w && ny < h {
                    let b = lab[ny * w + nx];
                    if a != b {
                        adj[a as usize].push(b);
                        adj[b as usize].push(a);
                    }
                }
            }
        }
    }
    for a in &mut adj {
        a.sort_unstable();
        a.dedup();
    }
    let diag = (g.width as f32).hypot(g.height as f32);
    let min_area = ((s * diag / 40.0).powi(2)).max(2.0) as usize;
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let find = |p: &mut [u32], x: u32| crate::raster::root(p, x as usize) as u32;
    let mut order: Vec<u32> = (1..n as u32).filter(|&r| area[r as usize] > 0).collect();
    order.sort_by_key(|&r| area[r as usize]);
    for r in order {
        let r = find(&mut parent, r);
        if area[r as usize] >= min_area {
            continue;
        }
        let mean = sum[r as usize] / area[r as usize] as f64;
        let mut best: Option<(f64, u32)> = None;
        let neighbours = std::mem::take(&mut adj[r as usize]);
        for &b in &neighbours {
            let b = find(&mut parent, b);
            if b == r {
                continue;
            }
            let d = (sum[b as usize] / area[b as usize] as f64 - mean).abs();
            if best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, b));
            }
        }
        let Some((_, b)) = best else {
            adj[r as usize] = neighbours;
            continue;
        };
        parent[r as usize] = b;
        area[b as usize] += area[r as usize];
        sum[b as usize] += sum[r as usize];
        adj[b as usize].extend(neighbours);
    }
    let data = lab
        .iter()
        .map(|&l| {
            let r = find(&mut parent, l) as usize;
            (sum[r] / area[r] as f64) as f32
        })
        .collect();
    Gray::from_data(g.width, g.height, data)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Lcg;

    fn ramp(w: u32, h: u32) -> Gray {
        let mut g = Gray::new(w, h, 0.0);
        for y in 0..h {
            for x in 0..w {
                g.set(x, y, x as f32 / (w - 1) as f32);
            }
        }
        g
    }

    #[test]
    fn crop_and_turns_move_pixels_where_they_should() {
        let g = ramp(10, 4);
        let c = Adjust {
            crop_px: Some([2, 1, 5, 2]),
            ..Default::default()
        }
        .apply(&g);
        assert_eq!((c.width, c.height), (5, 2));
        assert_eq!(c.get(0, 0), g.get(2, 1));
        let t = Adjust {
            quarter_turns: 1,
            ..Default::default()
        }
        .apply(&g);
        assert_eq!((t.width, t.height), (4, 10));
        // Clockwise: the left column becomes the top row.
        assert_eq!(t.get(0, 0), g.get(0, 3));
        assert_eq!(t.get(3, 9), g.get(9, 3));
        let back = turn(turn(t, 2), 1);
        assert_eq!(back.data, g.data);
    }

    #[test]
    fn gamma_lifts_midtones_and_keeps_the_ends() {
        let g = ramp(11, 1);
        let a = Adjust {
            gamma: 2.0,
            ..Default::default()
        }
        .apply(&g);
        assert!(a.get(5, 0) > 0.7, "{}", a.get(5, 0));
        assert_eq!(a.get(0, 0), 0.0);
        assert_eq!(a.get(10, 0), 1.0);
    }

    #[test]
    fn abstraction_flattens_noise_and_keeps_an_edge() {
        let mut g = Gray::new(60, 40, 0.2);
        let mut rng = Lcg(1);
        for y in 0..40 {
            for x in 0..60 {
                let noise = rng.below(256) as f32 / 255.0 * 0.06;
                g.set(x, y, if x < 30 { 0.2 } else { 0.8 } + noise);
            }
        }
        let a = abstraction(&g, 0.6);
        let var = |x0: u32, x1: u32| {
            let v: Vec<f32> = (0..40)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .map(|(x, y)| a.get(x, y))
                .collect();
            let m = v.iter().sum::<f32>() / v.len() as f32;
            v.iter().map(|x| (x - m) * (x - m)).sum::<f32>() / v.len() as f32
        };
        assert!(var(2, 26) < 1e-4 && var(34, 58) < 1e-4);
        assert!(a.get(5, 20) < 0.35 && a.get(55, 20) > 0.65);
    }
}
