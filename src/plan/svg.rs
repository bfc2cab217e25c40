//! Cut geometry back from an SVG (`stencil gcode job.svg`): straight-line path data only.
//!
//! Reads our own `stencil.svg` (paths of `M`/`L`/`H`/`V`/`Z`, width and height in mm with a viewBox
//! in mm) and the same subset from other tools. If any element's `id` or `class` mentions "cut",
//! only paths inside such elements are cut (so preview layers such as bridges or material are
//! skipped); otherwise every path is. `transform` attributes (matrix, translate, scale, rotate,
//! skewX, skewY, as Inkscape writes on layers) are applied; paths inside `<defs>`, clip paths,
//! masks, markers, patterns and symbols are not cut. Curves and arcs are refused with a message
//! naming them, rather than cut wrongly.

use geo::{Coord, LineString, MultiPolygon, Polygon, Rect};
use svg::node::element::path::{Command, Data, Position};
use svg::node::element::tag::Type;
use svg::parser::Event;

use crate::vector::CutGeometry;

#[derive(Debug, thiserror::Error)]
pub enum SvgError {
    #[error("{file}: {msg}")]
    Bad { file: String, msg: String },
}

/// A length attribute in mm: `12mm`, `1.2cm`, `2in`, `10pt`, `96px` or a bare number (CSS px).
fn length_mm(v: &str) -> Option<f64> {
    let v = v.trim();
    let split = v
        .find(|c: char| c.is_ascii_alphabetic() || c == '%')
        .unwrap_or(v.len());
    let (n, unit) = v.split_at(split);
    let n: f64 = n.trim().parse().ok()?;
    let f = match unit.trim() {
        "mm" => 1.0,
        "cm" => 10.0,
        "in" => 25.4,
        "pt" => 25.4 / 72.0,
        "pc" => 25.4 / 6.0,
        "" | "px" => 25.4 / 96.0,
        _ => return None,
    };
    Some(n * f)
}

/// A 2-D affine map `[a, b, c, d, e, f]`: x' = a·x + c·y + e, y' = b·x + d·y + f (SVG's matrix).
type Affine = [f64; 6];
const IDENTITY: Affine = [1.0, 0.0, 0.0, 1.0, 0.0, 0.0];

/// `m ∘ n`: apply `n` first, then `m`.
fn compose(m: &Affine, n: &Affine) -> Affine {
    [
        m[0] * n[0] + m[2] * n[1],
        m[1] * n[0] + m[3] * n[1],
        m[0] * n[2] + m[2] * n[3],
        m[1] * n[2] + m[3] * n[3],
        m[0] * n[4] + m[2] * n[5] + m[4],
        m[1] * n[4] + m[3] * n[5] + m[5],
    ]
}

fn apply(m: &Affine, p: [f64; 2]) -> [f64; 2] {
    [
        m[0] * p[0] + m[2] * p[1] + m[4],
        m[1] * p[0] + m[3] * p[1] + m[5],
    ]
}

/// Parse an SVG transform list, e.g. `translate(10,20) rotate(45 5 5)`.
fn parse_transform(t: &str) -> Result<Affine, String> {
    let mut m = IDENTITY;
    let mut rest = t.trim();
    while !rest.is_empty() {
        let open = rest
            .find('(')
            .ok_or_else(|| format!("bad transform '{t}'"))?;
        let close = rest[open..]
            .find(')')
            .map(|c| open + c)
            .ok_or_else(|| format!("bad transform '{t}'"))?;
        let name = rest[..open].trim().trim_start_matches(',').trim();
        let args: Vec<f64> = rest[open + 1..close]
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .map(|s| s.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("bad numbers in transform '{t}'"))?;
        let n = args.len();
        let f: Affine = match (name, n) {
            ("matrix", 6) => [args[0], args[1], args[2], args[3], args[4], args[5]],
            ("translate", 1 | 2) => [
                1.0,
                0.0,
                0.0,
                1.0,
                args[0],
                if n == 2 { args[1] } else { 0.0 },
            ],
            ("scale", 1 | 2) => [
                args[0],
                0.0,
                0.0,
                if n == 2 { args[1] } else { args[0] },
                0.0,
                0.0,
            ],
            ("rotate", 1 | 3) => {
                let (s, c) = args[0].to_radians().sin_cos();
                let r = [c, s, -s, c, 0.0, 0.0];
                if n == 3 {
                    let (cx, cy) = (args[1], args[2]);
                    compose(
                        &compose(&[1.0, 0.0, 0.0, 1.0, cx, cy], &r),
                        &[1.0, 0.0, 0.0, 1.0, -cx, -cy],
                    )
                } else {
                    r
                }
            }
            ("skewX", 1) => [1.0, 0.0, args[0].to_radians().tan(), 1.0, 0.0, 0.0],
            ("skewY", 1) => [1.0, args[0].to_radians().tan(), 0.0, 1.0, 0.0, 0.0],
            _ => {
                return Err(format!(
                    "unsupported transform '{name}' with {n} numbers in '{t}'"
                ))
            }
        };
        m = compose(&m, &f);
        rest = rest[close + 1..].trim_start();
    }
    Ok(m)
}

/// Elements whose paths are never drawn directly.
const HIDDEN: &[&str] = &["defs", "clipPath", "mask", "marker", "pattern", "symbol"];

fn mentions_cut(attrs: &svg::node::Attributes) -> bool {
    ["id", "class", "inkscape:label"].iter().any(|k| {
        attrs
            .get(*k)
            .is_some_and(|v| v.to_ascii_lowercase().contains("cut"))
    })
}

/// Rings of one path's data, in user units.
fn rings(data: &Data, file: &str) -> Result<Vec<Vec<[f64; 2]>>, SvgError> {
    let bad = |msg: String| SvgError::Bad {
        file: file.to_string(),
        msg,
    };
    let mut out = Vec::new();
    let mut cur: Vec<[f64; 2]> = Vec::new();
    let mut pos = [0.0f64, 0.0];
    let mut start = pos;
    for cmd in data.iter() {
        match cmd {
            Command::Move(p, params) => {
                if cur.len() > 1 {
                    out.push(std::mem::take(&mut cur));
                }
                cur.clear();
                for (k, xy) in params.chunks(2).enumerate() {
                    let [x, y] = [xy[0] as f64, *xy.get(1).unwrap_or(&0.0) as f64];
                    pos = match p {
                        Position::Absolute => [x, y],
                        Position::Relative => [pos[0] + x, pos[1] + y],
                    };
                    if k == 0 {
                        start = pos;
                    }
                    cur.push(pos); // extra pairs after M are line-tos
                }
            }
            Command::Line(p, params) => {
                for xy in params.chunks(2) {
                    let [x, y] = [xy[0] as f64, *xy.get(1).unwrap_or(&0.0) as f64];
                    pos = match p {
                        Position::Absolute => [x, y],
                        Position::Relative => [pos[0] + x, pos[1] + y],
                    };
                    cur.push(pos);
                }
            }
            Command::HorizontalLine(p, params) => {
                for &x in params.iter() {
                    pos[0] = match p {
                        Position::Absolute => x as f64,
                        Position::Relative => pos[0] + x as f64,
                    };
                    cur.push(pos);
                }
            }
            Command::VerticalLine(p, params) => {
                for &y in params.iter() {
                    pos[1] = match p {
                        Position::Absolute => y as f64,
                        Position::Relative => pos[1] + y as f64,
                    };
                    cur.push(pos);
                }
            }
            Command::Close => {
                if cur.len() > 2 {
                    out.push(std::mem::take(&mut cur));
                }
                cur.clear();
                pos = start;
                cur.push(pos);
            }
            other => {
                let name = match other {
                    Command::CubicCurve(..) | Command::SmoothCubicCurve(..) => "C/S (cubic curve)",
                    Command::QuadraticCurve(..) | Command::SmoothQuadraticCurve(..) => {
                        "Q/T (quadratic curve)"
                    }
                    _ => "A (arc)",
                };
                return Err(bad(format!(
                    "path data uses {name}; only straight segments (M, L, H, V, Z) are supported: \
                     convert curves to lines first (e.g. Inkscape: Extensions > Modify Path > Flatten)"
                )));
            }
        }
    }
    if cur.len() > 2 {
        out.push(cur); // an unclosed subpath is cut as a closed loop
    }
    Ok(out)
}

/// Parse SVG text into cut geometry in mm (y down, origin top-left). `file` names it in errors.
pub fn cut_geometry_from_svg(text: &str, file: &str) -> Result<CutGeometry, SvgError> {
    let bad = |msg: String| SvgError::Bad {
        file: file.to_string(),
        msg,
    };
    let mut size_mm: Option<[f64; 2]> = None;
    // user unit → mm, and the sheet (the viewBox, or the whole canvas) in user units.
    let mut scale = [25.4 / 96.0; 2];
    let mut view = [0.0, 0.0, 0.0, 0.0];
    // Open elements: whether each is (inside) a "cut" element, hidden, and its transform.
    let mut stack: Vec<(bool, bool, Affine)> = Vec::new();
    let mut all: Vec<(bool, Vec<Vec<[f64; 2]>>)> = Vec::new();
    for ev in svg::read(text).map_err(|e| bad(e.to_string()))? {
        match ev {
            Event::Error(e) => return Err(bad(format!("not valid SVG: {e}"))),
            Event::Tag(name, ty, attrs) => {
                let (inside_cut, inside_hidden, parent) =
                    stack.last().copied().unwrap_or((false, false, IDENTITY));
                let here_cut = inside_cut || mentions_cut(&attrs);
                let hidden = inside_hidden || HIDDEN.contains(&name);
                let here = match attrs.get("transform") {
                    Some(t) if matches!(ty, Type::Start | Type::Empty) => {
                        let own = parse_transform(t).map_err(|e| bad(format!("<{name}>: {e}")))?;
                        compose(&parent, &own)
                    }
                    _ => parent,
                };
                if name == "svg" && matches!(ty, Type::Start | Type::Empty) && size_mm.is_none() {
                    let w = attrs.get("width").and_then(|v| length_mm(v));
                    let h = attrs.get("height").and_then(|v| length_mm(v));
                    let vb: Option<Vec<f64>> = attrs.get("viewBox").map(|v| {
                        v.split(|c: char| c == ',' || c.is_whitespace())
                            .filter(|s| !s.is_empty())
                            .filter_map(|s| s.parse().ok())
                            .collect()
                    });
                    let vb = vb.filter(|v| v.len() == 4 && v[2] > 0.0 && v[3] > 0.0);
                    let (w, h) = match (w, h, &vb) {
                        (Some(w), Some(h), _) => (w, h),
                        (_, _, Some(v)) => (v[2] * 25.4 / 96.0, v[3] * 25.4 / 96.0),
                        _ => {
                            return Err(bad(
                                "the <svg> element has neither width/height nor a viewBox".into(),
                            ))
                        }
                    };
                    if !(w > 0.0 && h > 0.0) {
                        return Err(bad(format!("the <svg> size {w} x {h} mm is not positive")));
                    }
                    match &vb {
                        Some(v) => {
                            scale = [w / v[2], h / v[3]];
                            view = [v[0], v[1], v[0] + v[2], v[1] + v[3]];
                        }
                        None => view = [0.0, 0.0, w / scale[0], h / scale[1]],
                    }
                    size_mm = Some([w, h]);
                }
                if name == "path" && !hidden && matches!(ty, Type::Start | Type::Empty) {
                    if let Some(d) = attrs.get("d") {
                        let data =
                            Data::parse(d).map_err(|e| bad(format!("bad path data: {e}")))?;
                        let mut rs = rings(&data, file)?;
                        for r in &mut rs {
                            r.iter_mut().for_each(|p| *p = apply(&here, *p));
                        }
                        all.push((here_cut, rs));
                    }
                }
                match ty {
                    Type::Start => stack.push((here_cut, hidden, here)),
                    Type::End => {
                        stack.pop();
                    }
                    Type::Empty => {}
                }
            }
            _ => {}
        }
    }
    let [w, h] = size_mm.ok_or_else(|| bad("no <svg> element".into()))?;
    let any_cut = all.iter().any(|(c, _)| *c);
    let to_mm = |p: [f64; 2]| (p[0] * scale[0], p[1] * scale[1]);
    let polys: Vec<Polygon<f64>> = all
        .into_iter()
        .filter(|(c, _)| *c || !any_cut)
        .flat_map(|(_, rs)| rs)
        .map(|r| {
            Polygon::new(
                LineString::from(r.into_iter().map(to_mm).collect::<Vec<_>>()),
                vec![],
            )
        })
        .collect();
    if polys.is_empty() {
        return Err(bad(
            "no closed paths to cut (expected <path d=\"M ... Z\"> elements)".into(),
        ));
    }
    let cuts = MultiPolygon(polys);
    // The SVG knows the sheet only: the picture is taken to be the whole sheet. The cuts are as
    // drawn (our SVG carries the design line; `stencil gcode` applies the material's kerf).
    let outline = Rect::new(
        Coord {
            x: view[0] * scale[0],
            y: view[1] * scale[1],
        },
        Coord {
            x: view[2] * scale[0],
            y: view[3] * scale[1],
        },
    );
    Ok(CutGeometry::from_cuts(w, h, outline, cuts))
}

#[cfg(test)]
mod tests {
    use super::*;
    use geo::Area;

    #[test]
    fn reads_mm_viewbox_and_hv_relative_commands() {
        let svg = r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="50mm" viewBox="0 0 200 100">
  <g id="bridges"><path d="M0 0 L10 0 L10 10 Z"/></g>
  <g id="cuts"><path d="M 20 20 H 60 V 40 H 20 Z m 100 0 h 10 v 10 h -10 z"/></g>
</svg>"#;
        let g = cut_geometry_from_svg(svg, "t.svg").unwrap();
        assert_eq!((g.width_mm, g.height_mm), (100.0, 50.0));
        assert_eq!(g.cuts.0.len(), 2, "bridges layer skipped");
        // 40 x 20 user units at 0.5 mm/unit = 20 x 10 mm; 10 x 10 units = 5 x 5 mm.
        assert!((g.cuts.0[0].unsigned_area() - 200.0).abs() < 1e-6);
        assert!((g.cuts.0[1].unsigned_area() - 25.0).abs() < 1e-6);
        let first = g.cuts.0[1].exterior().0[0];
        assert_eq!((first.x, first.y), (60.0, 10.0));
        let o = g.outline;
        assert_eq!(
            (o.min().x, o.min().y, o.max().x, o.max().y),
            (0.0, 0.0, 100.0, 50.0)
        );
    }

    #[test]
    fn reads_our_own_svg_back() {
        let ring = |x0: f64, y0: f64, x1: f64, y1: f64| {
            Polygon::new(
                LineString::from(vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)]),
                vec![],
            )
        };
        let cuts = MultiPolygon(vec![ring(1.0, 1.0, 4.0, 3.0), ring(6.0, 2.0, 9.5, 7.25)]);
        let geom = CutGeometry {
            width_mm: 10.0,
            height_mm: 8.0,
            outline: Rect::new(Coord { x: -2.0, y: -2.0 }, Coord { x: 12.0, y: 10.0 }),
            cuts: cuts.clone(),
            design_cuts: cuts,
            material: MultiPolygon(vec![]),
            bridges: vec![ring(4.0, 1.5, 6.0, 2.5)],
        };
        let text = String::from_utf8(crate::export::svg::encode(&geom)).unwrap();
        let back = cut_geometry_from_svg(&text, "stencil.svg").unwrap();
        assert_eq!(back.outline, geom.outline);
        assert_eq!(back.cuts.0.len(), 2, "the bridges layer is not cut");
        for (a, b) in back.cuts.0.iter().zip(&geom.design_cuts.0) {
            assert!((a.unsigned_area() - b.unsigned_area()).abs() < 1e-9);
            let (p, q) = (a.exterior().0[0], b.exterior().0[0]);
            assert!((p.x - q.x).abs() < 1e-6 && (p.y - q.y).abs() < 1e-6);
        }
    }

    #[test]
    fn transforms_apply_and_defs_are_skipped() {
        let t = r#"<svg width="100mm" height="100mm" viewBox="0 0 100 100">
<defs><path d="M0 0 L50 0 L50 50 Z"/></defs>
<g transform="translate(10,20)"><g transform="scale(2) rotate(90)">
<path d="M0 0 L5 0 L5 1 Z" transform="translate(1 0)"/></g></g></svg>"#;
        let g = cut_geometry_from_svg(t, "t.svg").unwrap();
        assert_eq!(g.cuts.0.len(), 1, "the path in <defs> is not cut");
        // (0,0) → translate(1 0): (1,0) → rotate 90°: (0,1) → scale 2: (0,2) → translate: (10,22).
        let pts: Vec<(f64, f64)> = g.cuts.0[0]
            .exterior()
            .0
            .iter()
            .map(|c| (c.x, c.y))
            .collect();
        let want = [(10.0, 22.0), (10.0, 32.0), (8.0, 32.0)];
        for (p, w) in pts.iter().zip(want) {
            assert!(
                (p.0 - w.0).abs() < 1e-9 && (p.1 - w.1).abs() < 1e-9,
                "{pts:?}"
            );
        }
        let bad = r#"<svg width="10mm" height="10mm"><g transform="perspective(2)"><path d="M0 0 L1 0 L1 1 Z"/></g></svg>"#;
        let e = cut_geometry_from_svg(bad, "b.svg").unwrap_err().to_string();
        assert!(e.contains("perspective"), "{e}");
    }

    #[test]
    fn curves_are_refused() {
        let c = r#"<svg width="10mm" height="10mm"><path d="M0 0 C1 1 2 2 3 3 Z"/></svg>"#;
        let e = cut_geometry_from_svg(c, "c.svg").unwrap_err().to_string();
        assert!(e.starts_with("c.svg:") && e.contains("cubic"), "{e}");
        let n = r#"<svg width="10mm" height="10mm"></svg>"#;
        assert!(cut_geometry_from_svg(n, "n.svg").is_err());
    }
}
