//! Issue 43 item 2: a job whose lines arrive slower than its feed uses them is flagged where it
//! starves Grbl's planner, its time includes the starvation, and the jobs `gcode` writes keep the
//! machine fed by default.

use std::path::Path;

use crate::common::{s, stderr, stencil, tmp};

/// A circle of radius 15 mm around (30, 30) as `n` straight segments, from its rightmost point.
fn circle(n: usize) -> Vec<[f64; 2]> {
    (0..n)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            [30.0 + 15.0 * a.cos(), 30.0 + 15.0 * a.sin()]
        })
        .collect()
}

/// A square of 20 mm sides in four long moves at 1200 mm/min, then the circle in 0.05 mm
/// segments at 6000 mm/min: lines 9 to 1893.
fn tiny_job() -> String {
    let mut p = String::from("G21 G90\nG0 X5 Y5\nM4 S500\nG1 X25 F1200\nG1 Y25\nG1 X5\nG1 Y5\n");
    p.push_str("G0 X45 Y30\n");
    for (i, q) in circle(1885).iter().enumerate().skip(1) {
        let f = if i == 1 { " F6000" } else { "" };
        p.push_str(&format!("G1 X{:.3} Y{:.3}{f}\n", q[0], q[1]));
    }
    p.push_str("G1 X45 Y30\nM5\nG0 X0 Y0\nM2\n");
    p
}

/// The seconds `stencil estimate` prints: "about 5 s (5.21 s)".
fn seconds(out: &str) -> f64 {
    let at = out.find(" s) on ").expect(out);
    let open = out[..at].rfind('(').unwrap();
    out[open + 1..at].parse().unwrap()
}

fn estimate(file: &Path, machine: &str) -> (String, f64) {
    let o = stencil(&["estimate", s(file), "--machine", machine]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    let t = seconds(&out);
    (out, t)
}

/// The CO2 profile (3000 mm/s²) with its serial line made as fast as a native USB board's:
/// nothing starves on it, so it times the job as the plain estimate does.
fn fast_link_profile(dir: &Path) -> String {
    let co2 = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("profiles/machines/co2-600x400.toml"),
    )
    .unwrap();
    let mut text = String::new();
    for line in co2.lines() {
        if line.starts_with("baud") {
            text.push_str("baud = 4000000\n");
        } else {
            text.push_str(line);
            text.push('\n');
        }
    }
    assert!(
        text.contains("baud = 4000000"),
        "the profile has no [link] baud"
    );
    let p = dir.join("co2-usb.toml");
    std::fs::write(
        &p,
        text.replace("name = \"co2-600x400\"", "name = \"co2-usb\""),
    )
    .unwrap();
    p.to_string_lossy().into_owned()
}

#[test]
fn estimate_says_where_tiny_segments_starve_and_counts_the_time() {
    let dir = tmp();
    let job = dir.path().join("tiny.nc");
    std::fs::write(&job, tiny_job()).unwrap();
    let (out, streamed) = estimate(&job, "co2-600x400");
    assert!(
        out.contains("warning: the planner starves in 1 place at 115200 baud"),
        "{out}"
    );
    // Where: the lines of the tiny segments (9..=1893), not the square before them.
    let at = out.find("  lines ").expect(&out);
    let range = out[at + 8..].split_whitespace().next().unwrap();
    let (a, b) = range.split_once('-').unwrap();
    let (a, b): (usize, usize) = (a.parse().unwrap(), b.parse().unwrap());
    assert!((9..200).contains(&a) && (1700..=1893).contains(&b), "{out}");
    assert!(out.contains("the serial line brings 6"), "{out}");
    // The time includes it: on a line fast enough the same job is timed shorter, by about the
    // time lost that the warning states.
    let fast = fast_link_profile(dir.path());
    let (out_fast, plain) = estimate(&job, &fast);
    assert!(!out_fast.contains("starves"), "{out_fast}");
    let lost: f64 = out
        .split("; ")
        .find_map(|p| p.strip_suffix(" s lost"))
        .expect(&out)
        .parse()
        .unwrap();
    assert!(streamed > plain + 0.5, "{streamed} vs {plain}");
    assert!(
        (streamed - plain - lost).abs() < 0.02,
        "{streamed} {plain} {lost}"
    );
}

/// An SVG of the circle as a 0.05 mm polygon (a fine outline written without arcs).
fn fine_svg(dir: &Path) -> String {
    let pts: Vec<String> = circle(1885)
        .iter()
        .map(|q| format!("{:.4},{:.4}", q[0], q[1]))
        .collect();
    let svg = format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="0 0 60 60"><polygon points="{}"/></svg>"#,
        pts.join(" ")
    );
    let p = dir.join("fine.svg");
    std::fs::write(&p, svg).unwrap();
    p.to_string_lossy().into_owned()
}

fn gcode(dir: &Path, svg: &str, out: &str, extra: &[&str]) -> String {
    let job = dir.join(out);
    let mut args = vec![
        "gcode",
        svg,
        "-o",
        s(&job),
        "--machine",
        "co2-600x400",
        "--power",
        "50",
        "--speed",
        "6000",
        "--no-arcs",
    ];
    args.extend_from_slice(extra);
    let o = stencil(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn gcode_lowers_the_feed_where_the_line_cannot_keep_up_and_the_job_then_does_not_starve() {
    let dir = tmp();
    let svg = fine_svg(dir.path());
    // By default: the feed is lowered where it would starve, and the summary says where.
    let out = gcode(dir.path(), &svg, "fed.gcode", &[]);
    assert!(out.contains("feed lowered in 1 place"), "{out}");
    assert!(out.contains(" mm/min instead of 6000"), "{out}");
    assert!(!out.contains("warning: the planner starves"), "{out}");
    let fed = dir.path().join("fed.gcode");
    let text = std::fs::read_to_string(&fed).unwrap();
    let lowered: Vec<f64> = text
        .lines()
        .filter_map(|l| l.split(' ').find_map(|w| w.strip_prefix('F')))
        .map(|f| f.parse().unwrap())
        .filter(|&f| f < 6000.0)
        .collect();
    assert!(
        !lowered.is_empty() && lowered.iter().all(|&f| f > 1000.0),
        "{lowered:?}"
    );
    // The written job, timed over the serial line by `estimate`, does not starve.
    let (est, _) = estimate(&fed, "co2-600x400");
    assert!(!est.contains("starves"), "{est}");
    // Asked to keep the feed: the job keeps 6000 mm/min, and both the summary and the estimate
    // say where it starves.
    let out = gcode(dir.path(), &svg, "kept.gcode", &["--keep-feed"]);
    assert!(
        out.contains("warning: the planner starves in 1 place"),
        "{out}"
    );
    let kept = dir.path().join("kept.gcode");
    let (est, _) = estimate(&kept, "co2-600x400");
    assert!(est.contains("warning: the planner starves"), "{est}");
}
