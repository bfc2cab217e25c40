//! Vectorising + bridge union + width check on a 2000 × 2000 stencil with 1,024 islands, each held
//! by one synthetic bridge (the bridge stage is not needed to measure this stage).
//!
//! Run: `cargo bench --bench vector` (release). Target: ≤ 100 ms on 2 cores for the whole of
//! `vectorize_and_check` (what `make` and `check` run); the stage benches show where the time
//! goes. The kerf offset, made only for G-code, is timed on its own.

/// The binary's allocator settings, so that the bench measures what `stencil` runs.
#[path = "../src/alloc.rs"]
mod alloc;

use criterion::{criterion_group, criterion_main, Criterion};

use stencil_core::check;
use stencil_core::material::Material;
use stencil_core::pipeline::{self, Timings};
use stencil_core::raster::BitGrid;
use stencil_core::vector::{self, steps, VectorConfig};
use stencil_geom::kerf;

const SIZE: u32 = 2000;
const CELLS: u32 = 32; // 32 × 32 = 1,024 islands
const R_CUT: f64 = 24.0;
const R_ISLAND: f64 = 12.0;
const BRIDGE_W: f64 = 14.0; // px: 1.4 mm at 0.1 mm/px, wider than cardstock's 1 mm + allowance

/// A ring of cut around each island, and a horizontal bridge from the island's right side to the
/// sheet. Returns the bits and the bridge outlines in pixels.
fn stencil() -> (BitGrid, Vec<Vec<[f64; 2]>>) {
    let cell = SIZE as f64 / CELLS as f64;
    let bits = BitGrid::from_fn(SIZE, SIZE, |x, y| {
        let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
        let (i, j) = ((px / cell).floor(), (py / cell).floor());
        let (cx, cy) = ((i + 0.5) * cell, (j + 0.5) * cell);
        let d = ((px - cx).powi(2) + (py - cy).powi(2)).sqrt();
        let in_bridge = px >= cx && (py - cy).abs() < BRIDGE_W / 2.0;
        d > R_CUT || d <= R_ISLAND || in_bridge
    });
    let mut bridges = Vec::new();
    for j in 0..CELLS {
        for i in 0..CELLS {
            let (cx, cy) = ((i as f64 + 0.5) * cell, (j as f64 + 0.5) * cell);
            let (x0, x1) = (cx + R_ISLAND - 2.0, cx + R_CUT + 2.0);
            let (y0, y1) = (cy - BRIDGE_W / 2.0, cy + BRIDGE_W / 2.0);
            bridges.push(vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]);
        }
    }
    (bits, bridges)
}

fn bench(c: &mut Criterion) {
    // As the `stencil` binary runs.
    alloc::keep_freed_memory();
    let (bits, bridges) = stencil();
    let material = Material::default();
    let vcfg = VectorConfig {
        kerf_mm: material.kerf_mm,
        ..Default::default()
    };
    // Sanity: the synthetic stencil passes and is one piece.
    let (geom, stats, report) = pipeline::vectorize_and_check(
        &bits,
        Some(&bridges),
        &vcfg,
        &material,
        &mut Timings::default(),
    )
    .unwrap();
    assert_eq!(report.pieces, 1, "{:?}", report.violations.first());
    assert!(report.passed(), "{:?}", report.violations.first());
    eprintln!(
        "rings {}, points {} -> {}, cut loops {}, triangles {}",
        stats.simplify.rings,
        stats.simplify.points_in,
        stats.simplify.points_out,
        geom.cuts.0.len(),
        report.triangles
    );

    // The whole stage as `make` runs it, 30 times: the spread shows how noisy this machine is.
    let mut runs: Vec<(f64, f64)> = (0..30)
        .map(|_| {
            let mut tm = Timings::default();
            let s = std::time::Instant::now();
            pipeline::vectorize_and_check(&bits, Some(&bridges), &vcfg, &material, &mut tm)
                .unwrap();
            (s.elapsed().as_secs_f64() * 1e3, tm.get("check"))
        })
        .collect();
    runs.sort_by(|a, b| a.0.total_cmp(&b.0));
    eprintln!(
        "vectorize_and_check, 30 runs: best {:.1} ms, median {:.1} ms (of which the check {:.1} ms)",
        runs[0].0, runs[15].0, runs[15].1
    );
    breakdown(&bits, &bridges, &vcfg, &material);
    let mut g = c.benchmark_group("vector_2000px_1024_islands");
    g.sample_size(10);
    g.bench_function("vectorize_union_check", |b| {
        b.iter(|| {
            pipeline::vectorize_and_check(
                &bits,
                Some(&bridges),
                &vcfg,
                &material,
                &mut Timings::default(),
            )
            .unwrap()
        })
    });
    g.bench_function("trace", |b| b.iter(|| steps::trace(&bits, true)));
    g.bench_function("vectorize_design", |b| {
        b.iter(|| vector::vectorize_design(&bits, &bridges, &vcfg).unwrap())
    });
    g.bench_function("kerf", |b| {
        b.iter(|| kerf::offset_cuts(&geom.design_cuts, vcfg.kerf_mm))
    });
    g.bench_function("check", |b| {
        b.iter(|| check::check(&geom, &material, true).unwrap())
    });
    g.finish();
}

/// Each sub-step timed alone (best of five passes), printed, to show where the time goes.
fn breakdown(bits: &BitGrid, bridges: &[Vec<[f64; 2]>], vcfg: &VectorConfig, material: &Material) {
    let t = |name: &str, f: &mut dyn FnMut()| {
        let best = (0..5)
            .map(|_| {
                let s = std::time::Instant::now();
                f();
                s.elapsed().as_secs_f64() * 1e3
            })
            .fold(f64::INFINITY, f64::min);
        eprintln!("  {name:<28} {best:>8.1} ms");
    };
    let rings = steps::trace(bits, true);
    let (geom, _) = vector::vectorize(bits, bridges, vcfg).unwrap();
    eprintln!("breakdown (best of five passes each):");
    t("trace (marching squares)", &mut || {
        steps::trace(bits, true);
    });
    t("simplify", &mut || {
        let mut pts: Vec<Vec<[f64; 2]>> = rings.iter().map(|r| r.pts.clone()).collect();
        let guards: Vec<Vec<steps::Guard>> = rings.iter().map(|r| r.guards.clone()).collect();
        steps::simplify_rings(&mut pts, Some(&guards), 0.5);
    });
    t("union bridges (Clipper, by region)", &mut || {
        steps::union_bridges(geom.material.clone(), &geom.bridges).unwrap();
    });
    t("cuts_of", &mut || {
        steps::cuts_of(&geom.material);
    });
    t("kerf offset (Clipper)", &mut || {
        kerf::offset_cuts(&geom.design_cuts, vcfg.kerf_mm).unwrap();
    });
    t("vectorize_design (all but kerf)", &mut || {
        vector::vectorize_design(bits, bridges, vcfg).unwrap();
    });
    t("check (CDT + necks)", &mut || {
        check::check(&geom, material, true).unwrap();
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
