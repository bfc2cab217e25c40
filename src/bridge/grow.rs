//! Growing a chosen strip into a bridge of the width its island needs, and drawing it.

use super::candidates::Candidates;
use super::cost::StripCost;
use super::strips::Strip;
use super::BridgeConfig;
use crate::raster::{BitGrid, Gray};

/// Width of the bridge between two nodes, in pixels:
///
/// `width = clamp(⌈√A / 4⌉, min_width_px, max_width_px)`, where `A` is the area in pixels of the
/// **smaller** of the two nodes (the frame's area counts as infinite, so for a bridge to the frame
/// `A` is the island's area).
///
/// Why: an island hangs from its bridges; its weight grows with its area and a bridge's strength
/// with its width, while a bridge wider than about a quarter of the island's side would smother its
/// shape. √A/4 is a quarter of the side of a square of that area: a 10×10 px island gets the
/// minimum, a 100×100 px island 25 px (clamped to the maximum).
pub fn width_for(smaller_area: usize, cfg: &BridgeConfig) -> u32 {
    let w = ((smaller_area as f64).sqrt() / 4.0).ceil() as u32;
    w.clamp(
        cfg.min_width_px.max(1),
        cfg.max_width_px.max(cfg.min_width_px.max(1)),
    )
}

/// Grow from candidate `id` strip by strip, always adding the cheaper of the two neighbouring
/// strips along the border (weighted normalised ΣI + L^α) that reach the same node, until the
/// bridge is `width` px wide or no neighbour can be added. Returns the members in chain order.
///
/// Width is measured, not counted: on a slanted edge the border pixels form a staircase, so `n`
/// strips there span only about n/√2 px. The bridge grows until it has at least `width` strips
/// and both its start and its end are `width` px across, measured at right angles to the bridge
/// ([`band_width`]; strips converging on a smaller island land closer together than they start),
/// but never past 4 × `width` strips.
pub fn grow(
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
    // band of this width, and `plan` thickens or straightens what there is.
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
const ACROSS_SLACK: f64 = 0.05;

/// The narrowest width across a bridge made of `members` (in chain order), in pixels: the spread
/// of the outer strips' start points and of their end points, measured at right angles to the
/// bridge's mean direction, plus one pixel for the strips' own width; the smaller of the two ends.
pub fn band_width(c: &Candidates, strips: &[Option<Strip>], members: &[usize]) -> f64 {
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
    let spread = |pick: fn(&([f64; 2], [f64; 2])) -> [f64; 2]| {
        let proj = ends.iter().map(|e| {
            let p = pick(e);
            p[0] * nx + p[1] * ny
        });
        let (lo, hi) = proj.fold((f64::MAX, f64::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)));
        hi - lo + 1.0
    };
    spread(|e| e.0).min(spread(|e| e.1))
}

/// What drawing a bridge would change, computed before committing it.
#[derive(Clone, Debug, Default)]
pub struct Plan {
    /// Cut pixels (linear indices) it turns into material.
    pub pixels: Vec<u32>,
    /// Outline: start and end points of the outer strips, in pixel coordinates where pixel (x, y)
    /// covers [x, x+1) × [y, y+1) (points are pixel centres).
    pub polygon: Vec<[f64; 2]>,
    /// Real intensity error: Σ (1 − gray)² over `pixels`.
    pub real: f64,
    /// Achieved width in pixels (strips, or the minimum width when it had to be thickened).
    pub width: u32,
    /// Mean strip length, px.
    pub length: f64,
}

/// Plan the bridge made of `members`' strips: every strip pixel, plus the cut pixels whose centres
/// lie inside the polygon of the outer strips' end points (kept only where 4-connected to a strip,
/// so the fill can never leave a loose speck), and, when fewer strips than `min_width` could be
/// grown, the strips thickened by a square brush to that width. `want` is the width the island
/// asked for: a fanning bridge (see below) is drawn that wide. `max_width`: an outline wider than
/// this at either end is drawn as a straight band of `want` instead (a fan never grows past the
/// material's widest bridge).
#[allow(clippy::too_many_arguments)]
pub fn plan(
    bits: &BitGrid,
    gray: &Gray,
    c: &Candidates,
    strips: &[Option<Strip>],
    members: &[usize],
    min_width: u32,
    want: u32,
    max_width: u32,
) -> Plan {
    let w = bits.width as i64;
    let h = bits.height as i64;
    let member_strips: Vec<(&Strip, (u32, u32))> = members
        .iter()
        .filter_map(|&m| strips[m].as_ref().map(|s| (s, c.pixels[m])))
        .collect();
    let (Some(first), Some(last)) = (member_strips.first(), member_strips.last()) else {
        return Plan::default();
    };
    let centre = |(x, y): (i64, i64)| [x as f64 + 0.5, y as f64 + 0.5];
    let start = |p: (u32, u32)| centre((p.0 as i64, p.1 as i64));
    let mut polygon = vec![
        start(first.1),
        centre(first.0.end),
        centre(last.0.end),
        start(last.1),
    ];
    let n = member_strips.len();
    let target = want.max(min_width);
    // A fan gone wrong: strips leaving a small or sharply curved island cross on their way, or spread
    // so far apart that their outline is no band, and the fill between them would leave loose
    // spokes. Such a bridge is drawn instead as its middle strip thickened to the full width: a
    // straight solid band. (A moderate fan keeps its filled outline; if that costs more than the
    // strips promised, the support rule halves it.)
    let fan = n > 1
        && (crosses(&polygon)
            || diverge(&polygon) > MAX_FAN_DEGREES.to_radians()
            || spread(&member_strips) > MAX_FAN_DEGREES.to_radians()
            || dist(polygon[1], polygon[2]) > 4.0 * (dist(polygon[0], polygon[3]) + target as f64)
            || dist(polygon[1], polygon[2]).max(dist(polygon[0], polygon[3]))
                > max_width.max(target) as f64 + 1.0);
    let (member_strips, across) = if fan {
        let mid = member_strips[n / 2];
        polygon = band_outline(start(mid.1), centre(mid.0.end), target as f64 / 2.0);
        (vec![mid], 1.0)
    } else {
        (member_strips, band_width(c, strips, members))
    };
    let goal = if fan { target } else { min_width };

    // Local grid over the bounding box of the polygon and the strips (plus a brush margin).
    let brush = if across < goal as f64 - ACROSS_SLACK {
        ((goal as f64 - across) / 2.0).ceil() as i64
    } else {
        0
    };
    let (mut x0, mut y0, mut x1, mut y1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
    let mut include = |x: i64, y: i64| {
        x0 = x0.min(x);
        y0 = y0.min(y);
        x1 = x1.max(x);
        y1 = y1.max(y);
    };
    for p in &polygon {
        include(p[0].floor() as i64, p[1].floor() as i64);
    }
    for (s, _) in &member_strips {
        for &p in &s.pixels {
            include(p as i64 % w, p as i64 / w);
        }
    }
    let (x0, y0) = ((x0 - brush).max(0), (y0 - brush).max(0));
    let (x1, y1) = ((x1 + brush).min(w - 1), (y1 + brush).min(h - 1));
    if x0 > x1 || y0 > y1 {
        return Plan::default();
    }
    let (lw, lh) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
    // 0 = untouched, 1 = fill candidate, 2 = taken.
    let mut state = vec![0u8; lw * lh];
    let local = |x: i64, y: i64| (y - y0) as usize * lw + (x - x0) as usize;
    let mut stack = Vec::new();
    for (s, _) in &member_strips {
        for &p in &s.pixels {
            let (x, y) = (p as i64 % w, p as i64 / w);
            let l = local(x, y);
            if state[l] != 2 {
                state[l] = 2;
                stack.push((x, y));
            }
        }
    }
    if polygon_area(&polygon).abs() > 0.0 {
        for y in y0..=y1 {
            for x in x0..=x1 {
                let l = local(x, y);
                if state[l] == 0
                    && !bits.get(x as u32, y as u32)
                    && inside(&polygon, x as f64 + 0.5, y as f64 + 0.5)
                {
                    state[l] = 1;
                }
            }
        }
        // Keep fill pixels 4-connected to a strip.
        while let Some((x, y)) = stack.pop() {
            for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                let (nx, ny) = (x + dx, y + dy);
                if nx < x0 || ny < y0 || nx > x1 || ny > y1 {
                    continue;
                }
                let l = local(nx, ny);
                if state[l] == 1 {
                    state[l] = 2;
                    stack.push((nx, ny));
                }
            }
        }
    }
    if brush > 0 {
        for (s, _) in &member_strips {
            for &p in &s.pixels {
                let (x, y) = (p as i64 % w, p as i64 / w);
                for yy in (y - brush).max(y0)..=(y + brush).min(y1) {
                    for xx in (x - brush).max(x0)..=(x + brush).min(x1) {
                        state[local(xx, yy)] = 2;
                    }
                }
            }
        }
    }
    let mut pixels = Vec::new();
    let mut real = 0.0;
    for y in y0..=y1 {
        for x in x0..=x1 {
            if state[local(x, y)] == 2 && !bits.get(x as u32, y as u32) {
                let i = (y * w + x) as u32;
                pixels.push(i);
                let d = 1.0 - gray.data[i as usize] as f64;
                real += d * d;
            }
        }
    }
    let n = member_strips.len();
    Plan {
        pixels,
        polygon,
        real,
        width: if brush > 0 {
            goal
        } else {
            (across + ACROSS_SLACK).floor() as u32
        },
        length: member_strips
            .iter()
            .map(|(s, _)| s.len() as f64)
            .sum::<f64>()
            / n as f64,
    }
}

/// Turn the planned pixels into material; returns how many were still cut (a pixel an earlier
/// bridge already took counts for that one).
pub fn commit(bits: &mut BitGrid, pixels: &[u32]) -> usize {
    let mut turned = 0;
    for &p in pixels {
        let cell = &mut bits.data[p as usize];
        if !*cell {
            *cell = true;
            turned += 1;
        }
    }
    turned
}

/// Outer strips whose directions differ by more than this are a fan to be redrawn as a band.
const MAX_FAN_DEGREES: f64 = 60.0;

/// The angle between the first and the last strip of the outline `[s0, e0, e1, s1]`, radians.
fn diverge(q: &[[f64; 2]]) -> f64 {
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

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
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
fn crosses(q: &[[f64; 2]]) -> bool {
    fn side(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
        (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
    }
    let cut = |a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]| {
        side(a, b, c) * side(a, b, d) < 0.0 && side(c, d, a) * side(c, d, b) < 0.0
    };
    q.len() == 4 && (cut(q[0], q[1], q[2], q[3]) || cut(q[1], q[2], q[3], q[0]))
}

/// The outline of a bridge drawn as one thickened strip (a path of the fallback search), when that
/// strip runs straight (every pixel within a pixel of the line through its first and last): the
/// band `width` wide from its candidate `start` to where it lands, as a fan is drawn, so that the
/// check knows it for a bridge. The band lies inside the thickened pixels (the brush reaches
/// `⌈(width − 1)/2⌉ + ½` px either side of the strip). `None` for a bent strip, whose outline stays
/// the segment [`plan`] gives it.
pub fn straight_band(
    start: (u32, u32),
    strip: &Strip,
    width: u32,
    image_width: u32,
) -> Option<Vec<[f64; 2]>> {
    let xy = |p: u32| [(p % image_width) as f64, (p / image_width) as f64];
    let (a, b) = (xy(*strip.pixels.first()?), xy(*strip.pixels.last()?));
    let len = dist(a, b);
    let off = |q: [f64; 2]| ((q[0] - a[0]) * (b[1] - a[1]) - (q[1] - a[1]) * (b[0] - a[0])).abs();
    if len > 0.0 && strip.pixels.iter().any(|&p| off(xy(p)) > len) {
        return None;
    }
    let centre = |x: f64, y: f64| [x + 0.5, y + 0.5];
    Some(band_outline(
        centre(start.0 as f64, start.1 as f64),
        centre(strip.end.0 as f64, strip.end.1 as f64),
        width as f64 / 2.0,
    ))
}

/// The rectangle of half-width `half` around the segment from `a` to `b`.
fn band_outline(a: [f64; 2], b: [f64; 2], half: f64) -> Vec<[f64; 2]> {
    let len = dist(a, b).max(1e-9);
    let (nx, ny) = (-(b[1] - a[1]) / len * half, (b[0] - a[0]) / len * half);
    vec![
        [a[0] + nx, a[1] + ny],
        [b[0] + nx, b[1] + ny],
        [b[0] - nx, b[1] - ny],
        [a[0] - nx, a[1] - ny],
    ]
}

fn polygon_area(p: &[[f64; 2]]) -> f64 {
    let n = p.len();
    (0..n)
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        / 2.0
}

/// Even-odd point-in-polygon test.
fn inside(p: &[[f64; 2]], x: f64, y: f64) -> bool {
    let n = p.len();
    let mut c = false;
    let mut j = n - 1;
    for i in 0..n {
        let (a, b) = (p[i], p[j]);
        if (a[1] > y) != (b[1] > y) && x < (b[0] - a[0]) * (y - a[1]) / (b[1] - a[1]) + a[0] {
            c = !c;
        }
        j = i;
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bridge::cost::Norm;
    use crate::bridge::{candidates, strips};
    use crate::islands::label;
    use crate::raster::TwoTone;

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

    #[test]
    fn point_in_polygon() {
        let sq = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]];
        assert!(inside(&sq, 2.0, 2.0));
        assert!(!inside(&sq, 5.0, 2.0));
        assert_eq!(polygon_area(&sq), 16.0);
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
        let t = TwoTone { bits, gray };
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
        let p = plan(&t.bits, &t.gray, &c, &st, &members, 3, 3, 40);
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
            assert!(strip_px.contains(&q) || inside(&p.polygon, x, y), "{q}");
            real += (1.0 - t.gray.data[q as usize] as f64).powi(2);
        }
        assert!(p.pixels.len() >= 12);
        assert!((p.real - real).abs() < 1e-9);
    }

    #[test]
    fn converging_strips_grow_until_the_narrow_end_is_wide_enough() {
        // A ring island around a disc island: strips from the ring's inner edge converge on the
        // disc, so 8 strips are 8 px apart where they start but closer where they land.
        let n = 81u32;
        let r = |x: u32, y: u32| (x as f64 + 0.5 - 40.5).hypot(y as f64 + 0.5 - 40.5);
        let bits = BitGrid::from_fn(n, n, |x, y| {
            let d = r(x, y);
            d <= 8.0 || (22.0..=30.0).contains(&d) || d >= 37.0
        });
        let t = TwoTone {
            gray: Gray::new(n, n, 0.0),
            bits,
        };
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
        let costs = vec![
            Some(StripCost {
                intensity: 1.0,
                length: 1.0
            });
            c.len()
        ];
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
        let p = plan(&t.bits, &t.gray, &c, &st, &members, 3, 8, 40);
        assert!(p.width >= 8);
    }

    #[test]
    fn a_lone_strip_is_thickened_to_the_minimum_width() {
        // A one-pixel island: one strip per side; the bridge must still be 3 wide.
        let bits = BitGrid::from_fn(9, 9, |x, y| y == 0 || (x == 4 && y == 4));
        let t = TwoTone {
            gray: Gray::new(9, 9, 0.0),
            bits,
        };
        let (_, c, st) = walk_all(&t);
        let cfg = BridgeConfig::default();
        let costs = vec![None; c.len()];
        let members = grow(&c, &st, &costs, 0, 3, &cfg);
        assert_eq!(members.len(), 1);
        let p = plan(&t.bits, &t.gray, &c, &st, &members, 3, 3, 40);
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
}
