//! Weeding aids, as sign-making software cuts them (CutStudio's and SignCut's weed border and
//! weeding lines): a box around the job, so the sheet around it comes away in one piece, and
//! lines that split large cut-out areas into pieces a person can lift one by one.
//!
//! A stencil is the sheet that stays; what its cuts free (the holes) is the waste that is
//! weeded. A sign's weeding lines run through the background between letters because there the
//! background is the waste; on a stencil the background is the stencil, and a line across it
//! would cut it apart. So a weeding line here only ever runs inside a cut-out area (inside an
//! odd number of the job's loops: an island inside a hole is kept, and a bridge lies outside
//! the loops), from a point well inside it to the cuts around it, and the box lies outside
//! every cut: the stencil stays one piece.

use stencil_gcode::Loop;

/// What weeding aids to cut.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Weeding {
    /// A box around the job's cuts this far outside them, mm.
    pub box_margin_mm: Option<f64>,
    /// Split cut-out areas wider or taller than this, mm, with lines this far apart.
    pub line_spacing_mm: Option<f64>,
}

/// How far a weeding line's starting point must be from every cut, mm: where the knife goes
/// down (the tip swivels there before it cuts).
pub const WEED_START_CLEAR_MM: f64 = 0.5;

/// Why a weeding aid cannot be cut.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum WeedError {
    /// The box would leave the plotter's cutting area.
    #[error(
        "a weeding box {margin_mm} mm outside the cuts would run off the plotter's cutting area \
         ({side} side: {room_mm:.1} mm of room); ask for a smaller margin or place the job \
         further in"
    )]
    OffArea {
        /// The margin asked for.
        margin_mm: f64,
        /// Which side.
        side: &'static str,
        /// The room there, mm.
        room_mm: f64,
    },
}

/// The loops that bound cut-out areas (the sheet's outline is not one).
fn cut_loops(loops: &[Loop]) -> impl Iterator<Item = &[[f64; 2]]> {
    loops
        .iter()
        .filter(|l| !l.outline && l.points.len() >= 3)
        .map(|l| l.points.as_slice())
}

fn bounds<'a>(rings: impl Iterator<Item = &'a [[f64; 2]]>) -> Option<([f64; 2], [f64; 2])> {
    let mut b: Option<([f64; 2], [f64; 2])> = None;
    for q in rings.flatten() {
        let (lo, hi) = b.get_or_insert((*q, *q));
        for a in 0..2 {
            lo[a] = lo[a].min(q[a]);
            hi[a] = hi[a].max(q[a]);
        }
    }
    b
}

/// The weeding box: a closed rectangle (counter-clockwise, machine mm) `margin` outside every
/// cut loop, which must lie on the cutting area `[0, area]` with `reach` to spare (a drag
/// knife's axis swings that far outside the tip's path at the corners). `None` without cuts.
pub fn weed_box(
    loops: &[Loop],
    margin: f64,
    reach: f64,
    area: [f64; 2],
) -> Result<Option<Vec<[f64; 2]>>, WeedError> {
    let Some((lo, hi)) = bounds(cut_loops(loops)) else {
        return Ok(None);
    };
    let (a, b) = (
        [lo[0] - margin, lo[1] - margin],
        [hi[0] + margin, hi[1] + margin],
    );
    for (side, room) in [
        ("left", lo[0]),
        ("front", lo[1]),
        ("right", area[0] - hi[0]),
        ("back", area[1] - hi[1]),
    ] {
        if room < margin + reach {
            return Err(WeedError::OffArea {
                margin_mm: margin,
                side,
                room_mm: room,
            });
        }
    }
    Ok(Some(vec![a, [b[0], a[1]], b, [a[0], b[1]]]))
}

/// Where the line `axis = c` (x when `vertical`, else y) runs inside an odd number of `rings`:
/// the intervals along it, sorted.
fn chords(rings: &[&[[f64; 2]]], vertical: bool, c: f64) -> Vec<[f64; 2]> {
    let (u, v) = if vertical { (0, 1) } else { (1, 0) };
    let mut hits: Vec<f64> = Vec::new();
    for r in rings {
        for i in 0..r.len() {
            let (p, q) = (r[i], r[(i + 1) % r.len()]);
            // Half-open: a vertex on the line counts once.
            if (p[u] > c) != (q[u] > c) {
                let t = (c - p[u]) / (q[u] - p[u]);
                hits.push(p[v] + t * (q[v] - p[v]));
            }
        }
    }
    hits.sort_by(f64::total_cmp);
    hits.chunks_exact(2).map(|w| [w[0], w[1]]).collect()
}

fn inside(ring: &[[f64; 2]], p: [f64; 2]) -> bool {
    let mut odd = false;
    for i in 0..ring.len() {
        let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0])
        {
            odd = !odd;
        }
    }
    odd
}

fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

/// The weeding lines, as the tip should cut them: pairs of paths from a chord's middle to each
/// of its ends, where the chord crosses a cut-out area wider (vertical lines) or taller
/// (horizontal lines) than `spacing`, on a grid `spacing` apart from the cuts' lower-left
/// corner. A chord whose middle lies within [`WEED_START_CLEAR_MM`] of a cut is left out.
pub fn weed_lines(loops: &[Loop], spacing: f64) -> Vec<[[f64; 2]; 2]> {
    let rings: Vec<&[[f64; 2]]> = cut_loops(loops).collect();
    let Some((lo, _)) = bounds(rings.iter().copied()) else {
        return Vec::new();
    };
    let mut out: Vec<[[f64; 2]; 2]> = Vec::new();
    let mut seen = std::collections::BTreeSet::new();
    for ring in &rings {
        let Some((rlo, rhi)) = bounds(std::iter::once(*ring)) else {
            continue;
        };
        for (vertical, a) in [(true, 0), (false, 1)] {
            if rhi[a] - rlo[a] <= spacing {
                continue;
            }
            let mut k = ((rlo[a] - lo[a]) / spacing).floor() + 1.0;
            while lo[a] + k * spacing < rhi[a] {
                let c = lo[a] + k * spacing;
                k += 1.0;
                for [s, e] in chords(&rings, vertical, c) {
                    let at = |t: f64| if vertical { [c, t] } else { [t, c] };
                    let mid = at(0.5 * (s + e));
                    let key = (vertical, c.to_bits(), s.to_bits());
                    if !inside(ring, mid) || !seen.insert(key) {
                        continue;
                    }
                    let clear = rings.iter().all(|r| {
                        (0..r.len()).all(|i| {
                            seg_dist(mid, r[i], r[(i + 1) % r.len()]) >= WEED_START_CLEAR_MM
                        })
                    });
                    if clear {
                        out.push([mid, at(s)]);
                        out.push([mid, at(e)]);
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    fn lp(points: Vec<[f64; 2]>, outline: bool) -> Loop {
        Loop {
            points,
            outline,
            area_mm2: 0.0,
            curve: Vec::new(),
        }
    }

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<[f64; 2]> {
        vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    }

    #[test]
    fn lines_split_only_the_large_hole_and_stop_at_an_island() {
        let loops = vec![
            lp(rect(10.0, 10.0, 70.0, 40.0), false),
            // An island inside the big hole (kept): no line crosses it.
            lp(rect(35.0, 18.0, 45.0, 26.0), false),
            // A small hole: no line.
            lp(rect(80.0, 10.0, 85.0, 15.0), false),
            lp(rect(0.0, 0.0, 100.0, 50.0), true),
        ];
        let lines = weed_lines(&loops, 15.0);
        assert!(!lines.is_empty());
        for [m, e] in &lines {
            for p in [m, e] {
                let in_hole = (10.0..=70.0).contains(&p[0]) && (10.0..=40.0).contains(&p[1]);
                let in_island = p[0] > 35.0 && p[0] < 45.0 && p[1] > 18.0 && p[1] < 26.0;
                assert!(in_hole && !in_island, "{p:?}");
            }
        }
        // Vertical lines at x = 25, 40 and 55 (the grid from x = 10); the one at 40 stops at the
        // island, from both sides.
        let xs: BTreeSet<i64> = lines
            .iter()
            .filter(|l| l[0][0] == l[1][0])
            .map(|l| l[0][0] as i64)
            .collect();
        assert_eq!(xs.into_iter().collect::<Vec<_>>(), vec![25, 40, 55]);
        assert!(lines.iter().any(|l| l[1] == [40.0, 18.0]));
        assert!(lines.iter().any(|l| l[1] == [40.0, 26.0]));
        // One horizontal line, at y = 25, in two pieces either side of the island.
        assert!(lines.iter().any(|l| l[1] == [35.0, 25.0]));
        assert!(lines.iter().any(|l| l[1] == [45.0, 25.0]));
        assert!(lines.iter().all(|l| l[0][1] != 40.0));
    }

    #[test]
    fn the_box_lies_outside_every_cut_and_on_the_area() {
        let loops = vec![lp(rect(10.0, 10.0, 70.0, 40.0), false)];
        let b = weed_box(&loops, 5.0, 0.25, [100.0, 100.0])
            .unwrap()
            .unwrap();
        assert_eq!(b, rect(5.0, 5.0, 75.0, 45.0));
        let e = weed_box(&loops, 12.0, 0.0, [100.0, 100.0]).unwrap_err();
        assert!(matches!(e, WeedError::OffArea { side: "left", .. }), "{e}");
        // The knife's reach counts: 10 mm of room holds a 9.8 mm margin only with less reach.
        assert!(weed_box(&loops, 9.8, 0.1, [100.0, 100.0]).is_ok());
        assert!(weed_box(&loops, 9.8, 0.25, [100.0, 100.0]).is_err());
    }
}
