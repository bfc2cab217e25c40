//! Seeing a gray picture from afar: the box average that shrinks it and the separable blur that
//! smooths it. One copy of each for every stage that does either (the likeness measures, the
//! `--threshold auto` search on a reduced picture, the local threshold's mean).

use rayon::prelude::*;

use super::grid::{BitGrid, Gray};

/// The `w` × `h` picture of `value(i)` box-averaged by `d` (partial boxes at the right and bottom
/// edges averaged over what they hold). Each box sums its rows top to bottom and each row left
/// to right, from 0, and is divided by its count of pixels; an output row's boxes are summed
/// together, a source row at a time, so the picture is read in order.
pub(crate) fn box_average(w: u32, h: u32, d: u32, value: impl Fn(usize) -> f32 + Sync) -> Gray {
    let (ow, oh) = (w.div_ceil(d), h.div_ceil(d));
    let (wu, du) = (w as usize, d as usize);
    let mut data = vec![0f32; (ow * oh) as usize];
    data.par_chunks_mut(ow as usize)
        .enumerate()
        .for_each(|(oy, out)| {
            let rows = oy as u32 * d..((oy as u32 + 1) * d).min(h);
            let n_rows = rows.len() as u32;
            for y in rows {
                let base = y as usize * wu;
                for (ox, o) in out.iter_mut().enumerate() {
                    let x0 = ox * du;
                    for x in x0..(x0 + du).min(wu) {
                        *o += value(base + x);
                    }
                }
            }
            for (ox, o) in out.iter_mut().enumerate() {
                let cols = (du).min(wu - ox * du) as u32;
                *o /= (n_rows * cols) as f32;
            }
        });
    Gray {
        width: ow,
        height: oh,
        data,
    }
}

/// [`box_average`] of a two-tone's tone (1 where `bits` differs from `invert`), by counting: a
/// box's sum of ones and zeros is its count of ones, exactly, in any order. An output row's
/// source rows are first added column by column (a long loop over bytes that vectorises), then
/// each box's columns summed. (The measures use [`box_average_bits_into`], which reuses a buffer.)
#[cfg(test)]
pub(crate) fn box_average_bits(bits: &BitGrid, d: u32, invert: bool) -> Gray {
    let mut data = Vec::new();
    let (width, height) = box_average_bits_into(bits, d, invert, &mut data);
    Gray {
        width,
        height,
        data,
    }
}

/// [`box_average_bits`] written into `data` (resized to the result, every value written, so a
/// buffer reused from an earlier call needs no clearing); returns the result's size.
pub(crate) fn box_average_bits_into(
    bits: &BitGrid,
    d: u32,
    invert: bool,
    data: &mut Vec<f32>,
) -> (u32, u32) {
    let (w, h) = (bits.width, bits.height);
    let (ow, oh) = (w.div_ceil(d), h.div_ceil(d));
    let (wu, du) = (w as usize, d as usize);
    resize_unset(data, (ow * oh) as usize);
    if ow == 0 || oh == 0 {
        return (ow, oh);
    }
    data.par_chunks_mut(ow as usize).enumerate().for_each_init(
        Vec::new,
        |cols: &mut Vec<u32>, (oy, out)| {
            cols.clear();
            cols.resize(wu, 0);
            let rows = oy as u32 * d..((oy as u32 + 1) * d).min(h);
            let n_rows = rows.len() as u32;
            for y in rows {
                let row = &bits.data[y as usize * wu..(y as usize + 1) * wu];
                for (c, &b) in cols.iter_mut().zip(row) {
                    *c += (b != invert) as u32;
                }
            }
            for (ox, (o, chunk)) in out.iter_mut().zip(cols.chunks(du)).enumerate() {
                let cols = du.min(wu - ox * du) as u32;
                *o = chunk.iter().sum::<u32>() as f32 / (n_rows * cols) as f32;
            }
        },
    );
    (ow, oh)
}

/// `v` made `n` long without writing the values it already holds: for a buffer every value of
/// which is written next, reused between calls (clearing it first would cost a pass over it).
fn resize_unset(v: &mut Vec<f32>, n: usize) {
    v.truncate(n);
    v.resize(n, 0.0);
}

/// A Gaussian blur of standard deviation `sigma` pixels (edges padded by continuity): the same
/// floats as `imageproc`'s `gaussian_blur_f32` (its kernel and sums, in its order), but a row at
/// a time so the sums vectorise, and over threads.
pub(crate) fn blur(g: &Gray, sigma: f32) -> Gray {
    blur_of(g.width, g.height, sigma, |i| g.data[i])
}

/// [`blur`] of the `w` × `h` picture of `value(i)` (pixel `i` row-major), not made first: the
/// likeness blurs squares and products, each a picture-sized buffer of fresh memory if made.
pub(crate) fn blur_of(w: u32, h: u32, sigma: f32, value: impl Fn(usize) -> f32 + Sync) -> Gray {
    let mut data = Vec::new();
    blur_of_into(w, h, sigma, value, &mut Vec::new(), &mut data);
    Gray {
        width: w,
        height: h,
        data,
    }
}

/// [`blur_of`] written into `out` (resized to `w` × `h`, every value written), with `across` as
/// the buffer between the two passes: both reusable between calls, so that measuring many
/// two-tones of one picture (`--threshold auto`'s levels) does not allocate and clear
/// picture-sized buffers for each.
pub(crate) fn blur_of_into(
    w: u32,
    h: u32,
    sigma: f32,
    value: impl Fn(usize) -> f32 + Sync,
    across: &mut Vec<f32>,
    out: &mut Vec<f32>,
) {
    // A NaN or non-positive sigma blurs nothing.
    if sigma.is_nan() || sigma <= 0.0 || w == 0 || h == 0 {
        out.clear();
        out.extend((0..w as usize * h as usize).map(value));
        return;
    }
    convolve_into(w, h, &gaussian_kernel(sigma), 1.0, value, across, out);
}

/// The `w` × `h` picture of `value(i)` (pixel `i` row-major) convolved with the symmetric
/// `kernel` (an odd count of taps) along the rows, then down the columns, edges padded by
/// continuity, each pass's sums divided by `sum`: 1 for a kernel already normalised ([`blur`]'s;
/// dividing by 1 changes no float, and is skipped), or the sum of unnormalised taps (the set
/// likeness's window, whose sums were always divided after). Per pixel and pass:
/// `Σ kernel[i] · src[i]` over the taps in order from 0, then the division.
pub(crate) fn convolve(
    width: u32,
    height: u32,
    kernel: &[f32],
    sum: f32,
    value: impl Fn(usize) -> f32 + Sync,
) -> Gray {
    let mut data = Vec::new();
    convolve_into(
        width,
        height,
        kernel,
        sum,
        value,
        &mut Vec::new(),
        &mut data,
    );
    Gray {
        width,
        height,
        data,
    }
}

/// [`convolve`] written into `out`, with `across` between the passes (see [`blur_of_into`]).
fn convolve_into(
    width: u32,
    height: u32,
    kernel: &[f32],
    sum: f32,
    value: impl Fn(usize) -> f32 + Sync,
    across: &mut Vec<f32>,
    out: &mut Vec<f32>,
) {
    let (w, h) = (width as usize, height as usize);
    resize_unset(out, w * h);
    if w == 0 || h == 0 {
        return;
    }
    let r = kernel.len() / 2;
    let divide = |out: &mut [f32]| {
        if sum != 1.0 {
            out.iter_mut().for_each(|o| *o /= sum);
        }
    };
    // Per row of `across` and whole run of pixels in it: the value the run holds when every tap
    // of it read one value (so the run is flat), else NaN. A run of the column pass whose taps'
    // runs are all flat with one value reads only that value too.
    let runs = w / RUN;
    let mut flat = vec![f32::NAN; h * runs.max(1)];
    // Along the rows: each row padded by its end pixels, then each run of pixels summed tap by
    // tap (see `taps`).
    resize_unset(across, w * h);
    across
        .par_chunks_mut(w)
        .zip(flat.par_chunks_mut(runs.max(1)))
        .enumerate()
        .for_each_init(Vec::new, |padded, (y, (out, flat))| {
            let row = y * w;
            padded.clear();
            padded.extend(std::iter::repeat_n(value(row), r));
            padded.extend((row..row + w).map(&value));
            padded.extend(std::iter::repeat_n(value(row + w - 1), r));
            let padded = &padded[..];
            // The run from `x` reads the padded row from `x` to `x + RUN + 2r`.
            let one_value = |x: usize| {
                let read = &padded[x..x + RUN + 2 * r];
                let v = read[0];
                read.iter().all(|&p| p == v).then_some(v)
            };
            taps(out, kernel, |i, x| &padded[i + x..], one_value, flat);
            divide(out);
            for (k, f) in flat.iter_mut().enumerate().take(runs) {
                if !f.is_nan() {
                    *f = out[k * RUN];
                }
            }
        });
    // Down the columns: each output row sums the rows above and below it (clamped to the
    // picture), tap by tap; the rows of its taps are found once per output row, not per run.
    let (across, flat) = (&across[..], &flat[..]);
    out.par_chunks_mut(w).enumerate().for_each_init(
        || (Vec::new(), Vec::new()),
        |(rows, at): &mut (Vec<&[f32]>, Vec<usize>), (y, out)| {
            rows.clear();
            at.clear();
            for i in 0..kernel.len() {
                let sy = (y + i).saturating_sub(r).min(h - 1);
                rows.push(&across[sy * w..(sy + 1) * w]);
                at.push(sy * runs);
            }
            let (rows, at) = (&rows[..], &at[..]);
            let one_value = |x: usize| {
                let k = x / RUN;
                let v = flat[at[0] + k];
                (!v.is_nan() && at.iter().all(|&a| flat[a + k] == v)).then_some(v)
            };
            taps(out, kernel, |i, x| &rows[i][x..], one_value, &mut []);
            divide(out);
        },
    );
}

/// `out[x] = Σ kernel[i] · src(i, x)[0]` over the taps in order, each sum starting at 0, as
/// adding each tap's product to every pixel in turn gives it (imageproc's order, to the bit), but
/// a run of [`RUN`] pixels at a time with its sums held in registers instead of read and written
/// back once per tap. `src(i, x)` is the source of tap `i` from pixel `x` on.
///
/// When `one_value(x)` finds every tap of the run from `x` reads one value `v` (a flat part of
/// the picture: a two-tone's measure blurs large areas of one tone), each of the run's sums is
/// `Σ kernel[i] · v` in the same order, made once; the run's entry of `flat` (when there is one)
/// then says so. Equal floats are the same float but for the sign of zero, and a sum from +0 of
/// zeros of either sign is +0 either way.
#[inline(always)]
fn taps<'a>(
    out: &mut [f32],
    kernel: &[f32],
    src: impl Fn(usize, usize) -> &'a [f32],
    one_value: impl Fn(usize) -> Option<f32>,
    flat: &mut [f32],
) {
    let mut x = 0;
    while x + RUN <= out.len() {
        if let Some(v) = one_value(x) {
            let mut s = 0f32;
            for &k in kernel {
                s += v * k;
            }
            out[x..x + RUN].fill(s);
            if let Some(f) = flat.get_mut(x / RUN) {
                *f = s;
            }
            x += RUN;
            continue;
        }
        let mut acc = [0f32; RUN];
        for (i, &k) in kernel.iter().enumerate() {
            let p = &src(i, x)[..RUN];
            for j in 0..RUN {
                acc[j] += p[j] * k;
            }
        }
        out[x..x + RUN].copy_from_slice(&acc);
        x += RUN;
    }
    let rest = out.len() - x;
    if rest > 0 {
        let out = &mut out[x..];
        out.fill(0.0);
        for (i, &k) in kernel.iter().enumerate() {
            for (o, &p) in out.iter_mut().zip(&src(i, x)[..rest]) {
                *o += p * k;
            }
        }
    }
}

/// Pixels a [`taps`] run holds in registers: eight SSE vectors, enough independent sums to keep
/// the adder busy while each waits for the one before (16 left it waiting: a fifth slower).
const RUN: usize = 32;

/// `imageproc`'s Gaussian kernel for `sigma`, to the last bit: `2σ` taps each side (rounded
/// up), the density at each tap, divided by their sum.
fn gaussian_kernel(sigma: f32) -> Vec<f32> {
    let r = (2.0 * sigma).ceil() as usize;
    let pdf = |x: f32| {
        (sigma * (2.0 * std::f32::consts::PI).sqrt()).recip()
            * (-x.powi(2) / (2.0 * sigma.powi(2))).exp()
    };
    let mut k = vec![0f32; 2 * r + 1];
    for i in 0..=r {
        let v = pdf(i as f32);
        k[r + i] = v;
        k[r - i] = v;
    }
    let sum: f32 = k.iter().sum();
    k.iter_mut().for_each(|x| *x /= sum);
    k
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Lcg;
    use image::ImageBuffer;
    use imageproc::filter::gaussian_blur_f32;

    /// The box average as it was: box by box, each summed row by row.
    fn shrink_by_boxes(w: u32, h: u32, d: u32, value: impl Fn(usize) -> f32) -> Vec<f32> {
        let (ow, oh) = (w.div_ceil(d), h.div_ceil(d));
        let mut out = Vec::new();
        for oy in 0..oh {
            for ox in 0..ow {
                let (mut s, mut n) = (0f32, 0u32);
                for y in oy * d..((oy + 1) * d).min(h) {
                    for x in ox * d..((ox + 1) * d).min(w) {
                        s += value((y * w + x) as usize);
                        n += 1;
                    }
                }
                out.push(s / n as f32);
            }
        }
        out
    }

    fn bit_vals(v: &[f32]) -> Vec<u32> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// Summed a source row at a time (and a two-tone by counting), the boxes hold the same
    /// values to the bit: random sizes, partial boxes at the edges, both tones.
    #[test]
    fn shrinking_by_rows_and_by_counts_is_shrinking_box_by_box() {
        let mut rng = Lcg(17u64);
        let mut rnd = |n: u64| rng.below(n);
        for _ in 0..60 {
            let (w, h, d) = (1 + rnd(90) as u32, 1 + rnd(70) as u32, 1 + rnd(6) as u32);
            let gray: Vec<f32> = (0..w * h).map(|_| rnd(1 << 20) as f32 / 1e6).collect();
            let bits = BitGrid::from_fn(w, h, |_, _| rnd(3) == 0);
            let want = shrink_by_boxes(w, h, d, |i| gray[i]);
            let got = box_average(w, h, d, |i| gray[i]);
            assert_eq!((got.width, got.height), (w.div_ceil(d), h.div_ceil(d)));
            assert_eq!(bit_vals(&got.data), bit_vals(&want), "{w}x{h} by {d}");
            for invert in [false, true] {
                let want =
                    shrink_by_boxes(w, h, d, |i| if bits.data[i] != invert { 1.0 } else { 0.0 });
                let got = box_average_bits(&bits, d, invert);
                assert_eq!(bit_vals(&got.data), bit_vals(&want), "{w}x{h} by {d} bits");
            }
        }
    }

    /// The row-at-a-time blur gives `imageproc`'s floats exactly, on random pictures of many
    /// shapes (a row or column alone, a kernel wider than the picture) and many widths.
    #[test]
    fn blur_is_imageprocs_to_the_bit() {
        let mut rng = Lcg(7);
        let mut next = || (rng.next_u64() >> 32) as u32;
        for (w, h) in [
            (1, 1),
            (1, 9),
            (13, 1),
            (5, 3),
            (37, 23),
            (64, 65),
            (200, 130),
        ] {
            let mut g = Gray::new(w, h, 0.0);
            for v in &mut g.data {
                // Mostly 0..1, a few outside it, as a stretched or adjusted gray may be.
                *v = (next() >> 8) as f32 / (1 << 24) as f32 * 1.2 - 0.1;
            }
            for sigma in [0.3f32, 0.5, 1.0, 1.7, 2.9, 5.8, 11.3, 40.0] {
                let image: ImageBuffer<image::Luma<f32>, Vec<f32>> =
                    ImageBuffer::from_raw(g.width, g.height, g.data.clone()).unwrap();
                let want = gaussian_blur_f32(&image, sigma).into_raw();
                let got = blur(&g, sigma).data;
                assert_eq!(bit_vals(&got), bit_vals(&want), "{w}x{h} sigma {sigma}");
            }
        }
    }

    /// Blurring the picture of a function (a square, a product) gives the floats of blurring
    /// that picture made first, on random pictures of many widths (runs and their remainders).
    #[test]
    fn blurring_a_function_is_blurring_its_picture() {
        let mut rng = Lcg(31);
        for (w, h) in [(1, 1), (3, 40), (31, 5), (33, 17), (64, 9), (95, 30)] {
            let a: Vec<f32> = (0..w * h).map(|_| rng.unit() as f32).collect();
            let b: Vec<f32> = (0..w * h).map(|_| rng.unit() as f32).collect();
            let product = Gray {
                width: w,
                height: h,
                data: a.iter().zip(&b).map(|(p, q)| p * q).collect(),
            };
            for sigma in [0.0f32, 0.7, 2.9, 5.8] {
                let want = blur(&product, sigma).data;
                let got = blur_of(w, h, sigma, |i| a[i] * b[i]).data;
                assert_eq!(bit_vals(&got), bit_vals(&want), "{w}x{h} sigma {sigma}");
            }
        }
    }

    /// Pictures with flat parts (a two-tone's areas of one tone, a constant, zeros of both signs
    /// side by side) beside noise: the runs of pixels whose taps all read one value, summed once,
    /// hold the floats summing each pixel gives (`imageproc`'s blur; the pixel-by-pixel blur with
    /// a sum), and so do the runs next to them.
    #[test]
    fn flat_parts_blur_to_the_same_floats() {
        let mut rng = Lcg(43);
        let taps: Vec<f32> = (-5i32..=5)
            .map(|d| (-(d * d) as f32 / (2.0 * 1.5 * 1.5)).exp())
            .collect();
        let sum: f32 = taps.iter().sum();
        for (w, h) in [(40, 30), (97, 64), (160, 130), (400, 90)] {
            let mut g = Gray::new(w, h, 0.0);
            for (i, v) in g.data.iter_mut().enumerate() {
                let (x, y) = (i as u32 % w, i as u32 / w);
                *v = match (x / 75 + y / 40) % 5 {
                    0 => 0.0,
                    1 => 1.0,
                    2 => 0.37,
                    3 if (x + y) % 2 == 0 => -0.0,
                    3 => 0.0,
                    _ => rng.unit() as f32,
                };
            }
            let image: ImageBuffer<image::Luma<f32>, Vec<f32>> =
                ImageBuffer::from_raw(w, h, g.data.clone()).unwrap();
            for sigma in [0.5f32, 1.0, 2.9, 5.8] {
                let want = gaussian_blur_f32(&image, sigma).into_raw();
                let got = blur(&g, sigma).data;
                assert_eq!(bit_vals(&got), bit_vals(&want), "{w}x{h} sigma {sigma}");
            }
            let want = blur_11_taps(&g.data, w, h);
            let got = convolve(w, h, &taps, sum, |i| g.data[i]).data;
            assert_eq!(bit_vals(&got), bit_vals(&want), "{w}x{h} with a sum");
        }
    }

    /// The set likeness's blur as it was written in `layers`: 11 unnormalised taps, each pass
    /// summed pixel by pixel with clamped edges, then divided by the taps' sum.
    fn blur_11_taps(v: &[f32], w: u32, h: u32) -> Vec<f32> {
        let taps: Vec<f32> = (-5i32..=5)
            .map(|d| (-(d * d) as f32 / (2.0 * 1.5 * 1.5)).exp())
            .collect();
        let norm: f32 = taps.iter().sum();
        let (w, h) = (w as i32, h as i32);
        let pass = |src: &[f32], horizontal: bool| -> Vec<f32> {
            let mut out = vec![0f32; src.len()];
            for y in 0..h {
                for x in 0..w {
                    let mut s = 0.0;
                    for (t, d) in taps.iter().zip(-5i32..=5) {
                        let (sx, sy) = if horizontal {
                            ((x + d).clamp(0, w - 1), y)
                        } else {
                            (x, (y + d).clamp(0, h - 1))
                        };
                        s += t * src[(sy * w + sx) as usize];
                    }
                    out[(y * w + x) as usize] = s / norm;
                }
            }
            out
        };
        pass(&pass(v, true), false)
    }

    /// [`convolve`] with unnormalised taps and their sum gives that blur's floats exactly.
    #[test]
    fn convolving_with_a_sum_is_the_pixel_by_pixel_blur() {
        let mut rng = Lcg(23);
        let taps: Vec<f32> = (-5i32..=5)
            .map(|d| (-(d * d) as f32 / (2.0 * 1.5 * 1.5)).exp())
            .collect();
        let sum: f32 = taps.iter().sum();
        for (w, h) in [
            (1, 1),
            (1, 7),
            (9, 1),
            (3, 4),
            (17, 33),
            (40, 21),
            (200, 150),
        ] {
            let data: Vec<f32> = (0..w * h).map(|_| rng.unit() as f32).collect();
            let g = Gray {
                width: w,
                height: h,
                data,
            };
            let want = blur_11_taps(&g.data, w, h);
            let got = convolve(w, h, &taps, sum, |i| g.data[i]).data;
            assert_eq!(bit_vals(&got), bit_vals(&want), "{w}x{h}");
        }
    }
}
