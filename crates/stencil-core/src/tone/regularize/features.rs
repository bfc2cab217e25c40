//! The thin features of a round (see [`super`], "Deciding"): the 8-connected groups of thin
//! pixels, each with the pixels its widening would paint (the other tone within the disc of its
//! ridge), kept from the round before where nothing near them changed.

use rayon::prelude::*;

use super::packed::{self, Packed, BAND};
use super::work::{Feature, Work};
use crate::raster::{join_runs, push_runs, Run};

/// 8-connected groups of the set pixels of `mask` (those holding a pixel of `seeds`, when given):
/// a list of pixel indices per group, in raster order, the groups in the order of their first
/// pixel. (What [`groups_where`] gives when every group is fresh.)
#[cfg(test)]
pub(super) fn groups(mask: &Packed, seeds: Option<&Packed>) -> Vec<Vec<usize>> {
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
pub(super) enum Group {
    Pixels(Vec<usize>),
    Kept(usize),
}

/// 8-connected groups of the set pixels of `mask` (those holding a pixel of `seeds`, when given),
/// in the order of their first pixel. A group none of whose runs is `fresh` and whose first
/// pixel `known` accepts is [`Group::Kept`], by its first pixel: the caller has its pixels from
/// an earlier call, so they are not listed again. Every other group lists its pixel indices, in
/// raster order. By runs along rows joined to the runs they touch in the row above (union-find),
/// not pixel by pixel; freshness is asked once per run, not per pixel.
pub(super) fn groups_where(
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

/// [`widening`]'s buffers, one per thread, kept between features and rounds: a round widens
/// hundreds of features, most of a few dozen pixels, and each then allocates only its result.
#[derive(Default)]
pub(super) struct WidenScratch {
    /// The pixels listed so far, the grid's size; all clear between features.
    pub(super) seen: Packed,
    /// The feature's pixels' depths on a grid one pixel wider than the grid on every side (so
    /// a pixel's eight neighbours are there without bounds checks), 0 at every other pixel; all
    /// 0 between features.
    pub(super) depths: Vec<u16>,
    /// The feature's pixels: coordinates, depth and centre (see [`Work::depth_xy`]).
    pub(super) pixels: Vec<(u32, u32, u16, u8)>,
    /// The widening being listed.
    pub(super) out: Vec<usize>,
}

/// The pixels of the other tone within the disc of each ridge pixel of a thin feature: its
/// pixels whose depth is at least each of their 8-neighbours' in the feature. The disc is
/// centred on the pixel (odd span) or on its deepest corner (even span), so once painted that
/// centre is a valid one and covers the ridge pixel. Listed ridge pixel by ridge pixel in the
/// feature's order, each disc row by row, left to right (the order its price is summed in).
pub(super) fn widening(
    work: &Work,
    feature: &[usize],
    phase: bool,
    scratch: &mut WidenScratch,
) -> Vec<usize> {
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
    // Each pixel's depth once (an even span's is the largest of four corners'), where the ridge
    // test reads each up to nine times. A neighbour outside the feature reads 0, which no depth
    // is (every depth is at least 1).
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

/// Every thin feature of both tones, with its widening. A feature with no pixel in a tile the
/// refresh recomputed is taken as it was in the last round ([`Work::kept`]). Thin holes' widenings
/// are listed only when `widen_holes` (the monotone phase only fills holes).
pub(super) fn features(work: &mut Work, widen_holes: bool) -> Vec<Feature> {
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

impl Work<'_> {
    /// Keep a round's features (as [`features`] gave them) for the next.
    pub(super) fn keep(&mut self, feats: Vec<Feature>) {
        let (material, cut) = feats.into_iter().partition(|f| f.phase);
        self.kept = [material, cut];
    }
}
