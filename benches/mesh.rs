//! The mesh two-tone stage: a displaced sphere of 69,312 triangles rendered at 1024×1024
//! (about 1 megapixel) with suggestive contours, from the OBJ file and from memory.
//! `cargo bench --bench mesh`; prints where the time goes (load, curvature, raster, shade,
//! lines, compose) once before measuring.

use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use stencil_core::pipeline::Timings;
use stencil_core::tone::mesh::{self, Mesh};
use stencil_core::tone::Threshold;

#[path = "../crates/stencil-core/tests/support/shapes.rs"]
mod shapes;
#[path = "support/studio_inputs.rs"]
mod studio_inputs;

fn bench(c: &mut Criterion) {
    let m = shapes::displaced_sphere(76);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bumpy.obj");
    std::fs::write(&path, m.to_obj("bumpy")).unwrap();
    // The studio's mesh rendering.
    let cfg = studio_inputs::mesh_config();

    // One run's breakdown, averaged over a few runs.
    let runs = 10;
    let mut load_ms = 0.0;
    let mut t = Timings::default();
    for _ in 0..runs {
        let clock = Instant::now();
        let loaded = mesh::load(&path).unwrap();
        load_ms += clock.elapsed().as_secs_f64() * 1e3;
        let r = mesh::render_mesh(&loaded, &cfg).unwrap();
        for (step, ms) in r.timings.iter() {
            t.add(step, ms);
        }
    }
    let n = runs as f64;
    eprintln!(
        "{} triangles, 1024x1024: load {:.1} ms, curvature {:.1}, raster {:.1}, shade {:.1}, lines {:.1}, compose {:.1}",
        m.triangles.len(),
        load_ms / n,
        t.get("curvature") / n,
        t.get("raster") / n,
        t.get("shade") / n,
        t.get("lines") / n,
        t.get("compose") / n
    );

    let mut g = c.benchmark_group("mesh");
    g.sample_size(20);
    g.bench_function("two_tone_from_obj_70k_tris_1mp", |b| {
        b.iter(|| mesh::render(&path, &cfg, Threshold::Level(128), false).unwrap())
    });
    g.bench_function("render_in_memory_70k_tris_1mp", |b| {
        b.iter(|| mesh::render_mesh(&m, &cfg).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
