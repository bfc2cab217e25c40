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

use geo::{Coord, LineString, MultiPolygon, Polygon, Rect};
use usvg::roxmltree;

use stencil_geom::clip;
use stencil_io::excerpt;

use crate::cuts::CutLoops;

mod walk;
use walk::Walk;
pub use walk::FLATTEN_TOLERANCE_MM;

/// The largest number accepted in coordinates, lengths and transforms: far beyond any sheet, and
/// within `f32`, which usvg computes in (a larger number would become infinite there and the
/// shape would vanish without a word).
const MAX_NUMBER: f64 = 1e30;

/// The deepest nesting of elements read: 256 levels, as libxml2 allows by default. Drawing
/// programs nest a few dozen (layers, groups, clones); usvg converts a nested element by
/// recursion, so 13,000 nested `<g>` (91 KB of text) overflowed the stack and aborted the process.
pub(crate) const MAX_DEPTH: usize = 256;

/// The most attributes one element may have. A drawing program writes a few dozen; the XML parser
/// checks each new attribute against all the element's earlier ones, so 80,000 on one `<path>`
/// took 27 s.
pub(crate) const MAX_ATTRIBUTES: usize = 1000;

/// Why an SVG drawing cannot be read; each names the file and, where there is one, the line and
/// column.
#[derive(Debug, thiserror::Error)]
pub enum SvgError {
    /// At a place in the text: XML that is not well-formed, a number that does not read as one
    /// or is out of range (naming the element and attribute), a limit of the reader.
    #[error("{file}:{line}:{col}: {msg}")]
    At {
        /// The file, as named in messages.
        file: String,
        /// Where, from 1.
        line: u32,
        /// Where, from 1.
        col: u32,
        /// What is wrong.
        msg: String,
    },
    /// Anything else that cannot be cut as drawn.
    #[error("{file}: {msg}")]
    Bad {
        /// The file, as named in messages.
        file: String,
        /// What is wrong.
        msg: String,
    },
}

/// A drawing read from SVG: its cut loops and lines, and what was left out, for the user.
#[derive(Clone, Debug)]
pub struct SvgDrawing {
    /// The loops and lines to cut.
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

/// A length attribute (`width`, `height`) in mm, no unit being px. Relative units (%, em, ex,
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
    let length = |a| root.attribute(a).map(|v| length_mm(a, v)).transpose();
    let (w, h) = (length("width")?, length("height")?);
    let view_box = |v| match numbers(v) {
        Some(n) if n.len() == 4 && n[2] > 0.0 && n[3] > 0.0 => Ok([n[0], n[1], n[2], n[3]]),
        _ => Err(format!(
            "viewBox=\"{}\" is not four finite numbers (x, y, width, height) with a width and \
             height above 0",
            excerpt(v)
        )),
    };
    let vb = root.attribute("viewBox").map(view_box).transpose()?;
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

fn parse_xml<'a>(text: &'a str, file: &str) -> Result<roxmltree::Document<'a>, SvgError> {
    let opt = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    roxmltree::Document::parse_with_options(text, opt).map_err(|e| {
        let p = e.pos();
        at(file, (p.row, p.col), format!("not well-formed XML: {e}"))
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
                return Err(at(
                    file,
                    line_col(text, lt),
                    format!(
                        "<{}> has {attributes} attributes; at most {MAX_ATTRIBUTES} per element \
                         are read (a drawing program writes a few dozen): remove the extra ones",
                        excerpt(tag_name(&text[lt + 1..]))
                    ),
                ));
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

/// An [`SvgError::At`] at (line, column).
fn at(file: &str, (line, col): (u32, u32), msg: String) -> SvgError {
    let file = file.to_string();
    SvgError::At {
        file,
        line,
        col,
        msg,
    }
}

fn too_deep(text: &str, file: &str, lt: usize) -> SvgError {
    at(
        file,
        line_col(text, lt),
        format!(
            "<{}> is nested more than {MAX_DEPTH} elements deep; at most {MAX_DEPTH} levels are \
             read (a drawing program nests a few dozen): ungroup the drawing (Inkscape: Edit > \
             Select All in All Layers, then Object > Ungroup)",
            excerpt(tag_name(&text[lt + 1..]))
        ),
    )
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
        let hidden = in_hidden(node);
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
            return Err(at(
                file,
                (p.row, p.col),
                format!(
                    "<{}{}> has a mask, which shows it partly, by the brightness of another \
                     drawing; a cutter cannot follow that: remove the mask, or make it a clip \
                     path (which is cut along its edge)",
                    excerpt(name),
                    id_attr(node)
                ),
            ));
        }
        let is_root = node.parent().is_some_and(|p| p.is_root());
        for a in node.attributes().filter(|a| a.namespace().is_none()) {
            // The element and attribute, as written: `<path> d="M 1 1 L 5x 5"`.
            let bad_number = |offset: usize, msg: String| {
                let p = doc.text_pos_at(a.range_value().start + offset);
                let (v, n) = (excerpt(a.value()), excerpt(name));
                at(
                    file,
                    (p.row, p.col),
                    format!("<{n}> {}=\"{v}\": {msg}", a.name()),
                )
            };
            match a.name() {
                "transform" => check_transform(a.value()).map_err(|m| bad_number(0, m))?,
                "viewBox" => check_view_box(a.value()).map_err(|m| bad_number(0, m))?,
                "d" if name == "path" => {
                    check_path_data(a.value()).map_err(|(o, m)| bad_number(o, m))?
                }
                "points" if name == "polygon" || name == "polyline" => {
                    check_points(a.value()).map_err(|m| bad_number(0, m))?
                }
                n if LENGTHS.contains(&n) && !(is_root && (n == "width" || n == "height")) => {
                    check_length(a.value()).map_err(|m| bad_number(0, m))?
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
        if in_hidden(node) || hidden_by_style(node) {
            continue;
        }
        let p = doc.text_pos_at(node.range().start);
        let what = format!(
            "<{name}{}> (shape {count}, line {}, column {})",
            id_attr(node),
            p.row,
            p.col
        );
        // The transforms from the root down to the shape, composed.
        let mut chain: Vec<&str> = node
            .ancestors()
            .filter_map(|a| a.attribute("transform"))
            .collect();
        chain.reverse();
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

/// Whether `node` is inside (or is) an element whose content is never drawn directly.
fn in_hidden(node: roxmltree::Node) -> bool {
    node.ancestors()
        .any(|a| HIDDEN.contains(&a.tag_name().name()))
}

/// ` id="…"` as the element has it, or nothing.
fn id_attr(node: roxmltree::Node) -> String {
    node.attribute("id")
        .map(|i| format!(" id=\"{}\"", excerpt(i)))
        .unwrap_or_default()
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

#[cfg(test)]
mod tests;
