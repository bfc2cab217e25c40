//! Bridges in millimetres: the same picture made at two sizes gets bridges whose widths lie in
//! the material's range at both, read from report.json and measured on stencil.png, and the
//! outputs pass `stencil check`.

use crate::common::*;
use stencil_core::material::Material;
use stencil_core::raster::BitGrid;

/// Paper discs of five sizes, each inside a ring of ink: five islands, each to be bridged across
/// its ring (to the paper outside it, the frame).
fn discs(path: &std::path::Path) {
    const DISCS: [(f64, f64, f64); 5] = [
        (40.0, 40.0, 6.0),
        (110.0, 45.0, 12.0),
        (200.0, 60.0, 20.0),
        (80.0, 160.0, 30.0),
        (230.0, 170.0, 42.0),
    ];
    ink_png(path, 300, 240, |x, y| {
        DISCS.iter().any(|&(cx, cy, r)| {
            let d = (x as f64 + 0.5 - cx).hypot(y as f64 + 0.5 - cy);
            d > r && d <= r + 10.0
        })
    });
}

/// A bridge as made: its report entry and what stencil.png shows of it.
struct Measured {
    nodes: (u64, u64),
    width_mm: f64,
    /// Narrowest and widest run across the bridge at right angles, mm (see [`across`]).
    narrowest_mm: f64,
    widest_mm: f64,
}

/// Runs across each bridge of an output folder, measured on stencil.png and twotone.png at right
/// angles to the line from the middle of its outline's start (first and last points) to the middle
/// of its end (second and third), at stations a pixel apart, skipping `skip` px at either end
/// (where the clean-up rounds the joints). At each station through a pixel the bridge added, the
/// run of material through that point (stopping at cut; the narrowest), and the run of added
/// pixels (the widest), sampled every 0.1 px.
fn across(out: &std::path::Path, r: &serde_json::Value) -> Vec<Measured> {
    let st = read_bits(&out.join("stencil.png"));
    let two = read_bits(&out.join("twotone.png"));
    let mm = r["mm_per_px"].as_f64().unwrap();
    let skip = r["filter_radius_px"].as_f64().unwrap() + 2.0;
    let inside = |b: &BitGrid, x: f64, y: f64| {
        let (x, y) = (x.floor() as i64, y.floor() as i64);
        (x >= 0 && y >= 0 && x < b.width as i64 && y < b.height as i64)
            .then(|| b.get(x as u32, y as u32))
    };
    let material = |x: f64, y: f64| inside(&st, x, y).unwrap_or(true);
    let added =
        |x: f64, y: f64| inside(&st, x, y) == Some(true) && inside(&two, x, y) == Some(false);
    // The run through (x, y) along ±n while `test` holds; None if it runs 200 px.
    let run = |x: f64, y: f64, n: [f64; 2], test: &dyn Fn(f64, f64) -> bool| {
        let mut total = 0.0;
        for sign in [1.0, -1.0] {
            let mut u = 0.05;
            while test(x + sign * n[0] * u, y + sign * n[1] * u) {
                u += 0.1;
                if u > 200.0 {
                    return None;
                }
            }
            total += u - 0.05;
        }
        Some(total)
    };
    r["bridges"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| {
            let p: Vec<[f64; 2]> = serde_json::from_value(b["polygon_px"].clone()).unwrap();
            let a = [(p[0][0] + p[3][0]) / 2.0, (p[0][1] + p[3][1]) / 2.0];
            let e = [(p[1][0] + p[2][0]) / 2.0, (p[1][1] + p[2][1]) / 2.0];
            let len = (e[0] - a[0]).hypot(e[1] - a[1]);
            let d = [(e[0] - a[0]) / len, (e[1] - a[1]) / len];
            let n = [-d[1], d[0]];
            let (mut narrowest, mut widest) = (f64::INFINITY, 0.0f64);
            let mut k = skip.min(len / 2.0);
            while k <= (len - skip).max(len / 2.0) {
                let (x, y) = (a[0] + d[0] * k, a[1] + d[1] * k);
                k += 1.0;
                if !added(x, y) {
                    continue;
                }
                if let Some(w) = run(x, y, n, &material) {
                    narrowest = narrowest.min(w);
                }
                if let Some(w) = run(x, y, n, &added) {
                    widest = widest.max(w);
                }
            }
            Measured {
                nodes: (
                    b["nodes"][0].as_u64().unwrap(),
                    b["nodes"][1].as_u64().unwrap(),
                ),
                width_mm: b["width_mm"].as_f64().expect("width_mm in the report"),
                narrowest_mm: narrowest * mm,
                widest_mm: widest * mm,
            }
        })
        .collect()
}

/// The same picture at `--width-mm 50` and `200`, in cardstock (bridges 1–4 mm) and in Mylar
/// (1.5–6 mm). Before widths were in millimetres the 200 mm stencil got bridges four times as
/// wide as the 50 mm one, up to 17.5 mm in cardstock, and some narrower than the minimum.
#[test]
fn the_same_picture_at_two_sizes_gets_bridges_in_the_materials_range() {
    let dir = tmp();
    let input = dir.path().join("discs.png");
    discs(&input);
    for material in ["cardstock", "mylar-0.19"] {
        let (m, _) = Material::find(material).unwrap();
        let (lo, hi) = (m.min_bridge_mm, m.max_bridge_mm);
        assert!(hi > lo);
        let mut widths = Vec::new();
        for size in ["50", "200"] {
            let out = dir.path().join(format!("{material}-{size}"));
            let o = stencil(&[
                "make",
                s(&input),
                "-o",
                s(&out),
                "--material",
                material,
                "--width-mm",
                size,
            ]);
            assert!(o.status.success(), "{material} {size}: {}", stderr(&o));
            assert_valid_stencil(&out);
            let o = stencil(&["check", s(&out)]);
            assert!(
                o.status.success(),
                "stencil check {material} {size}: {}",
                stderr(&o)
            );
            let r = report(&out);
            assert_eq!(r["islands"], 5, "{material} {size}");
            let mm = r["mm_per_px"].as_f64().unwrap();
            let bridges = across(&out, &r);
            for b in &bridges {
                let what = format!(
                    "{material} at {size} mm, bridge {:?}: report {:.2} mm, measured {:.2}..{:.2} mm, range {lo}..{hi} mm",
                    b.nodes, b.width_mm, b.narrowest_mm, b.widest_mm
                );
                assert!(b.width_mm >= lo - 1e-9 && b.width_mm <= hi + 1e-9, "{what}");
                // Measured through pixel squares: a slanted band reads up to a pixel narrower
                // than its count of pixels (the tracing allowance covers it), a staircase edge a
                // pixel wider.
                assert!(b.narrowest_mm.is_finite(), "{what}: nothing measured");
                assert!(b.narrowest_mm >= lo - mm, "{what}");
                assert!(b.narrowest_mm <= hi + mm, "{what}");
                assert!(b.widest_mm <= hi + 1.5 * mm, "{what}");
            }
            widths.push(bridges);
        }
        // The same class at both sizes. The rule gives an island k·√A, a quarter of its side, so
        // an island four times larger on the sheet asks for a bridge four times wider; what keeps
        // the class is the material's range: the widest bridges here are within a factor of 2
        // (under the pixel rule: 3.67 and 12.7 mm), and no island's bridge grows by more than the
        // picture does.
        let widest = |v: &[Measured]| v.iter().map(|b| b.width_mm).fold(0.0, f64::max);
        let (w50, w200) = (widest(&widths[0]), widest(&widths[1]));
        assert!(
            w200 <= 2.0 * w50,
            "{material}: widest bridge {w50:.2} mm at 50 mm, {w200:.2} mm at 200 mm"
        );
        for b in &widths[1] {
            if let Some(a) = widths[0].iter().find(|a| a.nodes == b.nodes) {
                assert!(
                    b.width_mm <= 4.0 * a.width_mm + 1e-9,
                    "{material}: bridge {:?} {:.2} mm at 50 mm, {:.2} mm at 200 mm",
                    b.nodes,
                    a.width_mm,
                    b.width_mm
                );
            }
        }
        for (size, v) in ["50", "200"].iter().zip(&widths) {
            let list: Vec<String> = v
                .iter()
                .map(|b| {
                    format!(
                        "{:?} {:.2} mm ({:.2}..{:.2})",
                        b.nodes, b.width_mm, b.narrowest_mm, b.widest_mm
                    )
                })
                .collect();
            eprintln!("{material} at {size} mm: {}", list.join(", "));
        }
    }
}
