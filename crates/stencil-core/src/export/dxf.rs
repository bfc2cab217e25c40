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

use super::svg::rings;
use super::ExportError;
use crate::vector::CutGeometry;

/// Layer names.
pub const CUT_LAYER: &str = "CUT";
pub const OUTLINE_LAYER: &str = "OUTLINE";

/// Encode the stencil as DXF (R2000, or R12 when `r12`).
pub fn encode(geom: &CutGeometry, r12: bool) -> Result<Vec<u8>, ExportError> {
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
    let add = |d: &mut Drawing, ring: &LineString<f64>, layer: &str| {
        let pts = &ring.0;
        let n = if pts.len() > 1 && pts.first() == pts.last() {
            pts.len() - 1
        } else {
            pts.len()
        };
        if n < 3 {
            return;
        }
        let ent = if r12 {
            let mut pl = Polyline::default();
            pl.set_is_closed(true);
            for c in &pts[..n] {
                let (x, y) = tf(c.x, c.y);
                pl.add_vertex(d, Vertex::new(Point::new(x, y, 0.0)));
            }
            EntityType::Polyline(pl)
        } else {
            let mut lw = LwPolyline::default();
            lw.set_is_closed(true);
            lw.vertices = pts[..n]
                .iter()
                .map(|c| {
                    let (x, y) = tf(c.x, c.y);
                    LwPolylineVertex {
                        x,
                        y,
                        ..Default::default()
                    }
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
        None => add(&mut d, o.to_polygon().exterior(), OUTLINE_LAYER),
    }
    for r in rings(&geom.design_cuts) {
        add(&mut d, r, CUT_LAYER);
    }
    let mut out = Vec::new();
    d.save(&mut out).map_err(|e| ExportError::Encode {
        path: "stencil.dxf".into(),
        msg: e.to_string(),
    })?;
    Ok(out)
}
