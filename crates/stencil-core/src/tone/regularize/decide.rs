//! The regularisation's cost-based phase (see [`super`], "Deciding" and "Why it ends"): each
//! round, every thin feature removed or widened, whichever the gray picture prices lower, no
//! pixel changing back.

use rayon::prelude::*;

use super::features::features;
use super::packed::{self, Packed};
use super::stats::RegularizeStats;
use super::work::{Feature, Work};

/// Rounds of cost-based deciding before the monotone phase settles what is left.
pub(super) const FREE_ROUNDS: usize = 4;

/// The cost-based phase: each round, every thin feature is removed or widened, whichever costs
/// less; a pixel that changed may not change back; at most [`FREE_ROUNDS`] rounds.
pub(super) fn decide(work: &mut Work, stats: &mut RegularizeStats) {
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
