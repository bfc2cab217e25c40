//! Tests of the cut's pieces: arcs fitted, bounded, flattened and checked as the head cuts them.

use super::*;

/// The largest distance from any point of `a` (dense) to the polygon `b`, both closed.
fn one_way(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    let n = b.len();
    a.iter()
        .map(|&p| {
            (0..n)
                .map(|i| seg_dist(p, b[i], b[(i + 1) % n]))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

fn densify(r: &[[f64; 2]], step: f64) -> Vec<[f64; 2]> {
    let n = r.len();
    let mut out = Vec::new();
    for i in 0..n {
        let (a, b) = (r[i], r[(i + 1) % n]);
        let k = (dist(a, b) / step).ceil().max(1.0) as usize;
        for s in 0..k {
            let t = s as f64 / k as f64;
            out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }
    out
}

fn hausdorff(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    one_way(&densify(a, 0.01), b).max(one_way(&densify(b, 0.01), a))
}

fn circle(r: f64, n: usize, ccw: bool) -> Vec<[f64; 2]> {
    (0..n)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / n as f64 * if ccw { 1.0 } else { -1.0 };
            [5.0 + r * a.cos(), 3.0 + r * a.sin()]
        })
        .collect()
}

#[test]
fn a_polygon_circle_becomes_a_few_arcs_on_the_circle() {
    for ccw in [true, false] {
        let ring = circle(4.0, 360, ccw);
        let pieces = fit_ring(&ring, 0.01);
        assert!(pieces.len() <= 4, "{}", pieces.len());
        // The greedy's last piece may be whatever is left over.
        assert!(arc_count(&pieces) + 1 >= pieces.len(), "{pieces:?}");
        assert_eq!(pieces[0].from, ring[0]);
        for (k, p) in pieces.iter().enumerate() {
            let Some(arc) = arc_of(p.from, pieces[(k + 1) % pieces.len()].from, p.bulge) else {
                continue;
            };
            assert!((arc.radius - 4.0).abs() < 0.01, "{arc:?}");
            assert!(dist(arc.center, [5.0, 3.0]) < 0.01, "{arc:?}");
            assert_eq!(arc.sweep > 0.0, ccw);
        }
        let flat = flatten(&pieces, 0.001);
        assert!(hausdorff(&flat, &ring) < 0.01 + 1e-3);
    }
}

#[test]
fn corners_stay_corners_and_lines_stay_lines() {
    // A square with one rounded corner (radius 2), as a polygon.
    let mut ring = vec![[0.0, 0.0], [10.0, 0.0], [10.0, 8.0]];
    for i in 0..=30 {
        let a = std::f64::consts::FRAC_PI_2 * i as f64 / 30.0;
        ring.push([8.0 + 2.0 * a.cos(), 8.0 + 2.0 * a.sin()]);
    }
    ring.push([0.0, 10.0]);
    let pieces = fit_ring(&ring, 0.02);
    let froms: Vec<[f64; 2]> = pieces.iter().map(|p| p.from).collect();
    // Each corner a piece's start (to the last bits: a piece may end where a vertex is
    // nearest it rather than on the vertex).
    for corner in [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]] {
        assert!(froms.iter().any(|&f| dist(f, corner) < 1e-9), "{froms:?}");
    }
    assert_eq!(arc_count(&pieces), 1, "{pieces:?}");
    let flat = flatten(&pieces, 0.002);
    assert!(hausdorff(&flat, &ring) <= 0.02 + 2e-3);
}

#[test]
fn a_staircase_is_smoothed_within_the_tolerance_both_ways() {
    // A pixel staircase around a disc of radius 30 px: marching squares' worst case.
    let mut ring = Vec::new();
    for i in 0..720 {
        let a = std::f64::consts::TAU * i as f64 / 720.0;
        let p = [(30.0 * a.cos()).round(), (30.0 * a.sin()).round()];
        if ring.last() != Some(&p) {
            ring.push(p);
        }
    }
    if ring.first() == ring.last() {
        ring.pop();
    }
    for tol in [0.3, 0.5, 1.0] {
        let pieces = fit_ring(&ring, tol);
        // Within 0.3 px no curve passes every step's corner (they stray ±0.35 px from the
        // disc); from half a pixel on, most steps go.
        if tol >= 0.5 {
            assert!(
                pieces.len() * 3 < ring.len(),
                "tol {tol}: {} of {}",
                pieces.len(),
                ring.len()
            );
        }
        let h = hausdorff(&flatten(&pieces, tol / 20.0), &ring);
        assert!(h <= tol * 1.05 + 0.01, "tol {tol}: {h}");
    }
}

#[test]
fn sides_are_kept_clear_of_the_curve() {
    // A shallow bump: without sides it is one arc (or line); a left point just below the
    // bump's top forbids cutting across it.
    let ring: Vec<[f64; 2]> = (0..=20)
        .map(|i| [i as f64, -(0.04 * (i as f64 - 10.0).powi(2) - 4.0)])
        .chain([[20.0, -10.0], [0.0, -10.0]])
        .collect();
    // Sides of the bump's vertices: the ring walks +x along the bump, so left is 0.2 above
    // each vertex and right 0.2 below; the other two vertices have none that can hold.
    let mut pts: Vec<[[f64; 2]; 2]> = ring
        .iter()
        .map(|p| [[p[0], p[1] + 0.2], [p[0], p[1] - 0.2]])
        .collect();
    for p in pts.iter_mut().skip(21) {
        *p = [[f64::NAN; 2]; 2];
    }
    let sides = Sides {
        points: &pts,
        margin: 0.05,
    };
    let kept = fit_ring_within(&ring, 5.0, Some(sides));
    // Every bump vertex's sides hold for the fitted pieces, flattened: the curve passes
    // between them.
    let flat = flatten(&kept, 0.001);
    for (k, &[l, r]) in pts.iter().enumerate().take(20).skip(1) {
        let curve_y = flat
            .iter()
            .zip(flat.iter().skip(1))
            .filter(|(a, b)| (a[0] - l[0]) * (b[0] - l[0]) <= 0.0 && a[0] != b[0])
            .map(|(a, b)| a[1] + (l[0] - a[0]) / (b[0] - a[0]) * (b[1] - a[1]))
            .next()
            .unwrap();
        assert!(
            l[1] > curve_y && r[1] < curve_y,
            "{k}: {l:?} {r:?} vs {curve_y}"
        );
    }
}

/// A half disc of radius 2 about (1, 1), its arc from (3, 1) counter-clockwise over the top
/// to (-1, 1): a half turn would be bulge 1, so two quarter arcs (bulge tan(π/8)), and back
/// along its diameter.
fn half_disc() -> [Piece; 3] {
    let q = (std::f64::consts::PI / 8.0).tan();
    [
        Piece {
            from: [3.0, 1.0],
            bulge: q,
        },
        Piece {
            from: [1.0, 3.0],
            bulge: q,
        },
        Piece {
            from: [-1.0, 1.0],
            bulge: 0.0,
        },
    ]
}

#[test]
fn bounds_are_the_arcs_own_extremes() {
    let pieces = half_disc();
    let b = bounds(&pieces).unwrap();
    for (got, want) in b.iter().zip([-1.0, 1.0, 3.0, 3.0]) {
        assert!((got - want).abs() < 1e-12, "{b:?}");
    }
    // One quarter arc from (3, 1) to (1, 3), back by its chord: its extremes are its ends.
    let b = bounds(&pieces[..2]).unwrap();
    assert!(
        (b[2] - 3.0).abs() < 1e-12 && (b[3] - 3.0).abs() < 1e-12,
        "{b:?}"
    );
    // A shallow counter-clockwise arc from (0, 0) to (4, 0): its centre above the chord, it
    // sags below it by the sagitta, bulge · chord / 2 = 0.5, through its 270° point, past
    // the box of its ends.
    let arc = [
        Piece {
            from: [0.0, 0.0],
            bulge: 0.25,
        },
        Piece {
            from: [4.0, 0.0],
            bulge: 0.0,
        },
    ];
    let g = arc_of([0.0, 0.0], [4.0, 0.0], 0.25).unwrap();
    let b = bounds(&arc).unwrap();
    assert!(
        (b[1] - (g.center[1] - g.radius)).abs() < 1e-12,
        "{b:?} {g:?}"
    );
    assert!(b[1] < -0.4, "{b:?}");
    // Against a dense flattening: the same box within the flattening's own error.
    let flat = flatten(&arc, 1e-6);
    let lo = flat.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
    assert!((lo - b[1]).abs() < 1e-5, "{lo} vs {}", b[1]);
    assert!(bounds(&[]).is_none());
}

#[test]
fn inside_a_box_no_arc_leaves_it() {
    // A 7-gon's circle bulges past the polygon's own box on every side but one: arcs
    // through its vertices would leave it. A fine polygon of a circle starting off-axis,
    // and a staircase disc, likewise.
    let off_axis: Vec<[f64; 2]> = (0..97)
        .map(|i| {
            let a = 0.3 + std::f64::consts::TAU * i as f64 / 97.0;
            [5.0 + 4.0 * a.cos(), 3.0 + 4.0 * a.sin()]
        })
        .collect();
    let mut stairs = Vec::new();
    for i in 0..720 {
        let a = std::f64::consts::TAU * i as f64 / 720.0;
        let p = [(30.0 * a.cos()).round(), (30.0 * a.sin()).round()];
        if stairs.last() != Some(&p) && stairs.first() != Some(&p) {
            stairs.push(p);
        }
    }
    for (ring, tol, arcs) in [
        (circle(4.0, 7, true), 0.5, false),
        (off_axis, 0.01, true),
        (stairs, 0.5, true),
    ] {
        let bx = crate::ring::bbox(&ring);
        let free = fit_ring(&ring, tol);
        let fb = bounds(&free).unwrap();
        let kept = fit_ring_inside(&ring, tol, bx);
        let kb = bounds(&kept).unwrap();
        assert!(
            kb[0] >= bx[0] - 1e-9
                && kb[1] >= bx[1] - 1e-9
                && kb[2] <= bx[2] + 1e-9
                && kb[3] <= bx[3] + 1e-9,
            "{kb:?} vs {bx:?}"
        );
        // The free fit does leave the box (else this test tests nothing), and the kept
        // one is still a fit within the tolerance, with arcs where they can stay inside
        // (the 7-gon's arcs would all bulge out: it stays its lines).
        assert!(
            fb[0] < bx[0] - 1e-6
                || fb[1] < bx[1] - 1e-6
                || fb[2] > bx[2] + 1e-6
                || fb[3] > bx[3] + 1e-6,
            "{fb:?} vs {bx:?}"
        );
        assert_eq!(arc_count(&kept) > 0, arcs, "{kept:?}");
        let h = hausdorff(&flatten(&kept, tol / 50.0), &ring);
        assert!(h <= tol * 1.05 + 0.01, "{h}");
    }
}

#[test]
fn vertices_move_onto_their_pieces_by_at_most_the_tolerance() {
    // The staircase disc: its steps move onto the arcs (radius within a pixel of 30), each
    // by at most the fit's tolerance; the pieces' own starts stay.
    let mut ring = Vec::new();
    for i in 0..720 {
        let a = std::f64::consts::TAU * i as f64 / 720.0;
        let p = [(30.0 * a.cos()).round(), (30.0 * a.sin()).round()];
        if ring.last() != Some(&p) && ring.first() != Some(&p) {
            ring.push(p);
        }
    }
    let tol = 0.5;
    let pieces = fit_ring(&ring, tol);
    assert!(arc_count(&pieces) > 0);
    let on = onto_pieces(&ring, &pieces).unwrap();
    assert_eq!(on.len(), ring.len());
    let mut moved = 0;
    for (q, p) in ring.iter().zip(&on) {
        assert!(dist(*q, *p) <= tol + 1e-9, "{q:?} -> {p:?}");
        if pieces.iter().any(|pc| pc.from == *q) {
            assert_eq!(q, p);
        } else {
            moved += usize::from(q != p);
            let r = p[0].hypot(p[1]);
            assert!((r - 30.0).abs() < 1.0, "{p:?}");
        }
    }
    assert!(moved * 2 > ring.len(), "{moved} of {}", ring.len());
    // Lines: a vertex beside a line piece moves onto it, perpendicular.
    let sq = [
        [0.0, 0.0],
        [5.0, 0.1],
        [10.0, 0.0],
        [10.0, 10.0],
        [0.0, 10.0],
    ];
    let pieces = fit_ring(&sq, 0.2);
    assert_eq!(pieces.len(), 4, "{pieces:?}");
    assert_eq!(onto_pieces(&sq, &pieces).unwrap()[1], [5.0, 0.0]);
    // Pieces of another ring: none.
    assert!(onto_pieces(&sq[1..], &pieces).is_none());
}

#[test]
fn length_is_the_arcs_length() {
    let pieces = half_disc();
    let want = std::f64::consts::PI * 2.0 + 4.0;
    assert!((length(&pieces) - want).abs() < 1e-12);
}

#[test]
fn no_tolerance_or_a_tiny_ring_gives_lines() {
    let tri = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
    assert_eq!(arc_count(&fit_ring(&tri, 0.0)), 0);
    assert_eq!(fit_ring(&tri[..2], 1.0).len(), 2);
    assert_eq!(flatten(&fit_ring(&tri, 0.1), 0.1), tri.to_vec());
}

#[test]
fn a_flattening_is_found_again_either_way_and_from_any_start() {
    let pieces = half_disc().to_vec();
    let flat = flatten(&pieces, 0.01);
    // Its box is the arcs' own (the extremes are vertices).
    assert_eq!(crate::ring::bbox(&flat), bounds(&pieces).unwrap());
    let mut table = Curves::new(0.01);
    assert!(table.insert(pieces.clone(), flat.clone()));
    // As stored.
    assert_eq!(table.pieces_of(&flat), Some((0, pieces.clone())));
    // Rotated: the first piece start found is the second piece's.
    let at = flat.iter().position(|p| *p == pieces[1].from).unwrap();
    let mut rot = flat.clone();
    rot.rotate_left(3);
    let (q, got) = table.pieces_of(&rot).unwrap();
    assert_eq!(rot[q], pieces[1].from);
    assert_eq!(q, at - 3);
    assert_eq!(got[0], pieces[1]);
    // Reversed (a cut region's outline is a material hole walked back): the same path.
    let mut back = flat.clone();
    back.reverse();
    let (q, got) = table.pieces_of(&back).unwrap();
    assert_eq!(back[q], got[0].from);
    let again = flatten(&got, 0.01);
    assert!((length(&got) - length(&pieces)).abs() < 1e-12);
    assert_eq!(again.len(), flat.len());
    // A ring moved by a nanometre anywhere is not found.
    let mut moved = flat.clone();
    moved[5][0] += 1e-9;
    assert!(table.pieces_of(&moved).is_none());
    assert!(table.pieces_of(&flat[1..]).is_none());
    // Pieces whose starts the polygon lacks are refused.
    assert!(!table.insert(pieces, flat[1..].to_vec()));
}

#[test]
fn long_arcs_are_split_into_equal_parts_on_the_same_circle() {
    let q = (std::f64::consts::PI / 8.0).tan();
    // Nearly a half turn, then a quarter turn back: the first in two, the second kept.
    let pieces = [
        Piece {
            from: [1.0, 0.0],
            bulge: 0.99,
        },
        Piece {
            from: [-1.0, 0.0],
            bulge: q,
        },
    ];
    let split = split_arcs(&pieces, std::f64::consts::FRAC_PI_2);
    assert_eq!(split.len(), 3, "{split:?}");
    assert!((length(&split) - length(&pieces)).abs() < 1e-9);
}

/// Even-odd: whether `p` is inside the closed polygon `r`.
fn inside(r: &[[f64; 2]], p: [f64; 2]) -> bool {
    let n = r.len();
    let mut c = false;
    for i in 0..n {
        let (a, b) = (r[i], r[(i + 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0])
        {
            c = !c;
        }
    }
    c
}

#[test]
fn a_flattening_keeps_points_between_an_arc_and_its_chords_inside() {
    let pieces = half_disc();
    let tol = 0.05;
    // Points a hair inside the arc (radius 2 about (1, 1)) all along it, and some outside it
    // and deep inside: the first are what plain chords cut off.
    let keep: Vec<[f64; 2]> = (1..200)
        .flat_map(|i| {
            let a = std::f64::consts::PI * i as f64 / 200.0;
            [1.999, 2.001, 1.5].map(|r| [1.0 + r * a.cos(), 1.0 + r * a.sin()])
        })
        .collect();
    let plain = flatten(&pieces, tol);
    let clear = flatten_clear(&pieces, tol, &keep);
    let wrong = |flat: &[[f64; 2]]| {
        keep.iter()
            .filter(|&&p| inside(flat, p) != (dist(p, [1.0, 1.0]) < 2.0))
            .count()
    };
    assert!(wrong(&plain) > 100, "{}", wrong(&plain));
    assert_eq!(wrong(&clear), 0);
    // Every vertex still on the arc or the diameter, in order along the path, and the plain
    // flattening's vertices among them.
    for p in &clear {
        assert!(
            (dist(*p, [1.0, 1.0]) - 2.0).abs() < 1e-12 || p[1] == 1.0,
            "{p:?}"
        );
    }
    let ang = |p: &[f64; 2]| (p[1] - 1.0).atan2(p[0] - 1.0);
    for w in clear.windows(2) {
        assert!(w[1][1] == 1.0 || ang(&w[1]) > ang(&w[0]), "{w:?}");
    }
    assert!(plain.iter().all(|p| clear.contains(p)));
    assert_eq!(flatten_clear(&pieces, tol, &[]), plain);
    // Points away from the band add nothing.
    assert_eq!(
        flatten_clear(&pieces, tol, &[[1.0, 1.5], [1.0, 3.5]]),
        plain
    );
}

/// A circle of radius 100 traced as a pixel outline is: 800 vertices, each up to 0.35 off the
/// circle (the steps), the two pixel centres beside each half a unit either side of the circle.
fn stepped_circle() -> (Vec<[f64; 2]>, Vec<[[f64; 2]; 2]>) {
    let n = 800;
    let at = |k: usize, r: f64| {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        [r * a.cos(), r * a.sin()]
    };
    // A deterministic spread of offsets in [-0.35, 0.35] (the golden ratio's multiples).
    let off = |k: usize| 0.7 * ((k as f64 * 0.618_033_988_7).fract() - 0.5);
    let ring = (0..n).map(|k| at(k, 100.0 + off(k))).collect();
    // Counter-clockwise: the inside (the disc) is on the left.
    let sides = (0..n).map(|k| [at(k, 99.5), at(k, 100.5)]).collect();
    (ring, sides)
}

/// The loose chain through a stepped circle: its pieces' circles run through the middle of the
/// steps, so a few long arcs hold where pieces pinned to the vertices (or to the last piece's
/// tangent) hold only short ones: 6 pieces here, 14 without the loose chain, 25 for round 3's fit
/// alone. Every vertex within the tolerance, and the pixel centres on their sides.
#[test]
fn a_stepped_circle_is_a_few_arcs_through_the_middle_of_its_steps() {
    let (ring, pts) = stepped_circle();
    let tol = 0.5;
    let sides = Sides {
        points: &pts,
        margin: 0.01,
    };
    let kept = fit_ring_within(&ring, tol, Some(sides));
    assert!(kept.len() <= 8, "{} pieces", kept.len());
    // The flattening's vertices are on the arcs, every 0.3 units or closer.
    let flat = flatten(&kept, 1e-4);
    let d = one_way(&ring, &flat).max(one_way(&flat, &ring));
    assert!(d <= tol + 1e-3, "{d}");
    for &[l, r] in &pts {
        assert!(inside(&flat, l) && !inside(&flat, r), "{l:?} {r:?}");
    }
}

/// The spread of bulges through a chord is what folding `min` and `max` over every point's
/// bulge gives, to the bit: on points anywhere around the chord, on it, on the circle with the
/// chord as diameter, nearly on the chord, and far from it.
#[test]
fn a_spread_of_bulges_is_the_plain_fold_to_the_bit() {
    // A fixed generator (xorshift), so a failure can be run again.
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut runs_with_none = 0;
    for run in 0..4000 {
        let half = 0.5 + 40.0 * next();
        let n = 1 + (next() * 12.0) as usize;
        let points: Vec<(f64, f64)> = (0..n)
            .map(|_| {
                let u = (2.0 * next() - 1.0) * half;
                let v = match run % 5 {
                    // On the chord, or a rounding's width off it.
                    0 if next() < 0.5 => 0.0,
                    1 => (2.0 * next() - 1.0) * 1e-12,
                    // On the diameter's circle (w = 0 up to rounding).
                    2 => (half * half - u * u).sqrt() * if next() < 0.5 { -1.0 } else { 1.0 },
                    3 => (2.0 * next() - 1.0) * 3.0 * half,
                    _ => (2.0 * next() - 1.0) * half,
                };
                (u, v)
            })
            .collect();
        let mut plain = Some((f64::INFINITY, f64::NEG_INFINITY));
        for &(u, v) in &points {
            plain = match (plain, through(half, u, v)) {
                (Some((lo, hi)), Some(b)) => Some((lo.min(b), hi.max(b))),
                _ => None,
            };
        }
        let mut spread = Spread::new(half);
        let added = points.iter().try_for_each(|&(u, v)| spread.add(u, v));
        match (plain, added) {
            (None, None) => runs_with_none += 1,
            (Some((lo, hi)), Some(())) => {
                let (slo, shi) = spread.range(|| points.iter().copied());
                assert_eq!(
                    (lo.to_bits(), hi.to_bits()),
                    (slo.to_bits(), shi.to_bits()),
                    "run {run}: half {half}, points {points:?}"
                );
            }
            _ => panic!("run {run}: a point past the half turn seen by one and not the other"),
        }
    }
    // Both kinds of run were met.
    assert!(
        runs_with_none > 100 && runs_with_none < 3900,
        "{runs_with_none}"
    );
}
