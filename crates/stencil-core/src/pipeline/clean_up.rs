//! The clean-up before the islands (the paper's Stage 1 topological filter; the design-rule
//! regularisation to the material's smallest feature is ours), and `--threshold auto`'s search
//! for the level whose cleaned-up two-tone looks most like the picture.

use std::borrow::Cow;
use std::sync::Mutex;

use rayon::prelude::*;

use crate::plan::CleanParams;
use crate::raster::{BitGrid, Gray, TwoTone};
use crate::tone::filter::{self, FilterConfig, FilterStats};
use crate::tone::regularize::{regularize, RegularizeConfig};
use crate::tone::{self, LevelChoice, Likeness};

/// The two-tone after the clean-up, and what the clean-up measured.
#[derive(Clone, Debug)]
pub struct Cleaned {
    /// The picture thresholded, before the clean-up (what fidelity is measured against).
    pub picture: BitGrid,
    /// The two-tone after the clean-up.
    pub twotone: TwoTone,
    /// The threshold level, 8-bit.
    pub level: u8,
    /// What the morphological filter changed.
    pub(crate) filter_stats: FilterStats,
    /// What the regularisation changed, when it ran.
    pub(crate) reg_stats: Option<crate::tone::regularize::RegularizeStats>,
    /// How much the cleaned two-tone looks like the gray picture ([`tone::likeness()`]).
    pub likeness: f64,
    /// How `--threshold auto` chose the level.
    pub choice: Option<LevelChoice>,
}

/// A two-tone after the clean-up, and what the filter and the regularisation changed.
type Clean = (
    BitGrid,
    FilterStats,
    Option<crate::tone::regularize::RegularizeStats>,
);

/// The clean-up of `bits` (the gray thresholded at `level`): the regularisation, or the filter.
fn clean_bits(bits: &BitGrid, gray: &Gray, level: u8, p: &CleanParams) -> Clean {
    match p.regularize_px {
        Some(min_width_px) => {
            let rcfg = RegularizeConfig {
                min_width_px,
                threshold: level as f32 / 255.0,
                invert: p.invert,
            };
            let (bits, stats) = regularize(bits, gray, &rcfg);
            (bits, FilterStats::default(), Some(stats))
        }
        None => {
            let (bits, stats) = filter::filter(bits, &p.filter);
            (bits, stats, None)
        }
    }
}

/// A level measured at full size, its likeness, its thresholded gray and clean-up.
type Measured = ((u8, f64), BitGrid, Clean);

/// Above this many working pixels, `--threshold auto` searches on the gray box-averaged to about
/// this size (the clean-up's widths scaled alike), then measures the finalists at full size.
const AUTO_SEARCH_PIXELS: u64 = 1_000_000;

/// `--threshold auto`: the level whose cleaned-up two-tone is likeliest ([`tone::likeness`]).
/// Every eighth level from 16 to 240, 128 and Otsu's level are tried through the clean-up, then
/// the levels within 6 of the best in steps of 2. On a picture above [`AUTO_SEARCH_PIXELS`] the
/// search runs on a reduced copy and the two best, 128 and Otsu's level are measured again at
/// full size; the full-size measure decides. 128 and Otsu's level are always among those
/// measured, so the level chosen is at least as likely as either by the same measure. Also the
/// gray thresholded at the level chosen and cleaned up, as made when it was measured.
fn choose_level(gray: &Gray, look: &Likeness, p: &CleanParams) -> (LevelChoice, BitGrid, Clean) {
    let otsu = tone::otsu_level(gray);
    let pixels = gray.width as u64 * gray.height as u64;
    let d = if pixels > AUTO_SEARCH_PIXELS {
        ((pixels as f64 / AUTO_SEARCH_PIXELS as f64).sqrt().ceil()) as u32
    } else {
        1
    };
    let (small, small_look, sp) = if d > 1 {
        let g = crate::raster::box_average(gray.width, gray.height, d, |i| gray.data[i]);
        let l = tone::Likeness::of(&g);
        let sp = CleanParams {
            regularize_px: p.regularize_px.map(|w| (w / d as f64).max(1.0)),
            filter: FilterConfig {
                radius: p.filter.radius.div_ceil(d),
                min_speck_px: (p.filter.min_speck_px / (d * d) as usize).max(1),
                ..p.filter
            },
            ..*p
        };
        (Cow::Owned(g), Cow::Owned(l), sp)
    } else {
        (Cow::Borrowed(gray), Cow::Borrowed(look), *p)
    };
    let cleaned_at = |g: &Gray, cp: &CleanParams, level: u8| {
        let raw = tone::bits_at(g, level, cp.invert);
        (clean_bits(&raw, g, level, cp), raw)
    };
    let measure = |g: &Gray, look: &Likeness, cp: &CleanParams, level: u8| {
        let (clean, raw) = cleaned_at(g, cp, level);
        (look.of_bits(&clean.0, cp.invert), raw, clean)
    };
    // The choice's order: likelier, then the lower level.
    let order = |a: &(u8, f64), b: &(u8, f64)| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0));
    // The first in that order of the levels measured at full size so far, with its clean-up.
    // Levels differ, so no two are equal in that order: the first is the same whatever order
    // the levels are measured in, and they are measured on threads, a level each (the clean-up
    // and the measure of one level are sequences of short parallel steps, which on their own
    // leave the threads waiting between steps).
    let kept: Mutex<Option<Measured>> = Mutex::new(None);
    let keep = |t: (u8, f64), raw: BitGrid, clean: Clean| {
        let mut kept = kept.lock().unwrap_or_else(|e| e.into_inner());
        if kept.as_ref().is_none_or(|k| order(&t, &k.0).is_gt()) {
            *kept = Some((t, raw, clean));
        }
    };
    // The levels of `levels` not tried yet, first occurrences in order, each measured; their
    // results appended to `tried` in that order.
    let measure_new =
        |levels: &[u8], tried: &mut Vec<(u8, f64)>, at: &(dyn Fn(u8) -> f64 + Sync)| {
            let mut new: Vec<u8> = Vec::new();
            for &l in levels {
                if !tried.iter().any(|t| t.0 == l) && !new.contains(&l) {
                    new.push(l);
                }
            }
            let likes: Vec<f64> = new.par_iter().map(|&l| at(l)).collect();
            tried.extend(new.into_iter().zip(likes));
        };
    let search = |l: u8| {
        let (like, raw, clean) = measure(&small, &small_look, &sp, l);
        if d == 1 {
            keep((l, like), raw, clean);
        }
        like
    };
    let mut tried: Vec<(u8, f64)> = Vec::new();
    let mut levels: Vec<u8> = (16..=240).step_by(8).collect();
    levels.extend([128, otsu]);
    measure_new(&levels, &mut tried, &search);
    let best = |t: &[(u8, f64)]| t.iter().copied().max_by(order).unwrap_or((128, 0.0));
    let b = best(&tried).0;
    let near: Vec<u8> = [-6i32, -4, -2, 2, 4, 6]
        .iter()
        .map(|k| (b as i32 + k).clamp(1, 255) as u8)
        .collect();
    measure_new(&near, &mut tried, &search);
    let mut at_full = tried.clone();
    if d > 1 {
        let mut order = tried.clone();
        order.sort_by(|a, b| b.1.total_cmp(&a.1));
        let mut finalists: Vec<u8> = order.iter().take(2).map(|t| t.0).collect();
        finalists.extend([128, otsu]);
        at_full = Vec::new();
        let full = |l: u8| {
            let (like, raw, clean) = measure(gray, look, p, l);
            keep((l, like), raw, clean);
            like
        };
        measure_new(&finalists, &mut at_full, &full);
        tried.extend(at_full.iter().copied());
    }
    let (level, like) = best(&at_full);
    let at = |l: u8| at_full.iter().find(|t| t.0 == l).map_or(0.0, |t| t.1);
    // Kept is the best of `at_full` in the same order, so at the level chosen.
    let kept = kept.into_inner().unwrap_or_else(|e| e.into_inner());
    let (clean, raw) = match kept {
        Some(((l, _), raw, clean)) if l == level => (clean, raw),
        _ => cleaned_at(gray, p, level),
    };
    (
        LevelChoice {
            level,
            likeness: like,
            likeness_128: at(128),
            otsu_level: otsu,
            likeness_otsu: at(otsu),
            tried,
            uneven_paper: tone::uneven_page(gray),
        },
        raw,
        clean,
    )
}

/// Stage 4: the clean-up the material needs: the design-rule regularisation to its smallest
/// feature, or the morphological filter with an explicit radius. With `--threshold auto` (a
/// picture), the level is chosen here, judged on the cleaned-up result (`choose_level`), and
/// `raw` is thresholded again at it. `look` is [`look`](super::two_tone::look) of `raw`.
pub fn clean(raw: TwoTone, level: u8, p: &CleanParams, look: &Likeness) -> Cleaned {
    let mut cleaned = clean_unmeasured(raw, level, p, look);
    cleaned.likeness = measure(&cleaned, p, look);
    cleaned
}

/// [`clean`] but for the likeness of its result, left NaN: [`measure`] gives it. Nothing after
/// the clean-up reads the likeness (the report only shows it), so the studio measures it beside
/// the walks that follow rather than before them.
pub fn clean_unmeasured(raw: TwoTone, level: u8, p: &CleanParams, look: &Likeness) -> Cleaned {
    let (picture, level, choice, clean) = if p.auto {
        let (choice, picture, clean) = choose_level(&raw.gray, look, p);
        (picture, choice.level, Some(choice), Some(clean))
    } else {
        (raw.bits, level, None, None)
    };
    let (bits, filter_stats, reg_stats) =
        clean.unwrap_or_else(|| clean_bits(&picture, &raw.gray, level, p));
    Cleaned {
        picture,
        twotone: TwoTone {
            bits,
            gray: raw.gray,
        },
        level,
        filter_stats,
        reg_stats,
        likeness: f64::NAN,
        choice,
    }
}

/// The likeness of a [`clean_unmeasured`] result (`look` is the one it was cleaned with): what
/// [`clean`] puts in [`Cleaned::likeness`].
pub fn measure(cleaned: &Cleaned, p: &CleanParams, look: &Likeness) -> f64 {
    look.of_bits(&cleaned.twotone.bits, p.invert)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Lcg;

    /// With `--threshold auto` the clean-up of the level chosen comes from the search, not made
    /// again: the same picture, two-tone and statistics as thresholding and cleaning up the gray
    /// at that level afterwards, as it was done before (regularisation and filter, both tones).
    #[test]
    fn the_level_chosen_is_cleaned_up_as_if_again() {
        let mut rng = Lcg(5);
        let (w, h) = (90, 70);
        let mut gray = Gray::new(w, h, 0.0);
        for (i, v) in gray.data.iter_mut().enumerate() {
            let (x, y) = ((i as u32 % w) as f32, (i as u32 / w) as f32);
            *v =
                ((x / 7.0).sin() * (y / 5.0).cos() * 0.35 + 0.5 + rng.unit() as f32 * 0.3).min(1.0);
        }
        let look = Likeness::of(&gray);
        for (regularize_px, invert) in [(Some(2.5), false), (Some(3.0), true), (None, false)] {
            let p = CleanParams {
                filter: FilterConfig::default(),
                regularize_px,
                invert,
                auto: true,
            };
            let raw = TwoTone {
                bits: tone::bits_at(&gray, 128, invert),
                gray: std::sync::Arc::new(gray.clone()),
            };
            let c = clean_unmeasured(raw, 128, &p, &look);
            let picture = tone::bits_at(&gray, c.level, invert);
            let (bits, filter_stats, reg_stats) = clean_bits(&picture, &gray, c.level, &p);
            assert_eq!(c.picture, picture, "{regularize_px:?} {invert}");
            assert_eq!(c.twotone.bits, bits, "{regularize_px:?} {invert}");
            assert_eq!((c.filter_stats, c.reg_stats), (filter_stats, reg_stats));
            let choice = c.choice.as_ref().expect("auto chose");
            assert_eq!(choice.level, c.level);
            assert_eq!(measure(&c, &p, &look), choice.likeness);
        }
    }
}
