//! The working resolution follows the material: a picture whose pixels are coarse for its size is
//! supersampled automatically, so the cut follows the picture rather than its pixel staircase;
//! `--scale` overrides; the picture keeps its size in mm at any working scale.

use std::path::Path;

use crate::common::*;

/// 320 px across at 200 mm: 0.625 mm per input pixel.
const SIDE: u32 = 320;
const WIDTH_MM: f64 = 200.0;
/// The disc: centre and radius in input pixels.
const CENTRE: f64 = 160.0;
const RADIUS: f64 = 120.0;

/// A dark disc on white, anti-aliased as a scan or a photo would be.
fn disc_png(path: &Path) {
    smooth_png(path, SIDE, SIDE, |x, y| {
        if (x - CENTRE).hypot(y - CENTRE) < RADIUS {
            0.0
        } else {
            1.0
        }
    });
}

/// Run `stencil make INPUT -o OUT ARGS...`, which must succeed: its report and what it printed.
fn make(input: &Path, out: &Path, args: &[&str]) -> (serde_json::Value, String) {
    let mut all = vec!["make", s(input), "-o", s(out)];
    all.extend_from_slice(args);
    let o = stencil(&all);
    assert!(o.status.success(), "stencil {all:?}: {}", stderr(&o));
    (report(out), String::from_utf8_lossy(&o.stdout).into_owned())
}

/// The closed paths of the SVG's CUT layer, as points in mm: lines and arcs read with kurbo
/// ([`svg_subpaths`]) and flattened within a micrometre, so that a distance measured on them is
/// the drawn curve's, not only its vertices'.
fn cut_paths(svg: &str) -> Vec<Vec<[f64; 2]>> {
    let start = svg.find("id=\"cut\"").expect("a CUT layer");
    let layer = &svg[start..start + svg[start..].find("</g>").expect("layer ends")];
    let mut paths = Vec::new();
    for chunk in layer.split(" d=\"").skip(1) {
        let d = &chunk[..chunk.find('"').unwrap()];
        paths.extend(svg_subpaths(d, 0.001));
    }
    paths
}

/// The largest distance (mm) of the stencil's only cut path from the true circle, after checking
/// that the picture measures 200 mm in the report and in the SVG.
fn disc_run(out: &Path, extra: &[&str]) -> (serde_json::Value, f64, String) {
    let input = out.parent().unwrap().join("disc.png");
    disc_png(&input);
    let w = WIDTH_MM.to_string();
    let mut args = vec!["--width-mm", &w, "--material", "cardstock"];
    args.extend_from_slice(extra);
    let (r, stdout) = make(&input, out, &args);
    // The picture is 200 mm wide at any working scale.
    let k = r["scale_factor"].as_u64().unwrap() as f64;
    assert!(
        (r["width_mm"].as_f64().unwrap() - WIDTH_MM).abs() < 1e-9,
        "{r}"
    );
    assert_eq!(r["width_px"].as_f64().unwrap(), SIDE as f64 * k);
    let mm = r["mm_per_px"].as_f64().unwrap();
    assert!((mm - WIDTH_MM / (SIDE as f64 * k)).abs() < 1e-12, "{mm}");
    let svg = std::fs::read_to_string(out.join("stencil.svg")).unwrap();
    // The sheet: the picture plus the default 5 mm margin on each side.
    assert!(svg.contains("width=\"210mm\""), "{}", &svg[..200]);
    let paths = cut_paths(&svg);
    assert_eq!(paths.len(), 1, "one cut: the disc");
    let (c, radius) = (
        CENTRE / SIDE as f64 * WIDTH_MM,
        RADIUS / SIDE as f64 * WIDTH_MM,
    );
    assert!(
        paths[0].len() > 50,
        "a circle, not a polygon: {:?}",
        paths[0]
    );
    let worst = paths[0]
        .iter()
        .map(|p| ((p[0] - c).hypot(p[1] - c) - radius).abs())
        .fold(0.0, f64::max);
    (r, worst, stdout)
}

#[test]
fn a_coarse_picture_is_supersampled_and_its_edge_follows_the_picture() {
    let dir = tmp();
    let (r, worst, stdout) = disc_run(&dir.path().join("auto"), &[]);
    // 0.625 mm per pixel; cardstock asks for at most min(0.5 / 5, 2 × 0.05) = 0.1 mm: 7 × (0.089).
    assert_eq!(r["scale_factor"], 7, "{r}");
    let a = &r["scale_auto"];
    assert_eq!(a["wanted"], 7, "{a}");
    assert!((a["target_mm_per_px"].as_f64().unwrap() - 0.1).abs() < 1e-12);
    assert!(a.get("capped_by").is_none(), "{a}");
    assert!(
        stdout.contains("supersampled 7x (0.089 mm per working pixel)"),
        "{stdout}"
    );
    // An input pixel is 0.625 mm and its staircase 0.2-0.3 mm (see the test below). A traced edge
    // lies within half a working pixel (0.045 mm) of the edge, and simplification moves it by at
    // most the tolerance (0.05 mm): within 0.1 mm of the circle (0.086 measured).
    assert!(worst < 0.1, "the cut strays {worst:.3} mm from the circle");
}

#[test]
fn scale_1_turns_supersampling_off() {
    let dir = tmp();
    let (r, worst, stdout) = disc_run(&dir.path().join("off"), &["--scale", "1"]);
    assert_eq!(r["scale_factor"], 1, "{r}");
    assert!(r.get("scale_auto").is_none(), "given, not automatic: {r}");
    assert!(!stdout.contains("supersampled"), "{stdout}");
    // What the automatic factor prevents: the input pixels' staircase in the cut (0.235 mm
    // measured).
    assert!(
        worst > 0.2,
        "the staircase at 0.625 mm per pixel: {worst:.3} mm"
    );
}

/// A 4 mm disc on a 60 × 50 px picture: 6 mm wide at the default 0.1 mm per pixel.
fn dot_png(path: &Path) {
    ink_png(path, 60, 50, |x, y| {
        (x as f64 + 0.5 - 30.0).hypot(y as f64 + 0.5 - 25.0) < 20.0
    });
}

#[test]
fn a_picture_fine_enough_is_not_supersampled() {
    let dir = tmp();
    let input = dir.path().join("dot.png");
    dot_png(&input);
    // Cardstock at the default size is exactly as fine as the rule asks (0.1 mm): factor 1.
    let (r, stdout) = make(&input, &dir.path().join("cardstock"), &[]);
    assert!(!stdout.contains("supersampled"), "{stdout}");
    assert_eq!(r["scale_factor"], 1, "{r}");
    assert_eq!(r["scale_auto"]["wanted"], 1, "{r}");
    assert_eq!(
        (r["width_px"].as_u64(), r["mm_per_px"].as_f64()),
        (Some(60), Some(0.1))
    );

    // Brass etch holds 0.33 mm features: 0.066 mm asks for 2x, and the picture stays 6 mm wide.
    let brass = ["--material", "brass-0.3-etch"];
    let (r, _) = make(&input, &dir.path().join("brass"), &brass);
    assert_eq!(
        (r["scale_factor"].as_u64(), r["width_px"].as_u64()),
        (Some(2), Some(120))
    );
    assert!((r["width_mm"].as_f64().unwrap() - 6.0).abs() < 1e-9, "{r}");

    // --dpi is per input pixel: at 254 dpi (0.1 mm) and --scale 3 the picture is still 6 mm wide.
    let dpi = ["--dpi", "254", "--scale", "3"];
    let (r, _) = make(&input, &dir.path().join("dpi"), &dpi);
    assert_eq!(
        (r["scale_factor"].as_u64(), r["width_px"].as_u64()),
        (Some(3), Some(180))
    );
    assert!((r["width_mm"].as_f64().unwrap() - 6.0).abs() < 1e-9, "{r}");
}

#[test]
fn a_given_scale_stays_within_max_pixels() {
    let dir = tmp();
    let input = dir.path().join("dot.png");
    dot_png(&input);
    // 60 × 50 × 4² = 48,000 working pixels, over a limit of 10,000: refused, nothing written.
    let out = dir.path().join("out");
    let limit = ["--max-pixels", "10000"];
    let o = stencil(
        &[
            &["make", s(&input), "-o", s(&out), "--scale", "4"][..],
            &limit,
        ]
        .concat(),
    );
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(
        err.contains("dot.png") && err.contains("--scale 4") && err.contains("--max-pixels"),
        "{err}"
    );
    assert!(!out.exists());
    // The automatic factor keeps within it instead: at 0.5 mm per pixel cardstock wants 5x, and
    // 10,000 pixels allow only 1x (2x would be 12,000).
    let (r, stdout) = make(&input, &out, &[&["--width-mm", "30"][..], &limit].concat());
    assert!(stdout.contains("kept to 1x by --max-pixels"), "{stdout}");
    assert_eq!(r["scale_factor"], 1);
    assert_eq!(r["scale_auto"]["wanted"], 5);
    assert_eq!(r["scale_auto"]["capped_by"], "max_pixels");
}
