//! Lighting a mesh like a photographer (issue 27 item 4), checked on `make`'s outputs: a light
//! placed by direction relative to the view puts the dark side opposite it; ambient and fill
//! light shrink the hole the shadow side becomes; named views are their angles; a model exported
//! Z-up and given `--up Z` comes out as the same model Y-up (to rounding).

use std::path::Path;

use crate::common::{self, read_bits, s, stderr, stencil, tmp};
use stencil_core::raster::BitGrid;

use crate::shapes;

/// A smooth sphere as an OBJ file.
fn sphere_obj(dir: &Path) -> std::path::PathBuf {
    let p = dir.join("sphere.obj");
    std::fs::write(&p, shapes::uv_sphere(1.0, 96, 48).to_obj("sphere")).unwrap();
    p
}

/// `stencil make INPUT -o OUT ARGS...` on a mesh, small and without lines (only the shading
/// makes holes), succeeding; returns the two-tone.
fn make(input: &Path, out: &Path, args: &[&str]) -> BitGrid {
    let mut a = vec![
        "make",
        s(input),
        "-o",
        s(out),
        "--size",
        "200",
        "--supersample",
        "1",
        "--lines",
        "none",
        "--specular",
        "0",
        "--width-mm",
        "150",
    ];
    a.extend_from_slice(args);
    let o = stencil(&a);
    assert!(o.status.success(), "{:?}: {}", args, stderr(&o));
    read_bits(&out.join("twotone.png"))
}

/// Cut pixels in the left and the right half of the picture.
fn cut_by_half(b: &BitGrid) -> (usize, usize) {
    let w = b.width as usize;
    let (mut l, mut r) = (0, 0);
    for (i, &m) in b.data.iter().enumerate() {
        if !m {
            if i % w < w / 2 {
                l += 1;
            } else {
                r += 1;
            }
        }
    }
    (l, r)
}

fn cut(b: &BitGrid) -> usize {
    b.data.iter().filter(|&&m| !m).count()
}

#[test]
fn a_light_from_the_left_leaves_the_right_side_dark() {
    let d = tmp();
    let obj = sphere_obj(d.path());
    // From the front left: what faces it is lit, the side turned away from it is dark.
    let left = make(
        &obj,
        &d.path().join("l"),
        &["--view", "front", "--light", "-60,0"],
    );
    let (l, r) = cut_by_half(&left);
    assert!(r > 1000, "the far side is a hole: {r} cut px on the right");
    // Lambert at the threshold's 0.5 lights what lies within 60 degrees of the light: less
    // than the whole left half, none of the right.
    assert!(
        l * 3 < r * 2,
        "lit from the left, the cut is on the right: {l} left, {r} right"
    );
    let right = make(
        &obj,
        &d.path().join("r"),
        &["--view", "front", "--light", "60,0"],
    );
    let (l, r) = cut_by_half(&right);
    assert!(
        r * 3 < l * 2,
        "lit from the right, the cut is on the left: {l} left, {r} right"
    );
}

#[test]
fn ambient_and_fill_light_shrink_the_shadow_hole() {
    let d = tmp();
    let obj = sphere_obj(d.path());
    let side = ["--view", "front", "--light", "-60,0"];
    let base = cut(&make(&obj, &d.path().join("a0"), &side));
    let amb = cut(&make(
        &obj,
        &d.path().join("a5"),
        &[&side[..], &["--ambient", "0.6"]].concat(),
    ));
    let fill = cut(&make(
        &obj,
        &d.path().join("f5"),
        &[&side[..], &["--fill", "1"]].concat(),
    ));
    assert!(base > 1000, "no hole to shrink: {base}");
    // Above the threshold's 0.5 everywhere: no hole is left of the shadow side.
    assert!(
        amb * 10 < base,
        "ambient 0.6 lifts the shadow side: {amb} vs {base} cut px"
    );
    // A fill as strong as the key, mirrored: the right side lit as the left is (the middle,
    // lit by both at a grazing angle, stays dark).
    assert!(
        fill * 10 < base * 8,
        "a fill of 1 lifts the shadow side: {fill} vs {base} cut px"
    );
    // Ambient at or above 1 would be no light at all from any direction: refused, named.
    let o = stencil(&[
        "make",
        s(&obj),
        "-o",
        s(&d.path().join("bad")),
        "--ambient",
        "1",
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--ambient"), "{}", stderr(&o));
}

#[test]
fn a_light_by_position_is_still_accepted_and_a_direction_is_its_point() {
    let d = tmp();
    let obj = sphere_obj(d.path());
    // Azimuth -90, elevation 0 at 3 bounding radii is the point (-3, 0, 0) of the view's frame.
    let by_dir = make(
        &obj,
        &d.path().join("d"),
        &["--view", "front", "--light", "-90,0"],
    );
    let by_pos = make(
        &obj,
        &d.path().join("p"),
        &["--view", "front", "--light", "-3,0,0"],
    );
    let diff = by_dir
        .data
        .iter()
        .zip(&by_pos.data)
        .filter(|(a, b)| a != b)
        .count();
    // sin/cos of 90 degrees in f32 are not exactly 1 and 0: a pixel or two on the terminator.
    assert!(diff <= 4, "{diff} pixels differ");
}

#[test]
fn named_views_are_their_angles() {
    let d = tmp();
    let obj = d.path().join("pawn.obj");
    std::fs::write(&obj, shapes::pawn().to_obj("pawn")).unwrap();
    for (name, angles) in [("front", "0,0"), ("side", "90,0"), ("top", "0,90")] {
        let a = make(&obj, &d.path().join(name), &["--view", name]);
        let b = make(&obj, &d.path().join(angles), &["--view", angles]);
        assert_eq!(a, b, "--view {name} is --view {angles}");
    }
    let o = stencil(&[
        "make",
        s(&obj),
        "-o",
        s(&d.path().join("x")),
        "--view",
        "sideways",
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--view"), "{}", stderr(&o));
}

#[test]
fn a_z_up_model_with_up_z_is_the_y_up_model() {
    let d = tmp();
    let m = shapes::pawn();
    let y_up = d.path().join("y.obj");
    std::fs::write(&y_up, m.to_obj("pawn")).unwrap();
    // The same model as a Z-up tool writes it: (x, y, z) -> (x, -z, y).
    let mut z = m.clone();
    for p in &mut z.positions {
        *p = glam::Vec3::new(p.x, -p.z, p.y);
    }
    let z_up = d.path().join("z.obj");
    std::fs::write(&z_up, z.to_obj("pawn")).unwrap();
    for view in ["30,20", "top", "side"] {
        let a = make(&y_up, &d.path().join(format!("y{view}")), &["--view", view]);
        let b = make(
            &z_up,
            &d.path().join(format!("z{view}")),
            &["--view", view, "--up", "Z"],
        );
        // The camera is the same rotation of the same numbers; only sums of three products
        // (a dot product) add their terms in another order: a pixel or two on a boundary.
        let n = a.data.len();
        let same = common::differing(&a, &b);
        assert!(
            same * 1000 <= n,
            "--view {view}: --up Z differs in {same} of {n} px"
        );
        let c = make(&z_up, &d.path().join(format!("n{view}")), &["--view", view]);
        let lying = if a.width == c.width && a.height == c.height {
            common::differing(&a, &c)
        } else {
            n
        };
        assert!(
            lying * 20 > n,
            "--view {view}: without --up Z the Z-up copy is seen lying down ({lying} px differ)"
        );
    }
}
