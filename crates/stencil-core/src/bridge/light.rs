//! Whether the cut where the bridges can go has light places: the survey behind report.json's
//! `bridge_light` and `make`'s note. Bridges are chosen for the error they add, Σ(1 − gray)² over
//! the cut they cover; where every way through the cut is equally dark (black-and-white art, a
//! uniformly dark background, flat colour) no choice lowers it, and the bridges simply take the
//! shortest ways. The person should be told so rather than led to expect bridges hidden in light
//! places. A light place is relative: a cut pixel at most three quarters as dark, (1 − gray)², as
//! the surveyed cut is on average (a level at mid-gray leaves cut from 0.25 to 1 dark, so half
//! the mean would find none in a photo whose cut is mostly mid-gray).

use super::strips::Strip;
use crate::raster::Gray;

/// A cut pixel at most this fraction of the surveyed cut's mean darkness is a light place: a
/// bridge over it costs at most three quarters of what one over the typical cut does.
const LIGHT_SHARE: f64 = 0.75;

/// At least one in this many of the surveyed pixels must be light for the picture to count as
/// having light places.
const ONE_IN: usize = 100;

/// What the cut the candidate strips cross is like.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Light {
    /// Cut pixels the candidate strips (walks, shortest gaps, searched paths) cross, each
    /// counted once per strip: where the islands' bridges can go.
    pub near_islands_px: usize,
    /// Of those, the ones at most three quarters as dark, (1 − gray)², as they are on average.
    pub light_px: usize,
    /// Whether at least one in a hundred of them is light: a bridge has somewhere lighter than
    /// black to go.
    pub light_places: bool,
}

impl Light {
    /// The survey of `strips` over `gray`.
    pub(crate) fn survey<'a>(
        gray: &Gray,
        strips: impl Iterator<Item = &'a Strip> + Clone,
    ) -> Light {
        let dark = |p: &u32| (1.0 - gray.data[*p as usize] as f64).powi(2);
        let (mut near, mut sum) = (0usize, 0.0);
        for s in strips.clone() {
            near += s.pixels.len();
            sum += s.pixels.iter().map(dark).sum::<f64>();
        }
        let limit = LIGHT_SHARE * sum / near.max(1) as f64;
        let light = strips
            .map(|s| s.pixels.iter().filter(|p| dark(p) <= limit).count())
            .sum::<usize>();
        Light {
            near_islands_px: near,
            light_px: light,
            light_places: near > 0 && light * ONE_IN >= near,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strip(pixels: Vec<u32>) -> Strip {
        Strip {
            from: 1,
            to: 0,
            pixels,
            end: (0, 0),
            intensity: 0.0,
        }
    }

    #[test]
    fn a_light_place_is_counted_and_flat_tones_have_none() {
        // Pixels 0..4 black, 4 dark gray, 5 pale.
        let gray = Gray::from_data(6, 1, vec![0.0, 0.0, 0.0, 0.0, 0.3, 0.9]);
        let l = Light::survey(&gray, [strip(vec![0, 1, 2, 3]), strip(vec![4, 5])].iter());
        // Mean darkness (4 + 0.49 + 0.01) / 6 = 0.75: the two grays are under 3/4 of it.
        assert_eq!(
            (l.near_islands_px, l.light_px, l.light_places),
            (6, 2, true)
        );
        // All black, or all one gray: nowhere lighter to go.
        let l = Light::survey(&gray, [strip(vec![0, 1, 2, 3])].iter());
        assert_eq!(
            (l.near_islands_px, l.light_px, l.light_places),
            (4, 0, false)
        );
        let flat = Gray::from_data(2, 1, vec![0.4, 0.4]);
        assert!(!Light::survey(&flat, [strip(vec![0, 1])].iter()).light_places);
        // One light pixel in more than a hundred: none to speak of; no strips: none.
        let many: Vec<u32> = std::iter::repeat_n(0, 150).chain([5]).collect();
        assert!(!Light::survey(&gray, [strip(many)].iter()).light_places);
        assert!(!Light::survey(&gray, std::iter::empty()).light_places);
    }
}
