//! `stencil make` as a person runs it, the whole process (start, read, every stage, write):
//! `cargo bench --bench process`. Beside the in-memory benches (`make`, `stages`, `studio`),
//! this one sees what they cannot: the binary's start, decoding, encoding, the output folder's
//! transaction and thread pools spinning up, on the inputs issue 41 measures:
//! - a photo at its own size (`samples/grace_hopper.jpg`, 512×600) and supersampled 2× (about
//!   1 megapixel working), `--emit png,svg`;
//! - the same 1-megapixel photo with `--threshold auto` (a photo's default level since issue 42:
//!   some 36 clean-ups and likeness measures), and at a fixed `--threshold 128`, which leaves out
//!   that search and so shows what the rest of `make` costs;
//! - a small mesh (`samples/pawn.obj`) and a 200k-triangle one (a displaced sphere), `--emit png`.
//!
//! Each case also prints the CPU time (user + system) the child processes used per run, which
//! other work on a busy machine inflates less than the wall time.

#[path = "../crates/stencil-core/tests/support/shapes.rs"]
mod shapes;

use std::path::Path;
use std::process::Command;

use criterion::{criterion_group, criterion_main, Criterion};
use stencil_core::tone::mesh::Mesh;

/// CPU milliseconds (user + system) of this process's waited-for children, from /proc/self/stat
/// (fields cutime and cstime, clock ticks of 10 ms).
fn children_cpu_ms() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let rest = stat.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
    let f: Vec<f64> = rest
        .split_whitespace()
        .map(|x| x.parse().unwrap_or(0.0))
        .collect();
    if f.len() < 15 {
        return f64::NAN;
    }
    (f[13] + f[14]) * 10.0
}

/// One `stencil make` of `args` into a fresh `out` folder; panics (naming the run) if it fails.
fn make(args: &[&str], out: &Path) {
    let _ = std::fs::remove_dir_all(out);
    let o = Command::new(env!("CARGO_BIN_EXE_stencil"))
        .arg("make")
        .args(args)
        .arg("-o")
        .arg(out)
        .output()
        .expect("stencil runs");
    assert!(
        o.status.success(),
        "stencil make {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("bumpy.obj");
    std::fs::write(&mesh, shapes::displaced_sphere(130).to_obj("bumpy")).unwrap();
    let mesh = mesh.to_str().unwrap();
    let out = dir.path().join("out");
    let photo = "samples/grace_hopper.jpg";
    let cases = [
        ("photo_512x600", photo, "--emit png,svg"),
        ("photo_1mp", photo, "--scale 2 --emit png,svg"),
        ("auto_1mp", photo, "--scale 2 --threshold auto --emit png"),
        (
            "level128_1mp",
            photo,
            "--scale 2 --threshold 128 --emit png,svg",
        ),
        ("mesh_pawn", "samples/pawn.obj", "--emit png"),
        ("mesh_200k", mesh, "--emit png"),
    ];
    let mut g = c.benchmark_group("process");
    g.sample_size(10);
    for (name, input, options) in cases {
        let args: Vec<&str> = std::iter::once(input)
            .chain(options.split_whitespace())
            .collect();
        let (t0, n) = (children_cpu_ms(), 5);
        for _ in 0..n {
            make(&args, &out);
        }
        println!(
            "{name}: cpu {:.0} ms per run",
            (children_cpu_ms() - t0) / f64::from(n)
        );
        g.bench_function(name, |b| b.iter(|| make(&args, &out)));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
