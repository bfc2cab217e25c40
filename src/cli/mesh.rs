//! Mesh rendering options (`make` and `tone` on an .obj). OWNER: the mesh issue.

use clap::Args;

use stencil::tone::mesh::MeshConfig;

/// Options that apply when the input is an OBJ mesh.
#[derive(Args, Debug, Clone, Default)]
#[command(next_help_heading = "Mesh input (.obj)")]
pub struct MeshArgs {}

impl MeshArgs {
    pub fn to_config(&self) -> anyhow::Result<MeshConfig> {
        Ok(MeshConfig::default())
    }
}
