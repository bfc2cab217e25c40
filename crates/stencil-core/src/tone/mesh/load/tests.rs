use super::*;
use crate::tone::mesh::shapes;

fn p() -> &'static Path {
    Path::new("test.obj")
}

/// A unit cube written as six groups, each repeating its own four corners.
fn cube_groups() -> String {
    let faces: [[[f32; 3]; 4]; 6] = [
        [[0., 0., 1.], [1., 0., 1.], [1., 1., 1.], [0., 1., 1.]],
        [[1., 0., 0.], [0., 0., 0.], [0., 1., 0.], [1., 1., 0.]],
        [[1., 0., 1.], [1., 0., 0.], [1., 1., 0.], [1., 1., 1.]],
        [[0., 0., 0.], [0., 0., 1.], [0., 1., 1.], [0., 1., 0.]],
        [[0., 1., 1.], [1., 1., 1.], [1., 1., 0.], [0., 1., 0.]],
        [[0., 0., 0.], [1., 0., 0.], [1., 0., 1.], [0., 0., 1.]],
    ];
    let mut s = String::new();
    for (i, f) in faces.iter().enumerate() {
        s += &format!("o side{i}\n");
        for v in f {
            s += &format!("v {} {} {}\n", v[0], v[1], v[2]);
        }
        s += "f -4 -3 -2 -1\n";
    }
    s
}

#[test]
fn groups_are_merged_welded_and_triangulated() {
    let m = parse(p(), &cube_groups()).unwrap();
    assert_eq!(m.positions.len(), 8, "24 repeated corners weld to 8");
    assert_eq!(m.triangles.len(), 12, "6 quads become 12 triangles");
    assert!(m.is_closed());
    assert!((m.signed_volume() - 1.0).abs() < 1e-6);
    assert!(m.corner_normals.is_none());
}

#[test]
fn inside_out_closed_mesh_is_turned_right_side_out() {
    let text = cube_groups().replace("f -4 -3 -2 -1", "f -1 -2 -3 -4");
    let m = parse(p(), &text).unwrap();
    assert!((m.signed_volume() - 1.0).abs() < 1e-6);
}

#[test]
fn smooth_normals_point_outwards() {
    let m = parse(p(), &cube_groups()).unwrap();
    let n = m.vertex_normals();
    for (v, n) in m.positions.iter().zip(&n) {
        let out = (*v - Vec3::splat(0.5)).normalize();
        assert!(n.dot(out) > 0.9, "{v} {n}");
    }
}

#[test]
fn file_normals_are_kept_per_corner() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n";
    let m = parse(p(), text).unwrap();
    assert_eq!(m.corner_normals.unwrap()[0], [Vec3::Z; 3]);
}

#[test]
fn bad_lines_are_reported_with_their_number() {
    let cases = [
        ("v 0 0 0\nv 1 0\n", "test.obj:2:"),
        ("v 0 0 0\nv 1 x 0\n", "test.obj:2:"),
        ("v 0 0 0\n\nv 1 NaN 0\n", "test.obj:3:"),
        ("v 0 0 0\nv 1 inf 0\n", "test.obj:2:"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "test.obj:4:"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", "test.obj:4:"),
        ("v 0 0 0\nv 1 0 0\nf 1 2\n", "test.obj:3:"),
        ("\u{1}\u{2}binary\n", "test.obj:1:"),
    ];
    for (text, want) in cases {
        let e = parse(p(), text).unwrap_err().to_string();
        assert!(e.starts_with(want), "{text:?} gave {e}");
    }
}

#[test]
fn no_faces_is_an_empty_mesh() {
    let e = parse(p(), "v 0 0 0\nv 1 0 0\n").unwrap_err().to_string();
    assert!(e.contains("test.obj") && e.contains("no faces"), "{e}");
    let e = parse(p(), "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("zero area"), "{e}");
}

#[test]
fn what_tobj_refuses_is_refused_first_with_the_line() {
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let cases = [
        (
            format!("{tri}v 1 1 1 1 2 3 4\nf 1 2 3\n"),
            "test.obj:4:",
            "7 numbers",
        ),
        (
            format!("{tri}v 1 1 1 0.5 0.5\nf 1 2 3\n"),
            "test.obj:4:",
            "5 numbers",
        ),
        (
            format!("{tri}v 1 1 1 0\nf 1 2 3\n"),
            "test.obj:4:",
            "weight",
        ),
        (
            format!("{tri}v 1e30 1 1 1e-30\nf 1 2 3\n"),
            "test.obj:4:",
            "weight",
        ),
        (
            format!("{tri}vt 0.5\nf 1 2 3\n"),
            "test.obj:4:",
            "'vt' needs 2",
        ),
        (
            format!("{tri}vn 0 0\nf 1 2 3\n"),
            "test.obj:4:",
            "'vn' needs 3",
        ),
        (
            format!("{tri}l 1\nf 1 2 3\n"),
            "test.obj:4:",
            "line needs at least 2",
        ),
        (
            format!("{tri}usemtl\nf 1 2 3\n"),
            "test.obj:4:",
            "material name",
        ),
        (
            "v 0 0 0 1 0 0\nv 1 0 0 1 0 0\nv 0 1 0\nf 1 2 3\n".to_string(),
            "test.obj:3:",
            "colour",
        ),
        // tobj resolves a face when its object ends: a vertex after that is too late.
        (
            format!("o a\n{tri}f 1 2 4\no b\nv 1 1 0\nf 1 2 4\n"),
            "test.obj:5:",
            "index 4",
        ),
    ];
    for (text, at, what) in cases {
        let e = parse(p(), &text).unwrap_err().to_string();
        assert!(e.starts_with(at) && e.contains(what), "{text:?} gave {e}");
    }
    // A forward reference within one object is fine.
    assert!(parse(p(), &format!("f 1 2 3\n{tri}")).is_ok());
}

#[test]
fn a_byte_order_mark_is_not_a_statement() {
    let m = parse(p(), "\u{feff}v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    assert_eq!((m.positions.len(), m.triangles.len()), (3, 1));
}

#[test]
fn long_values_are_quoted_short() {
    let big = "1".repeat(1_000_000);
    for text in [
        format!("v 0 0 0\nv 1 0 {big}\nv 0 1 0\nf 1 2 3\n"),
        format!("v 0 0 0\nv 1 0 x{big}\n"),
        format!("v 0 0 0\nf 1 2 {big}\n"),
        format!("{big}x 1 2\n"),
    ] {
        let e = parse(p(), &text).unwrap_err().to_string();
        assert!(
            e.len() < 300 && e.contains("characters)"),
            "{}",
            &e[..e.len().min(300)]
        );
    }
}

#[test]
fn repeated_triangles_are_kept_once() {
    let mut text = "v 0 0 0\nv 1 0 0\nv 0 1 0\n".to_string();
    for _ in 0..1000 {
        text += "f 1 2 3\nf 2 3 1\n";
    }
    text += "f 1 3 2\n";
    let m = parse(p(), &text).unwrap();
    assert_eq!(m.triangles.len(), 2, "one each way round");
}

#[test]
fn a_stray_far_vertex_is_refused_with_its_line() {
    let mut text = String::new();
    for (x, y, z) in [
        (0, 0, 0),
        (1, 0, 0),
        (0, 1, 0),
        (1, 1, 0),
        (0, 0, 1),
        (1, 0, 1),
        (0, 1, 1),
    ] {
        text += &format!("v {x} {y} {z}\n");
    }
    text += "v 3 1e20 0\nf 1 2 4\nf 1 4 3\nf 5 6 7\nf 1 2 8\n";
    let e = parse(p(), &text).unwrap_err().to_string();
    assert!(e.starts_with("test.obj:8: vertex (3, 1.00e20, 0)"), "{e}");
    // A model 400 times larger than its bulk still loads.
    let ok = text.replace("v 3 1e20 0", "v 3 400 0");
    assert!(parse(p(), &ok).is_ok());
}

// The procedural test shapes (tests/support/shapes.rs) are right side out.
#[test]
fn closed_shapes_are_closed_and_outward() {
    for (name, m) in [
        ("sphere", shapes::uv_sphere(1.0, 16, 8)),
        ("torus", shapes::torus(2.0, 0.5, 24, 12)),
        ("cube", shapes::cube(1.0)),
        ("bumpy", shapes::displaced_sphere(6)),
        ("pawn", shapes::pawn()),
        ("trefoil", shapes::trefoil()),
    ] {
        assert!(m.is_closed(), "{name} is not closed");
        assert!(m.signed_volume() > 0.0, "{name}");
    }
    assert_eq!(shapes::cube(1.0).positions.len(), 8);
    assert_eq!(shapes::displaced_sphere(76).triangles.len(), 69_312);
    let s = shapes::uv_sphere(1.0, 16, 8);
    assert_eq!(s.positions.len(), 16 * 7 + 2);
    assert!(
        (shapes::uv_sphere(1.0, 64, 32).signed_volume() - 4.0 / 3.0 * std::f64::consts::PI).abs()
            < 0.03
    );
}

#[test]
fn height_field_faces_up() {
    let m = shapes::height_field(4, |_, _| 0.0);
    assert!(!m.is_closed());
    assert!(m.vertex_normals().iter().all(|n| n.y > 0.99));
}

/// Every refusal of the pre-scan names its line and says what is wrong; forward indices are
/// checked when a group ends or at the end of the file, so their line is the face's.
#[test]
fn prescan_names_the_line_of_each_fault() {
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    for (body, line, what) in [
        ("v 1 2\n", 4, "'v' needs 3 numbers (x y z), found 2"),
        ("v 1 2 3 4 5\n", 4, "a vertex ('v') with 5 numbers"),
        ("v 1 x 3\n", 4, "vertex coordinate 'x' is not a number"),
        ("v 1 2 3 0\n", 4, "vertex weight w = 0 divides"),
        ("vn 1 2\n", 4, "'vn' needs 3 numbers, found 2"),
        ("vt 1\n", 4, "'vt' needs 2 numbers, found 1"),
        ("vn 1 q 2\n", 4, "normal 'q' is not a number"),
        ("f 1 2\n", 4, "a face needs at least 3 corners, found 2"),
        ("l 1\n", 4, "a line needs at least 2 corners, found 1"),
        ("f 1/2/3/4 2 3\n", 4, "face corner '1/2/3/4' is not v"),
        ("f /1 2 3\n", 4, "face corner '/1' is not v"),
        ("f 1 2 x\n", 4, "face index 'x' in 'x' is not an integer"),
        ("f 1 2 0\n", 4, "face index 0 in '0'"),
        ("f 1 2 -4\n", 4, "index -4"),
        ("f 1 2 9\no x\nv 1 1 1\n", 4, "index 9"),
        ("f 1 2 5\nv 1 1 1\n", 4, "index 5"),
        ("f 1//5 2 3\n", 4, "index 5"),
        ("usemtl\n", 4, "'usemtl' without a material name"),
        ("zork 1\n", 4, "unknown statement 'zork'"),
        (
            "v 1 1 1 1 0 0\nf 1 2 3\n",
            4,
            "vertices with a colour (first at line 4)",
        ),
    ] {
        let text = format!("{tri}{body}");
        let e = prescan(p(), &text).expect_err(body).to_string();
        assert!(
            e.contains(&format!(":{line}:")) && e.contains(what),
            "{body:?}: {e}"
        );
    }
    // A forward index that a later vertex satisfies, before the group ends, is fine.
    let counts = prescan(p(), &format!("{tri}f 1 2 4\nv 1 1 1\nl 1 4\n")).unwrap();
    assert_eq!((counts.vertices, counts.faces), (4, 1));
}
