//! The input, read and rendered (the paper's Stage 1, "two-tone image", up to the gray): a
//! picture loaded and adjusted, or a mesh loaded, drawn from its view and lit.

use std::path::Path;
use std::sync::Arc;

use crate::error::Error;
use crate::plan::SourceParams;
use crate::raster::Gray;
use crate::tone::mesh::{self, MeshConfig};
use crate::tone::{self, image::load_gray};

/// Whether a path is a mesh (by extension) rather than a picture.
pub fn is_mesh_path(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"))
}

/// The input as read: a picture's gray at its own resolution, or a mesh with what every view
/// of it shares (its normals and curvature, see [`mesh::Prepared`]). Shared (`Arc`) so that the
/// studio keeps it once and each run borrows it.
#[derive(Clone, Debug)]
pub enum Input {
    /// A picture's gray.
    Picture(Arc<Gray>),
    /// A mesh, prepared.
    Mesh(Arc<mesh::Prepared>),
}

/// The input rendered: a picture is its own rendering; a mesh is drawn from its view and light.
#[derive(Clone, Debug)]
pub enum Source {
    /// The picture's gray, as read.
    Picture(Arc<Gray>),
    /// The mesh, drawn.
    Mesh(Arc<mesh::Rendering>),
}

impl Source {
    /// Width and height in pixels (before supersampling).
    pub fn size(&self) -> (u32, u32) {
        match self {
            Source::Picture(g) => (g.width, g.height),
            Source::Mesh(r) => (r.gray.width, r.gray.height),
        }
    }
}

/// Stage 0: read the input (bounded: a picture's header is checked against the pixel limit
/// before decoding).
pub fn load(input: &Path, p: &SourceParams) -> Result<Input, Error> {
    Ok(match p {
        SourceParams::Picture { max_pixels, .. } => {
            Input::Picture(Arc::new(load_gray(input, *max_pixels)?))
        }
        SourceParams::Mesh(_) => Input::Mesh(Arc::new(mesh::Prepared::new(
            mesh::load(input).map_err(tone::ToneError::from)?,
        ))),
    })
}

/// Stage 1a: a mesh's view before it is lit (raster, surfaces, lines); `None` for a picture.
pub fn draw(input: &Input, p: &SourceParams) -> Result<Option<Arc<mesh::Drawn>>, Error> {
    Ok(match (input, p) {
        (Input::Mesh(m), SourceParams::Mesh(cfg)) => {
            Some(Arc::new(mesh::draw(m, cfg).map_err(tone::ToneError::from)?))
        }
        (Input::Picture(_), _) => None,
        (Input::Mesh(_), SourceParams::Picture { .. }) => {
            unreachable!("SourceParams::of gives a mesh its mesh settings")
        }
    })
}

/// Stage 1b: the drawn view lit; a picture adjusted (cropped, turned, its tones and detail
/// changed; see [`tone::Adjust`]), or passed through when no adjustment was asked.
pub fn light(
    input: &Input,
    drawn: Option<&mesh::Drawn>,
    p: &SourceParams,
) -> Result<Source, Error> {
    Ok(match (input, drawn, p) {
        (Input::Picture(g), _, SourceParams::Picture { adjust, .. }) if !adjust.is_identity() => {
            Source::Picture(Arc::new(adjust.apply(g)))
        }
        (Input::Picture(g), _, _) => Source::Picture(g.clone()),
        (Input::Mesh(_), Some(d), SourceParams::Mesh(cfg)) => {
            Source::Mesh(Arc::new(mesh::light(d, cfg)))
        }
        (Input::Mesh(_), _, _) => {
            unreachable!("a mesh is drawn with its mesh settings before it is lit")
        }
    })
}

impl SourceParams {
    /// The part of a mesh's settings its [`draw`] reads: everything but the light (`None` for
    /// a picture). Equal keys draw the same view, so the studio re-lights a kept one.
    pub fn view_key(&self) -> Option<MeshConfig> {
        match self {
            SourceParams::Picture { .. } => None,
            SourceParams::Mesh(m) => Some(MeshConfig {
                light: [0.0; 3],
                ambient: 0.0,
                fill: 0.0,
                specular: 0.0,
                shininess: 1.0,
                ..m.clone()
            }),
        }
    }
}
