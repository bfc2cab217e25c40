//! The inputs the studio's issue-24 latencies are measured on, in one place so that the end-to-end
//! bench (`studio.rs`), the per-stage one (`stages.rs`) and the mesh renderer's (`mesh.rs`)
//! measure the same thing.

use std::path::PathBuf;

use stencil_core::pipeline::MakeConfig;
use stencil_core::tone::mesh::{LineMode, MeshConfig, RenderSize};

/// A 1-megapixel photo with cardstock: `samples/grace_hopper.jpg` (512×600) supersampled 2×.
#[allow(dead_code)]
pub fn photo() -> MakeConfig {
    let mut cfg = MakeConfig {
        input: PathBuf::from("samples/grace_hopper.jpg"),
        ..Default::default()
    };
    cfg.tone.scale = Some(2);
    cfg
}

/// A mesh rendered at 1024×1024 (1 megapixel), no supersampling, with suggestive contours.
pub fn mesh_config() -> MeshConfig {
    MeshConfig {
        size: RenderSize::Exact {
            width: 1024,
            height: 1024,
        },
        supersample: 1,
        lines: LineMode::Suggestive,
        ..MeshConfig::default()
    }
}

/// `make` of the mesh at `path` as [`mesh_config`] renders it.
#[allow(dead_code)]
pub fn mesh(path: PathBuf) -> MakeConfig {
    MakeConfig {
        input: path,
        mesh: mesh_config(),
        ..Default::default()
    }
}
