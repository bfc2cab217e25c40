//! `--keep-out` with `--crop` and `--rotate` (issue 27): a keep-out picture of the whole
//! picture's size is cropped and turned with the picture; any other size is in the stencil's
//! frame (what the studio paints). Checked on what `make` writes: the same stencil from either
//! frame's mask, and the bridges out of the dark area.
//!
//! The scene: a 300 × 200 px picture (30 × 20 mm at 0.1 mm a pixel) whose right 200 × 200 px hold
//! a square of ink (cut) from 40 to 160 px with a square island from 80 to 120 px; `--crop
//! 10,0,20,20` keeps exactly that part.

use crate::common::*;
use std::path::Path;

const CROP: &str = "10,0,20,20";

fn scene(path: &Path) {
    ink_png(path, 300, 200, |x, y| {
        let Some(x) = x.checked_sub(100) else {
            return false;
        };
        let ink = (40..160).contains(&x) && (40..160).contains(&y);
        let island = (80..120).contains(&x) && (80..120).contains(&y);
        ink && !island
    });
}

fn make(input: &Path, out: &Path, extra: &[&str]) {
    let mut a = vec!["make", s(input), "-o", s(out), "--crop", CROP];
    a.extend_from_slice(extra);
    let o = stencil(&a);
    assert!(o.status.success(), "{a:?}: {}", stderr(&o));
}

#[test]
fn a_keep_out_of_the_whole_picture_is_cropped_and_turned_with_it() {
    let dir = tmp();
    let input = dir.path().join("scene.png");
    scene(&input);
    let free = dir.path().join("free");
    make(&input, &free, &[]);
    let first = added_at(&free);
    assert!(!first.is_empty());
    // Dark over the half of the cropped scene its bridge used (in the cropped frame).
    let n = first.len() as f64;
    let mx = first.iter().map(|p| p.0 as f64).sum::<f64>() / n;
    let my = first.iter().map(|p| p.1 as f64).sum::<f64>() / n;
    let horizontal = (mx - 100.0).abs() > (my - 100.0).abs();
    let dark = move |x: u32, y: u32| {
        if horizontal {
            (x < 100) == (mx < 100.0)
        } else {
            (y < 100) == (my < 100.0)
        }
    };
    // The same mask drawn over the whole picture, and over the cropped one.
    let whole = dir.path().join("whole.png");
    ink_png(&whole, 300, 200, |x, y| x >= 100 && dark(x - 100, y));
    let cropped = dir.path().join("cropped.png");
    ink_png(&cropped, 200, 200, dark);

    let a = dir.path().join("a");
    make(&input, &a, &["--keep-out", s(&whole)]);
    let b = dir.path().join("b");
    make(&input, &b, &["--keep-out", s(&cropped)]);
    let kept = |d: &Path| report(d)["user_bridges"]["kept_out_px"].as_u64().unwrap();
    assert_eq!(kept(&a), 200 * 100, "half the cropped picture is kept out");
    assert_eq!(kept(&a), kept(&b));
    assert_eq!(
        std::fs::read(a.join("stencil.png")).unwrap(),
        std::fs::read(b.join("stencil.png")).unwrap(),
        "the whole picture's mask, cropped, is the cropped picture's"
    );
    assert_valid_stencil(&a);
    let now = added_at(&a);
    assert!(!now.is_empty());
    let inside: Vec<_> = now.iter().filter(|&&(x, y)| dark(x, y)).collect();
    assert!(inside.is_empty(), "bridge pixels kept out: {inside:?}");

    // Turned a quarter clockwise: the whole picture's mask is turned with it; the stencil frame's
    // mask is drawn turned.
    let c = dir.path().join("c");
    make(&input, &c, &["--rotate", "90", "--keep-out", s(&whole)]);
    let turned = dir.path().join("turned.png");
    // Output (x, y) of a clockwise quarter turn of a 200 × 200 picture comes from (y, 199 − x).
    ink_png(&turned, 200, 200, |x, y| dark(y, 199 - x));
    let d = dir.path().join("d");
    make(&input, &d, &["--rotate", "90", "--keep-out", s(&turned)]);
    assert_eq!(kept(&c), kept(&d));
    assert_eq!(
        std::fs::read(c.join("stencil.png")).unwrap(),
        std::fs::read(d.join("stencil.png")).unwrap(),
        "the whole picture's mask is turned as the picture is"
    );
}
