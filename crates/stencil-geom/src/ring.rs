//! Rings as plain point lists (`[x, y]`, closing point not repeated): the few measures every stage
//! takes of them. One copy of each, so that every stage measures the same way.

/// The bounding box `[min x, min y, max x, max y]` of points (infinite and inverted when there
/// are none).
pub fn bbox(points: &[[f64; 2]]) -> [f64; 4] {
    points
        .iter()
        .fold(NO_BOX, |b, &p| union_box(b, point_box(p)))
}

/// The box of nothing: its union with any box is that box.
pub(crate) const NO_BOX: [f64; 4] = [
    f64::INFINITY,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::NEG_INFINITY,
];

/// Index `k` of a closed ring of `n` points, counted on past its end (`k % n`): the fits walk
/// at most twice round, so a subtraction usually does instead of a division, which costs as
/// much as the distance it serves.
#[inline]
pub(crate) fn wrap(k: usize, n: usize) -> usize {
    if k < n {
        k
    } else if k - n < n {
        k - n
    } else {
        k % n
    }
}

pub(crate) fn point_box(p: [f64; 2]) -> [f64; 4] {
    [p[0], p[1], p[0], p[1]]
}

pub(crate) fn union_box(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0].min(b[0]),
        a[1].min(b[1]),
        a[2].max(b[2]),
        a[3].max(b[3]),
    ]
}

/// Twice the signed shoelace area of a ring: positive when it runs counter-clockwise in the
/// numeric (x, y) plane (material on the left of the walk).
pub fn signed_area2(ring: &[[f64; 2]]) -> f64 {
    let n = ring.len();
    let mut a = 0.0;
    for i in 0..n {
        let p = ring[i];
        let q = ring[(i + 1) % n];
        a += p[0] * q[1] - q[0] * p[1];
    }
    a
}

/// The area of a simple ring, whichever way it runs.
pub fn area(ring: &[[f64; 2]]) -> f64 {
    signed_area2(ring).abs() / 2.0
}

/// Even-odd ray cast: whether `p` lies inside the closed ring. A point exactly on an edge may
/// fall either way; callers test points that are not on edges (pixel centres against outlines on
/// pixel corners, or points of one loop against another that does not touch it).
pub fn point_in_ring(p: [f64; 2], ring: &[[f64; 2]]) -> bool {
    let n = ring.len();
    if n == 0 {
        return false;
    }
    let mut inside = false;
    let mut j = n - 1;
    for i in 0..n {
        let (a, b) = (ring[i], ring[j]);
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

/// The distance between two points.
pub fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

/// The distance from `p` to the segment from `a` to `b` (to `a` when the two are one point).
pub fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    dist(p, seg_closest(p, a, b))
}

/// The point of the segment from `a` to `b` closest to `p` (`a` when the two are one point).
pub(crate) fn seg_closest(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    let d = [b[0] - a[0], b[1] - a[1]];
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    [a[0] + t * d[0], a[1] + t * d[1]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measures_of_a_unit_square_and_an_l() {
        let sq = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        assert_eq!(signed_area2(&sq), 2.0);
        let cw: Vec<_> = sq.iter().rev().copied().collect();
        assert_eq!(signed_area2(&cw), -2.0);
        assert_eq!(area(&cw), 1.0);
        assert_eq!(bbox(&sq), [0.0, 0.0, 1.0, 1.0]);
        assert!(bbox(&[])[0].is_infinite());
        // An L: the notch is outside.
        let l = [
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [0.0, 2.0],
        ];
        assert!(point_in_ring([0.5, 1.5], &l));
        assert!(point_in_ring([1.5, 0.5], &l));
        assert!(!point_in_ring([1.5, 1.5], &l));
        assert!(!point_in_ring([3.0, 0.5], &l));
        assert!(!point_in_ring([0.5, 0.5], &[]));
        assert_eq!(dist([0.0, 0.0], [3.0, 4.0]), 5.0);
    }
}
