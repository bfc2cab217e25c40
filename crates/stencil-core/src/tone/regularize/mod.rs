//! Design-rule regularisation: the two-tone clean-up that makes every web of material and every
//! hole of cut at least as wide as the material can hold, changing the picture as little as it can.
//!
//! ## The rule
//! A pixel is *wide enough* when some disc of the required width lying wholly in its phase covers
//! it (it survives the opening of its phase by the disc); otherwise it is *thin*. With no thin
//! pixel in either phase, no neck of material (web) or cut (hole) is narrower than the disc. The
//! disc holds the pixels whose centres lie within `span / 2` of its centre (`span` = the width
//! rounded up to whole pixels; centred on a pixel for odd spans, a corner for even), so a line
//! `span` pixels wide is wide enough and one pixel narrower is not. Outside the picture is
//! material: discs of material may lie partly outside, discs of cut may not, except that a cut
//! filling a corner of the picture keeps its square corner (see `Work::corner_caps`).
//!
//! ## Cost
//! The first round opens the whole grid on bit-packed rows (see `packed`), about a millisecond a
//! megapixel; a thin pixel's depth in its tone is searched only near thin pixels. Later rounds
//! recompute only the tiles near pixels changed since and keep untouched features from the round
//! before (see `Work::refresh`), with the same result as recomputing everything.
//!
//! ## Deciding
//! Thin pixels group into 8-connected features. Each is *removed* (its pixels take the other tone)
//! or *widened* (the other tone's pixels within the disc's radius of its ridge take its tone),
//! whichever flips less: a flipped pixel costs `0.1 + |gray − threshold|`.
//!
//! ## Why it ends
//! Rounds decide all features at once. For at most [`decide::FREE_ROUNDS`] rounds a pixel that has
//! changed is locked, so nothing oscillates. What is still thin is then settled monotonically:
//! thin holes filled, thin webs widened, both only adding material. Opening is increasing, so wide
//! material stays wide, and each round adds a pixel: the phase ends, in practice in a few rounds.

use rayon::prelude::*;

use crate::raster::{BitGrid, Gray};

mod decide;
mod disc;
mod features;
mod local;
mod packed;
mod settle;
mod stats;
mod work;

pub(crate) use local::{fill_sealed_pockets, settle_all, settle_near};
pub(crate) use stats::{RegularizeConfig, RegularizeStats};

use decide::decide;
use disc::Disc;
use settle::settle;
use work::{Price, Work};

/// Regularise `bits` (material = true) so that no web or hole is narrower than
/// `cfg.min_width_px`, deciding each thin feature by the gray picture. See the module comment.
pub(crate) fn regularize(
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

#[cfg(test)]
mod tests;
