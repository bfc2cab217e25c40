//! The studio's tiles (issue 44), through its JSON API: a tiled request's state gives the seams
//! `make` computes (their paths in working pixels, for the page's overlay), a seam moved as the
//! page moves it (every seam's straight line along that axis, `--seam-x` in mm) runs where
//! `make --seam-x` puts it, within its band around the new line, and the export writes what
//! `make` with the command line the studio shows writes, byte for byte.

use serde_json::{json, Value};

use crate::common::{make_as_shown, same_outputs};
use crate::studio::{tmp, Studio};

/// The vertical seam of a 2 x 1 tiling: its straight line (mm), band (mm) and path's across
/// positions (working px).
fn vertical_seam(tiles: &Value) -> (f64, f64, Vec<u64>) {
    let seams = tiles["seams"].as_array().expect("seams");
    assert_eq!(seams.len(), 1, "{tiles}");
    let s = &seams[0];
    assert_eq!(s["axis"], "vertical", "{s}");
    let xs = s["points_px"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p[0].as_u64().unwrap())
        .collect();
    (
        s["at_mm"].as_f64().unwrap(),
        s["band_mm"].as_f64().unwrap(),
        xs,
    )
}

#[test]
fn the_studio_shows_the_seams_and_a_moved_seam_is_makes_seam_x() {
    let dir = tmp("tiles");
    let out = dir.join("studio");
    let st = Studio::start("samples/rings.png", &out, &["--tiles", "2x1"]);
    let s0 = st.ok("GET", "/api/state?wait=1", json!(null));
    assert!(s0["error"].is_null(), "{}", s0["error"]);
    let t = &s0["tiles"];
    assert_eq!(t["grid"], json!([2, 1]), "{s0}");
    assert_eq!(s0["tile_reports"].as_array().map(Vec::len), Some(2));
    let (at, band, xs) = vertical_seam(t);
    // rings.png is 32 mm wide by default: the seam's line is at the middle.
    assert!((at - 16.0).abs() < 1e-9, "{at}");
    let mm = s0["mm_per_px"].as_f64().unwrap();
    assert_eq!(s0["width_px"], t["size_px"][0]);

    // The map and each tile's images; no third tile; no bridge deleted by index.
    for (name, code) in [("tiles", 200), ("t1-preview", 200), ("t2-stencil", 200)] {
        let (c, b) = st.call("GET", &format!("/api/image/{name}.png"), b"");
        assert_eq!(c, code, "{name}");
        assert!(b.starts_with(b"\x89PNG"), "{name}");
    }
    let (c, _) = st.call("GET", "/api/image/t3-preview.png", b"");
    assert_eq!(c, 404, "a 2 x 1 tiling has no third tile");
    let (c, _) = st.json("POST", "/api/bridges", json!({"delete": 0}));
    assert_eq!(c, 409);

    // The seam moved 3 mm left, as the page sends a dropped handle.
    let to = at - 3.0;
    let s1 = st.ok("POST", "/api/params", json!({"seam-x": format!("{to}")}));
    assert!(s1["error"].is_null(), "{}", s1["error"]);
    let command = s1["command"].as_str().unwrap().to_string();
    assert!(command.contains("--tiles 2x1 --seam-x 13"), "{command}");
    let (at1, band1, xs1) = vertical_seam(&s1["tiles"]);
    assert_eq!((at1, band1), (to, band));
    assert_ne!(xs1, xs, "the seam's path moved with its line");
    // The path is in the picture grown by the marks' band; the seam's line on the picture.
    let off = s1["tiles"]["marks_band_px"].as_f64().unwrap();
    let (lo, hi) = ((to - band) / mm + off, (to + band) / mm + off);
    for &x in &xs1 {
        assert!(
            x as f64 >= lo - 1.0 && x as f64 <= hi + 1.0,
            "{x} px outside the band {lo}..{hi} around the new line"
        );
    }

    // Export, and `make` with the command line shown: the same files, so the same seams.
    let e = st.ok("POST", "/api/export", json!(null));
    assert_eq!(e["command"], command.as_str());
    let files: Vec<&str> = e["files"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(Value::as_str)
        .collect();
    assert!(
        files.contains(&"tiles.png") && files.contains(&"tile-1-2/stencil.svg"),
        "{files:?}"
    );
    let made = dir.join("make");
    make_as_shown(&command, &made);
    same_outputs(&out, &made, &command);
    let report: Value =
        serde_json::from_slice(&std::fs::read(made.join("report.json")).unwrap()).unwrap();
    assert_eq!(
        report["seams"], s1["tiles"]["seams"],
        "make's seams are the page's"
    );
    assert_eq!(report["tiles"], s1["tiles"]["tiles"]);

    // Back to one stencil: no tiles in the state, none left by the export.
    let s2 = st.ok("POST", "/api/params", json!({"tiles": "", "seam-x": ""}));
    assert!(s2["tiles"].is_null() && s2["report"].is_object(), "{s2}");
    st.ok("POST", "/api/export", json!(null));
    assert!(!out.join("tile-1-1").exists() && !out.join("tiles.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
