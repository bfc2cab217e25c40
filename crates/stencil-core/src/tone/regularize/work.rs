//! The regularisation's working grid (see [`super`], "Cost"): a padded window of the picture,
//! what may change there and at what price, both tones' thin pixels and how deep each lies in
//! its tone, kept up to date tile by tile near the pixels a round changed.

use super::disc::{paint, ring, ring_from, Disc, CORNERS};
use super::packed::{self, thin_both, thin_in_tiles, tiles_near, Packed, ThinScratch, BAND};
use crate::raster::{BitGrid, Gray};

/// Pixel index → `(x, y)` for rows `width` long, by a multiply rather than a division when
/// both fit in 32 bits: with `c = ⌈2⁶⁴ / width⌉`, `⌊c · i / 2⁶⁴⌋ = ⌊i / width⌋` for every 32-bit
/// `i` and `width` (Lemire, Kaser and Kurz, "Faster remainder by direct computation", 2019).
/// The lists of pixels a round prices and flips are turned into coordinates once per pixel, and
/// a 64-bit division costs several times the multiply.
#[derive(Clone, Copy, Debug)]
pub(super) struct Rows {
    pub(super) width: usize,
    /// `⌈2⁶⁴ / width⌉`, or 0 when the multiply does not apply (a width of 1, or indices past
    /// 32 bits), and then the index is divided.
    pub(super) c: u64,
}

impl Rows {
    pub(super) fn new(width: usize, height: usize) -> Rows {
        let fits = width >= 2 && (width as u64).saturating_mul(height as u64) <= u32::MAX as u64;
        Rows {
            width,
            c: if fits { u64::MAX / width as u64 + 1 } else { 0 },
        }
    }

    pub(super) fn xy(&self, i: usize) -> (usize, usize) {
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
pub(super) struct Work<'a> {
    /// Material, bit-packed; past the padded grid lies material too.
    pub(super) bits: Packed,
    /// Its pixel indices to coordinates.
    pub(super) rows: Rows,
    /// The price of flipping a pixel, in picture coordinates.
    pub(super) price: Price<'a>,
    /// The pixels that may change, `[x0, y0, x1, y1)` in padded coordinates, and of those only
    /// the ones set in `allowed` when there is one.
    pub(super) core: [usize; 4],
    pub(super) allowed: Option<Packed>,
    /// When set, only thin features holding one of these pixels are resolved.
    pub(super) seeds: Option<Packed>,
    /// The picture coordinates of padded pixel `(pad, pad)`.
    pub(super) origin: (u32, u32),
    /// Per pixel: changed tone in the cost-based phase (may not change back there).
    pub(super) locked: Packed,
    pub(super) pad: u32,
    /// Top-left corners (padded coordinates) of the span × span blocks at the picture's own
    /// corners that lie in this window (see [`Work::corner_caps`]).
    pub(super) corners: Vec<(u32, u32)>,
    pub(super) disc: Disc,
    pub(super) ring: Vec<(i64, i64, f32)>,
    /// The ring as offsets of bit index (`dy · stride · 64 + dx`) with the depth each gives, and
    /// how far it reaches: for lattice points at least that far inside the grid.
    pub(super) ring_bits: Vec<(i64, u16)>,
    pub(super) ring_reach: i64,
    /// Per depth of a neighbouring lattice point of the same tone (its [`Work::depth2`] value,
    /// the last entry for `u16::MAX`), the first ring entry a point's search need probe (see
    /// [`ring_from`]).
    pub(super) ring_from: Vec<usize>,
    /// Per candidate centre of a widening (the pixel itself, or its corner `(ox, oy)` in the
    /// order [`Work::depth_xy`] tries them), the rows of its disc (see [`paint`]).
    pub(super) paint: Vec<Vec<(i64, i64, i64)>>,
    /// The thin pixels of material and of cut, as of the last [`Work::refresh`].
    pub(super) thin: [Packed; 2],
    /// Per centre-lattice point next to a thin pixel, as of the last refresh: how deep it lies
    /// in its tone, as twice its squared distance to the nearest pixel of another tone (a corner
    /// between pixels of both tones: 1), or `u16::MAX` past the disc's radius. Points next to no
    /// thin pixel hold stale values: only thin pixels' centres are read.
    pub(super) depth2: Vec<u16>,
    /// Kept between rounds: [`thin`]'s buffers per tone, and the pixels a round changed.
    pub(super) thin_scratch: [ThinScratch; 2],
    pub(super) changed: Packed,
    /// The pixels changed since the last refresh ([`Work::flip`]), and whether there was one:
    /// after the first, a refresh recomputes thinness and depths only near these.
    pub(super) since: Packed,
    pub(super) refreshed: bool,
    /// The tiles ([`BAND`] rows by a word) within reach of the changes the last refresh saw;
    /// `None` after the first refresh, which had no earlier one to keep. What lies outside them
    /// is as it was the refresh before.
    pub(super) dirty: Option<Vec<bool>>,
    /// The last round's features per tone (material, cut), in
    /// [`super::features::groups_where`] order: a feature that lies wholly outside the tiles a
    /// refresh recomputed is the same feature, with the same widening and cost, and is taken
    /// from here rather than worked out again.
    pub(super) kept: [Vec<Feature>; 2],
}

/// A cut that fills a corner of the picture has a square corner against the sheet's margin,
/// which no round disc covers, yet it is no neck (the width check does not count cutting across a
/// corner). Where the span × span block at a picture corner (`corners`, see [`Work::corners`]) is
/// all cut in `bits`, its pixels are not thin in `mask`.
pub(super) fn corner_caps(bits: &Packed, corners: &[(u32, u32)], disc: Disc, mask: &mut Packed) {
    let span = disc.span as usize;
    for &(cx, cy) in corners {
        let (cx, cy) = (cx as usize, cy as usize);
        let block = || (cy..cy + span).flat_map(move |y| (cx..cx + span).map(move |x| (x, y)));
        if block().all(|(x, y)| !bits.get(x, y)) {
            block().for_each(|(x, y)| mask.set(x, y, false));
        }
    }
}

impl<'a> Work<'a> {
    /// The window `x0..x1 × y0..y1` of `bits`, padded; pixels in `core` (window coordinates,
    /// `[x0, y0, x1, y1)`) may change, priced by `price` (see [`Price`]).
    pub(super) fn new(
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
    pub(super) fn flip(&mut self, x: usize, y: usize, v: bool) {
        self.bits.set(x, y, v);
        self.since.set(x, y, true);
    }

    /// How far a change reaches: a pixel's thinness depends on the pixels within `2 · reach + 1`
    /// of it, a lattice point's depth on those within the ring's reach (and on whether a pixel
    /// next to it is thin); a pixel farther than this from every change keeps both.
    pub(super) fn influence(&self) -> usize {
        (2 * self.disc.reach() as usize + 2).max(self.ring_reach as usize + 1)
    }

    /// Both tones' thin pixels and the depths next to them: over the whole grid the first time,
    /// then only in the tiles within [`Work::influence`] (and a pixel more) of a pixel changed
    /// since; the rest is as it was. Either way the same as recomputing the whole grid.
    pub(super) fn refresh(&mut self) {
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
    pub(super) fn refresh_depths(&mut self) {
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
    pub(super) fn lattice_depth(&self, cx: i64, cy: i64) -> u16 {
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
    pub(super) fn lattice_depth_from(&self, cx: i64, cy: i64, phase: bool, from: usize) -> u16 {
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
    pub(super) fn ring_start(&self, d: u16) -> usize {
        if d == u16::MAX {
            *self.ring_from.last().expect("the entry past the radius")
        } else {
            self.ring_from.get(d as usize).copied().unwrap_or(0)
        }
    }

    /// The depth of a lattice point probing through the bounds-checked path only.
    #[cfg(test)]
    pub(super) fn lattice_depth_checked(&self, cx: i64, cy: i64) -> u16 {
        match self.lattice_phase(cx, cy) {
            Ok(phase) => self.ring_depth_checked(cx, cy, phase, 0),
            Err(mixed) => mixed,
        }
    }

    /// The tone of pixel `(x, y)`; past the grid, material.
    pub(super) fn tone_at(&self, x: i64, y: i64) -> bool {
        x < 0
            || y < 0
            || x >= self.bits.width as i64
            || y >= self.bits.height as i64
            || self.bits.get(x as usize, y as usize)
    }

    /// The tone lattice point `(cx, cy)` lies in: its pixel's, or for an even span its four
    /// pixels' when they agree (`Err(1)`, its depth, when they do not).
    pub(super) fn lattice_phase(&self, cx: i64, cy: i64) -> Result<bool, u16> {
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
    pub(super) fn ring_depth_checked(&self, cx: i64, cy: i64, phase: bool, from: usize) -> u16 {
        for &(dx, dy, d) in &self.ring[from..] {
            if self.tone_at(cx + dx, cy + dy) != phase {
                return (2.0 * d) as u16;
            }
        }
        u16::MAX
    }

    pub(super) fn changeable(&self, i: usize) -> bool {
        let (x, y) = self.rows.xy(i);
        self.changeable_at(x, y)
    }

    pub(super) fn changeable_at(&self, x: usize, y: usize) -> bool {
        x >= self.core[0]
            && y >= self.core[1]
            && x < self.core[2]
            && y < self.core[3]
            && self.allowed.as_ref().is_none_or(|a| a.get(x, y))
    }

    /// The price of flipping pixel `(x, y)`, which must be changeable.
    pub(super) fn price_at(&self, x: usize, y: usize) -> f32 {
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
    pub(super) fn depth(&self, i: usize) -> (u16, usize) {
        if !self.disc.on_corners() {
            return (self.depth2[i], 0);
        }
        let (x, y) = self.rows.xy(i);
        self.depth_xy(x, y)
    }

    /// How deep thin pixel `(x, y)` lies in its tone (see [`Work::depth2`]): the largest depth
    /// over its candidate centres (itself, or its four corners for an even span), and which of
    /// them (an index into [`Work::paint`]).
    pub(super) fn depth_xy(&self, x: usize, y: usize) -> (u16, usize) {
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
    pub(super) fn window(&self) -> BitGrid {
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

/// One thin feature and what each way of resolving it would flip.
pub(super) struct Feature {
    /// The tone of its pixels.
    pub(super) phase: bool,
    pub(super) pixels: Vec<usize>,
    /// The other tone's pixels a widening turns to `phase`.
    pub(super) widen: Vec<usize>,
    /// What removing and widening it cost in the cost-based phase, once worked out (`None`
    /// inside: not available). Nothing either reads changes while the feature stays the same.
    pub(super) cost: Option<(Option<f32>, Option<f32>)>,
}

impl Feature {
    pub(super) fn empty(phase: bool) -> Feature {
        Feature {
            phase,
            pixels: Vec::new(),
            widen: Vec::new(),
            cost: None,
        }
    }
}

/// The price of flipping a pixel: `0.1 + |gray − threshold|` of its picture pixel (the gray
/// and the threshold), or 1 for every pixel. A plain value rather than a boxed closure, so the
/// per-pixel sums inline it.
#[derive(Clone, Copy)]
pub(super) enum Price<'a> {
    Gray(&'a Gray, f32),
    One,
}
