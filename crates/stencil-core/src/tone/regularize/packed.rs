//! Bit-packed rows and the disc opening on them. A round of the regularisation needs, for both
//! tones, which pixels no disc of their tone covers; with 64 pixels to a word that is a few
//! shifts, ANDs and ORs per word and disc row over the whole grid, and after the first round
//! only over pieces of rows around the tiles near the pixels that changed ([`thin_in_tiles`]).

use rayon::prelude::*;

use super::disc::{paint, Disc};
use crate::raster::packed::pack_word;

/// A grid of bits, `stride` words per row: column `x` is bit `x % 64` of word `x / 64`. The bits
/// past `width` in a row's last word hold what lies past the grid's edge (see [`Packed::tail`]):
/// the row operations read them, and the words past either end of a row, as that value.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct Packed {
    pub width: usize,
    pub height: usize,
    pub(crate) stride: usize,
    pub data: Vec<u64>,
}

impl Packed {
    /// All `fill`, the tail bits too.
    pub(crate) fn new(width: usize, height: usize, fill: bool) -> Packed {
        let stride = width.div_ceil(64).max(1);
        Packed {
            width,
            height,
            stride,
            data: vec![word_of(fill); stride * height],
        }
    }

    pub(crate) fn get(&self, x: usize, y: usize) -> bool {
        self.data[y * self.stride + x / 64] >> (x % 64) & 1 == 1
    }

    pub(crate) fn set(&mut self, x: usize, y: usize, v: bool) {
        let w = &mut self.data[y * self.stride + x / 64];
        let m = 1u64 << (x % 64);
        if v {
            *w |= m;
        } else {
            *w &= !m;
        }
    }

    /// The pixel at index `i = y · width + x`.
    #[cfg(test)]
    pub(crate) fn at(&self, i: usize) -> bool {
        self.get(i % self.width, i / self.width)
    }

    #[cfg(test)]
    pub(crate) fn put(&mut self, i: usize, v: bool) {
        self.set(i % self.width, i / self.width, v);
    }

    pub(crate) fn row(&self, y: usize) -> &[u64] {
        &self.data[y * self.stride..(y + 1) * self.stride]
    }

    /// Set the bits past `width` in every row to `v`.
    pub(crate) fn tail(&mut self, v: bool) {
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

    /// The number of set bits inside the grid (tail bits not counted).
    #[cfg(test)]
    pub(crate) fn count(&self) -> usize {
        let mut c = self.clone();
        c.tail(false);
        c.data.iter().map(|w| w.count_ones() as usize).sum()
    }
}

/// Columns `x0..x0 + src.len()` of a packed row set from `src`, the other bits left as they are.
pub(super) fn put_bits(row: &mut [u64], x0: usize, src: &[bool]) {
    let (mut x, mut k) = (x0, 0);
    while k < src.len() {
        let (word, bit) = (x / 64, x % 64);
        let n = (64 - bit).min(src.len() - k);
        let v = pack_word(&src[k..k + n]);
        let mask = if n == 64 { !0 } else { (1u64 << n) - 1 } << bit;
        let d = &mut row[word];
        *d = (*d & !mask) | (v << bit);
        x += n;
        k += n;
    }
}

/// `out` set from columns `x0..x0 + out.len()` of a packed row: the row shifted into whole
/// words first, then each word's bits written out 64 at a time.
pub(super) fn get_bits(row: &[u64], x0: usize, out: &mut [bool], scratch: &mut Vec<u64>) {
    scratch.resize(out.len().div_ceil(64), 0);
    shift(row, x0 as i64, 0, scratch);
    for (o, &w) in out.chunks_mut(64).zip(scratch.iter()) {
        for (j, b) in o.iter_mut().enumerate() {
            *b = w >> j & 1 == 1;
        }
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

/// `out[x] = src[x] ∘ src[x + d]` (`d ≥ 0`; past the end of `src`, `fill`), a shift and the
/// combine in one pass.
fn pair(src: &[u64], d: i64, fill: u64, out: &mut [u64], op: impl Fn(u64, u64) -> u64) {
    let (q, r) = ((d / 64) as usize, (d % 64) as u32);
    let n = src.len();
    let at = |j: usize| if j < n { src[j] } else { fill };
    // The words whose sources `i + q` and `i + q + 1` both lie in `src`, without the checks.
    let inner = n.saturating_sub(q + 1);
    let here = &src[..inner];
    let (lo, hi) = (&src[q.min(n)..][..inner], &src[(q + 1).min(n)..][..inner]);
    if r == 0 {
        for ((o, &x), &y) in out[..inner].iter_mut().zip(here).zip(lo) {
            *o = op(x, y);
        }
    } else {
        for (((o, &x), &a), &b) in out[..inner].iter_mut().zip(here).zip(lo).zip(hi) {
            *o = op(x, (a >> r) | (b << (64 - r)));
        }
    }
    for (i, o) in out.iter_mut().enumerate().take(n).skip(inner) {
        let j = i + q;
        let v = if r == 0 {
            at(j)
        } else {
            (at(j) >> r) | (at(j + 1) << (64 - r))
        };
        *o = op(src[i], v);
    }
}

/// Scratch rows for [`runs_of`], kept between rows.
#[cfg(test)]
#[derive(Default)]
pub(super) struct RunScratch {
    cur: Vec<u64>,
    next: Vec<u64>,
}

/// For each span `(a, b)` of `spans` (narrowest first), `out[k · n..(k + 1) · n] = row[x + a] ∘ …
/// ∘ row[x + b]` (`∘` AND when `and`, else OR; past the row's ends `fill`), by doubling: about
/// log₂ s passes over the words for a span of width `s`. The tests' measure of [`runs_of_rows`].
#[cfg(test)]
fn runs_of(
    row: &[u64],
    spans: &[(i64, i64)],
    and: bool,
    fill: u64,
    n: usize,
    out: &mut [u64],
    s: &mut RunScratch,
) {
    let reach = spans.iter().map(|&(a, b)| a.abs().max(b.abs())).max();
    let p = (reach.unwrap_or(0) as usize).div_ceil(64) + 1;
    let len = row.len().max(n) + 2 * p;
    s.cur.clear();
    s.cur.resize(len, fill);
    s.cur[p..p + row.len()].copy_from_slice(row);
    s.next.resize(len, 0);
    // `cur` holds, at bit x, the combined bits x..x + c of the row set in fill.
    let mut c = 1i64;
    for (k, &(a, b)) in spans.iter().enumerate() {
        let w = b - a + 1;
        debug_assert!(w >= c, "spans come narrowest first");
        while c < w {
            let d = (w - c).min(c);
            if and {
                pair(&s.cur, d, fill, &mut s.next, |x, y| x & y);
            } else {
                pair(&s.cur, d, fill, &mut s.next, |x, y| x | y);
            }
            std::mem::swap(&mut s.cur, &mut s.next);
            c += d;
        }
        shift(
            &s.cur,
            a + 64 * p as i64,
            fill,
            &mut out[k * n..(k + 1) * n],
        );
    }
}

/// The runs of a band for each span of `spans` in turn (narrowest first), the step
/// [`runs_of_rows`] and [`runs_of_segs`] share: `cur` holds rows or pieces of rows laid end to
/// end, each set in `p` words of `fill` on either side; it is combined with itself shifted by
/// doubling (`next` the scratch), so at bit x it holds the combined bits x..x + c; each span's
/// runs are then shifted by its start in one pass over the whole band into `moved`, and
/// `emit(k, moved)` copies span `k`'s out.
#[allow(clippy::too_many_arguments)]
fn band_runs(
    cur: &mut Vec<u64>,
    next: &mut Vec<u64>,
    moved: &mut Vec<u64>,
    spans: &[(i64, i64)],
    and: bool,
    fill: u64,
    p: usize,
    mut emit: impl FnMut(usize, &[u64]),
) {
    next.resize(cur.len(), 0);
    let mut c = 1i64;
    for (k, &(a, b)) in spans.iter().enumerate() {
        let w = b - a + 1;
        debug_assert!(w >= c, "spans come narrowest first");
        while c < w {
            let d = (w - c).min(c);
            if and {
                pair(cur, d, fill, next, |x, y| x & y);
            } else {
                pair(cur, d, fill, next, |x, y| x | y);
            }
            std::mem::swap(cur, next);
            c += d;
        }
        moved.resize(cur.len(), 0);
        shift(cur, a + 64 * p as i64, fill, moved);
        emit(k, moved);
    }
}

/// [`runs_of`] for every row of `src` at once: `out[(y · ns + k) · n..][..n]` the runs of row `y`
/// for span `k` (`ns` spans). Rows are laid end to end in bands, each padded by `p` words of
/// `fill`, so each step is one long pass over a band; no run that lands in `out` reads past its
/// row's padding.
fn runs_of_rows(
    src: &Packed,
    spans: &[(i64, i64)],
    and: bool,
    fill: u64,
    n: usize,
    out: &mut [u64],
    par: bool,
) {
    const BAND: usize = 32;
    let ns = spans.len();
    let reach = spans.iter().map(|&(a, b)| a.abs().max(b.abs())).max();
    let p = (reach.unwrap_or(0) as usize).div_ceil(64) + 1;
    let l = src.stride.max(n) + 2 * p;
    let scratch = || (Vec::new(), Vec::new(), Vec::new());
    rows_mut_with(
        out,
        BAND * ns * n,
        par,
        scratch,
        |(cur, next, moved), (band, out)| {
            let (y0, rows) = (band * BAND, out.len() / (ns * n));
            cur.clear();
            cur.resize(rows * l, fill);
            for r in 0..rows {
                cur[r * l + p..r * l + p + src.stride].copy_from_slice(src.row(y0 + r));
            }
            // Each row's words read only its own (as above).
            band_runs(cur, next, moved, spans, and, fill, p, |k, moved| {
                for r in 0..rows {
                    let to = (r * ns + k) * n;
                    out[to..to + n].copy_from_slice(&moved[r * l..r * l + n]);
                }
            });
        },
    );
}

/// [`runs_of`] as it was: each span built from the one before by two shifted rows, for the
/// tests to hold the doubling to.
#[cfg(test)]
fn runs_of_by_steps(
    row: &[u64],
    spans: &[(i64, i64)],
    and: bool,
    fill: u64,
    n: usize,
    out: &mut [u64],
) {
    let op = |x: &mut [u64], y: &[u64]| {
        for (p, &q) in x.iter_mut().zip(y) {
            *p = if and { *p & q } else { *p | q };
        }
    };
    let (mut cur, mut tmp) = (vec![0u64; n], vec![0u64; n]);
    let (a0, b0) = spans[0];
    shift(row, a0, fill, &mut cur);
    for t in a0 + 1..=b0 {
        shift(row, t, fill, &mut tmp);
        op(&mut cur, &tmp);
    }
    let (mut a, mut b) = (a0, b0);
    for (k, &(_, sb)) in spans.iter().enumerate() {
        while b < sb {
            a -= 1;
            b += 1;
            shift(row, a, fill, &mut tmp);
            op(&mut cur, &tmp);
            shift(row, b, fill, &mut tmp);
            op(&mut cur, &tmp);
        }
        out[k * n..(k + 1) * n].copy_from_slice(&cur);
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
    /// The rows the disc paints about the lattice point (its first centre, see [`paint`]).
    fn of(disc: Disc) -> Shape {
        let rows = paint(disc).swap_remove(0);
        Shape {
            dy0: rows.first().map_or(0, |r| r.0),
            rows: rows.iter().map(|&(_, a, b)| (a, b)).collect(),
        }
    }

    /// The distinct disc rows, narrowest first: each row of a grid is run-combined once per
    /// span, not once per disc row (the disc is symmetric, so rows of one width are one span).
    fn spans(&self) -> Vec<(i64, i64)> {
        let mut spans = self.rows.clone();
        spans.sort_unstable_by_key(|&(a, b)| b - a);
        spans.dedup();
        spans
    }

    /// For each disc row, the index of its run among `spans` ([`Shape::spans`]), or among
    /// their mirror images (`(−b, −a)` for `(a, b)`) when `mirrored`.
    fn which(&self, spans: &[(i64, i64)], mirrored: bool) -> Vec<usize> {
        self.rows
            .iter()
            .map(|&(a, b)| {
                let want = if mirrored { (-b, -a) } else { (a, b) };
                spans
                    .iter()
                    .position(|&s| s == want)
                    .expect("every disc row has its run")
            })
            .collect()
    }
}

/// What [`thin`] keeps between calls: the lattice points whose disc fits, and the runs.
#[derive(Default)]
pub(super) struct ThinScratch {
    centres: Option<Packed>,
    runs: Vec<u64>,
}

impl ThinScratch {
    /// The lattice points' grid, `lw` × `lh`, reshaped in place when the size changes (its
    /// callers write every word they read), and the runs.
    fn lattice(&mut self, lw: usize, lh: usize) -> (&mut Packed, &mut Vec<u64>) {
        let centres = self
            .centres
            .get_or_insert_with(|| Packed::new(lw, lh, false));
        if centres.width != lw || centres.height != lh {
            centres.width = lw;
            centres.height = lh;
            centres.stride = lw.div_ceil(64).max(1);
            centres.data.resize(centres.stride * lh, 0);
        }
        (centres, &mut self.runs)
    }
}

/// The pixels of one tone (`phase`: true = material) that no disc lying wholly in that tone
/// covers: the tone minus its opening by the disc, into `out` (its buffer reused). `bits` is
/// material; past its edges lies material (its tail bits must be set), so a disc of material may
/// reach past them and one of cut may not. The result's tail bits are clear.
pub(super) fn thin(
    bits: &Packed,
    phase: bool,
    disc: Disc,
    scratch: &mut ThinScratch,
    out: &mut Packed,
) {
    out.width = bits.width;
    out.height = bits.height;
    out.stride = bits.stride;
    out.data.clear();
    if phase {
        out.data.extend_from_slice(&bits.data);
    } else {
        out.data.extend(bits.data.iter().map(|w| !w));
    }
    let shape = Shape::of(disc);
    let spans = shape.spans();
    let corners = disc.on_corners() as usize;
    let (lw, lh) = (bits.width + corners, bits.height + corners);
    let (centres, runs) = scratch.lattice(lw, lh);
    disc_centres(out, phase, &shape, &spans, centres, runs);
    uncovered(out, centres, &shape, &spans, runs);
}

/// [`thin`] of both tones over the whole grid (`out`: material, cut; `scratch` one per tone),
/// side by side on threads when the grid is large.
pub(super) fn thin_both(
    bits: &Packed,
    disc: Disc,
    [sm, sc]: [&mut ThinScratch; 2],
    [material, cut]: [&mut Packed; 2],
) {
    if parallel(bits.width * bits.height) {
        rayon::join(
            || thin(bits, true, disc, sm, material),
            || thin(bits, false, disc, sc, cut),
        );
    } else {
        thin(bits, true, disc, sm, material);
        thin(bits, false, disc, sc, cut);
    }
}

/// Rows per band of the tiles [`thin_in_tiles`] recomputes: a tile is one word (64 columns) of
/// one band, tile `(b, k)` at index `b · stride + k`.
pub(super) const BAND: usize = 32;

/// Which tiles hold a pixel within `m` pixels (rows and columns apart) of a set pixel of
/// `changed` (its tail bits clear).
pub(super) fn tiles_near(changed: &Packed, m: usize) -> Vec<bool> {
    let (h, s) = (changed.height, changed.stride);
    let bands = h.div_ceil(BAND);
    let mut out = vec![false; bands * s];
    let mut any = vec![0u64; s];
    for b in 0..bands {
        let (y0, y1) = (b * BAND, ((b + 1) * BAND).min(h));
        any.fill(0);
        for y in y0.saturating_sub(m)..(y1 + m).min(h) {
            for (a, &v) in any.iter_mut().zip(changed.row(y)) {
                *a |= v;
            }
        }
        if any.iter().all(|&a| a == 0) {
            continue;
        }
        for k in 0..s {
            out[b * s + k] = any_between(&any, (64 * k).saturating_sub(m), 64 * (k + 1) + m);
        }
    }
    out
}

/// Whether `row` has a set bit in columns `x0..x1` (clipped to the row).
fn any_between(row: &[u64], x0: usize, x1: usize) -> bool {
    let x1 = x1.min(row.len() * 64);
    if x0 >= x1 {
        return false;
    }
    let (k0, k1) = (x0 / 64, (x1 - 1) / 64);
    (k0..=k1).any(|k| {
        let lo = if k == k0 { x0 % 64 } else { 0 };
        let hi = if k == k1 { (x1 - 1) % 64 } else { 63 };
        row[k] & (!0u64 << lo) & (!0u64 >> (63 - hi)) != 0
    })
}

impl Default for Packed {
    fn default() -> Packed {
        Packed::new(0, 0, false)
    }
}

/// A piece of a row: `(row, first word, end word)`.
type Seg = (usize, usize, usize);

/// The maximal runs of set entries of `on` as pieces of row `y`, appended to `segs`.
fn push_segs(segs: &mut Vec<Seg>, y: usize, on: &[bool]) {
    let mut k = 0;
    while k < on.len() {
        if !on[k] {
            k += 1;
            continue;
        }
        let a = k;
        while k < on.len() && on[k] {
            k += 1;
        }
        segs.push((y, a, k));
    }
}

/// [`runs_of_rows`] on pieces of rows only: for each piece `(y, a, b)` of `segs` (by row), words
/// `a..min(b, n)` of row `y`'s runs in `out`, from the row's words `a..b` alone (`!` of them when
/// `invert`): right wherever a run does not reach past the piece; the rest of `out` is left.
#[allow(clippy::too_many_arguments)]
fn runs_of_segs(
    src: &Packed,
    invert: bool,
    segs: &[Seg],
    spans: &[(i64, i64)],
    and: bool,
    fill: u64,
    n: usize,
    out: &mut [u64],
    par: bool,
) {
    const BAND: usize = 32;
    let ns = spans.len();
    // Enough for the shifts below to read the piece's own words (see [`runs_of_rows`]'s one
    // more: the bits that differ lie within a run's reach of the piece's ends).
    let reach = spans.iter().map(|&(a, b)| a.abs().max(b.abs())).max();
    let p = (reach.unwrap_or(0) as usize).div_ceil(64);
    let inv = word_of(invert);
    let scratch = || (Vec::new(), Vec::new(), Vec::new());
    rows_mut_with(
        out,
        BAND * ns * n,
        par,
        scratch,
        |(cur, next, moved), (band, out)| {
            let y0 = band * BAND;
            let segs = &segs[segs.partition_point(|s| s.0 < y0)..];
            let segs = &segs[..segs.partition_point(|s| s.0 < y0 + BAND)];
            if segs.is_empty() {
                return;
            }
            cur.clear();
            for &(y, a, b) in segs {
                let e = b.min(src.stride);
                cur.resize(cur.len() + p, fill);
                if a < e {
                    cur.extend(src.row(y)[a..e].iter().map(|w| w ^ inv));
                }
                cur.resize(cur.len() + b - a.max(e) + p, fill);
            }
            // Each piece's words read only its own.
            band_runs(cur, next, moved, spans, and, fill, p, |k, moved| {
                let mut at = 0;
                for &(y, a, b) in segs {
                    let nb = b.min(n);
                    if a < nb {
                        let to = ((y - y0) * ns + k) * n;
                        out[to + a..to + nb].copy_from_slice(&moved[at..at + nb - a]);
                    }
                    at += b - a + 2 * p;
                }
            });
        },
    );
}

/// [`thin`] of both tones (`out`: material, cut), recomputed only in the tiles `dirty` marks
/// ([`BAND`] rows by a word, tile `(b, k)` at `b · stride + k`), which the caller marks wherever
/// thinness may have changed; `scratch` is [`thin`]'s, one per tone. Each stage is worked out
/// only on the pieces of rows the next reads, each reaching `⌈(2 · reach + 2) / 64⌉` words past
/// the marked ones (a piece is wrong only within a disc's reach of its ends, which nothing marked
/// reads): the result is [`thin`] over the whole grid at the cost of the marked tiles.
pub(super) fn thin_in_tiles(
    bits: &Packed,
    disc: Disc,
    dirty: &[bool],
    out: &mut [Packed; 2],
    scratch: &mut [ThinScratch; 2],
) {
    let (w, h, s) = (bits.width, bits.height, bits.stride);
    let shape = Shape::of(disc);
    let spans = shape.spans();
    let corners = disc.on_corners() as usize;
    let (lw, lh) = (w + corners, h + corners);
    let ls = lw.div_ceil(64).max(1);
    let bands = h.div_ceil(BAND);
    let mw = (2 * disc.reach() as usize + 2).div_ceil(64);
    let (dy0, len) = (shape.dy0, shape.rows.len() as i64);
    // Per band, the lattice words within `mw` words of a marked tile.
    let mut wide = vec![false; bands * ls];
    for b in 0..bands {
        for k in 0..s {
            if dirty[b * s + k] {
                wide[b * ls + k.saturating_sub(mw)..b * ls + (k + mw + 1).min(ls)].fill(true);
            }
        }
    }
    // The pieces of the rows whose pixels lie in `y0..=y1`'s bands' wide words.
    let mut on = vec![false; ls];
    let mut pieces = |rows: usize, near: &dyn Fn(i64) -> (i64, i64)| {
        let mut segs = Vec::new();
        for y in 0..rows {
            let (y0, y1) = near(y as i64);
            let (y0, y1) = (y0.max(0), y1.min(h as i64 - 1));
            if y0 > y1 {
                continue;
            }
            on.fill(false);
            for b in y0 as usize / BAND..=y1 as usize / BAND {
                for (o, &v) in on.iter_mut().zip(&wide[b * ls..(b + 1) * ls]) {
                    *o |= v;
                }
            }
            push_segs(&mut segs, y, &on);
        }
        segs
    };
    // Lattice row `cy` is read by pixel rows `cy + dy0..cy + dy0 + len`, and tone row `y` by
    // the lattice rows read by pixel rows `y − len + 1..=y + len − 1`.
    let csegs = pieces(lh, &|cy| (cy + dy0, cy + dy0 + len - 1));
    let tsegs = pieces(h, &|y| (y - len + 1, y + len - 1));
    let [sm, sc] = scratch;
    let [material, cut] = out;
    // The words the pieces cover: when they are most of the grid, whole rows are quicker; when
    // they are few, threads cost more than they save.
    let words: usize = tsegs.iter().map(|&(_, a, b)| b - a).sum();
    if 4 * words > 3 * h * ls {
        thin_both(bits, disc, [sm, sc], [material, cut]);
        return;
    }
    let par = parallel(16 * words);
    let one = |phase: bool, sc: &mut ThinScratch, out: &mut Packed| {
        thin_in_segs(
            bits, phase, &shape, &spans, corners, dirty, &csegs, &tsegs, par, sc, out,
        )
    };
    if parallel(64 * words) {
        rayon::join(|| one(true, sm, material), || one(false, sc, cut));
    } else {
        one(true, sm, material);
        one(false, sc, cut);
    }
}

/// One tone of [`thin_in_tiles`]: the valid lattice points in `csegs`, from the tone's runs in
/// `tsegs`, then the thin pixels of the marked tiles.
#[allow(clippy::too_many_arguments)]
fn thin_in_segs(
    bits: &Packed,
    phase: bool,
    shape: &Shape,
    spans: &[(i64, i64)],
    corners: usize,
    dirty: &[bool],
    csegs: &[Seg],
    tsegs: &[Seg],
    par: bool,
    scratch: &mut ThinScratch,
    out: &mut Packed,
) {
    let (w, h, s) = (bits.width, bits.height, bits.stride);
    let ns = spans.len();
    let fill = word_of(phase);
    let (lw, lh) = (w + corners, h + corners);
    let (centres, runs) = scratch.lattice(lw, lh);
    let ls = centres.stride;
    runs.resize((h * ns * ls).max(lh * ns * s), 0);
    // Erosion ([`disc_centres`]) in the lattice pieces.
    runs_of_segs(bits, !phase, tsegs, spans, true, fill, ls, runs, par);
    let which = shape.which(spans, false);
    let dy0 = shape.dy0;
    let tail = if lw % 64 == 0 {
        !0
    } else {
        !(!0u64 << (lw % 64))
    };
    {
        let runs = &runs[..];
        rows_mut(&mut centres.data, BAND * ls, par, |(band, data)| {
            let y0 = band * BAND;
            let segs = &csegs[csegs.partition_point(|s| s.0 < y0)..];
            let segs = &segs[..segs.partition_point(|s| s.0 < y0 + BAND)];
            for &(cy, a, b) in segs {
                let out = &mut data[(cy - y0) * ls + a..(cy - y0) * ls + b];
                out.fill(!0);
                for (r, &k) in which.iter().enumerate() {
                    let y = cy as i64 + dy0 + r as i64;
                    if (0..h as i64).contains(&y) {
                        let at = (y as usize * ns + k) * ls;
                        for (o, &v) in out.iter_mut().zip(&runs[at + a..at + b]) {
                            *o &= v;
                        }
                    } else if !phase {
                        out.fill(0);
                    }
                }
                if b == ls {
                    out[b - a - 1] &= tail;
                }
            }
        });
    }
    // Dilation, subtracted ([`uncovered`]), in the marked tiles.
    let mirrored: Vec<(i64, i64)> = spans.iter().map(|&(a, b)| (-b, -a)).collect();
    runs_of_segs(centres, false, csegs, &mirrored, false, 0, s, runs, par);
    let which = shape.which(&mirrored, true);
    let runs = &runs[..];
    let inv = word_of(!phase);
    let last = if w % 64 == 0 {
        !0
    } else {
        !(!0u64 << (w % 64))
    };
    rows_mut(&mut out.data, BAND * s, par, |(band, data)| {
        let tiles = &dirty[band * s..(band + 1) * s];
        if !tiles.contains(&true) {
            return;
        }
        for (r0, row) in data.chunks_mut(s).enumerate() {
            let y = band * BAND + r0;
            for k in (0..s).filter(|&k| tiles[k]) {
                let mut covered = 0u64;
                for (r, &j) in which.iter().enumerate() {
                    let cy = y as i64 - dy0 - r as i64;
                    if (0..lh as i64).contains(&cy) {
                        covered |= runs[(cy as usize * ns + j) * s + k];
                    }
                }
                let v = (bits.row(y)[k] ^ inv) & !covered;
                row[k] = if k + 1 == s { v & last } else { v };
            }
        }
    });
}

/// Erosion: the lattice points (`corners` more per side than pixels when the disc's centre lies
/// on pixel corners) whose disc, of `shape`'s rows (`spans` the distinct ones), lies wholly in
/// `tone`, into `centres` (sized for them). Past the grid's edges lies material: a disc of
/// material may reach there (`phase`).
fn disc_centres(
    tone: &Packed,
    phase: bool,
    shape: &Shape,
    spans: &[(i64, i64)],
    centres: &mut Packed,
    runs: &mut Vec<u64>,
) {
    let (w, h) = (tone.width, tone.height);
    let fill = word_of(phase);
    let ls = centres.stride;
    let ns = spans.len();
    let par = parallel(w * h);
    runs.resize(h * ns * ls, 0);
    runs_of_rows(tone, spans, true, fill, ls, runs, par);
    let which = shape.which(spans, false);
    let runs = &runs[..];
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
}

/// Dilation, subtracted: `tone` minus the pixels some valid centre's disc holds, in place. Pixel
/// (x, y) is held by centre (x − dx, y − dy), so each centre row is run-ORed over the mirrored
/// disc row.
fn uncovered(
    tone: &mut Packed,
    centres: &Packed,
    shape: &Shape,
    spans: &[(i64, i64)],
    runs: &mut Vec<u64>,
) {
    let (w, h) = (tone.width, tone.height);
    let lh = centres.height;
    let ns = spans.len();
    let par = parallel(w * h);
    let mirrored: Vec<(i64, i64)> = spans.iter().map(|&(a, b)| (-b, -a)).collect();
    let ps = tone.stride;
    runs.resize(lh * ns * ps, 0);
    runs_of_rows(centres, &mirrored, false, 0, ps, runs, par);
    let which = shape.which(&mirrored, true);
    let runs = &runs[..];
    let scratch = || vec![0u64; ps];
    rows_mut_with(&mut tone.data, ps, par, scratch, |covered, (y, row)| {
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
    tone.tail(false);
}

#[cfg(test)]
mod tests;
