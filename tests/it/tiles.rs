//! Tiles, checked on the files `make` writes: every tile a valid sheet that fits the stock, the
//! seams through no feature thinner than the material's smallest, and the tiles put back at their
//! places painting what the untiled stencil paints outside the overlaps (counted in pixels), for
//! a picture and a mesh; `check` on the tiled folder; bad tile options refused by name.

use std::path::Path;

use stencil_core::raster::BitGrid;

use crate::common::*;

/// A seam's path from the report's corner points: the across position at every step along.
fn seam_path(s: &serde_json::Value, len: u32) -> (bool, Vec<i64>) {
    let vertical = s["axis"] == "vertical";
    let pts: Vec<(i64, i64)> = s["points_px"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let (x, y) = (p[0].as_i64().unwrap(), p[1].as_i64().unwrap());
            if vertical {
                (y, x)
            } else {
                (x, y)
            }
        })
        .collect();
    let mut path = vec![0i64; len as usize];
    for w in pts.windows(2) {
        let ((s0, a0), (s1, a1)) = (w[0], w[1]);
        for s in s0..=s1 {
            let t = if s1 == s0 {
                0.0
            } else {
                (s - s0) as f64 / (s1 - s0) as f64
            };
            path[s as usize] = a0 + ((a1 - a0) as f64 * t).round() as i64;
        }
    }
    (vertical, path)
}

/// What the tiles paint, put back at their places, against the untiled stencil: pixels compared
/// (outside the overlaps: farther than the overlap plus a pixel from every seam), of those the
/// ones where the two differ, and of those the ones that are no bridge of either (neither
/// stencil has a bridge there: the pixels the bridges do not explain).
fn reassembly(tiled: &Path, untiled: &Path) -> (usize, usize, usize) {
    let r = report(tiled);
    let whole = read_bits(&untiled.join("stencil.png"));
    let whole_two = read_bits(&untiled.join("twotone.png"));
    let (w, h) = (
        r["size_px"][0].as_u64().unwrap() as u32,
        r["size_px"][1].as_u64().unwrap() as u32,
    );
    // The tiles' grid is the picture's grown by the marks' band on every side.
    let band = r["marks_band_px"].as_u64().unwrap() as u32;
    assert_eq!(
        (whole.width + 2 * band, whole.height + 2 * band),
        (w, h),
        "the same working grid"
    );
    let ov =
        (r["overlap_mm"].as_f64().unwrap() / r["mm_per_px"].as_f64().unwrap()).ceil() as i64 + 1;
    let seams: Vec<(bool, Vec<i64>)> = r["seams"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            let len = if s["axis"] == "vertical" { h } else { w };
            seam_path(s, len)
        })
        .collect();
    let tiles: Vec<(u32, u32, [u32; 4], BitGrid, BitGrid)> = r["tiles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            let b = &t["box_px"];
            let bx = [0, 1, 2, 3].map(|i| b[i].as_u64().unwrap() as u32);
            let dir = tiled.join(t["folder"].as_str().unwrap());
            let bits = read_bits(&dir.join("stencil.png"));
            assert_eq!((bits.width, bits.height), (bx[2], bx[3]), "{}", t["folder"]);
            (
                t["row"].as_u64().unwrap() as u32 - 1,
                t["col"].as_u64().unwrap() as u32 - 1,
                bx,
                bits,
                read_bits(&dir.join("twotone.png")),
            )
        })
        .collect();
    let (mut compared, mut differ, mut unexplained) = (0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let (mut col, mut row, mut near) = (0, 0, false);
            for (vertical, p) in &seams {
                let (along, across) = if *vertical { (y, x) } else { (x, y) };
                let at = p[along as usize];
                near |= (across as i64 - at).abs() <= ov;
                if across as i64 >= at {
                    if *vertical {
                        col += 1
                    } else {
                        row += 1
                    }
                }
            }
            let in_picture = x >= band && y >= band && x < w - band && y < h - band;
            if near || !in_picture {
                continue;
            }
            let (px, py) = (x - band, y - band);
            let (_, _, [x0, y0, _, _], bits, two) = tiles
                .iter()
                .find(|t| t.0 == row && t.1 == col)
                .expect("a tile for every pixel");
            compared += 1;
            let (tx, ty) = (x - x0, y - y0);
            if bits.get(tx, ty) != whole.get(px, py) {
                differ += 1;
                // A bridge: cut in a two-tone, material in its stencil.
                let bridge = (!two.get(tx, ty) && bits.get(tx, ty))
                    || (!whole_two.get(px, py) && whole.get(px, py));
                if !bridge {
                    unexplained += 1;
                }
            }
        }
    }
    (compared, differ, unexplained)
}

/// Every tile one valid sheet that fits the stock and passed the check, with its own files.
fn assert_tiles_valid(out: &Path, stock: Option<[f64; 2]>) {
    let r = report(out);
    let tiles = r["tiles"].as_array().unwrap();
    let [c, rows] = [0, 1].map(|i| r["grid"][i].as_u64().unwrap() as usize);
    assert_eq!(tiles.len(), c * rows);
    for (i, t) in tiles.iter().enumerate() {
        assert_eq!(
            t["number"].as_u64().unwrap() as usize,
            i + 1,
            "cutting order"
        );
        let dir = out.join(t["folder"].as_str().unwrap());
        assert_valid_stencil(&dir);
        let tr = report(&dir);
        assert_eq!(tr["check"]["pieces"], 1, "{}", dir.display());
        assert!(
            tr["check"]["violations"].as_array().unwrap().is_empty(),
            "{}",
            dir.display()
        );
        assert!(dir.join("stencil.svg").is_file());
        if let Some([sw, sh]) = stock {
            let [tw, th] = [0, 1].map(|k| t["sheet_mm"][k].as_f64().unwrap());
            assert!(
                tw <= sw + 1e-6 && th <= sh + 1e-6,
                "{tw} x {th} on {sw} x {sh}"
            );
        }
    }
    for s in r["seams"].as_array().unwrap() {
        assert_eq!(s["through_thin_mm"].as_f64().unwrap(), 0.0, "{s}");
    }
    assert_seams_registered(out);
    assert!(out.join("tiles.png").is_file());
}

/// Every seam registered: two pin holes or more on each pair of tiles it parts, each cut through
/// both tiles' stencils (every layer's) at the same place on the wall. Returns the marks' places
/// (`clear`, `band`, `pad`) counted.
fn assert_seams_registered(out: &Path) -> std::collections::BTreeMap<String, usize> {
    let r = report(out);
    let mm = r["mm_per_px"].as_f64().unwrap();
    let tiles = r["tiles"].as_array().unwrap();
    let [cols, rows] = [0, 1].map(|i| r["grid"][i].as_u64().unwrap() as usize);
    let mut places = std::collections::BTreeMap::new();
    for s in r["seams"].as_array().unwrap() {
        assert_eq!(s["unregistered_segments"], 0, "{s}");
        let vertical = s["axis"] == "vertical";
        let marks = s["marks"].as_array().unwrap();
        for seg in 1..=(if vertical { rows } else { cols }) {
            let n = marks.iter().filter(|m| m["segment"] == seg).count();
            assert!(n >= 2, "segment {seg} of {s} has {n} marks");
        }
        for m in marks {
            *places
                .entry(m["place"].as_str().unwrap().to_string())
                .or_insert(0) += 1;
            let [x, y] = [0, 1].map(|k| m["at_mm"][k].as_f64().unwrap());
            // Every tile whose pins list it cuts it, in every stencil it has; two tiles do.
            let mut carried = 0;
            for t in tiles {
                let (tx, ty) = (
                    x - t["x_mm"].as_f64().unwrap(),
                    y - t["y_mm"].as_f64().unwrap(),
                );
                let has = t["pins_mm"].as_array().unwrap().iter().any(|p| {
                    (p[0].as_f64().unwrap() - tx).abs() < 1e-6
                        && (p[1].as_f64().unwrap() - ty).abs() < 1e-6
                });
                if !has {
                    continue;
                }
                carried += 1;
                let layers = t["layers"].as_array().unwrap();
                let dirs: Vec<String> = if layers.is_empty() {
                    vec![t["folder"].as_str().unwrap().to_string()]
                } else {
                    layers
                        .iter()
                        .map(|l| l["folder"].as_str().unwrap().to_string())
                        .collect()
                };
                for d in dirs {
                    let bits = read_bits(&out.join(&d).join("stencil.png"));
                    let (px, py) = ((tx / mm) as u32, (ty / mm) as u32);
                    assert!(!bits.get(px, py), "{d}: no pin hole at {tx:.1}, {ty:.1} mm");
                    // A hole, not the window: material a pin's width away along the seam.
                    let r = (r["pin_mm"].as_f64().unwrap() / 2.0 / mm) as u32 + 2;
                    let ring = if vertical {
                        [(px, py + r), (px, py.saturating_sub(r))]
                    } else {
                        [(px + r, py), (px.saturating_sub(r), py)]
                    };
                    assert!(
                        ring.iter().any(|&(a, b)| bits.get(a, b)),
                        "{d}: the pin at {tx:.1}, {ty:.1} mm is in no material"
                    );
                }
            }
            assert!(carried >= 2, "mark {m} on {carried} tile(s)");
        }
    }
    places
}

/// Rings and bars across where straight seams would fall: islands to bridge on both sides.
fn rings_picture(path: &Path) {
    ink_png(path, 240, 160, |x, y| {
        let (fx, fy) = (x as f64, y as f64);
        let ring = |cx: f64, cy: f64, r0: f64, r1: f64| {
            let d = ((fx - cx).powi(2) + (fy - cy).powi(2)).sqrt();
            d >= r0 && d <= r1
        };
        ring(60.0, 50.0, 20.0, 30.0)
            || ring(125.0, 80.0, 22.0, 34.0)
            || ring(190.0, 110.0, 15.0, 24.0)
            || ((70..76).contains(&y) && (10..230).contains(&x))
            || ((150..156).contains(&x) && (20..140).contains(&y))
    });
}

#[test]
fn tiles_fit_the_sheet_and_put_back_paint_the_untiled_stencil() {
    let d = tmp();
    let pic = d.path().join("rings.png");
    rings_picture(&pic);
    let (un, ti) = (d.path().join("untiled"), d.path().join("tiled"));
    let o = stencil(&["make", s(&pic), "--width-mm", "240", "-o", s(&un)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = stencil(&[
        "make",
        s(&pic),
        "--width-mm",
        "240",
        "--tiles",
        "auto",
        "--sheet",
        "160x130",
        "-o",
        s(&ti),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&ti);
    // 240 x 160 mm and the marks' band on 160 x 130 mm: two across, two down.
    assert_eq!(r["grid"], serde_json::json!([2, 2]));
    assert_tiles_valid(&ti, Some([160.0, 130.0]));
    let (compared, differ, unexplained) = reassembly(&ti, &un);
    let pct = 100.0 * differ as f64 / compared as f64;
    println!(
        "picture: {differ} of {compared} px differ outside the overlaps ({pct:.3} %), {unexplained} not at a bridge"
    );
    assert!(
        unexplained * 1000 < compared,
        "{unexplained} px differ not at a bridge"
    );
    assert!(compared > 1_000_000, "{compared}");
    // Only where a tile bridges an island the whole stencil bridged elsewhere.
    assert!(pct < 0.5, "{differ} of {compared} px differ ({pct:.3} %)");
    // Pins: on both tiles of a seam, at the same place in the whole picture.
    let mut places: Vec<(i64, i64)> = Vec::new();
    for t in r["tiles"].as_array().unwrap() {
        for p in t["pins_mm"].as_array().unwrap() {
            let at = |k: usize, o: &str| {
                ((p[k].as_f64().unwrap() + t[o].as_f64().unwrap()) * 10.0).round() as i64
            };
            places.push((at(0, "x_mm"), at(1, "y_mm")));
        }
    }
    places.sort();
    assert!(!places.is_empty());
    for p in &places {
        assert!(
            places.iter().filter(|q| *q == p).count() >= 2,
            "pin {p:?} on one tile only"
        );
    }
    // `check` goes through the tiles.
    let o = stencil(&["check", s(&ti)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert_eq!(text.matches("== ").count(), 4, "{text}");
    // A run without tiles into the folder leaves none of them behind.
    let o = stencil(&["make", s(&pic), "--width-mm", "240", "-o", s(&ti)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!ti.join("tile-1-1").exists() && !ti.join("tiles.png").exists());
}

#[test]
fn a_mesh_in_tiles_puts_back_as_its_untiled_stencil() {
    let d = tmp();
    let mesh = samples().join("torus.obj");
    let (un, ti) = (d.path().join("untiled"), d.path().join("tiled"));
    let o = stencil(&["make", s(&mesh), "-o", s(&un)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = stencil(&["make", s(&mesh), "--tiles", "2x1", "-o", s(&ti)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_tiles_valid(&ti, None);
    let (compared, differ, unexplained) = reassembly(&ti, &un);
    let pct = 100.0 * differ as f64 / compared as f64;
    println!(
        "mesh: {differ} of {compared} px differ outside the overlaps ({pct:.3} %), {unexplained} not at a bridge"
    );
    assert!(
        unexplained * 1000 < compared,
        "{unexplained} px differ not at a bridge"
    );
    assert!(compared > 100_000, "{compared}");
    assert!(pct < 0.5, "{differ} of {compared} px differ ({pct:.3} %)");
}

#[test]
fn bad_tile_options_are_refused_by_name() {
    let d = tmp();
    let pic = d.path().join("rings.png");
    rings_picture(&pic);
    let out = d.path().join("o");
    // Seams given that do not match the grid.
    let o = stencil(&[
        "make",
        s(&pic),
        "--tiles",
        "3x1",
        "--seam-x",
        "100",
        "-o",
        s(&out),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--seam-x"), "{}", stderr(&o));
    // Tiles that cannot fit: a sheet smaller than the margins and overlaps need.
    let o = stencil(&[
        "make",
        s(&pic),
        "--width-mm",
        "240",
        "--tiles",
        "2x1",
        "--sheet",
        "100x100",
        "-o",
        s(&out),
    ]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("tile 1-1") && e.contains("--tiles auto"), "{e}");
    assert!(!out.exists(), "nothing written");
    let o = stencil(&["make", s(&pic), "--tiles", "two", "-o", s(&out)]);
    assert!(stderr(&o).contains("CxR"), "{}", stderr(&o));
}

/// A dark area all along a seam: where the picture gives no clear place, the seam's marks sit in
/// the band around the picture and on pads, and still every pair of tiles gets two, each cut
/// through both tiles.
#[test]
fn every_seam_is_registered_even_through_the_dark() {
    let d = tmp();
    let pic = d.path().join("dark.png");
    // A dark band down the middle (where the vertical seam must run), light elsewhere, with a
    // few light rings so neither half is plain.
    ink_png(&pic, 160, 120, |x, y| {
        let (fx, fy) = (x as f64, y as f64);
        let ring = ((fx - 20.0).powi(2) + (fy - 30.0).powi(2)).sqrt();
        (55..105).contains(&x) || (8.0..12.0).contains(&ring)
    });
    let out = d.path().join("o");
    let o = stencil(&[
        "make",
        s(&pic),
        "--width-mm",
        "160",
        "--tiles",
        "2x2",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_tiles_valid(&out, None);
    let places = assert_seams_registered(&out);
    println!("marks: {places:?}");
    assert!(places.get("pad").copied().unwrap_or(0) >= 2, "{places:?}");
    assert!(places.get("band").copied().unwrap_or(0) >= 4, "{places:?}");
    assert!(places.get("clear").copied().unwrap_or(0) >= 2, "{places:?}");
    // Where the horizontal seam crosses the dark band, the tiles on the wall together leave
    // unpainted only the earlier tile's strip (the later one's overlap gives way to the dark):
    // one overlap wide, not two. A pixel is painted when no tile over it has material there.
    let r = report(&out);
    let mm = r["mm_per_px"].as_f64().unwrap();
    let ov = (r["overlap_mm"].as_f64().unwrap() / mm).round() as i64;
    let band = r["marks_band_px"].as_i64().unwrap();
    let tiles: Vec<([i64; 4], BitGrid)> = r["tiles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            let b = [0, 1, 2, 3].map(|i| t["box_px"][i].as_i64().unwrap());
            let dir = out.join(t["folder"].as_str().unwrap());
            (b, read_bits(&dir.join("stencil.png")))
        })
        .collect();
    let blocked = |x: i64, y: i64| {
        tiles.iter().any(|([x0, y0, w, h], bits)| {
            x >= *x0
                && y >= *y0
                && x < x0 + w
                && y < y0 + h
                && bits.get((x - x0) as u32, (y - y0) as u32)
        })
    };
    let seam = r["seams"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["axis"] == "horizontal")
        .unwrap();
    let (_, path) = seam_path(seam, r["size_px"][0].as_u64().unwrap() as u32);
    let px = |mm_in_picture: f64| band + (mm_in_picture / mm) as i64;
    let mut widths = Vec::new();
    // The dark band is 55..105 mm across; its middle, clear of its edges and the other seam.
    for x in (px(62.0)..px(98.0)).step_by(3) {
        let at = path[x as usize];
        let w = (at - 3 * ov..at + 3 * ov)
            .filter(|&y| blocked(x, y))
            .count() as i64;
        widths.push(w);
    }
    widths.sort();
    let median = widths[widths.len() / 2];
    println!("unpainted across the seam in the dark: {median} px (overlap {ov} px)");
    assert!(median <= ov + 2, "{widths:?}, overlap {ov} px");
}

/// The numbers of a large run made by hand (`TILED` and `UNTILED` name its two folders): not
/// run by default. `cargo test --test it tiles::measure -- --ignored --nocapture`.
#[test]
#[ignore]
fn measure() {
    let (Ok(t), Ok(u)) = (std::env::var("TILED"), std::env::var("UNTILED")) else {
        return;
    };
    let (compared, differ, unexplained) = reassembly(Path::new(&t), Path::new(&u));
    println!(
        "{differ} of {compared} px differ outside the overlaps ({:.3} %), {unexplained} not at a bridge",
        100.0 * differ as f64 / compared as f64
    );
}

#[test]
fn layers_in_tiles_share_the_seams_and_the_pins() {
    let d = tmp();
    let pic = d.path().join("steps.png");
    // Three grays and white in bands that cross where the seam falls.
    smooth_png(&pic, 200, 120, |x, y| {
        let r = ((x - 100.0).powi(2) + (y - 60.0).powi(2)).sqrt();
        match r as u32 {
            0..=14 => 0.05,
            15..=29 => 0.4,
            30..=44 => 0.7,
            _ => 1.0,
        }
    });
    let out = d.path().join("o");
    let o = stencil(&[
        "make",
        s(&pic),
        "--width-mm",
        "200",
        "--tiles",
        "2x1",
        "--layers",
        "3",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&out);
    let tiles = r["tiles"].as_array().unwrap();
    assert_eq!(tiles.len(), 2);
    let mm = r["mm_per_px"].as_f64().unwrap();
    for t in tiles {
        let layers = t["layers"].as_array().unwrap();
        assert_eq!(layers.len(), 3, "{t}");
        let pins = t["pins_mm"].as_array().unwrap();
        assert!(!pins.is_empty(), "{t}");
        let mut sizes = Vec::new();
        for l in layers {
            let dir = out.join(l["folder"].as_str().unwrap());
            assert_valid_stencil(&dir);
            assert_eq!(report(&dir)["check"]["pieces"], 1);
            let bits = read_bits(&dir.join("stencil.png"));
            sizes.push((bits.width, bits.height));
            // Every layer has the tile's pin holes, at the same place.
            for p in pins {
                let (x, y) = (p[0].as_f64().unwrap() / mm, p[1].as_f64().unwrap() / mm);
                assert!(
                    !bits.get(x as u32, y as u32),
                    "{}: no pin at {p}",
                    dir.display()
                );
            }
        }
        assert!(sizes.windows(2).all(|w| w[0] == w[1]), "{sizes:?}");
    }
    assert_seams_registered(&out);
    let o = stencil(&["check", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(String::from_utf8_lossy(&o.stdout).matches("== ").count(), 6);
}

/// `send` and `frame` take a tile's G-code as any stencil's: each tile's job streams to the
/// virtual Grbl whole with the laser off at the end, and its frame is its own tile's outline
/// (the second tile's job is narrower: it starts at its seam).
#[test]
fn send_and_frame_take_a_tiles_gcode() {
    let d = tmp();
    let out = d.path().join("tiled");
    let rings = samples().join("rings.png");
    let o = stencil(&[
        "make",
        s(&rings),
        "--tiles",
        "2x1",
        "--machine",
        "diode-400",
        "--emit",
        "gcode",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut widths = Vec::new();
    for t in ["tile-1-1", "tile-1-2"] {
        let job = out.join(t).join("stencil.gcode");
        // Every line but the blank ones and the comments is sent.
        let text = std::fs::read_to_string(&job).unwrap();
        let lines = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with(';') && !l.starts_with('('))
            .count();
        let o = stencil(&["send", s(&job), "--dry-run"]);
        assert!(o.status.success(), "{t}: {}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(text.contains(&format!("sent {lines} lines")), "{t}: {text}");
        assert!(
            text.contains("laser off") && text.contains("alarms: none"),
            "{text}"
        );
        let o = stencil(&["frame", s(&job), "--dry-run"]);
        assert!(o.status.success(), "{t}: {}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(text.contains("laser off at the end"), "{text}");
        // "the job cuts within X a..b Y ...": the tile's width.
        let x: Vec<f64> = text
            .split_once("cuts within X ")
            .and_then(|(_, r)| r.split_once(' '))
            .map(|(x, _)| x.split("..").filter_map(|v| v.parse().ok()).collect())
            .unwrap_or_default();
        assert_eq!(x.len(), 2, "no frame: {text}");
        let w = x[1] - x[0];
        // Within the tile's sheet (its cuts reach the margin on the seam's side: see
        // a_tile_comes_off_the_machine_ready_to_tape).
        let r = report(&out);
        let tile = r["tiles"]
            .as_array()
            .unwrap()
            .iter()
            .find(|x| x["folder"] == t);
        let sheet = tile.unwrap()["sheet_mm"][0].as_f64().unwrap();
        assert!(
            w > 5.0 && w <= sheet + 1e-6,
            "{t}: frame {w} mm, tile {sheet} mm"
        );
        widths.push(w);
    }
    assert!(widths[1] < widths[0], "{widths:?}");
}

/// A colour picture in layers and tiles: its layers are the untiled set's (the same colours and
/// levels, from the colours' clusters), and in every tile a darker layer's cut lies inside the
/// lighter one's (the set's nesting), every layer carrying the tile's marks.
#[test]
fn tiled_layers_are_the_untiled_sets_colours_and_nest() {
    let d = tmp();
    let pic = d.path().join("colour.png");
    let img = image::RgbImage::from_fn(160, 100, |x, y| {
        let (fx, fy) = (x as f64, y as f64);
        let r = ((fx - 80.0).powi(2) + (fy - 50.0).powi(2)).sqrt();
        if r < 14.0 {
            image::Rgb([30, 20, 90])
        } else if r < 30.0 {
            image::Rgb([200, 40, 40])
        } else if (20..40).contains(&y) || (120..140).contains(&x) {
            image::Rgb([60, 160, 70])
        } else {
            image::Rgb([250, 240, 200])
        }
    });
    img.save(&pic).unwrap();
    let (un, ti) = (d.path().join("untiled"), d.path().join("tiled"));
    // Cropped: the layers start from the adjusted picture, tiled or not.
    let base = [
        "make",
        s(&pic),
        "--width-mm",
        "160",
        "--crop",
        "0,10,160,80",
        "--layers",
        "3",
    ];
    let o = stencil(&[&base[..], &["-o", s(&un)]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let o = stencil(&[&base[..], &["--tiles", "2x1", "-o", s(&ti)]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let u = report(&un);
    assert_ne!(u["method"], "gray", "{}", u["method"]);
    let t = report(&ti);
    assert_eq!(t["surface_color"], u["surface_color"]);
    let ul = report(&un.join("layer-1"));
    let band = t["marks_band_mm"].as_f64().unwrap();
    for (k, want) in [(0, 160.0), (1, 80.0)] {
        let key = ["width_mm", "height_mm"][k];
        let untiled = ul[key].as_f64().unwrap() - 2.0 * u["marks"]["band_mm"].as_f64().unwrap();
        assert!((untiled - want).abs() < 1.5, "untiled {key}: {untiled}");
        let tiled = t[key].as_f64().unwrap() - 2.0 * band;
        assert!((tiled - want).abs() < 1.5, "tiled {key}: {tiled}");
    }
    for tile in t["tiles"].as_array().unwrap() {
        let layers = tile["layers"].as_array().unwrap();
        assert_eq!(layers.len(), 3);
        for (tl, ul) in layers.iter().zip(u["layers"].as_array().unwrap()) {
            assert_eq!(tl["color"], ul["color"], "{tile}");
            assert_eq!(tl["level"], ul["level"], "{tile}");
        }
        // Nesting: no pixel a darker layer's two-tone cuts that a lighter one's keeps.
        let two: Vec<_> = layers
            .iter()
            .map(|l| read_bits(&ti.join(l["folder"].as_str().unwrap()).join("twotone.png")))
            .collect();
        for k in 0..2 {
            let breaks = (two[k].data.iter().zip(&two[k + 1].data))
                .filter(|&(&lighter, &darker)| lighter && !darker)
                .count();
            assert_eq!(
                breaks,
                0,
                "{}: layer {} and {}",
                tile["folder"],
                k + 1,
                k + 2
            );
        }
    }
    assert_seams_registered(&ti);
}

/// `--fill-in` and `--mask-marks` with `--tiles`: each tile gets its fill-in stencil (cutting
/// what its bridges hide) in `tile-R-C/fill-in/`, a valid sheet `check` goes through; with mask
/// marks, the tiles carry the registration marks they always carry.
#[test]
fn tiles_take_a_fill_in_and_mask_marks() {
    let d = tmp();
    let pic = d.path().join("rings.png");
    rings_picture(&pic);
    let out = d.path().join("o");
    let o = stencil(&[
        "make",
        s(&pic),
        "--width-mm",
        "240",
        "--tiles",
        "2x1",
        "--fill-in",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&out);
    for t in r["tiles"].as_array().unwrap() {
        let dir = out.join(t["folder"].as_str().unwrap());
        let fill = out.join(t["fill_in"]["folder"].as_str().unwrap());
        assert_eq!(fill, dir.join("fill-in"));
        assert_valid_stencil(&dir);
        assert_valid_stencil(&fill);
        // The tile's bridges: cut in its two-tone, material in its stencil; the fill-in cuts them.
        let (two, st) = (
            read_bits(&dir.join("twotone.png")),
            read_bits(&dir.join("stencil.png")),
        );
        let fb = read_bits(&fill.join("stencil.png"));
        assert_eq!((fb.width, fb.height), (st.width, st.height));
        let bridge: Vec<usize> = (0..st.data.len())
            .filter(|&i| !two.data[i] && st.data[i])
            .collect();
        assert!(!bridge.is_empty(), "{}: no bridges", dir.display());
        let covered = bridge.iter().filter(|&&i| !fb.data[i]).count();
        assert!(
            covered * 10 >= bridge.len() * 9,
            "{}: the fill-in cuts {covered} of {} bridge px",
            dir.display(),
            bridge.len()
        );
    }
    let o = stencil(&["check", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(String::from_utf8_lossy(&o.stdout).matches("== ").count(), 4);
    let o = stencil(&[
        "make",
        s(&pic),
        "--width-mm",
        "240",
        "--tiles",
        "2x1",
        "--emit",
        "png,svg,mask",
        "--mask-marks",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        !out.join("tile-1-1/fill-in").exists(),
        "the fill-in removed"
    );
    assert_tiles_valid(&out, None);
}

/// The closed paths of a stencil.svg's CUT layer, in mm.
fn cut_paths(svg: &str) -> Vec<Vec<[f64; 2]>> {
    let start = svg.find("id=\"cut\"").expect("a CUT layer");
    let layer = &svg[start..start + svg[start..].find("</g>").expect("layer ends")];
    let mut paths = Vec::new();
    for chunk in layer.split(" d=\"").skip(1) {
        let d = &chunk[..chunk.find('"').unwrap()];
        paths.extend(svg_subpaths(d, 0.01));
    }
    paths
}

/// What stays of the sheet along the line at `y` once every loop is cut: the material's
/// stretches between `x0` and `x1` (even-odd across the loops, as the cuts free them).
fn kept_on_row(paths: &[Vec<[f64; 2]>], y: f64, (x0, x1): (f64, f64)) -> Vec<(f64, f64)> {
    let mut xs = Vec::new();
    for p in paths {
        for k in 0..p.len() {
            let (a, b) = (p[k], p[(k + 1) % p.len()]);
            if (a[1] > y) != (b[1] > y) {
                xs.push(a[0] + (y - a[1]) / (b[1] - a[1]) * (b[0] - a[0]));
            }
        }
    }
    xs.sort_by(f64::total_cmp);
    let mut kept = Vec::new();
    let mut at = x0;
    for pair in xs.chunks(2) {
        if let [a, b] = pair {
            if *a > at {
                kept.push((at, a.min(x1)));
            }
            at = at.max(*b);
        }
    }
    if at < x1 {
        kept.push((at, x1));
    }
    kept
}

/// A tile's cut follows its seam: once its loops are cut, no material stays beyond its strip
/// past the seam (no frame of margin to trim by hand), while its outer sides keep their margin.
#[test]
fn a_tile_comes_off_the_machine_ready_to_tape() {
    let d = tmp();
    let pic = d.path().join("rings.png");
    rings_picture(&pic);
    let out = d.path().join("o");
    let o = stencil(&[
        "make",
        s(&pic),
        "--width-mm",
        "240",
        "--tiles",
        "2x1",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&out);
    let (m, ov) = (
        r["margin_mm"].as_f64().unwrap(),
        r["overlap_mm"].as_f64().unwrap(),
    );
    let seam_x: Vec<f64> = r["seams"][0]["points_mm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p[0].as_f64().unwrap())
        .collect();
    let (lo, hi) = (
        seam_x.iter().copied().fold(f64::MAX, f64::min),
        seam_x.iter().copied().fold(f64::MIN, f64::max),
    );
    for (i, t) in r["tiles"].as_array().unwrap().iter().enumerate() {
        let svg =
            std::fs::read_to_string(out.join(t["folder"].as_str().unwrap()).join("stencil.svg"))
                .unwrap();
        let paths = cut_paths(&svg);
        let (tx, w, h) = (
            t["x_mm"].as_f64().unwrap(),
            t["width_mm"].as_f64().unwrap(),
            t["height_mm"].as_f64().unwrap(),
        );
        let (mut outer_margin, mut near_seam) = (0, 0);
        for k in 0..24 {
            let y = -m + (h + 2.0 * m) * (k as f64 + 0.5) / 24.0;
            let kept = kept_on_row(&paths, y, (-m, w + m));
            for &(a, b) in &kept {
                if i == 0 {
                    // The left tile: nothing past its strip, right of the seam.
                    assert!(
                        b <= hi - tx + ov + 0.5,
                        "{}: material to {b} at y {y}",
                        t["folder"]
                    );
                    outer_margin += (a < -m / 2.0) as usize;
                    near_seam += (b > lo - tx + ov - 0.5) as usize;
                } else {
                    assert!(
                        a >= lo - tx - ov - 0.5,
                        "{}: material from {a} at y {y}",
                        t["folder"]
                    );
                    outer_margin += (b > w + m / 2.0) as usize;
                    near_seam += (a < hi - tx - ov + 0.5) as usize;
                }
            }
        }
        assert!(
            outer_margin >= 20,
            "{}: the outer margin is kept",
            t["folder"]
        );
        assert!(
            near_seam >= 20,
            "{}: the strip reaches the seam",
            t["folder"]
        );
    }
}
