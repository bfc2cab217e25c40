//! The bridge stage's tests, end to end through [`super::connect`], and the helpers other bridge tests share.

use super::*;
use crate::islands::{self, label};
use crate::raster::Gray;
use crate::test_rng::Lcg;

/// A two-tone whose gray is the bits themselves: white material, black cut.
pub(crate) fn black_white(bits: BitGrid) -> TwoTone {
    let gray = Gray {
        width: bits.width,
        height: bits.height,
        data: bits
            .data
            .iter()
            .map(|&b| if b { 1.0 } else { 0.0 })
            .collect(),
    };
    TwoTone {
        bits,
        gray: gray.into(),
    }
}

/// Connect, then check what a user relies on: no floating piece, nothing cut that was
/// material, every bridge reported with its pixels.
fn connect_and_check(two: &TwoTone, cfg: &BridgeConfig) -> Bridged {
    let map = label(&two.bits);
    let out = connect(two, &map, cfg).unwrap();
    assert_eq!(label(&out.bits).island_count(), 0, "pieces still float");
    for (i, (&before, &after)) in two.bits.data.iter().zip(&out.bits.data).enumerate() {
        assert!(!before || after, "pixel {i} was material and is cut now");
    }
    let added = out
        .bits
        .data
        .iter()
        .zip(&two.bits.data)
        .filter(|(a, b)| **a && !**b)
        .count();
    assert_eq!(added, out.bridges.iter().map(|b| b.pixels).sum::<usize>());
    assert!(out.bridges.len() >= map.island_count());
    for b in &out.bridges {
        assert!(b.nodes[0] < b.nodes[1] && (b.nodes[1] as usize) < map.nodes.len());
        // Measured width: may overshoot the target by a pixel on a staircase edge.
        assert!(b.width_px >= cfg.min_width_px && b.width_px <= cfg.max_width_px + 1);
        assert_eq!(b.polygon.len(), 4);
        assert!(b.cost.total.is_finite());
    }
    out
}

fn rings(n: u32, depth: u32, band: u32) -> BitGrid {
    let c = n as f64 / 2.0;
    BitGrid::from_fn(n, n, |x, y| {
        let r = ((x as f64 + 0.5 - c).powi(2) + (y as f64 + 0.5 - c).powi(2)).sqrt();
        // Frame outside radius c - band; then alternating cut / material bands inwards.
        let k = ((c - r) / band as f64).floor() as i64;
        k <= 0 || (k % 2 == 0 && k <= 2 * depth as i64)
    })
}

#[test]
fn nested_rings_five_deep_are_all_joined() {
    let bits = rings(160, 5, 7);
    let two = black_white(bits);
    let islands = label(&two.bits).island_count();
    assert_eq!(islands, 5);
    let out = connect_and_check(&two, &BridgeConfig::default());
    // A tree over 6 nodes needs at least 5 bridges.
    assert!(out.bridges.iter().filter(|b| !b.support).count() >= 5);
}

#[test]
fn checkerboard_squares_touching_at_corners_are_bridged() {
    let bits = BitGrid::from_fn(96, 96, |x, y| {
        if x < 4 || y < 4 || x >= 92 || y >= 92 {
            return true;
        }
        if !(8..88).contains(&x) || !(8..88).contains(&y) {
            return false;
        }
        ((x - 8) / 8 + (y - 8) / 8) % 2 == 0
    });
    let two = black_white(bits);
    assert_eq!(label(&two.bits).island_count(), 50);
    connect_and_check(&two, &BridgeConfig::default());
}

pub(crate) fn blobs(w: u32, h: u32, count: usize, seed: u64) -> BitGrid {
    let mut rng = Lcg(seed);
    let discs: Vec<(f64, f64, f64)> = (0..count)
        .map(|_| {
            (
                rng.unit() * w as f64,
                rng.unit() * h as f64,
                2.0 + rng.unit() * 9.0,
            )
        })
        .collect();
    let mut bits = BitGrid::new(w, h, false);
    for &(cx, cy, r) in &discs {
        let (x0, x1) = ((cx - r).max(0.0) as u32, ((cx + r) as u32).min(w - 1));
        let (y0, y1) = ((cy - r).max(0.0) as u32, ((cy + r) as u32).min(h - 1));
        for y in y0..=y1 {
            for x in x0..=x1 {
                if (x as f64 + 0.5 - cx).powi(2) + (y as f64 + 0.5 - cy).powi(2) <= r * r {
                    bits.set(x, y, true);
                }
            }
        }
    }
    bits
}

#[test]
fn random_blobs_are_all_joined() {
    for seed in [1u64, 7, 42] {
        let bits = blobs(200, 150, 60, seed);
        let two = black_white(bits);
        assert!(label(&two.bits).island_count() > 10, "seed {seed}");
        connect_and_check(&two, &BridgeConfig::default());
    }
}

/// Noise at random densities, random discs of both tones, and concentric bands, on small
/// images of random size: every one must come out as one sheet. (Seed 84 once left a
/// one-pixel island floating when a fallback strip overwrote a walked strip another edge used.)
#[test]
fn random_noise_discs_and_bands_are_always_joined() {
    for seed in 0..300u64 {
        let mut r = Lcg(seed * 7919 + 1);
        let (w, h) = (
            20 + (r.unit() * 100.0) as u32,
            20 + (r.unit() * 80.0) as u32,
        );
        let dens = r.unit();
        let bits = match seed % 3 {
            0 => BitGrid::from_fn(w, h, |_, _| r.unit() < dens),
            1 => {
                let mut b = BitGrid::new(w, h, r.unit() < 0.5);
                for _ in 0..(5 + (dens * 40.0) as usize) {
                    let (cx, cy) = (r.unit() * w as f64, r.unit() * h as f64);
                    let (rad, v) = (1.0 + r.unit() * 8.0, r.unit() < 0.5);
                    for y in 0..h {
                        for x in 0..w {
                            if (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2) <= rad * rad {
                                b.set(x, y, v);
                            }
                        }
                    }
                }
                b
            }
            _ => {
                let (cx, cy) = (w as f64 / 2.0, h as f64 / 2.0);
                let band = 1.0 + r.unit() * 4.0;
                BitGrid::from_fn(w, h, |x, y| {
                    (((x as f64 - cx).hypot(y as f64 - cy) / band) as u32).is_multiple_of(2)
                })
            }
        };
        let gray = Gray {
            width: w,
            height: h,
            data: (0..bits.len())
                .map(|i| {
                    if bits.data[i] {
                        1.0
                    } else {
                        ((i * 37) % 100) as f32 / 300.0
                    }
                })
                .collect(),
        };
        let cfg = BridgeConfig {
            max_length_px: 400,
            ..Default::default()
        };
        connect_and_check(
            &TwoTone {
                bits,
                gray: gray.into(),
            },
            &cfg,
        );
    }
}

#[test]
fn shaded_gray_and_one_pixel_islands_are_joined() {
    // Single-pixel islands on a gray ramp: walks steer by the gray, fallbacks thicken.
    let bits = BitGrid::from_fn(60, 40, |x, y| (x % 6 == 3 && y % 6 == 3) || y == 0);
    let gray = Gray {
        width: 60,
        height: 40,
        data: (0..60 * 40)
            .map(|i| {
                if bits.data[i] {
                    1.0
                } else {
                    (i % 60) as f32 / 120.0
                }
            })
            .collect(),
    };
    connect_and_check(
        &TwoTone {
            bits,
            gray: gray.into(),
        },
        &BridgeConfig::default(),
    );
}

#[test]
fn an_island_beyond_the_length_limit_is_joined_by_the_search() {
    let bits = BitGrid::from_fn(60, 60, |x, y| {
        (25..35).contains(&x) && (25..35).contains(&y)
    });
    let two = black_white(bits);
    let cfg = BridgeConfig {
        max_length_px: 10,
        ..Default::default()
    };
    // No walk of at most 10 px reaches the image edge 25 px away: once a cut-off, now the
    // search joins it, by a bridge longer than the limit, marked as such.
    let out = connect_and_check(&two, &cfg);
    assert_eq!(out.bridges.len(), 1);
    let b = &out.bridges[0];
    assert_eq!(b.via, Via::Search);
    assert!(b.length_px > 10.0, "{b:?}");
    // With the default limit a walk joins it.
    let out = connect_and_check(&two, &BridgeConfig::default());
    assert!(out.bridges.iter().all(|b| b.via == Via::Walk));
}

#[test]
fn an_island_500_px_from_anything_is_joined() {
    // A frame band 10 px wide round a black field; a 20 × 20 island in the middle, 500 px from
    // the band on every side (and from the image edge beyond it): no walk of 200 px gets out.
    let n = 10 + 500 + 20 + 500 + 10;
    let island = |v: u32| (510..530).contains(&v);
    let bits = BitGrid::from_fn(n, n, |x, y| {
        x < 10 || y < 10 || x >= n - 10 || y >= n - 10 || (island(x) && island(y))
    });
    let two = black_white(bits);
    let map = label(&two.bits);
    assert_eq!(map.island_count(), 1);
    let cfg = BridgeConfig::default();
    let out = connect(&two, &map, &cfg).unwrap();
    assert_eq!(
        islands::floating_count(&out.bits),
        0,
        "the island still floats"
    );
    assert_eq!(label(&out.bits).island_count(), 0);
    for (&before, &after) in two.bits.data.iter().zip(&out.bits.data) {
        assert!(!before || after, "material was cut");
    }
    assert_eq!(out.bridges.len(), 1);
    let b = &out.bridges[0];
    assert_eq!((b.nodes, b.via, b.support), ([0, 1], Via::Search, false));
    assert!(b.length_px >= 500.0, "{b:?}");
    // Straight (along a row or a column, the shortest way over flat black) and as wide as
    // the minimum all along: its added pixels fill a band min_width..min_width + 2 across.
    let (w, min) = (n as usize, cfg.min_width_px as usize);
    let added: Vec<(usize, usize)> = (0..two.bits.len())
        .filter(|&i| out.bits.data[i] && !two.bits.data[i])
        .map(|i| (i % w, i / w))
        .collect();
    assert_eq!(added.len(), b.pixels);
    let span = |k: fn(&(usize, usize)) -> usize| {
        added.iter().map(k).max().unwrap() - added.iter().map(k).min().unwrap() + 1
    };
    let across = span(|p| p.0).min(span(|p| p.1));
    assert!((min..=min + 2).contains(&across), "{across} px across");
    assert!(added.len() >= 500 * min, "{} pixels", added.len());
    // Outlined as a band of the minimum width (so the check measures it as a bridge), lying
    // on material: here an axis-aligned rectangle, every pixel centre inside it material.
    let p = &b.polygon;
    assert!(((p[0][0] - p[3][0]).hypot(p[0][1] - p[3][1]) - min as f64).abs() < 1e-9);
    let (lo, hi) = p
        .iter()
        .fold(([f64::MAX; 2], [f64::MIN; 2]), |(lo, hi), q| {
            (
                [lo[0].min(q[0]), lo[1].min(q[1])],
                [hi[0].max(q[0]), hi[1].max(q[1])],
            )
        });
    assert!(
        (hi[0] - lo[0]).min(hi[1] - lo[1]) >= min as f64 - 1e-9,
        "{p:?}"
    );
    for y in lo[1].floor() as u32..=(hi[1].ceil() as u32).min(n - 1) {
        for x in lo[0].floor() as u32..=(hi[0].ceil() as u32).min(n - 1) {
            let c = (x as f64 + 0.5, y as f64 + 0.5);
            if c.0 > lo[0] && c.0 < hi[0] && c.1 > lo[1] && c.1 < hi[1] {
                assert!(out.bits.get(x, y), "({x}, {y}) in the outline is cut");
            }
        }
    }
}

#[test]
fn fallback_search_joins_an_island_whose_walks_all_fail() {
    // A one-pixel bar whose normals all run more than 12 px to the frame, and a frame tooth
    // hanging from the top whose tip is 14 cut pixels away diagonally: no walk or straight
    // gap under the limit finds it, the search does.
    let bits = BitGrid::from_fn(60, 60, |x, y| {
        (y == 30 && (20..=40).contains(&x)) || (x == 10 && y <= 25)
    });
    let two = black_white(bits);
    let map = label(&two.bits);
    assert_eq!(map.island_count(), 1);
    // The shortest gap to the tip is 11.2 px, but its straight strip is 14 pixels.
    let cfg = BridgeConfig {
        max_length_px: 12,
        ..Default::default()
    };
    let fields = strips::Fields::new(&two, &map);
    let c = candidates::collect(&map);
    assert!((0..c.len()).all(|id| strips::walk_candidate(&fields, &c, id, 12).is_err()));
    let out = connect_and_check(&two, &cfg);
    assert_eq!(out.bridges.len(), 1);
    assert_eq!(out.bridges[0].via, Via::Search);
    // From the bar's left end to the tooth's tip: a straight band 3 px wide between them.
    let p = &out.bridges[0].polygon;
    assert!(
        p.iter()
            .all(|q| (8.0..=22.0).contains(&q[0]) && (24.0..=32.0).contains(&q[1])),
        "{p:?}"
    );
}

#[test]
fn a_fanning_bridge_is_halved_and_gets_a_support() {
    // A disc of radius 12 far from the frame: its strips fan out, so the drawn bridge covers
    // far more dark pixels than its strips promised.
    let n = 110u32;
    let disc =
        |x: u32, y: u32| (x as f64 + 0.5 - 55.0).powi(2) + (y as f64 + 0.5 - 55.0).powi(2) <= 144.0;
    let two = black_white(BitGrid::from_fn(n, n, disc));
    let cfg = BridgeConfig {
        min_width_px: 2,
        ..Default::default()
    };
    let map = label(&two.bits);
    let need = grow::width_for(map.nodes[1].area, &cfg);
    assert!(need >= 4, "{need}");
    // The paper's walks alone: a shortest gap leaves the disc as a parallel band.
    let cfg = BridgeConfig { gaps: false, ..cfg };
    let out = connect_and_check(&two, &cfg);
    assert_eq!(out.bridges.len(), 2);
    assert!(!out.bridges[0].support && out.bridges[1].support);
    assert_eq!(out.bridges[0].width_px, need / 2);
    assert_eq!(out.bridges[1].width_px, need / 2);
    // Apart from each other.
    let c = |b: &Bridge| b.polygon[0];
    let (a, b) = (c(&out.bridges[0]), c(&out.bridges[1]));
    assert!((a[0] - b[0]).hypot(a[1] - b[1]) > need as f64);

    // With a wide margin the same bridge stays whole and alone.
    let relaxed = BridgeConfig {
        support_margin: 1000.0,
        ..cfg.clone()
    };
    let out = connect_and_check(&two, &relaxed);
    assert_eq!(out.bridges.len(), 1);
    assert_eq!(out.bridges[0].width_px, need);
}

#[test]
fn a_square_bridge_across_a_straight_gap_needs_no_support() {
    // Straight parallel strips: the drawn bridge is exactly its strips.
    let bits = BitGrid::from_fn(80, 80, |x, y| {
        y < 4 || ((10..70).contains(&x) && (10..70).contains(&y))
    });
    let two = black_white(bits);
    let cfg = BridgeConfig {
        min_width_px: 2,
        ..Default::default()
    };
    let out = connect_and_check(&two, &cfg);
    assert_eq!(out.bridges.len(), 1);
    assert!(!out.bridges[0].support);
}

#[test]
fn bad_settings_are_refused_by_name() {
    let two = black_white(BitGrid::new(4, 4, true));
    let map = label(&two.bits);
    for cfg in [
        BridgeConfig {
            alpha: 2.0,
            ..Default::default()
        },
        BridgeConfig {
            w_length: -1.0,
            ..Default::default()
        },
        BridgeConfig {
            min_width_px: 50,
            ..Default::default()
        },
    ] {
        let e = connect(&two, &map, &cfg).unwrap_err();
        assert!(matches!(e, BridgeError::BadSetting { .. }), "{e}");
    }
}

#[test]
fn no_islands_means_no_bridges() {
    let two = black_white(BitGrid::from_fn(10, 10, |x, _| x < 3));
    let out = connect_and_check(&two, &BridgeConfig::default());
    assert!(out.bridges.is_empty());
    assert_eq!(out.bits, two.bits);
}

// Helpers the bridge modules' tests share.

// Helpers the bridge modules' tests share.

pub(crate) fn two(rows: &[&str]) -> TwoTone {
    crate::bridge::tests::black_white(BitGrid::from_fn(
        rows[0].len() as u32,
        rows.len() as u32,
        |x, y| rows[y as usize].as_bytes()[x as usize] == b'#',
    ))
}

pub(crate) fn four_connected(pixels: &[u32], w: u32) -> bool {
    pixels.windows(2).all(|p| {
        let (a, b) = (p[0], p[1]);
        let (ax, ay, bx, by) = (a % w, a / w, b % w, b / w);
        ax.abs_diff(bx) + ay.abs_diff(by) == 1
    })
}

/// Numbers for the random pictures below (31 bits each, the generator's high ones).
pub(crate) fn rng(seed: u64) -> impl FnMut() -> u64 {
    let mut r = Lcg(seed);
    move || r.next_u64() >> 33
}

/// Random specks and blobs of material (clustered, so there are islands of all sizes) over a
/// random gray, `w`×`h`.
pub(crate) fn random_picture(w: u32, h: u32, next: &mut impl FnMut() -> u64) -> TwoTone {
    let centres: Vec<(i64, i64, i64)> = (0..(w * h / 150).max(2))
        .map(|_| {
            (
                (next() % w as u64) as i64,
                (next() % h as u64) as i64,
                (next() % 5) as i64,
            )
        })
        .collect();
    let bits = BitGrid::from_fn(w, h, |x, y| {
        centres
            .iter()
            .any(|&(cx, cy, r)| (x as i64 - cx).pow(2) + (y as i64 - cy).pow(2) <= r * r)
    });
    let mut gray = Gray::new(w, h, 0.0);
    let smooth = next().is_multiple_of(2);
    for y in 0..h {
        for x in 0..w {
            let v = if smooth {
                ((x as f32 * 0.13).sin() + (y as f32 * 0.07).cos()) * 0.25 + 0.5
            } else {
                (next() % 1000) as f32 / 1000.0
            };
            gray.set(x, y, v);
        }
    }
    TwoTone {
        bits,
        gray: gray.into(),
    }
}
