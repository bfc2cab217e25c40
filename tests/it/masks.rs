//! Photo-etch masks as shops want them (issue 28, item 2): the console and report.json state
//! every mask's polarity, mirroring and dpi; a two-sided etch writes a front and a back.

use crate::common::{stderr, stencil};

#[test]
fn the_report_and_the_console_say_what_each_mask_is() {
    let tmp = tempfile::tempdir().unwrap();
    let rings = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/rings.png");
    let out = tmp.path().join("brass");
    let o = stencil(&[
        "make",
        rings,
        "-o",
        out.to_str().unwrap(),
        "--material",
        "brass-0.3-etch",
        "--width-mm",
        "80",
        "--emit",
        "mask",
        "--mask-dpi",
        "600",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let so = String::from_utf8_lossy(&o.stdout);
    for needle in [
        "mask front: mask-front.png",
        "mask back",
        "600 dpi",
        "black where metal stays",
        "mirrored left-right",
        "right-reading",
        "0.060 mm smaller",
    ] {
        assert!(so.contains(needle), "{needle}: {so}");
    }
    for f in [
        "mask-front.png",
        "mask-front.svg",
        "mask-back.png",
        "mask-back.svg",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    assert!(!out.join("mask.png").exists());
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    let m = &r["mask"];
    assert_eq!(m["dpi"], 600.0);
    assert_eq!(m["masks"][0]["side"], "front");
    assert_eq!(m["masks"][0]["mirrored"], false);
    assert_eq!(m["masks"][1]["side"], "back");
    assert_eq!(m["masks"][1]["mirrored"], true);
    // brass-0.3-etch: 0.3 mm from both sides with etch factor 2.5: 0.15 / 2.5 = 0.06 mm.
    assert!((m["undercut_compensation_mm"].as_f64().unwrap() - 0.06).abs() < 1e-9);
    assert!(m["polarity"].as_str().unwrap().contains("metal stays"));

    // The gobo profile mirrors its one mask, and --mask-invert turns the polarity.
    let out = tmp.path().join("gobo");
    let o = stencil(&[
        "make",
        rings,
        "-o",
        out.to_str().unwrap(),
        "--material",
        "aluminium-gobo",
        "--width-mm",
        "80",
        "--emit",
        "mask",
        "--mask-invert",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(r["mask"]["masks"][0]["png"], "mask.png");
    assert_eq!(r["mask"]["masks"][0]["mirrored"], true);
    assert!(r["mask"]["polarity"]
        .as_str()
        .unwrap()
        .starts_with("clear where metal stays"));
}
