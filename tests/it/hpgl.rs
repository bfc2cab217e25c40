//! HP-GL for plotter cutters (issue 45): `make --emit hpgl` read back and drawn by Debian's
//! `hp2xx` (an HP-GL interpreter we did not write) and compared with the stencil's outlines;
//! `send --dry-run` of a 20,000-instruction job through the virtual plotter cutter with XON/XOFF
//! and with RTS/CTS; an abort that lifts the tool; refusals before anything is sent.
//!
//! Without `hp2xx` on the PATH the hp2xx test says so and passes, unless
//! `STENCIL_HPGL_TEST=required` (which `.ci/run` sets after installing it), where it fails.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::{s, samples, seg_dist, stderr, stencil, svg_subpaths, tmp};

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn on_path(name: &str) -> Option<PathBuf> {
    std::env::var_os("PATH")?
        .to_str()?
        .split(':')
        .map(|d| Path::new(d).join(name))
        .find(|p| p.is_file())
}

/// hp2xx, or `None` (and a SKIPPED line) where it is absent and not required.
fn hp2xx() -> Option<PathBuf> {
    let required = std::env::var("STENCIL_HPGL_TEST").is_ok_and(|v| v == "required");
    let found = on_path("hp2xx");
    if found.is_none() {
        assert!(
            !required,
            "STENCIL_HPGL_TEST=required but hp2xx is not on the PATH (apt-get install hp2xx)"
        );
        println!(
            "SKIPPED the hp2xx check: hp2xx is not on the PATH; install Debian's hp2xx \
             (apt-get install hp2xx) to run it"
        );
    }
    found
}

/// The strokes hp2xx draws for a .plt (its gnuplot output at true size: mm), as polylines.
fn hp2xx_strokes(hp2xx: &Path, plt: &Path, dir: &Path) -> Vec<Vec<[f64; 2]>> {
    let gpt = dir.join("hp2xx.gpt");
    let o = Command::new(hp2xx)
        .args(["-q", "-m", "gpt", "-t", "-f", s(&gpt), s(plt)])
        .output()
        .expect("run hp2xx");
    assert!(o.status.success(), "hp2xx failed: {}", stderr(&o));
    let text = std::fs::read_to_string(&gpt).unwrap();
    let mut strokes: Vec<Vec<[f64; 2]>> = Vec::new();
    let mut up = true;
    for l in text.lines().map(str::trim) {
        match l {
            "#PU" => up = true,
            "#PD" => up = false,
            l if l.is_empty() || l.starts_with('#') => {}
            l => {
                let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
                let p = [v[0], v[1]];
                // hp2xx breaks long polylines, starting each piece where the last ended.
                let joins = strokes.last().and_then(|s| s.last()) == Some(&p);
                if (up && !joins) || strokes.is_empty() {
                    strokes.push(vec![p]);
                } else if up {
                } else {
                    strokes.last_mut().unwrap().push(p);
                }
            }
        }
    }
    strokes.retain(|s| s.len() > 1);
    strokes
}

/// The cut layer of stencil.svg, placed as the planner places a job: its box's lower-left corner
/// at 0,0, y up.
fn placed_outlines(svg: &Path) -> Vec<Vec<[f64; 2]>> {
    let text = std::fs::read_to_string(svg).unwrap();
    let cut = &text[text.find("<g id=\"cut\"").unwrap()..];
    let cut = &cut[..cut.find("</g>").unwrap()];
    let mut rings = Vec::new();
    for part in cut.split(" d=\"").skip(1) {
        rings.extend(svg_subpaths(&part[..part.find('"').unwrap()], 0.001));
    }
    let (mut x0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in rings.iter().flatten() {
        x0 = x0.min(p[0]);
        y1 = y1.max(p[1]);
    }
    rings
        .into_iter()
        .map(|r| r.into_iter().map(|p| [p[0] - x0, y1 - p[1]]).collect())
        .collect()
}

/// The farthest a point of `from` lies from the polylines `to` (closed when `closed`).
fn farthest(from: &[Vec<[f64; 2]>], to: &[Vec<[f64; 2]>], closed: bool) -> f64 {
    let segs: Vec<([f64; 2], [f64; 2])> = to
        .iter()
        .flat_map(|r| {
            let n = r.len();
            let k = if closed { n } else { n - 1 };
            (0..k).map(move |i| (r[i], r[(i + 1) % n]))
        })
        .collect();
    from.iter()
        .flatten()
        .map(|&p| {
            segs.iter()
                .map(|&(a, b)| seg_dist(p, a, b))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

#[test]
fn make_emit_hpgl_is_drawn_by_hp2xx_on_the_stencil_outlines() {
    let Some(hp2xx) = hp2xx() else { return };
    let dir = tmp();
    // The generic cutter with its overcut off, and no blade offset: the drawn paths must then lie
    // on the outlines.
    let profile = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("profiles/machines/vinyl-hpgl.toml"),
    )
    .unwrap()
    .replace("overcut_mm = 1", "overcut_mm = 0");
    let machine = dir.path().join("no-overcut.toml");
    std::fs::write(&machine, profile).unwrap();
    let out = dir.path().join("out");
    let o = stencil(&[
        "make",
        s(&samples().join("rings.png")),
        "--width-mm",
        "80",
        "--material",
        "vinyl-0.08",
        "--machine",
        s(&machine),
        "--blade-offset",
        "0",
        "--emit",
        "png,svg,hpgl",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let plt = out.join("stencil.plt");
    assert!(
        stdout(&o).contains("stencil.plt: vinyl-hpgl"),
        "{}",
        stdout(&o)
    );
    // hp2xx renders it without error.
    let png = dir.path().join("render.png");
    let r = Command::new(&hp2xx)
        .args(["-q", "-m", "png", "-f", s(&png), s(&plt)])
        .output()
        .unwrap();
    assert!(r.status.success() && png.is_file(), "{}", stderr(&r));
    // What it draws lies on the outlines, and every outline is drawn, within 0.03 mm (a
    // plotter unit is 0.025 mm: each point is rounded by at most 0.018 mm).
    let drawn = hp2xx_strokes(&hp2xx, &plt, dir.path());
    let outlines = placed_outlines(&out.join("stencil.svg"));
    assert_eq!(drawn.len(), outlines.len(), "one stroke per loop");
    let off = farthest(&drawn, &outlines, true);
    assert!(off < 0.03, "hp2xx draws {off} mm off the outlines");
    let missed = farthest(&outlines, &drawn, false);
    assert!(
        missed < 0.03,
        "an outline point is {missed} mm from what hp2xx draws"
    );
}

#[test]
fn make_emit_hpgl_closes_loops_with_the_overcut() {
    let dir = tmp();
    let out = dir.path().join("out");
    let o = stencil(&[
        "make",
        s(&samples().join("rings.png")),
        "--width-mm",
        "80",
        "--material",
        "vinyl-0.08",
        "--machine",
        "roland-camm",
        "--emit",
        "hpgl",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(out.join("stencil.plt")).unwrap();
    assert!(text.starts_with("IN;\nSP1;\nVS4;\nFS80;\n"), "{text:.60}");
    // Every stroke cuts back past its start: it passes within 0.2 mm of where it began (with
    // the axis 0.25 mm ahead of the tip) after going round, and goes on about 1 mm further.
    let mut strokes: Vec<Vec<[f64; 2]>> = Vec::new();
    for l in text.lines() {
        let nums = |s: &str| -> Vec<[f64; 2]> {
            let v: Vec<f64> = s
                .trim_end_matches(';')
                .split(',')
                .filter(|x| !x.is_empty())
                .map(|x| x.parse::<f64>().unwrap() / 40.0)
                .collect();
            v.chunks(2).map(|c| [c[0], c[1]]).collect()
        };
        if let Some(p) = l.strip_prefix("PU") {
            strokes.push(nums(p));
        } else if let Some(p) = l.strip_prefix("PD") {
            strokes.last_mut().unwrap().extend(nums(p));
        }
    }
    let loops: Vec<_> = strokes.iter().filter(|s| s.len() > 3).collect();
    assert!(loops.len() > 5);
    for s in loops {
        let start = s[0];
        let d = |p: [f64; 2]| (p[0] - start[0]).hypot(p[1] - start[1]);
        // The last point within 0.6 mm of the start (the axis comes back round), after which
        // the path runs on by the overcut.
        let back = s
            .iter()
            .rposition(|&p| d(p) < 0.6)
            .expect("the loop comes back to its start");
        let after: f64 = s[back..]
            .windows(2)
            .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
            .sum();
        assert!(
            back > 2 && (0.4..1.6).contains(&after),
            "overcut {after} mm"
        );
    }
}

/// A job of `n` cuts (a PU and a PD each) on the generic cutter's area.
fn big_job(n: usize) -> String {
    let mut s = String::from("IN;\nSP1;\nVS20;\nFS80;\n");
    for i in 0..n {
        let (x, y) = (400 + (i % 200) as i64 * 40, 400 + (i / 200) as i64 * 40);
        s.push_str(&format!(
            "PU{x},{y};\nPD{},{},{},{y};\n",
            x + 20,
            y + 20,
            x + 30
        ));
    }
    s.push_str("PU0,0;\n");
    s
}

fn ran(out: &str) -> usize {
    let at = out
        .find("virtual cutter: ")
        .expect("the virtual cutter's line");
    out[at + 16..]
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn send_dry_run_streams_20000_instructions_with_xon_xoff_and_rts_cts() {
    let dir = tmp();
    let plt = dir.path().join("big.plt");
    let text = big_job(9_998);
    std::fs::write(&plt, &text).unwrap();
    let total = text.lines().count();
    assert_eq!(total, 20_001);
    for (machine, flow, buffer) in [
        ("vinyl-hpgl", "xon-xoff", 1024),
        ("roland-camm", "rts-cts", 2048),
    ] {
        let o = stencil(&["send", s(&plt), "--machine", machine, "--dry-run"]);
        let out = stdout(&o);
        assert!(o.status.success(), "{machine}: {}{out}", stderr(&o));
        assert!(out.contains(&format!("{flow} flow control")), "{out}");
        // Every instruction run once, none lost or repeated.
        assert_eq!(ran(&out), total, "{out}");
        assert!(out.contains(&format!("sent {total} instructions")), "{out}");
        // The buffer never overflowed (the cutter refuses an overrun), the flow control acted.
        let peak: usize = out
            .split("buffer peak ")
            .nth(1)
            .unwrap()
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!(
            peak <= buffer && peak > buffer / 2,
            "{machine}: peak {peak}"
        );
        assert!(!out.contains(" 0 flow stop(s)"), "{out}");
        assert!(out.contains("tool up at the end"), "{out}");
    }
}

#[test]
fn an_abort_mid_job_clears_the_buffer_lifts_the_tool_and_resumes() {
    let dir = tmp();
    let plt = dir.path().join("big.plt");
    let text = big_job(3_000);
    std::fs::write(&plt, &text).unwrap();
    let o = stencil(&[
        "send",
        s(&plt),
        "--machine",
        "vinyl-hpgl",
        "--dry-run",
        "--dry-run-abort-at",
        "2001",
    ]);
    let (out, err) = (stdout(&o), stderr(&o));
    assert_eq!(o.status.code(), Some(1), "{out}{err}");
    assert!(
        out.contains("1 buffer clear(s); tool up at the end"),
        "{out}"
    );
    assert!(ran(&out) < 2001, "{out}");
    assert!(err.contains("the tool lifted (PU)"), "{err}");
    let line: usize = err
        .split("--from-line ")
        .nth(1)
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    // The resume starts no later than the first instruction the cutter had not run.
    assert!(
        line <= ran(&out) + 1 && line > 1000,
        "resume at {line}: {out}"
    );
    let o = stencil(&[
        "send",
        s(&plt),
        "--machine",
        "vinyl-hpgl",
        "--dry-run",
        "--from-line",
        &line.to_string(),
    ]);
    let out = stdout(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    let rest = text.lines().count() - (line - 1);
    assert!(out.contains(&format!("sent {rest} instructions")), "{out}");
    assert!(out.contains("tool up at the end"), "{out}");
}

#[test]
fn what_the_plotter_would_refuse_is_refused_before_sending() {
    let dir = tmp();
    for (text, machine, says) in [
        (
            "IN;SP1;FS40;PU10,10;\n",
            "hp7475a",
            "`FS` is not an instruction of the hp7475a",
        ),
        ("IN;SP1;PU99999,10;\n", "hp7475a", "off the cutting area"),
        ("G1 X10 Y10\n", "vinyl-hpgl", "where an instruction"),
    ] {
        let plt = dir.path().join("bad.plt");
        std::fs::write(&plt, text).unwrap();
        let o = stencil(&["send", s(&plt), "--machine", machine, "--dry-run"]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{text}");
        assert!(
            err.contains(says) && err.contains("nothing was sent"),
            "{err}"
        );
        assert!(!stdout(&o).contains("virtual cutter:"), "{}", stdout(&o));
    }
    // An HP-GL job for a GRBL machine, and G-code's --machine for HP-GL, are named as such.
    let o = stencil(&[
        "make",
        s(&samples().join("rings.png")),
        "--machine",
        "drag-knife",
        "--emit",
        "hpgl",
        "-o",
        s(&dir.path().join("o")),
    ]);
    assert!(stderr(&o).contains("is a GRBL machine"), "{}", stderr(&o));
}

#[test]
fn estimate_simulate_and_profiles_know_the_plotters() {
    let dir = tmp();
    let plt = dir.path().join("job.plt");
    // Two 10 mm cuts at 2 cm/s on a 2000 mm/s² cutter: 0.51 s each with the ramps, 0.06 s of
    // tool lifts, plus the travel.
    std::fs::write(
        &plt,
        "IN;\nSP1;\nVS2;\nPU400,400;\nPD800,400;\nPU400,800;\nPD800,800;\nPU0,0;\n",
    )
    .unwrap();
    let o = stencil(&["estimate", s(&plt), "--machine", "vinyl-hpgl"]);
    let out = stdout(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        out.contains("on vinyl-hpgl") && out.contains("cut 20 mm"),
        "{out}"
    );
    let png = dir.path().join("sim.png");
    let o = stencil(&[
        "simulate",
        s(&plt),
        "--machine",
        "vinyl-hpgl",
        "-o",
        s(&png),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("cut 20 mm in 2 strokes"),
        "{}",
        stdout(&o)
    );
    let img = image::open(&png).unwrap().to_rgb8();
    assert!(
        img.pixels().any(|p| p[0] >= 180 && p[1] < 80),
        "no red stroke drawn"
    );
    // Without a plotter named, a .plt is not guessed at.
    let o = stencil(&["estimate", s(&plt)]);
    assert!(stderr(&o).contains("needs its plotter"), "{}", stderr(&o));
    let o = stencil(&["profiles"]);
    let out = stdout(&o);
    for (name, flow) in [
        ("vinyl-hpgl", "xon-xoff"),
        ("roland-camm", "rts-cts"),
        ("graphtec-hpgl", "xon-xoff"),
        ("hp7475a", "rts-cts"),
    ] {
        let line = out
            .lines()
            .find(|l| l.starts_with(name))
            .unwrap_or_else(|| panic!("{out}"));
        assert!(line.contains(flow) && !line.contains("error"), "{line}");
    }
}

#[test]
fn the_grbl_drag_knife_slows_small_features_too() {
    let dir = tmp();
    let svg = dir.path().join("two.svg");
    // A 3 mm square (a small feature: under the profile's 5 mm) and a 20 mm one.
    std::fs::write(
        &svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="40mm" viewBox="0 0 40 40">
<path d="M2 2H5V5H2Z"/><path d="M10 10H30V30H10Z"/></svg>"#,
    )
    .unwrap();
    let gcode = dir.path().join("two.gcode");
    let o = stencil(&[
        "gcode",
        s(&svg),
        "-o",
        s(&gcode),
        "--machine",
        "drag-knife",
        "--speed",
        "1200",
        "--blade-offset",
        "0.25",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&gcode).unwrap();
    let feeds: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("G1 X"))
        .filter_map(|l| l.split_whitespace().find(|w| w.starts_with('F')))
        .collect();
    assert_eq!(feeds, ["F600", "F1200"], "{text}");
}
