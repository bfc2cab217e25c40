//! The studio's latencies: a change, through the incremental engine, to the PNG the page shows
//! (`cargo bench --bench studio`), beside `make`'s full time on the same input in the same run.
//! - a 1-megapixel photo with cardstock (`samples/grace_hopper.jpg`, 512×600 supersampled 2×):
//!   a bridge weight (`w_length`) and a threshold, each toggled between two values so every
//!   iteration is a real change;
//! - a 200k-triangle mesh rendered at 1024×1024: the light and the view.
//!
//! Each iteration is `Engine::preview` (only the stages after the change run, up to the
//! bridges) plus encoding the preview PNG, which is what the page waits for; the trace and the
//! check follow (`Engine::check`), their CPU time printed beside.

#[path = "../src/alloc.rs"]
mod alloc;

#[path = "../crates/stencil-core/tests/support/shapes.rs"]
mod shapes;

#[path = "support/studio_inputs.rs"]
mod studio_inputs;

use criterion::{criterion_group, criterion_main, Criterion};
use stencil_core::driver::run;
use stencil_core::pipeline::MakeConfig;
use stencil_core::tone::mesh::Mesh;
use stencil_core::tone::Threshold;
use stencil_studio::Engine;
use studio_inputs::{mesh, photo};

/// CPU milliseconds (user + system, every thread) this process has used, from /proc/self/stat
/// (clock ticks of 10 ms): on a machine shared with other builds wall time says more about
/// them than about us, so each latency is also printed as CPU time per change, which the other
/// builds do not inflate (on an idle 2-core machine the wall time is between half of it and all
/// of it).
fn cpu_ms() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the command's closing parenthesis: state is field 3, utime 14, stime 15.
    let rest = stat.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
    let f: Vec<f64> = rest
        .split_whitespace()
        .map(|x| x.parse().unwrap_or(0.0))
        .collect();
    if f.len() < 13 {
        return f64::NAN;
    }
    (f[11] + f[12]) * 10.0
}

/// Print the CPU time per call of `f` over `n` calls.
fn cpu_per(name: &str, n: usize, mut f: impl FnMut()) {
    let t0 = cpu_ms();
    for _ in 0..n {
        f();
    }
    println!(
        "{name}: cpu {:.1} ms per change",
        (cpu_ms() - t0) / n as f64
    );
}

/// Time `change(cfg, flip)` then the engine up to the preview and the preview's PNG (what the
/// page shows first), alternating `flip`; then print the CPU time of the same with the trace and
/// the check after it (what follows on the page, marked as updating until it arrives).
fn latency(
    g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    base: &MakeConfig,
    change: impl Fn(&mut MakeConfig, bool),
) {
    let mut engine = Engine::new();
    let never = || false;
    let first = engine.run(base, &never).expect("the input makes a stencil");
    println!("{name}: first run computed {:?}", first.ran);
    let mut flip = false;
    let mut cfg = base.clone();
    g.bench_function(name, |b| {
        b.iter(|| {
            flip = !flip;
            change(&mut cfg, flip);
            let c = engine.preview(&cfg, &never).expect("a stencil");
            c.image("preview").expect("the preview")
        })
    });
    cpu_per(name, 20, || {
        flip = !flip;
        change(&mut cfg, flip);
        let c = engine.preview(&cfg, &never).expect("a stencil");
        c.image("preview").expect("the preview");
    });
    cpu_per(&format!("{name} (then checked)"), 10, || {
        flip = !flip;
        change(&mut cfg, flip);
        let c = engine.preview(&cfg, &never).expect("a stencil");
        c.image("preview").expect("the preview");
        engine.check(&c, &never).expect("a stencil");
    });
    change(&mut cfg, !flip);
    let c = engine.run(&cfg, &never).expect("a stencil");
    println!("{name}: a change re-ran {:?}", c.ran);
}

fn bench(c: &mut Criterion) {
    alloc::keep_freed_memory();
    let mut g = c.benchmark_group("studio");
    g.sample_size(10);
    let p = photo();
    g.bench_function("make_photo_1mp", |b| b.iter(|| run(&p).expect("a stencil")));
    cpu_per("make_photo_1mp", 5, || {
        run(&p).expect("a stencil");
    });
    latency(&mut g, "photo_1mp_bridge_weight", &p, |c, f| {
        c.bridge.w_length = if f { 1.25 } else { 1.0 }
    });
    latency(&mut g, "photo_1mp_threshold", &p, |c, f| {
        c.tone.threshold = Threshold::Level(if f { 120 } else { 136 })
    });

    let m = shapes::displaced_sphere(130);
    println!("mesh: {} triangles", m.triangles.len());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bumpy.obj");
    std::fs::write(&path, m.to_obj("bumpy")).unwrap();
    let mc = mesh(path);
    g.bench_function("make_mesh_200k_1mp", |b| {
        b.iter(|| run(&mc).expect("a stencil"))
    });
    cpu_per("make_mesh_200k_1mp", 5, || {
        run(&mc).expect("a stencil");
    });
    latency(&mut g, "mesh_200k_1mp_light", &mc, |c, f| {
        c.mesh.light = if f { [1.0, 1.0, 2.0] } else { [-1.0, 1.0, 2.0] }
    });
    latency(&mut g, "mesh_200k_1mp_view", &mc, |c, f| {
        c.mesh.azimuth_deg = if f { 20.0 } else { 30.0 }
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
