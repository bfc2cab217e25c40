//! Issue 13 item 4: the user decides where bridges go. Each test runs `stencil make` and reads the
//! stencil back: where bridges were added (stencil material that the two-tone did not have), and
//! report.json.
//!
//! The scene: a 200 × 200 px picture (20 × 20 mm at the default 0.1 mm a pixel) with a square of
//! ink (cut) from 40 to 160 px holding a square island from 80 to 120 px: 4 mm of cut on every
//! side of the island.

use crate::common::*;
use std::path::Path;

const N: u32 = 200;

fn scene(path: &Path, speck: bool) {
    ink_png(path, N, N, |x, y| {
        let ink = (40..160).contains(&x) && (40..160).contains(&y);
        let island = (80..120).contains(&x) && (80..120).contains(&y);
        // A 1 mm² speck of paper in the ink, far from the island.
        let small = speck && (50..60).contains(&x) && (140..150).contains(&y);
        ink && !island && !small
    });
}

fn make(input: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut a = vec!["make", s(input), "-o", s(out)];
    a.extend_from_slice(extra);
    stencil(&a)
}

#[test]
fn a_keep_out_mask_moves_the_bridge_out_of_the_dark_area() {
    let dir = tmp();
    let input = dir.path().join("scene.png");
    scene(&input, false);
    // Without a mask: note where the bridge goes.
    let free = dir.path().join("free");
    let o = make(&input, &free, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let first = added_at(&free);
    assert!(!first.is_empty());
    // A mask at half the picture's size, dark over the half of the sheet the bridge used.
    let (mx, my) = (
        first.iter().map(|p| p.0 as f64).sum::<f64>() / first.len() as f64,
        first.iter().map(|p| p.1 as f64).sum::<f64>() / first.len() as f64,
    );
    let horizontal = (mx - 100.0).abs() > (my - 100.0).abs();
    let dark = move |x: u32, y: u32| {
        let (x, y) = (x as f64 * 2.0 + 1.0, y as f64 * 2.0 + 1.0);
        if horizontal {
            (x < 100.0) == (mx < 100.0)
        } else {
            (y < 100.0) == (my < 100.0)
        }
    };
    let mask = dir.path().join("mask.png");
    ink_png(&mask, N / 2, N / 2, dark);
    let out = dir.path().join("kept");
    let o = make(&input, &out, &["--keep-out", s(&mask)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_valid_stencil(&out);
    let now = added_at(&out);
    assert!(!now.is_empty());
    let inside = now.iter().filter(|&&(x, y)| dark(x / 2, y / 2)).count();
    let bad: Vec<_> = now.iter().filter(|&&(x, y)| dark(x / 2, y / 2)).collect();
    assert_eq!(
        inside, 0,
        "{inside} bridge pixels in the keep-out area: {bad:?} of {now:?}"
    );
    let r = report(&out);
    assert!(r["user_bridges"]["kept_out_px"].as_u64().unwrap() > 0);
}

#[test]
fn an_island_entirely_kept_out_is_an_error_naming_it_and_nothing_is_written() {
    let dir = tmp();
    let input = dir.path().join("scene.png");
    scene(&input, false);
    // Dark over the whole ink square: no bridge can leave the island.
    let mask = dir.path().join("mask.png");
    ink_png(&mask, N, N, |x, y| {
        (36..164).contains(&x) && (36..164).contains(&y)
    });
    let out = dir.path().join("out");
    let o = make(&input, &out, &["--keep-out", s(&mask)]);
    assert!(!o.status.success());
    let e = stderr(&o);
    // The island's position in mm (its border starts at 8.0 mm) and what to relax.
    assert!(e.contains("island 1 at (8.") && e.contains("mm"), "{e}");
    assert!(
        e.contains("--keep-out") && e.contains("--min-island-mm2"),
        "{e}"
    );
    assert!(!out.exists(), "nothing written");
}

#[test]
fn no_bridge_near_a_point_and_a_bridge_at_a_point() {
    let dir = tmp();
    let input = dir.path().join("scene.png");
    scene(&input, false);
    let free = dir.path().join("free");
    assert!(make(&input, &free, &[]).status.success());
    let first = added_at(&free);
    let (cx, cy) = (
        first.iter().map(|p| p.0 as f64 + 0.5).sum::<f64>() / first.len() as f64,
        first.iter().map(|p| p.1 as f64 + 0.5).sum::<f64>() / first.len() as f64,
    );
    // A 3 mm disc around where the bridge was: none of the new bridge's pixels in it.
    let disc = format!("{:.2},{:.2},3", cx * 0.1, cy * 0.1);
    let out = dir.path().join("near");
    let o = make(&input, &out, &["--no-bridge-near", &disc]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_valid_stencil(&out);
    let now = added_at(&out);
    assert!(!now.is_empty());
    assert!(now
        .iter()
        .all(|&(x, y)| (x as f64 + 0.5 - cx).hypot(y as f64 + 0.5 - cy) > 30.0));

    // A bridge asked for at the island's bottom-right corner region: one starts within 1.5 mm of
    // it (the material's bridge is 1 mm wide), besides the tree's.
    let at = (118.0, 110.0);
    let out = dir.path().join("at");
    let o = make(
        &input,
        &out,
        &["--bridge-at", &format!("{},{}", at.0 * 0.1, at.1 * 0.1)],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_valid_stencil(&out);
    let near = added_at(&out)
        .iter()
        .map(|&(x, y)| (x as f64 + 0.5 - at.0).hypot(y as f64 + 0.5 - at.1))
        .fold(f64::INFINITY, f64::min);
    assert!(
        near <= 15.0,
        "nearest bridge pixel {near} px from the point"
    );
    let r = report(&out);
    let req = &r["user_bridges"]["bridge_at"][0];
    assert_eq!(req["island"], 1);
    assert!(req["distance_mm"].as_f64().unwrap() <= 1.5, "{req}");
    // Without the request, no bridge there: the test can tell.
    let far = first
        .iter()
        .map(|&(x, y)| (x as f64 + 0.5 - at.0).hypot(y as f64 + 0.5 - at.1))
        .fold(f64::INFINITY, f64::min);
    assert!(far > 15.0, "the free bridge is already there ({far} px)");
}

#[test]
fn islands_under_the_minimum_area_are_cut_away_and_counted() {
    let dir = tmp();
    let input = dir.path().join("scene.png");
    scene(&input, true);
    let out = dir.path().join("out");
    let o = make(&input, &out, &["--min-island-mm2", "2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_valid_stencil(&out);
    let st = read_bits(&out.join("stencil.png"));
    // The speck (1 mm²) is cut; the island (16 mm²) stays.
    assert!(!st.get(55, 145), "the speck was cut away");
    assert!(st.get(100, 100), "the island stays");
    let r = report(&out);
    assert_eq!(r["user_bridges"]["islands_cut_away"], 1);
    let area = r["user_bridges"]["cut_away_mm2"].as_f64().unwrap();
    assert!((0.5..=1.5).contains(&area), "{area}");
    // Without the option the speck is bridged and kept.
    let kept = dir.path().join("kept");
    // Every island kept (none dropped by least change), so the small one is bridged.
    assert!(make(&input, &kept, &["--keep-all-islands"])
        .status
        .success());
    assert!(read_bits(&kept.join("stencil.png")).get(55, 145));
}

#[test]
fn bad_positions_and_areas_name_the_option() {
    let dir = tmp();
    let input = dir.path().join("scene.png");
    scene(&input, false);
    let out = dir.path().join("out");
    for (opt, bad) in [
        ("--bridge-at", "3"),
        ("--bridge-at", "a,b"),
        ("--no-bridge-near", "1,2,0"),
        ("--no-bridge-near", "1,2,inf"),
        ("--min-island-mm2", "1e300"),
        ("--min-island-mm2", "some"),
    ] {
        let o = make(&input, &out, &[opt, bad]);
        assert!(!o.status.success(), "{opt} {bad}");
        assert!(stderr(&o).contains(opt), "{opt} {bad}: {}", stderr(&o));
    }
    let o = make(&input, &out, &["--keep-out", "/no/such/mask.png"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("mask.png"), "{}", stderr(&o));
}
