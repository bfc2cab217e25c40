//! `stencil make` on real photographs, through to G-code, as `driver::run` does it in memory
//! (nothing written): `cargo bench --bench make`. The photos are `samples/grace_hopper.jpg` and
//! `../shared/photos/*.jpg` when that folder is there; each at its own size (0.1 mm per pixel,
//! cardstock) and supersampled 2× (about 1 megapixel working, the yardstick). Before the
//! criterion runs, one run per case prints where the time goes, stage by stage.

/// The binary's allocator settings, so that the bench measures what `stencil` runs.
#[path = "../src/alloc.rs"]
mod alloc;

use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use stencil_core::driver::run;
use stencil_core::material::settings_for;
use stencil_core::pipeline::MakeConfig;
use stencil_gcode::machine;
use stencil_gcode::{GcodeConfig, PlanConfig};

fn photos() -> Vec<PathBuf> {
    let mut v = vec![PathBuf::from("samples/grace_hopper.jpg")];
    for name in ["china.jpg", "flower.jpg"] {
        let p = PathBuf::from("../shared/photos").join(name);
        if p.is_file() {
            v.push(p);
        }
    }
    v
}

fn config(input: PathBuf, scale: u32) -> MakeConfig {
    let mut cfg = MakeConfig {
        input,
        ..Default::default()
    };
    cfg.tone.scale = Some(scale);
    let m = machine::load(None).expect("the default machine loads");
    let settings = settings_for(&cfg.physical.material, &m).expect("cardstock cuts on a laser");
    cfg.gcode = Some(GcodeConfig {
        plan: PlanConfig::new(settings),
        machine: m,
        settings_from: String::new(),
    });
    cfg
}

fn bench(c: &mut Criterion) {
    alloc::keep_freed_memory();
    let mut g = c.benchmark_group("make");
    g.sample_size(10);
    for p in photos() {
        for scale in [1, 2] {
            let cfg = config(p.clone(), scale);
            let made = run(&cfg).expect("the photo makes a valid stencil");
            let r = &made.report;
            let name = format!(
                "{}_{}x{}",
                p.file_stem().unwrap().to_string_lossy(),
                r.width_px,
                r.height_px
            );
            let stages: Vec<String> = r
                .timings_ms
                .iter()
                .map(|(k, v)| format!("{k} {v:.1}"))
                .collect();
            eprintln!("{name}: {} (ms)", stages.join(", "));
            g.bench_function(&name, |b| b.iter(|| run(&cfg).unwrap()));
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
