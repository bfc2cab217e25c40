//! Issue 13 item 5: bridges are stable under small changes. The same picture shifted by one pixel
//! (right, then down; the uncovered edge white) must keep at least 90 % of its bridges where they
//! were: a bridge has stayed when the shifted run has one whose centre, in picture pixels, lies
//! within [`TOLERANCE_PX`] of the first run's centre moved by the shift.
//!
//! Two pictures of the corpus (`samples/`): the Grace Hopper photograph at 250 mm (supersampled,
//! over a hundred bridges) and the drawn target.

use crate::common::*;
use std::path::Path;

/// How far a bridge's centre may drift and still count as the same place, in picture pixels.
const TOLERANCE_PX: f64 = 2.0;

/// Write `src` shifted by (dx, dy) picture pixels, the uncovered rows and columns white.
fn shifted(src: &Path, dst: &Path, dx: u32, dy: u32) {
    let g = image::open(src).unwrap().to_luma8();
    let (w, h) = g.dimensions();
    let out = image::GrayImage::from_fn(w, h, |x, y| {
        if x < dx || y < dy {
            image::Luma([255])
        } else {
            *g.get_pixel(x - dx, y - dy)
        }
    });
    out.save(dst).unwrap();
}

/// The centre of every bridge (mean of its outline's points), in picture pixels.
fn centres(out: &Path) -> Vec<[f64; 2]> {
    let r = report(out);
    let k = r["scale_factor"].as_f64().unwrap_or(1.0);
    r["bridges"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| {
            let p = b["polygon_px"].as_array().unwrap();
            let (mut x, mut y) = (0.0, 0.0);
            for q in p {
                x += q[0].as_f64().unwrap();
                y += q[1].as_f64().unwrap();
            }
            [x / p.len() as f64 / k, y / p.len() as f64 / k]
        })
        .collect()
}

/// How many of `a`'s bridges have none in `b` near their place moved by `shift`.
fn moved(a: &[[f64; 2]], b: &[[f64; 2]], shift: [f64; 2]) -> usize {
    a.iter()
        .filter(|c| {
            !b.iter()
                .any(|d| (d[0] - c[0] - shift[0]).hypot(d[1] - c[1] - shift[1]) <= TOLERANCE_PX)
        })
        .count()
}

fn check(picture: &str, args: &[&str], at_least: usize) {
    let dir = tmp();
    let src = samples().join(picture);
    let base = dir.path().join("base.png");
    // The same decoding for both runs: the original re-saved as gray PNG.
    shifted(&src, &base, 0, 0);
    let run = |input: &Path, name: &str| {
        let out = dir.path().join(name);
        let mut a = vec!["make", s(input), "-o", s(&out)];
        a.extend_from_slice(args);
        let o = stencil(&a);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_valid_stencil(&out);
        centres(&out)
    };
    let a = run(&base, "a");
    assert!(a.len() >= at_least, "{picture}: only {} bridges", a.len());
    for (dx, dy) in [(1u32, 0u32), (0, 1)] {
        let input = dir.path().join(format!("shift-{dx}-{dy}.png"));
        shifted(&src, &input, dx, dy);
        let b = run(&input, &format!("b-{dx}-{dy}"));
        let n = moved(&a, &b, [dx as f64, dy as f64]);
        assert!(
            n * 10 <= a.len(),
            "{picture} shifted by ({dx}, {dy}): {n} of {} bridges moved",
            a.len()
        );
        // The measure can fail: matched against the wrong shift, most bridges count as moved.
        let wrong = moved(&a, &b, [dx as f64 + 4.0, dy as f64 + 4.0]);
        assert!(wrong * 2 > a.len(), "{picture}: {wrong} of {}", a.len());
    }
}

#[test]
fn a_photograph_shifted_by_one_pixel_keeps_its_bridges() {
    // Every island bridged (none dropped by least change): this judges the bridger's stability.
    check(
        "grace_hopper.jpg",
        &["--width-mm", "250", "--keep-all-islands"],
        60,
    );
}

#[test]
fn a_drawing_shifted_by_one_pixel_keeps_its_bridges() {
    check("target.png", &[], 10);
}
