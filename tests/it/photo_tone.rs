//! The two-tone a photo deserves (issue 27 item 1), checked on what `make` writes: `--threshold
//! auto` against 128 and Otsu by the documented likeness, each picture adjustment's effect on
//! twotone.png, crop and rotation sizes and frames, and islands dropped rather than bridged.

use std::path::Path;

use crate::common::*;
use stencil_core::raster::{BitGrid, Gray};

fn make_ok(input: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["make", s(input), "-o", s(out)];
    args.extend_from_slice(extra);
    let o = stencil(&args);
    assert!(o.status.success(), "{extra:?}: {}", stderr(&o));
    assert_valid_stencil(out);
    o
}

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// 4-connected pieces of both tones (a count of how busy a two-tone is).
fn pieces(b: &BitGrid) -> usize {
    let (w, h) = (b.width as usize, b.height as usize);
    let (_, m) = pieces_of(w, h, |i| b.data[i]);
    let (_, c) = pieces_of(w, h, |i| !b.data[i]);
    m + c
}

/// `--threshold auto` is at least as like the photo as 128 and Otsu's level, measured here on the
/// written twotone.png against the photo's gray with the library's likeness; both print the
/// level they chose.
#[test]
fn auto_beats_128_and_otsu_on_a_photo() {
    let dir = tmp();
    let input = samples().join("grace_hopper.jpg");
    let gray = stencil_core::tone::load_gray(&input, 1 << 30).unwrap();
    let mut like = Vec::new();
    for t in ["auto", "128", "otsu"] {
        let out = dir.path().join(t);
        let o = make_ok(
            &input,
            &out,
            &["--threshold", t, "--keep-all-islands", "--scale", "1"],
        );
        let r = report(&out);
        let level = r["threshold_level"].as_u64().unwrap();
        if t != "128" {
            assert!(
                stdout(&o).contains(&format!("{t} chose level {level}")),
                "{}",
                stdout(&o)
            );
        }
        let two = read_bits(&out.join("twotone.png"));
        like.push(stencil_core::tone::likeness(&two, &gray, false));
        if t == "auto" {
            let c = &r["threshold_choice"];
            assert!(c["tried"].as_array().unwrap().len() > 20, "{c}");
            assert!(c["likeness"].as_f64() >= c["likeness_128"].as_f64());
        }
    }
    assert!(
        like[0] >= like[1] - 1e-9 && like[0] >= like[2] - 1e-9,
        "auto {like:?}"
    );
}

/// A horizontal ramp, black to white, 256 × 40 px.
fn ramp(path: &Path) {
    let data: Vec<u8> = (0..40).flat_map(|_| 0..=255u8).collect();
    write_gray_png(path, 256, 40, &data);
}

#[test]
fn brightness_contrast_and_gamma_move_the_edge_as_expected() {
    let dir = tmp();
    let input = dir.path().join("ramp.png");
    ramp(&input);
    // At a fixed level (a ramp is a photo to the default, which would choose its own level).
    let material = |extra: &[&str]| {
        let out = dir.path().join(extra.join("_"));
        let mut a = if extra.contains(&"--threshold") {
            vec![]
        } else {
            vec!["--threshold", "128"]
        };
        a.extend_from_slice(extra);
        make_ok(&input, &out, &a);
        read_bits(&out.join("twotone.png")).count_material()
    };
    let base = material(&["--scale", "1"]);
    // On the ramp, material is the part at or above 128: half of it.
    assert!((base as i64 - 128 * 40).abs() <= 3 * 40, "{base}");
    // Gamma 2 lifts the midtones: 0.25 becomes 0.5, so about three quarters are light.
    let g = material(&["--scale", "1", "--gamma", "2"]);
    assert!((g as i64 - 192 * 40).abs() <= 4 * 40, "{g}");
    assert!(material(&["--scale", "1", "--brightness", "20"]) > base + 40 * 40);
    assert!(material(&["--scale", "1", "--brightness", "-20"]) < base - 40 * 40);
    // More contrast about mid-gray leaves the 128 edge where it is but moves a 100 edge up.
    let at100 = material(&["--scale", "1", "--threshold", "100"]);
    let at100c = material(&["--scale", "1", "--threshold", "100", "--contrast", "100"]);
    assert!(at100c < at100 - 10 * 40, "{at100} {at100c}");
}

/// A noisy two-tone field: left half 0.42, right half 0.58, each pixel off by up to ±0.15.
fn noisy(path: &Path) {
    let mut seed = 7u32;
    let mut data = Vec::new();
    for _ in 0..120 {
        for x in 0..160u32 {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            let n = ((seed >> 24) as f64 / 255.0 - 0.5) * 0.3;
            let v = if x < 80 { 0.42 } else { 0.58 } + n;
            data.push((v.clamp(0.0, 1.0) * 255.0) as u8);
        }
    }
    write_gray_png(path, 160, 120, &data);
}

#[test]
fn smoothing_and_abstraction_quiet_the_noise_and_keep_the_edge() {
    let dir = tmp();
    let input = dir.path().join("noisy.png");
    noisy(&input);
    let run = |extra: &[&str]| {
        let out = dir.path().join(extra.join("_"));
        let mut a = vec![
            "--threshold",
            "128",
            "--scale",
            "1",
            "--filter-radius",
            "0",
            "--min-speck-px",
            "1",
            "--allow-thin",
        ];
        a.extend_from_slice(extra);
        make_ok(&input, &out, &a);
        read_bits(&out.join("twotone.png"))
    };
    let base = run(&[]);
    let smooth = run(&["--smooth", "0.5"]);
    let abs = run(&["--abstract", "0.6"]);
    assert!(
        pieces(&smooth) * 2 < pieces(&base),
        "{} {}",
        pieces(&smooth),
        pieces(&base)
    );
    assert!(
        pieces(&abs) * 4 < pieces(&base),
        "{} {}",
        pieces(&abs),
        pieces(&base)
    );
    // The edge stays at the middle: the left quarter mostly cut, the right quarter mostly material.
    for b in [&smooth, &abs] {
        let light = |x0: u32, x1: u32| {
            (0..120)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|&(x, y)| b.get(x, y))
                .count() as f64
                / ((x1 - x0) * 120) as f64
        };
        assert!(
            light(5, 70) < 0.1 && light(90, 155) > 0.9,
            "{} {}",
            light(5, 70),
            light(90, 155)
        );
    }
}

#[test]
fn a_local_threshold_shows_stripes_in_shadow_and_light() {
    let dir = tmp();
    let input = dir.path().join("lit.png");
    // Stripes 0.15 darker than their surroundings, lit from dark (left) to bright (right).
    let mut data = Vec::new();
    for _ in 0..80 {
        for x in 0..300u32 {
            let base = 0.1 + 0.8 * x as f64 / 299.0;
            let stripe = (x / 10) % 2 == 0;
            let v = base - if stripe { 0.15 } else { 0.0 };
            data.push((v.clamp(0.0, 1.0) * 255.0) as u8);
        }
    }
    write_gray_png(&input, 300, 80, &data);
    let mixed = |b: &BitGrid, x0: u32, x1: u32| {
        let n = (x0..x1).filter(|&x| b.get(x, 40)).count();
        n > 0 && n < (x1 - x0) as usize
    };
    let out = dir.path().join("global");
    make_ok(&input, &out, &["--scale", "1", "--keep-all-islands"]);
    let global = read_bits(&out.join("twotone.png"));
    assert!(!mixed(&global, 0, 60) && !mixed(&global, 240, 300));
    let out = dir.path().join("local");
    make_ok(
        &input,
        &out,
        &[
            "--scale",
            "1",
            "--local-threshold",
            "2",
            "--keep-all-islands",
        ],
    );
    let local = read_bits(&out.join("twotone.png"));
    assert!(mixed(&local, 0, 60) && mixed(&local, 240, 300));
}

/// A 400 × 300 dark picture (0.1 mm per pixel: 40 × 30 mm) with a light disc of radius 3 mm at
/// (30, 20) mm and a light mark in its top-left corner.
fn disc_picture(path: &Path) {
    let mut data = Vec::new();
    for y in 0..300u32 {
        for x in 0..400u32 {
            let d = (x as f64 + 0.5 - 300.0).hypot(y as f64 + 0.5 - 200.0);
            let light = d < 30.0 || (x < 40 && y < 20);
            data.push(if light { 230 } else { 20 });
        }
    }
    write_gray_png(path, 400, 300, &data);
}

#[test]
fn crop_is_in_mm_and_bridge_at_refers_to_the_cropped_picture() {
    let dir = tmp();
    let input = dir.path().join("disc.png");
    disc_picture(&input);
    let out = dir.path().join("crop");
    // 20 × 15 mm from (20, 10) mm: 200 × 150 px; the disc's centre is at (10, 10) mm in it,
    // its right edge at (13, 10).
    make_ok(
        &input,
        &out,
        &[
            "--scale",
            "1",
            "--crop",
            "20,10,20,15",
            "--bridge-at",
            "13.2,10",
        ],
    );
    let two = read_bits(&out.join("twotone.png"));
    assert_eq!((two.width, two.height), (200, 150));
    assert!(
        two.get(100, 100) && !two.get(150, 20),
        "the disc at (10, 10) mm"
    );
    let r = report(&out);
    let at = &r["user_bridges"]["bridge_at"][0];
    assert!(at["distance_mm"].as_f64().unwrap() < 1.0, "{at}");
    let start = at["start_mm"].as_array().unwrap();
    assert!((start[0].as_f64().unwrap() - 13.0).abs() < 1.0, "{at}");
    // Outside the picture: refused, naming the option.
    let o = stencil(&[
        "make",
        s(&input),
        "-o",
        s(&dir.path().join("bad")),
        "--crop",
        "30,10,20,15",
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--crop"), "{}", stderr(&o));
}

#[test]
fn rotation_turns_the_picture_clockwise() {
    let dir = tmp();
    let input = dir.path().join("disc.png");
    disc_picture(&input);
    let out = dir.path().join("turned");
    make_ok(
        &input,
        &out,
        &["--scale", "1", "--rotate", "90", "--keep-all-islands"],
    );
    let two = read_bits(&out.join("twotone.png"));
    assert_eq!((two.width, two.height), (300, 400));
    // The top-left mark is now top-right; the disc at (300, 200) now at (100, 300).
    assert!(two.get(290, 10) && !two.get(10, 10));
    assert!(two.get(100, 300));
}

/// A dark field inside a light frame, with a 1.5 × 1.5 mm highlight and a 16 mm light disc.
fn highlight_picture(path: &Path) {
    let mut data = Vec::new();
    for y in 0..300u32 {
        for x in 0..400u32 {
            let frame = x < 20 || y < 20 || x >= 380 || y >= 280;
            let speck = (95..110).contains(&x) && (145..160).contains(&y);
            let disc = (x as f64 - 280.0).hypot(y as f64 - 150.0) < 80.0;
            data.push(if frame || speck || disc { 235 } else { 15 });
        }
    }
    write_gray_png(path, 400, 300, &data);
}

#[test]
fn a_small_highlight_is_dropped_not_bridged_unless_asked() {
    let dir = tmp();
    let input = dir.path().join("hl.png");
    highlight_picture(&input);
    let out = dir.path().join("drop");
    let o = make_ok(&input, &out, &["--scale", "1"]);
    let r = report(&out);
    let d = r["dropped_islands"]
        .as_array()
        .expect("dropped islands listed");
    assert_eq!(d.len(), 1, "{r}");
    assert!(
        (d[0]["area_mm2"].as_f64().unwrap() - 2.25).abs() < 0.3,
        "{d:?}"
    );
    assert!(stdout(&o).contains("dropped 1 island"), "{}", stdout(&o));
    // twotone.png shows it cut, the disc kept; the preview shows it yellow.
    let two = read_bits(&out.join("twotone.png"));
    assert!(!two.get(102, 152) && two.get(280, 150));
    assert!(!r["bridges"].as_array().unwrap().is_empty());
    let preview = image::open(out.join("preview.png")).unwrap().to_rgb8();
    let f = preview.width() / 400;
    assert_eq!(preview.get_pixel(102 * f, 152 * f).0, [255, 220, 0]);
    // Asked to keep every island: bridged, nothing dropped.
    let out = dir.path().join("keep");
    make_ok(&input, &out, &["--scale", "1", "--keep-all-islands"]);
    let r = report(&out);
    assert!(r.get("dropped_islands").is_none(), "{r}");
    assert!(read_bits(&out.join("twotone.png")).get(102, 152));
    assert_eq!(r["islands"], 2);
}

/// The likeness measure on a known case: a faithful two-tone scores higher than a blank one.
#[test]
fn likeness_prefers_the_faithful_two_tone() {
    let mut g = Gray::new(100, 80, 0.85);
    let mut b = BitGrid::new(100, 80, true);
    for y in 20..60 {
        for x in 30..70 {
            g.set(x, y, 0.15);
            b.set(x, y, false);
        }
    }
    let good = stencil_core::tone::likeness(&b, &g, false);
    let blank = stencil_core::tone::likeness(&BitGrid::new(100, 80, true), &g, false);
    assert!(good > blank + 0.15, "{good} {blank}");
}

/// `tone --threshold otsu|auto` prints the level it chose, as `make` does, and it is the level
/// `make` cuts at (report.json's `threshold_level`) (issue 42 item 1).
#[test]
fn tone_says_the_level_otsu_and_auto_chose() {
    let dir = tmp();
    let pic = samples().join("grace_hopper.jpg");
    for how in ["otsu", "auto"] {
        let png = dir.path().join(format!("{how}.png"));
        let o = stencil(&["tone", s(&pic), "--threshold", how, "-o", s(&png)]);
        assert!(o.status.success(), "{}", stderr(&o));
        let said = stdout(&o);
        let level: u64 = said
            .split(&format!("threshold: {how} chose level "))
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("tone --threshold {how} said no level: {said}"));
        let out = dir.path().join(how);
        let m = make_ok(&pic, &out, &["--threshold", how]);
        assert!(
            stdout(&m).contains(&format!("{how} chose level {level} ")),
            "{}",
            stdout(&m)
        );
        assert_eq!(report(&out)["threshold_level"].as_u64(), Some(level));
    }
}

/// The bytes of `name` in `dir`.
fn bytes(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{}: {e}", dir.join(name).display()))
}

/// Without `--threshold`, a photo is cut at the level `auto` chooses, said on the output; two-tone
/// art keeps its own tones (128 for black and white, halfway between two other tones); a mesh is
/// cut at 128 (issue 42 item 1).
#[test]
fn the_default_level_is_autos_for_a_photo_and_the_arts_own_for_art() {
    let dir = tmp();
    let d = dir.path();
    // A photo: the same two-tone and level as --threshold auto, and the level said.
    let photo = samples().join("grace_hopper.jpg");
    let plain = make_ok(&photo, &d.join("photo"), &[]);
    let auto = make_ok(&photo, &d.join("photo-auto"), &["--threshold", "auto"]);
    let level = report(&d.join("photo-auto"))["threshold_level"]
        .as_u64()
        .unwrap();
    assert_ne!(level, 128, "this photo's auto level is not the old default");
    assert_eq!(
        report(&d.join("photo"))["threshold_level"].as_u64(),
        Some(level)
    );
    assert!(
        stdout(&plain).contains(&format!(
            "threshold: level {level}, the likeliest for a photo (likeness "
        )),
        "{}",
        stdout(&plain)
    );
    assert!(stdout(&auto).contains(&format!("auto chose level {level} ")));
    assert!(
        !stdout(&plain).contains("note: the paper"),
        "{}",
        stdout(&plain)
    );
    assert_eq!(
        bytes(&d.join("photo"), "twotone.png"),
        bytes(&d.join("photo-auto"), "twotone.png")
    );
    // Black-and-white art (anti-aliased edges): as at 128, and nothing said of the level.
    let art = samples().join("letters.png");
    let plain = make_ok(&art, &d.join("art"), &[]);
    make_ok(&art, &d.join("art-128"), &["--threshold", "128"]);
    assert!(!stdout(&plain).contains("threshold:"), "{}", stdout(&plain));
    assert_eq!(
        bytes(&d.join("art"), "twotone.png"),
        bytes(&d.join("art-128"), "twotone.png")
    );
    // Two-tone art in two dark tones (a dark red drawing on black: grays 20 and 90): cut halfway
    // between them, so the drawing is kept; 128 would cut the whole sheet.
    let dark = d.join("dark.png");
    let data: Vec<u8> = (0..160u32 * 120)
        .map(|i| {
            let (x, y) = (i % 160, i / 160);
            let ring = ((x as f64 - 80.0).hypot(y as f64 - 60.0) - 35.0).abs() < 8.0;
            if ring || (20..140).contains(&x) && (8..20).contains(&y) {
                90
            } else {
                20
            }
        })
        .collect();
    write_gray_png(&dark, 160, 120, &data);
    make_ok(&dark, &d.join("dark"), &[]);
    make_ok(&dark, &d.join("dark-55"), &["--threshold", "55"]);
    assert_eq!(
        report(&d.join("dark"))["threshold_level"].as_u64(),
        Some(55)
    );
    assert_eq!(
        bytes(&d.join("dark"), "twotone.png"),
        bytes(&d.join("dark-55"), "twotone.png")
    );
    // A rendered mesh: 128, as before.
    let mesh = samples().join("pawn.obj");
    make_ok(&mesh, &d.join("mesh"), &[]);
    make_ok(&mesh, &d.join("mesh-128"), &["--threshold", "128"]);
    assert_eq!(
        bytes(&d.join("mesh"), "twotone.png"),
        bytes(&d.join("mesh-128"), "twotone.png")
    );
}

/// A page of text lit from one side: no single level shows it all, and `make` says to try a local
/// threshold, which does (issue 42 item 1).
#[test]
fn a_page_in_uneven_light_gets_a_local_threshold_suggested() {
    let dir = tmp();
    let (w, h) = (600u32, 400u32);
    let mut data = vec![0u8; (w * h) as usize];
    let mut seed = 1u32;
    for y in 0..h {
        for x in 0..w {
            data[(y * w + x) as usize] = ((0.3 + 0.65 * x as f64 / w as f64) * 255.0) as u8;
        }
    }
    // Letters: a stem and a bar of ink at a quarter of the paper's light, in rows.
    for r in (20..h - 40).step_by(24) {
        for c in (20..w - 20).step_by(14) {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            if seed >> 24 < 204 {
                for (x0, y0, x1, y1) in [(c, r, c + 3, r + 14), (c, r, c + 10, r + 3)] {
                    for y in y0..y1 {
                        for x in x0..x1 {
                            let i = (y * w + x) as usize;
                            data[i] /= 4;
                        }
                    }
                }
            }
        }
    }
    let page = dir.path().join("page.png");
    write_gray_png(&page, w, h, &data);
    let plain = make_ok(&page, &dir.path().join("plain"), &[]);
    assert!(
        stdout(&plain).contains("note: the paper's light varies across the picture")
            && stdout(&plain).contains("--local-threshold"),
        "{}",
        stdout(&plain)
    );
    make_ok(
        &page,
        &dir.path().join("local"),
        &["--local-threshold", "5"],
    );
    // The dark side's paper: cut at the one level, material under the local threshold.
    let paper_kept = |out: &str| {
        let b = read_bits(&dir.path().join(out).join("twotone.png"));
        let (bw, bh) = (b.width, b.height);
        let n = (0..bh)
            .flat_map(|y| (0..bw / 4).map(move |x| (x, y)))
            .filter(|&(x, y)| b.get(x, y))
            .count();
        n as f64 / (bw / 4 * bh) as f64
    };
    let (one, local) = (paper_kept("plain"), paper_kept("local"));
    assert!(
        one < 0.1 && local > 0.5,
        "dark side kept: one level {one}, local {local}"
    );
}
