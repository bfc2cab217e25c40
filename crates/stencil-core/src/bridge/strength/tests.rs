use super::*;
use crate::bridge::config::G;

#[test]
fn sag_follows_the_strip_formula_and_its_inverse() {
    // 3 mm plywood, E 8 GPa, 680 kg/m³: 5·680·9.80665·0.1⁴ / (2·8e9·0.003²) m = 0.0232 mm.
    let ply = StrengthConfig {
        thickness_mm: 3.0,
        youngs_modulus_gpa: 8.0,
        density_kg_m3: 680.0,
        ..Default::default()
    };
    let want = 5.0 * 680.0 * G * 1e-4 / (2.0 * 8e9 * 9e-6) * 1e3;
    assert!((ply.sag_mm(100.0) - want).abs() < 1e-12);
    assert!((want - 0.0232).abs() < 1e-3, "{want}");
    // Four times the span, 256 times the sag; the longest span within the limit sags it.
    assert!((ply.sag_mm(400.0) / ply.sag_mm(100.0) - 256.0).abs() < 1e-9);
    let l = ply.max_span_mm();
    assert!((ply.sag_mm(l) - ply.max_sag_mm).abs() < 1e-9, "{l}");
    // Paper a tenth of the thickness sags a hundred times more (at the same E and ρ).
    let thin = StrengthConfig {
        thickness_mm: 0.3,
        ..ply.clone()
    };
    assert!((thin.sag_mm(100.0) / ply.sag_mm(100.0) - 100.0).abs() < 1e-9);
}

#[test]
fn path_lengths_run_inside_the_island() {
    // A U: from the top of its left arm to the top of its right arm the path runs down and
    // round (27 px), not the 9 px straight across the gap.
    // The grid carries a margin of one empty cell all round: island pixel (x, y) is cell
    // (x + 1, y + 1).
    let (w, h) = (12usize, 12usize);
    let cell = |x: usize, y: usize| (y + 1) * w + x + 1;
    let inside: Vec<bool> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let inner = (1..=10).contains(&x) && (1..=10).contains(&y);
            let (x, y) = (x.wrapping_sub(1), y.wrapping_sub(1));
            inner && (x == 0 || x == 9 || y == 9)
        })
        .collect();
    let l = Local {
        x0: 0,
        y0: 0,
        k: 1,
        w,
        h,
        inside,
    };
    let d = l.field(&[cell(0, 0)]);
    // From (0, 0) to (9, 0): 9 down, 9 across, 9 up; no corner cut at the U's bends (the
    // pixel inside each bend is cut).
    assert_eq!(d[cell(9, 0)], 27 * STEP);
    assert_eq!(d[cell(5, 0)], u32::MAX, "(5, 0) is cut: unreached");
    assert_eq!(l.farthest(&d), (cell(9, 0), 27 * STEP));
    assert_eq!(l.index(9, 0), Some(cell(9, 0)));
    assert_eq!(l.index(5, 0), None);
    assert_eq!(l.index(10, 0), None, "beyond the box");
    assert_eq!(l.centre(cell(9, 0)), (9.5, 0.5));
    // A solid square's far corner is reached diagonally: 9 diagonal steps.
    let solid = Local {
        inside: (0..w * h)
            .map(|i| (1..=10).contains(&(i % w)) && (1..=10).contains(&(i / w)))
            .collect(),
        ..l
    };
    assert_eq!(solid.field(&[cell(0, 0)])[cell(9, 9)], 9 * DIAG);
}

/// The bucket queue's path lengths are a plain Dijkstra's (binary heap, the eight steps
/// tried one by one), on random grids of every density, from one source and from several,
/// and when relaxing an earlier result by a further source.
#[test]
fn relax_is_a_plain_dijkstra() {
    use std::collections::BinaryHeap;
    let plain = |l: &Local, dist: &mut [u32], sources: &[usize]| {
        let mut heap = BinaryHeap::new();
        for &s in sources {
            dist[s] = 0;
            heap.push(Reverse((0u32, s)));
        }
        let w = l.w as isize;
        while let Some(Reverse((d, i))) = heap.pop() {
            if d > dist[i] {
                continue;
            }
            for dy in -1isize..=1 {
                for dx in -1isize..=1 {
                    let at = |dx: isize, dy: isize| (i as isize + dx + dy * w) as usize;
                    let j = at(dx, dy);
                    if (dx, dy) == (0, 0) || !l.inside[j] {
                        continue;
                    }
                    let diag = dx != 0 && dy != 0;
                    if diag && !(l.inside[at(dx, 0)] && l.inside[at(0, dy)]) {
                        continue;
                    }
                    let nd = d + if diag { DIAG } else { STEP };
                    if nd < dist[j] {
                        dist[j] = nd;
                        heap.push(Reverse((nd, j)));
                    }
                }
            }
        }
    };
    let mut rng = crate::test_rng::Lcg(0x51ab_1e5e_ed00_d1e5);
    let mut next = move || rng.next_u64() >> 33;
    for k in 0..60usize {
        let (w, h) = (3 + k % 23, 3 + (k * 7) % 19);
        let fill = 30 + next() % 70;
        let inside: Vec<bool> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                x > 0 && y > 0 && x + 1 < w && y + 1 < h && next() % 100 < fill
            })
            .collect();
        let cells: Vec<usize> = (0..w * h).filter(|&i| inside[i]).collect();
        if cells.is_empty() {
            continue;
        }
        let l = Local {
            x0: 0,
            y0: 0,
            k: 1,
            w,
            h,
            inside,
        };
        let pick = |r: u64| cells[r as usize % cells.len()];
        let sources: Vec<usize> = (0..1 + k % 3).map(|_| pick(next())).collect();
        let mut want = vec![u32::MAX; w * h];
        plain(&l, &mut want, &sources);
        let mut got = l.field(&sources);
        assert_eq!(got, want, "grid {k}");
        let more = pick(next());
        plain(&l, &mut want, &[more]);
        l.relax(&mut got, &[more]);
        assert_eq!(got, want, "grid {k}, one more source");
    }
}

#[test]
fn angles_apart_wrap_round() {
    assert_eq!(apart(170.0, -170.0), 20.0);
    assert_eq!(apart(0.0, 90.0), 90.0);
    assert_eq!(apart(-90.0, 90.0), 180.0);
}

#[test]
fn bad_settings_are_named() {
    let c = StrengthConfig {
        per_island: 0,
        ..Default::default()
    };
    assert_eq!(c.check().unwrap_err().0, "bridges_per_island");
    let c = StrengthConfig {
        max_sag_mm: f64::NAN,
        ..Default::default()
    };
    assert_eq!(c.check().unwrap_err().0, "max_sag_mm");
}
