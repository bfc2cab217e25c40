//! Growing a chosen strip into a bridge of the width its island needs (the paper's stage 5,
//! first step: "add the cheaper neighbouring strip on either side until the bridge is as wide as
//! needed"), and the width rule itself. The grown members are drawn by [`super::outline`].

use super::candidates::Candidates;
use super::config::BridgeConfig;
use super::cost::StripCost;
use super::strips::Strip;

/// The width rule's factor `k`: an island of area `A` gets a bridge `k·√A` wide, a quarter of the
/// side of a square of that area (the paper's ⌈√A / 4⌉).
pub(crate) const WIDTH_PER_SIDE: f64 = 0.25;

/// Width of the bridge between two nodes, in pixels: `clamp(⌈k·√A⌉, min_width_px, max_width_px)`,
/// `k` = [`WIDTH_PER_SIDE`], `A` the area in pixels of the **smaller** node (the frame's counts as
/// infinite). Since `√A` scales with the pixel size, `k·√A` px are `k·√A_mm²` mm: only the range
/// is converted, by the pipeline (`PhysicalConfig::bridge_for`). Why √A/4: an island's weight
/// grows with its area, and a bridge wider than a quarter of its side smothers its shape (with
/// cardstock, 1..4 mm: an island 4 mm across gets 1 mm, one 16 mm or more 4 mm).
pub(crate) fn width_for(smaller_area: usize, cfg: &BridgeConfig) -> u32 {
    let w = (WIDTH_PER_SIDE * (smaller_area as f64).sqrt()).ceil() as u32;
    w.clamp(
        cfg.min_width_px.max(1),
        cfg.max_width_px.max(cfg.min_width_px.max(1)),
    )
}

/// Grow from candidate `id` strip by strip, adding the cheaper neighbouring strip along the border
/// (weighted normalised ΣI + L^α) that reaches the same node, until the bridge is `width` px wide
/// or no neighbour can be added; returns the members in chain order. Width is measured, not
/// counted (a slanted edge's staircase spans n/√2 px for n strips): at least `width` strips and
/// both ends `width` px across ([`band_width`]), never past 4 × `width` strips.
pub(crate) fn grow(
    c: &Candidates,
    strips: &[Option<Strip>],
    costs: &[Option<StripCost>],
    id: usize,
    width: u32,
    cfg: &BridgeConfig,
) -> Vec<usize> {
    let Some(to) = strips[id].as_ref().map(|s| s.to) else {
        return Vec::new();
    };
    let chain_len = c.chains[c.chain_of[id] as usize].len;
    let want = (width as usize).min(chain_len).max(1);
    let usable = |j: usize| -> Option<f64> {
        match (&strips[j], &costs[j]) {
            (Some(s), Some(sc)) if s.to == to => Some(sc.weighted(cfg)),
            _ => None,
        }
    };
    let (mut lo, mut hi) = (0isize, 0isize);
    // Grow until the band is `want` pixels wide across, not merely `want` strips: strips that
    // leave a staircase or a slanted edge sit closer than one pixel apart across the bridge.
    let across = |lo: isize, hi: isize| {
        let members: Vec<usize> = (lo..=hi).filter_map(|k| c.along(id, k)).collect();
        band_width(c, strips, &members)
    };
    // At most four times the strips asked for: past that the border is too curved to carry a
    // band of this width, and `outline::plan` thickens or straightens what there is.
    let most = (4 * want).min(chain_len);
    while ((hi - lo + 1) as usize) < most
        && (((hi - lo + 1) as usize) < want || across(lo, hi) < want as f64 - ACROSS_SLACK)
    {
        let left = c.along(id, lo - 1).and_then(usable);
        let right = c.along(id, hi + 1).and_then(usable);
        match (left, right) {
            (Some(l), Some(r)) if l <= r => lo -= 1,
            (Some(_), Some(_)) => hi += 1,
            (Some(_), None) => lo -= 1,
            (None, Some(_)) => hi += 1,
            (None, None) => break,
        }
    }
    (lo..=hi).filter_map(|k| c.along(id, k)).collect()
}

/// Widths across a bridge within this many pixels of the target count as reached: strips that fan
/// out by a pixel tilt the mean direction and shave thousandths off an exact width.
pub(super) const ACROSS_SLACK: f64 = 0.05;

/// The narrowest width across a bridge made of `members` (in chain order), in pixels: the spread
/// of the outer strips' start points and of their end points, measured at right angles to the
/// bridge's mean direction, plus one pixel for the strips' own width; the smaller of the two ends.
pub(crate) fn band_width(c: &Candidates, strips: &[Option<Strip>], members: &[usize]) -> f64 {
    let ends: Vec<([f64; 2], [f64; 2])> = members
        .iter()
        .filter_map(|&m| {
            strips[m].as_ref().map(|s| {
                let (x, y) = c.pixels[m];
                ([x as f64, y as f64], [s.end.0 as f64, s.end.1 as f64])
            })
        })
        .collect();
    if ends.len() < 2 {
        return ends.len() as f64;
    }
    let (mut dx, mut dy) = (0.0, 0.0);
    for (a, b) in &ends {
        dx += b[0] - a[0];
        dy += b[1] - a[1];
    }
    let len = (dx * dx + dy * dy).sqrt();
    if len == 0.0 {
        return ends.len() as f64;
    }
    // Unit normal to the mean direction.
    let (nx, ny) = (-dy / len, dx / len);
    type Pick = fn(&([f64; 2], [f64; 2])) -> [f64; 2];
    let spread = |pick: Pick| {
        let proj = ends.iter().map(|e| {
            let p = pick(e);
            p[0] * nx + p[1] * ny
        });
        let (lo, hi) = proj.fold((f64::MAX, f64::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)));
        hi - lo + 1.0
    };
    spread(|e| e.0).min(spread(|e| e.1))
}
