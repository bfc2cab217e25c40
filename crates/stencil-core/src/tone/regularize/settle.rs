//! The regularisation's monotone phase (see [`super`], "Why it ends"): thin holes filled and thin
//! webs widened, both only adding material, until nothing that may change is thin.

use super::features::features;
use super::stats::RegularizeStats;
use super::work::Work;

/// The monotone phase: fill thin holes and widen thin webs (both only add material) until nothing
/// that may change is thin. Ends: see the module comment.
pub(super) fn settle(work: &mut Work, stats: &mut RegularizeStats) {
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
