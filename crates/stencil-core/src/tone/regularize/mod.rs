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
//! [`decide::FREE_ROUNDS`] rounds) a pixel that has changed tone is locked: a choice that would change it
//! back is not available, so no pixel flips twice and nothing oscillates. What is still thin after
//! that is settled by a second, *monotone* phase: thin holes are filled and thin webs widened, both
//! of which only add material. Opening is increasing, so a material pixel that is wide enough stays
//! so when material is added; and each round adds at least one pixel (a thin web's ridge pixel
//! farthest from the cut is thin, so its disc still holds a cut pixel, which widening fills; a thin
//! hole's pixels are filled). Material grows strictly every round, so the second phase ends after at
//! most as many rounds as there are cut pixels, with nothing thin left; in practice in a few.

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
