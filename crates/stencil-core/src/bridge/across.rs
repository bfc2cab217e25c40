//! Measuring a drawn bridge at right angles to its axis: its narrowest and widest runs of
//! material across, station by station, and where it reaches the image's edge, the run along
//! that edge. What the outline and band drawings check a bridge's width with.

use super::draw::{material_at, pixel_of};
use crate::raster::BitGrid;
use stencil_geom::ring::{dist, seg_dist};

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

/// Sample step along a line across a bridge, px.
const SAMPLE_STEP: f64 = 0.25;

/// Points closer than this to an end of the outline may lie in a pixel the fill left out (its
/// centre is outside): they do not anchor a run.
const END_MARGIN: f64 = 0.75;

/// Measure a drawn bridge at right angles to its axis (middle of its start, the outline's first
/// and last points, to middle of its end), once a pixel along it. At each station the line across
/// is sampled every [`SAMPLE_STEP`] px within `reach` of the chord, in the material after drawing
/// (outside the image is the sheet); the station's width is the longest run of material covering
/// the chord at least [`END_MARGIN`] from its ends (infinite past `reach`). The narrowest is the
/// least station width, the widest the longest run of the bridge's own pixels or the outline's
/// widest chord; a slanted band measures up to a pixel less (see [`crate::check::allowance_px`]).
/// The middle station is kept too ([`Across::middle`]).
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
            if drawn || (i < count && material_at(self.bits, p)) {
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
pub(super) fn along_edges(bits: &BitGrid, pixels: &[u32], drawn: impl Fn(i64, i64) -> bool) -> f64 {
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
pub(super) fn widest(polygon: &[[f64; 2]]) -> f64 {
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
