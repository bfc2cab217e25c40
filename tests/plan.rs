//! The planning side at the machine (issue 14): cut order by freed islands, one cut rule for
//! simulate and estimate, tool-matching default materials, program end and header comments, air
//! assist, and the bed check on send, estimate and simulate. Every test runs the `stencil` binary
//! or reads the files it writes.

mod common;

use std::path::{Path, PathBuf};

use geo::{ConvexHull, Coord, Intersects, MultiPoint, Point, Polygon};
use stencil::machine::gcode::interpret;

fn samples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("samples")
}

/// Run the binary; (success, stdout, stderr).
fn run(args: &[&str]) -> (bool, String, String) {
    let o = common::stencil(args);
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The cut loops of a laser program in the order it cuts them: runs of moves with the beam on.
fn laser_loops(text: &str) -> Vec<Vec<[f64; 2]>> {
    let mut out: Vec<Vec<[f64; 2]>> = Vec::new();
    let mut cutting = false;
    for m in interpret(text).unwrap() {
        if !m.rapid && m.power > 0.0 {
            if !cutting {
                out.push(vec![[m.from[0], m.from[1]]]);
            }
            out.last_mut().unwrap().push([m.to[0], m.to[1]]);
            cutting = true;
        } else {
            cutting = false;
        }
    }
    out
}

fn hull(points: &[[f64; 2]]) -> Polygon<f64> {
    MultiPoint::from(
        points
            .iter()
            .map(|p| Point::new(p[0], p[1]))
            .collect::<Vec<_>>(),
    )
    .convex_hull()
}

/// Pairs (inner, outer) of loops where every vertex of `inner` lies in the convex hull of
/// `outer` (geo's hull and point test, not the planner's), and no vertex of `outer` lies in
/// the hull of `inner` (a true nesting, not twins).
fn nested_pairs(loops: &[Vec<[f64; 2]>]) -> Vec<(usize, usize)> {
    let hulls: Vec<Polygon<f64>> = loops.iter().map(|l| hull(l)).collect();
    let inside = |l: &[[f64; 2]], h: &Polygon<f64>| {
        l.iter().all(|p| h.intersects(&Coord { x: p[0], y: p[1] }))
    };
    let mut pairs = Vec::new();
    for (a, la) in loops.iter().enumerate() {
        for (b, lb) in loops.iter().enumerate() {
            if a != b && inside(la, &hulls[b]) && !inside(lb, &hulls[a]) {
                pairs.push((a, b));
            }
        }
    }
    pairs
}

/// Every loop lying inside another's hull is cut before it; returns the nested pairs found.
fn assert_inside_first(text: &str, what: &str) -> Vec<(usize, usize)> {
    let loops = laser_loops(text);
    let pairs = nested_pairs(&loops);
    for &(inner, outer) in &pairs {
        assert!(
            inner < outer,
            "{what}: loop {inner} (of {}) lies inside loop {outer}'s hull but is cut after it",
            loops.len()
        );
    }
    pairs
}

/// The longest chain of loops each inside the next's hull.
fn nesting_depth(n: usize, pairs: &[(usize, usize)]) -> usize {
    // Longest path in the containment DAG (inner -> outer).
    let mut depth = vec![1usize; n];
    // Cut order is a topological order once inside-first holds: inner < outer.
    let mut sorted = pairs.to_vec();
    sorted.sort();
    for _ in 0..n {
        for &(a, b) in &sorted {
            depth[b] = depth[b].max(depth[a] + 1);
        }
    }
    depth.into_iter().max().unwrap_or(0)
}

#[test]
fn rings_are_cut_from_the_inside_out() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rings");
    let (ok, _, err) = run(&[
        "make",
        s(&samples().join("rings.png")),
        "-o",
        s(&out),
        "--emit",
        "svg,gcode",
    ]);
    assert!(ok, "{err}");
    let text = std::fs::read_to_string(out.join("stencil.gcode")).unwrap();
    let pairs = assert_inside_first(&text, "rings");
    // Five cut rings, each C-shaped by its bridge, each inside the next: a chain of five.
    assert_eq!(laser_loops(&text).len(), 5);
    assert_eq!(nesting_depth(5, &pairs), 5, "{pairs:?}");
}

/// A target whose paper disc holds two smaller targets side by side, each with a paper disc
/// holding a ring around a paper dot with an ink dot in it: islands three deep, siblings at each
/// level, and a lone dot on the big island.
fn nested_targets(path: &Path) {
    let ring = |x: f64, y: f64, cx: f64, cy: f64, r_in: f64, r_out: f64| {
        let d = ((x - cx).powi(2) + (y - cy).powi(2)).sqrt();
        d >= r_in && d <= r_out
    };
    common::smooth_png(path, 400, 400, |x, y| {
        let mut ink = ring(x, y, 200.0, 200.0, 160.0, 180.0) || ring(x, y, 200.0, 110.0, 0.0, 12.0);
        for cx in [130.0, 270.0] {
            ink |= ring(x, y, cx, 215.0, 45.0, 60.0)
                || ring(x, y, cx, 215.0, 25.0, 35.0)
                || ring(x, y, cx, 215.0, 0.0, 10.0);
        }
        if ink {
            0.0
        } else {
            1.0
        }
    });
}

#[test]
fn islands_inside_islands_are_cut_before_what_holds_them() {
    let dir = tempfile::tempdir().unwrap();
    let pic = dir.path().join("targets.png");
    nested_targets(&pic);
    let out = dir.path().join("t");
    let (ok, _, err) = run(&[
        "make",
        s(&pic),
        "-o",
        s(&out),
        "--emit",
        "svg,gcode",
        "--cut-outline",
    ]);
    assert!(ok, "{err}");
    let text = std::fs::read_to_string(out.join("stencil.gcode")).unwrap();
    let loops = laser_loops(&text);
    // 1 outer ring + 1 lone dot + 2 x (ring, ring, dot) + the sheet outline.
    assert_eq!(loops.len(), 9, "loops");
    let pairs = assert_inside_first(&text, "nested targets");
    // outline > outer ring > ring > ring > dot.
    assert_eq!(nesting_depth(loops.len(), &pairs), 5, "{pairs:?}");
    // The outline is last.
    let last = &loops[loops.len() - 1];
    let xs: Vec<f64> = last.iter().map(|p| p[0]).collect();
    assert!(
        xs.iter().cloned().fold(f64::MAX, f64::min) < 0.01,
        "outline last"
    );
}

/// The first "`key`N mm" in `text` ("cut 241 mm" -> 241).
fn mm_after(text: &str, key: &str) -> f64 {
    text.match_indices(key)
        .find_map(|(at, _)| {
            let rest = &text[at + key.len()..];
            rest[..rest.find(" mm")?].trim().parse().ok()
        })
        .unwrap_or_else(|| panic!("no '{key}N mm' in {text}"))
}

/// `make` letters.png for `machine` with no --material; the output folder.
fn make_for(dir: &Path, machine: &str) -> PathBuf {
    let out = dir.join(machine);
    let (ok, _, err) = run(&[
        "make",
        s(&samples().join("letters.png")),
        "-o",
        s(&out),
        "--emit",
        "svg,gcode",
        "--machine",
        machine,
    ]);
    assert!(ok, "{machine}: {err}");
    out
}

#[test]
fn naming_only_a_machine_picks_a_material_for_its_tool() {
    let dir = tempfile::tempdir().unwrap();
    for (machine, material, tool_on) in [
        ("pen-a3", "plotter-paper", "G1 Z0 F1500"),
        ("drag-knife", "cardstock-knife", "G1 Z-0.3 F300"),
        ("pen-servo", "plotter-paper", "M3 S1000"),
        ("diode-400", "cardstock", "M4 S0"),
    ] {
        let out = make_for(dir.path(), machine);
        let report = std::fs::read_to_string(out.join("report.json")).unwrap();
        assert!(
            report.contains(&format!("\"material\": \"{material}\"")),
            "{machine}: {report:.300}"
        );
        let text = std::fs::read_to_string(out.join("stencil.gcode")).unwrap();
        assert!(
            text.contains(&format!("; material {material}")),
            "{machine}"
        );
        assert!(
            text.lines().any(|l| l.starts_with(tool_on)),
            "{machine}: no '{tool_on}'"
        );
        let laser = text.contains("M4");
        assert_eq!(laser, machine == "diode-400", "{machine}: laser words");
    }
    // A folder made for a laser, drawn with a pen: the pen's material, said in a note.
    let laser_dir = dir.path().join("diode-400");
    let pen = dir.path().join("pen.gcode");
    let (ok, _, err) = run(&["gcode", s(&laser_dir), "--machine", "pen-a3", "-o", s(&pen)]);
    assert!(ok && err.contains("'plotter-paper'"), "{err}");
    // A material the user names for the wrong tool is still an error that says so.
    let (ok, _, err) = run(&[
        "gcode",
        s(&laser_dir),
        "--machine",
        "pen-a3",
        "--material",
        "cardstock",
        "-o",
        s(&pen),
    ]);
    assert!(!ok && err.contains("set up for a laser"), "{err}");
}

#[test]
fn simulate_and_estimate_agree_on_pen_and_knife_cuts() {
    let dir = tempfile::tempdir().unwrap();
    for machine in ["pen-a3", "drag-knife", "pen-servo"] {
        let out = make_for(dir.path(), machine);
        let job = out.join("stencil.gcode");
        let (ok, est, err) = run(&["estimate", s(&job), "--machine", machine]);
        assert!(ok, "{err}");
        let png = out.join("sim.png");
        let (ok, sim, err) = run(&["simulate", s(&job), "-o", s(&png), "--machine", machine]);
        assert!(ok, "{err}");
        let (e_cut, s_cut) = (mm_after(&est, "cut "), mm_after(&sim, "cut "));
        assert!(e_cut > 100.0, "{machine}: estimate cut {e_cut} mm: {est}");
        assert_eq!(e_cut, s_cut, "{machine}: estimate {est} vs simulate {sim}");
        // The picture shows the cuts in cut colour, not as travel.
        let img = image::open(&png).unwrap().to_rgb8();
        let red = img
            .pixels()
            .filter(|p| p.0 == stencil::machine::simulate::CUT_RGB)
            .count();
        let blue = img
            .pixels()
            .filter(|p| p.0 == stencil::machine::simulate::TRAVEL_RGB)
            .count();
        assert!(
            red > 1000 && blue > 0,
            "{machine}: {red} cut px, {blue} travel px"
        );
    }
}
