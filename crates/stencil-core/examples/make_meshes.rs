//! Regenerate the sample meshes in `samples/`: `cargo run --example make_meshes`.
//!
//! Every model is procedural (see `tests/support/shapes.rs`), so the repository carries its
//! own test models and no third-party assets.

use std::path::Path;

use stencil_core::tone::mesh::Mesh;

#[path = "../tests/support/shapes.rs"]
mod shapes;

fn main() -> anyhow::Result<()> {
    let dir = Path::new("samples");
    let models = [
        ("pawn", shapes::pawn()),
        ("trefoil", shapes::trefoil()),
        ("torus", shapes::torus(1.0, 0.4, 64, 24)),
    ];
    for (name, mesh) in models {
        let path = dir.join(format!("{name}.obj"));
        stencil_io::write_atomic(&path, mesh.to_obj(name).as_bytes())?;
        println!(
            "{}: {} vertices, {} triangles",
            path.display(),
            mesh.positions.len(),
            mesh.triangles.len()
        );
    }
    Ok(())
}
