//! A real photograph (samples/grace_hopper.jpg, public domain) made end to end as users do: plain
//! `stencil make` with two materials at two sizes, no `--allow-thin`. The run must succeed, the
//! sheet must be one 4-connected piece, `stencil check` on the folder must pass with the same
//! material, the G-code must be written, and the fidelity figures must add up.

use crate::common::*;

fn make_photo(material: &str, extra: &[&str]) {
    let dir = tmp();
    let out = dir.path().join("out");
    let input = samples().join("grace_hopper.jpg");
    let mut args = vec![
        "make",
        s(&input),
        "-o",
        s(&out),
        "--material",
        material,
        "--emit",
        "png,svg,gcode",
    ];
    args.extend_from_slice(extra);
    let o = stencil(&args);
    assert!(o.status.success(), "{material} {extra:?}: {}", stderr(&o));
    assert_valid_stencil(&out);
    let r = report(&out);
    assert_eq!(r["material"], material);
    assert_eq!(r["check"]["violations"].as_array().unwrap().len(), 0);
    // The photo has islands (the face, the collar's pieces): they were joined.
    assert!(r["islands"].as_u64().unwrap() > 0, "{r}");
    assert!(out.join("stencil.gcode").is_file());
    // Fidelity: the parts add up to what the test counts itself from the written PNGs.
    let f = &r["fidelity"];
    let two = read_bits(&out.join("twotone.png"));
    let st = read_bits(&out.join("stencil.png"));
    let bridges = two
        .data
        .iter()
        .zip(&st.data)
        .filter(|(a, b)| !**a && **b)
        .count();
    assert_eq!(f["bridges_px"].as_u64().unwrap() as usize, bridges);
    assert_eq!(f["pixels"].as_u64().unwrap() as usize, st.len());
    // The independent check of the written folder agrees.
    let o = stencil(&["check", s(&out), "--material", material]);
    assert!(o.status.success(), "check {material}: {}", stderr(&o));
}

#[test]
fn photo_makes_a_valid_cardstock_stencil_at_the_default_size() {
    make_photo("cardstock", &[]);
}

#[test]
fn photo_makes_a_valid_plywood_stencil_at_150_mm() {
    make_photo(
        "plywood-3mm",
        &["--width-mm", "150", "--machine", "co2-600x400"],
    );
}
