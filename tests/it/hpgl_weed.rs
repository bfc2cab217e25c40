//! Weeding aids on a plotter job (issue 45, item 3): `--weed-lines` split only a large cut-out
//! area (never the stencil between cuts, never a small hole), `--weed-box` surrounds every cut.
//! Read from the written `.plt`: the cuts a weeded job adds to the same job without weeding.

use std::collections::BTreeSet;

use crate::common::{s, stderr, stencil, tmp};
use crate::hpgl_send::cut_segments;

type Seg = ([i64; 2], [i64; 2]);

/// Bounding boxes of each stroke (a PU, then PDs) of a file, plotter units.
fn strokes(text: &str) -> Vec<([i64; 2], [i64; 2])> {
    let mut boxes: Vec<([i64; 2], [i64; 2])> = Vec::new();
    let mut last_end = None;
    for (a, b) in cut_segments(text) {
        if last_end != Some(a) {
            boxes.push((a, a));
        }
        let bx = boxes.last_mut().unwrap();
        for p in [a, b] {
            bx.0 = [bx.0[0].min(p[0]), bx.0[1].min(p[1])];
            bx.1 = [bx.1[0].max(p[0]), bx.1[1].max(p[1])];
        }
        last_end = Some(b);
    }
    boxes
}

#[test]
fn weeding_lines_split_only_the_large_hole_and_the_box_surrounds_the_cuts() {
    let dir = tmp();
    let svg = dir.path().join("d.svg");
    std::fs::write(
        &svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="60mm" viewBox="0 0 100 60">
<path d="M10 10H70V40H10Z"/><path d="M80 10H85V15H80Z"/></svg>"#,
    )
    .unwrap();
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "hpgl",
            s(&svg),
            "--machine",
            "vinyl-hpgl",
            "--material",
            "vinyl-0.08",
            "--blade-offset",
            "0",
            "-o",
            s(&out),
        ];
        args.extend(extra);
        let o = stencil(&args);
        let so = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(o.status.success(), "{so}{}", stderr(&o));
        (std::fs::read_to_string(&out).unwrap(), so)
    };
    let (plain, so) = run("plain.plt", &[]);
    assert!(!so.contains("weeding"), "{so}");
    let (weeded, so) = run("weeded.plt", &["--weed-lines", "15", "--weed-box", "5"]);
    assert!(
        so.contains("weeding: 8 line(s) inside cut-out areas, a box around the job"),
        "{so}"
    );
    // The holes, as the plain job cuts them: the large one (60 x 30 mm) and the small one.
    // The weeded job moves in just as far as its box needs (the plain one sits at the origin):
    // 5 mm, and 0.05 mm the head may go beyond the box (no blade offset here), 202 units.
    let plain_raw = cut_segments(&plain);
    let lo0 = plain_raw
        .iter()
        .flat_map(|(a, b)| [*a, *b])
        .fold([i64::MAX; 2], |m, p| [m[0].min(p[0]), m[1].min(p[1])]);
    let shift = [(202 - lo0[0]).max(0), (202 - lo0[1]).max(0)];
    assert!(
        shift != [0, 0],
        "the test expects the job at the origin: {lo0:?}"
    );
    let plain: String = plain_raw
        .iter()
        .map(|(a, b)| {
            format!(
                "PU{},{};PD{},{};",
                a[0] + shift[0],
                a[1] + shift[1],
                b[0] + shift[0],
                b[1] + shift[1]
            )
        })
        .collect();
    let mut holes = strokes(&plain);
    holes.sort_by_key(|(lo, hi)| -(hi[0] - lo[0]) * (hi[1] - lo[1]));
    let (big, small) = (holes[0], holes[1]);
    assert_eq!((big.1[0] - big.0[0], big.1[1] - big.0[1]), (2400, 1200));
    let all_lo = [big.0[0].min(small.0[0]), big.0[1].min(small.0[1])];
    let all_hi = [big.1[0].max(small.1[0]), big.1[1].max(small.1[1])];
    let plain_set: BTreeSet<Seg> = cut_segments(&plain).into_iter().collect();
    let added: Vec<Seg> = cut_segments(&weeded)
        .into_iter()
        .filter(|s| !plain_set.contains(s))
        .collect();
    // Every cut of the plain job is still there.
    let weeded_set: BTreeSet<Seg> = cut_segments(&weeded).into_iter().collect();
    assert!(plain_set.is_subset(&weeded_set));
    let on_box = |p: [i64; 2]| {
        let (lo, hi) = (
            [all_lo[0] - 200, all_lo[1] - 200],
            [all_hi[0] + 200, all_hi[1] + 200],
        );
        let inside = (lo[0]..=hi[0]).contains(&p[0]) && (lo[1]..=hi[1]).contains(&p[1]);
        inside && (p[0] == lo[0] || p[0] == hi[0] || p[1] == lo[1] || p[1] == hi[1])
    };
    let (boxed, lines): (Vec<Seg>, Vec<Seg>) = added
        .into_iter()
        .partition(|(a, b)| on_box(*a) && on_box(*b));
    // The box: all four sides, 5 mm (200 units) outside the cuts.
    let sides: BTreeSet<(bool, i64)> = boxed
        .iter()
        .map(|(a, b)| {
            if a[0] == b[0] {
                (true, a[0])
            } else {
                (false, a[1])
            }
        })
        .collect();
    assert_eq!(
        sides,
        BTreeSet::from([
            (true, all_lo[0] - 200),
            (true, all_hi[0] + 200),
            (false, all_lo[1] - 200),
            (false, all_hi[1] + 200)
        ])
    );
    // The weeding lines: inside the large hole only (the stencil between the cuts and the small
    // hole untouched), from boundary to boundary, 15 mm (600 units) apart from its corner.
    let in_big = |p: [i64; 2]| {
        (big.0[0]..=big.1[0]).contains(&p[0]) && (big.0[1]..=big.1[1]).contains(&p[1])
    };
    assert_eq!(lines.len(), 8, "{lines:?}");
    for (a, b) in &lines {
        assert!(
            in_big(*a) && in_big(*b),
            "a weeding line leaves the hole: {a:?} {b:?}"
        );
    }
    let mut xs: BTreeSet<i64> = BTreeSet::new();
    let mut ys: BTreeSet<i64> = BTreeSet::new();
    for (a, b) in &lines {
        if a[0] == b[0] {
            xs.insert(a[0]);
            // Each half runs from the middle to an edge of the hole.
            assert!(b[1] == big.0[1] || b[1] == big.1[1], "{a:?} {b:?}");
        } else {
            ys.insert(a[1]);
            assert!(b[0] == big.0[0] || b[0] == big.1[0], "{a:?} {b:?}");
        }
    }
    let x0 = big.0[0];
    assert_eq!(xs, BTreeSet::from([x0 + 600, x0 + 1200, x0 + 1800]));
    assert_eq!(ys, BTreeSet::from([big.0[1] + 600]));
    // Cut before the holes (while the sheet is whole), the box after them.
    let pos = |seg: &Seg| cut_segments(&weeded).iter().position(|s| s == seg).unwrap();
    let first_hole = cut_segments(&weeded)
        .iter()
        .position(|s| plain_set.contains(s))
        .unwrap();
    assert!(lines.iter().all(|l| pos(l) < first_hole));
    assert!(boxed.iter().all(|l| pos(l) > first_hole));
}
