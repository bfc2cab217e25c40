//! `stencil.svg`: the stencil at its real size for laser software, plotters and Inkscape.
//!
//! Width and height are in `mm` with a viewBox in millimetres (without units Inkscape assumes
//! 96 px per inch: the classic 25.4/96 scale error). Three layers (Inkscape layers, i.e. groups
//! with `inkscape:groupmode="layer"`): `OUTLINE` (the sheet's edge, red hairline), `CUT` (the cut
//! regions as designed, filled black with the even-odd rule so islands show as holes) and `BRIDGES`
//! (bridge outlines, blue hairline, for reference). The design line is written, not the kerf
//! offset: laser software applies its own kerf.

use std::fmt::Write;

use geo::{LineString, MultiPolygon, Polygon};
use stencil_geom::curve::{self, Curves};

use crate::vector::CutGeometry;

/// Millimetres with 4 decimals (0.1 µm), trailing zeros dropped: a coordinate in a file, at a
/// fixed resolution whatever its size (unlike [`crate::limits::num`], which gives a message's
/// number 6 significant digits; the two cannot be one without changing the SVG's bytes).
pub(crate) fn num(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.to_string()
    }
}

/// Path data for closed rings (each `M … Z`).
pub(crate) fn path_data<'a>(rings: impl IntoIterator<Item = &'a LineString<f64>>) -> String {
    let mut d = String::new();
    for pts in rings.into_iter().filter_map(ring_points) {
        for (i, &[x, y]) in pts.iter().enumerate() {
            let _ = write!(d, "{}{} {}", if i == 0 { "M" } else { "L" }, num(x), num(y));
        }
        d.push('Z');
    }
    d
}

/// A ring's points without the closing repeat, or `None` for fewer than 3.
pub(crate) fn ring_points(r: &LineString<f64>) -> Option<Vec<[f64; 2]>> {
    let pts = &r.0;
    let n = if pts.len() > 1 && pts.first() == pts.last() {
        pts.len() - 1
    } else {
        pts.len()
    };
    (n >= 3).then(|| pts[..n].iter().map(|c| [c.x, c.y]).collect())
}

/// The lines and arcs a ring is written as, from its pieces' first start: those in `curves`
/// when the ring is the flattening of known curves (the vector stage's fit, written as it is),
/// else fitted to the polygon within `tol` ([`stencil_geom::curve::fit_ring`]; `tol` 0: its
/// lines). The SVG and DXF writers share it, so both carry the same pieces.
pub(crate) fn ring_pieces(pts: &[[f64; 2]], curves: &Curves, tol: f64) -> Vec<curve::Piece> {
    match curves.pieces_of(pts) {
        Some((_, pieces)) if tol > 0.0 => pieces,
        _ => curve::fit_ring(pts, tol),
    }
}

/// Path data for closed rings as lines and arcs ([`ring_pieces`]: the fitted curves when
/// `curves` knows the ring, else fitted within `tol` mm): each `M … Z`, straight pieces as `L`,
/// arcs as `A` (an exact circular arc, which every SVG reader takes; never more than a half
/// turn, so the large-arc flag is 0; the sweep flag is 1 for an arc turning towards +y from
/// +x, as the numbers run). `tol` 0 gives [`path_data`]'s polygons.
pub(crate) fn curve_path_data<'a>(
    rings: impl IntoIterator<Item = &'a LineString<f64>>,
    curves: &Curves,
    tol: f64,
) -> String {
    let mut d = String::new();
    for r in rings {
        let Some(pts) = ring_points(r) else { continue };
        let pieces = ring_pieces(&pts, curves, tol);
        let n = pieces.len();
        let _ = write!(d, "M{} {}", num(pieces[0].from[0]), num(pieces[0].from[1]));
        for k in 0..n {
            let (p, to) = (pieces[k], pieces[(k + 1) % n].from);
            match curve::arc_of(p.from, to, p.bulge) {
                Some(a) => {
                    let _ = write!(
                        d,
                        "A{r} {r} 0 0 {} {} {}",
                        u8::from(a.sweep > 0.0),
                        num(to[0]),
                        num(to[1]),
                        r = num(a.radius)
                    );
                }
                // The closing line is Z's.
                None if k + 1 < n => {
                    let _ = write!(d, "L{} {}", num(to[0]), num(to[1]));
                }
                None => {}
            }
        }
        d.push('Z');
    }
    d
}

/// All rings of a polygon set (exteriors and holes).
pub(crate) fn rings(mp: &MultiPolygon<f64>) -> impl Iterator<Item = &LineString<f64>> {
    mp.0.iter()
        .flat_map(|p: &Polygon<f64>| std::iter::once(p.exterior()).chain(p.interiors()))
}

fn layer(id: &str, label: &str, body: &str) -> svg::node::element::Group {
    svg::node::element::Group::new()
        .set("id", id)
        .set("inkscape:groupmode", "layer")
        .set("inkscape:label", label)
        .add(svg::node::Blob::new(body.to_string()))
}

/// Encode the stencil as SVG, the cut regions' outlines as lines and arcs: the vector stage's
/// curves ([`CutGeometry::curves`]) where a ring is theirs, else fitted within
/// `arc_tolerance_mm` of the design polygons (0: the polygons as they are, no arcs at all).
pub(crate) fn encode(geom: &CutGeometry, arc_tolerance_mm: f64) -> Vec<u8> {
    use svg::node::element::{Path, Rectangle};
    let o = geom.outline;
    let (w, h) = (o.width(), o.height());
    let outline = Rectangle::new()
        .set("x", num(o.min().x))
        .set("y", num(o.min().y))
        .set("width", num(w))
        .set("height", num(h))
        .set("fill", "none")
        .set("stroke", "#ff0000")
        .set("stroke-width", "0.02");
    // A gobo's edge is its rim: the circle is what is cut, the square only its sheet.
    let outline = match geom.rim {
        Some(rim) => svg::node::element::Circle::new()
            .set("cx", num(rim.centre_mm[0]))
            .set("cy", num(rim.centre_mm[1]))
            .set("r", num(rim.od_mm / 2.0))
            .set("fill", "none")
            .set("stroke", "#ff0000")
            .set("stroke-width", "0.02")
            .to_string(),
        None => outline.to_string(),
    };
    let mut cut = String::new();
    for p in &geom.design_cuts.0 {
        let d = curve_path_data(
            std::iter::once(p.exterior()).chain(p.interiors()),
            &geom.curves,
            arc_tolerance_mm,
        );
        let path = Path::new()
            .set("d", d)
            .set("fill", "#000000")
            .set("fill-rule", "evenodd")
            .set("stroke", "none");
        cut.push_str(&path.to_string());
    }
    let mut bridges = String::new();
    for b in &geom.bridges {
        let path = Path::new()
            .set("d", path_data(std::iter::once(b.exterior())))
            .set("fill", "none")
            .set("stroke", "#0077ff")
            .set("stroke-width", "0.02");
        bridges.push_str(&path.to_string());
    }
    let doc = svg::Document::new()
        .set(
            "xmlns:inkscape",
            "http://www.inkscape.org/namespaces/inkscape",
        )
        .set("width", format!("{}mm", num(w)))
        .set("height", format!("{}mm", num(h)))
        .set(
            "viewBox",
            format!(
                "{} {} {} {}",
                num(o.min().x),
                num(o.min().y),
                num(w),
                num(h)
            ),
        )
        .add(layer("outline", "OUTLINE", &outline))
        .add(layer("cut", "CUT", &cut))
        .add(layer("bridges", "BRIDGES", &bridges));
    doc.to_string().into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;
    use geo::{Area, Coord, LineString, MultiPolygon, Polygon, Rect};

    /// What `make` writes, `stencil gcode` reads back: the same outline and the cut layer only.
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
            unbridged_cuts: MultiPolygon(vec![]),
            kerf_mm: 0.0,
            rim: None,
            curves: Default::default(),
        };
        let text = String::from_utf8(encode(&geom, 0.05)).unwrap();
        let back = stencil_gcode::cut_loops_from_svg(&text, "stencil.svg").unwrap();
        assert_eq!(back.outline, geom.outline);
        assert_eq!(back.cuts.0.len(), 2, "the bridges layer is not cut");
        // usvg computes in f32 (7 significant digits): equal to 0.1 µm, not to the bit.
        for (a, b) in back.cuts.0.iter().zip(&geom.design_cuts.0) {
            assert!((a.unsigned_area() - b.unsigned_area()).abs() < 1e-4);
            let (p, q) = (a.exterior().0[0], b.exterior().0[0]);
            assert!((p.x - q.x).abs() < 1e-6 && (p.y - q.y).abs() < 1e-6);
        }
    }
}
