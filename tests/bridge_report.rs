//! report.json's per-bridge pixels describe the stencil written: together they are exactly the
//! material the bridges and their clean-up added (stencil.png minus twotone.png). They used to be
//! counted when the bridges were drawn, before the clean-up settled them into the picture.

mod common;
use common::*;

/// `make` on `input` with `extra`, then the report's bridges against the PNGs.
fn bridges_count_the_final_stencil(input: &str, extra: &[&str]) {
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
    assert_eq!(
        pixels.iter().sum::<u64>(),
        added,
        "{args:?}: per-bridge pixels {pixels:?} against stencil.png minus twotone.png"
    );
    assert_eq!(rep["fidelity"]["bridges_px"].as_u64(), Some(added));
    assert!(
        pixels.iter().all(|&p| p > 0),
        "{args:?}: every bridge adds material: {pixels:?}"
    );
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
