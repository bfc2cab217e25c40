//! Planning speed: ordering and start points for many loops, writing, and the time estimate.
//! `cargo bench --bench plan`

use criterion::{criterion_group, criterion_main, Criterion};
use geo::{Coord, LineString, MultiPolygon, Polygon, Rect};
use stencil_gcode::interpret::interpret;
use stencil_gcode::machine;
use stencil_gcode::CutLoops;
use stencil_gcode::{estimate, gcode_for, CutSettings, PlanConfig};

/// `n × n` circles of 32 vertices on a 10 mm grid, in a scrambled order.
fn grid(n: usize) -> CutLoops {
    let mut cuts = Vec::new();
    for k in 0..n * n {
        let idx = (k * 7919) % (n * n);
        let (cx, cy) = (10.0 * (idx % n) as f64 + 5.0, 10.0 * (idx / n) as f64 + 5.0);
        let pts: Vec<(f64, f64)> = (0..=32)
            .map(|i| {
                let a = i as f64 / 32.0 * std::f64::consts::TAU;
                (cx + 3.0 * a.cos(), cy + 3.0 * a.sin())
            })
            .collect();
        cuts.push(Polygon::new(LineString::from(pts), vec![]));
    }
    let (w, h) = (10.0 * n as f64, 10.0 * n as f64);
    let outline = Rect::new(Coord { x: 0.0, y: 0.0 }, Coord { x: w, y: h });
    CutLoops::drawn(outline, MultiPolygon(cuts))
}

fn bench(c: &mut Criterion) {
    let m = machine::load(None).unwrap();
    let cfg = PlanConfig::new(CutSettings {
        power_pct: 50.0,
        speed_mm_min: 1500.0,
        passes: 1,
        blade_offset_mm: 0.0,
        air_assist: false,
    });
    for n in [10, 30] {
        let g = grid(n);
        c.bench_function(&format!("plan+write {} loops", n * n), |b| {
            b.iter(|| gcode_for(&g, &m, &cfg, &[]).unwrap())
        });
    }
    let (text, _) = gcode_for(&grid(30), &m, &cfg, &[]).unwrap();
    let moves = interpret(&text).unwrap();
    c.bench_function(&format!("estimate {} moves", moves.len()), |b| {
        b.iter(|| estimate(&moves, &m.motion))
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);
