//! Bridging speed on generated pictures: 1280×720 and 1920×1080, about 100 and about 1,000 islands.
//! `cargo bench --bench bridge`. Labelling is measured on its own, and `connect` with the default
//! candidates and with the paper's walks alone (`connect-walks-only`); before the criterion runs,
//! one run per image prints where `connect`'s time goes (phase by phase).
//!
//! The pictures: paper (material) with ink donuts (cut) on a jittered grid, each holding a paper
//! spot (the island); sizes vary with a fixed seed. The gray is the two-tone with a faint
//! left-to-right shading in the ink, as from a scanned print.

/// The binary's allocator settings, so that the bench measures what `stencil` runs.
#[path = "../src/alloc.rs"]
mod alloc;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use stencil_core::bridge::{connect, connect_timed, BridgeConfig};
use stencil_core::islands::label;
use stencil_core::pipeline::Timings;
use stencil_core::raster::{BitGrid, Gray, TwoTone};

struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// About `islands` donuts on a `w`×`h` sheet.
fn picture(w: u32, h: u32, islands: usize, seed: u64) -> TwoTone {
    let mut rng = Lcg(seed);
    let aspect = w as f64 / h as f64;
    let rows = ((islands as f64 / aspect).sqrt().round() as u32).max(1);
    let cols = ((islands as f64 / rows as f64).round() as u32).max(1);
    let (cw, ch) = (w as f64 / cols as f64, h as f64 / rows as f64);
    let cell = cw.min(ch);
    let mut bits = BitGrid::new(w, h, true);
    for r in 0..rows {
        for c in 0..cols {
            let outer = cell * (0.30 + 0.12 * rng.next());
            let inner = outer * (0.35 + 0.25 * rng.next());
            let cx = (c as f64 + 0.5) * cw + (rng.next() - 0.5) * (cw / 2.0 - outer).max(0.0);
            let cy = (r as f64 + 0.5) * ch + (rng.next() - 0.5) * (ch / 2.0 - outer).max(0.0);
            // A slightly elliptical spot so borders are not all circles.
            let squash = 0.7 + 0.3 * rng.next();
            let (x0, x1) = (
                (cx - outer).max(0.0) as u32,
                ((cx + outer) as u32).min(w - 1),
            );
            let (y0, y1) = (
                (cy - outer).max(0.0) as u32,
                ((cy + outer) as u32).min(h - 1),
            );
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
                    let d2 = dx * dx + dy * dy;
                    if d2 <= outer * outer {
                        let spot = (dx * dx) / (inner * inner)
                            + (dy * dy) / (inner * inner * squash * squash);
                        bits.set(x, y, spot <= 1.0);
                    }
                }
            }
        }
    }
    let gray = Gray {
        width: w,
        height: h,
        data: bits
            .data
            .iter()
            .enumerate()
            .map(|(i, &b)| {
                if b {
                    1.0
                } else {
                    0.3 * (i as u32 % w) as f32 / w as f32
                }
            })
            .collect(),
    };
    TwoTone {
        bits,
        gray: gray.into(),
    }
}

fn bench(c: &mut Criterion) {
    // As the `stencil` binary runs (see `crate::alloc`).
    alloc::keep_freed_memory();
    let cfg = BridgeConfig::default();
    let mut group = c.benchmark_group("bridge");
    group.sample_size(20);
    for &(w, h) in &[(1280u32, 720u32), (1920, 1080)] {
        for &n in &[100usize, 1000] {
            let two = picture(w, h, n, 7);
            let map = label(&two.bits);
            let mut times = Timings::default();
            let out = connect_timed(&two, &map, &cfg, &mut times).expect("bridging succeeds");
            let perimeter: usize = map.nodes[1..].iter().map(|n| n.border.len()).sum();
            println!(
                "{w}x{h}: {} islands, perimeter {perimeter} px, {} bridges ({} support); phases ms: {}",
                map.island_count(),
                out.bridges.len(),
                out.bridges.iter().filter(|b| b.support).count(),
                times
                    .iter()
                    .map(|(k, v)| format!("{k} {v:.2}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            assert_eq!(label(&out.bits).island_count(), 0);
            let id = format!("{w}x{h}/{}", map.island_count());
            group.bench_function(BenchmarkId::new("label", &id), |b| {
                b.iter(|| label(&two.bits))
            });
            group.bench_function(BenchmarkId::new("connect", &id), |b| {
                b.iter(|| connect(&two, &map, &cfg).expect("bridging succeeds"))
            });
            // The paper's candidates alone, for what the shortest gaps cost in the same run.
            let walks = BridgeConfig {
                gaps: false,
                ..cfg.clone()
            };
            group.bench_function(BenchmarkId::new("connect-walks-only", &id), |b| {
                b.iter(|| connect(&two, &map, &walks).expect("bridging succeeds"))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
