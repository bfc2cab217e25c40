//! A picture posterised into tones, one per layer plus the surface (see [`super`], "Tones"):
//! multi-level Otsu on the luma, the levels given, or k-means for a colour picture.
//!
//! Each layer is a sheet to cut, lay and spray, so each must change the picture noticeably
//! ([`worth_a_sheet`]): where the tones chosen for the layers asked for have one that does not,
//! the picture has fewer tones than asked, and it is posterised again into one layer fewer, until
//! every tone shows (the levels or the colours given are the person's choice, and kept).

use serde::Serialize;

use super::config::LayersConfig;
use super::kmeans::kmeans_tones;
use super::lab::{dist2, lab, srgb};
use crate::error::LayersError;
use crate::limits::MAX_LAYERS;
use crate::raster::Gray;
use crate::tone::is_light;

/// How the picture was posterised.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Multi-level Otsu on the luma.
    MultiOtsu,
    /// The levels the person gave, on the luma.
    LevelsGiven,
    /// k-means in CIELAB.
    KmeansLab,
    /// Multi-level Otsu on the luma of a colour picture, each class its mean colour: where
    /// k-means gave two tones too alike for a sheet each.
    LightnessClasses,
}

/// The picture posterised: what each layer is cut from and painted with.
#[derive(Clone, Debug)]
pub struct Tones {
    /// What the layers are thresholded from: the luma, or each pixel's cluster's L* (colour).
    pub gray: Gray,
    /// The picture's own luma (what the composite's likeness is measured against).
    pub luma: Gray,
    /// Per layer, light to dark: layer k cuts where `gray` is below `levels[k-1]` (descending).
    pub levels: Vec<u8>,
    /// The surface's colour, then each layer's paint (sRGB).
    pub colors: Vec<[u8; 3]>,
    /// How it was posterised.
    pub method: Method,
    /// The layers asked for, when the picture has fewer tones worth a sheet and fewer were made
    /// (see [`worth_a_sheet`]); `None` when every layer asked for is there.
    pub asked: Option<u32>,
}

/// The least step in lightness (CIE L*) between a layer's paint and the tone under it that shows
/// in the painted picture (a person sees it at a glance in spray paint; a mid-tone photo's
/// neighbouring tones are 9 to 17 apart), unless the two differ as clearly in colour
/// ([`MIN_STEP_DELTA_E`]).
pub const MIN_STEP_L: f32 = 6.0;

/// The least colour difference (CIE76 ΔE) between a layer's paint and the tone under it that
/// shows in the painted picture when their lightness is close: two paints this far apart are
/// different colours even at the same lightness (a near-black navy and black, 27 apart with
/// 4 of lightness, are not).
pub const MIN_STEP_DELTA_E: f32 = 30.0;

/// The least share of the picture, %, a layer's tone must paint last to show.
pub const MIN_TONE_PCT: f64 = 0.5;

/// Whether every layer of `tones` changes the painted picture noticeably: its paint at least
/// [`MIN_STEP_L`] darker than the tone under it or [`MIN_STEP_DELTA_E`] from it, and its tone
/// painted last on at least [`MIN_TONE_PCT`] % of the picture.
pub fn worth_a_sheet(tones: &Tones) -> bool {
    let labs: Vec<[f32; 3]> = tones
        .colors
        .iter()
        .map(|c| lab(c.map(|v| v as f32 / 255.0)))
        .collect();
    let mut count = vec![0usize; tones.colors.len()];
    let last = count.len() - 1;
    for &v in &tones.gray.data {
        count[tones.tone_of(v).min(last)] += 1;
    }
    let total = tones.gray.data.len().max(1) as f64;
    (1..labs.len()).all(|k| {
        let shows = labs[k - 1][0] - labs[k][0] >= MIN_STEP_L
            || dist2(labs[k - 1], labs[k]) >= MIN_STEP_DELTA_E * MIN_STEP_DELTA_E;
        shows && count[k] as f64 * 100.0 / total >= MIN_TONE_PCT
    })
}

impl Tones {
    /// The tone of a gray value: how many layers paint it (0 = the surface).
    pub fn tone_of(&self, v: f32) -> usize {
        self.levels.iter().filter(|&&l| !is_light(v, l)).count()
    }
}

/// Posterise a picture into `lc.count + 1` tones (see the module notes), or fewer when the
/// picture has fewer tones worth a sheet ([`worth_a_sheet`]; not with levels or colours given).
/// `rgb`: the picture's colours (sRGB 0..1, alpha over white) when it has any, `None` for a gray
/// one.
pub fn posterise(
    luma: &Gray,
    rgb: Option<&[[f32; 3]]>,
    lc: &LayersConfig,
) -> Result<Tones, LayersError> {
    if !lc.levels.is_empty() || !lc.colors.is_empty() {
        return posterise_into(luma, rgb, lc);
    }
    // k-means finds the picture's colours, but two of them may differ in hue alone, where a
    // layer on the other shows little: then classes of lightness (multi-level Otsu on the luma,
    // each painted its pixels' mean colour), which layers painted light to dark show best.
    let best = |lc: &LayersConfig| -> Result<Tones, LayersError> {
        let tones = posterise_into(luma, rgb, lc)?;
        if worth_a_sheet(&tones) || tones.method != Method::KmeansLab {
            return Ok(tones);
        }
        let by_lightness = lightness_classes(luma, rgb.unwrap_or_default(), lc.count as usize);
        Ok(if worth_a_sheet(&by_lightness) {
            by_lightness
        } else {
            tones
        })
    };
    let mut tones = best(lc)?;
    let mut fewer = lc.clone();
    while fewer.count > 1 && !worth_a_sheet(&tones) {
        fewer.count -= 1;
        tones = best(&fewer)?;
    }
    if fewer.count != lc.count {
        tones.asked = Some(lc.count);
    }
    Ok(tones)
}

/// [`posterise`] into exactly `lc.count + 1` tones.
fn posterise_into(
    luma: &Gray,
    rgb: Option<&[[f32; 3]]>,
    lc: &LayersConfig,
) -> Result<Tones, LayersError> {
    let n = lc.count as usize;
    if !(1..=MAX_LAYERS).contains(&lc.count) {
        return Err(LayersError::Count(lc.count));
    }
    if !lc.colors.is_empty() && lc.colors.len() != n && lc.colors.len() != n + 1 {
        return Err(LayersError::Colors {
            given: lc.colors.len(),
            count: lc.count,
        });
    }
    let colour = rgb.filter(|_| lc.levels.is_empty());
    let (gray, levels, method, mut colors) = if let Some(rgb) = colour {
        let (gray, levels, colors) = kmeans_tones(luma, rgb, n + 1);
        (gray, levels, Method::KmeansLab, colors)
    } else {
        let (levels, method) = if lc.levels.is_empty() {
            let descending = multi_otsu(luma, n + 1).into_iter().rev().collect();
            (descending, Method::MultiOtsu)
        } else {
            if lc.levels.len() != n {
                return Err(LayersError::Levels {
                    given: lc.levels.len(),
                    count: lc.count,
                });
            }
            let mut l = lc.levels.clone();
            l.sort_unstable_by(|a, b| b.cmp(a));
            if let Some(w) = l.windows(2).find(|w| w[0] == w[1]) {
                return Err(LayersError::SameLevel(w[0]));
            }
            (l, Method::LevelsGiven)
        };
        let colors = class_grays(luma, &levels);
        (luma.clone(), levels, method, colors)
    };
    if lc.colors.len() == n {
        colors = std::iter::once([255, 255, 255])
            .chain(lc.colors.iter().copied())
            .collect();
    } else if lc.colors.len() == n + 1 {
        colors = lc.colors.clone();
    }
    Ok(Tones {
        gray,
        luma: luma.clone(),
        levels,
        colors,
        method,
        asked: None,
    })
}

/// The levels (ascending, `classes − 1` of them) that split the 8-bit histogram into `classes`
/// classes with the least sum of squared deviations from their means (Otsu's criterion for
/// several thresholds), exactly, by dynamic programming over the 256 bins. A pixel at or above a
/// level is in the lighter class, as `tone::is_light` reads a level.
pub fn multi_otsu(gray: &Gray, classes: usize) -> Vec<u8> {
    let mut hist = [0f64; 256];
    for &v in &gray.data {
        hist[(v.clamp(0.0, 1.0) * 255.0).round() as usize] += 1.0;
    }
    // Prefix sums of count, sum and sum of squares.
    let (mut w, mut s, mut s2) = ([0f64; 257], [0f64; 257], [0f64; 257]);
    for i in 0..256 {
        w[i + 1] = w[i] + hist[i];
        s[i + 1] = s[i] + hist[i] * i as f64;
        s2[i + 1] = s2[i] + hist[i] * (i * i) as f64;
    }
    // Spread of bins a..b (b exclusive).
    let cost = |a: usize, b: usize| {
        let n = w[b] - w[a];
        if n <= 0.0 {
            0.0
        } else {
            let m = s[b] - s[a];
            (s2[b] - s2[a]) - m * m / n
        }
    };
    let k = classes.clamp(1, 256);
    // best[c][b]: least cost of bins 0..b in c + 1 classes; from[c][b]: where the last starts.
    let mut best = vec![vec![f64::INFINITY; 257]; k];
    let mut from = vec![vec![0usize; 257]; k];
    for (b, v) in best[0].iter_mut().enumerate().skip(1) {
        *v = cost(0, b);
    }
    for c in 1..k {
        for b in (c + 1)..=256 {
            for a in c..b {
                let v = best[c - 1][a] + cost(a, b);
                if v < best[c][b] {
                    best[c][b] = v;
                    from[c][b] = a;
                }
            }
        }
    }
    let mut levels = Vec::with_capacity(k - 1);
    let mut b = 256;
    for c in (1..k).rev() {
        let a = from[c][b];
        levels.push(a as u8);
        b = a;
    }
    levels.reverse();
    levels
}

/// A colour picture posterised into `n + 1` classes of lightness (multi-level Otsu on `luma`),
/// each painted the mean colour of its pixels (averaged in CIELAB).
fn lightness_classes(luma: &Gray, rgb: &[[f32; 3]], n: usize) -> Tones {
    let levels: Vec<u8> = multi_otsu(luma, n + 1).into_iter().rev().collect();
    let mut sum = vec![[0f64; 3]; n + 1];
    let mut count = vec![0usize; n + 1];
    for (&v, &c) in luma.data.iter().zip(rgb) {
        let t = levels.iter().filter(|&&l| !is_light(v, l)).count();
        let l = lab(c);
        for j in 0..3 {
            sum[t][j] += l[j] as f64;
        }
        count[t] += 1;
    }
    let grays = class_grays(luma, &levels);
    let colors = (0..=n)
        .map(|t| {
            if count[t] == 0 {
                grays[t]
            } else {
                srgb(sum[t].map(|v| (v / count[t] as f64) as f32))
            }
        })
        .collect();
    Tones {
        gray: luma.clone(),
        luma: luma.clone(),
        levels,
        colors,
        method: Method::LightnessClasses,
        asked: None,
    }
}

/// Each tone's mean gray as a colour (the surface's first): the posterised picture of a gray one.
fn class_grays(luma: &Gray, levels: &[u8]) -> Vec<[u8; 3]> {
    let n = levels.len() + 1;
    let (mut sum, mut count) = (vec![0f64; n], vec![0usize; n]);
    for &v in &luma.data {
        let t = levels.iter().filter(|&&l| !is_light(v, l)).count();
        sum[t] += v as f64;
        count[t] += 1;
    }
    (0..n)
        .map(|t| {
            let v = if count[t] > 0 {
                sum[t] / count[t] as f64
            } else {
                // An empty tone: the middle of its band.
                let hi = if t == 0 { 255.0 } else { levels[t - 1] as f64 };
                let lo = if t == n - 1 { 0.0 } else { levels[t] as f64 };
                (hi + lo) / 2.0 / 255.0
            };
            let g = (v.clamp(0.0, 1.0) * 255.0).round() as u8;
            [g, g, g]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn multi_otsu_finds_the_gaps_between_populations() {
        let mut g = Gray::new(300, 1, 0.0);
        for x in 0..300 {
            g.data[x] = [0.1, 0.5, 0.9][x / 100];
        }
        let l = multi_otsu(&g, 3);
        assert_eq!(l.len(), 2);
        let v = |f: f32| (f * 255.0).round() as u8;
        assert!(l[0] > v(0.1) && l[0] <= v(0.5), "{l:?}");
        assert!(l[1] > v(0.5) && l[1] <= v(0.9), "{l:?}");
    }

    #[test]
    fn kmeans_tones_order_light_to_dark_and_threshold_to_clusters() {
        // Three colours of different lightness: red, pale yellow, dark blue.
        let cols = [[0.9f32, 0.1, 0.1], [0.95, 0.95, 0.6], [0.1, 0.1, 0.4]];
        let rgb: Vec<[f32; 3]> = (0..300).map(|i| cols[i / 100]).collect();
        let luma = Gray::new(300, 1, 0.5);
        let lc = LayersConfig {
            count: 2,
            ..Default::default()
        };
        let t = posterise(&luma, Some(&rgb), &lc).unwrap();
        assert_eq!(t.method, Method::KmeansLab);
        assert!(t.levels[0] > t.levels[1]);
        // Yellow is the surface, red layer 1, blue layer 2.
        assert_eq!(t.tone_of(t.gray.data[150]), 0);
        assert_eq!(t.tone_of(t.gray.data[50]), 1);
        assert_eq!(t.tone_of(t.gray.data[250]), 2);
        assert!(t.colors[2][2] > t.colors[2][0], "blue {:?}", t.colors[2]);
    }

    #[test]
    fn levels_given_are_checked() {
        let g = Gray::new(4, 4, 0.5);
        let lc = |levels: Vec<u8>| LayersConfig {
            count: 2,
            levels,
            ..Default::default()
        };
        assert!(matches!(
            posterise(&g, None, &lc(vec![100])),
            Err(LayersError::Levels { given: 1, count: 2 })
        ));
        assert!(matches!(
            posterise(&g, None, &lc(vec![90, 90])),
            Err(LayersError::SameLevel(90))
        ));
        let t = posterise(&g, None, &lc(vec![90, 200])).unwrap();
        assert_eq!(t.levels, vec![200, 90]);
        assert_eq!(t.method, Method::LevelsGiven);
    }
}
