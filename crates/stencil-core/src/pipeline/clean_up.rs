//! The clean-up before the islands (the paper's Stage 1 topological filter; the design-rule
//! regularisation to the material's smallest feature is ours), and `--threshold auto`'s search
//! for the level whose cleaned-up two-tone looks most like the picture.

use std::borrow::Cow;

use crate::plan::CleanParams;
use crate::raster::{BitGrid, Gray, TwoTone};
use crate::tone;
use crate::tone::filter::{self, FilterConfig, FilterStats};
use crate::tone::regularize::{regularize, RegularizeConfig};

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
    pub choice: Option<tone::LevelChoice>,
}

/// The clean-up of `bits` (the gray thresholded at `level`): the regularisation, or the filter.
fn clean_bits(
    bits: &BitGrid,
    gray: &Gray,
    level: u8,
    p: &CleanParams,
) -> (
    BitGrid,
    FilterStats,
    Option<crate::tone::regularize::RegularizeStats>,
) {
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

/// Above this many working pixels, `--threshold auto` searches on the gray box-averaged to about
/// this size (the clean-up's widths scaled alike), then measures the finalists at full size.
const AUTO_SEARCH_PIXELS: u64 = 1_000_000;

/// `--threshold auto`: the level whose cleaned-up two-tone is likeliest ([`tone::likeness`]).
/// Every eighth level from 16 to 240, 128 and Otsu's level are tried through the clean-up, then
/// the levels within 6 of the best in steps of 2. On a picture above [`AUTO_SEARCH_PIXELS`] the
/// search runs on a reduced copy and the two best, 128 and Otsu's level are measured again at
/// full size; the full-size measure decides. 128 and Otsu's level are always among those
/// measured, so the level chosen is at least as likely as either by the same measure.
fn choose_level(gray: &Gray, look: &tone::Likeness, p: &CleanParams) -> (u8, tone::LevelChoice) {
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
    let measure = |g: &Gray, look: &tone::Likeness, cp: &CleanParams, level: u8| -> f64 {
        let raw = tone::bits_at(g, level, cp.invert);
        let (bits, _, _) = clean_bits(&raw, g, level, cp);
        look.of_bits(&bits, cp.invert)
    };
    let mut tried: Vec<(u8, f64)> = Vec::new();
    let mut levels: Vec<u8> = (16..=240).step_by(8).collect();
    levels.extend([128, otsu]);
    let try_all = |levels: &[u8], tried: &mut Vec<(u8, f64)>| {
        for &l in levels {
            if !tried.iter().any(|t| t.0 == l) {
                tried.push((l, measure(&small, &small_look, &sp, l)));
            }
        }
    };
    try_all(&levels, &mut tried);
    let best = |t: &[(u8, f64)]| {
        t.iter()
            .copied()
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
            .unwrap_or((128, 0.0))
    };
    let b = best(&tried).0;
    let near: Vec<u8> = [-6i32, -4, -2, 2, 4, 6]
        .iter()
        .map(|k| (b as i32 + k).clamp(1, 255) as u8)
        .collect();
    try_all(&near, &mut tried);
    let mut at_full = tried.clone();
    if d > 1 {
        let mut order = tried.clone();
        order.sort_by(|a, b| b.1.total_cmp(&a.1));
        let mut finalists: Vec<u8> = order.iter().take(2).map(|t| t.0).collect();
        finalists.extend([128, otsu]);
        finalists.dedup();
        at_full = Vec::new();
        for l in finalists {
            if !at_full.iter().any(|t: &(u8, f64)| t.0 == l) {
                at_full.push((l, measure(gray, look, p, l)));
                tried.push((l, at_full.last().map_or(0.0, |t| t.1)));
            }
        }
    }
    let (level, like) = best(&at_full);
    let at = |l: u8| at_full.iter().find(|t| t.0 == l).map_or(0.0, |t| t.1);
    (
        level,
        tone::LevelChoice {
            level,
            likeness: like,
            likeness_128: at(128),
            otsu_level: otsu,
            likeness_otsu: at(otsu),
            tried,
            uneven_paper: tone::uneven_page(gray),
        },
    )
}

/// Stage 4: the clean-up the material needs: the design-rule regularisation to its smallest
/// feature, or the morphological filter with an explicit radius. With `--threshold auto` (a
/// picture), the level is chosen here, judged on the cleaned-up result (`choose_level`), and
/// `raw` is thresholded again at it. `look` is [`look`](super::two_tone::look) of `raw`.
pub fn clean(raw: TwoTone, level: u8, p: &CleanParams, look: &tone::Likeness) -> Cleaned {
    let mut cleaned = clean_unmeasured(raw, level, p, look);
    cleaned.likeness = measure(&cleaned, p, look);
    cleaned
}

/// [`clean`] but for the likeness of its result, left NaN: [`measure`] gives it. Nothing after
/// the clean-up reads the likeness (the report only shows it), so the studio measures it beside
/// the walks that follow rather than before them.
pub fn clean_unmeasured(
    raw: TwoTone,
    level: u8,
    p: &CleanParams,
    look: &tone::Likeness,
) -> Cleaned {
    let (picture, level, choice) = if p.auto {
        let (l, choice) = choose_level(&raw.gray, look, p);
        (tone::bits_at(&raw.gray, l, p.invert), l, Some(choice))
    } else {
        (raw.bits, level, None)
    };
    let (bits, filter_stats, reg_stats) = clean_bits(&picture, &raw.gray, level, p);
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
pub fn measure(cleaned: &Cleaned, p: &CleanParams, look: &tone::Likeness) -> f64 {
    look.of_bits(&cleaned.twotone.bits, p.invert)
}
