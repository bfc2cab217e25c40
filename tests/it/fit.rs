//! A size that fits, decided from the picture's header before the work (issue 28, item 3).

use crate::common;

use std::path::Path;

use crate::common::{stderr, stencil};

/// A gray PNG `w` x `h` of vertical stripes 50 px wide; with `garbage` its pixel data is not
/// deflate at all (a decoder refuses it, but the header is sound).
fn stripes(path: &Path, w: u32, h: u32, garbage: bool) {
    if garbage {
        let mut png = Vec::new();
        let mut chunk = |t: &[u8], d: &[u8]| {
            png.extend_from_slice(&(d.len() as u32).to_be_bytes());
            png.extend_from_slice(t);
            png.extend_from_slice(d);
            png.extend_from_slice(&crc(t, d).to_be_bytes());
        };
        let mut ihdr = Vec::new();
        ihdr.extend_from_slice(&w.to_be_bytes());
        ihdr.extend_from_slice(&h.to_be_bytes());
        ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
        chunk(b"IHDR", &ihdr);
        chunk(b"IDAT", b"not deflate data at all");
        chunk(b"IEND", b"");
        let mut file = b"\x89PNG\r\n\x1a\n".to_vec();
        file.extend_from_slice(&png);
        std::fs::write(path, file).unwrap();
        return;
    }
    let data: Vec<u8> = (0..h)
        .flat_map(|_| (0..w).map(|x| if (x / 50) % 2 == 0 { 0 } else { 255 }))
        .collect();
    common::write_gray_png(path, w, h, &data);
}

/// PNG's CRC-32 of a chunk's type and data.
fn crc(t: &[u8], d: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in t.iter().chain(d) {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xedb8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

fn report(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("report.json")).unwrap()).unwrap()
}

#[test]
fn a_picture_too_wide_for_the_bed_at_the_default_scale_is_scaled_down_and_says_so() {
    let tmp = tempfile::tempdir().unwrap();
    let pic = tmp.path().join("wide.png");
    // 4100 px at 0.1 mm per pixel: 410 mm, over the 400 mm bed of diode-400.
    stripes(&pic, 4100, 300, false);
    let out = tmp.path().join("out");
    let o = stencil(&[
        "make",
        pic.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--emit",
        "png,gcode",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let so = String::from_utf8_lossy(&o.stdout);
    assert!(
        so.contains("410.0 x 30.0 mm") && so.contains("scaled down to fit"),
        "{so}"
    );
    let r = report(&out);
    // The picture is the bed's 400 mm (the margin is not cut, so it does not count).
    let w = r["width_mm"].as_f64().unwrap();
    assert!((w - 400.0).abs() < 0.01, "{w}");
    // The job is on the bed: the G-code's moves stay within 0..400.
    let g = std::fs::read_to_string(out.join("stencil.gcode")).unwrap();
    let moves = stencil_gcode::interpret::interpret(&g).unwrap();
    let e = stencil_gcode::interpret::extent(&moves).unwrap();
    assert!(e.min[0] >= -1e-6 && e.max[0] <= 400.0 + 1e-6, "{:?}", e);
}

#[test]
fn a_size_that_cannot_fit_is_refused_from_the_header_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let pic = tmp.path().join("broken.png");
    // A sound header over pixel data no decoder reads: the refusal comes from the header.
    stripes(&pic, 4100, 300, true);
    let out = tmp.path().join("out");
    let o = stencil(&[
        "make",
        pic.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--emit",
        "png,gcode",
        "--width-mm",
        "395",
        "--cut-outline",
    ]);
    assert!(!o.status.success());
    let err = stderr(&o);
    for needle in [
        "broken.png",
        "395 x 28.9 mm",
        "5 mm margin",
        "bed of diode-400",
        "--width-mm 390 or less",
        "--margin-mm",
    ] {
        assert!(err.contains(needle), "{needle}: {err}");
    }
    assert!(!out.exists());
    // The margin counts only where something is cut: without --cut-outline, 395 mm fits (and
    // then the decoder finds the broken data).
    let o = stencil(&[
        "make",
        pic.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--emit",
        "png,gcode",
        "--width-mm",
        "395",
    ]);
    let err = stderr(&o);
    assert!(
        !o.status.success() && !err.contains("--width-mm 390"),
        "{err}"
    );
}

#[test]
fn a_sheet_of_stock_is_filled_turned_if_that_is_larger() {
    let tmp = tempfile::tempdir().unwrap();
    let pic = tmp.path().join("wide.png");
    stripes(&pic, 1500, 1000, false);
    let out = tmp.path().join("out");
    let o = stencil(&[
        "make",
        pic.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--sheet",
        "A4",
        "--emit",
        "png,svg",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let so = String::from_utf8_lossy(&o.stdout);
    assert!(so.contains("A4") && so.contains("turned sideways"), "{so}");
    // A4 turned: 297 x 210 mm; 5 mm margins leave 287 x 200, and a 3:2 picture is 287 wide
    // (191.3 tall).
    let r = report(&out);
    assert!(
        (r["width_mm"].as_f64().unwrap() - 287.0).abs() < 0.05,
        "{r}"
    );
    assert!(r["height_mm"].as_f64().unwrap() <= 200.0);
    let o = stencil(&["make", pic.to_str().unwrap(), "--sheet", "B7"]);
    assert!(!o.status.success() && stderr(&o).contains("A4, A3, LETTER or WxH"));
}
