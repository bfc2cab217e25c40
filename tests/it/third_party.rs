//! Jobs from other programs (issue 26): files in the styles LightBurn, LaserGRBL, Inkscape's
//! gcodetools, vpype and svg2gcode write (arcs in I/J and R form, full circles, inches, N line
//! numbers, `;` and `( )` comments, `%` delimiters), written for these tests from the programs'
//! documented output, not copied from them. Each must stream dry through the virtual Grbl,
//! estimate and simulate, with arcs followed as Grbl follows them.

use std::path::{Path, PathBuf};
use std::process::Command;

use stencil_gcode::interpret::{interpret, CutRule, Move};
use stencil_gcode::simulate;

fn stencil() -> Command {
    Command::new(env!("CARGO_BIN_EXE_stencil"))
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/third_party")
        .join(name)
}

/// (file, arcs in it, its cutting extent in mm: min x, min y, max x, max y).
const JOBS: &[(&str, usize, [f64; 4])] = &[
    // The G3 quarter ends at (60,70); the full circle about (50,35) reaches Y25..45.
    ("lightburn.gc", 2, [20.0, 20.0, 80.0, 70.0]),
    // The R25 half circle from (80,60) to (30,60) clockwise dips to Y35.
    ("lasergrbl.nc", 3, [30.0, 30.0, 80.0, 60.0]),
    ("gcodetools.ngc", 2, [40.0, 40.0, 80.0, 80.0]),
    // Inches: 1..3 in is 25.4..76.2 mm.
    ("vpype.gcode", 1, [25.4, 25.4, 76.2, 76.2]),
    // The R25 arc from (25,75) to (25,25) counter-clockwise bulges left to X0.
    ("svg2gcode.gcode", 2, [0.0, 25.0, 100.0, 75.0]),
];

fn cut_extent(moves: &[Move]) -> [f64; 4] {
    let rule = CutRule::infer(moves);
    let mut e = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for m in moves.iter().filter(|m| rule.cuts(m)) {
        for p in [m.from, m.to] {
            e[0] = e[0].min(p[0]);
            e[1] = e[1].min(p[1]);
            e[2] = e[2].max(p[0]);
            e[3] = e[3].max(p[1]);
        }
    }
    e
}

#[test]
fn every_job_is_read_with_its_arcs_true() {
    for &(name, arcs, want) in JOBS {
        let text = std::fs::read_to_string(fixture(name)).unwrap();
        let moves = interpret(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
        let got = cut_extent(&moves);
        for k in 0..4 {
            assert!(
                (got[k] - want[k]).abs() < 0.05,
                "{name}: cut extent {got:?}, want {want:?}"
            );
        }
        // Each arc is many chords on one line (Grbl cuts it at $12 = 0.002 mm).
        let mut per_line = std::collections::BTreeMap::<usize, usize>::new();
        for m in &moves {
            *per_line.entry(m.line).or_default() += 1;
        }
        let arc_lines = per_line.values().filter(|&&n| n > 10).count();
        assert_eq!(arc_lines, arcs, "{name}: {per_line:?}");
    }
}

#[test]
fn simulate_draws_an_arc_as_an_arc() {
    // LightBurn's full circle about (50,35), r 10: its lowest point (50,25) is drawn, and the
    // chord a straight line would take (straight from (50,45) back to itself) is nothing.
    let text = std::fs::read_to_string(fixture("lightburn.gc")).unwrap();
    let moves = interpret(&text).unwrap();
    let d = simulate::draw(&moves, 1000, CutRule::infer(&moves));
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for m in &moves {
        for p in [m.from, m.to] {
            for a in 0..2 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
    }
    let px = |x: f64, y: f64| {
        let c = ((x - lo[0]) / d.mm_per_px + 8.0).round() as u32;
        let r = ((hi[1] - y) / d.mm_per_px + 8.0).round() as u32;
        let i = ((r * d.width + c) * 3) as usize;
        [d.rgb[i], d.rgb[i + 1], d.rgb[i + 2]]
    };
    for (x, y) in [
        (50.0, 25.0),
        (40.0, 35.0),
        (60.0, 35.0),
        (50.0 + 7.071, 35.0 - 7.071),
    ] {
        assert_eq!(px(x, y), simulate::CUT_RGB, "({x}, {y}) on the circle");
    }
    assert_ne!(px(50.0, 35.0), simulate::CUT_RGB, "the centre is not cut");
}

#[test]
fn every_job_streams_dry_estimates_and_simulates() {
    let dir = tempfile::tempdir().unwrap();
    for &(name, _, _) in JOBS {
        let file = fixture(name);
        let out = stencil()
            .args(["send", "--dry-run"])
            .arg(&file)
            .output()
            .unwrap();
        let so = String::from_utf8_lossy(&out.stdout);
        let se = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "send {name}: {so}\n{se}");
        assert!(so.contains("sent "), "send {name}: {so}");
        if name == "gcodetools.ngc" {
            assert!(so.contains("2 `%` line(s) left out"), "{so}");
        }

        let out = stencil().arg("estimate").arg(&file).output().unwrap();
        let so = String::from_utf8_lossy(&out.stdout);
        let se = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "estimate {name}: {so}\n{se}");
        assert!(so.contains("about"), "estimate {name}: {so}");

        let png = dir.path().join(format!("{name}.png"));
        let out = stencil()
            .arg("simulate")
            .arg(&file)
            .arg("-o")
            .arg(&png)
            .output()
            .unwrap();
        let so = String::from_utf8_lossy(&out.stdout);
        let se = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "simulate {name}: {so}\n{se}");
        let img = image::open(&png).unwrap().to_rgb8();
        assert!(
            img.pixels().any(|p| p.0 == simulate::CUT_RGB),
            "simulate {name}: nothing drawn as cut"
        );
    }
}

#[test]
fn a_job_with_m0_is_not_streamed_without_someone_to_resume_it() {
    // Grbl holds at M0 until cycle start: without a terminal nobody can give it, so send says
    // so up front instead of waiting for ever.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("pause.gcode");
    std::fs::write(&file, "G21 G90\nG0 X1\nM0 (check the sheet)\nG0 X2\n").unwrap();
    let out = stencil()
        .args(["send", "--dry-run"])
        .arg(&file)
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    let se = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        se.contains("line 3 has M0") && se.contains("terminal"),
        "{se}"
    );
}
