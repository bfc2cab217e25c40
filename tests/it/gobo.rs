//! Gobos and photo-etch masks as shops want them (issue 28, item 2), judged on the files `make`
//! writes: the rim measured in the DXF and the G-code, the picture inscribed in (or cropped to)
//! the image area, the --invert warning, the masks' dpi, mirroring and polarity as the files
//! carry them, and the undercut compensation measured on a line of known width.

use std::path::Path;

use crate::common::{self, gcode_loops, ink_png, report, s, stderr, stencil, tmp};

/// A circle: centre and radius, mm.
type Circle = ([f64; 2], f64);

/// The CUT layer's vertices and the OUTLINE layer's circles of a DXF.
fn dxf_parts(path: &Path) -> (Vec<[f64; 2]>, Vec<Circle>) {
    let d = dxf::Drawing::load_file(path).unwrap();
    let (mut cut, mut circles) = (Vec::new(), Vec::new());
    for e in d.entities() {
        match &e.specific {
            dxf::entities::EntityType::LwPolyline(p) => {
                assert_eq!(e.common.layer, "CUT");
                cut.extend(p.vertices.iter().map(|v| [v.x, v.y]));
            }
            dxf::entities::EntityType::Circle(c) => {
                assert_eq!(e.common.layer, "OUTLINE");
                circles.push(([c.center.x, c.center.y], c.radius));
            }
            other => panic!("unexpected entity {other:?}"),
        }
    }
    (cut, circles)
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[test]
fn a_b_gobo_is_a_circle_of_86_mm_with_the_picture_inscribed_in_its_image_area() {
    let t = tmp();
    // 300 x 200 px, a dark square in each corner (touching the picture's corners).
    let input = t.path().join("corners.png");
    ink_png(&input, 300, 200, |x, y| {
        !(30..270).contains(&x) && !(30..170).contains(&y)
    });
    let out = t.path().join("b");
    let o = stencil(&[
        "make",
        s(&input),
        "-o",
        s(&out),
        "--gobo",
        "B",
        "--emit",
        "svg,dxf",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (cut, circles) = dxf_parts(&out.join("stencil.dxf"));
    // Rosco's B: 86 mm outside diameter, 64.5 mm image area.
    assert_eq!(circles.len(), 1, "one rim");
    let (c, r) = circles[0];
    assert!((r - 43.0).abs() < 1e-9, "rim radius {r}");
    // The picture's diagonal is the image area: its corners (where the squares are cut) lie on
    // the image area's circle, and nothing is cut outside it.
    let far = cut.iter().map(|&p| dist(p, c)).fold(0.0, f64::max);
    assert!(far <= 32.25 + 0.05, "cut {far} mm from the centre");
    assert!(
        far >= 32.25 - 0.3,
        "the picture fills the image area: {far}"
    );
    let r = report(&out);
    let g = &r["gobo"];
    assert_eq!(g["letter"], "B");
    assert_eq!(g["od_mm"], 86.0);
    assert_eq!(g["ia_mm"], 64.5);
    assert_eq!(g["placement"], "inscribed");
    assert!(g["table"].as_str().unwrap().contains("Rosco"));
    let p = &g["picture_mm"];
    let diag = p[0].as_f64().unwrap().hypot(p[1].as_f64().unwrap());
    assert!((diag - 64.5).abs() < 1e-6, "{diag}");
    assert!(g["polarity"]
        .as_str()
        .unwrap()
        .contains("light passes where it is cut"));
    let svg = std::fs::read_to_string(out.join("stencil.svg")).unwrap();
    assert!(
        svg.contains("<circle") && svg.contains("r=\"43\""),
        "{svg:.400}"
    );
}

/// Issue 43 item 3: a gobo's stencil.png and preview.png are its round sheet, as the SVG draws
/// it: the sheet's outline around the picture, the rim a ring of cut pixels on the SVG's rim
/// circle all the way round, metal between it and the image area, the picture inside that.
#[test]
fn a_gobos_pngs_show_its_round_sheet_and_rim_where_the_svg_has_them() {
    let t = tmp();
    let input = t.path().join("corners.png");
    ink_png(&input, 150, 100, |x, y| {
        !(15..135).contains(&x) && !(15..85).contains(&y)
    });
    let out = t.path().join("e");
    let o = stencil(&[
        "make",
        s(&input),
        "-o",
        s(&out),
        "--gobo",
        "E",
        "--emit",
        "png,svg",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mm = report(&out)["mm_per_px"].as_f64().unwrap();
    let svg = std::fs::read_to_string(out.join("stencil.svg")).unwrap();
    let attr = |tag: &str, name: &str| -> f64 {
        let t = &svg[svg.find(tag).unwrap_or_else(|| panic!("{tag}: {svg:.600}"))..];
        let v = t.split(&format!(" {name}=\"")).nth(1).unwrap();
        v.split('"').next().unwrap().parse().unwrap()
    };
    // The SVG's rim circle, and its sheet (the viewBox), in mm.
    let (cx, cy, r) = (
        attr("<circle", "cx"),
        attr("<circle", "cy"),
        attr("<circle", "r"),
    );
    assert_eq!(r, 18.75, "Rosco's E: 37.5 mm across");
    let vb: Vec<f64> = svg
        .split("viewBox=\"")
        .nth(1)
        .unwrap()
        .split('"')
        .next()
        .unwrap()
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    let png = common::read_bits(&out.join("stencil.png"));
    // The PNG covers the SVG's sheet (to a pixel on each side), the rim at its centre as in
    // the SVG.
    let (w, h) = (png.width as f64, png.height as f64);
    assert!(
        (w * mm - vb[2]).abs() <= 2.0 * mm && (h * mm - vb[3]).abs() <= 2.0 * mm,
        "{w} x {h} px at {mm} mm against the SVG's {vb:?}"
    );
    assert!((vb[0] + vb[2] / 2.0 - cx).abs() < 1e-6 && (vb[1] + vb[3] / 2.0 - cy).abs() < 1e-6);
    let (pcx, pcy, rp) = (w / 2.0, h / 2.0, r / mm);
    // Every cut pixel is the picture's (inside the image area, 14 mm) or the rim's (on the
    // circle, within its pixel and a half outside it); the rim goes all the way round.
    let mut around = [false; 360];
    let (mut picture, mut rim) = (0, 0);
    for y in 0..png.height {
        for x in 0..png.width {
            if png.get(x, y) {
                continue;
            }
            let (dx, dy) = (x as f64 + 0.5 - pcx, y as f64 + 0.5 - pcy);
            let d = dx.hypot(dy);
            if d <= 14.0 / mm + 1.0 {
                picture += 1;
            } else {
                assert!(
                    d >= rp - 1.0 && d <= rp + 2.5,
                    "cut pixel ({x}, {y}) {d} px from the centre, the rim at {rp}"
                );
                rim += 1;
                around[(dy.atan2(dx).to_degrees().rem_euclid(360.0) as usize).min(359)] = true;
            }
        }
    }
    assert!(
        picture > 100 && rim > 360,
        "{picture} picture, {rim} rim pixels"
    );
    assert!(
        around.iter().all(|&a| a),
        "the rim is cut all the way round"
    );
    // The preview: the same sheet, enlarged by a whole factor; the rim dark, the metal
    // between the rim and the image area light.
    let pre = image::open(out.join("preview.png")).unwrap().to_rgb8();
    let f = pre.width() / png.width;
    assert!(
        f >= 1 && pre.width() == f * png.width && pre.height() == f * png.height,
        "{}x{} preview of a {}x{} sheet",
        pre.width(),
        pre.height(),
        png.width,
        png.height
    );
    let at = |d: f64, a: f64| {
        let (x, y) = (pcx + d * a.cos(), pcy + d * a.sin());
        let p = pre
            .get_pixel((x * f as f64) as u32, (y * f as f64) as u32)
            .0;
        p.iter().map(|&c| c as u32).sum::<u32>()
    };
    for k in 0..36 {
        let a = k as f64 * std::f64::consts::TAU / 36.0;
        assert!(
            at(rp + 0.75, a) < 3 * 100,
            "the rim at {k}0 degrees is dark"
        );
        assert!(
            at((rp + 14.0 / mm) / 2.0, a) > 3 * 200,
            "metal at {k}0 degrees is light"
        );
    }
    // `stencil check` of the folder judges the picture as make did, not the disc the rim frees
    // (read as a sheet, the disc would float and the rim be a hole too thin).
    let c = stencil(&["check", s(&out)]);
    let said = String::from_utf8_lossy(&c.stdout).to_string();
    assert!(
        c.status.success() && said.contains("1 piece(s)"),
        "{said}{}",
        stderr(&c)
    );
}

#[test]
fn a_cropped_gobo_fills_its_image_area_and_keeps_metal_outside_it() {
    let t = tmp();
    // A dark band across the whole width of a 300 x 200 px picture.
    let input = t.path().join("band.png");
    ink_png(&input, 300, 200, |_, y| (90..110).contains(&y));
    let out = t.path().join("crop");
    let o = stencil(&[
        "make",
        s(&input),
        "-o",
        s(&out),
        "--gobo",
        "60,40",
        "--gobo-crop",
        "--emit",
        "dxf",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (cut, circles) = dxf_parts(&out.join("stencil.dxf"));
    let (c, r) = circles[0];
    assert!((r - 30.0).abs() < 1e-9);
    // The shorter side is the image area (40 mm), so the picture is 60 x 40 mm; the band is
    // cut off at the image area's circle.
    let g = &report(&out)["gobo"];
    assert_eq!(g["placement"], "cropped");
    assert!((g["picture_mm"][0].as_f64().unwrap() - 60.0).abs() < 1e-6);
    assert!((g["picture_mm"][1].as_f64().unwrap() - 40.0).abs() < 1e-6);
    let far = cut.iter().map(|&p| dist(p, c)).fold(0.0, f64::max);
    assert!((19.5..=20.05).contains(&far), "band cut to {far} mm");
}

#[test]
fn the_rim_is_the_last_loop_of_the_gcode_a_circle_outside_the_disc_by_half_the_kerf() {
    let t = tmp();
    let input = t.path().join("corners.png");
    ink_png(&input, 200, 200, |x, y| {
        (80..120).contains(&x) && (80..120).contains(&y)
    });
    let out = t.path().join("g");
    let o = stencil(&[
        "make",
        s(&input),
        "-o",
        s(&out),
        "--gobo",
        "M",
        "--emit",
        "gcode",
        "--machine",
        "diode-400",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let kerf = report(&out)["material_values"]["kerf_mm"]
        .as_f64()
        .unwrap_or(0.0);
    let text = std::fs::read_to_string(out.join("stencil.gcode")).unwrap();
    // The last loop, read back with its arcs (the rim is fitted with G2/G3 arcs) as dense
    // points: a circle all round, not a polygon of a few points.
    let rim = gcode_loops(&text)
        .into_iter()
        .rev()
        .find(|l| !l.moves.is_empty())
        .expect("a cut loop");
    assert!(rim.arcs >= 3, "the rim as arcs: {:?}", rim.moves);
    let last = rim.points;
    assert!(last.len() > 100, "{} points", last.len());
    // The centre: the middle of the loop's box.
    let mid = |k: usize| {
        let (lo, hi) = last.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| {
            (lo.min(p[k]), hi.max(p[k]))
        });
        (lo + hi) / 2.0
    };
    let c = [mid(0), mid(1)];
    // Rosco's M: 66 mm. G-code carries 3 decimals.
    let want = 33.0 + kerf / 2.0;
    for p in &last {
        let d = dist(*p, c);
        assert!((d - want).abs() < 0.01, "{d} vs {want}");
    }
    // All the way round: no gap between the points' angles about the centre wider than 3°
    // (arcs come back as dense points; a short stretch the fit joins by a line, within its
    // tolerance, as two or three of the polygon's 0.9° edges).
    let mut ang: Vec<f64> = last
        .iter()
        .map(|p| (p[1] - c[1]).atan2(p[0] - c[0]))
        .collect();
    ang.sort_by(f64::total_cmp);
    let gap = ang.windows(2).map(|w| w[1] - w[0]).fold(
        ang[0] + std::f64::consts::TAU - ang[ang.len() - 1],
        f64::max,
    );
    assert!(gap < 3f64.to_radians(), "a gap of {gap} rad");
}

#[test]
fn a_bright_subject_left_as_metal_warns_that_invert_was_probably_meant() {
    let t = tmp();
    // A small white disc on a black ground.
    let input = t.path().join("moon.png");
    ink_png(&input, 200, 200, |x, y| {
        (x as f64 - 99.5).hypot(y as f64 - 99.5) > 30.0
    });
    let out = t.path().join("plain");
    let o = stencil(&["make", s(&input), "-o", s(&out), "--gobo", "B"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("warning") && err.contains("--invert"), "{err}");
    let g = &report(&out)["gobo"];
    assert!(g["clear_pct"].as_f64().unwrap() > 50.0, "{g}");
    assert!(g["warning"].is_string());
    let out = t.path().join("inverted");
    let o = stencil(&["make", s(&input), "-o", s(&out), "--gobo", "B", "--invert"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("--invert"), "{}", stderr(&o));
    let g = &report(&out)["gobo"];
    assert!(g["clear_pct"].as_f64().unwrap() < 10.0, "{g}");
    assert!(g.get("warning").is_none());
}

/// A PNG's chunks: (type, body).
fn chunks(png: &[u8]) -> Vec<([u8; 4], Vec<u8>)> {
    let mut out = Vec::new();
    let mut i = 8;
    while i + 8 <= png.len() {
        let len = u32::from_be_bytes(png[i..i + 4].try_into().unwrap()) as usize;
        let kind: [u8; 4] = png[i + 4..i + 8].try_into().unwrap();
        out.push((kind, png[i + 8..i + 8 + len].to_vec()));
        i += 12 + len;
    }
    out
}

/// The mask's resolution (pHYs, pixels per metre, as dpi) and its tEXt Description.
fn dpi_and_description(path: &Path) -> (f64, String) {
    let png = std::fs::read(path).unwrap();
    let c = chunks(&png);
    let phys = &c.iter().find(|(k, _)| k == b"pHYs").unwrap().1;
    let ppm = u32::from_be_bytes(phys[0..4].try_into().unwrap());
    assert_eq!(phys[8], 1, "unit: metre");
    let text = &c.iter().find(|(k, _)| k == b"tEXt").unwrap().1;
    let text = String::from_utf8_lossy(text).to_string();
    assert!(text.starts_with("Description\0"), "{text}");
    (ppm as f64 * 0.0254, text)
}

/// Etched (white) pixels of a mask inside its left and right halves, away from the rim (within
/// `r_px` of the centre).
fn white_left_right(path: &Path, r_px: f64) -> (usize, usize) {
    let img = image::open(path).unwrap().to_luma8();
    let (cx, cy) = (img.width() as f64 / 2.0, img.height() as f64 / 2.0);
    let (mut l, mut r) = (0, 0);
    for (x, y, p) in img.enumerate_pixels() {
        let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
        if p.0[0] > 127 && dx.hypot(dy) < r_px {
            if dx < 0.0 {
                l += 1
            } else {
                r += 1
            }
        }
    }
    (l, r)
}

#[test]
fn a_gobo_mask_says_its_dpi_mirroring_and_polarity_in_the_file_and_is_mirrored_as_said() {
    let t = tmp();
    // One dark square in the picture's left half.
    let input = t.path().join("left.png");
    ink_png(&input, 200, 200, |x, y| {
        (30..70).contains(&x) && (80..120).contains(&y)
    });
    // The aluminium gobo profile mirrors its mask (film laid emulsion side down).
    let out = t.path().join("al");
    let o = stencil(&[
        "make",
        s(&input),
        "-o",
        s(&out),
        "--gobo",
        "E",
        "--material",
        "aluminium-gobo",
        "--emit",
        "mask",
        "--mask-dpi",
        "600",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (dpi, desc) = dpi_and_description(&out.join("mask.png"));
    assert!((dpi - 600.0).abs() < 0.01, "{dpi}");
    for needle in [
        "mirrored left-right",
        "600 dpi",
        "metal stays where the stencil is material; light passes where it is cut",
        "black where metal stays",
    ] {
        assert!(desc.contains(needle), "{needle}: {desc}");
    }
    let svg = std::fs::read_to_string(out.join("mask.svg")).unwrap();
    assert!(svg.contains("<desc>") && svg.contains("mirrored left-right"));
    // The sheet: the rim's 37.5 mm square and the 5 mm margin, at 600 dpi.
    let img = image::open(out.join("mask.png")).unwrap().to_luma8();
    let side = (47.5f64 / 25.4 * 600.0).round() as u32;
    assert_eq!((img.width(), img.height()), (side, side));
    // Inside the image area (14 mm, 331 px at 600 dpi), the square etched is on the right.
    let ia_px = 14.0 / 25.4 * 600.0;
    let (l, r) = white_left_right(&out.join("mask.png"), ia_px);
    assert!(l == 0 && r > 1000, "mirrored: left {l}, right {r}");
    let m = &report(&out)["mask"];
    assert_eq!(m["masks"][0]["mirrored"], true);
    assert_eq!(m["dpi"], 600.0);
    // The rim's groove is etched outside the disc (1.5 × 0.5 mm wide, its mask 0.333 mm
    // narrower on each side for the undercut): etched in its middle, metal inside the rim and
    // beyond the groove.
    let px = |mm: f64| mm / 25.4 * 600.0;
    let c = side as f64 / 2.0;
    let at = |rad: f64| img.get_pixel((c + px(rad)) as u32, side / 2).0[0];
    assert_eq!(at(18.75 - 0.1), 0, "metal inside the rim");
    assert_eq!(at(18.75 + 0.375), 255, "the groove outside it");
    assert_eq!(at(18.75 + 0.75 + 0.1), 0, "metal beyond the groove");

    // The same picture on cardstock (no etch, no mirroring): right-reading, the square on the
    // left.
    let out = t.path().join("card");
    let o = stencil(&[
        "make",
        s(&input),
        "-o",
        s(&out),
        "--gobo",
        "E",
        "--emit",
        "mask",
        "--mask-dpi",
        "600",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (_, desc) = dpi_and_description(&out.join("mask.png"));
    assert!(desc.contains("right-reading"), "{desc}");
    let (l, r) = white_left_right(&out.join("mask.png"), ia_px);
    assert!(r == 0 && l > 1000, "right-reading: left {l}, right {r}");
}

/// Etched (white) runs along a mask's middle row, mm, and where each starts (mm from the left).
fn runs_mm(path: &Path, dpi: f64) -> Vec<(f64, f64)> {
    let img = image::open(path).unwrap().to_luma8();
    let y = img.height() / 2;
    let mm = 25.4 / dpi;
    let (mut runs, mut start) = (Vec::new(), None);
    for x in 0..=img.width() {
        let white = x < img.width() && img.get_pixel(x, y).0[0] > 127;
        match (white, start) {
            (true, None) => start = Some(x),
            (false, Some(s0)) => {
                runs.push((s0 as f64 * mm, (x - s0) as f64 * mm));
                start = None;
            }
            _ => {}
        }
    }
    runs
}

#[test]
fn two_sided_masks_are_narrower_by_the_undercut_on_a_line_of_known_width_and_register() {
    let t = tmp();
    // A 2.0 mm slot: 20 px at 0.1 mm per pixel (400 px = 40 mm).
    let input = t.path().join("slot.png");
    ink_png(&input, 400, 300, |x, y| {
        (190..210).contains(&x) && (50..250).contains(&y)
    });
    let out = t.path().join("brass");
    let o = stencil(&[
        "make",
        s(&input),
        "-o",
        s(&out),
        "--material",
        "brass-0.3-etch",
        "--width-mm",
        "40",
        "--emit",
        "mask",
        "--mask-dpi",
        "2540",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let m = &report(&out)["mask"];
    // 0.3 mm brass etched from both sides (0.15 mm each) at etch factor 2.5: 0.06 mm undercut.
    assert!((m["undercut_compensation_mm"].as_f64().unwrap() - 0.06).abs() < 1e-9);
    let front = runs_mm(&out.join("mask-front.png"), 2540.0);
    let back = runs_mm(&out.join("mask-back.png"), 2540.0);
    assert_eq!((front.len(), back.len()), (1, 1), "{front:?} {back:?}");
    // 2.0 mm less 2 × 0.06 mm; the traced edge sits within a quarter of a picture pixel.
    assert!((front[0].1 - 1.88).abs() <= 0.03, "{front:?}");
    assert!((back[0].1 - front[0].1).abs() <= 0.011);
    // Registered: the back's slot is the front's mirrored about the sheet's middle (the sheet is
    // 40 + 2 × 5 mm wide).
    let (f_mid, b_mid) = (front[0].0 + front[0].1 / 2.0, back[0].0 + back[0].1 / 2.0);
    assert!((f_mid + b_mid - 50.0).abs() <= 0.011, "{f_mid} {b_mid}");
    assert!(
        (f_mid - 25.0).abs() <= 0.03,
        "the slot is in the middle: {f_mid}"
    );
}

#[test]
fn an_etched_material_is_judged_at_the_narrowest_opening_its_mask_can_etch() {
    let t = tmp();
    let input = t.path().join("slot.png");
    ink_png(&input, 400, 300, |x, y| {
        (190..210).contains(&x) && (50..250).contains(&y)
    });
    let out = t.path().join("al");
    let o = stencil(&[
        "make",
        s(&input),
        "-o",
        s(&out),
        "--material",
        "aluminium-gobo",
        "--width-mm",
        "40",
        "--emit",
        "mask",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // 0.5 mm aluminium from one side at etch factor 1.5: 0.333 mm undercut; the profile's
    // 0.55 mm smallest feature would be closed by the mask's compensation (0.667 mm), so
    // webs and holes are made at least 0.667 + 0.05 mm.
    let so = String::from_utf8_lossy(&o.stdout);
    assert!(so.contains("at least 0.717 mm"), "{so}");
    let r = report(&out);
    assert_eq!(r["material_values"]["min_feature_mm"], 0.717);
    assert_eq!(r["mask"]["openings_closed"], 0);
}

#[test]
fn gobo_sizes_and_conflicts_are_refused_with_the_option_named() {
    let t = tmp();
    let rings = common::samples().join("rings.png");
    let out = t.path().join("x");
    for (args, needle) in [
        (vec!["--gobo", "Q"], "A, B, M, E"),
        (vec!["--gobo", "40,50"], "smaller than the outside diameter"),
        (vec!["--gobo", "B", "--width-mm", "30"], "--width-mm"),
        (vec!["--gobo-crop"], "--gobo"),
    ] {
        let mut a = vec!["make", s(&rings), "-o", s(&out)];
        a.extend(args.iter().copied());
        let o = stencil(&a);
        assert!(!o.status.success(), "{args:?}");
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
        assert!(!out.exists(), "nothing written for {args:?}");
    }
}

/// Issue 39, item 4: a gobo too small for the picture's pixels is refused in the words of
/// --gobo (the option that sized it), with the image areas that work; never with advice about
/// --width-mm, which --gobo excludes. The image area advised is past the bound it names.
#[test]
fn a_gobo_too_small_for_its_picture_is_refused_with_gobo_advice() {
    let t = tmp();
    let rings = common::samples().join("rings.png");
    let out = t.path().join("x");
    let least = |err: &str| -> f64 {
        let rest = err
            .split("an image area IA of at least ")
            .nth(1)
            .unwrap_or_else(|| panic!("no image area advised: {err}"));
        rest.split(' ').next().unwrap().parse().unwrap()
    };
    for (gobo, crop, bound) in [
        // Pixels under a micron.
        ("0.001,0.0005", false, "pixels must be at least 0.001 mm"),
        ("0.001,0.0005", true, "pixels must be at least 0.001 mm"),
        // Pixels too fine for the material's smallest feature.
        ("1,0.5", false, "smallest feature"),
    ] {
        let mut a = vec!["make", s(&rings), "-o", s(&out), "--gobo", gobo];
        if crop {
            a.push("--gobo-crop");
        }
        let o = stencil(&a);
        let err = stderr(&o);
        assert!(!o.status.success(), "{gobo}: {err}");
        assert!(
            err.contains(&format!("--gobo {gobo}")) && err.contains(bound),
            "{gobo}: {err}"
        );
        assert!(
            !err.contains("--width-mm"),
            "{gobo}: advice names --width-mm: {err}"
        );
        let ia = least(&err);
        assert!(ia > 0.0005 && ia < 1000.0, "{gobo}: {ia}");
        // The image area advised clears the bound that was broken.
        let advised = format!("{},{}", ia * 2.0, ia);
        let mut a = vec!["make", s(&rings), "-o", s(&out), "--gobo", &advised];
        if crop {
            a.push("--gobo-crop");
        }
        let o = stencil(&a);
        assert!(
            !stderr(&o).contains(bound),
            "{gobo} -> {advised}: {}",
            stderr(&o)
        );
        // Whatever it says next (another bound, or a warning that much changed), it never
        // advises an option --gobo excludes.
        assert!(
            !stderr(&o).contains("--width-mm"),
            "{gobo} -> {advised}: {}",
            stderr(&o)
        );
    }
}
