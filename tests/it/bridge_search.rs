//! The fallback search's bridges, by output: an island no walk under the length limit leaves is
//! joined along the shortest gap as the crow flies, drawn as a band of its width, where a search
//! that counted 4-connected pixels took the nearest gap along the rows and columns instead; and
//! the slanted band covers no more pixels than its area.

use crate::common::*;

/// A pixel material with no physical limits, as the corpus tool's quality runs use: bridges are
/// exactly the width asked for in pixels.
const PIXEL_MATERIAL: &str = "name = \"pixel\"\ndescription = \"no physical limits\"\n\
    thickness_mm = 0.1\nmin_bridge_mm = 0.01\nmin_feature_mm = 0.01\nkerf_mm = 0.0\n\
    process = \"laser\"\n[laser]\npower_pct = 20\nspeed_mm_min = 1500\npasses = 1\n";

/// Black, with a paper disc over the top-left corner (part of the sheet) and an 8 px paper
/// island at (80..88, 80..88). The island is 80 px from the top and left edges straight along a
/// row or column, 64 px from the disc along the diagonal; counted in 4-connected steps the
/// diagonal is 91, so such a search went straight up to the edge.
fn paper(x: u32, y: u32) -> bool {
    let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
    (fx - 15.0).hypot(fy - 15.0) <= 28.0 || ((80..88).contains(&x) && (80..88).contains(&y))
}

#[test]
fn a_far_island_is_joined_across_the_shortest_slanted_gap_not_the_nearest_straight_one() {
    let dir = tmp();
    let pic = dir.path().join("far.png");
    ink_png(&pic, 200, 200, |x, y| !paper(x, y));
    let material = dir.path().join("pixel.toml");
    std::fs::write(&material, PIXEL_MATERIAL).unwrap();
    let out = dir.path().join("out");
    let o = stencil(&[
        "make",
        s(&pic),
        "-o",
        s(&out),
        "--scale",
        "1",
        "--threshold",
        "128",
        "--filter-radius",
        "0",
        "--min-speck-px",
        "0",
        "--keep-all-islands",
        "--min-bridge-width-px",
        "3",
        "--max-bridge-width-px",
        "3",
        "--max-bridge-length-px",
        "20",
        "--material",
        s(&material),
        "--allow-thin",
        "--emit",
        "png",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_valid_stencil(&out);
    let r = report(&out);
    let bridges = r["bridges"].as_array().unwrap();
    assert_eq!(bridges.len(), 1, "{bridges:?}");
    assert_eq!(bridges[0]["via"], "search", "{bridges:?}");
    assert!(r["check"]["violations"].as_array().unwrap().is_empty());
    // Read from stencil.png: the bridge runs along the diagonal to the disc, nowhere near the
    // edges, and covers fewer pixels than a 3 px bridge straight up or left (240, as the old
    // search drew it: 242) or a 3 px band along the diagonal through the pixel centres, which
    // takes 5 pixels a row at 45° where its area is 4.24 (229).
    let added = added_at(&out);
    assert!(
        added
            .iter()
            .all(|&(x, y)| x.abs_diff(y) <= 4 && x >= 20 && y >= 20),
        "a bridge off the diagonal: {added:?}"
    );
    assert!(added.len() < 200, "{} pixels added", added.len());
}
