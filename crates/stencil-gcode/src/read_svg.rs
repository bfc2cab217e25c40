//! Cut geometry from an SVG drawing (`stencil gcode drawing.svg`), ours or anyone's, read as a
//! viewer shows it.
//!
//! The drawing is parsed by usvg (resvg's parser), which resolves what a hand-written reader gets
//! wrong: every shape (`rect`, `circle`, `ellipse`, `line`, `polyline`, `polygon`, `path`),
//! transforms, nested `<svg>` viewports, `<use>`, CSS (`<style>`, `style=""`), `display` and
//! `visibility`, and units. Its curves and arcs are flattened to lines within
//! [`FLATTEN_TOLERANCE_MM`] by kurbo. Before usvg sees it, the XML is checked here, because usvg
//! forgives what a cutter must not: it drops the rest of a path after a bad number and skips an
//! element with an unreadable transform, both without a word. So malformed XML is refused with its
//! line and column, and a bad number names its element, attribute, line and column.
//!
//! What is cut: if any element's `id` (or `class`, or Inkscape layer label) mentions "cut", only
//! what lies inside such elements (so the preview layers of our own `stencil.svg`, outline and
//! bridges, are skipped); otherwise everything drawn. A closed subpath is a loop; an open one (a
//! `<line>`, a `<polyline>`, a path without `Z`) is a line, which a pen draws and a cutting tool
//! refuses unless told to cut it open (see [`CutLoops::lines`]). Text and embedded pictures are not
//! cut, and said so; images are never loaded from files or links.
//!
//! The sheet's width and height must have a physical size (mm, cm, Q, in, pt, pc or px, any case,
//! exponents allowed); relative units are refused by name. Coordinates come out in mm, y down, in
//! the viewBox's frame (our own SVG reads back in its own coordinates). usvg computes in `f32`:
//! seven significant digits, 0.1 µm on a metre-wide sheet, finer than any machine steps.

use geo::{Area, Coord, LineString, MultiPolygon, Polygon, Rect};
use usvg::roxmltree;

use stencil_geom::clip;
use stencil_io::excerpt;

use crate::cuts::CutLoops;

/// How far a flattened curve may stray from the true one, mm: below a laser's kerf or a pen's
/// line (0.1 mm and more), above the G-code's 0.001 mm digits, so a circle of 100 mm gets about
/// 160 segments, not thousands.
pub const FLATTEN_TOLERANCE_MM: f64 = 0.01;

/// The largest number accepted in coordinates, lengths and transforms: far beyond any sheet, and
/// within `f32`, which usvg computes in (a larger number would become infinite there and the
/// shape would vanish without a word).
const MAX_NUMBER: f64 = 1e30;

/// The most points a drawing may flatten to: 10 million, about 160 MB as cut loops, far more than
/// a sheet's worth of cutting (20,000 drawn circles of 10 mm are 1.3 million).
const MAX_POINTS: usize = 10_000_000;

/// The deepest nesting of elements read: 256 levels, as libxml2 allows by default. Drawing
/// programs nest a few dozen (layers, groups, clones); usvg converts a nested element by
/// recursion, so 13,000 nested `<g>` (91 KB of text) overflowed the stack and aborted the process.
pub const MAX_DEPTH: usize = 256;

/// The most attributes one element may have. A drawing program writes a few dozen; the XML parser
/// checks each new attribute against all the element's earlier ones, so 80,000 on one `<path>`
/// took 27 s.
pub const MAX_ATTRIBUTES: usize = 1000;

fn too_many_points() -> String {
    format!(
        "the drawing flattens to more than {MAX_POINTS} points (curves at \
         {FLATTEN_TOLERANCE_MM} mm); simplify it"
    )
}

/// Why an SVG drawing cannot be read; each names the file and, where there is one, the line and
/// column.
#[derive(Debug, thiserror::Error)]
pub enum SvgError {
    /// Not well-formed XML (or not an SVG document).
    #[error("{file}:{line}:{col}: not well-formed XML: {msg}")]
    Xml {
        file: String,
        line: u32,
        col: u32,
        msg: String,
    },
    /// A number that does not read as one, or is out of range.
    #[error("{file}:{line}:{col}: {what}: {msg}")]
    Number {
        file: String,
        line: u32,
        col: u32,
        /// The element and attribute, as written: `<path> d="M 1 1 L 5x 5"`.
        what: String,
        msg: String,
    },
    /// Beyond a limit of the reader, at a place in the text.
    #[error("{file}:{line}:{col}: {msg}")]
    At {
        file: String,
        line: u32,
        col: u32,
        msg: String,
    },
    #[error("{file}: {msg}")]
    Bad { file: String, msg: String },
}

/// A drawing read from SVG: its cut loops and lines, and what was left out, for the user.
#[derive(Clone, Debug)]
pub struct SvgDrawing {
    pub geometry: CutLoops,
    /// Things drawn that are not cut (text, pictures), one sentence each.
    pub notes: Vec<String>,
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

/// The outermost `<svg>`'s size and coordinate system.
struct Sheet {
    /// The viewport in the frame the paths are read into (user units times `scale`): the viewBox's
    /// origin stays where it is, so our own SVG reads back in its own coordinates.
    outline: [f64; 4],
}

/// Read the `<svg>` element's `width`, `height`, `viewBox` and `preserveAspectRatio`. A size
/// given only as a viewBox is taken in px (96 per inch), as drawing programs write it; one of
/// width and height alone takes the other from the viewBox's shape.
fn sheet(root: roxmltree::Node) -> Result<Sheet, String> {
    let w = root
        .attribute("width")
        .map(|v| length_mm("width", v))
        .transpose()?;
    let h = root
        .attribute("height")
        .map(|v| length_mm("height", v))
        .transpose()?;
    let vb = match root.attribute("viewBox") {
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
            outline: [0.0, 0.0, w, h],
        });
    };
    let par = aspect(root.attribute("preserveAspectRatio"))?;
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
        outline: [x0, y0, x0 + w, y0 + h],
    };
    for c in sheet.outline.chunks(2) {
        clip::check_point(c[0], c[1]).map_err(|e| format!("the <svg> element's viewport: {e}"))?;
    }
    Ok(sheet)
}

/// Parse SVG text into cut loops and lines in mm (y down), as drawn (no kerf), nothing known of
/// the pieces. `file` names it in errors.
pub fn cut_loops_from_svg(text: &str, file: &str) -> Result<CutLoops, SvgError> {
    read(text, file).map(|d| d.geometry)
}

/// [`cut_loops_from_svg`] with the notes on what was left out.
pub fn read(text: &str, file: &str) -> Result<SvgDrawing, SvgError> {
    let bad = |msg: String| SvgError::Bad {
        file: file.to_string(),
        msg,
    };
    check_markup(text, file)?;
    let doc = parse_xml(text, file)?;
    check_depth(&doc, file)?;
    let root = doc.root_element();
    if root.tag_name().name() != "svg" {
        return Err(bad(format!(
            "the document's root element is <{}>, not <svg>",
            excerpt(root.tag_name().name())
        )));
    }
    let sheet = sheet(root).map_err(bad)?;
    let checked = check_document(&doc, file)?;
    let svg_text = for_usvg(text, root, &sheet);
    let source = doc;
    let doc = parse_xml(&svg_text, file)?;
    let opt = usvg::Options {
        // Never read a file or a link an `<image>` names; pictures are not cut anyway.
        resources_dir: None,
        image_href_resolver: usvg::ImageHrefResolver {
            resolve_data: Box::new(|_, _, _| None),
            resolve_string: Box::new(|_, _| None),
        },
        ..usvg::Options::default()
    };
    let tree = usvg::Tree::from_xmltree(&doc, &opt)
        .map_err(|e| bad(format!("not a drawing usvg can read: {e}")))?;
    let mut walk = Walk {
        cut_ids: &checked.cut_ids,
        shift: [sheet.outline[0], sheet.outline[1]],
        shapes: Vec::new(),
        count: 0,
        points: 0,
        transparent: 0,
    };
    walk.group(tree.root(), false, None)
        .map_err(|(label, e)| bad(format!("{label}: {e}")))?;
    let mut notes = checked.notes;
    if walk.transparent > 0 {
        notes.push(format!(
            "{} fully transparent element(s) (opacity 0) not cut: nothing of them shows",
            walk.transparent
        ));
    }
    let any_cut = walk.shapes.iter().any(|s| s.cut);
    let mut polys: Vec<Polygon<f64>> = Vec::new();
    let mut lines: Vec<LineString<f64>> = Vec::new();
    for s in walk.shapes.into_iter().filter(|s| s.cut || !any_cut) {
        polys.extend(s.rings.into_iter().map(|r| Polygon::new(r, vec![])));
        lines.extend(s.lines);
    }
    if polys.is_empty() && lines.is_empty() {
        return Err(bad(match vanished(&source) {
            Some(why) => format!("nothing to cut: {why}"),
            None => "nothing to cut: no shape is drawn (shapes hidden by display, visibility \
                     or opacity 0, or inside <defs>, are not cut)"
                .into(),
        }));
    }
    let o = sheet.outline;
    let outline = Rect::new(Coord { x: o[0], y: o[1] }, Coord { x: o[2], y: o[3] });
    let mut geometry = CutLoops::drawn(outline, MultiPolygon(polys));
    geometry.lines = lines;
    Ok(SvgDrawing { geometry, notes })
}

/// The text usvg reads: the root's width and height as this reader understood them (in mm, which
/// usvg takes as SVG does; it reads `100MM` or `1E1cm`, valid CSS, as no size at all), and the SVG
/// namespace where a file leaves it out (as hand-written ones do; usvg reads only elements in it).
fn for_usvg(text: &str, root: roxmltree::Node, sheet: &Sheet) -> String {
    let o = sheet.outline;
    let at = root.range().start + "<svg".len();
    let mut edits: Vec<(std::ops::Range<usize>, String)> = Vec::new();
    for (name, mm) in [("width", o[2] - o[0]), ("height", o[3] - o[1])] {
        match root.attribute_node(name) {
            Some(a) => edits.push((a.range_value(), format!("{mm}mm"))),
            None => edits.push((at..at, format!(" {name}=\"{mm}mm\""))),
        }
    }
    if root.tag_name().namespace().is_none() {
        edits.push((at..at, " xmlns=\"http://www.w3.org/2000/svg\"".into()));
    }
    edits.sort_by_key(|(r, _)| std::cmp::Reverse(r.start));
    let mut out = text.to_string();
    for (r, t) in edits {
        out.replace_range(r, &t);
    }
    out
}

/// usvg's px (96 per inch) in mm.
const PX_MM: f64 = 25.4 / 96.0;

fn parse_xml<'a>(text: &'a str, file: &str) -> Result<roxmltree::Document<'a>, SvgError> {
    let opt = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    roxmltree::Document::parse_with_options(text, opt).map_err(|e| {
        let p = e.pos();
        SvgError::Xml {
            file: file.to_string(),
            line: p.row,
            col: p.col,
            msg: e.to_string(),
        }
    })
}

/// Where byte `at` of `text` is, as (line, column) counted from 1 (columns in characters).
fn line_col(text: &str, at: usize) -> (u32, u32) {
    let before = &text[..at];
    let line = before.bytes().filter(|&b| b == b'\n').count() + 1;
    let col = before[before.rfind('\n').map_or(0, |i| i + 1)..]
        .chars()
        .count()
        + 1;
    (line as u32, col as u32)
}

/// Refuse, before the XML parser sees the text, what would take it (or usvg) unbounded time or
/// stack: elements nested deeper than [`MAX_DEPTH`] and an element with more than
/// [`MAX_ATTRIBUTES`] attributes. One pass over the markup (comments, CDATA, processing
/// instructions and declarations skipped); anything malformed ends the scan and is left to the
/// parser, which then stops at the same place and says what is wrong.
fn check_markup(text: &str, file: &str) -> Result<(), SvgError> {
    let b = text.as_bytes();
    let find = |from: usize, pat: &str| text[from..].find(pat).map(|i| from + i);
    let mut depth = 0usize;
    let mut i = 0usize;
    while let Some(lt) = memchr_lt(b, i) {
        let rest = &b[lt..];
        let skip_to = |pat: &str| find(lt, pat).map(|e| e + pat.len());
        let end = if rest.starts_with(b"<!--") {
            skip_to("-->")
        } else if rest.starts_with(b"<![CDATA[") {
            skip_to("]]>")
        } else if rest.starts_with(b"<?") {
            skip_to("?>")
        } else if rest.starts_with(b"<!") {
            // A declaration (DOCTYPE, with an internal subset in brackets, or one inside it):
            // scanned to its closing `>` outside quotes and brackets.
            declaration_end(b, lt)
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            skip_to(">")
        } else {
            let Some((end, attributes, empty)) = start_tag(b, lt) else {
                return Ok(());
            };
            if attributes > MAX_ATTRIBUTES {
                let (line, col) = line_col(text, lt);
                return Err(SvgError::At {
                    file: file.to_string(),
                    line,
                    col,
                    msg: format!(
                        "<{}> has {attributes} attributes; at most {MAX_ATTRIBUTES} per element \
                         are read (a drawing program writes a few dozen): remove the extra ones",
                        excerpt(tag_name(&text[lt + 1..]))
                    ),
                });
            }
            // An empty element (`<rect/>`) is a level too, as in the parsed tree.
            if depth + 1 > MAX_DEPTH {
                return Err(too_deep(text, file, lt));
            }
            if !empty {
                depth += 1;
            }
            Some(end)
        };
        match end {
            Some(e) => i = e,
            None => return Ok(()),
        }
    }
    Ok(())
}

fn too_deep(text: &str, file: &str, at: usize) -> SvgError {
    let (line, col) = line_col(text, at);
    SvgError::At {
        file: file.to_string(),
        line,
        col,
        msg: format!(
            "<{}> is nested more than {MAX_DEPTH} elements deep; at most {MAX_DEPTH} levels are \
             read (a drawing program nests a few dozen): ungroup the drawing (Inkscape: Edit > \
             Select All in All Layers, then Object > Ungroup)",
            excerpt(tag_name(&text[at + 1..]))
        ),
    }
}

/// The element name at the start of `s` (up to a space, `/` or `>`).
fn tag_name(s: &str) -> &str {
    let end = s
        .find(|c: char| c.is_whitespace() || c == '/' || c == '>')
        .unwrap_or(s.len());
    &s[..end]
}

/// The next `<` at or after `from`.
fn memchr_lt(b: &[u8], from: usize) -> Option<usize> {
    b.get(from..)?
        .iter()
        .position(|&c| c == b'<')
        .map(|i| from + i)
}

/// The end (just past `>`) of the declaration starting at `lt` (`<!...>`), skipping quoted
/// literals and a bracketed internal subset (whose own declarations and comments it contains).
fn declaration_end(b: &[u8], lt: usize) -> Option<usize> {
    let (mut i, mut brackets) = (lt + 2, 0usize);
    while i < b.len() {
        match b[i] {
            q @ (b'"' | b'\'') => i += 1 + b[i + 1..].iter().position(|&c| c == q)?,
            b'[' => brackets += 1,
            b']' => brackets = brackets.saturating_sub(1),
            b'<' if b[i..].starts_with(b"<!--") => {
                i += 4 + b[i + 4..].windows(3).position(|w| w == b"-->")? + 2;
            }
            b'>' if brackets == 0 => return Some(i + 1),
            _ => {}
        }
        i += 1;
    }
    None
}

/// A start tag at `lt`: its end (just past `>`), its number of attributes, and whether it is
/// empty (`/>`); `None` when it is not well-formed (left to the parser).
fn start_tag(b: &[u8], lt: usize) -> Option<(usize, usize, bool)> {
    let mut i = lt + 1;
    let mut attributes = 0usize;
    loop {
        let c = *b.get(i)?;
        match c {
            b'>' => return Some((i + 1, attributes, false)),
            b'/' if b.get(i + 1) == Some(&b'>') => return Some((i + 2, attributes, true)),
            b'"' | b'\'' => {
                attributes += 1;
                i += 1 + b[i + 1..].iter().position(|&q| q == c)?;
            }
            _ => {}
        }
        i += 1;
    }
}

/// [`MAX_DEPTH`] on the parsed document too: entities declared in a DTD can add levels the text
/// does not show. The XML parser itself walks without recursion.
fn check_depth(doc: &roxmltree::Document, file: &str) -> Result<(), SvgError> {
    let mut depth: Vec<u32> = Vec::new();
    for node in doc.descendants() {
        let d = node.parent().map_or(0, |p| depth[p.id().get_usize()] + 1);
        let id = node.id().get_usize();
        if depth.len() <= id {
            depth.resize(id + 1, 0);
        }
        depth[id] = d;
        if node.is_element() && d as usize > MAX_DEPTH {
            return Err(too_deep(doc.input_text(), file, node.range().start));
        }
    }
    Ok(())
}

/// What the check of the document found besides errors.
struct Checked {
    /// Ids of elements whose `class` or Inkscape label mentions "cut" (usvg keeps ids only).
    cut_ids: std::collections::HashSet<String>,
    notes: Vec<String>,
}

/// Attributes that hold one length or coordinate.
const LENGTHS: &[&str] = &[
    "x", "y", "width", "height", "rx", "ry", "r", "cx", "cy", "x1", "y1", "x2", "y2",
];

/// Elements whose content is never drawn directly (usvg draws only what `<use>` takes from them).
const HIDDEN: &[&str] = &[
    "defs", "clipPath", "mask", "marker", "pattern", "symbol", "metadata",
];

/// Check every number usvg would read silently wrong, and gather the ids of "cut" elements and
/// the notes on what is not cut.
fn check_document(doc: &roxmltree::Document, file: &str) -> Result<Checked, SvgError> {
    let mut out = Checked {
        cut_ids: Default::default(),
        notes: Vec::new(),
    };
    let (mut texts, mut images) = (0usize, 0usize);
    for node in doc.descendants().filter(|n| n.is_element()) {
        let name = node.tag_name().name();
        let hidden = node
            .ancestors()
            .any(|a| HIDDEN.contains(&a.tag_name().name()));
        match name {
            "text" if !hidden => texts += 1,
            "image" if !hidden => images += 1,
            _ => {}
        }
        let labelled_cut = node.attributes().any(|a| {
            (a.name() == "class" || a.name() == "label") && a.value().to_lowercase().contains("cut")
        });
        if labelled_cut {
            if let Some(id) = node.attribute("id") {
                out.cut_ids.insert(id.to_string());
            }
        }
        if !hidden && has_mask(node) {
            let p = doc.text_pos_at(node.range().start);
            let id = node
                .attribute("id")
                .map(|i| format!(" id=\"{}\"", excerpt(i)))
                .unwrap_or_default();
            return Err(SvgError::At {
                file: file.to_string(),
                line: p.row,
                col: p.col,
                msg: format!(
                    "<{}{id}> has a mask, which shows it partly, by the brightness of another \
                     drawing; a cutter cannot follow that: remove the mask, or make it a clip \
                     path (which is cut along its edge)",
                    excerpt(name)
                ),
            });
        }
        let is_root = node.parent().is_some_and(|p| p.is_root());
        for a in node.attributes().filter(|a| a.namespace().is_none()) {
            let at = |offset: usize, msg: String| {
                let p = doc.text_pos_at(a.range_value().start + offset);
                SvgError::Number {
                    file: file.to_string(),
                    line: p.row,
                    col: p.col,
                    what: format!(
                        "<{}> {}=\"{}\"",
                        excerpt(name),
                        a.name(),
                        excerpt(a.value())
                    ),
                    msg,
                }
            };
            match a.name() {
                "transform" => check_transform(a.value()).map_err(|m| at(0, m))?,
                "viewBox" => check_view_box(a.value()).map_err(|m| at(0, m))?,
                "d" if name == "path" => check_path_data(a.value()).map_err(|(o, m)| at(o, m))?,
                "points" if name == "polygon" || name == "polyline" => {
                    check_points(a.value()).map_err(|m| at(0, m))?
                }
                n if LENGTHS.contains(&n) && !(is_root && (n == "width" || n == "height")) => {
                    check_length(a.value()).map_err(|m| at(0, m))?
                }
                _ => {}
            }
        }
    }
    if texts > 0 {
        out.notes.push(format!(
            "{texts} text element(s) not cut: convert text to paths first (Inkscape: Path > \
             Object to Path)"
        ));
    }
    if images > 0 {
        out.notes.push(format!(
            "{images} embedded picture(s) not cut: trace them (or run `stencil make` on the \
             picture)"
        ));
    }
    Ok(out)
}

/// The elements that draw a shape.
const SHAPES: &[&str] = &[
    "rect", "circle", "ellipse", "line", "polyline", "polygon", "path",
];

/// Whether `node` or an element around it is hidden by `display="none"` or `visibility`, as an
/// attribute or in its `style`.
fn hidden_by_style(node: roxmltree::Node) -> bool {
    let says = |n: roxmltree::Node, key: &str, value: &str| {
        presentation(n, key).any(|v| v.trim() == value)
    };
    node.ancestors().filter(|n| n.is_element()).any(|n| {
        says(n, "display", "none") || says(n, "visibility", "hidden") || says(n, "opacity", "0")
    })
}

/// The values an element gives a presentation property (`key`): as an attribute and in its
/// `style` (not style sheets, which usvg resolves for the walk).
fn presentation<'a>(node: roxmltree::Node<'a, 'a>, key: &'a str) -> impl Iterator<Item = &'a str> {
    let in_style = node.attribute("style").into_iter().flat_map(move |st| {
        st.split(';').filter_map(move |d| {
            d.split_once(':')
                .filter(|(k, _)| k.trim().eq_ignore_ascii_case(key))
                .map(|(_, v)| v)
        })
    });
    node.attribute(key).into_iter().chain(in_style)
}

/// Why a drawing whose shapes are not hidden gave nothing to cut, naming the first such shape
/// (kind, id, number among the shapes, line and column) and the cause: a transform that squeezes
/// it flat or to nothing (usvg drops such a shape without a word), or no size of its own.
/// `None` when every shape is hidden or in `<defs>` (the plain message says so).
fn vanished(doc: &roxmltree::Document) -> Option<String> {
    let mut count = 0usize;
    for node in doc.descendants().filter(|n| n.is_element()) {
        let name = node.tag_name().name();
        if !SHAPES.contains(&name) {
            continue;
        }
        count += 1;
        if node
            .ancestors()
            .any(|a| HIDDEN.contains(&a.tag_name().name()))
            || hidden_by_style(node)
        {
            continue;
        }
        let p = doc.text_pos_at(node.range().start);
        let id = node
            .attribute("id")
            .map(|i| format!(" id=\"{}\"", excerpt(i)))
            .unwrap_or_default();
        let what = format!(
            "<{name}{id}> (shape {count}, line {}, column {})",
            p.row, p.col
        );
        // The transforms from the root down to the shape, composed.
        let chain: Vec<&str> = node
            .ancestors()
            .filter_map(|a| a.attribute("transform"))
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect();
        // The linear part [a c; b d], root first.
        let mut m = [1.0, 0.0, 0.0, 1.0];
        for t in &chain {
            if let Ok(t) = t.parse::<svgtypes::Transform>() {
                m = [
                    m[0] * t.a + m[2] * t.b,
                    m[1] * t.a + m[3] * t.b,
                    m[0] * t.c + m[2] * t.d,
                    m[1] * t.c + m[3] * t.d,
                ];
            }
        }
        let (sx, sy) = (m[0].hypot(m[1]), m[2].hypot(m[3]));
        let det = m[0] * m[3] - m[1] * m[2];
        // How far from flat: the sine of the angle between the transformed axes.
        let open = det.abs() / (sx * sy);
        let cause = if !chain.is_empty()
            && (sx.min(sy) < 1e-6 || det.abs() < 1e-9 || open.is_nan() || open < 1e-4)
        {
            format!(
                "its transform ({}) is degenerate: it squeezes the shape flat or to nothing \
                 (areas scaled by {det:.1e}, the axes {}° apart); remove or correct the \
                 transform",
                excerpt(&chain.join(" ")),
                match open.clamp(0.0, 1.0).asin().to_degrees() {
                    a if a >= 0.01 => format!("{a:.2}"),
                    a => format!("{a:.1e}"),
                }
            )
        } else if let Some(a) = ["width", "height", "r", "rx", "ry"].iter().find_map(|a| {
            node.attribute_node(*a)
                .filter(|v| v.value().trim().parse::<f64>() == Ok(0.0))
        }) {
            format!("it has no size ({}=\"{}\")", a.name(), excerpt(a.value()))
        } else {
            "it encloses no area and draws no line (a shape of zero size, or a path with no \
             segment)"
                .to_string()
        };
        return Some(format!("{what} comes out empty: {cause}"));
    }
    None
}

/// Whether an element names a mask, in its `mask` attribute or its `style`.
fn has_mask(node: roxmltree::Node) -> bool {
    presentation(node, "mask").any(|v| {
        let v = v.trim();
        !v.is_empty() && v != "none"
    })
}

fn number_ok(v: f64) -> Result<(), String> {
    if v.is_finite() && v.abs() <= MAX_NUMBER {
        Ok(())
    } else {
        Err(format!(
            "the number {v:e} is out of range (at most {MAX_NUMBER:e})"
        ))
    }
}

/// A viewBox usvg can scale to its viewport in `f32`: four numbers in range, a width and height
/// not so small that the scale overflows (usvg would ignore such a viewBox without a word).
fn check_view_box(v: &str) -> Result<(), String> {
    let n: Vec<f64> = svgtypes::NumberListParser::from(v)
        .collect::<Result<_, _>>()
        .map_err(|e| format!("not four numbers ({e})"))?;
    if n.len() != 4 {
        return Err(format!("{} numbers: give x, y, width and height", n.len()));
    }
    n.iter().try_for_each(|&x| number_ok(x))?;
    if n[2] < 1.0 / MAX_NUMBER || n[3] < 1.0 / MAX_NUMBER {
        return Err(format!(
            "the width and height must be at least {:e}",
            1.0 / MAX_NUMBER
        ));
    }
    Ok(())
}

fn check_transform(v: &str) -> Result<(), String> {
    let t = v
        .parse::<svgtypes::Transform>()
        .map_err(|e| format!("not a transform ({e}); e.g. translate(10 20) rotate(45)"))?;
    for x in [t.a, t.b, t.c, t.d, t.e, t.f] {
        number_ok(x).map_err(|m| format!("{m}: the transform gives no finite coordinates"))?;
    }
    Ok(())
}

/// The byte offset into the attribute of a number the path parser choked on, and the message.
fn check_path_data(v: &str) -> Result<(), (usize, String)> {
    use svgtypes::PathSegment as S;
    for seg in svgtypes::PathParser::from(v) {
        let seg = seg.map_err(|e| {
            let offset = match e {
                svgtypes::Error::InvalidNumber(p)
                | svgtypes::Error::UnexpectedData(p)
                | svgtypes::Error::InvalidChar(_, p)
                | svgtypes::Error::InvalidString(_, p) => p,
                _ => v.len(),
            };
            (
                offset,
                format!("bad path data ({e}): a number or command letter is not valid there"),
            )
        })?;
        let nums: &[f64] = &match seg {
            S::MoveTo { x, y, .. } | S::LineTo { x, y, .. } | S::SmoothQuadratic { x, y, .. } => {
                vec![x, y]
            }
            S::HorizontalLineTo { x, .. } => vec![x],
            S::VerticalLineTo { y, .. } => vec![y],
            S::CurveTo {
                x1,
                y1,
                x2,
                y2,
                x,
                y,
                ..
            } => vec![x1, y1, x2, y2, x, y],
            S::SmoothCurveTo { x2, y2, x, y, .. } => vec![x2, y2, x, y],
            S::Quadratic { x1, y1, x, y, .. } => vec![x1, y1, x, y],
            S::EllipticalArc {
                rx,
                ry,
                x_axis_rotation,
                x,
                y,
                ..
            } => vec![rx, ry, x_axis_rotation, x, y],
            S::ClosePath { .. } => vec![],
        };
        for &n in nums {
            number_ok(n).map_err(|m| (0, m))?;
        }
    }
    Ok(())
}

fn check_points(v: &str) -> Result<(), String> {
    let mut n = 0usize;
    for x in svgtypes::NumberListParser::from(v) {
        let x = x.map_err(|e| format!("not a list of numbers ({e})"))?;
        number_ok(x)?;
        n += 1;
    }
    if n % 2 == 1 {
        return Err(format!(
            "{n} numbers: points come in x,y pairs, so the last one has no y"
        ));
    }
    Ok(())
}

fn check_length(v: &str) -> Result<(), String> {
    let l = v.trim().parse::<svgtypes::Length>().map_err(|_| {
        "not a length: give a number, with a unit if any, e.g. 10 or 10mm".to_string()
    })?;
    number_ok(l.number)
}

/// One drawn shape: whether it lies inside a "cut" element, its closed rings and open lines in
/// sheet mm.
struct Shape {
    cut: bool,
    rings: Vec<LineString<f64>>,
    lines: Vec<LineString<f64>>,
}

/// The walk over usvg's tree.
struct Walk<'a> {
    cut_ids: &'a std::collections::HashSet<String>,
    /// The viewBox frame's origin in mm (added to usvg's viewport coordinates).
    shift: [f64; 2],
    shapes: Vec<Shape>,
    /// Shapes seen, for their names in messages.
    count: usize,
    /// Points flattened so far (bounded by [`MAX_POINTS`]).
    points: usize,
    /// Elements left out because nothing of them shows (opacity 0), for the note.
    transparent: usize,
}

/// A shape's flattened subpaths in sheet mm: closed rings and open lines.
type Flat = (Vec<LineString<f64>>, Vec<LineString<f64>>);

/// Whether nothing of `p` shows: every paint it has is fully transparent (a path with neither
/// fill nor stroke usvg already marks invisible).
fn transparent(p: &usvg::Path) -> bool {
    let fill = p.fill().map(|f| f.opacity().get());
    let stroke = p.stroke().map(|s| s.opacity().get());
    (fill.is_some() || stroke.is_some())
        && fill.is_none_or(|o| o <= 0.0)
        && stroke.is_none_or(|o| o <= 0.0)
}

impl Walk<'_> {
    fn is_cut(&self, id: &str) -> bool {
        !id.is_empty() && (id.to_lowercase().contains("cut") || self.cut_ids.contains(id))
    }

    /// A group's label in messages: its id, or that it has none.
    fn group_label(g: &usvg::Group) -> String {
        if g.id().is_empty() {
            "an element".to_string()
        } else {
            format!("<g id=\"{}\">", excerpt(g.id()))
        }
    }

    /// Walk a group: `clip` is the region (sheet mm) its ancestors' `clip-path`s leave visible.
    fn group(
        &mut self,
        g: &usvg::Group,
        inside_cut: bool,
        clip: Option<&MultiPolygon<f64>>,
    ) -> Result<(), (String, String)> {
        // Fully transparent (`opacity="0"`): nothing in it shows, so nothing is cut.
        if g.opacity().get() <= 0.0 {
            self.transparent += 1;
            return Ok(());
        }
        if g.mask().is_some() {
            return Err((
                Self::group_label(g),
                "has a mask, which shows it partly, by the brightness of another drawing; a \
                 cutter cannot follow that: remove the mask or turn it into a clip path"
                    .into(),
            ));
        }
        let region;
        let clip = match g.clip_path() {
            None => clip,
            Some(cp) => {
                let own = self
                    .clip_region(cp, g.abs_transform())
                    .map_err(|e| (Self::group_label(g), format!("its clip path: {e}")))?;
                region = match clip {
                    Some(outer) => clip::boolean(outer, &own, clip::Op::Intersection)
                        .map_err(|e| (Self::group_label(g), format!("its clip path: {e}")))?,
                    None => own,
                };
                Some(&region)
            }
        };
        let cut = inside_cut || self.is_cut(g.id());
        for node in g.children() {
            match node {
                usvg::Node::Group(g) => self.group(g, cut, clip)?,
                usvg::Node::Path(p) => self.path(p, cut, clip)?,
                usvg::Node::Image(_) | usvg::Node::Text(_) => {}
            }
        }
        Ok(())
    }

    /// The region (sheet mm) a clip path leaves visible, for a group placed by `outer`: the
    /// union of its shapes (each by its `clip-rule`), within its own clip path if it has one.
    fn clip_region(
        &mut self,
        cp: &usvg::ClipPath,
        outer: usvg::Transform,
    ) -> Result<MultiPolygon<f64>, String> {
        let t = outer.pre_concat(cp.transform());
        let mut region = self.clip_group(cp.root(), t)?;
        if let Some(inner) = cp.clip_path() {
            let inner = self.clip_region(inner, outer)?;
            region = clip::boolean(&region, &inner, clip::Op::Intersection)
                .map_err(|e| e.to_string())?;
        }
        Ok(region)
    }

    /// The filled region of a clip path's group (its children's transforms relative to `t`).
    fn clip_group(
        &mut self,
        g: &usvg::Group,
        t: usvg::Transform,
    ) -> Result<MultiPolygon<f64>, String> {
        let mut region = MultiPolygon::new(Vec::new());
        for node in g.children() {
            let part = match node {
                usvg::Node::Group(c) => {
                    let mut part = self.clip_group(c, t)?;
                    if let Some(cp) = c.clip_path() {
                        let own = self.clip_region(cp, t.pre_concat(c.abs_transform()))?;
                        part = clip::boolean(&part, &own, clip::Op::Intersection)
                            .map_err(|e| e.to_string())?;
                    }
                    part
                }
                usvg::Node::Path(p) if p.is_visible() => {
                    let (rings, _) = self.flatten(p, t.pre_concat(p.abs_transform()))?;
                    let polys: Vec<Polygon<f64>> =
                        rings.into_iter().map(|r| Polygon::new(r, vec![])).collect();
                    let even_odd = p
                        .fill()
                        .is_some_and(|f| f.rule() == usvg::FillRule::EvenOdd);
                    let empty = MultiPolygon::new(Vec::new());
                    if even_odd {
                        polys.into_iter().try_fold(empty, |acc, p| {
                            clip::boolean(&acc, &MultiPolygon::new(vec![p]), clip::Op::Xor)
                        })
                    } else {
                        clip::boolean(&MultiPolygon::new(polys), &empty, clip::Op::Union)
                    }
                    .map_err(|e| e.to_string())?
                }
                _ => continue,
            };
            region = clip::boolean(&region, &part, clip::Op::Union).map_err(|e| e.to_string())?;
        }
        Ok(region)
    }

    fn path(
        &mut self,
        p: &usvg::Path,
        inside_cut: bool,
        clip: Option<&MultiPolygon<f64>>,
    ) -> Result<(), (String, String)> {
        self.count += 1;
        let label = if p.id().is_empty() {
            format!("path {}", self.count)
        } else {
            format!("<path id=\"{}\"> (path {})", excerpt(p.id()), self.count)
        };
        if !p.is_visible() {
            return Ok(());
        }
        if transparent(p) {
            self.transparent += 1;
            return Ok(());
        }
        let (mut rings, mut lines) = self
            .flatten(p, p.abs_transform())
            .map_err(|e| (label.clone(), e))?;
        if let Some(region) = clip {
            (rings, lines) = clipped(rings, lines, region)
                .map_err(|e| (label.clone(), format!("clipping it by its clip path: {e}")))?;
        }
        if !rings.is_empty() || !lines.is_empty() {
            self.shapes.push(Shape {
                cut: inside_cut || self.is_cut(p.id()),
                rings,
                lines,
            });
        }
        Ok(())
    }

    /// `p`'s subpaths placed by `t` and flattened into sheet mm, counted against [`MAX_POINTS`].
    fn flatten(&mut self, p: &usvg::Path, t: usvg::Transform) -> Result<Flat, String> {
        let [sx, sy] = self.shift;
        let map = |q: usvg::tiny_skia_path::Point| {
            let (x, y) = (q.x as f64, q.y as f64);
            kurbo::Point::new(
                (t.sx as f64 * x + t.kx as f64 * y + t.tx as f64) * PX_MM + sx,
                (t.ky as f64 * x + t.sy as f64 * y + t.ty as f64) * PX_MM + sy,
            )
        };
        let mut bez = kurbo::BezPath::new();
        for seg in p.data().segments() {
            use usvg::tiny_skia_path::PathSegment as S;
            match seg {
                S::MoveTo(a) => bez.move_to(map(a)),
                S::LineTo(a) => bez.line_to(map(a)),
                S::QuadTo(a, b) => bez.quad_to(map(a), map(b)),
                S::CubicTo(a, b, c) => bez.curve_to(map(a), map(b), map(c)),
                S::Close => bez.close_path(),
            }
        }
        // Every control point in range before flattening: a curve's segment count grows with the
        // square root of its size over the tolerance, so a circle of radius 1e30 would never end.
        if let Some(e) = bez
            .elements()
            .iter()
            .flat_map(|el| match *el {
                kurbo::PathEl::MoveTo(a) | kurbo::PathEl::LineTo(a) => vec![a],
                kurbo::PathEl::QuadTo(a, b) => vec![a, b],
                kurbo::PathEl::CurveTo(a, b, c) => vec![a, b, c],
                kurbo::PathEl::ClosePath => vec![],
            })
            .find_map(|q| clip::check_point(q.x, q.y).err())
        {
            return Err(e.to_string());
        }
        // An upper bound of the points flattening gives (a curve of control polygon length L
        // gives fewer than sqrt(L / tolerance) + 1 segments), checked before it runs.
        let mut last = kurbo::Point::ZERO;
        let estimate: f64 = bez
            .elements()
            .iter()
            .map(|el| {
                let (len, end) = match *el {
                    kurbo::PathEl::MoveTo(a) | kurbo::PathEl::LineTo(a) => (0.0, a),
                    kurbo::PathEl::QuadTo(a, b) => (last.distance(a) + a.distance(b), b),
                    kurbo::PathEl::CurveTo(a, b, c) => {
                        (last.distance(a) + a.distance(b) + b.distance(c), c)
                    }
                    kurbo::PathEl::ClosePath => (0.0, last),
                };
                last = end;
                (len / FLATTEN_TOLERANCE_MM).sqrt() + 1.0
            })
            .sum();
        if self.points as f64 + estimate > 2.0 * MAX_POINTS as f64 {
            return Err(too_many_points());
        }
        let mut flat: Flat = (Vec::new(), Vec::new());
        let mut cur: Vec<Coord<f64>> = Vec::new();
        let mut bad: Option<String> = None;
        let mut end = |cur: &mut Vec<Coord<f64>>, closed: bool, flat: &mut Flat| {
            let mut pts = std::mem::take(cur);
            pts.dedup();
            if pts.len() < 2 {
                return;
            }
            let ls = LineString::from(pts);
            if let Err(e) = clip::check_rings([&ls]) {
                bad.get_or_insert(e.to_string());
                return;
            }
            let mut ring = ls.clone();
            ring.close();
            let area = Polygon::new(ring.clone(), vec![]).unsigned_area();
            if closed && area > 1e-12 {
                flat.0.push(ring);
            } else if closed {
                // A closed subpath that encloses nothing is a line there and back.
                flat.1.push(ring);
            } else {
                flat.1.push(ls);
            }
        };
        kurbo::flatten(bez, FLATTEN_TOLERANCE_MM, |el| match el {
            kurbo::PathEl::MoveTo(a) => {
                end(&mut cur, false, &mut flat);
                cur.push(Coord { x: a.x, y: a.y });
            }
            kurbo::PathEl::LineTo(a) => cur.push(Coord { x: a.x, y: a.y }),
            kurbo::PathEl::ClosePath => end(&mut cur, true, &mut flat),
            // flatten gives lines only.
            _ => {}
        });
        end(&mut cur, false, &mut flat);
        if let Some(e) = bad {
            return Err(e);
        }
        self.points += flat
            .0
            .iter()
            .chain(&flat.1)
            .map(|l| l.0.len())
            .sum::<usize>();
        if self.points > MAX_POINTS {
            return Err(too_many_points());
        }
        Ok(flat)
    }
}

/// A shape's rings and lines cut to what `region` leaves visible: each ring becomes the outlines
/// of its part inside the region (a loop the clip path's edge crosses is closed along that edge),
/// each line its pieces inside.
fn clipped(
    rings: Vec<LineString<f64>>,
    lines: Vec<LineString<f64>>,
    region: &MultiPolygon<f64>,
) -> Result<Flat, clip::ClipError> {
    use geo::BoundingRect;
    let Some(area) = region.bounding_rect() else {
        // Nothing visible.
        return Ok((Vec::new(), Vec::new()));
    };
    // A clip that is one upright rectangle (a nested viewport's, the commonest) keeps what lies
    // wholly inside it as drawn; what lies wholly outside any clip's box is gone. Only shapes its
    // edge may cross go to Clipper.
    let rectangle = match region.0.as_slice() {
        [p] if p.interiors().is_empty() => {
            let r = p.exterior();
            r.0.len() <= 5
                && r.lines()
                    .all(|l| l.start.x == l.end.x || l.start.y == l.end.y)
                && (p.unsigned_area() - area.width() * area.height()).abs()
                    <= 1e-9 * area.width() * area.height()
        }
        _ => false,
    };
    let placed = |l: &LineString<f64>| -> Option<bool> {
        let b = l.bounding_rect()?;
        let (lo, hi) = (b.min(), b.max());
        let (alo, ahi) = (area.min(), area.max());
        if hi.x < alo.x || lo.x > ahi.x || hi.y < alo.y || lo.y > ahi.y {
            Some(false)
        } else if rectangle && lo.x >= alo.x && hi.x <= ahi.x && lo.y >= alo.y && hi.y <= ahi.y {
            Some(true)
        } else {
            None
        }
    };
    let mut out_rings = Vec::new();
    for r in rings {
        match placed(&r) {
            Some(true) => {
                out_rings.push(r);
                continue;
            }
            Some(false) => continue,
            None => {}
        }
        let part = clip::boolean(
            &MultiPolygon::new(vec![Polygon::new(r, vec![])]),
            region,
            clip::Op::Intersection,
        )?;
        for p in part.0 {
            let (ext, holes) = p.into_inner();
            out_rings.extend(std::iter::once(ext).chain(holes).filter(|r| {
                r.0.len() >= 4 && Polygon::new(r.clone(), vec![]).unsigned_area() > 1e-12
            }));
        }
    }
    let (mut out_lines, mut crossing) = (Vec::new(), Vec::new());
    for l in lines {
        match placed(&l) {
            Some(true) => out_lines.push(l),
            Some(false) => {}
            None => crossing.push(l),
        }
    }
    if !crossing.is_empty() {
        out_lines.extend(
            clip::clip_lines(&crossing, region)?
                .into_iter()
                .filter(|l| l.0.len() >= 2),
        );
    }
    Ok((out_rings, out_lines))
}

#[cfg(test)]
mod tests {
    use super::*;
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
        let g =
            read_body(r#"<path d="M10 10 L50 10 L50 50"/><line x1="0" y1="90" x2="100" y2="90"/>"#)
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
        let t = format!(
            "<svg {MM}>\n<path d=\"M1 1 L5 1 L5 5 Z\"/></svg>\n<path d=\"M0 0 L9 0 L9 9 Z\"/>"
        );
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
        assert!(read_body(
            r#"<g transform="rotate(30) skewX(10)"><path d="M1 1 L2 1 L2 2 Z"/></g>"#
        )
        .is_ok());
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
        let c =
            g(r#"width="100mm" height="100mm" viewBox="0 0 200 100" preserveAspectRatio="none""#)
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
}

/// A stable-Rust fuzz of the reader: documents built from random shapes, transforms, nested
/// viewports, styles and deliberately broken numbers and tags. Every one must be read, or refused
/// naming the file; what is read must lie in range; a plain grid of squares must come back as
/// drawn. `PROPTEST_CASES=N` runs more.
#[cfg(test)]
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
