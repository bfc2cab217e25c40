//! Stage 1 from a mesh: load an OBJ, render it with a point light and toon shading, draw silhouettes
//! and suggestive contours. OWNER: the mesh issue. Placeholder until then.

use std::path::{Path, PathBuf};

use crate::raster::TwoTone;

/// Options of the mesh renderer.
#[derive(Clone, Debug, Default)]
pub struct MeshConfig {}

#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("{path}: mesh input is not implemented yet")]
    NotImplemented { path: PathBuf },
}

/// Render a mesh file into a two-tone image whose gray is the shaded rendering.
pub fn render(path: &Path, cfg: &MeshConfig) -> Result<TwoTone, MeshError> {
    let _ = cfg;
    Err(MeshError::NotImplemented {
        path: path.to_path_buf(),
    })
}
