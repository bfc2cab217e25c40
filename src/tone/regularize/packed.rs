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
    pub fn count(&self) -> usize {
        let mut c = self.clone();
        c.tail(false);
        c.data.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// The indices `y · width + x` of the set bits inside the grid, in order.
    pub fn ones(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.height).flat_map(move |y| {
            self.row(y).iter().enumerate().flat_map(move |(k, &w)| {
                let mut w = w;
                std::iter::from_fn(move || {
                    while w != 0 {
                        let b = w.trailing_zeros() as usize;
                        w &= w - 1;
                        let x = k * 64 + b;
                        if x < self.width {
                            return Some(y * self.width + x);
                        }
                    }
                    None
                })
            })
        })
    }
}

/// Whether work over a grid of this many pixels is worth spreading over threads: a small window
/// (a repair around one neck) is done sooner on one.
pub(super) fn parallel(pixels: usize) -> bool {
    pixels >= 1 << 16
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

/// `f` on each item, on threads when `par`.
pub(super) fn map_all<T: Sync, U: Send>(
    items: &[T],
    par: bool,
    f: impl Fn(&T) -> U + Sync + Send,
) -> Vec<U> {
    if par {
        items.par_iter().map(f).collect()
    } else {
        items.iter().map(f).collect()
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
    let n = row.len() as i64;
    let word = |j: i64| {
        if (0..n).contains(&j) {
            row[j as usize]
        } else {
            fill
        }
    };
    for (i, o) in out.iter_mut().enumerate() {
        let j = i as i64 + q;
        *o = if r == 0 {
            word(j)
        } else {
            (word(j) >> r) | (word(j + 1) << (64 - r))
        };
    }
}

/// `out[x] = row[x + a] ∘ … ∘ row[x + b]` for `∘` AND (`and`) or OR, by doubling runs; what lies
/// past either end reads as `fill`. `tmp` and `acc` are scratch at least as long as `out`.
fn run(
    row: &[u64],
    (a, b): (i64, i64),
    and: bool,
    fill: u64,
    out: &mut [u64],
    acc: &mut Vec<u64>,
    tmp: &mut Vec<u64>,
) {
    let len = b - a + 1;
    // acc[x] = row[x + a], far enough past the output's end that the runs read no stand-in.
    let n = out.len() + (len as usize).div_ceil(64) + 1;
    acc.resize(n, 0);
    tmp.resize(n, 0);
    shift(row, a, fill, acc);
    let combine = |acc: &mut Vec<u64>, tmp: &mut Vec<u64>, s: i64| {
        shift(acc, s, fill, tmp);
        for (x, &t) in acc.iter_mut().zip(tmp.iter()) {
            *x = if and { *x & t } else { *x | t };
        }
    };
    let mut m = 1;
    while 2 * m <= len {
        combine(acc, tmp, m);
        m *= 2;
    }
    if m < len {
        combine(acc, tmp, len - m);
    }
    out.copy_from_slice(&acc[..out.len()]);
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
    spans.sort_unstable();
    spans.dedup();
    let par = parallel(w * h);
    let runs: Vec<Vec<u64>> = map_all(&spans, par, |&ab| {
        let mut out = vec![0u64; h * ls];
        let (mut acc, mut tmp) = (Vec::new(), Vec::new());
        for y in 0..h {
            run(
                tone.row(y),
                ab,
                true,
                fill,
                &mut out[y * ls..(y + 1) * ls],
                &mut acc,
                &mut tmp,
            );
        }
        out
    });
    let which: Vec<usize> = shape
        .rows
        .iter()
        .map(|ab| spans.binary_search(ab).expect("every disc row has its run"))
        .collect();
    rows_mut(&mut centres.data, ls, par, |(cy, out)| {
        out.fill(!0);
        for (r, &s) in which.iter().enumerate() {
            let y = cy as i64 + shape.dy0 + r as i64;
            if (0..h as i64).contains(&y) {
                let src = &runs[s][y as usize * ls..(y as usize + 1) * ls];
                for (o, &v) in out.iter_mut().zip(src) {
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
    let mirrored: Vec<(i64, i64)> = {
        let mut m: Vec<(i64, i64)> = spans.iter().map(|&(a, b)| (-b, -a)).collect();
        m.sort_unstable();
        m
    };
    let ps = bits.stride;
    let runs: Vec<Vec<u64>> = map_all(&mirrored, par, |&ab| {
        let mut out = vec![0u64; lh * ps];
        let (mut acc, mut tmp) = (Vec::new(), Vec::new());
        for cy in 0..lh {
            run(
                centres.row(cy),
                ab,
                false,
                0,
                &mut out[cy * ps..(cy + 1) * ps],
                &mut acc,
                &mut tmp,
            );
        }
        out
    });
    let which: Vec<usize> = shape
        .rows
        .iter()
        .map(|&(a, b)| {
            mirrored
                .binary_search(&(-b, -a))
                .expect("every disc row has its mirror")
        })
        .collect();
    let mut out = tone;
    rows_mut(&mut out.data, ps, par, |(y, row)| {
        let mut covered = vec![0u64; ps];
        for (r, &s) in which.iter().enumerate() {
            let cy = y as i64 - shape.dy0 - r as i64;
            if (0..lh as i64).contains(&cy) {
                let src = &runs[s][cy as usize * ps..(cy as usize + 1) * ps];
                for (c, &v) in covered.iter_mut().zip(src) {
                    *c |= v;
                }
            }
        }
        for (o, c) in row.iter_mut().zip(covered) {
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
    fn runs_and_shifts_read_fill_past_the_ends() {
        let row = [0b1011u64, 1 << 63];
        let mut out = [0u64; 2];
        shift(&row, 1, 0, &mut out);
        assert_eq!(out, [0b101, 1 << 62]);
        shift(&row, -1, !0, &mut out);
        assert_eq!(out, [0b10111, 0]);
        shift(&row, 64, 0, &mut out);
        assert_eq!(out, [1 << 63, 0]);
        let (mut a, mut t) = (Vec::new(), Vec::new());
        run(
            &[0b0111_0110u64],
            (0, 2),
            true,
            0,
            &mut out[..1],
            &mut a,
            &mut t,
        );
        assert_eq!(out[0], 0b0001_0000);
        run(
            &[0b1000_0001u64],
            (-1, 1),
            false,
            0,
            &mut out[..1],
            &mut a,
            &mut t,
        );
        assert_eq!(out[0], 0b1_1100_0011);
    }
}
