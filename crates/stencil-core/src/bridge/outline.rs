//! Planning a grown bridge's drawing (the paper's stage 5: "the bridge polygon is formed from the
//! end points of its outer strips, and drawn as material"): the filled outline of its outer
//! strips, trimmed while it is wider than the material's widest bridge, thickened to the
//! narrowest; or, for a fan gone wrong or a drawing too narrow somewhere, a straight band
//! ([`super::band`]).

use super::across::{measure, widest};
use super::band::{band, runs_straight};
use super::candidates::Candidates;
use super::config::BridgeConfig;
use super::draw::{draw, draw_brushed, Brush, Plan};
use super::grow::{band_width, ACROSS_SLACK};
use super::strips::Strip;
use crate::raster::{BitGrid, Gray};
use stencil_geom::ring::{dist, seg_dist};

/// Plan the bridge made of `members`' strips, at least `cfg.min_width_px` and at most
/// `cfg.max_width_px` wide. `want` is the width the island asked for.
///
/// Drawn as every strip pixel plus the cut pixels inside the polygon of the outer strips' end
/// points (only where 4-connected to a strip), thickened by a square brush when too few strips
/// grew, then measured at right angles ([`measure`]). It is drawn instead as a straight band `want`
/// wide along its middle strip ([`band`]) when it is a fan gone wrong (strips crossing, or spread
/// too far to outline a band), narrower than the minimum somewhere (a tapering wedge), or still
/// wider than the maximum after dropping outer strips from the side that narrows it more. A
/// single bent strip (a fallback search path) is only thickened: a straight band could cross the
/// picture elsewhere. A moderate fan keeps its outline; the support rule halves it if it costs
/// more than the strips promised.
pub(crate) fn plan(
    bits: &BitGrid,
    gray: &Gray,
    c: &Candidates,
    strips: &[Option<Strip>],
    members: &[usize],
    cfg: &BridgeConfig,
    want: u32,
) -> Plan {
    let Some(m) = Members::new(c, strips, members) else {
        return Plan::default();
    };
    let n = m.strips.len();
    let min_width = cfg.min_width_px.max(1);
    let max_width = cfg.max_width_px.max(min_width);
    let target = want.clamp(min_width, max_width);
    let polygon = m.outline(0, n - 1);
    if n == 1 {
        let (s, from) = m.strips[0];
        let long = s.len() >= LONG_STRIP * min_width as usize;
        let straight = runs_straight(s, bits.width);
        if long && (!straight || cfg.user.keep_out.is_some()) {
            // A long bent path: its outline is no axis to measure across, nor to draw a band
            // along. (Beside a keep-out area a band could lose the pixels that join it.)
            return thickened(bits, gray, polygon, s, min_width, m.length, true);
        }
        if long {
            // A long straight strip (a straightened search path): a band of the narrowest
            // width along it, as thick as a bent one is thickened. A square brush on its
            // staircase covered up to √2 times the band's area where it runs slanted (4.2
            // pixels per pixel of length at 45°, the band 3 to 3.5).
            return band(
                bits,
                gray,
                [start(from), centre(s.end)],
                min_width,
                min_width,
                m.length,
            );
        }
        if !straight {
            return thickened(bits, gray, polygon, s, min_width, m.length, false);
        }
    }
    if !is_fan(&polygon, &m.strips, target) {
        if let Some(plan) = filled_outline(bits, gray, c, strips, &m, cfg) {
            return plan;
        }
    }
    let (mid, from) = m.strips[n / 2];
    band(
        bits,
        gray,
        [start(from), centre(mid.end)],
        target,
        min_width,
        m.length,
    )
}

/// The members of a bridge that have a strip, in chain order: what [`plan`] and its pieces draw
/// from.
struct Members<'a> {
    /// Their candidate ids.
    ids: Vec<usize>,
    /// Their strips, each with its candidate's pixel (where the strip starts).
    strips: Vec<(&'a Strip, (u32, u32))>,
    /// Mean strip length, px.
    length: f64,
}

impl<'a> Members<'a> {
    /// `None` when no member has a strip (nothing to draw).
    fn new(c: &Candidates, strips: &'a [Option<Strip>], members: &[usize]) -> Option<Members<'a>> {
        let ids: Vec<usize> = members
            .iter()
            .copied()
            .filter(|&m| strips[m].is_some())
            .collect();
        let member_strips: Vec<(&Strip, (u32, u32))> = ids
            .iter()
            .filter_map(|&m| strips[m].as_ref().map(|s| (s, c.pixels[m])))
            .collect();
        let n = member_strips.len();
        if n == 0 {
            return None;
        }
        let length = member_strips
            .iter()
            .map(|(s, _)| s.len() as f64)
            .sum::<f64>()
            / n as f64;
        Some(Members {
            ids,
            strips: member_strips,
            length,
        })
    }

    /// The outline `[s0, e0, e1, s1]` of members `lo..=hi`: the start and end points of the outer
    /// two strips.
    fn outline(&self, lo: usize, hi: usize) -> Vec<[f64; 2]> {
        let (first, last) = (self.strips[lo], self.strips[hi]);
        vec![
            start(first.1),
            centre(first.0.end),
            centre(last.0.end),
            start(last.1),
        ]
    }

    /// Which outer strip to drop next from `lo..=hi` to narrow the outline: `true` for the first,
    /// `false` for the last; the side whose loss leaves the narrower outline (a tie drops the
    /// first).
    fn drop_first(&self, lo: usize, hi: usize) -> bool {
        widest(&self.outline(lo + 1, hi)) <= widest(&self.outline(lo, hi - 1))
    }
}

/// Whether members with the outline `polygon` are a fan gone wrong, to be drawn as a band rather
/// than filled: their outer strips cross, or diverge by more than [`MAX_FAN_DEGREES`], or any two
/// of them do, or they land more than four times farther apart (plus the band's `target` width)
/// than they start. A single strip is never a fan.
fn is_fan(polygon: &[[f64; 2]], members: &[(&Strip, (u32, u32))], target: u32) -> bool {
    members.len() > 1
        && (crosses(polygon)
            || diverge(polygon) > MAX_FAN_DEGREES.to_radians()
            || spread(members) > MAX_FAN_DEGREES.to_radians()
            || dist(polygon[1], polygon[2]) > 4.0 * (dist(polygon[0], polygon[3]) + target as f64))
}

/// A lone strip at least this many times the narrowest width long is drawn round its straight
/// runs or as a band ([`plan`]); a shorter one as before, its pixels thickened by a square brush
/// where it bends (on the corpus, the band or round brush on short lone strips added pixels
/// where they meet pointed nodes: about a hundred more on `china.jpg`).
const LONG_STRIP: usize = 8;

/// A single strip that does not run straight, drawn thickened to `min_width` and reported as
/// that wide: a bent path has no axis to measure across nor to draw a band along. A long one
/// (`round`) is thickened round its straight runs (every pixel within half the width of the
/// polyline from where it leaves its island through its runs to where it lands), so a slanted
/// run is no wider than a band: a square brush on the staircase of a 45° run covered 4.2 pixels
/// per pixel of length, a band 3 to 3.5. A short one keeps the square brush on its pixels.
fn thickened(
    bits: &BitGrid,
    gray: &Gray,
    polygon: Vec<[f64; 2]>,
    s: &Strip,
    min_width: u32,
    length: f64,
    round: bool,
) -> Plan {
    let seal = (min_width as usize).pow(2);
    let (pixels, real) = if round {
        let half = (min_width as f64 / 2.0).max(0.75);
        let mut line = vec![polygon[0]];
        line.extend(runs(&s.pixels, bits.width));
        line.push(polygon[1]);
        draw_brushed(bits, gray, &polygon, &[s], Brush::Round(&line, half), seal)
    } else {
        let brush = ((min_width as f64 - 1.0) / 2.0).ceil().max(0.0) as i64;
        draw(bits, gray, &polygon, &[s], brush, seal)
    };
    Plan {
        pixels,
        polygon,
        real,
        width: min_width,
        length,
    }
}

/// How far a pixel of a straight run may lie from its chord: a 4-connected digital line's pixels
/// lie within ½·(|cos| + |sin|) ≤ 0.71 px of it.
const RUN_SLACK: f64 = 0.75;

/// The corners of a 4-connected path (linear pixel indices in an image `image_width` wide) taken
/// as straight runs: pixel centres from the first to the last, each run as long as every pixel
/// of it lies within [`RUN_SLACK`] of its chord (greedily, from the start).
fn runs(pixels: &[u32], image_width: u32) -> Vec<[f64; 2]> {
    let xy = |p: u32| {
        [
            (p % image_width) as f64 + 0.5,
            (p / image_width) as f64 + 0.5,
        ]
    };
    let Some(&first) = pixels.first() else {
        return Vec::new();
    };
    let fits = |a: usize, b: usize| {
        let (pa, pb) = (xy(pixels[a]), xy(pixels[b]));
        pixels[a..=b]
            .iter()
            .all(|&p| seg_dist(xy(p), pa, pb) <= RUN_SLACK)
    };
    let mut out = vec![xy(first)];
    let mut a = 0;
    while a + 1 < pixels.len() {
        let mut b = a + 1;
        while b + 1 < pixels.len() && fits(a, b + 1) {
            b += 1;
        }
        out.push(xy(pixels[b]));
        a = b;
    }
    out
}

/// The members drawn as their filled outline (thickened when they span less than the minimum
/// width), after dropping outer strips until no chord of the outline is wider than the maximum,
/// then measured and trimmed further (at most [`MAX_TRIMS`] drawings) while what is drawn is still
/// too wide. `None` when the drawing is narrower than the minimum somewhere, has no width at its
/// middle, or stays too wide: [`plan`] then draws a band instead.
fn filled_outline(
    bits: &BitGrid,
    gray: &Gray,
    c: &Candidates,
    strips: &[Option<Strip>],
    m: &Members,
    cfg: &BridgeConfig,
) -> Option<Plan> {
    let min_width = cfg.min_width_px.max(1);
    let max_width = cfg.max_width_px.max(min_width);
    // Never wider than the maximum: strips converging on a smaller island start farther apart
    // than they land, and a moderate fan spreads; drop outer strips, from the side that
    // narrows the outline more, until no chord across it is too wide.
    let too_wide = |lo: usize, hi: usize| widest(&m.outline(lo, hi)) > max_width as f64 + 0.5;
    let (mut lo, mut hi) = (0, m.strips.len() - 1);
    while hi > lo && too_wide(lo, hi) {
        if m.drop_first(lo, hi) {
            lo += 1;
        } else {
            hi -= 1;
        }
    }
    // Outer strips may bulge out of the outline: what is drawn is measured, and trimmed
    // further (a few times at most, each a full drawing) if it is still too wide.
    for _ in 0..MAX_TRIMS {
        let polygon = m.outline(lo, hi);
        let across = band_width(c, strips, &m.ids[lo..=hi]);
        let brush = if across < min_width as f64 - ACROSS_SLACK {
            ((min_width as f64 - across) / 2.0).ceil() as i64
        } else {
            0
        };
        let seeds: Vec<&Strip> = m.strips[lo..=hi].iter().map(|(s, _)| *s).collect();
        let seal = (min_width as usize).pow(2);
        let (pixels, real) = draw(bits, gray, &polygon, &seeds, brush, seal);
        let measured = measure(bits, &pixels, &polygon, min_width as f64 + 1.0);
        // A run across measures up to a pixel less than the strips it crosses at a slant.
        let narrowest = measured.narrowest + 1.0;
        if narrowest < min_width as f64 - ACROSS_SLACK || measured.middle.is_infinite() {
            return None;
        }
        if measured.widest <= max_width as f64 + 0.5 {
            let drawn = if brush > 0 { min_width as f64 } else { across };
            return Some(Plan {
                pixels,
                polygon,
                real,
                width: (drawn.min(narrowest) + ACROSS_SLACK).floor() as u32,
                length: m.length,
            });
        }
        if hi == lo {
            return None;
        }
        if m.drop_first(lo, hi) {
            lo += 1;
        } else {
            hi -= 1;
        }
    }
    None
}

/// The centre of pixel (x, y).
fn centre((x, y): (i64, i64)) -> [f64; 2] {
    [x as f64 + 0.5, y as f64 + 0.5]
}

fn start(p: (u32, u32)) -> [f64; 2] {
    centre((p.0 as i64, p.1 as i64))
}

/// Drawings of a bridge's outline at most, each with an outer strip fewer, before it is drawn as a
/// band for being too wide.
const MAX_TRIMS: usize = 4;

/// Outer strips whose directions differ by more than this are a fan to be redrawn as a band.
const MAX_FAN_DEGREES: f64 = 60.0;

/// The angle between the first and the last strip of the outline `[s0, e0, e1, s1]`, radians.
pub(super) fn diverge(q: &[[f64; 2]]) -> f64 {
    let (a, b) = (
        [q[1][0] - q[0][0], q[1][1] - q[0][1]],
        [q[2][0] - q[3][0], q[2][1] - q[3][1]],
    );
    let (la, lb) = (a[0].hypot(a[1]), b[0].hypot(b[1]));
    if la == 0.0 || lb == 0.0 {
        return 0.0;
    }
    ((a[0] * b[0] + a[1] * b[1]) / (la * lb))
        .clamp(-1.0, 1.0)
        .acos()
}

/// The angle between the most diverging member strips, radians, measured from the middle strip.
/// Why not only the outer two (see [`diverge`]): around an island smaller than the bridge the
/// members can wrap all the way round, so the first and the last strip leave side by side while
/// the ones between point every way.
fn spread(members: &[(&Strip, (u32, u32))]) -> f64 {
    let dir =
        |(s, p): &(&Strip, (u32, u32))| [s.end.0 as f64 - p.0 as f64, s.end.1 as f64 - p.1 as f64];
    let m = dir(&members[members.len() / 2]);
    let (lo, hi) = members
        .iter()
        .map(|x| {
            let d = dir(x);
            (m[0] * d[1] - m[1] * d[0]).atan2(m[0] * d[0] + m[1] * d[1])
        })
        .fold((0.0f64, 0.0f64), |(lo, hi), a| (lo.min(a), hi.max(a)));
    hi - lo
}

/// Whether the quadrilateral's opposite sides cross (a bow-tie: the outer strips crossed).
pub(super) fn crosses(q: &[[f64; 2]]) -> bool {
    fn side(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
        (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
    }
    let cut = |a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]| {
        side(a, b, c) * side(a, b, d) < 0.0 && side(c, d, a) * side(c, d, b) < 0.0
    };
    q.len() == 4 && (cut(q[0], q[1], q[2], q[3]) || cut(q[1], q[2], q[3], q[0]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bridge::across::{along_edges, measure};
    use crate::bridge::band::band_outline;
    use crate::bridge::cost::Norm;
    use crate::bridge::cost::StripCost;
    use crate::bridge::draw::commit;
    use crate::bridge::grow::{grow, width_for};
    use crate::bridge::{candidates, strips};
    use crate::islands::label;
    use crate::raster::TwoTone;
    use stencil_geom::ring::{dist, point_in_ring};

    /// Labels, candidates and every candidate's strip (walks up to 40 px).
    fn walk_all(
        t: &TwoTone,
    ) -> (
        crate::islands::IslandMap,
        candidates::Candidates,
        Vec<Option<Strip>>,
    ) {
        let m = label(&t.bits);
        let f = strips::Fields::new(t, &m);
        let c = candidates::collect(&m);
        let st = (0..c.len())
            .map(|i| strips::walk_candidate(&f, &c, i, 40).ok())
            .collect();
        (m, c, st)
    }

    #[test]
    fn width_grows_with_the_smaller_area_and_is_clamped() {
        let cfg = BridgeConfig {
            min_width_px: 3,
            max_width_px: 20,
            ..Default::default()
        };
        assert_eq!(width_for(4, &cfg), 3); // ⌈2/4⌉ = 1 → min
        assert_eq!(width_for(1600, &cfg), 10); // √1600 / 4
        assert_eq!(width_for(1601, &cfg), 11);
        assert_eq!(width_for(1_000_000, &cfg), 20); // max
        assert!(width_for(400, &cfg) <= width_for(900, &cfg));
    }

    /// A 6×6 island 4 px below the frame's top band, black everywhere: grow to 3 and draw.
    #[test]
    fn grows_cheaper_neighbours_first_and_fills_a_solid_bridge() {
        let w = 20u32;
        let bits = BitGrid::from_fn(w, 16, |x, y| {
            y < 2 || ((7..13).contains(&x) && (6..12).contains(&y))
        });
        let mut gray = Gray::new(w, 16, 0.0);
        // Light column over x = 11: the strip there is cheaper than the one at x = 9.
        for y in 2..6 {
            gray.set(11, y, 0.9);
        }
        let t = TwoTone {
            bits,
            gray: gray.into(),
        };
        let (m, c, st) = walk_all(&t);
        let cfg = BridgeConfig::default();
        let norm = Norm::new(st.iter().flatten().map(|s| s.len()).collect(), &cfg);
        let costs: Vec<_> = st
            .iter()
            .map(|s| s.as_ref().map(|s| norm.strip(s)))
            .collect();
        let id = c.id_at(&m, 1, 10, 6).unwrap();
        assert_eq!(st[id].as_ref().unwrap().to, 0);
        let members = grow(&c, &st, &costs, id, 3, &cfg);
        let xs: Vec<u32> = members.iter().map(|&i| c.pixels[i].0).collect();
        // From x = 10 the cheaper side (x = 11, light) comes first, then x = 9 or 12.
        assert_eq!(members.len(), 3);
        assert!(xs.contains(&10) && xs.contains(&11), "{xs:?}");
        let p = plan(&t.bits, &t.gray, &c, &st, &members, &cfg, 3);
        assert_eq!(p.width, 3);
        let mut b = t.bits.clone();
        commit(&mut b, &p.pixels);
        assert_eq!(label(&b).island_count(), 0);
        // Solid: every pixel between the outer strips in the gap is material.
        let xmin = *xs.iter().min().unwrap();
        for y in 2..6 {
            for x in xmin..xmin + 3 {
                assert!(b.get(x, y), "({x}, {y})");
            }
        }
        // Every planned pixel is a member strip's pixel or lies inside the polygon, and the real
        // error is Σ (1 − gray)² over exactly those pixels.
        let strip_px: Vec<u32> = members
            .iter()
            .flat_map(|&m| st[m].as_ref().unwrap().pixels.clone())
            .collect();
        let mut real = 0.0;
        for &q in &p.pixels {
            let (x, y) = ((q % w) as f64 + 0.5, (q / w) as f64 + 0.5);
            assert!(
                strip_px.contains(&q) || point_in_ring([x, y], &p.polygon),
                "{q}"
            );
            real += (1.0 - t.gray.data[q as usize] as f64).powi(2);
        }
        assert!(p.pixels.len() >= 12);
        assert!((p.real - real).abs() < 1e-9);
    }

    /// A ring island (radii 22..30) around a disc island (radius 8), inside the frame (from 37).
    fn ring_and_disc() -> TwoTone {
        let n = 81u32;
        let r = |x: u32, y: u32| (x as f64 + 0.5 - 40.5).hypot(y as f64 + 0.5 - 40.5);
        let bits = BitGrid::from_fn(n, n, |x, y| {
            let d = r(x, y);
            d <= 8.0 || (22.0..=30.0).contains(&d) || d >= 37.0
        });
        TwoTone {
            gray: Gray::new(n, n, 0.0).into(),
            bits,
        }
    }

    /// The same cost for every strip.
    fn flat_costs(n: usize) -> Vec<Option<StripCost>> {
        vec![
            Some(StripCost {
                intensity: 1.0,
                length: 1.0
            });
            n
        ]
    }

    #[test]
    fn converging_strips_grow_until_the_narrow_end_is_wide_enough() {
        // A ring island around a disc island: strips from the ring's inner edge converge on the
        // disc, so 8 strips are 8 px apart where they start but closer where they land.
        let t = ring_and_disc();
        let (m, c, st) = walk_all(&t);
        assert_eq!(m.island_count(), 2);
        let (ring, disc) = (m.label(40, 14), m.label(40, 40));
        let id = (0..c.len())
            .find(|&i| {
                c.node(i) == ring
                    && c.pixels[i].0 == 40
                    && c.pixels[i].1 < 40
                    && st[i].as_ref().is_some_and(|s| s.to == disc)
            })
            .unwrap();
        let cfg = BridgeConfig::default();
        let costs = flat_costs(c.len());
        let members = grow(&c, &st, &costs, id, 8, &cfg);
        let across = band_width(&c, &st, &members);
        assert!(across >= 8.0 - ACROSS_SLACK, "{across}");
        assert!(
            members.len() > 8 && members.len() <= 32,
            "{}",
            members.len()
        );
        // Counting strips alone would have stopped at 8, narrower than 8 px at the disc.
        let eight = &members[..8];
        assert!(band_width(&c, &st, eight) < 8.0);
        let p = plan(&t.bits, &t.gray, &c, &st, &members, &cfg, 8);
        assert!(p.width >= 8);
    }

    #[test]
    fn a_lone_strip_is_thickened_to_the_minimum_width() {
        // A one-pixel island: one strip per side; the bridge must still be 3 wide.
        let bits = BitGrid::from_fn(9, 9, |x, y| y == 0 || (x == 4 && y == 4));
        let t = TwoTone {
            gray: Gray::new(9, 9, 0.0).into(),
            bits,
        };
        let (_, c, st) = walk_all(&t);
        let cfg = BridgeConfig::default();
        let costs = vec![None; c.len()];
        let members = grow(&c, &st, &costs, 0, 3, &cfg);
        assert_eq!(members.len(), 1);
        let p = plan(&t.bits, &t.gray, &c, &st, &members, &cfg, 3);
        assert_eq!(p.width, 3);
        let mut b = t.bits.clone();
        commit(&mut b, &p.pixels);
        assert_eq!(label(&b).island_count(), 0);
        // 3 px wide across the whole gap.
        assert!(p.pixels.len() >= 3 * st[0].as_ref().unwrap().len());
    }

    #[test]
    fn fan_geometry() {
        // Parallel strips: no crossing, no divergence.
        let band = [[0.0, 0.0], [0.0, 10.0], [5.0, 10.0], [5.0, 0.0]];
        assert!(!crosses(&band));
        assert!(diverge(&band) < 1e-9);
        // Outer strips that cross make a bow-tie.
        let bow = [[0.0, 0.0], [5.0, 10.0], [0.0, 10.0], [5.0, 0.0]];
        assert!(crosses(&bow));
        // Strips leaving in opposite directions diverge by 180 degrees.
        let opposite = [[1.0, 0.0], [10.0, 0.0], [-10.0, 0.0], [-1.0, 0.0]];
        assert!((diverge(&opposite) - std::f64::consts::PI).abs() < 1e-9);
        // A band outline is a rectangle of the given half-width.
        let r = band_outline([0.0, 0.0], [10.0, 0.0], 3.0);
        assert!((dist(r[0], r[3]) - 6.0).abs() < 1e-9 && (dist(r[0], r[1]) - 10.0).abs() < 1e-9);
    }

    /// Extent of a set of pixels at right angles to their own principal axis (not the outline's):
    /// the pixel centres binned a pixel at a time along the axis, each bin's spread across plus
    /// one pixel. Returns (narrowest, widest) over the bins, leaving out `ends` bins at each end.
    fn extent_across(pixels: &[u32], width: u32, ends: usize) -> (f64, f64) {
        let pts: Vec<[f64; 2]> = pixels
            .iter()
            .map(|&p| [(p % width) as f64 + 0.5, (p / width) as f64 + 0.5])
            .collect();
        let n = pts.len() as f64;
        let (mx, my) = (
            pts.iter().map(|p| p[0]).sum::<f64>() / n,
            pts.iter().map(|p| p[1]).sum::<f64>() / n,
        );
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for p in &pts {
            let (dx, dy) = (p[0] - mx, p[1] - my);
            sxx += dx * dx;
            sxy += dx * dy;
            syy += dy * dy;
        }
        let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        let (d, nv) = ([angle.cos(), angle.sin()], [-angle.sin(), angle.cos()]);
        let mut bins: std::collections::BTreeMap<i64, (f64, f64)> = Default::default();
        for p in &pts {
            let t = (p[0] * d[0] + p[1] * d[1]).floor() as i64;
            let u = p[0] * nv[0] + p[1] * nv[1];
            let e = bins.entry(t).or_insert((u, u));
            *e = (e.0.min(u), e.1.max(u));
        }
        let spans: Vec<f64> = bins.values().map(|(lo, hi)| hi - lo + 1.0).collect();
        let inner = &spans[ends.min(spans.len() / 2)..spans.len() - ends.min(spans.len() / 2)];
        (
            inner.iter().copied().fold(f64::INFINITY, f64::min),
            inner.iter().copied().fold(0.0, f64::max),
        )
    }

    /// A small round island in the open: strips leave it in every direction. Whichever border
    /// pixel the bridge grows from, and however wide the island asks it to be, what is drawn is
    /// never wider than the maximum at right angles to it (measured on its pixels, about their
    /// own axis), holds the island, and is no narrower than the minimum.
    #[test]
    fn a_fan_around_a_small_round_island_is_never_wider_than_the_maximum() {
        let n = 64u32;
        let disc = |x: u32, y: u32| (x as f64 + 0.5 - 32.0).hypot(y as f64 + 0.5 - 32.0) <= 4.5;
        let t = TwoTone {
            gray: Gray::new(n, n, 0.0).into(),
            bits: BitGrid::from_fn(n, n, disc),
        };
        let (m, c, st) = walk_all(&t);
        assert_eq!(m.island_count(), 1);
        let cfg = BridgeConfig {
            min_width_px: 3,
            max_width_px: 8,
            ..Default::default()
        };
        let costs = flat_costs(c.len());
        let mut tried = 0;
        for id in (0..c.len()).filter(|&i| st[i].is_some()) {
            // The island asks for more than the maximum: width_for clamps, plan must hold it.
            for want in [8, 20] {
                let members = grow(&c, &st, &costs, id, want, &cfg);
                let p = plan(&t.bits, &t.gray, &c, &st, &members, &cfg, want);
                let mut b = t.bits.clone();
                commit(&mut b, &p.pixels);
                assert_eq!(label(&b).island_count(), 0, "candidate {id}: not joined");
                let (narrowest, widest) = extent_across(&p.pixels, n, 2);
                assert!(
                    widest <= 8.0 + 1.5,
                    "candidate {id} at {:?}, want {want}: {widest:.2} px across, {} members, polygon {:?}",
                    c.pixels[id],
                    members.len(),
                    p.polygon
                );
                assert!(narrowest >= 3.0 - 1.5, "candidate {id}: {narrowest:.2}");
                assert!((3..=8).contains(&p.width), "{}", p.width);
                tried += 1;
            }
        }
        assert!(tried >= 30, "{tried}");
    }

    #[test]
    fn strips_converging_on_a_small_island_are_kept_within_the_maximum() {
        // The ring and disc of `converging_strips_grow_until_the_narrow_end_is_wide_enough`: grown
        // to 8 px at the disc, the strips start 12 or more apart on the ring.
        let t = ring_and_disc();
        let (m, c, st) = walk_all(&t);
        let (ring, disc) = (m.label(40, 14), m.label(40, 40));
        let costs = flat_costs(c.len());
        let cfg = BridgeConfig {
            min_width_px: 3,
            max_width_px: 8,
            ..Default::default()
        };
        let mut tried = 0;
        for id in (0..c.len())
            .filter(|&i| c.node(i) == ring && st[i].as_ref().is_some_and(|s| s.to == disc))
        {
            let members = grow(&c, &st, &costs, id, 8, &cfg);
            let p = plan(&t.bits, &t.gray, &c, &st, &members, &cfg, 8);
            let mut b = t.bits.clone();
            commit(&mut b, &p.pixels);
            assert!(
                label(&b).nodes.len() < m.nodes.len(),
                "{id}: nothing joined"
            );
            let (narrowest, widest) = extent_across(&p.pixels, t.bits.width, 1);
            assert!(
                widest <= 8.0 + 1.5,
                "{id}: {widest:.2} px, polygon {:?}",
                p.polygon
            );
            assert!(narrowest >= 3.0 - 1.5, "{id}: {narrowest:.2} px");
            tried += 1;
        }
        assert!(tried >= 20, "{tried}");
    }

    #[test]
    fn a_wedge_tapering_into_the_cut_measures_thin_and_a_band_does_not() {
        // Material above (y < 5) and a block at the lower right; an outline from the top to the
        // block's corner and to the image's bottom edge tapers to a point there.
        let (w, h) = (40u32, 40u32);
        let bits = BitGrid::from_fn(w, h, |x, y| y < 5 || (x >= 25 && y >= 20));
        let fill = |polygon: &[[f64; 2]]| -> Vec<u32> {
            (0..w * h)
                .filter(|&i| {
                    let (x, y) = (i % w, i / w);
                    !bits.get(x, y) && point_in_ring([x as f64 + 0.5, y as f64 + 0.5], polygon)
                })
                .collect()
        };
        let wedge = [[10.5, 4.5], [25.5, 20.5], [5.5, 40.5], [17.5, 4.5]];
        let m = measure(&bits, &fill(&wedge), &wedge, 9.0);
        assert!(m.narrowest < 4.0, "{m:?}");
        // A straight band 8 px wide from the top material to the block: 8 across everywhere.
        let band = [[26.0, 4.5], [26.0, 30.5], [34.0, 30.5], [34.0, 4.5]];
        let m = measure(&bits, &fill(&band), &band, 9.0);
        assert!((7.5..=8.5).contains(&m.narrowest), "{m:?}");
        assert!((7.5..=9.5).contains(&m.widest), "{m:?}");
    }

    #[test]
    fn at_the_image_edge_the_run_along_the_edge_is_a_width() {
        // A bridge reaching the bottom edge over columns 5..8: the cut on either side meets the
        // sheet beyond the picture 3 px apart, however wide the bridge is above.
        let bits = BitGrid::new(20, 10, false);
        let drawn = |x: i64, y: i64| y >= 6 && (5..8).contains(&x) || y < 6 && (2..12).contains(&x);
        let pixels: Vec<u32> = (0..200u32)
            .filter(|&i| drawn((i % 20) as i64, (i / 20) as i64))
            .collect();
        assert_eq!(along_edges(&bits, &pixels, drawn), 3.0);
        // Running into the image's corner it joins the sheet on two sides: no neck.
        let corner = |x: i64, y: i64| y >= 6 && x < 3;
        let pixels: Vec<u32> = (0..200u32)
            .filter(|&i| corner((i % 20) as i64, (i / 20) as i64))
            .collect();
        assert_eq!(along_edges(&bits, &pixels, corner), f64::INFINITY);
    }

    #[test]
    fn a_bent_single_strip_is_thickened_along_its_path_not_drawn_as_a_straight_band() {
        // An island at the lower right and a block of material between it and the top edge; a
        // path of the fallback search leaves the island to the left, then runs up past the
        // block's left end to the sheet beyond the top edge.
        let (w, h) = (40u32, 40u32);
        let island = |x: u32, y: u32| (30..35).contains(&x) && (30..35).contains(&y);
        let block = |x: u32, y: u32| (10..38).contains(&x) && (15..20).contains(&y);
        let t = TwoTone {
            gray: Gray::new(w, h, 0.0).into(),
            bits: BitGrid::from_fn(w, h, |x, y| island(x, y) || block(x, y)),
        };
        let (m, c, mut st) = walk_all(&t);
        let node = m.label(32, 32);
        let id = c.id_at(&m, node, 30, 30).unwrap();
        let mut pixels: Vec<u32> = (5..30).rev().map(|x| 30 * w + x).collect();
        pixels.extend((0..30).rev().map(|y| y * w + 5));
        st[id] = Some(Strip {
            from: node,
            to: 0,
            pixels: pixels.clone(),
            end: (5, -1),
            intensity: 0.0,
        });
        let cfg = BridgeConfig {
            min_width_px: 5,
            max_width_px: 20,
            ..Default::default()
        };
        let p = plan(&t.bits, &t.gray, &c, &st, &[id], &cfg, 5);
        assert_eq!(p.width, 5);
        // Every pixel drawn lies within the brush (half the width, 2.5 px, round the path's
        // straight runs, whose chords stay within RUN_SLACK of its pixels) of the path.
        for &q in &p.pixels {
            let (x, y) = ((q % w) as f64, (q / w) as f64);
            let near = pixels.iter().any(|&s| {
                let (sx, sy) = ((s % w) as f64, (s / w) as f64);
                (x - sx).hypot(y - sy) <= 2.5 + RUN_SLACK
            });
            assert!(near, "({x}, {y}) is off the path");
        }
        let mut b = t.bits.clone();
        commit(&mut b, &p.pixels);
        let after = label(&b);
        assert_eq!(after.label(32, 32), 0, "the island is joined to the frame");
    }

    #[test]
    fn a_bent_strip_running_slanted_is_thickened_no_wider_than_a_band() {
        // A path of the fallback search leaves an island at the lower right as a 45° staircase
        // (27 steps each way), then bends to run straight up to the sheet beyond the top edge.
        // A square brush on the staircase covered 3 pixels a step, 4.2 a pixel of its length;
        // thickened round its straight runs it covers about what a band 3 px wide does.
        let (w, h) = (40u32, 40u32);
        let island = |x: u32, y: u32| (33..37).contains(&x) && (33..37).contains(&y);
        let t = TwoTone {
            gray: Gray::new(w, h, 0.0).into(),
            bits: BitGrid::from_fn(w, h, island),
        };
        let (m, c, mut st) = walk_all(&t);
        let node = m.label(34, 34);
        let id = c.id_at(&m, node, 33, 33).unwrap();
        let (mut x, mut y) = (32u32, 33u32);
        let mut pixels = vec![y * w + x];
        while x > 6 {
            y -= 1;
            pixels.push(y * w + x);
            x -= 1;
            pixels.push(y * w + x);
        }
        while y > 0 {
            y -= 1;
            pixels.push(y * w + x);
        }
        st[id] = Some(Strip {
            from: node,
            to: 0,
            pixels,
            end: (x as i64, -1),
            intensity: 0.0,
        });
        let cfg = BridgeConfig {
            min_width_px: 3,
            ..Default::default()
        };
        let p = plan(&t.bits, &t.gray, &c, &st, &[id], &cfg, 3);
        assert_eq!(p.width, 3);
        // Its length: the slanted run's diagonal, then the straight run up to the top edge.
        let length = 26.0 * 2f64.sqrt() + 7.0;
        let per = p.pixels.len() as f64 / length;
        assert!(
            (3.0..=3.7).contains(&per),
            "{} pixels, {per:.2} a pixel of length",
            p.pixels.len()
        );
        let mut b = t.bits.clone();
        commit(&mut b, &p.pixels);
        assert_eq!(
            label(&b).label(34, 34),
            0,
            "the island is joined to the frame"
        );
    }

    #[test]
    fn a_band_reaching_a_hollow_edge_is_outlined_from_where_it_first_meets_it() {
        // Material above (y < 5); below, a node whose edge is hollow toward the band (9 px wide,
        // columns 16..25): at y = 30 under it, from y = 26 right beside it. The band's pixels of
        // row 26 are the first to touch it; a flat edge is met at row 30 across the whole band.
        let (w, h) = (41u32, 40u32);
        let nodes = |hollow: bool| {
            BitGrid::from_fn(w, h, move |x, y| {
                !(5..30).contains(&y) || (hollow && y >= 26 && !(16..25).contains(&x))
            })
        };
        for (name, bits, end) in [("hollow", nodes(true), 27.0), ("flat", nodes(false), 31.0)] {
            let gray = Gray::new(w, h, 0.0);
            // The axis from the last pixel of the top node to the first of the bottom one.
            let p = band(&bits, &gray, [[20.5, 4.5], [20.5, 30.5]], 9, 3, 25.0);
            let ys: Vec<f64> = p.polygon.iter().map(|q| q[1]).collect();
            let (top, bottom) = (
                ys.iter().copied().fold(f64::INFINITY, f64::min),
                ys.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            );
            assert_eq!(top, 4.0, "{name}: {:?}", p.polygon);
            assert_eq!(bottom, end, "{name}: {:?}", p.polygon);
            // Drawn, it joins the two nodes across its whole width.
            let mut b = bits.clone();
            commit(&mut b, &p.pixels);
            assert!((16..25).all(|x| (5..30).all(|y| b.get(x, y))), "{name}");
            assert_eq!(label(&b).island_count(), 0, "{name}");
        }
    }
}
