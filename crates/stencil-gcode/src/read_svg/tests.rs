use super::*;
use geo::Area;
use geo::{BoundingRect, Centroid};

const MM: &str =
    r#"xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100""#;

fn read_body(body: &str) -> Result<CutLoops, String> {
    cut_loops_from_svg(&format!("<svg {MM}>{body}</svg>"), "t.svg").map_err(|e| e.to_string())
}

/// Each cut loop as (min x, min y, max x, max y, area), sorted.
fn boxes(g: &CutLoops) -> Vec<[f64; 5]> {
    let mut v: Vec<[f64; 5]> = g
        .cuts
        .0
        .iter()
        .map(|p| {
            let r = p.bounding_rect().unwrap();
            [
                r.min().x,
                r.min().y,
                r.max().x,
                r.max().y,
                p.unsigned_area(),
            ]
        })
        .collect();
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v
}

fn near(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn every_shape_is_cut_beside_paths() {
    // The hand-written reader dropped every shape but <path>.
    let g = read_body(
        r#"<path d="M10 10 h10 v10 h-10 z"/><rect x="30" y="10" width="10" height="5"/>
        <circle cx="55" cy="15" r="5"/><ellipse cx="75" cy="15" rx="8" ry="4"/>
        <polygon points="10,40 20,40 15,50"/>"#,
    )
    .unwrap();
    assert_eq!(g.cuts.0.len(), 5);
    assert!(g.lines.is_empty());
    let b = boxes(&g);
    let tol = 1e-4;
    let area = |x0: f64, y0: f64| {
        b.iter()
            .find(|r| near(r[0], x0, 1e-3) && near(r[1], y0, 1e-3))
    };
    assert!(near(area(10.0, 10.0).unwrap()[4], 100.0, tol), "{b:?}");
    assert!(near(area(30.0, 10.0).unwrap()[4], 50.0, tol), "{b:?}");
    assert!(near(area(10.0, 40.0).unwrap()[4], 50.0, tol), "{b:?}");
    // Curves flattened within the tolerance: a chord's sagitta is at most the tolerance, so
    // the polygon's area lies between the circle's and that of a circle smaller by it.
    let c = area(50.0, 10.0).unwrap();
    let pi = std::f64::consts::PI;
    let r = 5.0;
    assert!(
        c[4] <= pi * r * r && c[4] >= pi * (r - FLATTEN_TOLERANCE_MM).powi(2),
        "{c:?}"
    );
    let e = area(67.0, 11.0).unwrap();
    assert!(
        e[4] <= pi * 8.0 * 4.0 && e[4] >= pi * 8.0 * 4.0 * 0.99,
        "{e:?}"
    );
}

#[test]
fn hidden_shapes_are_not_cut() {
    let g = read_body(
        r#"<style>.off { display: none }</style>
        <rect x="10" y="10" width="10" height="10"/>
        <rect x="30" y="10" width="10" height="10" display="none"/>
        <g style="display:none"><rect x="50" y="10" width="10" height="10"/></g>
        <rect class="off" x="70" y="10" width="10" height="10"/>
        <rect x="10" y="30" width="10" height="10" visibility="hidden"/>
        <defs><rect id="d" x="30" y="30" width="10" height="10"/></defs>"#,
    )
    .unwrap();
    assert_eq!(boxes(&g).len(), 1, "{:?}", boxes(&g));
    assert!(near(boxes(&g)[0][0], 10.0, 1e-4));
}

#[test]
fn an_open_path_is_a_line_not_a_triangle() {
    let g = read_body(r#"<path d="M10 10 L50 10 L50 50"/><line x1="0" y1="90" x2="100" y2="90"/>"#)
        .unwrap();
    assert!(g.cuts.0.is_empty(), "nothing closed to cut: {:?}", g.cuts);
    assert_eq!(g.lines.len(), 2);
    let pts: Vec<(f64, f64)> = g.lines[0].0.iter().map(|c| (c.x, c.y)).collect();
    assert_eq!(pts.len(), 3, "{pts:?}");
    for (p, w) in pts.iter().zip([(10.0, 10.0), (50.0, 10.0), (50.0, 50.0)]) {
        assert!(near(p.0, w.0, 1e-4) && near(p.1, w.1, 1e-4), "{pts:?}");
    }
    // A closed path is a loop, not a line.
    let g = read_body(r#"<path d="M10 10 L50 10 L50 50 Z"/>"#).unwrap();
    assert_eq!((g.cuts.0.len(), g.lines.len()), (1, 0));
}

#[test]
fn a_nested_viewport_places_and_scales() {
    // A 20 mm viewport at (10, 60) showing a 10-unit viewBox: 2 mm per unit.
    let g = read_body(
        r#"<svg x="10" y="60" width="20" height="20" viewBox="0 0 10 10">
        <rect x="1" y="2" width="5" height="5"/></svg>"#,
    )
    .unwrap();
    let b = boxes(&g);
    assert_eq!(b.len(), 1);
    let want = [12.0, 64.0, 22.0, 74.0, 100.0];
    for k in 0..5 {
        assert!(near(b[0][k], want[k], 1e-3), "{b:?}");
    }
}

#[test]
fn use_and_transforms_are_applied() {
    let g = read_body(
        r##"<defs><rect id="sq" width="10" height="10"/></defs>
        <use href="#sq" x="20" y="20"/>
        <g transform="translate(50 50) rotate(90)"><use href="#sq"/></g>"##,
    )
    .unwrap();
    let b = boxes(&g);
    assert_eq!(b.len(), 2, "{b:?}");
    assert!(
        near(b[0][0], 20.0, 1e-3) && near(b[0][1], 20.0, 1e-3),
        "{b:?}"
    );
    // rotate(90): (x, y) -> (-y, x), so the square spans x 40..50, y 50..60.
    assert!(
        near(b[1][0], 40.0, 1e-3) && near(b[1][1], 50.0, 1e-3),
        "{b:?}"
    );
}

#[test]
fn only_cut_layers_when_one_is_named() {
    let t = format!(
        r#"<svg {MM} xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape">
        <g id="layer1" inkscape:label="Cut"><rect x="10" y="10" width="10" height="10"/></g>
        <g id="bridges"><rect x="30" y="10" width="10" height="10"/></g>
        <g id="outline"><rect x="0" y="0" width="100" height="100" fill="none" stroke="red"/></g>
        </svg>"#
    );
    let g = cut_loops_from_svg(&t, "t.svg").unwrap();
    assert_eq!(boxes(&g).len(), 1, "{:?}", boxes(&g));
    let c = g.cuts.0[0].centroid().unwrap();
    assert!(near(c.x(), 15.0, 1e-3) && near(c.y(), 15.0, 1e-3));
}

#[test]
fn malformed_xml_is_refused_naming_line_and_column() {
    let t =
        format!("<svg {MM}>\n<path d=\"M1 1 L5 1 L5 5 Z\"/></svg>\n<path d=\"M0 0 L9 0 L9 9 Z\"/>");
    let e = cut_loops_from_svg(&t, "x.svg").unwrap_err().to_string();
    assert!(e.starts_with("x.svg:3:1: not well-formed XML"), "{e}");
    let e = cut_loops_from_svg("<svg><g></svg>", "y.svg")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("y.svg:1:") && e.contains("XML"), "{e}");
}

#[test]
fn a_bad_number_is_named_with_its_place() {
    let t = format!("<svg {MM}>\n  <path d=\"M1 1 L5 1 L5x 5 Z\"/></svg>");
    let e = cut_loops_from_svg(&t, "b.svg").unwrap_err().to_string();
    assert!(e.starts_with("b.svg:2:"), "{e}");
    assert!(e.contains("<path> d=") && e.contains("number"), "{e}");
    for (body, what) in [
        (r#"<polygon points="1,1 5,1 5,x"/>"#, "points"),
        (r#"<polygon points="1,1 5,1 5"/>"#, "no y"),
        (r#"<rect x="1" y="1" width="1o" height="5"/>"#, "width"),
        (
            r#"<g transform="rotate(nan)"><rect width="5" height="5"/></g>"#,
            "transform",
        ),
        (
            r#"<g transform="scale(1e308)"><rect width="5" height="5"/></g>"#,
            "out of range",
        ),
        (r#"<path d="M1 1 L1e39 1 L5 5 Z"/>"#, "out of range"),
    ] {
        let e = read_body(body).unwrap_err();
        assert!(e.starts_with("t.svg:1:") && e.contains(what), "{body}: {e}");
    }
}

#[test]
fn coordinates_beyond_the_range_name_the_path() {
    for tr in ["skewX(90)", "scale(1e20)"] {
        let e = read_body(&format!(
            r#"<g transform="{tr}"><path id="p7" d="M1 1 L2 1 L2 2 Z"/></g>"#
        ))
        .unwrap_err();
        assert!(
            e.starts_with("t.svg: <path id=\"p7\"> (path 1): point"),
            "{tr}: {e}"
        );
    }
    assert!(
        read_body(r#"<g transform="rotate(30) skewX(10)"><path d="M1 1 L2 1 L2 2 Z"/></g>"#)
            .is_ok()
    );
}

/// Found by the fuzz: a huge circle flattened at 0.01 mm never ended (and exhausted memory).
#[test]
fn curves_too_large_to_flatten_are_refused_before_flattening() {
    let body: String = (0..200)
        .map(|i| format!(r#"<circle cx="{i}" cy="0" r="5e8"/>"#))
        .collect();
    let e = read_body(&body).unwrap_err();
    assert!(e.contains("flattens to more than"), "{e}");
    let e = read_body(r#"<circle cx="0" cy="0" r="1e29"/>"#).unwrap_err();
    assert!(e.contains("path 1") && e.contains("beyond"), "{e}");
}

#[test]
fn nothing_drawn_is_nothing_to_cut() {
    let e = read_body(r#"<rect width="5" height="5" display="none"/>"#).unwrap_err();
    assert!(e.contains("nothing to cut"), "{e}");
    let e = cut_loops_from_svg("<html/>", "h.svg")
        .unwrap_err()
        .to_string();
    assert!(e.contains("<html>, not <svg>"), "{e}");
}

#[test]
fn nesting_is_bounded_in_the_text_and_through_entities() {
    let nested = |n: usize| {
        format!(
            "{}<rect width=\"5\" height=\"5\"/>{}",
            "<g>".repeat(n),
            "</g>".repeat(n)
        )
    };
    // The <svg> element is the first level.
    assert!(read_body(&nested(MAX_DEPTH - 2)).is_ok());
    let e = read_body(&nested(MAX_DEPTH - 1)).unwrap_err();
    assert!(
        e.starts_with("t.svg:1:") && e.contains("nested more than 256"),
        "{e}"
    );
    // Comments, CDATA and quoted '>' do not confuse the count.
    let tricky = format!(
        "<!-- <g> <g> --><![CDATA[<g><g>]]><g id=\"a>b\">{}</g>",
        nested(MAX_DEPTH - 3)
    );
    assert!(read_body(&tricky).is_ok());
    // Levels an entity adds, which the text does not show.
    let deep = format!(
        "<!DOCTYPE svg [<!ENTITY d \"{}\">]><svg {MM}>{}&d;{}</svg>",
        nested(200).replace('"', "'"),
        "<g>".repeat(100),
        "</g>".repeat(100)
    );
    let e = cut_loops_from_svg(&deep, "e.svg").unwrap_err().to_string();
    assert!(
        e.starts_with("e.svg:") && e.contains("nested more than 256"),
        "{e}"
    );
}

#[test]
fn attributes_are_bounded_per_element() {
    let attrs = |n: usize| (0..n).map(|i| format!(" a{i}='1'")).collect::<String>();
    assert!(read_body(&format!(
        "<rect{} width='5' height='5'/>",
        attrs(MAX_ATTRIBUTES - 2)
    ))
    .is_ok());
    let e = read_body(&format!(
        "<rect{} width='5' height='5'/>",
        attrs(MAX_ATTRIBUTES)
    ))
    .unwrap_err();
    assert!(
        e.contains("<rect> has 1002 attributes; at most 1000"),
        "{e}"
    );
}

#[test]
fn text_and_pictures_are_noted_not_read() {
    let d = read(
        &format!(
            r#"<svg {MM}><rect width="5" height="5"/><text x="1" y="1">hi</text>
            <image href="/etc/passwd" width="5" height="5"/></svg>"#
        ),
        "n.svg",
    )
    .unwrap();
    assert_eq!(d.notes.len(), 2, "{:?}", d.notes);
    assert!(d.notes[0].contains("text") && d.notes[1].contains("picture"));
}

#[test]
fn the_default_namespace_may_be_left_out() {
    let g = cut_loops_from_svg(r#"<svg width="10mm" height="10mm" viewBox="0 0 10 10"><rect x="1" y="1" width="2" height="2"/></svg>"#, "n.svg").unwrap();
    assert!(near(g.cuts.0[0].unsigned_area(), 4.0, 1e-4));
}

fn size_of(w: &str, h: &str) -> Result<(f64, f64), String> {
    let t = format!(r#"<svg width="{w}" height="{h}"><path d="M1 1 L2 1 L2 2 Z"/></svg>"#);
    cut_loops_from_svg(&t, "u.svg")
        .map(|g| (g.outline.width(), g.outline.height()))
        .map_err(|e| e.to_string())
}

#[test]
fn every_absolute_unit_in_any_case_with_exponents() {
    let near = |a: f64, b: f64| (a - b).abs() < 1e-9 * b.max(1.0);
    for (w, mm) in [
        ("1e2mm", 100.0),
        ("100MM", 100.0),
        ("10cm", 100.0),
        ("1E1Cm", 100.0),
        ("400q", 100.0),
        ("2in", 50.8),
        ("72pt", 25.4),
        ("6pc", 25.4),
        ("96px", 25.4),
        ("96", 25.4),
        (" +1.5e+1 mm ", 15.0),
        (".5in", 12.7),
    ] {
        let (a, b) = size_of(w, w).unwrap_or_else(|e| panic!("{w}: {e}"));
        assert!(near(a, mm) && near(b, mm), "{w}: {a} x {b}, want {mm}");
    }
}

#[test]
fn relative_and_unknown_units_and_bad_sizes_are_refused_by_name() {
    for (w, want) in [
        ("50%", "relative (%)"),
        ("10em", "relative (em)"),
        ("5vw", "relative (vw)"),
        ("auto", "not a length"),
        ("10furlongs", "unit 'furlongs'"),
        ("0mm", "more than 0"),
        ("-5mm", "more than 0"),
        ("1e400mm", "more than 0"),
    ] {
        let e = size_of(w, "10mm").unwrap_err();
        assert!(
            e.starts_with("u.svg: width=") && e.contains(want),
            "{w}: {e}"
        );
    }
}

#[test]
fn the_viewbox_frame_and_aspect_are_kept() {
    let g = |attrs: &str| {
        let t = format!(r#"<svg {attrs}><path d="M10 10 L20 10 L20 20 Z"/></svg>"#);
        cut_loops_from_svg(&t, "a.svg")
    };
    // 100 x 100 mm showing a 200 x 100 viewBox: 0.5 mm per unit both ways, centred.
    let b = g(r#"width="100mm" height="100mm" viewBox="0 0 200 100""#).unwrap();
    let r = b.cuts.bounding_rect().unwrap();
    assert!(
        near(r.width(), 5.0, 1e-4) && near(r.height(), 5.0, 1e-4),
        "{r:?}"
    );
    assert!(
        near(r.min().x, 5.0, 1e-4) && near(r.min().y, 5.0, 1e-4),
        "{r:?}"
    );
    assert_eq!((b.outline.min().y, b.outline.max().y), (-25.0, 75.0));
    let c = g(r#"width="100mm" height="100mm" viewBox="0 0 200 100" preserveAspectRatio="none""#)
        .unwrap();
    let r = c.cuts.bounding_rect().unwrap();
    assert!(
        near(r.width(), 5.0, 1e-4) && near(r.height(), 10.0, 1e-4),
        "{r:?}"
    );
    // A viewBox not at the origin: coordinates stay in its frame.
    let d = g(r#"width="14mm" height="12mm" viewBox="-2 -2 14 12""#).unwrap();
    let r = d.cuts.bounding_rect().unwrap();
    assert!(
        near(r.min().x, 10.0, 1e-4) && near(r.min().y, 10.0, 1e-4),
        "{r:?}"
    );
    assert_eq!((d.outline.min().x, d.outline.max().x), (-2.0, 12.0));
    for vb in ["0 0 inf 10", "0 0 10", "0 0 -1 10", "a b c d"] {
        let e = g(&format!(r#"width="10mm" height="10mm" viewBox="{vb}""#)).unwrap_err();
        assert!(e.to_string().contains("viewBox="), "{vb}: {e}");
    }
}

/// A stable-Rust fuzz of the reader: documents built from random shapes, transforms, nested
/// viewports, styles and deliberately broken numbers and tags. Every one must be read, or refused
/// naming the file; what is read must lie in range; a plain grid of squares must come back as
/// drawn. `PROPTEST_CASES=N` runs more.
mod fuzz {
    use super::*;
    use proptest::prelude::*;

    fn number() -> impl Strategy<Value = String> {
        prop_oneof![
            8 => (-200.0f64..200.0).prop_map(|v| format!("{v:.3}")),
            1 => prop::sample::select(vec![
                "1e39", "-1e400", "nan", "inf", "1x", "", ".", "1e", "--1", "0", "1e-300", "1e30",
            ])
            .prop_map(String::from),
        ]
    }

    fn transform() -> impl Strategy<Value = String> {
        prop_oneof![
            3 => Just(String::new()),
            1 => (number(), number()).prop_map(|(a, b)| format!(r#" transform="translate({a} {b})""#)),
            1 => number().prop_map(|a| format!(r#" transform="rotate({a})""#)),
            1 => (number(), number()).prop_map(|(a, b)| format!(r#" transform="scale({a},{b})""#)),
            1 => number().prop_map(|a| format!(r#" transform="skewX({a})""#)),
            1 => Just(r#" transform="matrix(1 2 3)""#.to_string()),
        ]
    }

    fn style() -> impl Strategy<Value = &'static str> {
        prop::sample::select(vec![
            "",
            r#" display="none""#,
            r#" visibility="hidden""#,
            r#" fill="none" stroke="black""#,
            r#" style="display:none""#,
            r#" class="cut""#,
            r#" id="cut7""#,
        ])
    }

    fn shape() -> impl Strategy<Value = String> {
        let path = prop::collection::vec(
            (
                prop::sample::select(vec!["M", "L", "H", "V", "C", "Q", "A", "Z", "l", "c", "x"]),
                prop::collection::vec(number(), 0..7),
            ),
            1..8,
        )
        .prop_map(|segs| {
            let d: Vec<String> = segs
                .into_iter()
                .map(|(c, n)| format!("{c}{}", n.join(" ")))
                .collect();
            format!(r#"<path d="{}""#, d.join(" "))
        });
        let shape = prop_oneof![
            path,
            (number(), number(), number(), number()).prop_map(|(x, y, w, h)| format!(
                r#"<rect x="{x}" y="{y}" width="{w}" height="{h}""#
            )),
            (number(), number(), number())
                .prop_map(|(x, y, r)| format!(r#"<circle cx="{x}" cy="{y}" r="{r}""#)),
            (number(), number(), number(), number())
                .prop_map(|(a, b, c, d)| format!(r#"<line x1="{a}" y1="{b}" x2="{c}" y2="{d}""#)),
            prop::collection::vec(number(), 0..9)
                .prop_map(|p| format!(r#"<polygon points="{}""#, p.join(","))),
        ];
        (shape, transform(), style()).prop_map(|(s, t, st)| format!("{s}{t}{st}/>"))
    }

    fn element(depth: u32) -> BoxedStrategy<String> {
        let leaf = shape().boxed();
        if depth == 0 {
            return leaf;
        }
        prop_oneof![
            3 => leaf,
            1 => (prop::collection::vec(element(depth - 1), 0..4), transform(), style())
                .prop_map(|(kids, t, st)| format!("<g{t}{st}>{}</g>", kids.concat())),
            1 => (prop::collection::vec(element(depth - 1), 0..3), number(), number())
                .prop_map(|(kids, x, w)| format!(r#"<svg x="{x}" width="{w}" height="50" viewBox="0 0 10 10">{}</svg>"#, kids.concat())),
            1 => Just(r##"<defs><rect id="u" width="3" height="3"/></defs><use href="#u" x="5"/>"##.to_string()),
            1 => Just("<g><rect width='1' height='1'></g>".to_string()),
        ]
        .boxed()
    }

    fn in_range(g: &CutLoops) -> bool {
        g.cuts
            .0
            .iter()
            .flat_map(|p| p.exterior().0.iter())
            .chain(g.lines.iter().flat_map(|l| l.0.iter()))
            .all(|c| clip::check_point(c.x, c.y).is_ok())
    }

    proptest! {
        #[test]
        fn any_document_is_read_or_refused_by_name(
            kids in prop::collection::vec(element(3), 0..6),
            size in prop::sample::select(vec![r#"width="100mm" height="80mm""#, r#"width="4in""#, "", r#"width="10%" height="1""#]),
            vb in prop::sample::select(vec![r#" viewBox="0 0 100 80""#, "", r#" viewBox="0 0 0 1""#]),
        ) {
            let t = format!(r#"<svg xmlns="http://www.w3.org/2000/svg" {size}{vb}>{}</svg>"#, kids.concat());
            match read(&t, "f.svg") {
                Ok(d) => prop_assert!(in_range(&d.geometry), "{t}"),
                Err(e) => prop_assert!(e.to_string().starts_with("f.svg:"), "{e}"),
            }
        }

        #[test]
        fn a_grid_of_squares_comes_back_as_drawn(n in 1usize..40, s in 0.5f64..5.0) {
            let body: String = (0..n)
                .map(|i| format!(r#"<rect x="{}" y="{}" width="{s}" height="{s}"/>"#, (i % 7) as f64 * 10.0, (i / 7) as f64 * 10.0))
                .collect();
            let g = cut_loops_from_svg(&format!(r#"<svg width="100mm" height="100mm" viewBox="0 0 100 100">{body}</svg>"#), "g.svg").unwrap();
            prop_assert_eq!(g.cuts.0.len(), n);
            let total: f64 = g.cuts.0.iter().map(|p| p.unsigned_area()).sum();
            prop_assert!((total - n as f64 * s * s).abs() < 1e-3 * n as f64, "{total}");
        }
    }
}
