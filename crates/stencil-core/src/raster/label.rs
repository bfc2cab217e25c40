//! Connected pieces of a bit grid: runs along rows joined by union-find. The islands stage builds
//! the frame and the islands on it; the topological filter and the checks use it for specks.

use super::grid::BitGrid;

/// Label of a pixel that [`components`] did not label (its bit is not the one asked for).
pub(crate) const NOT_LABELLED: u32 = u32::MAX;

/// 4-connected components of the pixels equal to `value`: a label per pixel ([`NOT_LABELLED`] where the pixel
/// is not `value`), and the area of each component. O(pixels).
pub(crate) fn components(bits: &BitGrid, value: bool) -> (Vec<u32>, Vec<usize>) {
    let (w, h) = (bits.width as usize, bits.height as usize);
    let (runs, row_first) = runs_of(bits, value);
    let (piece, count) = join_runs(&runs, &row_first, false);
    let mut labels = vec![NOT_LABELLED; w * h];
    let mut areas = vec![0usize; count];
    for (r, &id) in runs.iter().zip(&piece) {
        let s = r.y as usize * w;
        labels[s + r.x0 as usize..=s + r.x1 as usize].fill(id);
        areas[id as usize] += (r.x1 - r.x0 + 1) as usize;
    }
    (labels, areas)
}

/// The runs of pixels equal to `value` along each row, left to right, and the index of each row's
/// first run (with one entry past the last row), as [`join_runs`] takes them. Bands of
/// [`RUN_BAND`] rows are scanned in parallel and their runs joined in order: the same list as
/// row after row (on the 1.2 MP photo the scan was a serial millisecond of the labelling).
pub(crate) fn runs_of(bits: &BitGrid, value: bool) -> (Vec<Run>, Vec<usize>) {
    use rayon::prelude::*;
    let h = bits.height as usize;
    if h <= RUN_BAND {
        return runs_of_rows(bits, value, 0..h);
    }
    let bands: Vec<(Vec<Run>, Vec<usize>)> = (0..h.div_ceil(RUN_BAND))
        .into_par_iter()
        .map(|b| runs_of_rows(bits, value, b * RUN_BAND..((b + 1) * RUN_BAND).min(h)))
        .collect();
    let mut runs = Vec::with_capacity(bands.iter().map(|b| b.0.len()).sum());
    let mut row_first = Vec::with_capacity(h + 1);
    for (band, first) in bands {
        let base = runs.len();
        row_first.extend(first[..first.len() - 1].iter().map(|&f| base + f));
        runs.extend(band);
    }
    row_first.push(runs.len());
    debug_assert_eq!(row_first.len(), h + 1);
    (runs, row_first)
}

/// Rows per band of [`runs_of`].
const RUN_BAND: usize = 64;

/// [`runs_of`] over `rows` only: their runs, and the index of each row's first run within them
/// (with one entry past the last row). Rows are read 64 pixels a word
/// ([`super::packed::pack_word`]) and runs found from the set bits by [`push_runs`].
fn runs_of_rows(
    bits: &BitGrid,
    value: bool,
    rows: std::ops::Range<usize>,
) -> (Vec<Run>, Vec<usize>) {
    let w = bits.width as usize;
    let mut runs: Vec<Run> = Vec::new();
    let mut row_first = Vec::with_capacity(rows.len() + 1);
    for y in rows {
        row_first.push(runs.len());
        let row = &bits.data[y * w..(y + 1) * w];
        let words = row.chunks(64).map(|chunk| {
            let packed = super::packed::pack_word(chunk);
            // Ones where the pixel is `value`; none past the row's end.
            if value {
                packed
            } else {
                !packed & (u64::MAX >> (64 - chunk.len()))
            }
        });
        push_runs(y as u32, words, &mut runs);
    }
    row_first.push(runs.len());
    (runs, row_first)
}

/// [`runs_of_rows`] pixel by pixel, as first written: the reference the tests compare it with.
#[cfg(test)]
fn runs_of_rows_plain(
    bits: &BitGrid,
    value: bool,
    rows: std::ops::Range<usize>,
) -> (Vec<Run>, Vec<usize>) {
    let w = bits.width as usize;
    let mut runs: Vec<Run> = Vec::new();
    let mut row_first = Vec::with_capacity(rows.len() + 1);
    for y in rows {
        row_first.push(runs.len());
        let row = &bits.data[y * w..(y + 1) * w];
        let mut x = 0;
        while x < w {
            if row[x] != value {
                x += 1;
                continue;
            }
            let start = x;
            while x < w && row[x] == value {
                x += 1;
            }
            runs.push(Run {
                y: y as u32,
                x0: start as u32,
                x1: x as u32 - 1,
            });
        }
    }
    row_first.push(runs.len());
    (runs, row_first)
}

/// Whether component labels touch the image border, indexed by label.
pub(crate) fn touches_border(labels: &[u32], width: u32, height: u32, count: usize) -> Vec<bool> {
    let (w, h) = (width as usize, height as usize);
    let mut t = vec![false; count];
    let mut mark = |i: usize| {
        if labels[i] != NOT_LABELLED {
            t[labels[i] as usize] = true;
        }
    };
    for x in 0..w {
        mark(x);
        mark((h - 1) * w + x);
    }
    for y in 0..h {
        mark(y * w);
        mark(y * w + w - 1);
    }
    t
}

/// A run of pixels along row `y`, columns `x0..=x1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Run {
    pub(crate) y: u32,
    pub(crate) x0: u32,
    pub(crate) x1: u32,
}

/// Append to `runs` the runs of set bits of row `y`, given as words of 64 pixels (bit `i` of word
/// `k` is column `64k + i`; no bit set past the row's end): one run per stretch of set bits, a
/// stretch that crosses from one word into the next included. Found with trailing-zero counts,
/// a few operations per run rather than a test per pixel.
pub(crate) fn push_runs(y: u32, words: impl IntoIterator<Item = u64>, runs: &mut Vec<Run>) {
    for (k, mut word) in words.into_iter().enumerate() {
        while word != 0 {
            let start = word.trailing_zeros();
            let len = (!(word >> start)).trailing_zeros();
            let (x0, x1) = (k as u32 * 64 + start, k as u32 * 64 + start + len - 1);
            match runs.last_mut() {
                // A run that goes on from the word before.
                Some(last) if last.y == y && last.x1 + 1 == x0 => last.x1 = x1,
                _ => runs.push(Run { y, x0, x1 }),
            }
            let end = start + len;
            word = if end >= 64 { 0 } else { word & (!0u64 << end) };
        }
    }
}

/// The root of `r`'s set in the union-find forest `parent`, halving the path on the way.
pub(crate) fn root(parent: &mut [u32], mut r: usize) -> usize {
    while parent[r] as usize != r {
        let p = parent[r] as usize;
        parent[r] = parent[p];
        r = p;
    }
    r
}

/// Join the sets of `a` and `b` in `parent`: the lower root stays the root, so each root is its
/// set's first member in scan order.
pub(crate) fn join(parent: &mut [u32], a: usize, b: usize) {
    let (ra, rb) = (root(parent, a), root(parent, b));
    if ra != rb {
        parent[ra.max(rb)] = ra.min(rb) as u32;
    }
}

/// The connected pieces of runs listed row by row (`row_first[y]` the index of row `y`'s first
/// run, one entry past the last row): runs in neighbouring rows join where they overlap, or touch
/// at a corner when `corners`. Returns each run's piece and the number of pieces, numbered in
/// raster order of their first pixel (union-find over the runs).
pub(crate) fn join_runs(runs: &[Run], row_first: &[usize], corners: bool) -> (Vec<u32>, usize) {
    let mut parent: Vec<u32> = (0..runs.len() as u32).collect();
    let slack = corners as i64;
    for y in 1..row_first.len().saturating_sub(1) {
        let (mut a, a_end) = (row_first[y - 1], row_first[y]);
        let (mut b, b_end) = (row_first[y], row_first[y + 1]);
        while a < a_end && b < b_end {
            let (ra, rb) = (runs[a], runs[b]);
            if ra.x0 as i64 <= rb.x1 as i64 + slack && rb.x0 as i64 <= ra.x1 as i64 + slack {
                join(&mut parent, a, b);
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
    use crate::test_rng::Lcg;

    /// The runs found a word at a time are the runs found pixel by pixel, on random grids of
    /// every density (all cut and all material included), as narrow as a pixel and wider than
    /// several words (widths at, just under and just over a multiple of 64), for both values.
    #[test]
    fn runs_of_rows_by_words_is_pixel_by_pixel() {
        let mut rng = Lcg(0x3c6e_f372_fe94_f82b);
        let mut next = move || rng.next_u64() >> 33;
        for k in 0..160u32 {
            let w = match k % 5 {
                0 => 64 * (1 + k % 3),
                1 => 64 * (1 + k % 3) - 1,
                2 => 64 * (1 + k % 3) + 1,
                _ => 1 + (k * 37) % 300,
            };
            let h = 1 + k % 7;
            let fill = match k % 9 {
                0 => 0,
                1 => 100,
                _ => next() % 101,
            };
            // Long runs too: a pixel repeats the last with probability 3/4 on some grids.
            let sticky = k % 2 == 0;
            let mut last = false;
            let bits = BitGrid::from_fn(w, h, |_, _| {
                if !(sticky && next() % 4 != 0) {
                    last = next() % 100 < fill;
                }
                last
            });
            for value in [false, true] {
                let plain = runs_of_rows_plain(&bits, value, 0..h as usize);
                assert_eq!(
                    runs_of_rows(&bits, value, 0..h as usize),
                    plain,
                    "grid {k} ({w}x{h}) {value}"
                );
            }
        }
    }

    /// The runs found band by band are the runs found row after row, on random grids as tall as
    /// several bands (the last one part full) and as short as one.
    #[test]
    fn runs_of_in_bands_is_row_after_row() {
        let mut rng = Lcg(0x0123_4567_89ab_cdef);
        let mut next = move || rng.next_u64() >> 33;
        for k in 0..40u32 {
            let (w, h) = (1 + k * 7 % 53, 1 + k * 37 % 300);
            let fill = next() % 100;
            let bits = BitGrid::from_fn(w, h, |_, _| next() % 100 < fill);
            for value in [false, true] {
                let plain = runs_of_rows(&bits, value, 0..h as usize);
                assert_eq!(runs_of(&bits, value), plain, "grid {k} ({w}x{h}) {value}");
            }
        }
    }
}
