//! Hostile and absurd inputs to the file readers and to `gcode`, `estimate`, `simulate` and `send`
//! (issue 12): each is refused with a non-zero exit and a message naming the file, line or option,
//! never a panic or an abort, and the inputs that used to take minutes finish. Speed is not timed
//! here: the inputs are sized so that the old quadratic steps would take minutes (measured in the
//! commits), while the fixed ones take well under a second each.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::common::{stderr, stencil};

/// A run that must fail cleanly: non-zero exit, no panic, one short message holding every needle.
fn refused(o: &Output, needles: &[&str]) -> String {
    let e = stderr(o);
    assert!(
        !o.status.success(),
        "expected a failure, got success; stderr: {e}"
    );
    assert!(!e.contains("panicked"), "{e}");
    assert!(o.status.code().is_some(), "killed by a signal: {e}");
    for n in needles {
        assert!(e.contains(n), "missing {n:?} in: {e}");
    }
    assert!(
        e.len() < 1000,
        "message too long ({} bytes): {}",
        e.len(),
        &e[..600]
    );
    e
}

fn ok(o: &Output) -> String {
    let e = stderr(o);
    assert!(o.status.success(), "failed: {e}");
    assert!(!e.contains("panicked"), "{e}");
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn svg(size: &str, inner: &str) -> String {
    format!(r#"<svg xmlns="http://www.w3.org/2000/svg" {size}>{inner}</svg>"#)
}

const SQUARE: &str = r#"<path d="M 10 10 L 90 10 L 90 90 L 10 90 Z"/>"#;

/// X extent of the cutting moves of a G-code file, by an independent reading of its words.
fn cut_width(gcode: &Path) -> f64 {
    let text = std::fs::read_to_string(gcode).unwrap();
    let xs: Vec<f64> = text
        .lines()
        .filter(|l| l.starts_with("G1"))
        .flat_map(|l| l.split_whitespace())
        .filter_map(|w| w.strip_prefix('X'))
        .map(|v| v.parse::<f64>().unwrap())
        .collect();
    let lo = xs.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    hi - lo
}

// ---- 1. Clipper behind one gate ------------------------------------------------------------------

#[test]
fn svg_coordinates_clipper_cannot_take_are_refused_naming_file_and_path() {
    let tmp = tempfile::tempdir().unwrap();
    let sz = r#"width="100mm" height="100mm" viewBox="0 0 100 100""#;
    let g = |tr: &str| svg(sz, &format!(r#"<g transform="{tr}">{SQUARE}</g>"#));
    let cases = [
        ("rotate.svg", g("rotate(nan)"), "transform"),
        ("matrix.svg", g("matrix(nan,0,0,1,0,0)"), "transform"),
        ("scale.svg", g("scale(1e308)"), "transform=\"scale(1e308)\""),
        ("skew.svg", g("skewX(90)"), "path 1"),
        (
            "far.svg",
            svg(sz, r#"<path d="M 10 10 L 1e20 10 L 90 90 Z"/>"#),
            "path 1",
        ),
        (
            "tiny_viewbox.svg",
            svg(
                r#"width="100mm" height="100mm" viewBox="0 0 1e-300 1e-300""#,
                SQUARE,
            ),
            "viewBox",
        ),
        (
            "inf_viewbox.svg",
            svg(
                r#"width="100mm" height="100mm" viewBox="0 0 inf 100""#,
                SQUARE,
            ),
            "viewBox",
        ),
    ];
    for (name, text, what) in cases {
        let p = write(tmp.path(), name, &text);
        let out = tmp.path().join(format!("{name}.gcode"));
        // With a material (its kerf goes through Clipper) and without.
        for material in [
            &["--material", "mylar-0.19"][..],
            &["--power", "50", "--speed", "1000"],
        ] {
            let mut args = vec!["gcode", s(&p), "-o", s(&out)];
            args.extend_from_slice(material);
            refused(&stencil(&args), &[name, what]);
            assert!(!out.exists(), "{name}: nothing is written");
        }
    }
}

#[test]
fn a_report_with_a_bridge_at_1e30_does_not_crash_check() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("rings");
    ok(&stencil(&["make", "samples/rings.png", "-o", s(&dir)]));
    let rp = dir.join("report.json");
    let mut r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&rp).unwrap()).unwrap();
    r["bridges"][0]["polygon_px"][0] = serde_json::json!([1e30, 1e30]);
    std::fs::write(&rp, serde_json::to_string(&r).unwrap()).unwrap();
    let o = stencil(&["check", s(&dir)]);
    let e = stderr(&o);
    assert!(!e.contains("panicked") && o.status.code().is_some(), "{e}");
    if !o.status.success() {
        assert!(e.contains("report.json"), "{e}");
    }
}

// ---- 2. SVG sizes ----------------------------------------------------------------------------------

#[test]
fn svg_sizes_in_any_absolute_unit_give_the_drawn_size() {
    let tmp = tempfile::tempdir().unwrap();
    // The square spans 80 % of the viewBox: 80 mm of a 100 mm drawing.
    for (i, w) in [
        "1e2mm",
        "100MM",
        "10cm",
        "10CM",
        "400q",
        "3.937007874015748in",
        "283.46456692913387pt",
    ]
    .iter()
    .enumerate()
    {
        let p = write(
            tmp.path(),
            &format!("s{i}.svg"),
            &svg(
                &format!(r#"width="{w}" height="{w}" viewBox="0 0 100 100""#),
                SQUARE,
            ),
        );
        let out = tmp.path().join(format!("s{i}.gcode"));
        ok(&stencil(&[
            "gcode",
            s(&p),
            "-o",
            s(&out),
            "--power",
            "50",
            "--speed",
            "1000",
        ]));
        let width = cut_width(&out);
        assert!(
            (width - 80.0).abs() < 0.01,
            "{w}: cut {width} mm wide, want 80"
        );
    }
}

#[test]
fn svg_sizes_without_a_physical_length_are_refused_naming_the_attribute() {
    let tmp = tempfile::tempdir().unwrap();
    for (i, (w, unit)) in [("50%", "%"), ("10em", "em"), ("2ex", "ex"), ("10vw", "vw")]
        .iter()
        .enumerate()
    {
        let p = write(
            tmp.path(),
            &format!("r{i}.svg"),
            &svg(
                &format!(r#"width="{w}" height="100mm" viewBox="0 0 100 100""#),
                SQUARE,
            ),
        );
        let o = stencil(&["gcode", s(&p), "--power", "50", "--speed", "1000"]);
        refused(&o, &[&format!("r{i}.svg"), &format!("width=\"{w}\""), unit]);
    }
}

// ---- 5. Super-linear time ----------------------------------------------------------------------

/// A comb of `teeth` teeth of distinct heights, 0.01 mm wide at a 0.02 mm pitch: a simple outline
/// whose edges nearly all span its height, the worst case of Clipper's sweep along y (20,000 teeth
/// took 103 s to offset). Returns the SVG and the comb's width in mm.
fn comb_svg(teeth: usize) -> (String, f64) {
    let pitch = 0.02;
    let mut d = String::from("M 1 1");
    for i in 0..teeth {
        let x = 1.0 + i as f64 * pitch;
        let h = 20.0 + ((i * 7919) % 20011) as f64 * 0.008;
        d += &format!(
            " L {x:.3} {h:.3} L {:.3} {h:.3} L {:.3} 1",
            x + 0.01,
            x + 0.01
        );
    }
    let end = 1.0 + teeth as f64 * pitch + 1.0;
    d += &format!(" L {end:.3} 1 L {end:.3} 0.5 L 0.5 0.5 Z");
    let text = svg(
        &format!(
            r#"width="{0}mm" height="200mm" viewBox="0 0 {0} 200""#,
            end + 1.0
        ),
        &format!(r#"<path d="{d}"/>"#),
    );
    (text, end - 0.5)
}

#[test]
fn a_comb_of_20000_teeth_is_offset_in_the_cheap_direction() {
    let tmp = tempfile::tempdir().unwrap();
    let (text, width_mm) = comb_svg(20_000);
    let p = write(tmp.path(), "comb.svg", &text);
    // A kerf narrower than the teeth, so they survive the offset.
    let mat = write(
        tmp.path(),
        "fine.toml",
        "name = \"fine\"\nthickness_mm = 0.1\nmin_bridge_mm = 0.5\nmin_feature_mm = 0.01\n\
         kerf_mm = 0.002\nprocess = \"laser\"\n[laser]\npower_pct = 20\nspeed_mm_min = 2000\n\
         passes = 1\n",
    );
    let out = tmp.path().join("comb.gcode");
    let o = ok(&stencil(&[
        "gcode",
        s(&p),
        "-o",
        s(&out),
        "--material",
        s(&mat),
        "--machine",
        "co2-600x400",
    ]));
    assert!(o.contains("1 loops"), "{o}");
    let width = cut_width(&out);
    assert!((width - width_mm).abs() < 0.01, "{width} vs {width_mm}");
}

#[test]
fn a_long_self_crossing_path_is_refused_for_the_kerf_and_cut_as_drawn_without() {
    let tmp = tempfile::tempdir().unwrap();
    // 140,000 points zigzagging up and down, every other stroke leaning back over its neighbour.
    let n = 140_000;
    let mut d = String::from("M");
    for i in 0..n {
        let x = 1.0 + 98.0 * i as f64 / n as f64
            - if i % 4 == 1 {
                3.0 * 98.0 / n as f64
            } else {
                0.0
            };
        let y = if i % 2 == 0 { 1.0 } else { 99.0 };
        d += &format!(" {x:.5},{y}");
    }
    // Back along a bar below the strokes, so that the loop encloses an area.
    d += " L 99,0.5 L 1,0.5 Z";
    let p = write(
        tmp.path(),
        "zigzag.svg",
        &svg(
            r#"width="100mm" height="100mm" viewBox="0 0 100 100""#,
            &format!(r#"<path d="{d}"/>"#),
        ),
    );
    let out = tmp.path().join("z.gcode");
    let o = stencil(&["gcode", s(&p), "-o", s(&out), "--material", "mylar-0.19"]);
    refused(
        &o,
        &[
            "zigzag.svg",
            "kerf offset",
            "crosses itself more than 1000 times",
        ],
    );
    assert!(!out.exists());
    // Without a material there is no kerf: cut as drawn.
    ok(&stencil(&[
        "gcode",
        s(&p),
        "-o",
        s(&out),
        "--power",
        "20",
        "--speed",
        "3000",
    ]));
}

fn obj_tone(dir: &Path, name: &str, text: &str) -> Output {
    let p = write(dir, name, text);
    stencil(&["tone", s(&p), "-o", s(&dir.join(format!("{name}.png")))])
}

#[test]
fn repeated_faces_and_huge_polygons_render_in_linear_time() {
    let tmp = tempfile::tempdir().unwrap();
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0.2\n";
    // 13,000 copies of one face (104 KB).
    ok(&obj_tone(
        tmp.path(),
        "same.obj",
        &format!("{tri}{}", "f 1 2 3\n".repeat(13_000)),
    ));
    // One `f` line of 50,000 indices cycling over four vertices.
    let idx: Vec<String> = (0..50_000).map(|i| (i % 4 + 1).to_string()).collect();
    ok(&obj_tone(
        tmp.path(),
        "cycle.obj",
        &format!("{tri}f {}\n", idx.join(" ")),
    ));
    // One face with 60,000 vertices on a circle (its fan's slivers span the picture).
    let n = 60_000;
    let mut text = String::new();
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        text += &format!("v {:.6} {:.6} 0\n", a.cos(), a.sin());
    }
    let idx: Vec<String> = (1..=n).map(|i| i.to_string()).collect();
    text += &format!("f {}\n", idx.join(" "));
    ok(&obj_tone(tmp.path(), "disc.obj", &text));
}

// ---- 3, 4. G-code reader and send options -----------------------------------------------------

#[test]
fn non_finite_and_absurd_gcode_numbers_are_refused_naming_the_line() {
    let tmp = tempfile::tempdir().unwrap();
    let huge = "9".repeat(400);
    let p = write(
        tmp.path(),
        "inf.gcode",
        &format!("G21 G90\nG0 X1 Y1\nG1 X{huge} F600\n"),
    );
    let sim = tmp.path().join("sim.png");
    for args in [
        vec!["estimate", s(&p)],
        vec!["simulate", s(&p), "-o", s(&sim)],
    ] {
        // Longer than Grbl's line buffer: error:11 there, refused here, without quoting it.
        refused(
            &stencil(&args),
            &["inf.gcode", "line 3", "characters", "error:11"],
        );
    }
    assert!(!sim.exists());
    // send refuses the 400-digit line by its length before anything else, and a 70-digit number
    // (which fits Grbl's line) by its size.
    refused(
        &stencil(&["send", s(&p), "--dry-run"]),
        &["inf.gcode", "line 3"],
    );
    let q = write(
        tmp.path(),
        "far.gcode",
        &format!("G21 G90\nG0 X1\nG0 X{}\n", "9".repeat(70)),
    );
    refused(
        &stencil(&["send", s(&q), "--dry-run"]),
        &["far.gcode", "line 3", "beyond"],
    );
    refused(
        &stencil(&["estimate", s(&q)]),
        &["far.gcode", "line 3", "beyond"],
    );
}

#[test]
fn send_timeouts_past_any_use_are_refused_naming_the_option() {
    let tmp = tempfile::tempdir().unwrap();
    let p = write(tmp.path(), "ok.gcode", "G21 G90\nG0 X1\n");
    for t in ["1e19", "1e20", "inf", "nan", "0", "-1"] {
        refused(
            &stencil(&["send", s(&p), "--dry-run", &format!("--timeout-s={t}")]),
            &["--timeout-s", "0.1 to 3600"],
        );
    }
}

// ---- 6, 7. OBJ messages and stray vertices --------------------------------------------------------

#[test]
fn obj_errors_name_the_line_and_quote_short() {
    let tmp = tempfile::tempdir().unwrap();
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let big = "1".repeat(1 << 20);
    let wide = " 1".repeat(2 << 20);
    for (name, text, line, what) in [
        (
            "seven.obj",
            format!("{tri}v 1 1 1 1 1 1 1\nf 1 2 3\n"),
            4,
            "7 numbers",
        ),
        (
            "wide.obj",
            format!("{tri}v 1 1 1{wide}\nf 1 2 3\n"),
            4,
            "numbers",
        ),
        (
            "bignum.obj",
            format!("{tri}v 1 1 {big}\nf 1 2 3\n"),
            4,
            "characters)",
        ),
        (
            "bigidx.obj",
            format!("{tri}f 1 2 {big}\n"),
            4,
            "characters)",
        ),
    ] {
        let o = obj_tone(tmp.path(), name, &text);
        refused(&o, &[&format!("{name}:{line}:"), what]);
    }
    // A byte-order mark is not a statement.
    ok(&obj_tone(
        tmp.path(),
        "bom.obj",
        &format!("\u{feff}{tri}f 1 2 3\n"),
    ));
}

/// A small part 1e12 away from a tetrahedron: the view frames both and every part shrinks below
/// a pixel. The stencil came out blank with exit 0 and no word; now both are warned about.
#[test]
fn a_part_far_from_the_model_is_warned_about_with_the_blank_stencil() {
    let tmp = tempfile::tempdir().unwrap();
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n\
                v 1e12 1e12 1e12\nv 1e12 1e12 1.000001e12\nv 1e12 1.000001e12 1e12\nf 5 6 7\n";
    let p = write(tmp.path(), "far.obj", text);
    let out = tmp.path().join("far");
    let o = stencil(&["make", s(&p), "-o", s(&out)]);
    ok(&o);
    let e = stderr(&o);
    assert!(
        e.contains("far.obj")
            && e.contains("2 of the mesh's 2 parts come out smaller than a pixel"),
        "{e}"
    );
    assert!(e.contains("the stencil is blank"), "{e}");
    // The tetrahedron alone: one part, drawn, no part warning.
    let p = write(tmp.path(), "near.obj", text.split("v 1e12").next().unwrap());
    let e = ok(&stencil(&[
        "make",
        s(&p),
        "-o",
        s(&tmp.path().join("near")),
    ]));
    assert!(
        !e.contains("smaller than a pixel") && !e.contains("blank"),
        "{e}"
    );
}

#[test]
fn a_vertex_far_from_the_model_is_refused_not_drawn_as_a_blank_stencil() {
    let tmp = tempfile::tempdir().unwrap();
    let mut text = String::new();
    for k in 0..8 {
        text += &format!("v {} {} {}\n", k & 1, (k >> 1) & 1, (k >> 2) & 1);
    }
    text += "v 1e20 0 0\nf 1 2 4\nf 1 4 3\nf 5 6 8\nf 1 2 9\n";
    for cmd in ["tone", "make"] {
        let p = write(tmp.path(), "stray.obj", &text);
        let out = tmp.path().join(format!("stray-{cmd}"));
        refused(
            &stencil(&[cmd, s(&p), "-o", s(&out)]),
            &["stray.obj:9:", "1.00e20", "dot"],
        );
    }
}

// ---- 8. Machine profiles and cut options --------------------------------------------------------

#[test]
fn absurd_machine_fields_and_cut_options_are_refused_by_name() {
    let tmp = tempfile::tempdir().unwrap();
    let p = write(
        tmp.path(),
        "sq.svg",
        &svg(
            r#"width="100mm" height="100mm" viewBox="0 0 100 100""#,
            SQUARE,
        ),
    );
    let knife = std::fs::read_to_string("profiles/machines/drag-knife.toml").unwrap();
    let diode = std::fs::read_to_string("profiles/machines/diode-400.toml").unwrap();
    for (base, from, to, field) in [
        (&knife, "z_up_mm = 3", "z_up_mm = 1e9", "tool.z_up_mm"),
        (
            &diode,
            "max_feed_mm_min = 6000",
            "max_feed_mm_min = 1e308",
            "motion.max_feed_mm_min",
        ),
        (
            &diode,
            "rapid_mm_min = 6000",
            "rapid_mm_min = 1e308",
            "motion.rapid_mm_min",
        ),
        (&diode, "width_mm = 400", "width_mm = 1e308", "bed.width_mm"),
        (
            &diode,
            "accel_mm_s2 = 1000",
            "accel_mm_s2 = 1e-300",
            "motion.accel_mm_s2",
        ),
        (&diode, "s_max = 1000", "s_max = 1e308", "tool.s_max"),
    ] {
        let text = base.replace(from, to);
        assert_ne!(&text, base);
        let m = write(tmp.path(), "m.toml", &text);
        let o = stencil(&[
            "gcode",
            s(&p),
            "--machine",
            s(&m),
            "--speed",
            "500",
            "--passes",
            "1",
            "--power",
            "50",
        ]);
        let e = refused(&o, &["m.toml", field, "allowed"]);
        assert!(!e.contains("internal error"), "{e}");
    }
    for (opt, v) in [
        ("--speed", "1e-300"),
        ("--speed", "1e308"),
        ("--power", "1e-300"),
        ("--power", "nan"),
        ("--blade-offset", "1e9"),
        ("--passes", "0"),
    ] {
        let mut args = vec!["gcode", s(&p)];
        for (o, d) in [("--power", "50"), ("--speed", "1000")] {
            if o != opt {
                args.extend_from_slice(&[o, d]);
            }
        }
        args.extend_from_slice(&[opt, v]);
        let e = refused(&stencil(&args), &[&format!("'{v}' for '{opt}")]);
        assert!(
            !e.contains("internal error") && !e.contains("multiple times"),
            "{e}"
        );
    }
}

// ---- Issue 39: the fourth campaign's SVGs, and item 5's messages ---------------------------------

/// `gcode` on an SVG in `dir` with plain laser settings and `extra` options; the output path.
fn gcode_svg(dir: &Path, name: &str, text: &str, extra: &[&str]) -> (Output, PathBuf) {
    let p = write(dir, name, text);
    let out = dir.join(format!("{name}.gcode"));
    let mut a = vec![
        "gcode",
        s(&p),
        "-o",
        s(&out),
        "--power",
        "50",
        "--speed",
        "1000",
    ];
    a.extend_from_slice(extra);
    (stencil(&a), out)
}

const MM200: &str = r#"width="200mm" height="200mm" viewBox="0 0 200 200""#;

/// Each cutting loop's box (min x, min y, max x, max y), in cut order, read from the G-code.
fn loop_boxes(gcode: &Path) -> Vec<[f64; 4]> {
    crate::common::gcode_loops(&std::fs::read_to_string(gcode).unwrap())
        .iter()
        .filter(|l| l.points.len() > 2)
        .map(|l| stencil_geom::ring::bbox(&l.points))
        .collect()
}

/// 13,000 nested groups (91 KB) overflowed usvg's recursion and aborted the process; 80,000
/// attributes on one path took 27 s in the XML parser's duplicate check. Both are refused before
/// the parser, naming the file, the place and the limit, and nothing is written; a drawing
/// nested 200 deep is still read.
#[test]
fn svg_nesting_and_attributes_past_the_limits_are_refused_before_parsing() {
    let dir = crate::common::tmp();
    let deep = svg(
        MM200,
        &format!(
            "\n{}{SQUARE}{}",
            "<g>".repeat(13_000),
            "</g>".repeat(13_000)
        ),
    );
    let (o, out) = gcode_svg(dir.path(), "deep.svg", &deep, &[]);
    refused(&o, &["deep.svg:2:", "nested more than 256", "ungroup"]);
    assert!(!out.exists());

    let attrs: String = (0..80_000).map(|i| format!(" a{i}=\"1\"")).collect();
    let many = svg(
        MM200,
        &format!("\n<path{attrs} d=\"M 10 10 L 90 10 L 90 90 Z\"/>"),
    );
    let (o, out) = gcode_svg(dir.path(), "attrs.svg", &many, &[]);
    refused(
        &o,
        &[
            "attrs.svg:2:1:",
            "<path> has 80001 attributes",
            "at most 1000",
        ],
    );
    assert!(!out.exists());

    let nested = svg(
        MM200,
        &format!("{}{SQUARE}{}", "<g>".repeat(200), "</g>".repeat(200)),
    );
    let (o, out) = gcode_svg(dir.path(), "nested.svg", &nested, &[]);
    ok(&o);
    assert_eq!(loop_boxes(&out).len(), 1);
}

/// `opacity="0"` shapes were cut; now nothing fully transparent is (the element's or a group's
/// opacity, or every paint's), and a shape with a clip path is cut along what the clip leaves.
#[test]
fn transparent_shapes_are_not_cut_and_clip_paths_are_applied() {
    let dir = crate::common::tmp();
    let body = r#"<rect x="10" y="10" width="30" height="30" opacity="0"/>
        <rect x="10" y="50" width="30" height="30" fill-opacity="0"/>
        <rect x="10" y="90" width="30" height="30" fill="none" stroke="red" stroke-opacity="0"/>
        <g style="opacity:0"><rect x="10" y="130" width="30" height="30"/></g>
        <rect x="100" y="10" width="7" height="7" opacity="0.5"/>"#;
    let (o, out) = gcode_svg(dir.path(), "opacity.svg", &svg(MM200, body), &[]);
    ok(&o);
    assert!(
        stderr(&o).contains("note: 4 fully transparent element(s)"),
        "{}",
        stderr(&o)
    );
    let b = loop_boxes(&out);
    assert_eq!(b.len(), 1, "only the half-transparent square: {b:?}");
    assert!((b[0][2] - b[0][0] - 7.0).abs() < 1e-3, "{b:?}");

    // A 20 x 20 square at (10, 10) clipped to (0..20, 0..15): a 10 x 5 loop; a circle clipped by
    // a half-plane box (objectBoundingBox units, a transform on the clip path); an open line
    // clipped for a pen.
    let body = r##"<defs>
          <clipPath id="c"><rect x="0" y="0" width="20" height="15"/></clipPath>
          <clipPath id="half" clipPathUnits="objectBoundingBox"><rect width="0.5" height="1"/></clipPath>
        </defs>
        <rect x="10" y="10" width="20" height="20" clip-path="url(#c)"/>
        <circle cx="100" cy="100" r="20" clip-path="url(#half)"/>
        <g clip-path="url(#c)"><rect x="2" y="2" width="3" height="3"/>
          <rect x="150" y="150" width="5" height="5"/></g>"##;
    let (o, out) = gcode_svg(dir.path(), "clip.svg", &svg(MM200, body), &[]);
    ok(&o);
    let mut b = loop_boxes(&out);
    b.sort_by(|p, q| p[0].total_cmp(&q[0]));
    // A shape wholly inside a clip is kept as drawn, one wholly outside is gone.
    assert_eq!(b.len(), 3, "{b:?}");
    let size = |r: &[f64; 4]| [r[2] - r[0], r[3] - r[1]];
    let near = |a: [f64; 2], w: [f64; 2]| (a[0] - w[0]).abs() < 0.05 && (a[1] - w[1]).abs() < 0.05;
    assert!(near(size(&b[0]), [3.0, 3.0]), "{b:?}");
    assert!(near(size(&b[1]), [10.0, 5.0]), "{b:?}");
    assert!(
        near(size(&b[2]), [20.0, 40.0]),
        "the left half of the circle: {b:?}"
    );
    // Unclipped, the same drawing cuts the whole square and circle (the test can fail).
    let plain = body
        .replace(" clip-path=\"url(#c)\"", "")
        .replace(" clip-path=\"url(#half)\"", "");
    let (o, out) = gcode_svg(dir.path(), "plain.svg", &svg(MM200, &plain), &[]);
    ok(&o);
    let mut b = loop_boxes(&out);
    b.sort_by(|p, q| p[0].total_cmp(&q[0]));
    assert_eq!(b.len(), 4, "{b:?}");
    assert!(
        near(size(&b[1]), [20.0, 20.0]) && near(size(&b[2]), [40.0, 40.0]),
        "{b:?}"
    );

    let line = r##"<defs><clipPath id="c"><rect x="0" y="0" width="50" height="50"/></clipPath></defs>
        <line x1="10" y1="20" x2="150" y2="20" stroke="black" clip-path="url(#c)"/>"##;
    let (o, out) = gcode_svg(
        dir.path(),
        "line.svg",
        &svg(MM200, line),
        &["--machine", "pen-a3"],
    );
    let stdout = ok(&o);
    assert!(
        stdout.contains("1 open paths; cut 40 mm"),
        "10..50 of the line 10..150: {stdout}"
    );
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("G1 X50 Y"), "{text}");
}

/// A mask shows a shape by another drawing's brightness, which a cutter cannot follow: refused,
/// naming the element and its place, instead of cutting the whole shape without a word.
#[test]
fn a_masked_shape_is_refused_naming_the_element() {
    let dir = crate::common::tmp();
    let body = r##"<defs><mask id="m"><rect width="20" height="20" fill="white"/></mask></defs>
<rect id="r1" x="10" y="10" width="20" height="20" mask="url(#m)"/>"##;
    let (o, out) = gcode_svg(dir.path(), "mask.svg", &svg(MM200, body), &[]);
    refused(
        &o,
        &["mask.svg:2:1:", "<rect id=\"r1\"> has a mask", "clip path"],
    );
    assert!(!out.exists());
}

/// Thousands of separate squares, each with a smaller one inside: every square is cut once, as
/// drawn, each inner one before the square around it, and the travel is shorter than the
/// drawing's order. (60,000 squares took 136 s when every pair of loops was compared; the
/// R-trees make that a few seconds; measured by hand, not timed here.)
#[test]
fn thousands_of_squares_are_each_cut_once_inner_first() {
    let dir = crate::common::tmp();
    let n = 40usize;
    let mut body = String::new();
    for k in 0..n * n {
        // A scrambled drawing order, so the travel has something to improve.
        let k = (k * 37) % (n * n);
        let (x, y) = ((k % n) as f64 * 4.5 + 5.0, (k / n) as f64 * 4.5 + 5.0);
        body += &format!(r#"<rect x="{x}" y="{y}" width="3" height="3"/>"#);
        body += &format!(
            r#"<rect x="{}" y="{}" width="1" height="1"/>"#,
            x + 1.0,
            y + 1.0
        );
    }
    let (o, out) = gcode_svg(dir.path(), "squares.svg", &svg(MM200, &body), &[]);
    let stdout = ok(&o);
    let got = loop_boxes(&out);
    assert_eq!(got.len(), 2 * n * n);
    // Each square by its centre (the G-code's frame is the drawing's, flipped and moved): one
    // 3 mm and one 1 mm loop at every centre of the grid, the small one cut first.
    let mut at: std::collections::HashMap<[i64; 2], [Option<usize>; 2]> = Default::default();
    for (i, b) in got.iter().enumerate() {
        let c = [(b[0] + b[2]) / 2.0, (b[1] + b[3]) / 2.0].map(|v| (v * 1000.0).round() as i64);
        let side = b[2] - b[0];
        let k = if (side - 3.0).abs() < 1e-3 {
            0
        } else {
            assert!((side - 1.0).abs() < 1e-3, "a loop of {side} mm: {b:?}");
            1
        };
        let e = at.entry(c).or_default();
        assert!(e[k].is_none(), "cut twice: {b:?}");
        e[k] = Some(i);
    }
    assert_eq!(at.len(), n * n, "one pair at each drawn centre");
    for (c, [outer, inner]) in &at {
        let (outer, inner) = (outer.expect("outer cut"), inner.expect("inner cut"));
        assert!(
            inner < outer,
            "the square at {c:?} cut before the one inside it"
        );
    }
    let mut xs: Vec<i64> = at.keys().map(|c| c[0]).collect();
    xs.sort_unstable();
    xs.dedup();
    assert_eq!(xs.len(), n);
    assert!(xs.windows(2).all(|w| w[1] - w[0] == 4500), "{xs:?}");
    // "travel T mm (input order N mm)"
    let num_after = |tag: &str| -> f64 {
        let i = stdout.find(tag).unwrap() + tag.len();
        stdout[i..]
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let (travel, input) = (num_after("travel "), num_after("(input order "));
    assert!(
        travel < 0.5 * input,
        "travel {travel} mm vs input order {input} mm"
    );
}

/// 200,000 small squares were refused as "too tangled ... up to 0 edges across one line": each
/// shape's offset is cheap, their number is what passes the limit. The message now says so, with
/// the count, about how many fit, and what to do. (2,000 polygons of 48 points pass it the same
/// way, in a fraction of a second.)
#[test]
fn too_many_shapes_for_the_kerf_are_refused_by_their_count() {
    let dir = crate::common::tmp();
    let body: String = (0..2000)
        .map(|i| {
            let (cx, cy) = ((i % 45) as f64 * 8.0 + 5.0, (i / 45) as f64 * 8.0 + 5.0);
            let pts: Vec<String> = (0..48)
                .map(|k| {
                    let a = std::f64::consts::TAU * k as f64 / 48.0;
                    format!("{:.3},{:.3}", cx + 3.0 * a.cos(), cy + 3.0 * a.sin())
                })
                .collect();
            format!(r#"<polygon points="{}"/>"#, pts.join(" "))
        })
        .collect();
    let p = write(
        dir.path(),
        "many.svg",
        &svg(
            r#"width="390mm" height="390mm" viewBox="0 0 390 390""#,
            &body,
        ),
    );
    let out = dir.path().join("many.gcode");
    let o = stencil(&["gcode", s(&p), "--material", "cardstock", "-o", s(&out)]);
    let e = refused(
        &o,
        &["many.svg", "2000 shapes are too many", "split the drawing"],
    );
    assert!(!e.contains("tangled") && !e.contains("edges across"), "{e}");
    assert!(!out.exists());
}

/// A drawing whose only shape a transform squeezes flat was "nothing to cut", naming nothing:
/// the message names the shape (kind, id, number, line) and the cause.
#[test]
fn nothing_to_cut_names_the_shape_and_why() {
    let dir = crate::common::tmp();
    let body =
        "\n<g transform=\"skewX(89.999)\">\n  <rect id=\"flat\" x=\"10\" y=\"10\" width=\"20\" \
                height=\"20\" transform=\"scale(1 1e-9)\"/></g>";
    let (o, out) = gcode_svg(dir.path(), "skew.svg", &svg(MM200, body), &[]);
    refused(
        &o,
        &[
            "skew.svg: nothing to cut: <rect id=\"flat\"> (shape 1, line 3, column 3)",
            "skewX(89.999) scale(1 1e-9)",
            "degenerate",
        ],
    );
    assert!(!out.exists());
    let (o, _) = gcode_svg(
        dir.path(),
        "zero.svg",
        &svg(MM200, r#"<rect x="1" y="1" width="0" height="5"/>"#),
        &[],
    );
    refused(&o, &["<rect> (shape 1,", "no size (width=\"0\")"]);
}

/// A PNG with a cICP chunk (colour metadata) whose values the png decoder does not support was
/// "cannot open: invalid data"; it is read without it, as a viewer shows it: the same stencil as
/// the picture without the chunk.
#[test]
fn a_png_with_a_cicp_chunk_is_read() {
    let dir = crate::common::tmp();
    let plain = dir.path().join("plain.png");
    crate::common::ink_png(&plain, 200, 200, |x, y| {
        let (dx, dy) = (x as f64 - 100.0, y as f64 - 100.0);
        (dx * dx + dy * dy).sqrt() < 60.0 && (dx * dx + dy * dy).sqrt() > 30.0
    });
    let bytes = std::fs::read(&plain).unwrap();
    // After the signature and IHDR (8 + 25 bytes): BT.709 primaries and transfer, matrix
    // coefficients 1, which the decoder refuses (PNG's RGB needs 0), full range.
    let mut with = bytes[..33].to_vec();
    with.extend(crate::common::png_chunk(b"cICP", &[1, 1, 1, 1]));
    with.extend_from_slice(&bytes[33..]);
    let cicp = dir.path().join("cicp.png");
    std::fs::write(&cicp, with).unwrap();
    let made = |input: &Path, out: &str| {
        let out = dir.path().join(out);
        ok(&stencil(&[
            "make",
            s(input),
            "-o",
            s(&out),
            "--emit",
            "png",
        ]));
        std::fs::read(out.join("stencil.png")).unwrap()
    };
    assert_eq!(made(&cicp, "a"), made(&plain, "b"));
}

/// An OBJ with classic Mac line ends (a lone CR) was read as one line, "a vertex with 61
/// numbers"; it renders as the same file with LF does, and its errors name the right line.
#[test]
fn obj_with_cr_line_ends_is_read_line_by_line() {
    let dir = crate::common::tmp();
    let lf = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n";
    ok(&obj_tone(dir.path(), "lf.obj", lf));
    ok(&obj_tone(dir.path(), "cr.obj", &lf.replace('\n', "\r")));
    let png = |n: &str| std::fs::read(dir.path().join(n)).unwrap();
    assert_eq!(png("cr.obj.png"), png("lf.obj.png"));
    let bad = lf.replace("v 0 0 1", "v 0 0 x").replace('\n', "\r");
    let o = obj_tone(dir.path(), "bad.obj", &bad);
    refused(&o, &["bad.obj:4:", "coordinate 'x'"]);
}

/// `gcode` on a folder without its report.json said "no cut settings: name a material"; it now
/// names the missing file and what to do, and writes nothing.
#[test]
fn gcode_on_a_folder_without_its_report_names_the_report() {
    let dir = crate::common::tmp();
    let folder = dir.path().join("job");
    std::fs::create_dir(&folder).unwrap();
    write(&folder, "stencil.svg", &svg(MM200, SQUARE));
    let o = stencil(&["gcode", s(&folder)]);
    let report = folder.join("report.json");
    refused(
        &o,
        &[
            &format!("{}: missing", report.display()),
            "--material",
            "stencil make",
        ],
    );
    assert!(!folder.join("stencil.gcode").exists());
    // With the settings given, the folder is cut without it.
    ok(&stencil(&[
        "gcode",
        s(&folder),
        "--power",
        "50",
        "--speed",
        "900",
    ]));
    assert!(folder.join("stencil.gcode").exists());
}
