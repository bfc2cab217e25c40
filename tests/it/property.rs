//! Property: whatever the picture, the stencil is one 4-connected sheet joined to the frame, and it
//! differs from the two-tone only where cut became material.

use crate::common::*;
use proptest::prelude::*;

/// A random picture: blobs with holes, rings, noise of a given density, text-like strokes, or a
/// checkerboard.
#[derive(Debug, Clone)]
enum Pic {
    Blobs {
        discs: Vec<(f64, f64, f64, bool)>,
    },
    Rings {
        cx: f64,
        cy: f64,
        band: f64,
    },
    Noise {
        density: f64,
        block: u32,
        seed: u64,
    },
    /// Thin straight strokes (x0, y0, x1, y1, half width), ink on paper, like lettering.
    Strokes {
        lines: Vec<(f64, f64, f64, f64, f64)>,
    },
    Checker {
        cell: u32,
    },
}

fn pic() -> impl Strategy<Value = Pic> {
    prop_oneof![
        prop::collection::vec(
            (0.0..96.0f64, 0.0..72.0f64, 3.0..18.0f64, any::<bool>()),
            1..14
        )
        .prop_map(|discs| Pic::Blobs { discs }),
        (30.0..66.0f64, 25.0..47.0f64, 3.0..9.0f64).prop_map(|(cx, cy, band)| Pic::Rings {
            cx,
            cy,
            band
        }),
        (0.2..0.8f64, 1u32..5, any::<u64>()).prop_map(|(density, block, seed)| Pic::Noise {
            density,
            block,
            seed
        }),
        prop::collection::vec(
            (
                0.0..96.0f64,
                0.0..72.0f64,
                0.0..96.0f64,
                0.0..72.0f64,
                0.4..3.0f64
            ),
            1..12
        )
        .prop_map(|lines| Pic::Strokes { lines }),
        (1u32..12).prop_map(|cell| Pic::Checker { cell }),
    ]
}

fn ink(p: &Pic, x: u32, y: u32) -> bool {
    let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
    match p {
        // Later discs paint over earlier ones: ink (true) or paper (false), so paper discs
        // inside ink ones make islands.
        Pic::Blobs { discs } => discs
            .iter()
            .rev()
            .find(|(cx, cy, r, _)| (fx - cx).powi(2) + (fy - cy).powi(2) < r * r)
            .is_some_and(|d| d.3),
        Pic::Rings { cx, cy, band } => {
            let r = ((fx - cx).powi(2) + (fy - cy).powi(2)).sqrt();
            r < 5.0 * band && ((r / band) as i64) % 2 == 1
        }
        Pic::Noise {
            density,
            block,
            seed,
        } => {
            let (bx, by) = ((x / block) as u64, (y / block) as u64);
            let mut h = seed
                ^ (bx.wrapping_mul(0x9e37_79b9_7f4a_7c15))
                ^ (by.wrapping_mul(0xc2b2_ae3d_27d4_eb4f));
            h ^= h >> 31;
            h = h.wrapping_mul(0xbf58_476d_1ce4_e5b9);
            h ^= h >> 29;
            (h % 1000) as f64 / 1000.0 < *density
        }
        Pic::Strokes { lines } => lines.iter().any(|&(x0, y0, x1, y1, hw)| {
            let (dx, dy) = (x1 - x0, y1 - y0);
            let l2 = (dx * dx + dy * dy).max(1e-9);
            let t = (((fx - x0) * dx + (fy - y0) * dy) / l2).clamp(0.0, 1.0);
            let (px, py) = (x0 + t * dx - fx, y0 + t * dy - fy);
            px * px + py * py <= hw * hw
        }),
        Pic::Checker { cell } => ((x / cell) + (y / cell)) % 2 == 1,
    }
}

/// A number from the environment (so `PROPTEST_CASES` and `PROPTEST_RNG_SEED` still work with
/// the fixed defaults below), or the default.
fn env_or(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Every shipped material, by name.
fn materials() -> Vec<&'static str> {
    stencil_core::material::SHIPPED
        .iter()
        .map(|m| m.name)
        .collect()
}

proptest! {
    // A fixed seed: CI must not fail by the luck of the draw. Explore more with
    // `PROPTEST_CASES=100` and another `PROPTEST_RNG_SEED`; a failure found that way is a bug to fix.
    #![proptest_config(ProptestConfig {
        cases: env_or("PROPTEST_CASES", 12) as u32,
        rng_seed: proptest::test_runner::RngSeed::Fixed(env_or("PROPTEST_RNG_SEED", 0x0571_3c11)),
        .. ProptestConfig::default()
    })]

    /// Whatever the picture, for every shipped material at two sizes, `make` succeeds without
    /// `--allow-thin` (so its own width and connectivity check passes: no violation), writes one
    /// 4-connected sheet that bridges only added material to, and reports its fidelity.
    #[test]
    fn every_picture_every_material_makes_a_valid_stencil(p in pic()) {
        let dir = tmp();
        let input = dir.path().join("in.png");
        ink_png(&input, 96, 72, |x, y| ink(&p, x, y));
        for name in materials() {
            let (material, origin) = stencil_core::material::Material::find(name).unwrap();
            for size in [stencil_core::pipeline::Size::Default, stencil_core::pipeline::Size::WidthMm(40.0)] {
                let out = dir.path().join(format!("{name}-{size:?}"));
                let cfg = stencil_core::MakeConfig {
                    input: input.clone(),
                    out_dir: out.clone(),
                    physical: stencil_core::pipeline::PhysicalConfig {
                        size,
                        material: material.clone(),
                        material_source: origin.display().to_string(),
                        ..Default::default()
                    },
                    ..Default::default()
                };
                let what = format!("{p:?} {name} {size:?}");
                let (made, _) = stencil_core::make(&cfg).map_err(|e| TestCaseError::fail(format!("{what}: {e}")))?;
                prop_assert!(made.check.violations.is_empty(), "{what}: {:?}", made.check.violations);
                assert_valid_stencil(&out);
                let r = report(&out);
                prop_assert!(r["fidelity"]["changed_pct"].as_f64().is_some(), "{what}: no fidelity");
            }
        }
    }
}
