//! Where a studio change spends its time, stage by stage (`cargo bench --bench stages`, or
//! `cargo bench --bench stages -- mesh` for the 200k-triangle mesh): the stages a threshold
//! change (the photo) or a light change (the mesh) re-runs, called as the engine calls them,
//! each timed 12 times alternating between two values, and for the mesh the draw a view change
//! re-runs, step by step; medians in ms of wall time. The studio bench (`benches/studio.rs`)
//! gives the end-to-end latency; this says which stage to make faster.

use std::time::Instant;
use stencil_core::pipeline::{self, SourceParams, Timings};
use stencil_core::tone::mesh::Mesh;
use stencil_core::tone::Threshold;
#[path = "../crates/stencil-core/tests/support/shapes.rs"]
mod shapes;
#[path = "support/studio_inputs.rs"]
mod studio_inputs;

fn main() {
    let meshy = std::env::args().any(|a| a == "mesh");
    let mut cfg = studio_inputs::photo();
    if meshy {
        let m = shapes::displaced_sphere(130);
        let dir = std::env::temp_dir().join(format!("stencil-stages-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let obj = dir.join("bumpy.obj");
        std::fs::write(&obj, m.to_obj("bumpy")).unwrap();
        cfg = studio_inputs::mesh(obj);
    }
    let sp = SourceParams::of(&cfg).unwrap();
    let input = pipeline::load(&cfg.input, &sp).unwrap();
    let drawn = pipeline::draw(&input, &sp).unwrap();
    if meshy {
        let _ = std::fs::remove_dir_all(cfg.input.parent().unwrap());
    }
    let mut tot: std::collections::BTreeMap<String, Vec<f64>> = Default::default();
    for i in 0..12 {
        let mut t = |n: &str, s: Instant| {
            tot.entry(n.into())
                .or_default()
                .push(s.elapsed().as_secs_f64() * 1e3)
        };
        if meshy {
            cfg.mesh.light = if i % 2 == 0 {
                [1.0, 1.0, 2.0]
            } else {
                [-1.0, 1.0, 2.0]
            };
        } else {
            cfg.tone.threshold = Threshold::Level(if i % 2 == 0 { 120 } else { 136 });
        }
        let sp = SourceParams::of(&cfg).unwrap();
        let s = Instant::now();
        let source = pipeline::light(&input, drawn.as_deref(), &sp).unwrap();
        t("0 light", s);
        let params = stencil_core::stage_params(&cfg, &source).unwrap();
        let s = Instant::now();
        let gray = pipeline::working_gray(source.clone(), params.working.factor);
        t("0b gray", s);
        let s = Instant::now();
        let (raw, level) = pipeline::threshold(&source, gray, &params.tone);
        t("1 threshold", s);
        // The studio keeps the picture's side of the likeness while the gray stays (a threshold
        // change); a mesh's light change makes a new gray, so it is made again.
        let s = Instant::now();
        let look = pipeline::look(&raw);
        t("1b look", s);
        let s = Instant::now();
        let c = pipeline::clean(raw, level, &params.clean, &look);
        t("2 clean", s);
        let s = Instant::now();
        look.of_bits(&c.twotone.bits, false);
        t("2b likeness", s);
        // The clean-up with the morphological filter instead of the regularisation (what an
        // explicit `--filter-radius` runs): the filter and the likeness.
        let filtered = pipeline::CleanParams {
            regularize_px: None,
            ..params.clean
        };
        let raw2 = pipeline::threshold(&source, c.twotone.gray.clone(), &params.tone).0;
        let s = Instant::now();
        std::hint::black_box(pipeline::clean(raw2, level, &filtered, &look));
        t("2c clean by filter", s);
        let mut timer = Timings::new(None);
        let s = Instant::now();
        let p = pipeline::prepare(c.twotone.clone(), c.level, &params.join, &mut timer).unwrap();
        t("3 prepare", s);
        // Inside the prepare, which its timings do not split: the labelling the drop starts
        // from, and the walks' own phases (candidates, gaps, walks), run again on its result.
        let s = Instant::now();
        std::hint::black_box(stencil_core::islands::label(&c.twotone.bits));
        t("3a label", s);
        let mut wt = Timings::new(None);
        let s = Instant::now();
        std::hint::black_box(
            stencil_core::bridge::walk(&p.twotone, &p.map, &params.join.bridge, &mut wt).unwrap(),
        );
        t("3b walk", s);
        let s = Instant::now();
        let j = pipeline::bridge_prepared(&p, &params.join, &mut timer).unwrap();
        t("4 bridge", s);
        let s = Instant::now();
        let idx = stencil_core::export::png::preview_indexed(
            &c.twotone.gray,
            &c.picture,
            &j.twotone.bits,
            &j.bridged.bits,
            &j.dropped_px,
        );
        t("5 preview", s);
        std::hint::black_box(idx);
        for (k, v) in timer.iter() {
            tot.entry(format!("  {k}")).or_default().push(v);
        }
        for (k, v) in wt.iter() {
            tot.entry(format!("  3b {k}")).or_default().push(v);
        }
    }
    if meshy {
        // The view change: the draw (raster, surfaces, lines), alternating two azimuths.
        for i in 0..6 {
            cfg.mesh.azimuth_deg = if i % 2 == 0 { 20.0 } else { 30.0 };
            let sp = SourceParams::of(&cfg).unwrap();
            let s = Instant::now();
            let d = pipeline::draw(&input, &sp).unwrap().unwrap();
            tot.entry("6 draw".into())
                .or_default()
                .push(s.elapsed().as_secs_f64() * 1e3);
            for (k, v) in d.timings.iter() {
                tot.entry(format!("  draw {k}")).or_default().push(v);
            }
        }
    }
    for (k, mut v) in tot {
        v.sort_by(f64::total_cmp);
        println!("{k:20} median {:7.1} ms", v[v.len() / 2]);
    }
}
