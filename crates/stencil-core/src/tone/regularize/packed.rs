//! Bit-packed rows and the disc opening on them. A round of the regularisation needs, for both
//! tones, which pixels no disc of their tone covers; with 64 pixels to a word that is a few
//! shifts, ANDs and ORs per word and disc row, so it is recomputed over the whole grid every
//! round instead of being kept up to date piecemeal.

use rayon::prelude::*;

use super::Disc;

/// A grid of bits, `stride` words per row: column `x` is bit `x % 64` of word `x / 64`. The bits
/// past `width` in a row's last word hold what lies past the grid's edge (see [`Packed::tail`]):
/// the row operations read them, and the words past either end of a row, as that value.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct Packed {
    pub width: usize,
    pub height: usize,
    pub stride: usize,
    pub data: Vec<u64>,
}

impl Packed {
    /// All `fill`, the tail bits too.
    pub fn new(width: usize, height: usize, fill: bool) -> Packed {
        let stride = width.div_ceil(64).max(1);
        Packed {
            width,
            height,
            stride,
            data: vec![word_of(fill); stride * height],
        }
    }

    pub fn get(&self, x: usize, y: usize) -> bool {
        self.data[y * self.stride + x / 64] >> (x % 64) & 1 == 1
    }

    pub fn set(&mut self, x: usize, y: usize, v: bool) {
        let w = &mut self.data[y * self.stride + x / 64];
        let m = 1u64 << (x % 64);
        if v {
            *w |= m;
        } else {
            *w &= !m;
        }
    }

    /// The pixel at index `i = y · width + x`.
    pub fn at(&self, i: usize) -> bool {
        self.get(i % self.width, i / self.width)
    }

    pub fn put(&mut self, i: usize, v: bool) {
        self.set(i % self.width, i / self.width, v);
    }

    /// Columns `x0..x0 + src.len()` of row `y` set from `src`.
    pub fn put_row(&mut self, y: usize, x0: usize, src: &[bool]) {
        let base = y * self.stride;
        let (mut x, mut k) = (x0, 0);
        while k < src.len() {
            let (word, bit) = (x / 64, x % 64);
            let n = (64 - bit).min(src.len() - k);
            let mut v = 0u64;
            for (j, &b) in src[k..k + n].iter().enumerate() {
                v |= (b as u64) << j;
            }
            let mask = if n == 64 { !0 } else { (1u64 << n) - 1 } << bit;
            let d = &mut self.data[base + word];
            *d = (*d & !mask) | (v << bit);
            x += n;
            k += n;
        }
    }

    /// Columns `x0..x0 + out.len()` of row `y`.
    pub fn get_row(&self, y: usize, x0: usize, out: &mut [bool]) {
        let row = self.row(y);
        for (k, o) in out.iter_mut().enumerate() {
            let x = x0 + k;
            *o = row[x / 64] >> (x % 64) & 1 == 1;
        }
    }

    pub fn row(&self, y: usize) -> &[u64] {
        &self.data[y * self.stride..(y + 1) * self.stride]
    }

    /// Set the bits past `width` in every row to `v`.
    pub fn tail(&mut self, v: bool) {
        let used = self.width % 64;
        if used == 0 {
            return;
        }
        let m = !0u64 << used;
        for y in 0..self.height {
            let w = &mut self.data[y * self.stride + self.stride - 1];
            if v {
                *w |= m;
            } else {
                *w &= !m;
            }
        }
    }

    /// Every bit flipped, the tail too.
    pub fn not(&self) -> Packed {
        Packed {
            data: self.data.iter().map(|w| !w).collect(),
            ..*self
        }
    }

    /// The number of set bits inside the grid (tail bits not counted).
    #[cfg(test)]
    pub fn count(&self) -> usize {
        let mut c = self.clone();
        c.tail(false);
        c.data.iter().map(|w| w.count_ones() as usize).sum()
    }
}

/// Whether work over a grid of this many pixels is worth spreading over threads: a small window
/// (a repair around one neck) is done sooner on one.
pub(super) fn parallel(pixels: usize) -> bool {
    pixels >= 1 << 16
}

/// `f` on each `n`-long chunk of `data` with its index and scratch from `init` (one per thread
/// or piece of work, not per chunk), on threads when `par`.
pub(super) fn rows_mut_with<T: Send, S>(
    data: &mut [T],
    n: usize,
    par: bool,
    init: impl Fn() -> S + Sync + Send,
    f: impl Fn(&mut S, (usize, &mut [T])) + Sync + Send,
) {
    if par {
        data.par_chunks_mut(n).enumerate().for_each_init(init, f)
    } else {
        let mut s = init();
        data.chunks_mut(n).enumerate().for_each(|c| f(&mut s, c))
    }
}

/// `f` on each `n`-long chunk of `data` with its index, on threads when `par`.
pub(super) fn rows_mut<T: Send>(
    data: &mut [T],
    n: usize,
    par: bool,
    f: impl Fn((usize, &mut [T])) + Sync + Send,
) {
    if par {
        data.par_chunks_mut(n).enumerate().for_each(f)
    } else {
        data.chunks_mut(n).enumerate().for_each(f)
    }
}

fn word_of(v: bool) -> u64 {
    if v {
        !0
    } else {
        0
    }
}

/// `out[x] = row[x + s]`, bit by bit; what lies past either end of `row` reads as `fill`.
fn shift(row: &[u64], s: i64, fill: u64, out: &mut [u64]) {
    let (q, r) = (s.div_euclid(64), s.rem_euclid(64) as u32);
    let (n, m) = (row.len() as i64, out.len() as i64);
    let word = |j: i64| {
        if (0..n).contains(&j) {
            row[j as usize]
        } else {
            fill
        }
    };
    let edge = |i: i64| {
        let j = i + q;
        if r == 0 {
            word(j)
        } else {
            (word(j) >> r) | (word(j + 1) << (64 - r))
        }
    };
    // The words whose sources `j` and `j + 1` both lie in the row, without the checks.
    let lo = (-q).clamp(0, m);
    let hi = (n - 1 - q).clamp(lo, m);
    for (i, o) in out.iter_mut().enumerate().take(lo as usize) {
        *o = edge(i as i64);
    }
    let (lo, hi) = (lo as usize, hi as usize);
    if lo < hi {
        let from = (lo as i64 + q) as usize;
        if r == 0 {
            out[lo..hi].copy_from_slice(&row[from..from + hi - lo]);
        } else {
            let src = &row[from..from + hi - lo + 1];
            for (o, w) in out[lo..hi].iter_mut().zip(src.windows(2)) {
                *o = (w[0] >> r) | (w[1] << (64 - r));
            }
        }
    }
    for (i, o) in out.iter_mut().enumerate().skip(hi) {
        *o = edge(i as i64);
    }
}

/// For each span `(a, b)` of `spans`, `out[k · n..(k + 1) · n] = row[x + a] ∘ … ∘ row[x + b]`
/// (`∘` AND when `and`, else OR; past the row's ends `fill`). The spans are the rows of one disc:
/// by length, each one longer at both ends than the one before (`a + b` the same for all), so
/// each is the one before it combined with two shifted rows.
fn runs_of(
    row: &[u64],
    spans: &[(i64, i64)],
    and: bool,
    fill: u64,
    n: usize,
    out: &mut [u64],
    (cur, tmp): &mut (Vec<u64>, Vec<u64>),
) {
    let op = |x: &mut [u64], y: &[u64]| {
        for (p, &q) in x.iter_mut().zip(y) {
            *p = if and { *p & q } else { *p | q };
        }
    };
    cur.resize(n, 0);
    tmp.resize(n, 0);
    let (cur, tmp) = (&mut cur[..n], &mut tmp[..n]);
    let (a0, b0) = spans[0];
    shift(row, a0, fill, cur);
    for t in a0 + 1..=b0 {
        shift(row, t, fill, tmp);
        op(cur, tmp);
    }
    let (mut a, mut b) = (a0, b0);
    for (k, &(sa, sb)) in spans.iter().enumerate() {
        debug_assert_eq!(sa + sb, a0 + b0, "the spans of a disc share their centre");
        while b < sb {
            a -= 1;
            b += 1;
            shift(row, a, fill, tmp);
            op(cur, tmp);
            shift(row, b, fill, tmp);
            op(cur, tmp);
        }
        out[k * n..(k + 1) * n].copy_from_slice(cur);
    }
}

/// The disc as rows of offsets: for a centre on the lattice point `(cx, cy)` it holds the pixels
/// `(cx + dx, cy + dy)` with `dx` in `rows[dy − dy0]`. Lattice points are pixels (odd span) or
/// pixel corners, corner `(cx, cy)` lying at `(cx − ½, cy − ½)` (even span).
struct Shape {
    dy0: i64,
    rows: Vec<(i64, i64)>,
}

impl Shape {
    fn of(disc: Disc) -> Shape {
        let k = disc.reach();
        let half = if disc.on_corners() { 0.5f32 } else { 0.0 };
        let inside = |dx: i64, dy: i64| {
            let (ex, ey) = (dx as f32 + half, dy as f32 + half);
            ex * ex + ey * ey <= disc.r2
        };
        let mut rows = Vec::new();
        let mut dy0 = None;
        for dy in -k - 1..=k + 1 {
            let xs: Vec<i64> = (-k - 1..=k + 1).filter(|&dx| inside(dx, dy)).collect();
            if let (Some(&a), Some(&b)) = (xs.first(), xs.last()) {
                dy0.get_or_insert(dy);
                rows.push((a, b));
            }
        }
        Shape {
            dy0: dy0.unwrap_or(0),
            rows,
        }
    }
}

/// The pixels of one tone (`phase`: true = material) that no disc lying wholly in that tone
/// covers: the tone minus its opening by the disc. `bits` is material; past its edges lies
/// material (its tail bits must be set), so a disc of material may reach past them and one of
/// cut may not. The result's tail bits are clear.
pub(super) fn thin(bits: &Packed, phase: bool, disc: Disc) -> Packed {
    let (w, h) = (bits.width, bits.height);
    let tone = if phase { bits.clone() } else { bits.not() };
    let fill = word_of(phase);
    let shape = Shape::of(disc);
    let corners = disc.on_corners() as usize;
    // Erosion: the lattice points whose disc lies wholly in the tone.
    let (lw, lh) = (w + corners, h + corners);
    let mut centres = Packed::new(lw, lh, false);
    let ls = centres.stride;
    // Each tone row run-ANDed once per distinct disc row.
    let mut spans: Vec<(i64, i64)> = shape.rows.clone();
    spans.sort_unstable_by_key(|&(a, b)| b - a);
    spans.dedup();
    let ns = spans.len();
    let par = parallel(w * h);
    let mut runs = vec![0u64; h * ns * ls];
    let scratch = || (Vec::new(), Vec::new());
    rows_mut_with(&mut runs, ns * ls, par, scratch, |s, (y, out)| {
        runs_of(tone.row(y), &spans, true, fill, ls, out, s);
    });
    let which: Vec<usize> = shape
        .rows
        .iter()
        .map(|ab| {
            spans
                .iter()
                .position(|s| s == ab)
                .expect("every disc row has its run")
        })
        .collect();
    rows_mut(&mut centres.data, ls, par, |(cy, out)| {
        out.fill(!0);
        for (r, &s) in which.iter().enumerate() {
            let y = cy as i64 + shape.dy0 + r as i64;
            if (0..h as i64).contains(&y) {
                let at = (y as usize * ns + s) * ls;
                for (o, &v) in out.iter_mut().zip(&runs[at..at + ls]) {
                    *o &= v;
                }
            } else if !phase {
                out.fill(0);
            }
        }
    });
    centres.tail(false);
    drop(runs);
    // Dilation: the pixels some valid centre's disc holds. Pixel (x, y) is held by centre
    // (x − dx, y − dy), so each centre row is run-ORed over the mirrored disc row.
    let mirrored: Vec<(i64, i64)> = spans.iter().map(|&(a, b)| (-b, -a)).collect();
    let ps = bits.stride;
    let mut runs = vec![0u64; lh * ns * ps];
    rows_mut_with(&mut runs, ns * ps, par, scratch, |s, (cy, out)| {
        runs_of(centres.row(cy), &mirrored, false, 0, ps, out, s);
    });
    let which: Vec<usize> = shape
        .rows
        .iter()
        .map(|&(a, b)| {
            mirrored
                .iter()
                .position(|&m| m == (-b, -a))
                .expect("every disc row has its mirror")
        })
        .collect();
    let mut out = tone;
    let scratch = || vec![0u64; ps];
    rows_mut_with(&mut out.data, ps, par, scratch, |covered, (y, row)| {
        covered.fill(0);
        for (r, &s) in which.iter().enumerate() {
            let cy = y as i64 - shape.dy0 - r as i64;
            if (0..lh as i64).contains(&cy) {
                let at = (cy as usize * ns + s) * ps;
                for (c, &v) in covered.iter_mut().zip(&runs[at..at + ps]) {
                    *c |= v;
                }
            }
        }
        for (o, c) in row.iter_mut().zip(covered.iter()) {
            *o &= !c;
        }
    });
    out.tail(false);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rule, pixel by pixel: a pixel of the tone is thin when no lattice point whose disc
    /// lies wholly in the tone (material past the edges) holds it.
    fn brute(bits: &[bool], w: usize, h: usize, phase: bool, disc: Disc) -> Vec<bool> {
        let at = |x: i64, y: i64| {
            if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                true
            } else {
                bits[y as usize * w + x as usize]
            }
        };
        let shape = Shape::of(disc);
        let c = disc.on_corners() as i64;
        let holds = |cx: i64, cy: i64, x: i64, y: i64| {
            let r = y - cy - shape.dy0;
            r >= 0
                && (r as usize) < shape.rows.len()
                && (shape.rows[r as usize].0..=shape.rows[r as usize].1).contains(&(x - cx))
        };
        let valid = |cx: i64, cy: i64| {
            (shape.dy0..shape.dy0 + shape.rows.len() as i64).all(|dy| {
                let (a, b) = shape.rows[(dy - shape.dy0) as usize];
                (a..=b).all(|dx| at(cx + dx, cy + dy) == phase)
            })
        };
        let mut out = vec![false; w * h];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                if at(x, y) != phase {
                    continue;
                }
                let k = disc.reach() + 1;
                let covered = (y - k..=y + k).any(|cy| {
                    (x - k..=x + k).any(|cx| {
                        (0..w as i64 + c).contains(&cx)
                            && (0..h as i64 + c).contains(&cy)
                            && holds(cx, cy, x, y)
                            && valid(cx, cy)
                    })
                });
                out[y as usize * w + x as usize] = !covered;
            }
        }
        out
    }

    #[test]
    fn thin_matches_the_rule_pixel_by_pixel() {
        let mut seed = 99u64;
        for (w, h) in [(70usize, 13usize), (129, 9), (64, 20), (5, 5)] {
            for density in [1u64, 3, 8] {
                let bits: Vec<bool> = (0..w * h)
                    .map(|_| {
                        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
                        (seed >> 60) >= density
                    })
                    .collect();
                let mut p = Packed::new(w, h, true);
                for (i, &b) in bits.iter().enumerate() {
                    p.put(i, b);
                }
                for span in [2.0, 3.0, 4.0, 5.0, 6.0, 9.0] {
                    let disc = Disc::for_width(span);
                    for phase in [true, false] {
                        let got = thin(&p, phase, disc);
                        let want = brute(&bits, w, h, phase, disc);
                        for (i, &t) in want.iter().enumerate() {
                            assert_eq!(
                                got.at(i),
                                t,
                                "{w}x{h} density {density} span {span} phase {phase} at {i}"
                            );
                        }
                        assert_eq!(got.count(), want.iter().filter(|&&t| t).count());
                    }
                }
            }
        }
    }

    #[test]
    fn shifts_match_bit_by_bit() {
        let mut seed = 5u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            seed
        };
        for n in [1usize, 2, 3, 5] {
            let row: Vec<u64> = (0..n).map(|_| next()).collect();
            for m in [1usize, n, n + 2] {
                for s in -200i64..200 {
                    for fill in [0u64, !0] {
                        let mut out = vec![0u64; m];
                        shift(&row, s, fill, &mut out);
                        for x in 0..m * 64 {
                            let j = x as i64 + s;
                            let want = if (0..(n * 64) as i64).contains(&j) {
                                row[j as usize / 64] >> (j % 64) & 1
                            } else {
                                fill & 1
                            };
                            assert_eq!(out[x / 64] >> (x % 64) & 1, want, "n {n} m {m} s {s}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn runs_and_shifts_read_fill_past_the_ends() {
        let row = [0b1011u64, 1 << 63];
        let mut out = [0u64; 2];
        shift(&row, 1, 0, &mut out);
        assert_eq!(out, [0b101, 1 << 62]);
        shift(&row, -1, !0, &mut out);
        assert_eq!(out, [0b10111, 0]);
        shift(&row, 64, 0, &mut out);
        assert_eq!(out, [1 << 63, 0]);
        let mut s = (Vec::new(), Vec::new());
        runs_of(
            &[0b0111_0110u64],
            &[(1, 1), (0, 2)],
            true,
            0,
            1,
            &mut out,
            &mut s,
        );
        assert_eq!(out, [0b0111_0110 >> 1, 0b0001_0000]);
        runs_of(
            &[0b1000_0001u64],
            &[(0, 0), (-1, 1)],
            false,
            0,
            1,
            &mut out,
            &mut s,
        );
        assert_eq!(out, [0b1000_0001, 0b1_1100_0011]);
    }
}
