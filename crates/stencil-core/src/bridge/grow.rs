//! Growing a chosen strip into a bridge of the width its island needs, and drawing it.

use super::candidates::Candidates;
use super::cost::StripCost;
use super::strips::Strip;
use super::BridgeConfig;
use crate::raster::{self, BitGrid, Gray};
use stencil_geom::ring::{dist, point_in_ring, signed_area2};

/// The width rule's factor `k`: an island of area `A` gets a bridge `k·√A` wide, a quarter of the
/// side of a square of that area (the paper's ⌈√A / 4⌉).
pub(crate) const WIDTH_PER_SIDE: f64 = 0.25;

/// Width of the bridge between two nodes, in pixels:
///
/// `width = clamp(⌈k·√A⌉, min_width_px, max_width_px)`, `k` = [`WIDTH_PER_SIDE`], where `A` is the
/// area in pixels of the **smaller** of the two nodes (the frame's area counts as infinite, so for a
/// bridge to the frame `A` is the island's area).
///
/// The rule is physical: in millimetres it reads `clamp(k·√A_mm², min_bridge_mm, max_bridge_mm)`,
/// and since `√A` scales with the pixel size, `k·√A` pixels *are* `k·√A_mm²` millimetres; only the
/// range is converted, by the pipeline (`PhysicalConfig::bridge_for`: the material's
/// `min_bridge_mm` plus the check's tracing allowance, rounded up; its `max_bridge_mm`, rounded
/// down). So a picture made four times larger keeps bridges within the same millimetre range
/// instead of getting them four times wider in pixels' worth of clamp.
///
/// Why √A/4: an island hangs from its bridges and its weight grows with its area, while a bridge
/// wider than about a quarter of the island's side would smother its shape. With cardstock
/// (1..4 mm) an island 4 mm across gets 1 mm, one 16 mm across or larger 4 mm.
pub(crate) fn width_for(smaller_area: usize, cfg: &BridgeConfig) -> u32 {
    let w = (WIDTH_PER_SIDE * (smaller_area as f64).sqrt()).ceil() as u32;
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

/// What drawing a bridge would change, computed before committing it.
#[derive(Clone, Debug, Default)]
pub(crate) struct Plan {
    /// Cut pixels (linear indices) it turns into material.
    pub(crate) pixels: Vec<u32>,
    /// Outline: start and end points of the outer strips (or the corners of the straight band it
    /// was drawn as), in pixel coordinates where pixel (x, y) covers [x, x+1) × [y, y+1) (points
    /// are pixel centres).
    pub(crate) polygon: Vec<[f64; 2]>,
    /// Real intensity error: Σ (1 − gray)² over `pixels`.
    pub(crate) real: f64,
    /// Width at right angles to the bridge at its narrowest, in pixels: what the strips span, the
    /// minimum width when they had to be thickened, the band's width when drawn as a band, and no
    /// more than the narrowest run of material measured across the drawn bridge plus one pixel
    /// (the staircase pixel the check's allowance counts too).
    pub(crate) width: u32,
    /// Mean strip length, px.
    pub(crate) length: f64,
}

/// Plan the bridge made of `members`' strips, at least `cfg.min_width_px` and at most
/// `cfg.max_width_px` wide. `want` is the width the island asked for.
///
/// Drawn as every strip pixel plus the cut pixels whose centres lie inside the polygon of the
/// outer strips' end points (kept only where 4-connected to a strip, so the fill can never leave a
/// loose speck), and, when fewer strips than the minimum width could be grown, the strips thickened
/// by a square brush to that width. The result is then measured at right angles to the bridge
/// ([`measure`]). A bridge is drawn instead as a straight band `want` wide (clamped to the range)
/// along its middle strip ([`band`]) when it is
/// - a fan gone wrong: strips leaving a small or sharply curved island cross on their way, or
///   spread so far apart that their outline is no band, and the fill between them would leave
///   loose spokes;
/// - narrower than the minimum somewhere (an outline corner running into a pocket of cut, say at
///   the image's edge, leaves a wedge of material that tapers to nothing);
/// - still wider than the maximum somewhere after dropping outer strips: a bridge wider than the
///   maximum anywhere (strips converging on a small island start far apart, a moderate fan
///   spreads, outer strips bulge out of the outline) first loses outer strips, from the side that
///   narrows it more, so a fan never grows past the material's widest bridge.
///
/// A single strip that does not run straight (a path of the fallback search, which may bend
/// around material on its way) is only thickened to the minimum width: a straight band between
/// its ends could cross the picture elsewhere.
///
/// A moderate fan keeps its filled outline; if that costs more than the strips promised, the
/// support rule halves it.
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
    if n == 1 && !runs_straight(m.strips[0].0, bits.width) {
        // A bent path: its outline is no axis to measure across, nor to draw a band along.
        return thickened(bits, gray, polygon, m.strips[0].0, min_width, m.length);
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

/// A single strip that does not run straight, drawn thickened by a square brush to `min_width`
/// and reported as that wide: a bent path has no axis to measure across nor to draw a band along.
fn thickened(
    bits: &BitGrid,
    gray: &Gray,
    polygon: Vec<[f64; 2]>,
    s: &Strip,
    min_width: u32,
    length: f64,
) -> Plan {
    let brush = ((min_width as f64 - 1.0) / 2.0).ceil().max(0.0) as i64;
    let seal = (min_width as usize).pow(2);
    let (pixels, real) = draw(bits, gray, &polygon, &[s], brush, seal);
    Plan {
        pixels,
        polygon,
        real,
        width: min_width,
        length,
    }
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

/// A bridge drawn as a straight band `width` px wide from pixel centre `ends[0]` (on one node) to
/// `ends[1]` (on the other): every cut pixel whose centre lies in the rectangle, which is solid, so
/// it joins the two nodes and is `width` wide everywhere at right angles to it.
///
/// Each end reaches on into its node, as long as the node's material continues along the axis, by
/// up to half the width: a band ending where it first touches a round island would rest on it by
/// less than its width (a neck between the cut on either side of the joint), while one reaching
/// in meets it across its whole width, or swallows an island smaller than itself. It stops at
/// the node's far edge, so a band never sticks out beyond a thin node. A band is also never
/// shorter than `min_width` along its axis: a short, wide band between two islands would otherwise
/// hang beside them as a flap thinner than a bridge may be.
fn band(
    bits: &BitGrid,
    gray: &Gray,
    ends: [[f64; 2]; 2],
    width: u32,
    min_width: u32,
    length: f64,
) -> Plan {
    let [a, b] = ends;
    let len = dist(a, b);
    let d = if len > 1e-9 {
        [(b[0] - a[0]) / len, (b[1] - a[1]) / len]
    } else {
        [1.0, 0.0]
    };
    let short = ((min_width as f64 - 1.0 - len) / 2.0).max(0.0);
    let back = reach(bits, a, [-d[0], -d[1]], width).max(short);
    let on = reach(bits, b, d, width).max(short);
    // Pixel centres lie at whole offsets from the axis through `a`: an even width is centred half
    // a pixel aside so that exactly `width` rows of centres fall inside.
    let shift = if width.is_multiple_of(2) { 0.5 } else { 0.0 };
    let axis = BandAxis {
        a,
        b,
        d,
        len,
        off: [-d[1] * shift, d[0] * shift],
        // At least 1.5 px: the centres within 0.75 px of a segment are 4-connected along it.
        half: (width as f64 / 2.0).max(0.75),
    };
    let (pixels, real) = draw(
        bits,
        gray,
        &axis.outline(back, on),
        &[],
        0,
        (min_width as usize).pow(2),
    );
    // A band lengthened to `min_width` reports its whole length.
    let reported = |p: [f64; 2], dir: [f64; 2]| {
        if short > 0.0 {
            short
        } else {
            axis.reported_end(bits, p, dir)
        }
    };
    let polygon = axis.outline(reported(a, d), reported(b, [-d[0], -d[1]]));
    Plan {
        pixels,
        polygon,
        real,
        width,
        length,
    }
}

/// How far the material at `p` continues in direction `dir`, by half pixels, up to half the
/// `width` (at least the half pixel of the end pixel itself): how far a band's end reaches on
/// into its node (see [`band`]).
fn reach(bits: &BitGrid, p: [f64; 2], dir: [f64; 2], width: u32) -> f64 {
    let mut e = 0.5;
    while e < width as f64 / 2.0 {
        let q = [p[0] + dir[0] * (e + 0.5), p[1] + dir[1] * (e + 0.5)];
        if !{
            let (x, y) = pixel_of(q);
            bits.get_or_frame(x, y)
        } {
            break;
        }
        e += 0.5;
    }
    e
}

/// The axis of a band [`band`] draws: from `a` to `b`, unit direction `d`, `len` long, its
/// outline offset by `off` (half a pixel aside for an even width) and `half` wide either side.
struct BandAxis {
    a: [f64; 2],
    b: [f64; 2],
    d: [f64; 2],
    len: f64,
    off: [f64; 2],
    half: f64,
}

impl BandAxis {
    /// The band's outline reaching `back` px before `a` and `on` px past `b`.
    fn outline(&self, back: f64, on: f64) -> Vec<[f64; 2]> {
        let (a, b, d, [nx, ny]) = (self.a, self.b, self.d, self.off);
        band_outline(
            [a[0] - d[0] * back + nx, a[1] - d[1] * back + ny],
            [b[0] + d[0] * on + nx, b[1] + d[1] * on + ny],
            self.half,
        )
    }

    /// How far past its end at `p` (the band running on in direction `dir`) the reported outline
    /// reaches: it stops at the node's edge, since the check takes a neck inside a bridge's
    /// outline for part of the bridge, and the nodes' own webs are not. Where a node's edge is
    /// hollow across the band (the inside of a ring seen from within it, a step of the picture's
    /// pixels), its material reaches toward the other end beside the axis: the outline stops
    /// where the band first meets it, in its own rows or the rows just beside it (pixels
    /// 4-adjacent to the band). Material that runs on alongside the band (another island beside
    /// it) is no edge.
    fn reported_end(&self, bits: &BitGrid, p: [f64; 2], dir: [f64; 2]) -> f64 {
        let (d, [nx, ny], half) = (self.d, self.off, self.half);
        let limit = (self.len / 2.0 - 0.5).max(0.0);
        let (ux, uy) = (-d[1], d[0]);
        let material = |q: [f64; 2]| {
            let (x, y) = pixel_of(q);
            bits.get_or_frame(x, y)
        };
        let mut pull = 0.0f64;
        let mut u = -(half + 0.5);
        while u <= half + 0.5 + 1e-9 {
            let q0 = [p[0] + ux * u + nx, p[1] + uy * u + ny];
            if material(q0) {
                let mut e = 0.5;
                while e - 0.5 < limit
                    && material([q0[0] + dir[0] * (e + 0.5), q0[1] + dir[1] * (e + 0.5)])
                {
                    e += 0.5;
                }
                if e - 0.5 < limit {
                    pull = pull.max(e - 0.5);
                }
            }
            u += 1.0;
        }
        0.5 - pull
    }
}

/// The cut pixels a bridge turns into material, in raster order, and Σ (1 − gray)² over them:
/// every pixel of `seeds`, the cut pixels whose centres lie inside `polygon` (kept only where
/// 4-connected to a seed; all of them when there are no seeds, for a convex band), the seeds
/// thickened by a square brush of radius `brush`, and any pocket of the cut of at most `seal`
/// pixels that this closes off (an outer strip that bulges out of the outline, or an outline that
/// meets a hollow edge, would otherwise leave a hole in or beside the bridge, a sliver no material
/// holds).
fn draw(
    bits: &BitGrid,
    gray: &Gray,
    polygon: &[[f64; 2]],
    seeds: &[&Strip],
    brush: i64,
    seal: usize,
) -> (Vec<u32>, f64) {
    let w = bits.width as i64;
    let Some(win) = Window::around(bits, polygon, seeds, brush) else {
        return (Vec::new(), 0.0);
    };
    // 0 = untouched, 1 = fill candidate, 2 = taken.
    let mut state = vec![0u8; win.lw * win.lh];
    let mut stack = Vec::new();
    for s in seeds {
        for &p in &s.pixels {
            let (x, y) = (p as i64 % w, p as i64 / w);
            let l = win.local(x, y);
            if state[l] != 2 {
                state[l] = 2;
                stack.push((x, y));
            }
        }
    }
    let fill = if seeds.is_empty() { 2 } else { 1 };
    if signed_area2(polygon).abs() > 0.0 {
        fill_polygon(&mut state, &win, bits, polygon, fill, stack);
    }
    if brush > 0 {
        for s in seeds {
            for &p in &s.pixels {
                let (x, y) = (p as i64 % w, p as i64 / w);
                for yy in (y - brush).max(win.y0)..=(y + brush).min(win.y1) {
                    for xx in (x - brush).max(win.x0)..=(x + brush).min(win.x1) {
                        state[win.local(xx, yy)] = 2;
                    }
                }
            }
        }
    }
    let (x0, y0, lw) = (win.x0, win.y0, win.lw);
    let cut = |l: usize| !bits.data[((y0 + (l / lw) as i64) * w + x0 + (l % lw) as i64) as usize];
    seal_pockets(&mut state, win.lw, win.lh, seal, cut);
    let mut pixels = Vec::new();
    let mut real = 0.0;
    for y in win.y0..=win.y1 {
        for x in win.x0..=win.x1 {
            if state[win.local(x, y)] == 2 && !bits.get(x as u32, y as u32) {
                let i = (y * w + x) as u32;
                pixels.push(i);
                let d = 1.0 - gray.data[i as usize] as f64;
                real += d * d;
            }
        }
    }
    (pixels, real)
}

/// The box of the image [`draw`] works in: pixels `x0..=x1` × `y0..=y1`, `lw` × `lh`, with
/// local indices row by row.
struct Window {
    x0: i64,
    y0: i64,
    x1: i64,
    y1: i64,
    lw: usize,
    lh: usize,
}

impl Window {
    /// The bounding box of `polygon` and the `seeds`' pixels, widened by the `brush` radius and
    /// clipped to the image; `None` when nothing of it lies in the image.
    fn around(
        bits: &BitGrid,
        polygon: &[[f64; 2]],
        seeds: &[&Strip],
        brush: i64,
    ) -> Option<Window> {
        let w = bits.width as i64;
        let h = bits.height as i64;
        let (mut x0, mut y0, mut x1, mut y1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
        let mut include = |x: i64, y: i64| {
            x0 = x0.min(x);
            y0 = y0.min(y);
            x1 = x1.max(x);
            y1 = y1.max(y);
        };
        for p in polygon {
            let (x, y) = pixel_of(*p);
            include(x, y);
        }
        for s in seeds {
            for &p in &s.pixels {
                include(p as i64 % w, p as i64 / w);
            }
        }
        let (x0, y0) = ((x0 - brush).max(0), (y0 - brush).max(0));
        let (x1, y1) = ((x1 + brush).min(w - 1), (y1 + brush).min(h - 1));
        if x0 > x1 || y0 > y1 {
            return None;
        }
        Some(Window {
            x0,
            y0,
            x1,
            y1,
            lw: (x1 - x0 + 1) as usize,
            lh: (y1 - y0 + 1) as usize,
        })
    }

    /// The local index of image pixel (x, y), which must lie in the box.
    #[inline]
    fn local(&self, x: i64, y: i64) -> usize {
        (y - self.y0) as usize * self.lw + (x - self.x0) as usize
    }
}

/// Mark the cut pixels whose centres lie inside `polygon` as `fill` (1, a candidate, when there
/// are seeds; 2, taken, for a seedless band), then take the candidates 4-connected to the seeds
/// on `stack` (already taken): a fill pixel no strip reaches would be a loose speck.
fn fill_polygon(
    state: &mut [u8],
    win: &Window,
    bits: &BitGrid,
    polygon: &[[f64; 2]],
    fill: u8,
    mut stack: Vec<(i64, i64)>,
) {
    for y in win.y0..=win.y1 {
        for x in win.x0..=win.x1 {
            let l = win.local(x, y);
            if state[l] == 0
                && !bits.get(x as u32, y as u32)
                && point_in_ring([x as f64 + 0.5, y as f64 + 0.5], polygon)
            {
                state[l] = fill;
            }
        }
    }
    // Keep fill pixels 4-connected to a strip.
    while let Some((x, y)) = stack.pop() {
        for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            let (nx, ny) = (x + dx, y + dy);
            if nx < win.x0 || ny < win.y0 || nx > win.x1 || ny > win.y1 {
                continue;
            }
            let l = win.local(nx, ny);
            if state[l] == 1 {
                state[l] = 2;
                stack.push((nx, ny));
            }
        }
    }
}

/// Mark as taken (`state` 2) every pocket of at most `seal` cut pixels that the taken pixels close
/// off inside the `lw` × `lh` box: cut that no longer reaches the box's edge but did before.
/// (A hole of the picture itself never reached it and is left alone.)
fn seal_pockets(state: &mut [u8], lw: usize, lh: usize, seal: usize, cut: impl Fn(usize) -> bool) {
    let (w, h) = (lw as u32, lh as u32);
    let grid = |f: &dyn Fn(usize) -> bool| BitGrid {
        width: w,
        height: h,
        data: (0..lw * lh).map(f).collect(),
    };
    let after = grid(&|l| cut(l) && state[l] != 2);
    let (labels, areas) = raster::components(&after, true);
    let open = raster::touches_border(&labels, w, h, areas.len());
    if open.iter().all(|&o| o) {
        return;
    }
    let (was, was_areas) = raster::components(&grid(&cut), true);
    let was_open = raster::touches_border(&was, w, h, was_areas.len());
    for l in 0..lw * lh {
        let k = labels[l];
        if k != raster::NOT_LABELLED
            && !open[k as usize]
            && areas[k as usize] <= seal
            && was_open[was[l] as usize]
        {
            state[l] = 2;
        }
    }
}

/// Widths across a drawn bridge at right angles to its axis, in pixels (see [`measure`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Across {
    /// The shortest run of material across it (infinite when every run reaches on into material).
    pub(crate) narrowest: f64,
    /// The longest chord of its outline plus one pixel for the pixels' own width, or the longest
    /// run across of the bridge's own pixels if that is longer (outer strips bulging out of the
    /// outline, thickening).
    pub(crate) widest: f64,
    /// The run of material across it at the middle of its axis: infinite when that line leaves
    /// through the bridge's ends into the nodes without meeting the cut on either side (a short,
    /// wide fan whose ends are slanted to its axis), so that no width at right angles to the
    /// bridge can be told there.
    pub(crate) middle: f64,
}

/// The pixel holding point `p`: its coordinates rounded down. Written out rather than with
/// `f64::floor`, which on the baseline x86-64 target is a library call: [`measure`] asks it for
/// hundreds of samples a bridge, and it was a fifth of that function's time.
#[inline]
fn pixel_of(p: [f64; 2]) -> (i64, i64) {
    let down = |v: f64| {
        let t = v as i64;
        t - ((v < t as f64) as i64)
    };
    (down(p[0]), down(p[1]))
}

/// Sample step along a line across a bridge, px.
const SAMPLE_STEP: f64 = 0.25;

/// Points closer than this to an end of the outline may lie in a pixel the fill left out (its
/// centre is outside): they do not anchor a run.
const END_MARGIN: f64 = 0.75;

/// Measure a drawn bridge at right angles to its axis, the line from the middle of its start (the
/// outline's first and last points) to the middle of its end (the second and third), once a pixel
/// along it. At each station the line across is sampled every [`SAMPLE_STEP`] px from `reach` px
/// before the outline's chord to `reach` px past it, in the material after drawing (`bits` plus
/// `pixels`; outside the image is the sheet); a run of material counts when it covers a point of
/// the chord at least [`END_MARGIN`] from the outline's ends, and the station's width is the
/// longest such run (infinite when it runs past `reach`, as where the bridge meets an island at a
/// slant). The narrowest is the smallest station width: a wedge of the fill tapering into a
/// pocket of cut shows there, while the island material beside a slanted end counts as the width
/// it is. The widest is the longest run of the bridge's own pixels on any of these lines, or the
/// outline's widest chord. Runs are measured through the pixel squares, so a band at a slant
/// measures up to a pixel less than its count of strips (the staircase pixel of
/// [`crate::check::allowance_px`]). The station at the middle of the axis is also kept on its
/// own ([`Across::middle`]).
pub(crate) fn measure(bits: &BitGrid, pixels: &[u32], polygon: &[[f64; 2]], reach: f64) -> Across {
    let mut widest = widest(polygon);
    let Some(axis) = Axis::new(polygon) else {
        return Across {
            narrowest: f64::INFINITY,
            widest,
            middle: f64::INFINITY,
        };
    };
    let drawn = Drawn::new(bits, pixels, polygon, reach);
    let scan = Scan {
        bits,
        drawn: &drawn,
        d: axis.d,
        nv: axis.nv,
        ends: [polygon[0], polygon[1], polygon[2], polygon[3]],
        reach,
    };
    let mut narrowest = f64::INFINITY;
    let mut stations: Vec<f64> = (0..)
        .map(|k| axis.tmin + 0.5 + k as f64)
        .take_while(|&t| t <= axis.tmax - 0.5)
        .collect();
    if stations.is_empty() {
        stations.push((axis.tmin + axis.tmax) / 2.0);
    }
    // The middle of the axis, halfway from the middle of the start to the middle of the end: the
    // last station.
    stations.push(axis.mid);
    let at_mid = stations.len() - 1;
    let mut middle = f64::INFINITY;
    for (k, t) in stations.into_iter().enumerate() {
        let Some((lo, hi)) = axis.chord(t) else {
            continue;
        };
        if let Some(b) = scan.station(t, lo, hi, &mut widest) {
            narrowest = narrowest.min(b);
            if k == at_mid {
                middle = b;
            }
        }
    }
    narrowest = narrowest.min(along_edges(bits, pixels, |x, y| {
        drawn.at([x as f64 + 0.5, y as f64 + 0.5])
    }));
    Across {
        narrowest,
        widest,
        middle,
    }
}

/// The pixels a bridge drew, on a local grid over its outline's box plus the `reach` [`measure`]
/// samples to (a lookup per sample point, where a search of the pixel list would not do).
struct Drawn {
    x0: i64,
    y0: i64,
    x1: i64,
    y1: i64,
    lw: usize,
    drawn: Vec<bool>,
}

impl Drawn {
    fn new(bits: &BitGrid, pixels: &[u32], polygon: &[[f64; 2]], reach: f64) -> Drawn {
        let (w, h) = (bits.width as i64, bits.height as i64);
        let m = reach.ceil() as i64 + 2;
        let (bx0, by0, bx1, by1) = polygon.iter().fold(
            (i64::MAX, i64::MAX, i64::MIN, i64::MIN),
            |(x0, y0, x1, y1), p| {
                let (x, y) = pixel_of(*p);
                (x0.min(x), y0.min(y), x1.max(x), y1.max(y))
            },
        );
        let (x0, y0) = ((bx0 - m).max(0), (by0 - m).max(0));
        let (x1, y1) = ((bx1 + m).min(w - 1), (by1 + m).min(h - 1));
        let lw = (x1 - x0 + 1).max(0) as usize;
        let mut drawn = vec![false; lw * (y1 - y0 + 1).max(0) as usize];
        for &p in pixels {
            let (x, y) = (p as i64 % w, p as i64 / w);
            if (x0..=x1).contains(&x) && (y0..=y1).contains(&y) {
                drawn[(y - y0) as usize * lw + (x - x0) as usize] = true;
            }
        }
        Drawn {
            x0,
            y0,
            x1,
            y1,
            lw,
            drawn,
        }
    }

    /// Whether the pixel holding point `p` was drawn (false outside the grid).
    #[inline]
    fn at(&self, p: [f64; 2]) -> bool {
        let (x, y) = pixel_of(p);
        (self.x0..=self.x1).contains(&x)
            && (self.y0..=self.y1).contains(&y)
            && self.drawn[(y - self.y0) as usize * self.lw + (x - self.x0) as usize]
    }
}

/// What [`measure`] samples a line across a bridge with: the material (`bits` plus the `drawn`
/// pixels), the axis's unit vectors along (`d`) and across (`nv`), the outline `[s0, e0, e1, s1]`
/// whose ends keep runs from anchoring near them, and how far past the chord to sample.
struct Scan<'a> {
    bits: &'a BitGrid,
    drawn: &'a Drawn,
    d: [f64; 2],
    nv: [f64; 2],
    ends: [[f64; 2]; 4],
    reach: f64,
}

impl Scan<'_> {
    /// Whether a run of material covering point `p` of the chord counts: it lies at least
    /// [`END_MARGIN`] from both ends of the outline.
    #[inline]
    fn anchor(&self, p: [f64; 2]) -> bool {
        let [s0, e0, e1, s1] = self.ends;
        seg_dist(p, s0, s1) >= END_MARGIN && seg_dist(p, e0, e1) >= END_MARGIN
    }

    /// The width at station `t` along the axis, whose chord runs from `lo` to `hi` across: the
    /// longest anchored run of material on the line across, sampled every [`SAMPLE_STEP`] px from
    /// `reach` before the chord to `reach` past it (infinite when it runs past either end);
    /// `None` when no run is anchored. Raises `widest` to the longest run of the bridge's own
    /// pixels on the line.
    fn station(&self, t: f64, lo: f64, hi: f64, widest: &mut f64) -> Option<f64> {
        let (d, nv) = (self.d, self.nv);
        let u0 = lo - self.reach;
        let count = ((hi - lo + 2.0 * self.reach) / SAMPLE_STEP).ceil() as usize + 1;
        let mut best: Option<f64> = None;
        // The current run: samples, whether it began at the first sample, whether anchored.
        let (mut run, mut open, mut anchored) = (0usize, false, false);
        // The current run of the bridge's own pixels.
        let mut own = 0usize;
        for i in 0..=count {
            let u = u0 + i as f64 * SAMPLE_STEP;
            let p = [t * d[0] + u * nv[0], t * d[1] + u * nv[1]];
            let drawn = i < count && self.drawn.at(p);
            if drawn {
                own += 1;
                *widest = widest.max(own as f64 * SAMPLE_STEP);
            } else {
                own = 0;
            }
            if drawn
                || (i < count && {
                    let (x, y) = pixel_of(p);
                    self.bits.get_or_frame(x, y)
                })
            {
                if run == 0 {
                    open = i == 0;
                    anchored = false;
                }
                run += 1;
                // The distances to the ends are asked only until one point anchors the run.
                anchored = anchored || ((lo..=hi).contains(&u) && self.anchor(p));
                continue;
            }
            if run > 0 && anchored {
                let len = if open || i == count {
                    f64::INFINITY
                } else {
                    run as f64 * SAMPLE_STEP
                };
                best = Some(best.map_or(len, |b: f64| b.max(len)));
            }
            run = 0;
        }
        best
    }
}

/// Where a bridge reaches the image's edge, the cut on either side of it meets the sheet beyond
/// the picture there: the material between them along the edge is a width of the bridge too
/// (however it is slanted). The shortest run of material along an edge row or column through a
/// pixel the bridge drew (`drawn`), in pixels; infinite when there is none, or when the run turns
/// the image's corner.
fn along_edges(bits: &BitGrid, pixels: &[u32], drawn: impl Fn(i64, i64) -> bool) -> f64 {
    let (w, h) = (bits.width as i64, bits.height as i64);
    let material = |x: i64, y: i64| bits.get(x as u32, y as u32) || drawn(x, y);
    let mut narrowest = f64::INFINITY;
    // Each edge as (fixed coordinate, is a column, length).
    for (fixed, column, n) in [
        (0, true, h),
        (w - 1, true, h),
        (0, false, w),
        (h - 1, false, w),
    ] {
        let at = |k: i64| if column { (fixed, k) } else { (k, fixed) };
        let mut done = i64::MIN;
        for &p in pixels {
            let (x, y) = (p as i64 % w, p as i64 / w);
            let (f, k) = if column { (x, y) } else { (y, x) };
            if f != fixed || k <= done {
                continue;
            }
            let (mut lo, mut hi) = (k, k);
            while lo > 0 && {
                let (x, y) = at(lo - 1);
                material(x, y)
            } {
                lo -= 1;
            }
            while hi < n - 1 && {
                let (x, y) = at(hi + 1);
                material(x, y)
            } {
                hi += 1;
            }
            done = hi;
            if lo > 0 && hi < n - 1 {
                narrowest = narrowest.min((hi - lo + 1) as f64);
            }
        }
    }
    narrowest
}

/// A bridge outline `[s0, e0, e1, s1]` in coordinates along its axis (from the middle of its start
/// `s0`–`s1` to the middle of its end `e0`–`e1`) and across it.
struct Axis {
    /// Unit vectors along and across.
    d: [f64; 2],
    nv: [f64; 2],
    /// The outline's points as (along, across).
    q: Vec<(f64, f64)>,
    tmin: f64,
    tmax: f64,
    /// Where along it the middle of the axis lies.
    mid: f64,
}

impl Axis {
    /// `None` when the start and the end have the same middle.
    fn new(polygon: &[[f64; 2]]) -> Option<Axis> {
        let (a, b) = (
            halfway(polygon[0], polygon[3]),
            halfway(polygon[1], polygon[2]),
        );
        let len = dist(a, b);
        if len < 1e-9 {
            return None;
        }
        let d = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
        let nv = [-d[1], d[0]];
        let q: Vec<(f64, f64)> = polygon
            .iter()
            .map(|p| (p[0] * d[0] + p[1] * d[1], p[0] * nv[0] + p[1] * nv[1]))
            .collect();
        let (tmin, tmax) = q.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| {
            (lo.min(p.0), hi.max(p.0))
        });
        let m = halfway(a, b);
        Some(Axis {
            d,
            nv,
            q,
            tmin,
            tmax,
            mid: m[0] * d[0] + m[1] * d[1],
        })
    }

    /// The outline's extent across the axis at `t` along it.
    fn chord(&self, t: f64) -> Option<(f64, f64)> {
        let q = &self.q;
        let (mut lo, mut hi) = (f64::MAX, f64::MIN);
        for i in 0..q.len() {
            let (p, r) = (q[i], q[(i + 1) % q.len()]);
            if (p.0 - t) * (r.0 - t) > 0.0 {
                continue;
            }
            if (r.0 - p.0).abs() < 1e-12 {
                lo = lo.min(p.1).min(r.1);
                hi = hi.max(p.1).max(r.1);
            } else {
                let u = p.1 + (r.1 - p.1) * (t - p.0) / (r.0 - p.0);
                lo = lo.min(u);
                hi = hi.max(u);
            }
        }
        (lo <= hi).then_some((lo, hi))
    }
}

/// The widest a bridge outline `[s0, e0, e1, s1]` is at right angles to its axis, plus one pixel
/// for the pixels' own width (the chord's length is piecewise linear along the axis, so its
/// maximum is at a corner).
fn widest(polygon: &[[f64; 2]]) -> f64 {
    let Some(axis) = Axis::new(polygon) else {
        return dist(polygon[0], polygon[3]).max(dist(polygon[1], polygon[2])) + 1.0;
    };
    axis.q
        .iter()
        .filter_map(|p| axis.chord(p.0.clamp(axis.tmin + 1e-9, axis.tmax - 1e-9)))
        .map(|(lo, hi)| hi - lo)
        .fold(0.0, f64::max)
        + 1.0
}

fn halfway(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0]
}

/// Distance from `p` to the segment from `a` to `b`.
fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    dist(p, [a[0] + t * dx, a[1] + t * dy])
}

/// Turn the planned pixels into material; returns those that were still cut (a pixel an earlier
/// bridge already took counts for that one).
pub(crate) fn commit(bits: &mut BitGrid, pixels: &[u32]) -> Vec<u32> {
    let mut turned = Vec::new();
    for &p in pixels {
        let cell = &mut bits.data[p as usize];
        if !*cell {
            *cell = true;
            turned.push(p);
        }
    }
    turned
}

/// Drawings of a bridge's outline at most, each with an outer strip fewer, before it is drawn as a
/// band for being too wide.
const MAX_TRIMS: usize = 4;

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

/// Whether every pixel of `strip` lies within a pixel of the line through its first and last
/// pixels (a strip as the walks make it, or a search path that was straightened).
fn runs_straight(strip: &Strip, image_width: u32) -> bool {
    let xy = |p: u32| [(p % image_width) as f64, (p / image_width) as f64];
    let (Some(&first), Some(&last)) = (strip.pixels.first(), strip.pixels.last()) else {
        return true;
    };
    let (a, b) = (xy(first), xy(last));
    let len = dist(a, b);
    let off = |q: [f64; 2]| ((q[0] - a[0]) * (b[1] - a[1]) - (q[1] - a[1]) * (b[0] - a[0])).abs();
    len == 0.0 || strip.pixels.iter().all(|&p| off(xy(p)) <= len)
}

/// The outline of a bridge drawn as one thickened strip (a path of the fallback search), when that
/// strip runs straight (every pixel within a pixel of the line through its first and last): the
/// band `width` wide from its candidate `start` to where it lands, as a fan is drawn, so that the
/// check knows it for a bridge. The band lies inside the thickened pixels (the brush reaches
/// `⌈(width − 1)/2⌉ + ½` px either side of the strip). `None` for a bent strip, whose outline stays
/// the segment [`plan`] gives it.
pub(crate) fn straight_band(
    start: (u32, u32),
    strip: &Strip,
    width: u32,
    image_width: u32,
) -> Option<Vec<[f64; 2]>> {
    if strip.pixels.is_empty() || !runs_straight(strip, image_width) {
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
        // Every pixel drawn lies within the brush (2 px) of the path.
        for &q in &p.pixels {
            let (x, y) = ((q % w) as i64, (q / w) as i64);
            let near = pixels.iter().any(|&s| {
                let (sx, sy) = ((s % w) as i64, (s / w) as i64);
                (x - sx).abs().max((y - sy).abs()) <= 2
            });
            assert!(near, "({x}, {y}) is off the path");
        }
        let mut b = t.bits.clone();
        commit(&mut b, &p.pixels);
        let after = label(&b);
        assert_eq!(after.label(32, 32), 0, "the island is joined to the frame");
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
