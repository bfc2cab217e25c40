//! Design-rule regularisation: the two-tone clean-up that makes every web of material and every
//! hole of cut at least as wide as the material can hold, changing the picture as little as it can.
//!
//! ## The rule
//! A phase (material or cut) is *wide enough* at a pixel when some disc of the required width that
//! lies wholly in that phase covers the pixel: the pixel survives the morphological opening of its
//! phase by that disc. A pixel that does not is *thin*. When neither phase has a thin pixel, every
//! boundary point has a disc of the required width on both sides of it, so no neck of material
//! (web) or of cut (hole) is narrower than the disc: at the narrowest chord across a region, the
//! disc touching one end would reach past the other end. The disc holds the pixels whose centres
//! lie within `span / 2` of its centre, `span` the required width rounded up to whole pixels; it
//! is centred on a pixel for an odd span and on a pixel corner for an even one, so its rows and
//! columns span exactly `span` pixels: a straight line or hole `span` pixels wide or more is wide
//! enough as it is, and one pixel narrower is not. (On a pixel grid this is the rule up to about
//! a pixel: the pipeline asks for the material's smallest feature plus one pixel, and widens what
//! the width check of the traced outline still finds.)
//!
//! The outside of the picture is material (the sheet continues past the border, as in `islands`
//! and the tracer): discs of material may lie partly outside, discs of cut may not. One exception:
//! a cut filling a corner of the picture keeps its square corner (see `Work::corner_caps`); other
//! square corners are rounded by the disc, a pixel or two, as any opening rounds them.
//!
//! ## Cost
//! The first round computes thinness over the whole grid as the opening itself, an erosion and a
//! dilation by the disc on bit-packed rows (64 pixels a word: a few shifts, ANDs and ORs per
//! word and disc row; see `packed`), a millisecond or so a megapixel. How deep a thin pixel lies
//! in its tone (which the ridge finder reads) is searched outward from its candidate centres only
//! where a thin pixel is, nearest pixels first, and ends within the disc's radius. Later rounds
//! change a few pixels here and there, and a pixel's thinness and depth depend only on the pixels
//! within about two disc radii of it: they are recomputed only in the tiles near a pixel changed
//! since, and a feature with nothing changed near it is kept, widening and cost included, from
//! the round before (see `Work::refresh`). The result is the same as recomputing everything.
//!
//! ## Deciding
//! Thin pixels are grouped into features (8-connected). A thin feature can be *removed* (its
//! pixels take the other tone: a web dropped, a hole filled) or *widened* (the other tone's pixels
//! within the disc's radius of its ridge, the pixels farthest from its edges, take its tone, so a
//! disc fits along it). Each choice is priced on the gray picture: a flipped pixel costs
//! `0.1 + |gray − threshold|` (a pixel whose gray sits on the threshold could go either way; one far
//! from it is plainly one tone), and the cheaper choice is made. Features that are wide enough are
//! never touched, except where a neighbour's widening reaches into them.
//!
//! ## Why it ends
//! Deciding runs in rounds, all features of a round at once. In the first phase (at most
//! [`FREE_ROUNDS`] rounds) a pixel that has changed tone is locked: a choice that would change it
//! back is not available, so no pixel flips twice and nothing oscillates. What is still thin after
//! that is settled by a second, *monotone* phase: thin holes are filled and thin webs widened, both
//! of which only add material. Opening is increasing, so a material pixel that is wide enough stays
//! so when material is added; and each round adds at least one pixel (a thin web's ridge pixel
//! farthest from the cut is thin, so its disc still holds a cut pixel, which widening fills; a thin
//! hole's pixels are filled). Material grows strictly every round, so the second phase ends after at
//! most as many rounds as there are cut pixels, with nothing thin left; in practice in a few.

use serde::{Deserialize, Serialize};

use rayon::prelude::*;

use crate::raster::{join_runs, push_runs, BitGrid, Gray, Run};

mod packed;
use packed::{thin_both, thin_in_tiles, tiles_near, Packed, ThinScratch, BAND};

/// Rounds of cost-based deciding before the monotone phase settles what is left.
pub const FREE_ROUNDS: usize = 4;

/// Options of the regularisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegularizeConfig {
    /// The narrowest web of material and hole of cut, in working pixels.
    pub min_width_px: f64,
    /// The gray level (0..1) the two-tone was cut at: a flip costs more the farther its gray is.
    pub threshold: f32,
    /// True when material is the dark side (`--invert`): only for the cost, which is symmetric.
    pub invert: bool,
}

/// What the regularisation changed, for the report.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub struct RegularizeStats {
    /// The disc's span in pixels: the required width rounded up to a whole number of pixels (an
    /// odd span is centred on a pixel, an even one on a pixel corner).
    pub disc_px: u32,
    /// Thin webs of material removed and widened, and thin holes of cut filled and widened.
    pub webs_removed: usize,
    pub webs_widened: usize,
    pub holes_filled: usize,
    pub holes_widened: usize,
    /// Material pixels that became cut, and cut pixels that became material (net, against the
    /// input two-tone).
    pub material_removed_px: usize,
    pub material_added_px: usize,
    /// Rounds of the cost-based phase and of the monotone phase.
    pub rounds: usize,
    pub monotone_rounds: usize,
}

/// The disc: `span` pixels across, centred on a pixel (odd span) or on a pixel corner (even
/// span), holding the pixels whose centres lie within `span / 2` of its centre.
#[derive(Clone, Copy, Debug)]
struct Disc {
    span: u32,
    /// Squared radius, `(span / 2)²` and a hair, so pixels exactly on the circle count.
    r2: f32,
}

impl Disc {
    fn for_width(px: f64) -> Disc {
        let span = if px.is_finite() && px > 1.0 {
            (px - 1e-6).ceil().min(u32::MAX as f64 / 4.0) as u32
        } else {
            1
        };
        let r = span as f32 / 2.0;
        Disc {
            span,
            r2: r * r + 1e-3,
        }
    }
    /// Centres sit on pixel corners: the lattice is offset by half a pixel.
    fn on_corners(&self) -> bool {
        self.span.is_multiple_of(2)
    }
    /// How far a disc's pixels reach from its centre pixel, in whole pixels.
    fn reach(&self) -> i64 {
        self.span as i64 / 2
    }
}

/// Offsets from a lattice point (a pixel, or a pixel corner for an even span) to the pixels its
/// disc holds, nearest first, with their squared distances: the search for how deep a lattice
/// point lies in its tone.
fn ring(disc: Disc) -> Vec<(i64, i64, f32)> {
    let k = disc.reach() + 1;
    let half = if disc.on_corners() { 0.5f32 } else { 0.0 };
    let mut v: Vec<(i64, i64, f32)> = (-k..=k)
        .flat_map(|dy| (-k..=k).map(move |dx| (dx, dy)))
        .map(|(dx, dy)| {
            let (ex, ey) = (dx as f32 + half, dy as f32 + half);
            (dx, dy, ex * ex + ey * ey)
        })
        .filter(|&(_, _, d)| d <= disc.r2)
        .collect();
    v.sort_by(|a, b| a.2.total_cmp(&b.2));
    v
}

/// Where a lattice point's search of `ring` may start, given the depth of a lattice point one
/// pixel from it in the same tone, per [`Work::depth2`] value of that neighbour (`u16::MAX`, past
/// the radius, as the last entry). The distance to the nearest pixel of the other tone changes
/// by at most the step between two points of one tone (both measure to the same pixels), so a
/// point whose neighbour lies `f` from the other tone lies at least `f − 1` from it: the ring's
/// entries nearer than that (with a margin for rounding) are all of its own tone, and skipping
/// them finds the same first entry of the other tone.
fn ring_from(ring: &[(i64, i64, f32)], disc: Disc) -> Vec<usize> {
    let max = (2.0 * disc.r2).ceil() as usize + 1;
    let from = |f: f64| {
        let lower = f - 1.0 - 1e-3;
        if lower <= 0.0 {
            0
        } else {
            ring.partition_point(|e| (e.2 as f64) < lower * lower)
        }
    };
    let mut out: Vec<usize> = (0..=max).map(|v| from((v as f64 / 2.0).sqrt())).collect();
    // Past the radius: the neighbour lies farther than the disc's radius from the other tone.
    out.push(from((disc.r2 as f64).sqrt()));
    out
}

/// Per candidate centre of a pixel's widening (the pixel, or its corners in [`CORNERS`] order),
/// the rows of pixels that centre's disc holds: `(dy, a, b)`, offsets `a..=b` along row `dy`
/// from the pixel.
fn paint(disc: Disc) -> Vec<Vec<(i64, i64, i64)>> {
    let k = disc.reach() + 1;
    let centres: Vec<(f32, f32)> = if disc.on_corners() {
        CORNERS
            .iter()
            .map(|&(ox, oy)| (ox as f32 - 0.5, oy as f32 - 0.5))
            .collect()
    } else {
        vec![(0.0, 0.0)]
    };
    centres
        .into_iter()
        .map(|(cx, cy)| {
            (-k..=k)
                .filter_map(|dy| {
                    let inside = |dx: i64| {
                        let (ex, ey) = (dx as f32 - cx, dy as f32 - cy);
                        ex * ex + ey * ey <= disc.r2
                    };
                    let a = (-k..=k).find(|&dx| inside(dx))?;
                    let b = (-k..=k).rev().find(|&dx| inside(dx))?;
                    Some((dy, a, b))
                })
                .collect()
        })
        .collect()
}

/// Pixel index → `(x, y)` for rows `width` long, by a multiply rather than a division when
/// both fit in 32 bits: with `c = ⌈2⁶⁴ / width⌉`, `⌊c · i / 2⁶⁴⌋ = ⌊i / width⌋` for every 32-bit
/// `i` and `width` (Lemire, Kaser and Kurz, "Faster remainder by direct computation", 2019).
/// The lists of pixels a round prices and flips are turned into coordinates once per pixel, and
/// a 64-bit division costs several times the multiply.
#[derive(Clone, Copy, Debug)]
struct Rows {
    width: usize,
    /// `⌈2⁶⁴ / width⌉`, or 0 when the multiply does not apply (a width of 1, or indices past
    /// 32 bits), and then the index is divided.
    c: u64,
}

impl Rows {
    fn new(width: usize, height: usize) -> Rows {
        let fits = width >= 2 && (width as u64).saturating_mul(height as u64) <= u32::MAX as u64;
        Rows {
            width,
            c: if fits { u64::MAX / width as u64 + 1 } else { 0 },
        }
    }

    fn xy(&self, i: usize) -> (usize, usize) {
        if self.c == 0 {
            return (i % self.width, i / self.width);
        }
        let y = ((self.c as u128 * i as u128) >> 64) as usize;
        (i - y * self.width, y)
    }
}

/// A working grid: a window of the picture padded by more than the disc's reach with material on
/// every side (the frame: discs of material may reach past the picture's border), which of its
/// pixels may change and what changing them costs, and both tones' thin pixels.
struct Work<'a> {
    /// Material, bit-packed; past the padded grid lies material too.
    bits: Packed,
    /// Its pixel indices to coordinates.
    rows: Rows,
    /// The price of flipping a pixel, in picture coordinates.
    price: Price<'a>,
    /// The pixels that may change, `[x0, y0, x1, y1)` in padded coordinates, and of those only
    /// the ones set in `allowed` when there is one.
    core: [usize; 4],
    allowed: Option<Packed>,
    /// When set, only thin features holding one of these pixels are resolved.
    seeds: Option<Packed>,
    /// The picture coordinates of padded pixel `(pad, pad)`.
    origin: (u32, u32),
    /// Per pixel: changed tone in the cost-based phase (may not change back there).
    locked: Packed,
    pad: u32,
    /// Top-left corners (padded coordinates) of the span × span blocks at the picture's own
    /// corners that lie in this window (see [`Work::corner_caps`]).
    corners: Vec<(u32, u32)>,
    disc: Disc,
    ring: Vec<(i64, i64, f32)>,
    /// The ring as offsets of bit index (`dy · stride · 64 + dx`) with the depth each gives, and
    /// how far it reaches: for lattice points at least that far inside the grid.
    ring_bits: Vec<(i64, u16)>,
    ring_reach: i64,
    /// Per depth of a neighbouring lattice point of the same tone (its [`Work::depth2`] value,
    /// the last entry for `u16::MAX`), the first ring entry a point's search need probe (see
    /// [`ring_from`]).
    ring_from: Vec<usize>,
    /// Per candidate centre of a widening (the pixel itself, or its corner `(ox, oy)` in the
    /// order [`Work::depth_xy`] tries them), the rows of its disc (see [`paint`]).
    paint: Vec<Vec<(i64, i64, i64)>>,
    /// The thin pixels of material and of cut, as of the last [`Work::refresh`].
    thin: [Packed; 2],
    /// Per centre-lattice point next to a thin pixel, as of the last refresh: how deep it lies
    /// in its tone, as twice its squared distance to the nearest pixel of another tone (a corner
    /// between pixels of both tones: 1), or `u16::MAX` past the disc's radius. Points next to no
    /// thin pixel hold stale values: only thin pixels' centres are read.
    depth2: Vec<u16>,
    /// Kept between rounds: [`thin`]'s buffers per tone, and the pixels a round changed.
    thin_scratch: [ThinScratch; 2],
    changed: Packed,
    /// The pixels changed since the last refresh ([`Work::flip`]), and whether there was one:
    /// after the first, a refresh recomputes thinness and depths only near these.
    since: Packed,
    refreshed: bool,
    /// The tiles ([`BAND`] rows by a word) within reach of the changes the last refresh saw;
    /// `None` after the first refresh, which had no earlier one to keep. What lies outside them
    /// is as it was the refresh before.
    dirty: Option<Vec<bool>>,
    /// The last round's features per tone (material, cut), in [`groups_where`] order: a feature that
    /// lies wholly outside the tiles a refresh recomputed is the same feature, with the same
    /// widening and cost, and is taken from here rather than worked out again.
    kept: [Vec<Feature>; 2],
}

/// A cut that fills a corner of the picture has a square corner against the sheet's margin,
/// which no round disc covers, yet it is no neck (the width check does not count cutting across a
/// corner). Where the span × span block at a picture corner (`corners`, see [`Work::corners`]) is
/// all cut in `bits`, its pixels are not thin in `mask`.
fn corner_caps(bits: &Packed, corners: &[(u32, u32)], disc: Disc, mask: &mut Packed) {
    let span = disc.span as usize;
    for &(cx, cy) in corners {
        let (cx, cy) = (cx as usize, cy as usize);
        let block = || (cy..cy + span).flat_map(move |y| (cx..cx + span).map(move |x| (x, y)));
        if block().all(|(x, y)| !bits.get(x, y)) {
            block().for_each(|(x, y)| mask.set(x, y, false));
        }
    }
}

/// A pixel's eight neighbours, as offsets: a fixed list [`widening_old`]'s ridge test runs
/// through without building an iterator of pairs per pixel.
#[cfg(test)]
const AROUND: [(i64, i64); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// The order in which a pixel's corners are tried as the centre of its widening.
const CORNERS: [(i64, i64); 4] = [(0, 0), (1, 0), (0, 1), (1, 1)];

impl<'a> Work<'a> {
    /// The window `x0..x1 × y0..y1` of `bits`, padded; pixels in `core` (window coordinates,
    /// `[x0, y0, x1, y1)`) may change, priced by `price` (see [`Price`]).
    fn new(
        bits: &BitGrid,
        window: [u32; 4],
        core: [u32; 4],
        disc: Disc,
        price: Price<'a>,
    ) -> Work<'a> {
        let pad = disc.reach() as u32 + 1;
        let [x0, y0, x1, y1] = window;
        let (pw, ph) = ((x1 - x0 + 2 * pad) as usize, (y1 - y0 + 2 * pad) as usize);
        let mut padded = Packed::new(pw, ph, true);
        let stride = padded.stride;
        let rows = pad as usize..(y1 - y0 + pad) as usize;
        packed::rows_mut(
            &mut padded.data,
            stride,
            packed::parallel(pw * ph),
            |(py, row)| {
                if rows.contains(&py) {
                    let y = (py - pad as usize) as u32 + y0;
                    let from = bits.idx(x0, y);
                    packed::put_bits(
                        row,
                        pad as usize,
                        &bits.data[from..from + (x1 - x0) as usize],
                    );
                }
            },
        );
        let (iw, ih) = (x1 - x0, y1 - y0);
        let sp = disc.span.min(iw).min(ih);
        let mut corners = Vec::new();
        for (cx, cy) in [
            (0, 0),
            (bits.width - sp, 0),
            (0, bits.height - sp),
            (bits.width - sp, bits.height - sp),
        ] {
            if cx >= x0 && cy >= y0 && cx + sp <= x1 && cy + sp <= y1 {
                corners.push((cx - x0 + pad, cy - y0 + pad));
            }
        }
        Work {
            bits: padded,
            rows: Rows::new(pw, ph),
            price,
            core: core.map(|c| (c + pad) as usize),
            allowed: None,
            seeds: None,
            origin: (x0, y0),
            locked: Packed::new(pw, ph, false),
            pad,
            corners,
            disc,
            ring: ring(disc),
            ring_bits: ring(disc)
                .into_iter()
                .map(|(dx, dy, d)| (dy * 64 * stride as i64 + dx, (2.0 * d) as u16))
                .collect(),
            ring_reach: ring(disc)
                .iter()
                .map(|&(dx, dy, _)| dx.abs().max(dy.abs()))
                .max()
                .unwrap_or(0)
                + 1,
            ring_from: ring_from(&ring(disc), disc),
            paint: paint(disc),
            thin: [Packed::new(pw, ph, false), Packed::new(pw, ph, false)],
            depth2: Vec::new(),
            thin_scratch: Default::default(),
            changed: Packed::new(pw, ph, false),
            since: Packed::new(pw, ph, false),
            refreshed: false,
            dirty: None,
            kept: Default::default(),
        }
    }

    /// Set pixel `(x, y)` to `v`, noting the change for the next refresh.
    fn flip(&mut self, x: usize, y: usize, v: bool) {
        self.bits.set(x, y, v);
        self.since.set(x, y, true);
    }

    /// How far a change reaches: a pixel's thinness depends on the pixels within `2 · reach + 1`
    /// of it, a lattice point's depth on those within the ring's reach (and on whether a pixel
    /// next to it is thin); a pixel farther than this from every change keeps both.
    fn influence(&self) -> usize {
        (2 * self.disc.reach() as usize + 2).max(self.ring_reach as usize + 1)
    }

    /// Both tones' thin pixels and the depths next to them: over the whole grid the first time,
    /// then only in the tiles within [`Work::influence`] (and a pixel more) of a pixel changed
    /// since; the rest is as it was. Either way the same as recomputing the whole grid.
    fn refresh(&mut self) {
        let (bits, disc) = (&self.bits, self.disc);
        if self.refreshed {
            let m = self.influence();
            let dirty = tiles_near(&self.since, m + 1);
            thin_in_tiles(bits, disc, &dirty, &mut self.thin, &mut self.thin_scratch);
            self.dirty = Some(dirty);
        } else {
            let [material, cut] = &mut self.thin;
            let [sm, sc] = &mut self.thin_scratch;
            thin_both(bits, disc, [sm, sc], [material, cut]);
            self.refreshed = true;
        }
        corner_caps(&self.bits, &self.corners, disc, &mut self.thin[1]);
        self.refresh_depths();
        self.since.data.fill(0);
    }

    /// Recompute [`Work::depth2`] at every centre next to a thin pixel (in the tiles the
    /// refresh recomputed: elsewhere neither the bits a depth reads nor the thin pixels changed).
    fn refresh_depths(&mut self) {
        let corners = self.disc.on_corners() as usize;
        let (w, h) = (self.bits.width, self.bits.height);
        let lw = w + corners;
        // Zeroed by the allocator (untouched pages cost nothing): a point next to no thin pixel
        // is never read, so what it holds does not matter.
        let mut depth2 = std::mem::take(&mut self.depth2);
        if depth2.is_empty() {
            depth2 = vec![0; lw * (h + corners)];
        }
        depth2.resize(lw * (h + corners), 0);
        let work = &*self;
        let stride = work.bits.stride;
        let [t0, t1] = &work.thin;
        let bands = h.div_ceil(BAND);
        packed::rows_mut(&mut depth2, lw, packed::parallel(w * h), |(cy, row)| {
            // The tiles of this row the refresh recomputed (the corner row `h` with the last
            // band, the corner column `w` with the last word).
            let tiles = work.dirty.as_ref().map(|d| {
                let b = (cy / BAND).min(bands - 1);
                &d[b * stride..(b + 1) * stride]
            });
            if tiles.is_some_and(|t| !t.contains(&true)) {
                return;
            }
            // The lattice points holding a thin pixel: the pixel itself, or the corners of the
            // pixels in the rows above and below the corner row (pixel x has corners x, x + 1).
            let rows = [cy.checked_sub(corners), (cy < h).then_some(cy)];
            let mut carry = 0u64;
            // The point just done: its column, tone and depth (see [`ring_from`]).
            let mut prev: Option<(usize, bool, u16)> = None;
            // Each point's tone a word at a time, as [`Work::lattice_phase`] gives it: the
            // tone of pixel `(cx, cy)`, and for an even span whether any of the pixels
            // `(cx − 1, cy − 1)`, `(cx, cy − 1)`, `(cx − 1, cy)` differs from it (past the
            // grid, material: rows above and below it, the column left of it, its tail).
            let tone_word = |y: Option<usize>, k: usize| match y {
                Some(y) if k < stride => {
                    let v = work.bits.row(y)[k];
                    if k + 1 == stride && w % 64 != 0 {
                        v | !0u64 << (w % 64)
                    } else {
                        v
                    }
                }
                _ => !0u64,
            };
            let (above, here) = (rows[0], (cy < h).then_some(cy));
            let (mut a_before, mut b_before) = (!0u64, !0u64);
            for k in 0..stride + corners {
                let mut word = 0u64;
                if k < stride {
                    for y in rows.iter().flatten() {
                        word |= t0.row(*y)[k] | t1.row(*y)[k];
                    }
                }
                if corners == 1 {
                    let next = word >> 63;
                    word |= (word << 1) | carry;
                    carry = next;
                }
                let tone = tone_word(here, k);
                let mixed = if corners == 1 {
                    let a = tone_word(above, k);
                    let a_left = (a << 1) | (a_before >> 63);
                    let b_left = (tone << 1) | (b_before >> 63);
                    (a_before, b_before) = (a, tone);
                    (a ^ tone) | (a_left ^ tone) | (b_left ^ tone)
                } else {
                    0
                };
                if tiles.is_some_and(|t| !t[k.min(stride - 1)]) {
                    continue;
                }
                while word != 0 {
                    let bit = word.trailing_zeros();
                    let cx = k * 64 + bit as usize;
                    word &= word - 1;
                    if cx < lw {
                        let (cxi, cyi) = (cx as i64, cy as i64);
                        let phase = if mixed >> bit & 1 == 1 {
                            Err(1)
                        } else {
                            Ok(tone >> bit & 1 == 1)
                        };
                        debug_assert_eq!(phase, work.lattice_phase(cxi, cyi));
                        match phase {
                            Ok(phase) => {
                                let from = match prev {
                                    Some((px, pp, pd)) if px + 1 == cx && pp == phase => {
                                        work.ring_start(pd)
                                    }
                                    _ => 0,
                                };
                                let d = work.lattice_depth_from(cxi, cyi, phase, from);
                                row[cx] = d;
                                prev = Some((cx, phase, d));
                            }
                            Err(mixed) => {
                                row[cx] = mixed;
                                prev = None;
                            }
                        }
                    }
                }
            }
        });
        self.depth2 = depth2;
    }

    /// [`Work::lattice_depth_from`] of any point, its ring searched from the start.
    #[cfg(test)]
    fn lattice_depth(&self, cx: i64, cy: i64) -> u16 {
        match self.lattice_phase(cx, cy) {
            Ok(phase) => self.lattice_depth_from(cx, cy, phase, 0),
            Err(mixed) => mixed,
        }
    }

    /// Twice the squared distance from lattice point `(cx, cy)` to the nearest pixel of another
    /// tone than its own (a corner whose four pixels are not all one tone: 1), or `u16::MAX` when
    /// that is farther than the disc's radius. (Searching the disc row by row, a word at a time,
    /// was tried: slower, as most thin pixels lie a pixel or two from the other tone, which the
    /// ring, nearest first, finds in a few probes.)
    ///
    /// Of a point of tone `phase` (see [`Work::lattice_phase`]), its ring searched from entry
    /// `from` (the entries before it known to be of its tone, see [`ring_from`]).
    fn lattice_depth_from(&self, cx: i64, cy: i64, phase: bool, from: usize) -> u16 {
        let (k, w, h) = (self.ring_reach, self.bits.width, self.bits.height);
        if cx >= k && cy >= k && cx + k < w as i64 && cy + k < h as i64 {
            // Every probe inside the grid: a bit index, no bounds to check.
            let base = cy * 64 * self.bits.stride as i64 + cx;
            let data = &self.bits.data;
            for &(off, d2) in &self.ring_bits[from..] {
                let b = (base + off) as usize;
                if (data[b / 64] >> (b % 64) & 1 == 1) != phase {
                    return d2;
                }
            }
            return u16::MAX;
        }
        self.ring_depth_checked(cx, cy, phase, from)
    }

    /// Where the ring search of a point may start when the point before it in its row, of the
    /// same tone, has depth `d` (a [`Work::depth2`] value).
    fn ring_start(&self, d: u16) -> usize {
        if d == u16::MAX {
            *self.ring_from.last().expect("the entry past the radius")
        } else {
            self.ring_from.get(d as usize).copied().unwrap_or(0)
        }
    }

    /// The depth of a lattice point probing through the bounds-checked path only.
    #[cfg(test)]
    fn lattice_depth_checked(&self, cx: i64, cy: i64) -> u16 {
        match self.lattice_phase(cx, cy) {
            Ok(phase) => self.ring_depth_checked(cx, cy, phase, 0),
            Err(mixed) => mixed,
        }
    }

    /// The tone of pixel `(x, y)`; past the grid, material.
    fn tone_at(&self, x: i64, y: i64) -> bool {
        x < 0
            || y < 0
            || x >= self.bits.width as i64
            || y >= self.bits.height as i64
            || self.bits.get(x as usize, y as usize)
    }

    /// The tone lattice point `(cx, cy)` lies in: its pixel's, or for an even span its four
    /// pixels' when they agree (`Err(1)`, its depth, when they do not).
    fn lattice_phase(&self, cx: i64, cy: i64) -> Result<bool, u16> {
        let t = self.tone_at(cx, cy);
        if self.disc.on_corners()
            && [(cx - 1, cy - 1), (cx, cy - 1), (cx - 1, cy)]
                .iter()
                .any(|&(x, y)| self.tone_at(x, y) != t)
        {
            return Err(1);
        }
        Ok(t)
    }

    /// The depth of a lattice point of tone `phase`, probing its ring with bounds checks.
    fn ring_depth_checked(&self, cx: i64, cy: i64, phase: bool, from: usize) -> u16 {
        for &(dx, dy, d) in &self.ring[from..] {
            if self.tone_at(cx + dx, cy + dy) != phase {
                return (2.0 * d) as u16;
            }
        }
        u16::MAX
    }

    fn changeable(&self, i: usize) -> bool {
        let (x, y) = self.rows.xy(i);
        self.changeable_at(x, y)
    }

    fn changeable_at(&self, x: usize, y: usize) -> bool {
        x >= self.core[0]
            && y >= self.core[1]
            && x < self.core[2]
            && y < self.core[3]
            && self.allowed.as_ref().is_none_or(|a| a.get(x, y))
    }

    /// The price of flipping pixel `(x, y)`, which must be changeable.
    fn price_at(&self, x: usize, y: usize) -> f32 {
        let p = self.pad as usize;
        match self.price {
            Price::Gray(gray, t) => {
                let (x, y) = (
                    (x - p) as u32 + self.origin.0,
                    (y - p) as u32 + self.origin.1,
                );
                0.1 + (gray.get(x, y) - t).abs()
            }
            Price::One => 1.0,
        }
    }

    /// [`Work::depth_xy`] of pixel index `i`.
    #[cfg(test)]
    fn depth(&self, i: usize) -> (u16, usize) {
        if !self.disc.on_corners() {
            return (self.depth2[i], 0);
        }
        let (x, y) = self.rows.xy(i);
        self.depth_xy(x, y)
    }

    /// How deep thin pixel `(x, y)` lies in its tone (see [`Work::depth2`]): the largest depth
    /// over its candidate centres (itself, or its four corners for an even span), and which of
    /// them (an index into [`Work::paint`]).
    fn depth_xy(&self, x: usize, y: usize) -> (u16, usize) {
        let w = self.bits.width;
        if !self.disc.on_corners() {
            return (self.depth2[y * w + x], 0);
        }
        let mut best = (0, 0);
        for (n, &(ox, oy)) in CORNERS.iter().enumerate() {
            let d = self.depth2[(y + oy as usize) * (w + 1) + x + ox as usize];
            if n == 0 || d > best.0 {
                best = (d, n);
            }
        }
        best
    }

    /// The window without its padding.
    fn window(&self) -> BitGrid {
        let p = self.pad as usize;
        let (w, h) = (self.bits.width - 2 * p, self.bits.height - 2 * p);
        let mut out = BitGrid::new(w as u32, h as u32, false);
        packed::rows_mut_with(
            &mut out.data,
            w.max(1),
            packed::parallel(w * h),
            Vec::new,
            |scratch, (y, row)| packed::get_bits(self.bits.row(y + p), p, row, scratch),
        );
        out
    }
}

/// 8-connected groups of the set pixels of `mask` (those holding a pixel of `seeds`, when given):
/// a list of pixel indices per group, in raster order, the groups in the order of their first
/// pixel. (What [`groups_where`] gives when every group is fresh.)
#[cfg(test)]
fn groups(mask: &Packed, seeds: Option<&Packed>) -> Vec<Vec<usize>> {
    groups_where(mask, seeds, |_| true, |_| false)
        .into_iter()
        .map(|g| match g {
            Group::Pixels(px) => px,
            Group::Kept(_) => unreachable!("every group is fresh"),
        })
        .collect()
}

/// One of [`groups_where`]'s groups: its pixels, or only its first pixel when it is a group the
/// caller already has.
#[derive(Debug, PartialEq)]
enum Group {
    Pixels(Vec<usize>),
    Kept(usize),
}

/// 8-connected groups of the set pixels of `mask` (those holding a pixel of `seeds`, when given),
/// in the order of their first pixel. A group none of whose runs is `fresh` and whose first
/// pixel `known` accepts is [`Group::Kept`], by its first pixel: the caller has its pixels from
/// an earlier call, so they are not listed again. Every other group lists its pixel indices, in
/// raster order. By runs along rows joined to the runs they touch in the row above (union-find),
/// not pixel by pixel; freshness is asked once per run, not per pixel.
fn groups_where(
    mask: &Packed,
    seeds: Option<&Packed>,
    fresh: impl Fn(&Run) -> bool,
    known: impl Fn(usize) -> bool,
) -> Vec<Group> {
    let (w, h) = (mask.width, mask.height);
    // The rows holding a set bit: in later rounds most rows hold none, and an OR over a row (a
    // few vector operations) costs less than walking its words one by one. A run starts at each
    // set bit whose left neighbour is clear: at most that many runs.
    let mut starts = 0;
    let mut busy = Vec::new();
    for y in 0..h {
        let row = mask.row(y);
        if row.iter().fold(0, |a, &v| a | v) != 0 {
            busy.push(y);
            starts += row
                .iter()
                .map(|&v| (v & !(v << 1)).count_ones() as usize)
                .sum::<usize>();
        }
    }
    let mut runs: Vec<Run> = Vec::with_capacity(starts);
    let mut row_first = Vec::with_capacity(h + 1);
    let mut busy = busy.into_iter().peekable();
    for y in 0..h {
        row_first.push(runs.len());
        if busy.next_if_eq(&y).is_some() {
            push_runs(y as u32, mask.row(y).iter().copied(), &mut runs);
        }
    }
    row_first.push(runs.len());
    let (piece, count) = join_runs(&runs, &row_first, true);
    let mut wanted = vec![seeds.is_none(); count];
    if let Some(seeds) = seeds {
        for (r, &p) in runs.iter().zip(&piece) {
            if (r.x0..=r.x1).any(|x| seeds.get(x as usize, r.y as usize)) {
                wanted[p as usize] = true;
            }
        }
    }
    // Each piece's size, so its list is allocated once, and whether it holds a fresh run.
    let mut size = vec![0usize; count];
    let mut is_fresh = vec![false; count];
    for (r, &p) in runs.iter().zip(&piece) {
        size[p as usize] += (r.x1 - r.x0 + 1) as usize;
        if !is_fresh[p as usize] && wanted[p as usize] {
            is_fresh[p as usize] = fresh(r);
        }
    }
    // Wanted pieces, in the order of their first pixel.
    let mut group_of = vec![u32::MAX; count];
    let mut out: Vec<Group> = Vec::new();
    for (r, &p) in runs.iter().zip(&piece) {
        let p = p as usize;
        if !wanted[p] {
            continue;
        }
        let base = r.y as usize * w;
        if group_of[p] == u32::MAX {
            group_of[p] = out.len() as u32;
            let first = base + r.x0 as usize;
            if !is_fresh[p] && known(first) {
                out.push(Group::Kept(first));
            } else {
                out.push(Group::Pixels(Vec::with_capacity(size[p])));
            }
        }
        if let Group::Pixels(px) = &mut out[group_of[p] as usize] {
            px.extend((r.x0..=r.x1).map(|x| base + x as usize));
        }
    }
    out
}

/// One thin feature and what each way of resolving it would flip.
struct Feature {
    /// The tone of its pixels.
    phase: bool,
    pixels: Vec<usize>,
    /// The other tone's pixels a widening turns to `phase`.
    widen: Vec<usize>,
    /// What removing and widening it cost in the cost-based phase, once worked out (`None`
    /// inside: not available). Nothing either reads changes while the feature stays the same.
    cost: Option<(Option<f32>, Option<f32>)>,
}

/// [`widening`]'s buffers, one per thread, kept between features and rounds: a round widens
/// hundreds of features, most of a few dozen pixels, and each then allocates only its result.
#[derive(Default)]
struct WidenScratch {
    /// The pixels listed so far, the grid's size; all clear between features.
    seen: Packed,
    /// The feature's pixels' depths on a grid one pixel wider than the grid on every side (so
    /// a pixel's eight neighbours are there without bounds checks), 0 at every other pixel; all
    /// 0 between features.
    depths: Vec<u16>,
    /// The feature's pixels: coordinates, depth and centre (see [`Work::depth_xy`]).
    pixels: Vec<(u32, u32, u16, u8)>,
    /// The widening being listed.
    out: Vec<usize>,
}

/// The pixels of the other tone within the disc of each ridge pixel of a thin feature: its
/// pixels whose depth is at least each of their 8-neighbours' in the feature. The disc is
/// centred on the pixel (odd span) or on its deepest corner (even span), so once painted that
/// centre is a valid one and covers the ridge pixel. Listed ridge pixel by ridge pixel in the
/// feature's order, each disc row by row, left to right (the order its price is summed in).
fn widening(work: &Work, feature: &[usize], phase: bool, scratch: &mut WidenScratch) -> Vec<usize> {
    let bits = &work.bits;
    let (w, h, stride) = (bits.width, bits.height, bits.stride);
    let lw = w + 2;
    if scratch.seen.width != w || scratch.seen.height != h {
        scratch.seen = Packed::new(w, h, false);
        scratch.depths = vec![0; lw * (h + 2)];
    }
    let WidenScratch {
        seen,
        depths,
        pixels,
        out,
    } = scratch;
    pixels.clear();
    out.clear();
    // Each pixel's depth once (an even span's is the largest of four corners'), where the
    // ridge test below reads each up to nine times. A neighbour outside the feature reads 0:
    // every depth is at least 1 (a centre lies half a pixel or more from another tone's
    // pixel), so 0 passes the ridge test as "not in the feature" did, and is never equal to a
    // depth. (A thin pixel of the same tone next to one of the feature is in it: features are
    // 8-connected.)
    for &i in feature {
        let (x, y) = work.rows.xy(i);
        let (d, centre) = work.depth_xy(x, y);
        debug_assert!(d >= 1, "a depth of 0 at ({x}, {y})");
        depths[(y + 1) * lw + x + 1] = d;
        pixels.push((x as u32, y as u32, d, centre as u8));
    }
    let other = if phase { !0u64 } else { 0 };
    // The ridge pixel painted last, and its centre.
    let mut last: Option<(u32, u32, u8)> = None;
    for &(x, y, d, centre) in pixels.iter() {
        let j = (y as usize + 1) * lw + x as usize + 1;
        let (up, down, left, right) =
            (depths[j - lw], depths[j + lw], depths[j - 1], depths[j + 1]);
        let corners = depths[j - lw - 1]
            .max(depths[j - lw + 1])
            .max(depths[j + lw - 1])
            .max(depths[j + lw + 1]);
        if up.max(down).max(left).max(right).max(corners) > d {
            continue;
        }
        // A ridge two pixels thick (a line an even number of pixels wide) keeps one of its rows
        // or columns: discs on both would widen the line by a pixel more than it needs.
        if (up == d && down < d) || (left == d && right < d) {
            continue;
        }
        let after_left = x > 0 && last == Some((x - 1, y, centre));
        last = Some((x, y, centre));
        let (x, y) = (x as i64, y as i64);
        if after_left {
            // The pixel to the left was just painted with a disc of the same shape: each row of
            // this disc is that one's moved a pixel right, so only its last pixel can be new.
            for &(dy, _, b) in &work.paint[centre as usize] {
                let (nx, ny) = (x + b, y + dy);
                if ny < 0 || ny >= h as i64 || nx < 0 || nx >= w as i64 {
                    continue;
                }
                let (nx, ny) = (nx as usize, ny as usize);
                let at = ny * stride + nx / 64;
                let bit = 1u64 << (nx % 64);
                if (bits.data[at] ^ other) & !seen.data[at] & bit != 0 {
                    seen.data[at] |= bit;
                    out.push(ny * w + nx);
                }
            }
            continue;
        }
        // Row by row, a word at a time: the other tone's pixels in the disc not yet listed.
        for &(dy, a, b) in &work.paint[centre as usize] {
            let ny = y + dy;
            let (x0, x1) = ((x + a).max(0), (x + b).min(w as i64 - 1));
            if ny < 0 || ny >= h as i64 || x0 > x1 {
                continue;
            }
            let (x0, x1, ny) = (x0 as usize, x1 as usize, ny as usize);
            let row = ny * stride;
            for k in x0 / 64..=x1 / 64 {
                let lo = if k == x0 / 64 { x0 % 64 } else { 0 };
                let hi = if k == x1 / 64 { x1 % 64 } else { 63 };
                let span = (!0u64 << lo) & (!0u64 >> (63 - hi));
                let mut hits = (bits.data[row + k] ^ other) & span & !seen.data[row + k];
                seen.data[row + k] |= hits;
                let base = ny * w + k * 64;
                while hits != 0 {
                    out.push(base + hits.trailing_zeros() as usize);
                    hits &= hits - 1;
                }
            }
        }
    }
    for &j in out.iter() {
        let (x, y) = work.rows.xy(j);
        seen.data[y * stride + x / 64] = 0;
    }
    for &(x, y, _, _) in pixels.iter() {
        depths[(y as usize + 1) * lw + x as usize + 1] = 0;
    }
    out.as_slice().to_vec()
}

/// Every thin feature of both tones, with its widening. A feature none of whose pixels lies in a
/// tile the refresh recomputed is one of the last round's ([`Work::kept`]): its pixels and their
/// neighbours are thin or not as they were, and the depths and bits its widening reads (within
/// the disc's reach and two pixels of it) did not change, so it is taken as it was. Thin holes'
/// widenings are listed only when `widen_holes`: the monotone phase fills thin holes and never
/// widens them, so it does not ask (its holes' `widen` is empty).
fn features(work: &mut Work, widen_holes: bool) -> Vec<Feature> {
    work.refresh();
    let kept = std::mem::take(&mut work.kept);
    let work = &*work;
    let (w, h) = (work.bits.width, work.bits.height);
    thread_local! {
        static SCRATCH: std::cell::RefCell<WidenScratch> = Default::default();
    }
    let feature = |phase: bool, (pixels, old): (Vec<usize>, Option<Feature>)| {
        if let Some(old) = old {
            return old;
        }
        let widen = if phase || widen_holes {
            SCRATCH.with(|scratch| widening(work, &pixels, phase, &mut scratch.borrow_mut()))
        } else {
            Vec::new()
        };
        Feature {
            phase,
            pixels,
            widen,
            cost: None,
        }
    };
    // Whether a run of thin pixels lies (in part) in a tile the refresh recomputed.
    let stride = work.bits.stride;
    let fresh = |r: &Run| {
        work.dirty.as_ref().is_none_or(|d| {
            let b = r.y as usize / BAND * stride;
            d[b + r.x0 as usize / 64..=b + r.x1 as usize / 64].contains(&true)
        })
    };
    let of_phase = |phase: bool, mut kept: Vec<Feature>| -> Vec<Feature> {
        // The same pixels, so the same first pixel, by which both lists run.
        let firsts: Vec<usize> = kept.iter().map(|f| f.pixels[0]).collect();
        let known = |first: usize| firsts.binary_search(&first).is_ok();
        let groups: Vec<(Vec<usize>, Option<Feature>)> = groups_where(
            &work.thin[!phase as usize],
            work.seeds.as_ref(),
            fresh,
            known,
        )
        .into_iter()
        .map(|g| match g {
            Group::Pixels(pixels) => (pixels, None),
            Group::Kept(first) => {
                let k = firsts.binary_search(&first).expect("a known first pixel");
                let old = std::mem::replace(&mut kept[k], Feature::empty(phase));
                (Vec::new(), Some(old))
            }
        })
        .collect();
        if packed::parallel(w * h) {
            groups
                .into_par_iter()
                .map(|pixels| feature(phase, pixels))
                .collect()
        } else {
            groups
                .into_iter()
                .map(|pixels| feature(phase, pixels))
                .collect()
        }
    };
    let [km, kc] = kept;
    let (mut material, cut) = if packed::parallel(w * h) {
        rayon::join(|| of_phase(true, km), || of_phase(false, kc))
    } else {
        (of_phase(true, km), of_phase(false, kc))
    };
    material.extend(cut);
    material
}

impl Feature {
    fn empty(phase: bool) -> Feature {
        Feature {
            phase,
            pixels: Vec::new(),
            widen: Vec::new(),
            cost: None,
        }
    }
}

impl Work<'_> {
    /// Keep a round's features (as [`features`] gave them) for the next.
    fn keep(&mut self, feats: Vec<Feature>) {
        let (material, cut) = feats.into_iter().partition(|f| f.phase);
        self.kept = [material, cut];
    }
}

/// The price of flipping a pixel: `0.1 + |gray − threshold|` of its picture pixel (the gray
/// and the threshold), or 1 for every pixel. A plain value rather than a boxed closure, so the
/// per-pixel sums inline it.
#[derive(Clone, Copy)]
enum Price<'a> {
    Gray(&'a Gray, f32),
    One,
}

/// Regularise `bits` (material = true) so that no web or hole is narrower than
/// `cfg.min_width_px`, deciding each thin feature by the gray picture. See the module comment.
pub fn regularize(
    bits: &BitGrid,
    gray: &Gray,
    cfg: &RegularizeConfig,
) -> (BitGrid, RegularizeStats) {
    let disc = Disc::for_width(cfg.min_width_px);
    let mut stats = RegularizeStats {
        disc_px: disc.span,
        ..Default::default()
    };
    if disc.span <= 1 || bits.is_empty() {
        return (bits.clone(), stats);
    }
    let all = [0, 0, bits.width, bits.height];
    let mut work = Work::new(bits, all, all, disc, Price::Gray(gray, cfg.threshold));
    decide(&mut work, &mut stats);
    settle(&mut work, &mut stats);
    let out = work.window();
    // Counted in pieces on threads: integer sums, the same in any order.
    let (removed, added) = bits
        .data
        .par_chunks(1 << 16)
        .zip(out.data.par_chunks(1 << 16))
        .map(|(a, b)| {
            a.iter().zip(b).fold((0usize, 0usize), |(r, d), (&a, &b)| {
                (r + (a & !b) as usize, d + (!a & b) as usize)
            })
        })
        .reduce(|| (0, 0), |x, y| (x.0 + y.0, x.1 + y.1));
    stats.material_removed_px = removed;
    stats.material_added_px = added;
    (out, stats)
}

/// The cost-based phase: each round, every thin feature is removed or widened, whichever costs
/// less; a pixel that changed may not change back; at most [`FREE_ROUNDS`] rounds.
fn decide(work: &mut Work, stats: &mut RegularizeStats) {
    for _ in 0..FREE_ROUNDS {
        let mut feats = features(work, true);
        if feats.is_empty() {
            break;
        }
        stats.rounds += 1;
        let mut changed = std::mem::replace(&mut work.changed, Packed::new(0, 0, false));
        changed.data.fill(0);
        let mut any = false;
        // Removing needs every pixel of the feature; a widening paints what it may (the frame
        // past the picture's border is material already, and cut may not reach into it). Each
        // feature's prices are its own sum, in its own order, so they are worked out on threads.
        {
            let work = &*work;
            let cost = |px: &[usize], all: bool| -> Option<f32> {
                let mut c = 0.0;
                for &i in px {
                    let (x, y) = work.rows.xy(i);
                    let changeable = work.changeable_at(x, y);
                    if work.locked.get(x, y) || (all && !changeable) {
                        return None;
                    }
                    if changeable {
                        c += work.price_at(x, y);
                    }
                }
                Some(c)
            };
            let price = |f: &mut Feature| {
                if f.cost.is_none() {
                    let remove = cost(&f.pixels, true);
                    let widen = if f.widen.is_empty() {
                        None
                    } else {
                        cost(&f.widen, false)
                    };
                    f.cost = Some((remove, widen));
                }
            };
            if packed::parallel(work.bits.width * work.bits.height) {
                feats.par_iter_mut().for_each(price);
            } else {
                feats.iter_mut().for_each(price);
            }
        }
        // Cheapest first, so where two features' choices meet the cheaper one's stands.
        let mut choices: Vec<(f32, usize, bool)> = Vec::new();
        for (n, f) in feats.iter().enumerate() {
            let (remove, widen) = f.cost.expect("every feature is priced");
            match (remove, widen) {
                (Some(r), Some(wd)) if wd < r => choices.push((wd, n, true)),
                (Some(r), _) => choices.push((r, n, false)),
                (None, Some(wd)) => choices.push((wd, n, true)),
                (None, None) => {}
            }
        }
        choices.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (_, n, widen) in choices {
            let f = &feats[n];
            let px = if widen { &f.widen } else { &f.pixels };
            let rows = work.rows;
            if px.iter().any(|&i| {
                let (x, y) = rows.xy(i);
                changed.get(x, y)
            }) {
                continue;
            }
            for &i in px {
                let (x, y) = rows.xy(i);
                if !work.changeable_at(x, y) {
                    continue;
                }
                let v = !work.bits.get(x, y);
                work.flip(x, y, v);
                work.locked.set(x, y, true);
                changed.set(x, y, true);
            }
            any = true;
            match (f.phase, widen) {
                (true, false) => stats.webs_removed += 1,
                (true, true) => stats.webs_widened += 1,
                (false, false) => stats.holes_filled += 1,
                (false, true) => stats.holes_widened += 1,
            }
        }
        work.changed = changed;
        work.keep(feats);
        if !any {
            break;
        }
    }
}

/// The monotone phase: fill thin holes and widen thin webs (both only add material) until nothing
/// that may change is thin. Ends: see the module comment.
fn settle(work: &mut Work, stats: &mut RegularizeStats) {
    loop {
        let feats = features(work, false);
        let live: Vec<usize> = (0..feats.len())
            .filter(|&n| feats[n].pixels.iter().any(|&i| work.changeable(i)))
            .collect();
        if live.is_empty() {
            break;
        }
        stats.monotone_rounds += 1;
        let mut added = 0usize;
        for &n in &live {
            let f = &feats[n];
            let px = if f.phase { &f.widen } else { &f.pixels };
            for &i in px {
                let (x, y) = work.rows.xy(i);
                if work.changeable_at(x, y) && !work.bits.get(x, y) {
                    work.flip(x, y, true);
                    added += 1;
                }
            }
            if f.phase {
                stats.webs_widened += 1;
            } else {
                stats.holes_filled += 1;
            }
        }
        work.keep(feats);
        // Cannot happen over the whole picture (see the module comment); in a window a widening
        // may lie outside the part that may change. Either way, stop rather than spin.
        if added == 0 {
            break;
        }
    }
}

/// How many pixels of material and of cut are thin for a web or hole `min_width_px` wide: both 0
/// for what [`regularize`] returns (the tests' measure of it).
#[cfg(test)]
pub fn thin_count(bits: &BitGrid, min_width_px: f64) -> [usize; 2] {
    let disc = Disc::for_width(min_width_px);
    if disc.span <= 1 || bits.is_empty() {
        return [0, 0];
    }
    let all = [0, 0, bits.width, bits.height];
    let mut work = Work::new(bits, all, all, disc, Price::One);
    work.refresh();
    work.thin.each_ref().map(|m| m.count())
}

/// Settle the whole stencil with the monotone phase alone: fill thin holes and widen thin webs,
/// only adding material, until nothing is thin. After bridges are drawn into a regularised
/// two-tone, every thin pixel is one a bridge made (a cut sliver beside it, a notch in its edge),
/// so this tidies exactly where bridges meet the picture; being monotone it never cuts a bridge
/// and ends (see the module comment). Returns the number of pixels added.
pub fn settle_all(bits: &mut BitGrid, min_width_px: f64) -> usize {
    let disc = Disc::for_width(min_width_px);
    if disc.span <= 1 || bits.is_empty() {
        return 0;
    }
    let all = [0, 0, bits.width, bits.height];
    let mut work = Work::new(bits, all, all, disc, Price::One);
    settle(&mut work, &mut RegularizeStats::default());
    let out = work.window();
    let added = out.count_material() - bits.count_material();
    *bits = out;
    added
}

/// Fill the pockets of cut that bridges sealed off: cut pieces of `after` whose every material
/// neighbour is material `after` added to `before` (overlapping bridges enclose a piece of the
/// picture's cut). Such a pocket shows nothing of the picture's outline and its ring lies wholly
/// inside bridges, where it only weakens them. Only adds material. Returns the pixels filled.
pub fn fill_sealed_pockets(before: &BitGrid, after: &mut BitGrid) -> usize {
    // A sealed pocket's material neighbours are all added, so it lies beside an added pixel:
    // only the cut pieces beside added pixels are searched, each until it shows itself open
    // (the picture's border, original material, or a pixel of a piece already found open). So
    // the cost follows the bridges, not the picture; the pieces filled are those a labelling of
    // every cut piece finds sealed.
    let (w, h) = (after.width as usize, after.height as usize);
    if w == 0 || h == 0 {
        return 0;
    }
    const UNSEEN: u8 = 0;
    const OPEN: u8 = 1;
    const HERE: u8 = 2;
    let mut state = vec![UNSEEN; w * h];
    // Breadth first, so a search stops at the original material nearest its seed.
    let (mut queue, mut piece) = (std::collections::VecDeque::new(), Vec::new());
    let mut filled = 0;
    // The added pixels are few and bunched: runs of 64 pixels with none are skipped by one
    // branch-free test (read when the scan reaches them, as the pixel loop would).
    const RUN: usize = 64;
    for run in (0..w * h).step_by(RUN) {
        let end = (run + RUN).min(w * h);
        let any = after.data[run..end]
            .iter()
            .zip(&before.data[run..end])
            .fold(false, |acc, (&a, &b)| acc | (a & !b));
        if !any {
            continue;
        }
        for i in run..end {
            if !after.data[i] || before.data[i] {
                continue;
            }
            for s in crate::raster::edge_neighbours(i, w, h)
                .into_iter()
                .flatten()
            {
                if after.data[s] || state[s] != UNSEEN {
                    continue;
                }
                queue.clear();
                piece.clear();
                state[s] = HERE;
                queue.push_back(s);
                let mut open = false;
                'fill: while let Some(p) = queue.pop_front() {
                    piece.push(p);
                    let (x, y) = (p % w, p / w);
                    if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
                        open = true;
                        break;
                    }
                    for q in [p - 1, p + 1, p - w, p + w] {
                        if after.data[q] {
                            if before.data[q] {
                                open = true;
                                break 'fill;
                            }
                        } else if state[q] == OPEN {
                            open = true;
                            break 'fill;
                        } else if state[q] == UNSEEN {
                            state[q] = HERE;
                            queue.push_back(q);
                        }
                    }
                }
                if open {
                    for &p in piece.iter().chain(&queue) {
                        state[p] = OPEN;
                    }
                } else {
                    for &p in &piece {
                        after.data[p] = true;
                    }
                    filled += piece.len();
                }
            }
        }
    }
    filled
}

/// Where bridges meet the picture: settle the pixels within reach of the bridges' bounding boxes
/// (`[x0, y0, x1, y1)` in pixels), only adding material, so no cut sliver and no web narrower than
/// the material's smallest feature is left beside a bridge. Only the pixels within `spread` disc
/// spans of a box may change; thin features holding none of them are left as they are. Returns
/// the number of pixels added.
pub fn settle_near(
    bits: &mut BitGrid,
    boxes: &[[u32; 4]],
    min_width_px: f64,
    spread: u32,
) -> usize {
    let disc = Disc::for_width(min_width_px);
    if disc.span <= 1 || bits.is_empty() {
        return 0;
    }
    let reach = disc.span + 1;
    // Boxes whose windows overlap are settled together, in one window holding them all with a
    // margin of two spans past the reach `spread` spans around each (a pixel's thinness depends
    // on the pixels within two spans), so thinness in the part that may change is measured
    // exactly; pixels within the margin of the window's cut edges may be misjudged (the padding
    // stands in for what lies beyond) and may not change ([`clusters`]).
    // Each cluster is settled in the box holding its windows, reading the bits there and
    // changing them only inside it. So clusters whose boxes do not overlap are independent: each
    // cluster runs in a wave after every earlier cluster (in cluster order) whose box overlaps its
    // own, the clusters of a wave in parallel against the bits the earlier waves left, and what
    // they add is set between waves: the same pixels as settling them one after the other.
    let jobs = clusters(bits, boxes, reach, spread);
    let mut wave = vec![0usize; jobs.len()];
    for j in 0..jobs.len() {
        wave[j] = (0..j)
            .filter(|&i| meets(jobs[i].window, jobs[j].window))
            .map(|i| wave[i] + 1)
            .max()
            .unwrap_or(0);
    }
    let mut added = 0;
    for now in 0..=wave.iter().copied().max().unwrap_or(0) {
        let snapshot: &BitGrid = bits;
        let found: Vec<Vec<(u32, u32)>> = jobs
            .par_iter()
            .zip(&wave)
            .filter(|(_, &k)| k == now)
            .map(|(c, _)| settle_window(snapshot, c.window, &c.own, &c.near, disc, reach))
            .collect();
        for (x, y) in found.into_iter().flatten() {
            bits.set(x, y, true);
            added += 1;
        }
    }
    added
}

/// A cluster of [`settle_near`]'s boxes: the box holding its windows, in which it is settled,
/// and its members' own boxes and their surroundings (`spread` reaches around each).
struct Cluster {
    window: [u32; 4],
    own: Vec<[u32; 4]>,
    near: Vec<[u32; 4]>,
}

/// [`settle_near`]'s clusters, in cluster-number order: each box's window (its box grown by two
/// spans past `spread` reaches, clipped to the picture), windows that overlap in one cluster.
fn clusters(bits: &BitGrid, boxes: &[[u32; 4]], reach: u32, spread: u32) -> Vec<Cluster> {
    let (w, h) = (bits.width, bits.height);
    let grow = |b: [u32; 4], m: u32| {
        [
            b[0].saturating_sub(m),
            b[1].saturating_sub(m),
            (b[2] + m).min(w),
            (b[3] + m).min(h),
        ]
    };
    let windows: Vec<[u32; 4]> = boxes
        .iter()
        .map(|&b| grow(b, (2 + spread) * reach))
        .collect();
    let cluster = overlapping(&windows);
    let mut ids = cluster.clone();
    ids.sort_unstable();
    ids.dedup();
    ids.iter()
        .map(|&id| {
            let members: Vec<usize> = (0..boxes.len()).filter(|&i| cluster[i] == id).collect();
            let window = members
                .iter()
                .map(|&i| windows[i])
                .reduce(|a, b| {
                    [
                        a[0].min(b[0]),
                        a[1].min(b[1]),
                        a[2].max(b[2]),
                        a[3].max(b[3]),
                    ]
                })
                .expect("a cluster has a box");
            Cluster {
                window,
                own: members.iter().map(|&i| grow(boxes[i], 0)).collect(),
                near: members
                    .iter()
                    .map(|&i| grow(boxes[i], spread * reach))
                    .collect(),
            }
        })
        .collect()
}

/// Whether two boxes `[x0, y0, x1, y1)` share a pixel.
fn meets(a: [u32; 4], b: [u32; 4]) -> bool {
    a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
}

/// A cluster number per window: windows that overlap, directly or through others, share the
/// smallest of their numbers. Past a few hundred windows, one cluster for all: clustering would
/// cost more than it saves.
fn overlapping(windows: &[[u32; 4]]) -> Vec<usize> {
    let n = windows.len();
    if n > 512 {
        return vec![0; n];
    }
    let mut cluster: Vec<usize> = (0..n).collect();
    loop {
        let mut merged = false;
        for i in 0..n {
            for j in 0..i {
                if cluster[i] != cluster[j] && meets(windows[i], windows[j]) {
                    let (from, to) = (cluster[i].max(cluster[j]), cluster[i].min(cluster[j]));
                    cluster
                        .iter_mut()
                        .filter(|c| **c == from)
                        .for_each(|c| *c = to);
                    merged = true;
                }
            }
        }
        if !merged {
            return cluster;
        }
    }
}

/// [`settle_near`] in one window: the thin features holding a pixel of `boxes` are resolved, and
/// only the pixels in `near` may change (both in picture coordinates). Returns the pixels it
/// turns into material (it leaves `bits` as it is).
fn settle_window(
    bits: &BitGrid,
    window: [u32; 4],
    boxes: &[[u32; 4]],
    near: &[[u32; 4]],
    disc: Disc,
    reach: u32,
) -> Vec<(u32, u32)> {
    let (w, h) = (bits.width, bits.height);
    let m = 2 * reach;
    let core = [
        if window[0] == 0 { 0 } else { window[0] + m },
        if window[1] == 0 { 0 } else { window[1] + m },
        if window[2] == w { w } else { window[2] - m },
        if window[3] == h { h } else { window[3] - m },
    ];
    let rel = [
        core[0] - window[0],
        core[1] - window[1],
        core[2].max(core[0]) - window[0],
        core[3].max(core[1]) - window[1],
    ];
    let mut work = Work::new(bits, window, rel, disc, Price::One);
    // What may change: each box and `spread` spans around it, so what a widening there pushes
    // outward is settled too.
    let pad = work.pad;
    let mask = |rects: &[[u32; 4]]| {
        let mut m = Packed::new(work.bits.width, work.bits.height, false);
        for &g in rects {
            for y in g[1]..g[3] {
                for x in g[0]..g[2] {
                    m.set(
                        (x - window[0] + pad) as usize,
                        (y - window[1] + pad) as usize,
                        true,
                    );
                }
            }
        }
        m
    };
    work.seeds = Some(mask(boxes));
    work.allowed = Some(mask(near));
    settle(&mut work, &mut RegularizeStats::default());
    let out = work.window();
    let mut added = Vec::new();
    for y in core[1]..core[3] {
        for x in core[0]..core[2] {
            let v = out.get(x - window[0], y - window[1]);
            if v && !bits.get(x, y) {
                added.push((x, y));
            }
        }
    }
    added
}

/// The pixels of the other tone within the disc of each ridge pixel of a thin feature: its pixels whose depth is at least each of their 8-neighbours' in the feature. The
/// disc is centred on the pixel (odd span) or on its deepest corner (even span), so once painted
/// that centre is a valid one and covers the ridge pixel. `seen` is all clear scratch the size of
/// the grid, left clear.
#[cfg(test)]
fn widening_old(
    work: &Work,
    feature: &[usize],
    phase: bool,
    seen: &mut Packed,
    depths: &mut Vec<u16>,
) -> Vec<usize> {
    let bits = &work.bits;
    let mask = &work.thin[!phase as usize];
    let (w, h) = (bits.width as i64, bits.height as i64);
    // Each pixel's depth once (an even span's is the largest of four corners'), where the
    // ridge test below reads each up to nine times.
    depths.resize(bits.width * bits.height, 0);
    for &i in feature {
        let (x, y) = work.rows.xy(i);
        depths[i] = work.depth_xy(x, y).0;
    }
    let depths = &depths[..];
    // A neighbour's depth, or none when it is not in the feature (a thin pixel of the same tone
    // next to one of the feature is in it: features are 8-connected, so its depth was just set).
    let depth_at = |nx: i64, ny: i64| -> Option<u16> {
        if nx < 0 || ny < 0 || nx >= w || ny >= h || !mask.get(nx as usize, ny as usize) {
            return None;
        }
        Some(depths[(ny * w + nx) as usize])
    };
    let mut out = Vec::new();
    for &i in feature {
        let (x, y) = work.rows.xy(i);
        let d = depths[i];
        let (x, y) = (x as i64, y as i64);
        let ridge = AROUND
            .iter()
            .all(|&(dx, dy)| depth_at(x + dx, y + dy) <= Some(d));
        if !ridge {
            continue;
        }
        // A ridge two pixels thick (a line an even number of pixels wide) keeps one of its rows
        // or columns: discs on both would widen the line by a pixel more than it needs.
        if (depth_at(x, y - 1) == Some(d) && depth_at(x, y + 1) < Some(d))
            || (depth_at(x - 1, y) == Some(d) && depth_at(x + 1, y) < Some(d))
        {
            continue;
        }
        // Row by row, a word at a time: the other tone's pixels in the disc not yet listed.
        let centre = work.depth_xy(x as usize, y as usize).1;
        for &(dy, a, b) in &work.paint[centre] {
            let ny = y + dy;
            let (x0, x1) = ((x + a).max(0), (x + b).min(w - 1));
            if ny < 0 || ny >= h || x0 > x1 {
                continue;
            }
            let (x0, x1, ny) = (x0 as usize, x1 as usize, ny as usize);
            for k in x0 / 64..=x1 / 64 {
                let lo = if k == x0 / 64 { x0 % 64 } else { 0 };
                let hi = if k == x1 / 64 { x1 % 64 } else { 63 };
                let span = (!0u64 << lo) & (!0u64 >> (63 - hi));
                let word = bits.row(ny)[k];
                let other = if phase { !word } else { word };
                let mut hits = other & span & !seen.row(ny)[k];
                seen.data[ny * seen.stride + k] |= hits;
                while hits != 0 {
                    out.push(ny * w as usize + k * 64 + hits.trailing_zeros() as usize);
                    hits &= hits - 1;
                }
            }
        }
    }
    for &j in &out {
        seen.put(j, false);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Lcg;

    /// A `w`×`h` grid of `cell`-pixel blocks, each material with chance `dense` in 10 (drawn
    /// from `rnd`, row of blocks by row): noise at cell 1, pieces of many sizes above it.
    fn blocky(w: u32, h: u32, cell: u32, dense: u64, rnd: &mut impl FnMut(u64) -> u64) -> BitGrid {
        let noise: Vec<bool> = (0..(w / cell + 1) * (h / cell + 1))
            .map(|_| rnd(10) < dense)
            .collect();
        BitGrid::from_fn(w, h, |x, y| {
            noise[((y / cell) * (w / cell + 1) + x / cell) as usize]
        })
    }

    fn cfg(px: f64) -> RegularizeConfig {
        RegularizeConfig {
            min_width_px: px,
            threshold: 0.5,
            invert: false,
        }
    }

    /// The sealed pockets by labelling every cut piece (what the seeded search must match).
    fn sealed_by_labels(before: &BitGrid, after: &BitGrid) -> BitGrid {
        let (labels, areas) = crate::raster::components(after, false);
        let (w, h) = (after.width as usize, after.height as usize);
        let mut open = vec![false; areas.len()];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let l = labels[i];
                if l == crate::raster::NOT_LABELLED {
                    continue;
                }
                if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
                    open[l as usize] = true;
                    continue;
                }
                for j in [i - 1, i + 1, i - w, i + w] {
                    if after.data[j] && before.data[j] {
                        open[l as usize] = true;
                    }
                }
            }
        }
        let mut out = after.clone();
        for (i, &l) in labels.iter().enumerate() {
            if l != crate::raster::NOT_LABELLED && !open[l as usize] {
                out.data[i] = true;
            }
        }
        out
    }

    #[test]
    fn sealed_pockets_are_the_cut_pieces_no_original_material_or_border_touches() {
        let mut rng = Lcg(11u64);
        let mut rnd = |n: u64| rng.below(n);
        let mut filled_some = false;
        for case in 0..300 {
            let (w, h) = (3 + rnd(30) as u32, 3 + rnd(30) as u32);
            let dense = 2 + rnd(6);
            let before = BitGrid::from_fn(w, h, |_, _| rnd(10) < dense);
            let mut after = before.clone();
            // Bridges: random rectangles of added material, some of them rings.
            for _ in 0..1 + rnd(4) {
                let (x0, y0) = (rnd(w as u64) as u32, rnd(h as u64) as u32);
                let (x1, y1) = (x0 + 1 + rnd(10) as u32, y0 + 1 + rnd(10) as u32);
                let ring = rnd(2) == 0;
                for y in y0..y1.min(h) {
                    for x in x0..x1.min(w) {
                        let edge = x == x0 || y == y0 || x + 1 == x1 || y + 1 == y1;
                        if !ring || edge {
                            after.set(x, y, true);
                        }
                    }
                }
            }
            let want = sealed_by_labels(&before, &after);
            let mut got = after.clone();
            let n = fill_sealed_pockets(&before, &mut got);
            assert_eq!(got, want, "case {case}");
            assert_eq!(n, want.count_material() - after.count_material());
            filled_some |= n > 0;
        }
        assert!(filled_some, "some case had a sealed pocket");
    }

    /// [`settle_near`] as it was: the clusters settled one after the other, each writing into
    /// the bits before the next reads them.
    fn settle_near_in_turn(
        bits: &mut BitGrid,
        boxes: &[[u32; 4]],
        min_width_px: f64,
        spread: u32,
    ) -> usize {
        let disc = Disc::for_width(min_width_px);
        let reach = disc.span + 1;
        let mut added = 0;
        for c in clusters(bits, boxes, reach, spread) {
            for (x, y) in settle_window(bits, c.window, &c.own, &c.near, disc, reach) {
                bits.set(x, y, true);
                added += 1;
            }
        }
        added
    }

    /// Settling the clusters in waves, each wave in parallel, adds the pixels settling them one
    /// after the other adds: random bits, random boxes (clusters whose boxes overlap, L-shaped
    /// clusters whose box holds another's windows, far-apart ones).
    #[test]
    fn settle_near_in_waves_is_settling_in_turn() {
        let mut rng = Lcg(0x5eed_u64);
        let mut rnd = |n: u64| rng.below(n);
        let mut changed = 0;
        for case in 0..60 {
            let (w, h) = (60 + rnd(200) as u32, 60 + rnd(200) as u32);
            let dense = 3 + rnd(5);
            let cell = 1 + rnd(4) as u32;
            let bits = blocky(w, h, cell, dense, &mut rnd);
            let boxes: Vec<[u32; 4]> = (0..1 + rnd(12))
                .map(|_| {
                    let (x0, y0) = (rnd(w as u64) as u32, rnd(h as u64) as u32);
                    let (x1, y1) = (x0 + 1 + rnd(12) as u32, y0 + 1 + rnd(12) as u32);
                    [x0, y0, x1.min(w), y1.min(h)]
                })
                .collect();
            let px = [3.0, 4.5, 6.0][case % 3];
            let (mut want, mut got) = (bits.clone(), bits.clone());
            let n_want = settle_near_in_turn(&mut want, &boxes, px, 1);
            let n_got = settle_near(&mut got, &boxes, px, 1);
            assert_eq!(got, want, "case {case}");
            assert_eq!(n_got, n_want, "case {case}");
            changed += n_got;
        }
        assert!(changed > 0, "some case settled something");
    }

    /// The depth probed by bit index inside the grid is the depth probed with bounds checks, at
    /// every lattice point of random grids (sparse, dense, blocky), odd and even spans.
    #[test]
    fn depth_by_bit_index_is_depth_with_checks() {
        let mut rng = Lcg(0xd3e9_u64);
        let mut rnd = |n: u64| rng.below(n);
        for case in 0..40 {
            let (w, h) = (1 + rnd(150) as u32, 1 + rnd(60) as u32);
            let dense = rnd(11);
            let cell = 1 + rnd(5) as u32;
            let bits = blocky(w, h, cell, dense, &mut rnd);
            let px = [2.0, 3.0, 4.0, 5.0, 6.0, 11.0, 12.0, 40.0, 71.0][case % 9];
            let disc = Disc::for_width(px);
            let all = [0, 0, w, h];
            let work = Work::new(&bits, all, all, disc, Price::One);
            let c = disc.on_corners() as i64;
            for cy in 0..work.bits.height as i64 + c {
                for cx in 0..work.bits.width as i64 + c {
                    assert_eq!(
                        work.lattice_depth(cx, cy),
                        work.lattice_depth_checked(cx, cy),
                        "case {case} span {} at ({cx}, {cy})",
                        disc.span
                    );
                }
            }
        }
    }

    /// Coordinates by the multiply are coordinates by division: random and extreme widths and
    /// indices within 32 bits, and the fallback past them.
    #[test]
    fn rows_by_multiply_are_rows_by_division() {
        let mut rng = Lcg(0xd1f);
        let mut next = || rng.next_u64() >> 32;
        let max = u32::MAX as usize;
        let mut widths: Vec<usize> = vec![1, 2, 3, 7, 63, 64, 65, 1000, 1031, 65535, 65536, max];
        widths.extend((0..200).map(|_| 1 + next() as usize % 5000));
        widths.extend((0..50).map(|_| 2 + next() as usize));
        for &w in &widths {
            let h = (max / w).max(1);
            let rows = Rows::new(w, h);
            let last = (w * h).min(max);
            let mut idx: Vec<usize> = vec![0, 1, w - 1, w, w + 1, last, last - 1, last / 2];
            idx.extend((0..300).map(|_| next() as usize % (last + 1)));
            for i in idx {
                assert_eq!(rows.xy(i), (i % w, i / w), "width {w} index {i}");
            }
        }
        let big = Rows::new(1 << 20, 1 << 20);
        assert_eq!(big.c, 0);
        assert_eq!(big.xy((5 << 20) + 3), (3, 5));
    }

    /// The depths a refresh keeps, searched from where the point before in the row allows
    /// ([`ring_from`]), are the depths searched from the ring's start with bounds checks, at
    /// every centre of every thin pixel of random grids (sparse, dense, blocky; odd and even
    /// spans, small and large).
    #[test]
    fn depths_searched_from_the_neighbours_bound_are_full_searches() {
        let mut rng = Lcg(0xdeb7_u64);
        let mut rnd = |n: u64| rng.below(n);
        let mut checked = 0;
        for case in 0..60 {
            let (w, h) = (1 + rnd(220) as u32, 1 + rnd(90) as u32);
            let dense = rnd(11);
            let cell = 1 + rnd(7) as u32;
            let bits = blocky(w, h, cell, dense, &mut rnd);
            let px = [2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 11.0, 12.0, 17.0, 24.0][case % 10];
            let disc = Disc::for_width(px);
            let all = [0, 0, w, h];
            let mut work = Work::new(&bits, all, all, disc, Price::One);
            work.refresh();
            let (pw, ph) = (work.bits.width, work.bits.height);
            let c = disc.on_corners() as usize;
            for y in 0..ph {
                for x in 0..pw {
                    if !(work.thin[0].get(x, y) || work.thin[1].get(x, y)) {
                        continue;
                    }
                    for (ox, oy) in [(0, 0), (c, 0), (0, c), (c, c)] {
                        let (cx, cy) = (x + ox, y + oy);
                        assert_eq!(
                            work.depth2[cy * (pw + c) + cx],
                            work.lattice_depth_checked(cx as i64, cy as i64),
                            "case {case} span {} at ({cx}, {cy})",
                            disc.span
                        );
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 1000, "{checked} depths checked");
    }

    /// The widening by one scratch kept over features and grids is the pixel-by-pixel one
    /// ([`widening_old`]): the same pixels in the same order, for every thin feature of both
    /// tones of random grids (sparse, dense, blocky; odd and even spans).
    #[test]
    fn widening_with_kept_scratch_is_the_pixel_by_pixel_widening() {
        let mut rng = Lcg(0x71de_u64);
        let mut rnd = |n: u64| rng.below(n);
        let mut scratch = WidenScratch::default();
        let mut widened = 0;
        for case in 0..60 {
            let (w, h) = (1 + rnd(260) as u32, 1 + rnd(120) as u32);
            let (cell, dense) = (1 + rnd(7) as u32, rnd(11));
            let bits = blocky(w, h, cell, dense, &mut rnd);
            let px = [2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 11.0, 12.0, 17.0, 24.0][case % 10];
            let disc = Disc::for_width(px);
            let all = [0, 0, w, h];
            let mut work = Work::new(&bits, all, all, disc, Price::One);
            work.refresh();
            let (pw, ph) = (work.bits.width, work.bits.height);
            let mut seen = Packed::new(pw, ph, false);
            let mut depths = Vec::new();
            for phase in [true, false] {
                for g in groups(&work.thin[!phase as usize], None) {
                    let want = widening_old(&work, &g, phase, &mut seen, &mut depths);
                    let got = widening(&work, &g, phase, &mut scratch);
                    assert_eq!(got, want, "case {case}: {w}x{h} span {}", disc.span);
                    widened += 1;
                }
            }
            assert!(seen.data.iter().all(|&v| v == 0));
            assert!(scratch.seen.data.iter().all(|&v| v == 0));
            assert!(scratch.depths.iter().all(|&v| v == 0));
        }
        assert!(widened > 1000, "{widened} features widened");
    }

    /// Rounds after the first recompute thinness and depths only near the pixels changed since
    /// and keep the features nothing near changed: the same thin pixels, depths and features
    /// (pixels, widening) as a fresh grid's first round, on random blocky two-tones changed at
    /// random over several rounds, odd and even spans.
    #[test]
    fn refresh_near_changes_is_refresh_of_all() {
        let mut rng = Lcg(0x1dc_u64);
        let mut rnd = |n: u64| rng.below(n);
        let mut kept = 0;
        for case in 0..30 {
            let (w, h) = (1 + rnd(400) as u32, 1 + rnd(250) as u32);
            let (cell, dense) = (1 + rnd(5) as u32, rnd(11));
            let bits = blocky(w, h, cell, dense, &mut rnd);
            let disc = Disc::for_width([3.0, 4.0, 5.0, 6.0, 11.0, 12.0][case % 6]);
            let all = [0, 0, w, h];
            let mut work = Work::new(&bits, all, all, disc, Price::One);
            let feats = features(&mut work, true);
            work.keep(feats);
            for round in 0..4 {
                let p = work.pad as usize;
                for _ in 0..rnd(6) {
                    let (x0, y0, n) = (rnd(w as u64) as usize, rnd(h as u64) as usize, rnd(4));
                    for y in y0..(y0 + n as usize + 1).min(h as usize) {
                        for x in x0..(x0 + n as usize + 1).min(w as usize) {
                            let v = !work.bits.get(x + p, y + p);
                            work.flip(x + p, y + p, v);
                        }
                    }
                }
                let got = features(&mut work, true);
                let mut fresh = Work::new(&work.window(), all, all, disc, Price::One);
                let want = features(&mut fresh, true);
                let at = format!("case {case} round {round}: {w}x{h} span {}", disc.span);
                assert_eq!(work.thin, fresh.thin, "{at}");
                for i in 0..work.bits.width * work.bits.height {
                    if work.thin[0].at(i) || work.thin[1].at(i) {
                        assert_eq!(work.depth(i), fresh.depth(i), "{at}, pixel {i}");
                    }
                }
                assert_eq!(got.len(), want.len(), "{at}");
                for (g, f) in got.iter().zip(&want) {
                    assert_eq!((g.phase, &g.pixels), (f.phase, &f.pixels), "{at}");
                    assert_eq!(g.widen, f.widen, "{at}");
                }
                kept += got.iter().filter(|f| f.cost.is_some()).count();
                let mut got = got;
                // Mark them as priced, so a feature taken from the kept list shows it.
                got.iter_mut().for_each(|f| f.cost = Some((None, None)));
                work.keep(got);
            }
        }
        assert!(kept > 0, "some features were kept");
    }

    fn any_thin(bits: &BitGrid, px: f64) -> bool {
        thin_count(bits, px) != [0, 0]
    }

    #[test]
    fn disc_spans_the_smallest_odd_width() {
        assert_eq!(Disc::for_width(5.0).span, 5);
        assert_eq!(Disc::for_width(4.2).span, 5);
        assert_eq!(Disc::for_width(6.0).span, 6);
        assert_eq!(Disc::for_width(0.5).span, 1);
    }

    #[test]
    fn groups_are_the_8_connected_pieces() {
        let mut rng = Lcg(3);
        for (w, h, density) in [
            (70usize, 9usize, 6u64),
            (130, 20, 9),
            (64, 64, 3),
            (1, 5, 8),
        ] {
            let mut mask = Packed::new(w, h, false);
            let mut seeds = Packed::new(w, h, false);
            for y in 0..h {
                for x in 0..w {
                    let r = rng.next_u64();
                    mask.set(x, y, (r >> 60) < density);
                    seeds.set(x, y, (r >> 40) & 31 == 0);
                }
            }
            // Flood fill, pixel by pixel.
            let mut label = vec![usize::MAX; w * h];
            let mut want: Vec<Vec<usize>> = Vec::new();
            for i in 0..w * h {
                if !mask.at(i) || label[i] != usize::MAX {
                    continue;
                }
                let mut stack = vec![i];
                label[i] = want.len();
                let mut g = Vec::new();
                while let Some(j) = stack.pop() {
                    g.push(j);
                    let (x, y) = ((j % w) as i64, (j / w) as i64);
                    for (dx, dy) in (-1..=1).flat_map(|a| (-1..=1).map(move |b| (a, b))) {
                        let (nx, ny) = (x + dx, y + dy);
                        if nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64 {
                            let k = ny as usize * w + nx as usize;
                            if mask.at(k) && label[k] == usize::MAX {
                                label[k] = want.len();
                                stack.push(k);
                            }
                        }
                    }
                }
                g.sort_unstable();
                want.push(g);
            }
            assert_eq!(groups(&mask, None), want, "{w}x{h}");
            // Groups the caller has: no pixel of theirs is fresh and it knows their first pixel.
            let fresh_at = |i: usize| (i % w + 3 * (i / w)).is_multiple_of(11);
            let known = |first: usize| !first.is_multiple_of(3);
            let with_kept: Vec<Group> = want
                .iter()
                .map(|g| {
                    if !g.iter().any(|&i| fresh_at(i)) && known(g[0]) {
                        Group::Kept(g[0])
                    } else {
                        Group::Pixels(g.clone())
                    }
                })
                .collect();
            let fresh = |r: &Run| (r.x0..=r.x1).any(|x| fresh_at(r.y as usize * w + x as usize));
            assert_eq!(
                groups_where(&mask, None, fresh, known),
                with_kept,
                "{w}x{h} kept"
            );
            let seeded: Vec<Vec<usize>> = want
                .into_iter()
                .filter(|g| g.iter().any(|&i| seeds.at(i)))
                .collect();
            assert_eq!(groups(&mask, Some(&seeds)), seeded, "{w}x{h} seeded");
        }
    }

    #[test]
    fn checkerboards_end_with_nothing_thin_and_wide_ones_are_kept() {
        for cell in [1u32, 2, 3, 5, 8, 13] {
            let bits = BitGrid::from_fn(90, 70, |x, y| ((x / cell) + (y / cell)) % 2 == 0);
            let gray = Gray::new(90, 70, 0.5);
            let (out, _) = regularize(&bits, &gray, &cfg(6.0));
            assert!(!any_thin(&out, 6.0), "cell {cell}");
        }
        // Squares wider than the disc touching only at corners: the corners are thin (no width
        // there), the squares' middles stay.
        let bits = BitGrid::from_fn(80, 80, |x, y| ((x / 20) + (y / 20)) % 2 == 0);
        let (out, _) = regularize(&bits, &Gray::new(80, 80, 0.5), &cfg(6.0));
        assert!(!any_thin(&out, 6.0));
        for (x, y) in [(10, 10), (30, 30), (50, 10), (10, 50)] {
            assert_eq!(out.get(x, y), bits.get(x, y), "({x}, {y})");
        }
    }

    #[test]
    fn the_gray_picture_decides_between_removing_and_widening() {
        // A cut line 4 px wide (the disc is 6) across paper. Same bits, two pictures.
        let bits = BitGrid::from_fn(60, 40, |_, y| !(18..22).contains(&y));
        let line_width = |out: &BitGrid| (0..40).filter(|&y| !out.get(30, y)).count();
        // A black line on paper that is barely light: widening (into near-threshold paper) is
        // cheaper than erasing a plainly dark line.
        let mut gray = Gray::new(60, 40, 0.55);
        for y in 18..22 {
            for x in 0..60 {
                gray.set(x, y, 0.0);
            }
        }
        let (out, s) = regularize(&bits, &gray, &cfg(6.0));
        assert_eq!(line_width(&out), 6, "{s:?}");
        // A faint line (just under the threshold) on white paper: erasing it changes less.
        let mut gray = Gray::new(60, 40, 1.0);
        for y in 18..22 {
            for x in 0..60 {
                gray.set(x, y, 0.45);
            }
        }
        let (out, s) = regularize(&bits, &gray, &cfg(6.0));
        assert_eq!(line_width(&out), 0, "{s:?}");
    }

    #[test]
    fn noise_ends_with_nothing_thin() {
        // Pseudo-random noise: the hardest case for deciding; the monotone phase must finish it.
        let mut rng = Lcg(12345);
        let bits = BitGrid::from_fn(80, 60, |_, _| rng.below(2) == 1);
        let gray = Gray::new(80, 60, 0.5);
        let (out, stats) = regularize(&bits, &gray, &cfg(5.0));
        assert!(!any_thin(&out, 5.0), "{stats:?}");
    }
}
