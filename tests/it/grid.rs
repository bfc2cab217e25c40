//! `stencil test-grid`: the squares and their S/F values in the G-code are the requested grid,
//! the grid stays on the bed, the SVG labels say what each square is cut at, an oversized grid is
//! refused, and the G-code streams through the virtual Grbl line by line.

use std::path::Path;
use std::process::{Command, Output};

use stencil_gcode::interpret::interpret;

fn stencil(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_stencil"))
        .args(args)
        // No settings a developer kept in their own config folder.
        .env(
            "STENCIL_CONFIG_DIR",
            std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("no-kept-settings"),
        )
        .output()
        .unwrap()
}

/// (S, F) of each square's first cutting move, in order, with the four corners it cut.
fn squares(gcode: &str) -> Vec<(f64, f64, Vec<[f64; 2]>)> {
    let moves = interpret(gcode).unwrap();
    let cuts: Vec<_> = moves.iter().filter(|m| m.power > 0.0).collect();
    assert_eq!(cuts.len() % 4, 0);
    cuts.chunks(4)
        .map(|c| {
            assert!(c
                .iter()
                .all(|m| m.power == c[0].power && m.feed == c[0].feed));
            (
                c[0].power,
                c[0].feed,
                c.iter().map(|m| [m.to[0], m.to[1]]).collect(),
            )
        })
        .collect()
}

/// The `; square ...` comments.
fn comments(gcode: &str) -> Vec<&str> {
    gcode
        .lines()
        .filter(|l| l.starts_with("; square "))
        .collect()
}

/// The SVG's square labels: (row, col, text).
fn svg_labels(svg: &str) -> Vec<(usize, usize, String)> {
    svg.lines()
        .filter(|l| l.contains("class=\"cell\""))
        .map(|l| {
            let attr = |name: &str| {
                let i = l.find(&format!("{name}=\"")).unwrap() + name.len() + 2;
                l[i..i + l[i..].find('"').unwrap()].to_string()
            };
            let text = &l[l.find('>').unwrap() + 1..l.rfind("</text>").unwrap()];
            (
                attr("data-row").parse().unwrap(),
                attr("data-col").parse().unwrap(),
                text.to_string(),
            )
        })
        .collect()
}

#[test]
fn laser_grid_has_the_requested_squares_labelled_and_on_the_bed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("grid.gcode");
    let o = out.to_str().unwrap();
    let r = stencil(&[
        "test-grid",
        "--machine",
        "diode-400",
        "--material",
        "cardstock",
        "-o",
        o,
        "--power",
        "20..100:5",
        "--speed",
        "300..1500:4",
        // One cut per square (cardstock on the 5.5 W diode takes two passes).
        "--passes",
        "1",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let g = std::fs::read_to_string(&out).unwrap();
    let sq = squares(&g);
    assert_eq!(sq.len(), 20);
    let powers = [20.0, 40.0, 60.0, 80.0, 100.0];
    let speeds = [300.0, 700.0, 1100.0, 1500.0];
    for (i, (s, f, corners)) in sq.iter().enumerate() {
        let (row, col) = (i / 4, i % 4);
        // S = power % of $30 = 1000 on diode-400.
        assert_eq!(*s, powers[row] * 10.0, "square {i}");
        assert_eq!(*f, speeds[col], "square {i}");
        // A 10 mm square at 15 mm pitch from (5, 5).
        let (x, y) = (5.0 + 15.0 * col as f64, 5.0 + 15.0 * row as f64);
        assert_eq!(
            corners,
            &vec![[x + 10.0, y], [x + 10.0, y + 10.0], [x, y + 10.0], [x, y]]
        );
    }
    // Nothing leaves the bed, and the travel is dark.
    for m in interpret(&g).unwrap() {
        assert!(m.to[0] >= 0.0 && m.to[0] <= 400.0 && m.to[1] >= 0.0 && m.to[1] <= 400.0);
        if m.rapid {
            assert_eq!(m.power, 0.0);
        }
    }
    let c = comments(&g);
    assert_eq!(c.len(), 20);
    assert_eq!(
        c[6],
        "; square 7 of 20, row 2 column 3: power 40 % S400, speed 1100 mm/min"
    );
    // The program's end: beam off, then home and M2 (the writer's end for every job).
    let tail: Vec<&str> = g.trim_end().lines().rev().take(4).collect();
    assert!(
        g.contains("M4 S0") && tail[0] == "M2" && tail.contains(&"M5 S0"),
        "{g}"
    );
    // The preview beside it labels every square with what it is cut at.
    let svg = std::fs::read_to_string(dir.path().join("grid.svg")).unwrap();
    let labels = svg_labels(&svg);
    assert_eq!(labels.len(), 20);
    for (row, col, text) in &labels {
        let p = powers[row - 1];
        let f = speeds[col - 1];
        assert_eq!(text, &format!("{p}% F{f}"));
    }
    assert!(svg.contains(">power 60 % (S600)</text>"), "{svg}");
    assert!(svg.contains(">F1100</text>") && svg.contains("width=\"") && svg.contains("mm\""));
    // Streamed through the virtual Grbl (after check mode), every line accepted.
    let lines = g
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with(';'))
        .count();
    let r = stencil(&["send", o, "--dry-run", "--check"]);
    let so = String::from_utf8_lossy(&r.stdout);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(so.contains(&format!("sent {lines} lines")), "{so}");
    assert!(so.contains("laser off"), "{so}");
}

#[test]
fn defaults_centre_on_the_material() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("g.gcode");
    let r = stencil(&[
        "test-grid",
        "--material",
        "cardstock",
        "-o",
        out.to_str().unwrap(),
        "--passes",
        "1",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert!(
        stdout.contains("stencil profiles set cardstock --machine diode-400 --power P"),
        "the grid says how to keep what it finds: {stdout}"
    );
    let sq = squares(&std::fs::read_to_string(&out).unwrap());
    assert_eq!(sq.len(), 25);
    // cardstock on the default 5.5 W diode: 48 % at 1650 mm/min, the middle square.
    assert_eq!((sq[12].0, sq[12].1), (480.0, 1650.0));
    assert_eq!((sq[0].0, sq[0].1), (240.0, 825.0));
    assert_eq!((sq[24].0, sq[24].1), (720.0, 2475.0));
}

#[test]
fn an_oversized_grid_is_refused_naming_the_size_and_the_bed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big.gcode");
    let r = stencil(&[
        "test-grid",
        "--machine",
        "pen-servo",
        "--speed",
        "500..5000:20",
        "--size",
        "12",
        "-o",
        out.to_str().unwrap(),
    ]);
    let se = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1));
    // 20 x 12 + 19 x 5 = 335 mm wide on a 300 x 220 mm bed.
    assert!(
        se.contains("335.0 x 12.0 mm")
            && se.contains("pen-servo")
            && se.contains("300.0 x 220.0 mm"),
        "{se}"
    );
    assert!(!out.exists() && !dir.path().join("big.svg").exists());
}

#[test]
fn knife_grid_varies_depth_and_pen_grid_speed_only() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("k.gcode");
    let r = stencil(&[
        "test-grid",
        "--machine",
        "drag-knife",
        "--speed",
        "300..900:3",
        "--depth",
        "-0.1..-0.3:3",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let g = std::fs::read_to_string(&out).unwrap();
    let plunges: Vec<&str> = g.lines().filter(|l| l.starts_with("G1 Z")).collect();
    assert_eq!(plunges.len(), 9);
    for (i, p) in plunges.iter().enumerate() {
        let d = ["-0.1", "-0.2", "-0.3"][i / 3];
        assert_eq!(*p, format!("G1 Z{d} F300"), "square {i}");
    }
    let svg = std::fs::read_to_string(dir.path().join("k.svg")).unwrap();
    assert!(
        svg_labels(&svg).contains(&(2, 3, "Z-0.2 F900".to_string())),
        "{svg}"
    );
    assert!(svg.contains(">depth Z-0.3</text>"));
    // Every cutting move of a square runs at its depth.
    let moves = interpret(&g).unwrap();
    assert!(moves
        .iter()
        .filter(|m| !m.rapid && m.to[0] != m.from[0])
        .all(|m| m.to[2] < 0.0));
    let r = stencil(&[
        "test-grid",
        "--machine",
        "pen-a3",
        "--power",
        "10..50",
        "-o",
        out.to_str().unwrap(),
    ]);
    let se = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1));
    assert!(
        se.contains("--power") && se.contains("has no power") && se.contains("--speed"),
        "{se}"
    );
    let r = stencil(&[
        "test-grid",
        "--machine",
        "pen-a3",
        "--speed",
        "1000..4000:4",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(Path::new(&out).exists());
    let g = std::fs::read_to_string(&out).unwrap();
    assert_eq!(comments(&g).len(), 4);
    assert!(comments(&g)[3].ends_with("square 4 of 4, row 1 column 4: speed 4000 mm/min"));
}
