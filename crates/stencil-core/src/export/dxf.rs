//! `stencil.dxf`: closed polylines in millimetres for CAD and laser software.
//!
//! R2000 (AC1015) by default: closed LWPOLYLINEs, `$INSUNITS` = 4 (mm), `$MEASUREMENT` = 1
//! (metric). `--dxf-r12` writes R12 closed POLYLINE/VERTEX/SEQEND for old software (R12 has no
//! units header: it is still millimetres). Layers: `CUT` (every cut loop, as designed: CAM applies
//! its own kerf) and `OUTLINE` (the sheet's edge, or a gobo's rim as an exact CIRCLE). DXF's y
//! axis points up, so y is flipped about the sheet (`y_dxf = height - y`): the drawing is not mirrored and sits at x, y ≥ 0.
//!
//! The dxf crate writes R12 by default and silently drops LWPOLYLINEs there, so the version is
//! always set explicitly.

use dxf::entities::{Entity, EntityType, LwPolyline, Polyline, Vertex};
use dxf::enums::{AcadVersion, DrawingUnits, Units};
use dxf::tables::Layer;
use dxf::{Color, Drawing, LwPolylineVertex, Point};

use geo::LineString;

use super::error::ExportError;
use super::svg::{ring_pieces, ring_points, rings};
use crate::vector::CutGeometry;

/// Layer names.
pub(crate) const CUT_LAYER: &str = "CUT";
pub(crate) const OUTLINE_LAYER: &str = "OUTLINE";

/// Encode the stencil as DXF (R2000, or R12 when `r12`). Cut loops are lines and arcs: the
/// vector stage's curves ([`CutGeometry::curves`]) where a ring is theirs, else fitted within
/// `arc_tolerance_mm` ([`stencil_geom::curve::fit_ring`]; 0: the polygons as they are), each arc a vertex bulge (group 42, `tan(sweep / 4)`, positive counter-clockwise), which
/// R12 POLYLINE vertices and R2000 LWPOLYLINEs both carry and CAD, LightBurn and LaserGRBL read
/// as true arcs: still one closed polyline per loop, not loose ARC entities.
pub(crate) fn encode(
    geom: &CutGeometry,
    r12: bool,
    arc_tolerance_mm: f64,
) -> Result<Vec<u8>, ExportError> {
    let mut d = Drawing::new();
    d.header.version = if r12 {
        AcadVersion::R12
    } else {
        AcadVersion::R2000
    };
    // Reproducible: the same stencil gives the same bytes (a fixed date, nil GUIDs), instead of
    // the clock and random GUIDs Drawing::new() puts in the header, so that a file can be
    // compared with another run's (the studio's export with `make`'s, a refactor's outputs).
    let epoch = chrono::DateTime::from_timestamp(946_684_800, 0).unwrap_or_default(); // 2000-01-01
    d.header.creation_date = epoch.with_timezone(&chrono::Local);
    d.header.update_date = epoch.with_timezone(&chrono::Local);
    d.header.creation_date_universal = epoch;
    d.header.update_date_universal = epoch;
    d.header.fingerprint_guid = uuid::Uuid::nil();
    d.header.version_guid = uuid::Uuid::nil();
    d.header.default_drawing_units = Units::Millimeters;
    d.header.drawing_units = DrawingUnits::Metric;
    for (name, color) in [(CUT_LAYER, 1u8), (OUTLINE_LAYER, 5u8)] {
        d.add_layer(Layer {
            name: name.into(),
            color: Color::from_index(color),
            ..Default::default()
        });
    }
    let o = geom.outline;
    let (x0, ymax) = (o.min().x, o.max().y);
    // Shift so the sheet's corner is at the origin, and flip y up.
    let tf = |x: f64, y: f64| (x - x0, ymax - y);
    let add = |d: &mut Drawing, ring: &LineString<f64>, layer: &str, tol: f64| {
        let Some(pts) = ring_points(ring) else {
            return;
        };
        // y flips, so a counter-clockwise arc in the sheet's numbers turns clockwise in the
        // DXF's: the bulge changes sign.
        let pieces: Vec<(f64, f64, f64)> = ring_pieces(&pts, &geom.curves, tol)
            .iter()
            .map(|p| {
                let (x, y) = tf(p.from[0], p.from[1]);
                (x, y, if p.bulge == 0.0 { 0.0 } else { -p.bulge })
            })
            .collect();
        let ent = if r12 {
            let mut pl = Polyline::default();
            pl.set_is_closed(true);
            for &(x, y, bulge) in &pieces {
                let mut v = Vertex::new(Point::new(x, y, 0.0));
                v.bulge = bulge;
                pl.add_vertex(d, v);
            }
            EntityType::Polyline(pl)
        } else {
            let mut lw = LwPolyline::default();
            lw.set_is_closed(true);
            lw.vertices = pieces
                .iter()
                .map(|&(x, y, bulge)| LwPolylineVertex {
                    x,
                    y,
                    bulge,
                    ..Default::default()
                })
                .collect();
            EntityType::LwPolyline(lw)
        };
        let mut e = Entity::new(ent);
        e.common.layer = layer.into();
        d.add_entity(e);
    };
    match geom.rim {
        // A gobo's edge is its rim: an exact CIRCLE of the outside diameter.
        Some(rim) => {
            let (x, y) = tf(rim.centre_mm[0], rim.centre_mm[1]);
            let mut e = Entity::new(EntityType::Circle(dxf::entities::Circle::new(
                Point::new(x, y, 0.0),
                rim.od_mm / 2.0,
            )));
            e.common.layer = OUTLINE_LAYER.into();
            d.add_entity(e);
        }
        None => add(&mut d, o.to_polygon().exterior(), OUTLINE_LAYER, 0.0),
    }
    for r in rings(&geom.design_cuts) {
        add(&mut d, r, CUT_LAYER, arc_tolerance_mm);
    }
    let mut out = Vec::new();
    d.save(&mut out).map_err(|e| ExportError::Encode {
        path: "stencil.dxf".into(),
        msg: e.to_string(),
    })?;
    Ok(out)
}
