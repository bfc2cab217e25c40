//! Stage 4: from the bridged bit grid to cut geometry in millimetres: marching squares,
//! simplification, bridge union, kerf offset. OWNER: the vectors issue.

use geo::{MultiPolygon, Polygon};

/// The stencil as physical geometry, in millimetres, x right and **y down** with the origin at the
/// image's top-left corner (the raster and SVG convention; G-code flips to y up when it places the
/// job on the bed).
///
/// Contract between `vector` (which fills it) and `check`, `export` and `plan` (which read it).
#[derive(Clone, Debug)]
pub struct CutGeometry {
    /// Size of the whole sheet (the image), in mm.
    pub width_mm: f64,
    pub height_mm: f64,
    /// Regions cut away (holes through the sheet), kerf already applied. After bridging they have
    /// no holes: a hole in a cut region would be a floating island.
    pub cuts: MultiPolygon<f64>,
    /// The material that stays (the sheet, bridges unioned in), without kerf.
    pub material: MultiPolygon<f64>,
    /// Bridge polygons as placed by the bridge stage, in mm.
    pub bridges: Vec<Polygon<f64>>,
}
