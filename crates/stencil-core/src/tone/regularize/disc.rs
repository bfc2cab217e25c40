//! The disc the regularisation measures width with: its span, the lattice its centres sit on,
//! the search order from a centre outward and the rows it paints.

/// The disc: `span` pixels across, centred on a pixel (odd span) or on a pixel corner (even
/// span), holding the pixels whose centres lie within `span / 2` of its centre.
#[derive(Clone, Copy, Debug)]
pub(super) struct Disc {
    pub(super) span: u32,
    /// Squared radius, `(span / 2)²` and a hair, so pixels exactly on the circle count.
    pub(super) r2: f32,
}

impl Disc {
    pub(super) fn for_width(px: f64) -> Disc {
        let span = if px.is_finite() && px > 1.0 {
            (px - 1e-6).ceil().min(u32::MAX as f64 / 4.0) as u32
        } else {
            1
        };
        let r = span as f32 / 2.0;
        Disc {
            span,
            r2: r * r + 1e-3,
        }
    }
    /// Centres sit on pixel corners: the lattice is offset by half a pixel.
    pub(super) fn on_corners(&self) -> bool {
        self.span.is_multiple_of(2)
    }
    /// How far a disc's pixels reach from its centre pixel, in whole pixels.
    pub(super) fn reach(&self) -> i64 {
        self.span as i64 / 2
    }
}

/// Offsets from a lattice point (a pixel, or a pixel corner for an even span) to the pixels its
/// disc holds, nearest first, with their squared distances: the search for how deep a lattice
/// point lies in its tone.
pub(super) fn ring(disc: Disc) -> Vec<(i64, i64, f32)> {
    let k = disc.reach() + 1;
    let half = if disc.on_corners() { 0.5f32 } else { 0.0 };
    let mut v: Vec<(i64, i64, f32)> = (-k..=k)
        .flat_map(|dy| (-k..=k).map(move |dx| (dx, dy)))
        .map(|(dx, dy)| {
            let (ex, ey) = (dx as f32 + half, dy as f32 + half);
            (dx, dy, ex * ex + ey * ey)
        })
        .filter(|&(_, _, d)| d <= disc.r2)
        .collect();
    v.sort_by(|a, b| a.2.total_cmp(&b.2));
    v
}

/// Where a lattice point's search of `ring` may start, per [`Work::depth2`] value of a neighbour
/// one pixel away in the same tone (`u16::MAX` last). A point whose neighbour lies `f` from the
/// other tone lies at least `f − 1` from it, so the ring's entries nearer than that (with a margin
/// for rounding) are of its own tone, and skipping them finds the same first entry.
pub(super) fn ring_from(ring: &[(i64, i64, f32)], disc: Disc) -> Vec<usize> {
    let max = (2.0 * disc.r2).ceil() as usize + 1;
    let from = |f: f64| {
        let lower = f - 1.0 - 1e-3;
        if lower <= 0.0 {
            0
        } else {
            ring.partition_point(|e| (e.2 as f64) < lower * lower)
        }
    };
    let mut out: Vec<usize> = (0..=max).map(|v| from((v as f64 / 2.0).sqrt())).collect();
    // Past the radius: the neighbour lies farther than the disc's radius from the other tone.
    out.push(from((disc.r2 as f64).sqrt()));
    out
}

/// Per candidate centre of a pixel's widening (the pixel, or its corners in [`CORNERS`] order),
/// the rows of pixels that centre's disc holds: `(dy, a, b)`, offsets `a..=b` along row `dy`
/// from the pixel.
pub(super) fn paint(disc: Disc) -> Vec<Vec<(i64, i64, i64)>> {
    let k = disc.reach() + 1;
    let centres: Vec<(f32, f32)> = if disc.on_corners() {
        CORNERS
            .iter()
            .map(|&(ox, oy)| (ox as f32 - 0.5, oy as f32 - 0.5))
            .collect()
    } else {
        vec![(0.0, 0.0)]
    };
    centres
        .into_iter()
        .map(|(cx, cy)| {
            (-k..=k)
                .filter_map(|dy| {
                    let inside = |dx: i64| {
                        let (ex, ey) = (dx as f32 - cx, dy as f32 - cy);
                        ex * ex + ey * ey <= disc.r2
                    };
                    let a = (-k..=k).find(|&dx| inside(dx))?;
                    let b = (-k..=k).rev().find(|&dx| inside(dx))?;
                    Some((dy, a, b))
                })
                .collect()
        })
        .collect()
}

/// The order in which a pixel's corners are tried as the centre of its widening.
pub(super) const CORNERS: [(i64, i64); 4] = [(0, 0), (1, 0), (0, 1), (1, 1)];
