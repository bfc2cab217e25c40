//! The planning side at the machine (issue 14): cut order by freed islands, one cut rule for
//! simulate and estimate, tool-matching default materials, program end and header comments, air
//! assist, and the bed check on send, estimate and simulate. Every test runs the `stencil` binary
//! or reads the files it writes.

use crate::common;

use std::path::{Path, PathBuf};

use geo::{ConvexHull, Coord, Intersects, MultiPoint, Point, Polygon};
use stencil_gcode::interpret::interpret;

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

/// `make` the picture `pic` into `out` with G-code and `extra` options; the program's text.
fn make_gcode(pic: &Path, out: &Path, extra: &[&str]) -> String {
    let mut args = vec!["make", s(pic), "-o", s(out), "--emit", "svg,gcode"];
    args.extend_from_slice(extra);
    let (ok, _, err) = run(&args);
    assert!(ok, "{err}");
    std::fs::read_to_string(out.join("stencil.gcode")).unwrap()
}

/// The middle of the box around everything cut (the centre of a symmetric design).
fn centre_of(loops: &[Vec<[f64; 2]>]) -> [f64; 2] {
    let (lo, hi) = loops
        .iter()
        .flatten()
        .fold(([f64::MAX; 2], [f64::MIN; 2]), |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        });
    [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0]
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
    let text = make_gcode(&pic, &dir.path().join("t"), &["--cut-outline"]);
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
    // A folder made for a laser, drawn with a pen: its material does not fit the tool, and the
    // error names the one that does; naming it works.
    let laser_dir = dir.path().join("diode-400");
    let pen = dir.path().join("pen.gcode");
    let (ok, _, err) = run(&["gcode", s(&laser_dir), "--machine", "pen-a3", "-o", s(&pen)]);
    assert!(
        !ok && err.contains("set up for a laser") && err.contains("plotter-paper"),
        "{err}"
    );
    let (ok, _, err) = run(&[
        "gcode",
        s(&laser_dir),
        "--machine",
        "pen-a3",
        "--material",
        "plotter-paper",
        "-o",
        s(&pen),
    ]);
    assert!(ok, "{err}");
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
            .filter(|p| p.0 == stencil_gcode::simulate::CUT_RGB)
            .count();
        let blue = img
            .pixels()
            .filter(|p| p.0 == stencil_gcode::simulate::TRAVEL_RGB)
            .count();
        assert!(
            red > 1000 && blue > 0,
            "{machine}: {red} cut px, {blue} travel px"
        );
    }
}

/// The header's comment lines, joined back into words.
fn header_words(text: &str) -> String {
    text.lines()
        .take_while(|l| l.starts_with(';'))
        .map(|l| l.trim_start_matches(';').trim())
        .collect::<Vec<_>>()
        .join(" ")
}

#[test]
fn programs_end_with_m2_and_header_comments_wrap_whole_and_legal() {
    let dir = tempfile::tempdir().unwrap();
    for name in stencil_gcode::machine::builtin_names() {
        let machine = stencil_gcode::machine::load(Some(name)).unwrap();
        let out = make_for(dir.path(), name);
        let text = std::fs::read_to_string(out.join("stencil.gcode")).unwrap();
        assert_eq!(text.lines().last(), Some("M2"), "{name}: ends with M2");
        assert_eq!(text.matches("M2").count(), 1, "{name}: one program end");
        for (i, l) in text.lines().enumerate() {
            // Grbl's line buffer: 80 bytes with the newline.
            assert!(l.len() <= 79, "{name} line {}: {} chars", i + 1, l.len());
            if l.starts_with(';') {
                assert!(
                    !l.contains('(') && !l.contains(')'),
                    "{name} line {}: parenthesis in a comment: {l}",
                    i + 1
                );
            }
        }
        // The machine's description is all there, parentheses as brackets, not cut off.
        let want = machine.description.replace('(', "[").replace(')', "]");
        let words = header_words(&text);
        assert!(words.contains(&want), "{name}: '{want}' not in '{words}'");
    }
    // The pen plotter's "(420 x 297 mm)" keeps its brackets instead of turning into spaces.
    let pen = std::fs::read_to_string(dir.path().join("pen-a3/stencil.gcode")).unwrap();
    assert!(
        pen.contains("A3 bed [420 x 297 mm], pen on Z"),
        "{pen:.300}"
    );
}

/// `make` letters.png for `machine` with extra options; the G-code text (or the error).
fn gcode_with(dir: &Path, tag: &str, args: &[&str]) -> Result<String, String> {
    let out = dir.join(tag);
    let pic = samples().join("letters.png");
    let mut all = vec!["make", s(&pic), "--emit", "svg,gcode", "-o", s(&out)];
    all.extend_from_slice(args);
    let (ok, _, err) = run(&all);
    if ok {
        Ok(std::fs::read_to_string(out.join("stencil.gcode")).unwrap())
    } else {
        Err(err)
    }
}

/// Where air assist goes on and off: the line indices of M8 and M9 and the first and last cut
/// (a line or an arc: a loop may start with either).
fn air_lines(text: &str) -> (Vec<usize>, Vec<usize>, usize, usize) {
    let lines: Vec<&str> = text.lines().collect();
    let at = |w: &str| -> Vec<usize> { (0..lines.len()).filter(|&i| lines[i] == w).collect() };
    let cuts: Vec<usize> = (0..lines.len())
        .filter(|&i| ["G1", "G2 ", "G3 "].iter().any(|g| lines[i].starts_with(g)))
        .collect();
    (at("M8"), at("M9"), cuts[0], *cuts.last().unwrap())
}

#[test]
fn air_assist_goes_on_before_the_first_cut_and_off_with_the_beam() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The CO2 profile has air assist: M8 once, right before the first cut (after the travel to
    // it), M9 once, right after the final M5, before the return and M2.
    let co2 = gcode_with(d, "co2", &["--machine", "co2-600x400"]).unwrap();
    let lines: Vec<&str> = co2.lines().collect();
    let (m8, m9, first, last) = air_lines(&co2);
    assert_eq!(m8, vec![first - 1], "M8 right before the first cut");
    assert!(lines[first - 2].starts_with("G0 ") && lines[first - 2].ends_with(" S0"));
    assert_eq!(m9.len(), 1);
    assert!(m9[0] > last);
    assert_eq!(
        &lines[m9[0] - 1..],
        &["M5 S0", "M9", "G0 X0 Y0", "M2"],
        "beam off, air off, home, end"
    );
    // The diode profile has none; --air-assist decides for one job either way.
    let diode = gcode_with(d, "diode", &["--machine", "diode-400"]).unwrap();
    assert!(!diode.contains("M8") && !diode.contains("M9"));
    let on = gcode_with(d, "on", &["--machine", "diode-400", "--air-assist", "on"]).unwrap();
    assert_eq!(air_lines(&on).0.len(), 1);
    let off = gcode_with(
        d,
        "off",
        &["--machine", "co2-600x400", "--air-assist", "off"],
    )
    .unwrap();
    assert!(!off.contains("M8") && !off.contains("M9"));
    // A material may turn it off (light paper the air would lift).
    let card = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("profiles/materials/cardstock.toml"),
    )
    .unwrap();
    let still = d.join("still-card.toml");
    std::fs::write(
        &still,
        card.replace("name = \"cardstock\"", "name = \"still-card\"")
            .replace("[laser]\n", "[laser]\nair_assist = false\n"),
    )
    .unwrap();
    let quiet = gcode_with(
        d,
        "quiet",
        &["--machine", "co2-600x400", "--material", s(&still)],
    )
    .unwrap();
    assert!(!quiet.contains("M8") && !quiet.contains("M9"));
    // Air assist is a laser's: refused on a pen, naming the option's subject.
    let e = gcode_with(d, "pen", &["--machine", "pen-a3", "--air-assist", "on"]).unwrap_err();
    assert!(e.contains("air assist is for a laser"), "{e}");
    // The virtual Grbl runs the air-assisted program to the end, laser off.
    let job = d.join("co2/stencil.gcode");
    let (ok, out, err) = run(&["send", s(&job), "--dry-run", "--machine", "co2-600x400"]);
    assert!(ok, "{err}");
    assert!(
        out.contains("laser off") && out.contains("0 bytes overflowed"),
        "{out}"
    );
}

/// A laser program whose line 4 cuts to X 612, past the 600 mm bed of co2-600x400.
const OFF_BED: &str =
    "G21 G90\nM4 S0 F1000\nG0 X10 Y10\nG1 X612 S500\nG1 X100\nG1 Y50\nM5\nG0 X0 Y0\nM2\n";

#[test]
fn send_estimate_and_simulate_refuse_a_job_off_the_bed() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("wide.gcode");
    std::fs::write(&job, OFF_BED).unwrap();
    let png = dir.path().join("sim.png");
    let want = "job reaches X 612.0 mm at line 4; the bed of co2-600x400 is 600 mm wide (X 0..600)";
    for cmd in [
        vec!["send", s(&job), "--dry-run"],
        vec!["estimate", s(&job)],
        vec!["simulate", s(&job), "-o", s(&png)],
    ] {
        let mut args = cmd.clone();
        args.extend_from_slice(&["--machine", "co2-600x400"]);
        let (ok, out, err) = run(&args);
        assert!(!ok, "{cmd:?}: accepted: {out}");
        assert!(
            err.contains(want) && err.contains("wide.gcode"),
            "{cmd:?}: {err}"
        );
        // Refused before anything ran: no connection, no stream, no picture.
        assert!(
            !err.contains("connected") && !out.contains("sent") && !png.exists(),
            "{cmd:?}: {out} {err}"
        );
        // --no-bed-check lets it through (a work zero set elsewhere).
        args.push("--no-bed-check");
        let (ok, _, err) = run(&args);
        assert!(ok, "{cmd:?} --no-bed-check: {err}");
    }
    // Below zero, on the default machine: the side and the line are named.
    let low = dir.path().join("low.gcode");
    std::fs::write(&low, "G21 G90\nG0 X10 Y10\nG1 Y-5 F500\nG0 X0 Y0\n").unwrap();
    let (ok, _, err) = run(&["estimate", s(&low)]);
    assert!(
        !ok && err.contains(
            "job reaches Y -5.0 mm at line 3; the bed of diode-400 is 400 mm deep (Y 0..400)"
        ),
        "{err}"
    );
    // Resuming after the part that leaves the bed, from a point on it, is allowed: only the
    // moves that will run are checked (the restore goes to X100 Y10).
    let (ok, out, err) = run(&[
        "send",
        s(&job),
        "--dry-run",
        "--machine",
        "co2-600x400",
        "--from-line",
        "6",
    ]);
    assert!(ok && out.contains("sent"), "{out} {err}");
    // The same job 12 mm shorter fits: streamed whole, without any flag.
    let fits = dir.path().join("fits.gcode");
    std::fs::write(&fits, OFF_BED.replace("X612", "X600")).unwrap();
    let (ok, out, err) = run(&["send", s(&fits), "--dry-run", "--machine", "co2-600x400"]);
    assert!(ok && out.contains("laser off"), "{out} {err}");
}

/// A target on a 400 px square (ink is cut): an ink ring (r 150..170 px) around a paper disc,
/// an ink ring (r 60..80) on that disc around a paper ring, and an ink dot (r < 20) in the middle.
/// The paper disc and the paper ring are islands.
fn target(path: &Path) {
    common::smooth_png(path, 400, 400, |x, y| {
        let d = ((x - 200.0).powi(2) + (y - 200.0).powi(2)).sqrt();
        if (150.0..=170.0).contains(&d) || (60.0..=80.0).contains(&d) || d < 20.0 {
            0.0
        } else {
            1.0
        }
    });
}

/// Whether every cut lying wholly within `r_in` of the centre comes before every cut lying wholly
/// beyond `r_out`: the cuts inside an island before the arcs around it. Returns (inner, outer)
/// loop counts; panics with the first loop out of order.
fn inside_radius_first(
    loops: &[Vec<[f64; 2]>],
    centre: [f64; 2],
    r_in: f64,
    r_out: f64,
    what: &str,
) -> (usize, usize) {
    let radii = |l: &[[f64; 2]]| {
        l.iter()
            .map(|p| ((p[0] - centre[0]).powi(2) + (p[1] - centre[1]).powi(2)).sqrt())
            .fold((f64::MAX, f64::MIN), |(lo, hi), d| (lo.min(d), hi.max(d)))
    };
    let inner: Vec<usize> = (0..loops.len())
        .filter(|&i| radii(&loops[i]).1 < r_in)
        .collect();
    let outer: Vec<usize> = (0..loops.len())
        .filter(|&i| radii(&loops[i]).0 > r_out)
        .collect();
    for &i in &inner {
        for &o in &outer {
            assert!(
                i < o,
                "{what}: loop {i} lies inside the island (within {r_in:.1} mm of its centre) but \
                 is cut after loop {o}, one of the arcs around it; order {inner:?} / {outer:?}"
            );
        }
    }
    (inner.len(), outer.len())
}

#[test]
fn islands_held_by_several_bridges_drop_only_after_the_cuts_inside_them() {
    let dir = tempfile::tempdir().unwrap();
    let pic = dir.path().join("target.png");
    target(&pic);
    for n in ["2", "3"] {
        let out = dir.path().join(format!("t{n}"));
        let loops = laser_loops(&make_gcode(&pic, &out, &["--bridges-per-island", n]));
        // The design is symmetric about its centre.
        let c = centre_of(&loops);
        // 0.1 mm per picture pixel: the outer ring's inner edge is at 15 mm, the middle ring
        // spans 6..8 mm, the dot 2 mm.
        let what = format!("--bridges-per-island {n}");
        // The big paper disc: the middle ring's arcs and the dot, before the outer ring's arcs.
        let (inner, outer) = inside_radius_first(&loops, c, 11.0, 14.0, &what);
        assert_eq!(
            inner,
            loops.len() - outer,
            "{what}: every loop is inside or around"
        );
        assert!(
            outer >= 2,
            "{what}: the disc is held by {outer} arc(s), not several"
        );
        assert!(
            inner >= 3,
            "{what}: the middle ring is cut in {} arc(s)",
            inner - 1
        );
        // The paper ring: the dot before the middle ring's arcs.
        let (dot, arcs) = inside_radius_first(&loops, c, 4.0, 5.0, &what);
        assert_eq!((dot, arcs), (1, loops.len() - 1), "{what}");
    }
}

/// The part of the ring `r_in..r_out` around (`cx`, `cy`) from angle `a0` to `a1` (radians), as
/// SVG path data: a cut arc, as bridges break a ring.
fn arc_path(cx: f64, cy: f64, r_in: f64, r_out: f64, a0: f64, a1: f64) -> String {
    let pt = |r: f64, a: f64| format!("{:.4} {:.4}", cx + r * a.cos(), cy + r * a.sin());
    let steps = 48;
    let mut d = String::new();
    for k in 0..=steps {
        let a = a0 + (a1 - a0) * k as f64 / steps as f64;
        d += &format!("{}{} ", if k == 0 { "M" } else { "L" }, pt(r_out, a));
    }
    for k in (0..=steps).rev() {
        let a = a0 + (a1 - a0) * k as f64 / steps as f64;
        d += &format!("L{} ", pt(r_in, a));
    }
    d + "Z"
}

#[test]
fn a_drawing_without_bridge_data_keeps_islands_held_by_several_gaps_until_last() {
    // A target drawn by hand in another program: the outer cut ring (15..17 mm) broken by two
    // 2 mm gaps (its bridges) at left and right, the middle one (6..8 mm) by two at top and
    // bottom, and a dot of 2 mm in the middle. The paper disc and the paper ring are islands,
    // each held by two bridges.
    let (c, tau) = (25.0, std::f64::consts::TAU);
    let gap = |r: f64| 2.0 / r; // radians for a 2 mm chord, about
    let mut paths = Vec::new();
    for (r_in, r_out, start) in [(15.0, 17.0, 0.0), (6.0, 8.0, tau / 4.0)] {
        let g = gap((r_in + r_out) / 2.0) / 2.0;
        for half in [0.0, tau / 2.0] {
            let (a0, a1) = (start + half + g, start + half + tau / 2.0 - g);
            paths.push(arc_path(c, c, r_in, r_out, a0, a1));
        }
    }
    let dot: String = (0..32)
        .map(|k| {
            let a = tau * k as f64 / 32.0;
            format!(
                "{}{:.4} {:.4} ",
                if k == 0 { "M" } else { "L" },
                c + 2.0 * a.cos(),
                c + 2.0 * a.sin()
            )
        })
        .collect::<String>()
        + "Z";
    paths.push(dot);
    let body: String = paths
        .iter()
        .map(|d| format!("<path d=\"{d}\"/>\n"))
        .collect();
    let svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"50mm\" height=\"50mm\" \
         viewBox=\"0 0 50 50\">\n{body}</svg>\n"
    );
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("drawing.svg");
    std::fs::write(&file, svg).unwrap();
    let out = dir.path().join("drawing.gcode");
    let (ok, _, err) = run(&[
        "gcode",
        s(&file),
        "-o",
        s(&out),
        "--power",
        "50",
        "--speed",
        "1200",
    ]);
    assert!(ok, "{err}");
    let text = std::fs::read_to_string(&out).unwrap();
    let loops = laser_loops(&text);
    assert_eq!(loops.len(), 5);
    let centre = centre_of(&loops);
    // The disc: the middle ring's two arcs and the dot before the outer ring's two arcs.
    assert_eq!(
        inside_radius_first(&loops, centre, 11.0, 14.0, "the paper disc"),
        (3, 2)
    );
    // The paper ring: the dot before the middle ring's arcs.
    assert_eq!(
        inside_radius_first(&loops, centre, 4.0, 5.0, "the paper ring"),
        (1, 4)
    );
}
