//! A bridge drawn as a straight band of its width between two nodes, each end reaching on into
//! its node, with the outline the check knows it by; and the band outline of a lone straight
//! strip.

use super::draw::{draw, material_at, Plan};
use super::strips::Strip;
use crate::raster::{BitGrid, Gray};
use stencil_geom::ring::dist;

/// A bridge drawn as a straight band `width` px wide from pixel centre `ends[0]` (on one node) to
/// `ends[1]` (on the other): every cut pixel whose centre lies in the solid rectangle. Each end
/// reaches on into its node by up to half the width while the node's material continues, so it
/// meets a round island across its whole width, stopping at the node's far edge; a band is never
/// shorter than `min_width`, which would hang as a flap thinner than a bridge may be.
pub(super) fn band(
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
    // a pixel aside so that exactly `width` rows of centres fall inside. A slanted band's count
    // of centres depends on where the axis falls between them: at 45° through centres a 3 px band
    // takes 5 pixels a row, a quarter pixel aside 4 (its area is 4.24 a row). So a narrow band's
    // axis is also tried a little to either side, and the placing whose pixels darken the
    // picture least is drawn, unless it leaves more slits than the centred one (see `slits`; the
    // first on a tie: an axis-parallel band keeps its rows).
    let base = if width.is_multiple_of(2) { 0.5 } else { 0.0 };
    let half = (width as f64 / 2.0).max(0.75);
    let seal = (min_width as usize).pow(2);
    let mut best: Option<(BandAxis, Vec<u32>, f64)> = None;
    let mut centred_slits = 0;
    let tries = if width <= MAX_SHIFTED_WIDTH {
        &SHIFTS[..]
    } else {
        &SHIFTS[..1]
    };
    for &aside in tries {
        let shift = base + aside;
        let axis = BandAxis {
            a,
            b,
            d,
            len,
            off: [-d[1] * shift, d[0] * shift],
            // At least 1.5 px: the centres within 0.75 px of a segment are 4-connected along it.
            half,
        };
        let (pixels, real) = draw(bits, gray, &axis.outline(back, on), &[], 0, seal);
        match &best {
            None => {
                if tries.len() > 1 {
                    centred_slits = slits(bits, &pixels);
                }
                best = Some((axis, pixels, real));
            }
            Some(b) if real < b.2 - 1e-9 && slits(bits, &pixels) <= centred_slits => {
                best = Some((axis, pixels, real));
            }
            _ => {}
        }
    }
    let (axis, pixels, real) = best.expect("SHIFTS is not empty");
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

/// The cut pixels beside `pixels` (linear indices in raster order, as [`draw`] gives them) that
/// drawing them would leave between material on both sides, across or along: slits a pixel
/// wide, which the check reports as holes or webs too thin to cut. A band set aside from where
/// its ends are may miss a pixel beside a node that the centred one covers; such a placing is
/// passed over (see [`band`]).
fn slits(bits: &BitGrid, pixels: &[u32]) -> usize {
    let (w, h) = (bits.width as i64, bits.height as i64);
    let solid = |x: i64, y: i64| {
        !(0..w).contains(&x)
            || !(0..h).contains(&y)
            || bits.data[(y * w + x) as usize]
            || pixels.binary_search(&((y * w + x) as u32)).is_ok()
    };
    let mut found: Vec<(i64, i64)> = pixels
        .iter()
        .flat_map(|&p| {
            let (x, y) = (p as i64 % w, p as i64 / w);
            [(1, 0), (-1, 0), (0, 1), (0, -1)].map(|(dx, dy)| (x + dx, y + dy))
        })
        .filter(|&(qx, qy)| {
            !solid(qx, qy)
                && ((solid(qx - 1, qy) && solid(qx + 1, qy))
                    || (solid(qx, qy - 1) && solid(qx, qy + 1)))
        })
        .collect();
    found.sort_unstable();
    found.dedup();
    found.len()
}

/// The widest band, px, [`band`] tries a quarter pixel aside: a pixel more or less a row is a
/// fifth of a band this narrow, a twelfth of a 12 px one, where the clean-up after bridging
/// (which reshapes a band's edges) took more than the placing saved (a 1 MP photo at the
/// default settings: bridges 1.37 % of the picture, 1.42 % with every band tried aside).
const MAX_SHIFTED_WIDTH: u32 = 5;

/// Where [`band`] tries its axis, px at right angles to the line between its ends (beside the
/// even width's half pixel): through the ends first, then a quarter pixel either side, never so
/// far that an axis-parallel band gains a row.
const SHIFTS: [f64; 3] = [0.0, 0.25, -0.25];

/// How far the material at `p` continues in direction `dir`, by half pixels, up to half the
/// `width` (at least the half pixel of the end pixel itself): how far a band's end reaches on
/// into its node (see [`band`]).
fn reach(bits: &BitGrid, p: [f64; 2], dir: [f64; 2], width: u32) -> f64 {
    let mut e = 0.5;
    while e < width as f64 / 2.0 {
        if !material_at(bits, [p[0] + dir[0] * (e + 0.5), p[1] + dir[1] * (e + 0.5)]) {
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
    /// reaches: to the node's edge, since the check counts a neck inside a bridge's outline as the
    /// bridge. Where the node's edge is hollow across the band, the outline stops where the band
    /// first meets material in its own or the adjacent rows; material running alongside is no edge.
    fn reported_end(&self, bits: &BitGrid, p: [f64; 2], dir: [f64; 2]) -> f64 {
        let (d, [nx, ny], half) = (self.d, self.off, self.half);
        let limit = (self.len / 2.0 - 0.5).max(0.0);
        let (ux, uy) = (-d[1], d[0]);
        let material = |q: [f64; 2]| material_at(bits, q);
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

/// Whether every pixel of `strip` lies within a pixel of the line through its first and last
/// pixels (a strip as the walks make it, or a search path that was straightened).
pub(super) fn runs_straight(strip: &Strip, image_width: u32) -> bool {
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
/// the segment [`super::outline::plan`] gives it.
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
pub(super) fn band_outline(a: [f64; 2], b: [f64; 2], half: f64) -> Vec<[f64; 2]> {
    let len = dist(a, b).max(1e-9);
    let (nx, ny) = (-(b[1] - a[1]) / len * half, (b[0] - a[0]) / len * half);
    vec![
        [a[0] + nx, a[1] + ny],
        [b[0] + nx, b[1] + ny],
        [b[0] - nx, b[1] - ny],
        [a[0] - nx, a[1] - ny],
    ]
}
