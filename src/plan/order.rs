//! Cut order constraints: what must be cut before what, so nothing falls out or shifts before the
//! cuts around it are finished.
//!
//! - A loop lying inside the region another loop frees is cut first (innermost first). After
//!   bridging, the cut around an island is not a closed ring around it but a C: the ring broken
//!   by the bridge. A C contains nothing, yet cutting it leaves the island hanging on its bridge,
//!   free to tilt and shift under the cuts still to come inside it. So the region a loop frees is
//!   taken as its convex hull (the C with its opening closed, which holds the island and all
//!   that lies on it), and a loop lying wholly inside another's hull is cut before it.
//! - Of the outermost cut regions, the largest is cut last: it weakens the sheet the most.
//! - The sheet's outline (`--cut-outline`) comes after everything inside it.
//!
//! The result is a sequence of groups; the travel optimiser orders loops freely within a group.
//!
//! Hull containment is transitive (A in hull(B) and B in hull(C) puts A in hull(C)), so counting
//! the hulls around a loop gives a depth that orders every such pair: the containing loop always
//! has fewer hulls around it. Equal hulls (two loops with the same hull) are ordered by a strict
//! key (hull area, then index), so the order never cycles.

use super::toolpath::Loop;

fn bbox(points: &[[f64; 2]]) -> [f64; 4] {
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for p in points {
        b[0] = b[0].min(p[0]);
        b[1] = b[1].min(p[1]);
        b[2] = b[2].max(p[0]);
        b[3] = b[3].max(p[1]);
    }
    b
}

/// Even-odd ray cast: whether `p` lies inside the closed ring `poly`.
pub fn point_in_ring(p: [f64; 2], poly: &[[f64; 2]]) -> bool {
    let n = poly.len();
    let mut inside = false;
    let mut j = n - 1;
    for i in 0..n {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

/// The convex hull of a ring, counter-clockwise, without a closing point (Andrew's monotone
/// chain).
pub fn convex_hull(points: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut p: Vec<[f64; 2]> = points.to_vec();
    p.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut h: Vec<[f64; 2]> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = h.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while h.len() >= start + 2 && cross(h[h.len() - 2], h[h.len() - 1], q) <= 0.0 {
                h.pop();
            }
            h.push(q);
        }
        h.pop();
    }
    h
}

/// Area of a simple polygon (absolute value).
fn area(ring: &[[f64; 2]]) -> f64 {
    let n = ring.len();
    (0..n)
        .map(|i| {
            let (a, b) = (ring[i], ring[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        .abs()
        / 2.0
}

/// Whether `p` lies in the counter-clockwise convex polygon `hull` (its edges count as inside,
/// within `eps` mm).
fn in_convex(p: [f64; 2], hull: &[[f64; 2]], eps: f64) -> bool {
    let n = hull.len();
    if n < 3 {
        return false;
    }
    (0..n).all(|i| {
        let (a, b) = (hull[i], hull[(i + 1) % n]);
        let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
        let len = (ex * ex + ey * ey).sqrt().max(1e-12);
        // Signed distance of p to the left of edge a -> b.
        (ex * (p[1] - a[1]) - ey * (p[0] - a[0])) / len >= -eps
    })
}

/// For each loop, the loops whose freed region (convex hull) it lies in and that are cut after
/// it: `inside[i]` lists j with loop i inside hull(j). Outline loops take no part.
pub fn containers(loops: &[Loop]) -> Vec<Vec<usize>> {
    let hulls: Vec<Vec<[f64; 2]>> = loops.iter().map(|l| convex_hull(&l.points)).collect();
    let hull_area: Vec<f64> = hulls.iter().map(|h| area(h)).collect();
    let boxes: Vec<[f64; 4]> = loops.iter().map(|l| bbox(&l.points)).collect();
    // A strict order on (hull area, index): only a larger key can contain a smaller one.
    let key_less = |i: usize, j: usize| (hull_area[i], i) < (hull_area[j], j);
    let eps = 1e-7;
    let mut out = vec![Vec::new(); loops.len()];
    for (i, li) in loops.iter().enumerate() {
        if li.outline {
            continue;
        }
        let bi = boxes[i];
        for (j, lj) in loops.iter().enumerate() {
            let bj = boxes[j];
            if i == j
                || lj.outline
                || !key_less(i, j)
                || bi[0] < bj[0] - eps
                || bi[1] < bj[1] - eps
                || bi[2] > bj[2] + eps
                || bi[3] > bj[3] + eps
            {
                continue;
            }
            // Every vertex of i in hull(j) puts all of i there: the hull is convex.
            if li.points.iter().all(|&p| in_convex(p, &hulls[j], eps)) {
                out[i].push(j);
            }
        }
    }
    out
}

/// Nesting depth of each loop among the non-outline loops (0 = inside no other loop's freed
/// region): how many loops it must be cut before.
pub fn depths(loops: &[Loop]) -> Vec<usize> {
    containers(loops).iter().map(Vec::len).collect()
}

/// For each loop, the loops that must be cut before it: those lying in its freed region; for the
/// largest outermost region, every other region; for the sheet's outline, every region. These are
/// the true constraints; [`groups`] layers them (and adds some).
pub fn before(loops: &[Loop], groups: &[Vec<usize>]) -> Vec<Vec<usize>> {
    let mut out = vec![Vec::new(); loops.len()];
    for (i, cs) in containers(loops).into_iter().enumerate() {
        for j in cs {
            out[j].push(i);
        }
    }
    let regions: Vec<usize> = (0..loops.len()).filter(|&i| !loops[i].outline).collect();
    // The group after the last region group is the outline; the largest region is alone just
    // before it when it was moved there.
    let last_regions = groups
        .iter()
        .rev()
        .find(|g| g.iter().all(|&i| !loops[i].outline));
    if let Some(g) = last_regions {
        if g.len() == 1
            && groups
                .iter()
                .filter(|g| g.iter().all(|&i| !loops[i].outline))
                .count()
                > 1
        {
            let largest = g[0];
            out[largest] = regions.iter().copied().filter(|&i| i != largest).collect();
        }
    }
    for i in 0..loops.len() {
        if loops[i].outline {
            out[i] = regions.clone();
        }
    }
    out
}

/// Groups of loop indices, to be cut group after group.
pub fn groups(loops: &[Loop]) -> Vec<Vec<usize>> {
    let depth = depths(loops);
    let max_depth = depth.iter().copied().max().unwrap_or(0);
    let mut out: Vec<Vec<usize>> = Vec::new();
    for d in (0..=max_depth).rev() {
        let g: Vec<usize> = (0..loops.len())
            .filter(|&i| !loops[i].outline && depth[i] == d)
            .collect();
        if !g.is_empty() {
            out.push(g);
        }
    }
    // The largest outermost region goes last among the regions.
    if let Some(top) = out.last_mut() {
        if top.len() > 1 {
            let (k, _) = top
                .iter()
                .enumerate()
                .fold((0, f64::NEG_INFINITY), |best, (k, &i)| {
                    if loops[i].area_mm2 > best.1 {
                        (k, loops[i].area_mm2)
                    } else {
                        best
                    }
                });
            let largest = top.remove(k);
            out.push(vec![largest]);
        }
    }
    let outline: Vec<usize> = (0..loops.len()).filter(|&i| loops[i].outline).collect();
    if !outline.is_empty() {
        out.push(outline);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sq(x: f64, y: f64, s: f64, outline: bool) -> Loop {
        Loop {
            points: vec![[x, y], [x + s, y], [x + s, y + s], [x, y + s]],
            outline,
            area_mm2: s * s,
        }
    }

    #[test]
    fn nested_inner_first_largest_then_outline_last() {
        let loops = vec![
            sq(0.0, 0.0, 100.0, true), // outline
            sq(10.0, 10.0, 50.0, false),
            sq(20.0, 20.0, 10.0, false), // inside the 50 square
            sq(70.0, 70.0, 5.0, false),
            sq(70.0, 10.0, 20.0, false),
        ];
        assert_eq!(depths(&loops), vec![0, 0, 1, 0, 0]);
        let g = groups(&loops);
        assert_eq!(g, vec![vec![2], vec![3, 4], vec![1], vec![0]]);
    }

    /// A ring of 32 points with a gap (a C, as bridging leaves a cut around an island).
    fn c_shape(cx: f64, cy: f64, r_out: f64, r_in: f64) -> Loop {
        let arc = |r: f64, rev: bool| -> Vec<[f64; 2]> {
            let mut v: Vec<[f64; 2]> = (0..=30)
                .map(|k| {
                    let a = 0.3 + k as f64 / 30.0 * (std::f64::consts::TAU - 0.6);
                    [cx + r * a.cos(), cy + r * a.sin()]
                })
                .collect();
            if rev {
                v.reverse();
            }
            v
        };
        let mut points = arc(r_out, false);
        points.extend(arc(r_in, true));
        let a = std::f64::consts::PI * (r_out * r_out - r_in * r_in);
        Loop {
            points,
            outline: false,
            area_mm2: a,
        }
    }

    #[test]
    fn cuts_inside_a_c_shaped_cut_come_first() {
        // Three Cs nested like the rings sample, and a dot in the middle; the outer C is the
        // largest by area, yet nothing inside its opening may come after it.
        let loops = vec![
            c_shape(50.0, 50.0, 40.0, 35.0),
            sq(48.0, 48.0, 4.0, false),
            c_shape(50.0, 50.0, 20.0, 15.0),
            c_shape(50.0, 50.0, 30.0, 25.0),
            sq(120.0, 50.0, 5.0, false), // beside, inside nothing
        ];
        assert_eq!(depths(&loops), vec![0, 3, 2, 1, 0]);
        let g = groups(&loops);
        assert_eq!(g, vec![vec![1], vec![2], vec![3], vec![4], vec![0]]);
        // Two loops with the same hull: one goes first, no cycle.
        let twins = vec![sq(0.0, 0.0, 10.0, false), sq(0.0, 0.0, 10.0, false)];
        assert_eq!(depths(&twins), vec![1, 0]);
    }

    #[test]
    fn hull_of_a_c_is_its_disc() {
        let c = c_shape(0.0, 0.0, 10.0, 8.0);
        let h = convex_hull(&c.points);
        assert!(in_convex([0.0, 0.0], &h, 0.0));
        assert!(in_convex([9.0, 0.0], &h, 0.0), "the opening is closed");
        assert!(!in_convex([10.5, 0.0], &h, 0.0));
        assert!((area(&h) - std::f64::consts::PI * 100.0).abs() < 0.05 * 314.0);
    }

    #[test]
    fn point_in_ring_basics() {
        let r = sq(0.0, 0.0, 10.0, false).points;
        assert!(point_in_ring([5.0, 5.0], &r));
        assert!(!point_in_ring([15.0, 5.0], &r));
        assert!(!point_in_ring([-1.0, 5.0], &r));
    }
}
