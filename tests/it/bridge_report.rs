//! report.json's per-bridge pixels describe the stencil written: together with the material the
//! clean-up added apart from every bridge (`fidelity.apart_from_bridges_px`) they are exactly the
//! material added after the two-tone (stencil.png minus twotone.png). They used to be counted when
//! the bridges were drawn, before the clean-up settled them into the picture.

use crate::common::*;

/// `make` on `input` with `extra`, then the report's bridges against the PNGs. Returns the pixels
/// of added material found away from every bridge.
fn bridges_count_the_final_stencil(input: &str, extra: &[&str]) -> u64 {
    let dir = tmp();
    let out = dir.path().join("out");
    let input = samples().join(input);
    let mut args = vec!["make", s(&input), "-o", s(&out)];
    args.extend_from_slice(extra);
    let o = stencil(&args);
    assert!(o.status.success(), "stencil {args:?}: {}", stderr(&o));
    assert_valid_stencil(&out);
    let rep = report(&out);
    let bridges = rep["bridges"].as_array().expect("bridges in report.json");
    assert!(!bridges.is_empty(), "{args:?}: the sample has islands");
    let pixels: Vec<u64> = bridges
        .iter()
        .map(|b| b["pixels"].as_u64().expect("pixels"))
        .collect();
    let added = added_pixels(&out) as u64;
    let apart = rep["fidelity"]["apart_from_bridges_px"]
        .as_u64()
        .expect("fidelity.apart_from_bridges_px");
    assert_eq!(
        pixels.iter().sum::<u64>() + apart,
        added,
        "{args:?}: per-bridge pixels {pixels:?} and {apart} apart against stencil.png minus \
         twotone.png"
    );
    assert_eq!(rep["fidelity"]["bridges_px"].as_u64(), Some(added));
    // A bridge owns all the added material joined to it, so what is apart lies in the pieces of
    // added material (4-connected) that hold no bridge's middle.
    let pieces = added_pieces(&out);
    let held: u64 = pieces
        .iter()
        .filter(|(_, piece)| {
            bridges.iter().any(|b| {
                let middle = middle(&b["polygon_px"]);
                piece.contains(&middle)
            })
        })
        .map(|(size, _)| *size)
        .sum();
    assert!(
        apart <= added - held,
        "{args:?}: {apart} px apart, but only {} px of added material holds no bridge",
        added - held
    );
    // And pieces well away from every bridge are apart, not any bridge's. (The outline runs
    // along the bridge's strips; what it drew reaches up to about its width beyond them.)
    let boxes: Vec<[f64; 4]> = bridges
        .iter()
        .map(|b| {
            let width = b["width_px"].as_f64().expect("width_px");
            outline_box(&b["polygon_px"], width + 2.0)
        })
        .collect();
    let far: u64 = pieces
        .iter()
        .filter(|(_, piece)| {
            piece.iter().all(|&(x, y)| {
                let (x, y) = (x as f64, y as f64);
                boxes
                    .iter()
                    .all(|b| x < b[0] || y < b[1] || x > b[2] || y > b[3])
            })
        })
        .map(|(size, _)| *size)
        .sum();
    assert!(
        apart >= far,
        "{args:?}: {far} px of added material lie away from every bridge, only {apart} apart"
    );
    assert!(
        pixels.iter().all(|&p| p > 0),
        "{args:?}: every bridge adds material: {pixels:?}"
    );
    far
}

#[test]
fn bridge_pixels_after_the_filter_and_tidy() {
    // An explicit filter radius: the topological filter, then the tidy pass around the bridges.
    bridges_count_the_final_stencil("rings.png", &["--filter-radius", "2"]);
}

#[test]
fn bridge_pixels_after_regularize_and_settle() {
    // The default: the regularised two-tone, then the settle and the sealed-pocket fill.
    bridges_count_the_final_stencil("letters.png", &[]);
}

/// The pieces (4-connected) of stencil.png minus twotone.png: each piece's size and pixels.
fn added_pieces(out: &std::path::Path) -> Vec<(u64, std::collections::HashSet<(usize, usize)>)> {
    let two = read_bits(&out.join("twotone.png"));
    let st = read_bits(&out.join("stencil.png"));
    let (w, h) = (two.width as usize, two.height as usize);
    let (label, count) = pieces_of(w, h, |i| !two.data[i] && st.data[i]);
    let mut pieces = vec![std::collections::HashSet::new(); count];
    for (i, &l) in label.iter().enumerate() {
        if let Some(p) = pieces.get_mut(l as usize) {
            p.insert((i % w, i / w));
        }
    }
    pieces.into_iter().map(|p| (p.len() as u64, p)).collect()
}

/// The pixel under the mean of a bridge's outline points (pixel centres, in pixels).
fn middle(polygon: &serde_json::Value) -> (usize, usize) {
    let points: Vec<[f64; 2]> = serde_json::from_value(polygon.clone()).expect("polygon_px");
    let n = points.len().max(1) as f64;
    let (x, y) = points
        .iter()
        .fold((0.0, 0.0), |(x, y), p| (x + p[0] / n, y + p[1] / n));
    (x.round().max(0.0) as usize, y.round().max(0.0) as usize)
}

/// The bounding box of a bridge's outline, grown by `margin` px: [x0, y0, x1, y1].
fn outline_box(polygon: &serde_json::Value, margin: f64) -> [f64; 4] {
    let points: Vec<[f64; 2]> = serde_json::from_value(polygon.clone()).expect("polygon_px");
    points
        .iter()
        .fold([f64::MAX, f64::MAX, f64::MIN, f64::MIN], |b, p| {
            [
                b[0].min(p[0] - margin),
                b[1].min(p[1] - margin),
                b[2].max(p[0] + margin),
                b[3].max(p[1] + margin),
            ]
        })
}

/// A photo, where the clean-up after bridging also adds material far from every bridge: that
/// material is reported apart (it went to the nearest bridge, however far, before).
#[test]
fn bridge_pixels_on_a_photo() {
    let far = bridges_count_the_final_stencil("grace_hopper.jpg", &[]);
    assert!(
        far > 0,
        "the photo's clean-up adds material away from the bridges"
    );
}
