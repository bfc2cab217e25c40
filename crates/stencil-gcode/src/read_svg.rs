//! Cut geometry back from an SVG (`stencil gcode job.svg`): straight-line path data only.
//!
//! Reads our own `stencil.svg` (paths of `M`/`L`/`H`/`V`/`Z`, width and height in mm with a viewBox
//! in mm) and the same subset from other tools. Width and height may be in any absolute CSS unit
//! (mm, cm, Q, in, pt, pc, px; any case, with exponents); relative ones (%, em, ...) are refused,
//! and the viewBox is fitted as `preserveAspectRatio` says (centred, uniform, by default). Every
//! coordinate must come out finite and within the range the later stages compute in. If any element's `id` or `class` mentions "cut",
//! only paths inside such elements are cut (so preview layers such as bridges or material are
//! skipped); otherwise every path is. `transform` attributes (matrix, translate, scale, rotate,
//! skewX, skewY, as Inkscape writes on layers) are applied; paths inside `<defs>`, clip paths,
//! masks, markers, patterns and symbols are not cut. Curves and arcs are refused with a message
//! naming them, rather than cut wrongly.

use geo::{Coord, LineString, MultiPolygon, Polygon, Rect};
use svg::node::element::path::{Command, Data, Position};
use svg::node::element::tag::Type;
use svg::parser::Event;

use stencil_geom::clip;
use stencil_io::excerpt;

use crate::cuts::CutLoops;

#[derive(Debug, thiserror::Error)]
pub enum SvgError {
    #[error("{file}: {msg}")]
    Bad { file: String, msg: String },
}

/// CSS's absolute units (the only ones SVG allows for a size in the real world), in mm.
const UNITS_MM: &[(&str, f64)] = &[
    ("mm", 1.0),
    ("cm", 10.0),
    ("q", 0.25),
    ("in", 25.4),
    ("pt", 25.4 / 72.0),
    ("pc", 25.4 / 6.0),
    ("px", 25.4 / 96.0),
    ("", 25.4 / 96.0),
];

/// Units that are lengths only relative to something an SVG file alone does not fix.
const RELATIVE_UNITS: &[&str] = &[
    "%", "em", "ex", "ch", "rem", "vw", "vh", "vmin", "vmax", "lh", "rlh", "cap", "ic", "rcap",
    "rch", "rex", "ric",
];

/// Split a CSS number from what follows it: `1e2mm` is 1e2 and `mm`, `1em` is 1 and `em`.
fn split_number(v: &str) -> (&str, &str) {
    let b = v.as_bytes();
    let digits = |mut i: usize| {
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        i
    };
    let mut i = 0;
    if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
        i += 1;
    }
    i = digits(i);
    if i < b.len() && b[i] == b'.' {
        i = digits(i + 1);
    }
    // An exponent only when digits follow (else the `e` starts a unit, as in `em` or `ex`).
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        let mut j = i + 1;
        if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
            j += 1;
        }
        if j < b.len() && b[j].is_ascii_digit() {
            i = digits(j);
        }
    }
    v.split_at(i)
}

/// A length attribute (`width`, `height`) in mm: a number with an absolute CSS unit (mm, cm, Q,
/// in, pt, pc, px or none, which is px; any case, exponents allowed). Relative units (%, em, ex,
/// ...) have no size without a page around the picture, so they are refused, not guessed.
fn length_mm(attr: &str, v: &str) -> Result<f64, String> {
    let t = v.trim();
    let (n, unit) = split_number(t);
    let unit = unit.trim().to_ascii_lowercase();
    let n: f64 = n.parse().map_err(|_| {
        format!(
            "{attr}=\"{}\" is not a length: give a number and a unit, e.g. 100mm",
            excerpt(v)
        )
    })?;
    if RELATIVE_UNITS.contains(&unit.as_str()) {
        return Err(format!(
            "{attr}=\"{}\" is relative ({unit}) and gives the drawing no physical size: set \
             width and height in mm, cm, in, pt, pc or px (e.g. in Inkscape: Document Properties)",
            excerpt(v)
        ));
    }
    let f = UNITS_MM
        .iter()
        .find(|(u, _)| *u == unit)
        .map(|(_, f)| *f)
        .ok_or_else(|| {
            format!(
                "{attr}=\"{}\" has the unit '{}', which is not a length: use mm, cm, Q, in, \
                 pt, pc or px",
                excerpt(v),
                excerpt(&unit)
            )
        })?;
    let mm = n * f;
    if !(mm.is_finite() && mm > 0.0) {
        return Err(format!(
            "{attr}=\"{}\" is not a size: it must be more than 0",
            excerpt(v)
        ));
    }
    Ok(mm)
}

/// Numbers separated by commas and/or spaces, each finite.
fn numbers(v: &str) -> Option<Vec<f64>> {
    v.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect()
}

/// How the viewBox fits the viewport (`preserveAspectRatio`): the fraction of the spare room
/// left of and above the drawing, and whether it is scaled to cover (`slice`) rather than fit
/// (`meet`); `None` for `none` (stretched to fill).
fn aspect(v: Option<&str>) -> Result<Option<([f64; 2], bool)>, String> {
    let v = v.unwrap_or("xMidYMid meet").trim();
    let mut words = v.split_whitespace();
    let align = words.next().unwrap_or("xMidYMid");
    if align == "none" {
        return Ok(None);
    }
    let frac = |s: &str| match s {
        "Min" => Some(0.0),
        "Mid" => Some(0.5),
        "Max" => Some(1.0),
        _ => None,
    };
    let bad = || format!("preserveAspectRatio=\"{}\" is not understood", excerpt(v));
    let (fx, fy) = match (align.get(..1), align.get(4..5)) {
        (Some("x"), Some("Y")) => (
            frac(align.get(1..4).unwrap_or("")).ok_or_else(bad)?,
            frac(align.get(5..).unwrap_or("")).ok_or_else(bad)?,
        ),
        _ => return Err(bad()),
    };
    let slice = match words.next() {
        None | Some("meet") => false,
        Some("slice") => true,
        Some(_) => return Err(bad()),
    };
    Ok(Some(([fx, fy], slice)))
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
            .ok_or_else(|| format!("bad transform '{}'", excerpt(t)))?;
        let close = rest[open..]
            .find(')')
            .map(|c| open + c)
            .ok_or_else(|| format!("bad transform '{}'", excerpt(t)))?;
        let name = rest[..open].trim().trim_start_matches(',').trim();
        let args: Vec<f64> = rest[open + 1..close]
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .map(|s| s.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or(()))
            .collect::<Result<_, _>>()
            .map_err(|_| {
                format!(
                    "transform '{}' holds a number that is not finite",
                    excerpt(t)
                )
            })?;
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
                    "unsupported transform '{}' with {n} numbers in '{}'",
                    excerpt(name),
                    excerpt(t)
                ))
            }
        };
        m = compose(&m, &f);
        if m.iter().any(|v| !v.is_finite()) {
            return Err(format!(
                "transform '{}' does not give finite coordinates",
                excerpt(t)
            ));
        }
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

/// Closed rings of points.
type Rings = Vec<Vec<[f64; 2]>>;

/// Rings of one path's data, in user units.
fn rings(data: &Data, file: &str) -> Result<Rings, SvgError> {
    let mut pen = Pen::default();
    for cmd in data.iter() {
        match cmd {
            Command::Move(p, params) => pen.move_to(p, params),
            Command::Line(p, params) => {
                for xy in params.chunks(2) {
                    pen.line_to(p, xy);
                }
            }
            Command::HorizontalLine(p, params) => {
                for &x in params.iter() {
                    pen.pos[0] = along(p, pen.pos[0], x);
                    pen.cur.push(pen.pos);
                }
            }
            Command::VerticalLine(p, params) => {
                for &y in params.iter() {
                    pen.pos[1] = along(p, pen.pos[1], y);
                    pen.cur.push(pen.pos);
                }
            }
            Command::Close => pen.close(),
            other => {
                return Err(SvgError::Bad {
                    file: file.to_string(),
                    msg: format!(
                        "path data uses {}; only straight segments (M, L, H, V, Z) are \
                         supported: convert curves to lines first (e.g. Inkscape: Extensions > \
                         Modify Path > Flatten)",
                        curve_name(other)
                    ),
                })
            }
        }
    }
    if pen.cur.len() > 2 {
        pen.out.push(pen.cur); // an unclosed subpath is cut as a closed loop
    }
    Ok(pen.out)
}

/// The state of drawing one path's data: the rings finished, the subpath being drawn, the
/// current point and where the subpath started (where `Z` returns to).
#[derive(Default)]
struct Pen {
    out: Rings,
    cur: Vec<[f64; 2]>,
    pos: [f64; 2],
    start: [f64; 2],
}

impl Pen {
    /// `M`/`m`: end the subpath (kept if it has a segment) and start one; extra pairs after the
    /// first are line-tos, as SVG says.
    fn move_to(&mut self, p: &Position, params: &[f32]) {
        if self.cur.len() > 1 {
            self.out.push(std::mem::take(&mut self.cur));
        }
        self.cur.clear();
        for (k, xy) in params.chunks(2).enumerate() {
            self.line_to(p, xy);
            if k == 0 {
                self.start = self.pos;
            }
        }
    }

    /// `L`/`l` with one coordinate pair (a missing y reads as 0).
    fn line_to(&mut self, p: &Position, xy: &[f32]) {
        self.pos = [
            along(p, self.pos[0], xy[0]),
            along(p, self.pos[1], *xy.get(1).unwrap_or(&0.0)),
        ];
        self.cur.push(self.pos);
    }

    /// `Z`: the subpath is a ring if it has an area's worth of points; drawing goes on from where
    /// it started.
    fn close(&mut self) {
        if self.cur.len() > 2 {
            self.out.push(std::mem::take(&mut self.cur));
        }
        self.cur.clear();
        self.pos = self.start;
        self.cur.push(self.pos);
    }
}

/// One coordinate after a command: `v` itself if absolute, `from + v` if relative.
fn along(p: &Position, from: f64, v: f32) -> f64 {
    match p {
        Position::Absolute => v as f64,
        Position::Relative => from + v as f64,
    }
}

/// The name of a path command the reader refuses, for the message (curves and arcs).
fn curve_name(cmd: &Command) -> &'static str {
    match cmd {
        Command::CubicCurve(..) | Command::SmoothCubicCurve(..) => "C/S (cubic curve)",
        Command::QuadraticCurve(..) | Command::SmoothQuadraticCurve(..) => "Q/T (quadratic curve)",
        _ => "A (arc)",
    }
}

/// The outermost `<svg>`'s size and coordinate system.
struct Sheet {
    /// User unit → mm along x and y.
    scale: [f64; 2],
    /// The viewport in the frame the paths are read into (user units times `scale`): the viewBox's
    /// origin stays where it is, so our own SVG reads back in its own coordinates.
    outline: [f64; 4],
}

/// Read the `<svg>` element's `width`, `height`, `viewBox` and `preserveAspectRatio`. A size
/// given only as a viewBox is taken in px (96 per inch), as drawing programs write it; one of
/// width and height alone takes the other from the viewBox's shape.
fn sheet(attrs: &svg::node::Attributes) -> Result<Sheet, String> {
    let w = attrs
        .get("width")
        .map(|v| length_mm("width", v))
        .transpose()?;
    let h = attrs
        .get("height")
        .map(|v| length_mm("height", v))
        .transpose()?;
    let vb = match attrs.get("viewBox") {
        None => None,
        Some(v) => match numbers(v) {
            Some(n) if n.len() == 4 && n[2] > 0.0 && n[3] > 0.0 => Some([n[0], n[1], n[2], n[3]]),
            _ => {
                return Err(format!(
                    "viewBox=\"{}\" is not four finite numbers (x, y, width, height) with a \
                     width and height above 0",
                    excerpt(v)
                ))
            }
        },
    };
    let px = 25.4 / 96.0;
    let (w, h) = match (w, h, vb) {
        (Some(w), Some(h), _) => (w, h),
        (Some(w), None, Some(v)) => (w, w * v[3] / v[2]),
        (None, Some(h), Some(v)) => (h * v[2] / v[3], h),
        (None, None, Some(v)) => (v[2] * px, v[3] * px),
        (Some(_), None, None) | (None, Some(_), None) => {
            return Err(
                "the <svg> element gives only one of width and height, and no viewBox \
                        to take the other from: give both"
                    .into(),
            )
        }
        (None, None, None) => {
            return Err("the <svg> element has neither width/height nor a viewBox".into())
        }
    };
    let Some(v) = vb else {
        return Ok(Sheet {
            scale: [px, px],
            outline: [0.0, 0.0, w, h],
        });
    };
    let par = aspect(attrs.get("preserveAspectRatio").map(|v| &v[..]))?;
    let (sx, sy) = (w / v[2], h / v[3]);
    let (scale, shift) = match par {
        None => ([sx, sy], [0.0, 0.0]),
        Some((frac, slice)) => {
            let s = if slice { sx.max(sy) } else { sx.min(sy) };
            ([s, s], [(w - v[2] * s) * frac[0], (h - v[3] * s) * frac[1]])
        }
    };
    // The viewport (0..w, 0..h once the viewBox is fitted) in the user frame times the scale.
    let (x0, y0) = (v[0] * scale[0] - shift[0], v[1] * scale[1] - shift[1]);
    let sheet = Sheet {
        scale,
        outline: [x0, y0, x0 + w, y0 + h],
    };
    for c in sheet.outline.chunks(2) {
        clip::check_point(c[0], c[1]).map_err(|e| format!("the <svg> element's viewport: {e}"))?;
    }
    Ok(sheet)
}

/// Parse SVG text into cut loops in mm (y down, origin top-left), as drawn (no kerf), nothing
/// known of the pieces. `file` names it in errors.
pub fn cut_loops_from_svg(text: &str, file: &str) -> Result<CutLoops, SvgError> {
    let bad = |msg: String| SvgError::Bad {
        file: file.to_string(),
        msg,
    };
    let (found, all) = drawn_paths(text, file)?;
    let sheet = found.ok_or_else(|| bad("no <svg> element".into()))?;
    let cuts = MultiPolygon(cut_polygons(all, &sheet, file)?);
    // The SVG knows the sheet only: the picture is taken to be the whole sheet. The cuts are as
    // drawn (our SVG carries the design line; `stencil gcode` applies the material's kerf).
    let o = sheet.outline;
    let outline = Rect::new(Coord { x: o[0], y: o[1] }, Coord { x: o[2], y: o[3] });
    Ok(CutLoops::drawn(outline, cuts))
}

/// One drawn `<path>`: whether it is inside a "cut" element, its name for messages, and its
/// rings in the document's user units (its transforms applied).
type DrawnPath = (bool, String, Rings);

/// Walk the document: the outermost `<svg>`'s sheet (if any) and every path that is drawn (not
/// inside `<defs>` and the like), with the transforms of the elements around it applied.
fn drawn_paths(text: &str, file: &str) -> Result<(Option<Sheet>, Vec<DrawnPath>), SvgError> {
    let bad = |msg: String| SvgError::Bad {
        file: file.to_string(),
        msg,
    };
    let mut found: Option<Sheet> = None;
    // Open elements: whether each is (inside) a "cut" element, hidden, and its transform.
    let mut stack: Vec<(bool, bool, Affine)> = Vec::new();
    let mut all: Vec<DrawnPath> = Vec::new();
    let mut paths = 0usize;
    for ev in svg::read(text).map_err(|e| bad(e.to_string()))? {
        let (name, ty, attrs) = match ev {
            Event::Error(e) => return Err(bad(format!("not valid SVG: {e}"))),
            Event::Tag(name, ty, attrs) => (name, ty, attrs),
            _ => continue,
        };
        let opens = matches!(ty, Type::Start | Type::Empty);
        let (inside_cut, inside_hidden, parent) =
            stack.last().copied().unwrap_or((false, false, IDENTITY));
        let here_cut = inside_cut || mentions_cut(&attrs);
        let hidden = inside_hidden || HIDDEN.contains(&name);
        let here = match attrs.get("transform") {
            Some(t) if opens => {
                let own = parse_transform(t).map_err(|e| bad(format!("<{name}>: {e}")))?;
                compose(&parent, &own)
            }
            _ => parent,
        };
        if name == "svg" && opens && found.is_none() {
            found = Some(sheet(&attrs).map_err(bad)?);
        }
        if name == "path" && opens {
            paths += 1;
        }
        if name == "path" && !hidden && opens {
            if let Some(d) = attrs.get("d") {
                let label = match attrs.get("id") {
                    Some(id) => format!("<path id=\"{}\"> (path {paths})", excerpt(id)),
                    None => format!("path {paths}"),
                };
                let data =
                    Data::parse(d).map_err(|e| bad(format!("{label}: bad path data: {e}")))?;
                let mut rs = rings(&data, file)?;
                for r in &mut rs {
                    r.iter_mut().for_each(|p| *p = apply(&here, *p));
                }
                all.push((here_cut, label, rs));
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
    Ok((found, all))
}

/// The paths to cut as polygons in mm: only those inside a "cut" element if any is, else all
/// (so that preview layers of our own SVG are skipped). Every point is checked to be finite and
/// in range, since every later stage computes with them.
fn cut_polygons(
    all: Vec<DrawnPath>,
    sheet: &Sheet,
    file: &str,
) -> Result<Vec<Polygon<f64>>, SvgError> {
    let bad = |msg: String| SvgError::Bad {
        file: file.to_string(),
        msg,
    };
    let any_cut = all.iter().any(|(c, _, _)| *c);
    let to_mm = |p: [f64; 2]| (p[0] * sheet.scale[0], p[1] * sheet.scale[1]);
    let mut polys: Vec<Polygon<f64>> = Vec::new();
    for (_, label, rs) in all.into_iter().filter(|(c, _, _)| *c || !any_cut) {
        for r in rs {
            let ring = LineString::from(r.into_iter().map(to_mm).collect::<Vec<_>>());
            clip::check_rings([&ring]).map_err(|e| bad(format!("{label}: {e}")))?;
            polys.push(Polygon::new(ring, vec![]));
        }
    }
    if polys.is_empty() {
        return Err(bad(
            "no closed paths to cut (expected <path d=\"M ... Z\"> elements)".into(),
        ));
    }
    Ok(polys)
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
        let g = cut_loops_from_svg(svg, "t.svg").unwrap();
        assert_eq!((g.outline.width(), g.outline.height()), (100.0, 50.0));
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
    fn transforms_apply_and_defs_are_skipped() {
        let t = r#"<svg width="100mm" height="100mm" viewBox="0 0 100 100">
<defs><path d="M0 0 L50 0 L50 50 Z"/></defs>
<g transform="translate(10,20)"><g transform="scale(2) rotate(90)">
<path d="M0 0 L5 0 L5 1 Z" transform="translate(1 0)"/></g></g></svg>"#;
        let g = cut_loops_from_svg(t, "t.svg").unwrap();
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
        let e = cut_loops_from_svg(bad, "b.svg").unwrap_err().to_string();
        assert!(e.contains("perspective"), "{e}");
    }

    #[test]
    fn curves_are_refused() {
        let c = r#"<svg width="10mm" height="10mm"><path d="M0 0 C1 1 2 2 3 3 Z"/></svg>"#;
        let e = cut_loops_from_svg(c, "c.svg").unwrap_err().to_string();
        assert!(e.starts_with("c.svg:") && e.contains("cubic"), "{e}");
        let n = r#"<svg width="10mm" height="10mm"></svg>"#;
        assert!(cut_loops_from_svg(n, "n.svg").is_err());
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
            ("400Q", 100.0),
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
            ("3EX", "relative (ex)"),
            ("5vw", "relative (vw)"),
            ("auto", "not a length"),
            ("10furlongs", "unit 'furlongs'"),
            ("0mm", "more than 0"),
            ("-5mm", "more than 0"),
            ("1e400mm", "more than 0"),
            ("nanmm", "not a length"),
        ] {
            let e = size_of(w, "10mm").unwrap_err();
            assert!(
                e.starts_with("u.svg: width=") && e.contains(want),
                "{w}: {e}"
            );
        }
        let long = "9".repeat(1000) + "em";
        let e = size_of(&long, "10mm").unwrap_err();
        assert!(e.contains('…') && e.len() < 400, "{e}");
    }

    #[test]
    fn one_size_takes_the_other_from_the_viewbox_and_the_aspect_is_kept() {
        let g = |attrs: &str| {
            let t = format!(r#"<svg {attrs}><path d="M10 10 L20 10 L20 20 Z"/></svg>"#);
            cut_loops_from_svg(&t, "a.svg")
        };
        let a = g(r#"width="100mm" viewBox="0 0 200 50""#).unwrap();
        assert_eq!((a.outline.width(), a.outline.height()), (100.0, 25.0));
        assert!(g(r#"width="100mm""#)
            .unwrap_err()
            .to_string()
            .contains("only one of"));
        // 100 x 100 mm showing a 200 x 100 viewBox: 0.5 mm per unit both ways, centred (25 mm
        // above and below), so the square stays square.
        let b = g(r#"width="100mm" height="100mm" viewBox="0 0 200 100""#).unwrap();
        let r = geo::BoundingRect::bounding_rect(&b.cuts).unwrap();
        assert!(
            (r.width() - 5.0).abs() < 1e-9 && (r.height() - 5.0).abs() < 1e-9,
            "{r:?}"
        );
        assert_eq!((b.outline.min().y, b.outline.max().y), (-25.0, 75.0));
        let c =
            g(r#"width="100mm" height="100mm" viewBox="0 0 200 100" preserveAspectRatio="none""#)
                .unwrap();
        let r = geo::BoundingRect::bounding_rect(&c.cuts).unwrap();
        assert!(
            (r.width() - 5.0).abs() < 1e-9 && (r.height() - 10.0).abs() < 1e-9,
            "{r:?}"
        );
        for vb in ["0 0 inf 10", "0 0 10", "0 0 -1 10", "0 0 nan 1", "a b c d"] {
            let e = g(&format!(r#"width="10mm" height="10mm" viewBox="{vb}""#)).unwrap_err();
            assert!(e.to_string().contains("viewBox="), "{vb}: {e}");
        }
        let e = g(r#"width="10mm" height="10mm" viewBox="0 0 1e-300 1e-300""#).unwrap_err();
        assert!(
            e.to_string().contains("path 1") && e.to_string().contains("beyond"),
            "{e}"
        );
    }

    #[test]
    fn transforms_and_coordinates_that_leave_the_range_are_refused_by_path() {
        let g = |tr: &str, d: &str| {
            let t = format!(
                r#"<svg width="10mm" height="10mm"><g transform="{tr}"><path id="p7" d="{d}"/></g></svg>"#
            );
            cut_loops_from_svg(&t, "t.svg").map_err(|e| e.to_string())
        };
        let sq = "M1 1 L2 1 L2 2 Z";
        for tr in [
            "rotate(nan)",
            "matrix(nan,0,0,1,0,0)",
            "scale(inf)",
            "translate(1e999)",
            "matrix(1e300,0,0,1e300,0,0) scale(1e10)",
        ] {
            let e = g(tr, sq).unwrap_err();
            assert!(
                e.starts_with("t.svg: <g>: transform") && e.contains("finite"),
                "{tr}: {e}"
            );
        }
        for tr in ["scale(1e308)", "skewX(90)", "rotate(45) scale(1e300)"] {
            let e = g(tr, sq).unwrap_err();
            assert!(
                e.starts_with("t.svg: <path id=\"p7\"> (path 1): point"),
                "{tr}: {e}"
            );
        }
        let e = g("", "M1 1 L1e20 1 L2 2 Z").unwrap_err();
        assert!(e.contains("beyond"), "{e}");
        let e = g("", "M1 1 L1e39 1 L2 2 Z").unwrap_err();
        assert!(
            e.contains("not a finite number") || e.contains("bad path data"),
            "{e}"
        );
        assert!(g("rotate(30) skewX(10)", sq).is_ok());
    }
}
