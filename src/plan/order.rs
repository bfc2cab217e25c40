//! Cut order constraints: what must be cut before what, so nothing falls out or shifts before the
//! cuts around it are finished.
//!
//! - A loop inside another loop is cut first (innermost first).
//! - Of the outermost cut regions, the largest is cut last: it weakens the sheet the most.
//! - The sheet's outline (`--cut-outline`) comes after everything inside it.
//!
//! The result is a sequence of groups; the travel optimiser orders loops freely within a group.

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

/// Nesting depth of each loop among the non-outline loops (0 = not inside any other).
pub fn depths(loops: &[Loop]) -> Vec<usize> {
    let boxes: Vec<[f64; 4]> = loops.iter().map(|l| bbox(&l.points)).collect();
    let mut depth = vec![0; loops.len()];
    for (i, li) in loops.iter().enumerate() {
        if li.outline {
            continue;
        }
        let bi = boxes[i];
        for (j, lj) in loops.iter().enumerate() {
            let bj = boxes[j];
            if i == j
                || lj.outline
                || lj.area_mm2 <= li.area_mm2
                || bi[0] < bj[0]
                || bi[1] < bj[1]
                || bi[2] > bj[2]
                || bi[3] > bj[3]
            {
                continue;
            }
            if point_in_ring(li.points[0], &lj.points) {
                depth[i] += 1;
            }
        }
    }
    depth
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

    #[test]
    fn point_in_ring_basics() {
        let r = sq(0.0, 0.0, 10.0, false).points;
        assert!(point_in_ring([5.0, 5.0], &r));
        assert!(!point_in_ring([15.0, 5.0], &r));
        assert!(!point_in_ring([-1.0, 5.0], &r));
    }
}
