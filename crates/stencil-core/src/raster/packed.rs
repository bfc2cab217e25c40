//! A bit grid packed 64 pixels to a word, and the disc morphology on it: dilation by a disc is
//! an OR, over the disc's rows, of each row dilated sideways by that row's half-width, and a
//! sideways dilation is a handful of word shifts. So opening and closing cost a few word
//! operations per 64 pixels instead of two distance transforms per pixel; the result is the
//! same pixel for pixel (the tests check it against the distance-transform form).

use rayon::prelude::*;

use super::grid::BitGrid;

/// Rows of 64-pixel words, bit `x % 64` of word `x / 64` is pixel x. Bits past the width are 0.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Packed {
    pub width: usize,
    pub height: usize,
    /// Words per row.
    pub(crate) stride: usize,
    pub(crate) words: Vec<u64>,
}

impl Packed {
    fn zeros(width: usize, height: usize, stride: usize) -> Packed {
        Packed {
            width,
            height,
            stride,
            words: vec![0; stride * height],
        }
    }

    pub(crate) fn from_grid(bits: &BitGrid) -> Packed {
        let (w, h) = (bits.width as usize, bits.height as usize);
        let mut p = Packed::zeros(w, h, w.div_ceil(64).max(1));
        let stride = p.stride;
        if w > 0 {
            p.words
                .par_chunks_mut(stride)
                .zip(bits.data.par_chunks(w))
                .for_each(|(row, src)| pack_row(src, row));
        }
        p
    }

    pub(crate) fn to_grid(&self) -> BitGrid {
        let (w, h) = (self.width, self.height);
        let mut data = vec![false; w * h];
        if w > 0 {
            data.par_chunks_mut(w)
                .zip(self.words.par_chunks(self.stride))
                .for_each(|(out, row)| {
                    for (x, o) in out.iter_mut().enumerate() {
                        *o = row[x / 64] >> (x % 64) & 1 == 1;
                    }
                });
        }
        BitGrid::from_data(w as u32, h as u32, data)
    }

    #[inline]
    pub(crate) fn row(&self, y: usize) -> &[u64] {
        &self.words[y * self.stride..(y + 1) * self.stride]
    }

    /// Row `y`'s words with a one where the pixel is `value`, none past the width.
    pub(crate) fn row_where(&self, y: usize, value: bool) -> impl Iterator<Item = u64> + '_ {
        let (last, tail) = (self.stride - 1, tail_mask(self.width));
        let flip = if value { 0 } else { u64::MAX };
        let row = self.row(y).iter().enumerate();
        row.map(move |(k, &v)| {
            if k == last {
                (v ^ flip) & tail
            } else {
                v ^ flip
            }
        })
    }

    /// Pixels that differ between two grids of the same size.
    pub(crate) fn count_diff(&self, other: &Packed) -> usize {
        self.words
            .iter()
            .zip(&other.words)
            .map(|(a, b)| (a ^ b).count_ones() as usize)
            .sum()
    }

    /// Every pixel flipped (the bits past the width stay 0).
    fn not(&self) -> Packed {
        let mut p = self.clone();
        let tail = tail_mask(self.width);
        for row in p.words.chunks_mut(self.stride) {
            for v in row.iter_mut() {
                *v = !*v;
            }
            if let Some(last) = row.last_mut() {
                *last &= tail;
            }
        }
        p
    }

    /// `pad` pixels added on every side, each repeating the nearest edge pixel.
    fn padded(&self, pad: usize) -> Packed {
        let (w, h) = (self.width + 2 * pad, self.height + 2 * pad);
        let mut p = Packed::zeros(w, h, w.div_ceil(64).max(1));
        let stride = p.stride;
        let (sw, sh) = (self.width, self.height);
        p.words
            .par_chunks_mut(stride)
            .enumerate()
            .for_each(|(y, row)| {
                let src = self.row(y.saturating_sub(pad).min(sh - 1));
                // The source row moved right by `pad`, then its edge pixels repeated.
                shift_into(src, row, pad as isize);
                let first = src[0] & 1 == 1;
                let last = src[(sw - 1) / 64] >> ((sw - 1) % 64) & 1 == 1;
                if first {
                    set_range(row, 0, pad);
                }
                if last {
                    set_range(row, pad + sw, w);
                }
            });
        p
    }

    /// The `width`×`height` window from (`x0`, `y0`).
    fn crop(&self, x0: usize, y0: usize, width: usize, height: usize) -> Packed {
        let mut p = Packed::zeros(width, height, width.div_ceil(64).max(1));
        let stride = p.stride;
        let tail = tail_mask(width);
        p.words
            .par_chunks_mut(stride)
            .enumerate()
            .for_each(|(y, row)| {
                shift_into(self.row(y + y0), row, -(x0 as isize));
                if let Some(l) = row.last_mut() {
                    *l &= tail;
                }
            });
        p
    }

    /// Every pixel within Euclidean distance `r` of a set pixel set; with `frame`, also every
    /// pixel within `r` of a ring just outside the grid (the distance transform's frame:
    /// see [`super::squared_distance_to`]).
    fn dilate(&self, r: usize, frame: bool) -> Packed {
        let (w, h, stride) = (self.width, self.height, self.stride);
        // The disc's half-width on each row offset: the largest dx with dx² + dy² <= r².
        let half: Vec<usize> = (0..=r)
            .map(|dy| {
                let rem = r * r - dy * dy;
                let mut dx = (rem as f64).sqrt() as usize;
                while (dx + 1) * (dx + 1) <= rem {
                    dx += 1;
                }
                while dx * dx > rem {
                    dx -= 1;
                }
                dx
            })
            .collect();
        let mut widths = half.clone();
        widths.sort_unstable();
        widths.dedup();
        // Room past the width for the shifts, so nothing is lost before the shift back.
        let wide = (w + 2 * r + 1).div_ceil(64) + 1;
        // Each row dilated sideways, once per distinct half-width.
        let sideways: Vec<Vec<u64>> = widths
            .iter()
            .map(|&hw| {
                let mut out = vec![0u64; stride * h];
                out.par_chunks_mut(stride).enumerate().for_each_init(
                    || (vec![0u64; wide], vec![0u64; wide], vec![0u64; wide]),
                    |(a, b, c), (y, row)| {
                        a.fill(0);
                        a[..stride].copy_from_slice(self.row(y));
                        run_or(a, 2 * hw + 1, b, c);
                        // `b` covers offsets 0..=2hw to the right: move it back by hw.
                        shift_into(b, row, -(hw as isize));
                    },
                );
                out
            })
            .collect();
        let which: Vec<usize> = half
            .iter()
            .map(|hw| widths.binary_search(hw).unwrap_or(0))
            .collect();
        let mut out = Packed::zeros(w, h, stride);
        let tail = tail_mask(w);
        out.words
            .par_chunks_mut(stride)
            .enumerate()
            .for_each(|(y, row)| {
                let lo = y.saturating_sub(r);
                let hi = (y + r).min(h - 1);
                for sy in lo..=hi {
                    let src = &sideways[which[sy.abs_diff(y)]][sy * stride..(sy + 1) * stride];
                    for (o, s) in row.iter_mut().zip(src) {
                        *o |= s;
                    }
                }
                if frame {
                    if y < r || y + r >= h {
                        set_range(row, 0, w);
                    } else {
                        set_range(row, 0, r.min(w));
                        set_range(row, w.saturating_sub(r), w);
                    }
                }
                if let Some(l) = row.last_mut() {
                    *l &= tail;
                }
            });
        out
    }

    /// Material eroded by a disc of radius `r`: a pixel stays set when no unset pixel of the grid
    /// lies within `r` (outside the grid counts as nothing).
    fn erode(&self, r: usize) -> Packed {
        self.not().dilate(r, false).not()
    }
}

/// Opening by a disc of radius `r`, the image extended by repeating its edge pixels (see
/// [`super::open`]).
pub(crate) fn open(bits: &Packed, r: u32) -> Packed {
    let (r, pad) = (r as usize, r as usize + 2);
    bits.padded(pad)
        .erode(r)
        .dilate(r, true)
        .crop(pad, pad, bits.width, bits.height)
}

/// Closing by a disc of radius `r`, as [`open`].
pub(crate) fn close(bits: &Packed, r: u32) -> Packed {
    let (r, pad) = (r as usize, r as usize + 2);
    bits.padded(pad)
        .dilate(r, true)
        .erode(r)
        .crop(pad, pad, bits.width, bits.height)
}

fn pack_row(src: &[bool], row: &mut [u64]) {
    for (word, chunk) in row.iter_mut().zip(src.chunks(64)) {
        *word = pack_word(chunk);
    }
}

/// A word whose bits `0..src.len()` (at most 64) are `src`: eight at a time, their bytes (each 0
/// or 1) gathered into one byte by a multiply (byte `i`'s bit lands on bit `56 + i` and no two
/// partial products share a bit, so nothing carries).
pub(crate) fn pack_word(src: &[bool]) -> u64 {
    debug_assert!(src.len() <= 64);
    let mut v = 0u64;
    let mut chunks = src.chunks_exact(8);
    for (k, c) in chunks.by_ref().enumerate() {
        let bytes = u64::from_le_bytes([
            c[0] as u8, c[1] as u8, c[2] as u8, c[3] as u8, c[4] as u8, c[5] as u8, c[6] as u8,
            c[7] as u8,
        ]);
        v |= (bytes.wrapping_mul(0x0102_0408_1020_4080) >> 56) << (8 * k);
    }
    let done = src.len() / 8 * 8;
    for (j, &b) in chunks.remainder().iter().enumerate() {
        v |= (b as u64) << (done + j);
    }
    v
}

/// Ones in the bits of the last word of a row that hold pixels.
fn tail_mask(width: usize) -> u64 {
    match width % 64 {
        0 => u64::MAX,
        n => (1u64 << n) - 1,
    }
}

/// Set pixels `from..to` of a row.
fn set_range(row: &mut [u64], from: usize, to: usize) {
    for x in from..to.min(row.len() * 64) {
        if x % 64 == 0 && x + 64 <= to {
            // A whole word at once.
            row[x / 64] = u64::MAX;
        } else {
            row[x / 64] |= 1 << (x % 64);
        }
    }
}

/// `dst[x] = src[x - by]` (to the right for `by` > 0), zero where `src` has no pixel; as many
/// words as `dst` holds.
fn shift_into(src: &[u64], dst: &mut [u64], by: isize) {
    let (words, bits) = (by.div_euclid(64), by.rem_euclid(64) as u32);
    let get = |i: isize| -> u64 {
        if i >= 0 && (i as usize) < src.len() {
            src[i as usize]
        } else {
            0
        }
    };
    for (i, d) in dst.iter_mut().enumerate() {
        let j = i as isize - words;
        *d = if bits == 0 {
            get(j)
        } else {
            get(j) << bits | get(j - 1) >> (64 - bits)
        };
    }
}

/// `out[x]` = any of `a[x - len + 1 ..= x]`: the OR of `a` shifted right by 0 to `len - 1`, by
/// doubling. `a` is used as scratch; `tmp` too.
fn run_or(a: &mut [u64], len: usize, out: &mut [u64], tmp: &mut [u64]) {
    out.fill(0);
    let (mut have, mut span) = (0usize, 1usize);
    let mut left = len;
    loop {
        if left & 1 == 1 {
            // out |= a shifted right by `have` (a covers offsets 0..span).
            shift_into(a, tmp, have as isize);
            for (o, t) in out.iter_mut().zip(tmp.iter()) {
                *o |= t;
            }
            have += span;
        }
        left >>= 1;
        if left == 0 {
            break;
        }
        shift_into(a, tmp, span as isize);
        for (x, t) in a.iter_mut().zip(tmp.iter()) {
            *x |= t;
        }
        span *= 2;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Lcg;

    /// The distance-transform forms these replace.
    fn open_ref(bits: &BitGrid, r: u32) -> BitGrid {
        super::super::morph::tests::open_edt(bits, r)
    }
    fn close_ref(bits: &BitGrid, r: u32) -> BitGrid {
        super::super::morph::tests::close_edt(bits, r)
    }

    fn random_grid(w: u32, h: u32, rng: &mut Lcg, density: u32) -> BitGrid {
        BitGrid::from_fn(w, h, |_, _| rng.below(100) < density as u64)
    }

    #[test]
    fn packing_round_trips() {
        let mut s = Lcg(7);
        for (w, h) in [(1, 1), (63, 3), (64, 2), (65, 5), (130, 7)] {
            let g = random_grid(w, h, &mut s, 50);
            assert_eq!(Packed::from_grid(&g).to_grid(), g);
        }
    }

    #[test]
    fn open_and_close_equal_the_distance_transform_forms() {
        let mut s = Lcg(12345);
        for (w, h) in [
            (1, 1),
            (5, 9),
            (63, 20),
            (64, 64),
            (65, 31),
            (129, 70),
            (200, 3),
        ] {
            for density in [3, 30, 50, 70, 97] {
                let g = random_grid(w, h, &mut s, density);
                let p = Packed::from_grid(&g);
                for r in [1, 2, 3, 4, 5, 7, 12] {
                    assert_eq!(
                        open(&p, r).to_grid(),
                        open_ref(&g, r),
                        "open {w}x{h} {density}% r{r}"
                    );
                    assert_eq!(
                        close(&p, r).to_grid(),
                        close_ref(&g, r),
                        "close {w}x{h} {density}% r{r}"
                    );
                }
            }
        }
    }

    #[test]
    fn blobs_open_and_close_alike() {
        // Smooth shapes (discs and bars) rather than noise: long runs across word boundaries.
        let g = BitGrid::from_fn(300, 170, |x, y| {
            let (fx, fy) = (x as f32, y as f32);
            ((fx - 80.0).hypot(fy - 60.0) < 45.0)
                || ((fx - 200.0).hypot(fy - 100.0) % 30.0 < 4.0)
                || (x % 67 < 2)
                || (y > 150 && x > 250)
        });
        let p = Packed::from_grid(&g);
        for r in [1, 2, 3, 6, 9] {
            assert_eq!(open(&p, r).to_grid(), open_ref(&g, r));
            assert_eq!(close(&p, r).to_grid(), close_ref(&g, r));
        }
    }
}
