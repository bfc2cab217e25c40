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
