//! The walk over usvg's tree: every shown shape flattened to closed rings and open lines in
//! sheet mm, clipped by its clip paths; what is hidden or transparent left out.

use geo::{Area, Coord, LineString, MultiPolygon, Polygon};
use stencil_geom::clip;
use stencil_io::excerpt;

/// How far a flattened curve may stray from the true one, mm: below a laser's kerf or a pen's
/// line (0.1 mm and more), above the G-code's 0.001 mm digits, so a circle of 100 mm gets about
/// 160 segments, not thousands.
pub const FLATTEN_TOLERANCE_MM: f64 = 0.01;

/// The most points a drawing may flatten to: 10 million, about 160 MB as cut loops, far more than
/// a sheet's worth of cutting (20,000 drawn circles of 10 mm are 1.3 million).
const MAX_POINTS: usize = 10_000_000;

/// usvg's px (96 per inch) in mm.
const PX_MM: f64 = 25.4 / 96.0;

fn too_many_points() -> String {
    format!(
        "the drawing flattens to more than {MAX_POINTS} points (curves at \
         {FLATTEN_TOLERANCE_MM} mm); simplify it"
    )
}

/// One drawn shape: whether it lies inside a "cut" element, its closed rings and open lines in
/// sheet mm.
pub(super) struct Shape {
    pub(super) cut: bool,
    pub(super) rings: Vec<LineString<f64>>,
    pub(super) lines: Vec<LineString<f64>>,
}

/// The walk over usvg's tree.
pub(super) struct Walk<'a> {
    pub(super) cut_ids: &'a std::collections::HashSet<String>,
    /// The viewBox frame's origin in mm (added to usvg's viewport coordinates).
    pub(super) shift: [f64; 2],
    pub(super) shapes: Vec<Shape>,
    /// Shapes seen, for their names in messages.
    pub(super) count: usize,
    /// Points flattened so far (bounded by [`MAX_POINTS`]).
    pub(super) points: usize,
    /// Elements left out because nothing of them shows (opacity 0), for the note.
    pub(super) transparent: usize,
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
    pub(super) fn group(
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
                let bad = |e: String| (Self::group_label(g), format!("its clip path: {e}"));
                let own = self.clip_region(cp, g.abs_transform()).map_err(bad)?;
                region = match clip {
                    Some(outer) => clip::boolean(outer, &own, clip::Op::Intersection)
                        .map_err(|e| bad(e.to_string()))?,
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
            Some(true) => out_rings.push(r),
            Some(false) => {}
            None => {
                let ring = MultiPolygon::new(vec![Polygon::new(r, vec![])]);
                for p in clip::boolean(&ring, region, clip::Op::Intersection)?.0 {
                    let (ext, holes) = p.into_inner();
                    out_rings.extend(std::iter::once(ext).chain(holes).filter(|r| {
                        r.0.len() >= 4 && Polygon::new(r.clone(), vec![]).unsigned_area() > 1e-12
                    }));
                }
            }
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
