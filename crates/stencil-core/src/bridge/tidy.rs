//! Tidy the edges where bridges meet the material.
//!
//! A bridge is filled from the end points of its outer strips, so its end is a straight chord while
//! the island edge it lands on is curved, and its sides follow pixel strips. That leaves one- and
//! two-pixel cut slivers between bridge and edge, and material spurs along the sides: features no
//! material can hold, which the width check rightly refuses. This pass applies the topological
//! filter (opening, then closing, by the material's radius) *only near bridges*, and only in the
//! direction a bridge may change a stencil: original material always stays material.

use crate::islands;
use crate::raster::{close, open, squared_distance_to, BitGrid};

/// Clean the bridged grid `after` (bridges drawn into `before`) within `radius + 2` pixels of the
/// pixels the bridges added. Returns `after` unchanged when `radius` is 0; when the opening would
/// break the sheet into pieces (a bridge narrower than the opening's disc somewhere), only the
/// closing is applied, and nothing if even that would (connectivity is what the stencil is for).
pub(crate) fn tidy(before: &BitGrid, after: &BitGrid, radius: u32) -> BitGrid {
    if radius == 0 || before == after {
        return after.clone();
    }
    let added = before.data.iter().zip(&after.data).map(|(&b, &a)| a && !b);
    let added = BitGrid::from_data(after.width, after.height, added.collect());
    let near = squared_distance_to(&added, true);
    // `squared_distance_to` counts the area outside the image as a target; measure from the
    // bridges only by padding the reach test with the real distance to the added pixels.
    let reach = ((radius + 2) * (radius + 2)) as f32;
    let opened = open(after, radius);
    // Opening and closing (spurs and slivers) if that keeps one sheet; else closing alone (it only
    // fills slivers of cut, so it cannot cut a bridge through); else nothing.
    for cleaned in [close(&opened, radius), close(after, radius)] {
        let out = apply_near(before, after, &added, &near, &cleaned, reach, radius);
        if islands::floating_count(&out) == 0 {
            return out;
        }
    }
    after.clone()
}

/// `after`, with every pixel near a bridge (and not original material) taken from `cleaned`.
fn apply_near(
    before: &BitGrid,
    after: &BitGrid,
    added: &BitGrid,
    near: &[f32],
    cleaned: &BitGrid,
    reach: f32,
    radius: u32,
) -> BitGrid {
    let mut out = after.clone();
    let (w, h) = (after.width as usize, after.height as usize);
    for (i, cell) in out.data.iter_mut().enumerate() {
        if before.data[i] || near[i] > reach {
            continue;
        }
        // Pixels at the image border count as near only through a real bridge pixel.
        let (x, y) = (i % w, i / w);
        let edge_dist2 = (x.min(w - 1 - x).min(y).min(h - 1 - y) + 1).pow(2) as f32;
        if near[i] >= edge_dist2 && !added_within(added, x, y, radius + 2) {
            continue;
        }
        *cell = cleaned.data[i];
    }
    out
}

/// Whether any added pixel lies within the square of half-size `r` around (x, y).
fn added_within(added: &BitGrid, x: usize, y: usize, r: u32) -> bool {
    let r = r as usize;
    let (w, h) = (added.width as usize, added.height as usize);
    (y.saturating_sub(r)..(y + r + 1).min(h))
        .any(|yy| (x.saturating_sub(r)..(x + r + 1).min(w)).any(|xx| added.data[yy * w + xx]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fills_a_sliver_beside_a_bridge_and_keeps_original_material() {
        // Frame on the left (x < 4), island on the right (x >= 14), cut between.
        let before = BitGrid::from_fn(24, 20, |x, _| !(4..14).contains(&x));
        // A bridge across rows 6..14 that stops one pixel short of the island on rows 6..9:
        // a one-pixel cut sliver between bridge and island.
        let mut after = before.clone();
        for y in 6..14 {
            for x in 4..14 {
                if !(x == 13 && y < 9) {
                    after.set(x, y, true);
                }
            }
        }
        let t = tidy(&before, &after, 2);
        assert!(t.get(13, 6) && t.get(13, 7), "sliver filled");
        // Original material never becomes cut; far from the bridge nothing changes.
        assert!(before.data.iter().zip(&t.data).all(|(&b, &a)| !b || a));
        assert_eq!(t.get(8, 1), before.get(8, 1));
        assert_eq!(t.get(8, 18), before.get(8, 18));
        assert_eq!(islands::floating_count(&t), 0);
    }

    #[test]
    fn removes_a_one_pixel_spur_of_bridge_material() {
        let before = BitGrid::from_fn(24, 20, |x, _| !(4..14).contains(&x));
        let mut after = before.clone();
        for y in 6..14 {
            for x in 4..14 {
                after.set(x, y, true);
            }
        }
        // A one-pixel-wide spur sticking four pixels out of the bridge's side.
        for y in 2..6 {
            after.set(8, y, true);
        }
        let t = tidy(&before, &after, 2);
        // Opening removes it; a digital disc's tip may keep the single pixel next to the bridge.
        assert!(!t.get(8, 2) && !t.get(8, 3) && !t.get(8, 4), "spur removed");
        assert!(t.get(8, 9), "bridge kept");
    }

    #[test]
    fn beside_a_bridge_the_opening_would_cut_slivers_are_still_filled() {
        // An island (x 14..20, y 4..16) held by a bridge three pixels wide (an opening of radius 2
        // would remove it, and the island would fall) that stops one pixel short of the island on
        // its top row.
        let before = BitGrid::from_fn(24, 20, |x, y| {
            x < 4 || ((14..20).contains(&x) && (4..16).contains(&y))
        });
        let mut after = before.clone();
        for y in 8..11 {
            for x in 4..14 {
                if !(x == 13 && y == 8) {
                    after.set(x, y, true);
                }
            }
        }
        let t = tidy(&before, &after, 2);
        assert!(t.get(13, 8), "sliver filled by the closing alone");
        assert!((4..14).all(|x| t.get(x, 9)), "bridge kept");
        assert!(before.data.iter().zip(&t.data).all(|(&b, &a)| !b || a));
        assert_eq!(islands::floating_count(&t), 0);
    }

    #[test]
    fn radius_zero_changes_nothing() {
        let before = BitGrid::from_fn(10, 10, |x, _| x < 3);
        let mut after = before.clone();
        after.set(5, 5, true);
        assert_eq!(tidy(&before, &after, 0), after);
    }
}
