//! One test per cost term: a scene built so that raising that term's weight moves the chosen
//! bridge from place A to place B. Each test first shows the bridge at A with the weight low, then
//! at B with it high, reading the bridge's position from its polygon and from the stencil bits.
//!
//! Scenes are hand-made two-tone images with a hand-made grayscale: one island between a frame
//! band on the left and one on the right, each gap with its own gray.

use stencil_core::bridge::{connect, Bridge, BridgeConfig, Bridged};
use stencil_core::islands::label;
use stencil_core::raster::{BitGrid, Gray, TwoTone};

const W: u32 = 140;
const H: u32 = 110;

/// Build a scene from a material test and a gray value for cut pixels (material is white).
fn scene(material: impl Fn(u32, u32) -> bool, cut_gray: impl Fn(u32, u32) -> f32) -> TwoTone {
    let bits = BitGrid::from_fn(W, H, &material);
    let mut gray = Gray::new(W, H, 1.0);
    for y in 0..H {
        for x in 0..W {
            if !material(x, y) {
                gray.set(x, y, cut_gray(x, y));
            }
        }
    }
    TwoTone {
        bits,
        gray: gray.into(),
    }
}

fn bridge(two: &TwoTone, cfg: &BridgeConfig) -> (Bridge, Bridged) {
    let map = label(&two.bits);
    assert_eq!(map.island_count(), 1, "the scene has one island");
    let out = connect(two, &map, cfg).unwrap();
    assert_eq!(label(&out.bits).island_count(), 0);
    let main = out
        .bridges
        .iter()
        .find(|b| !b.support)
        .cloned()
        .expect("a bridge");
    (main, out)
}

#[derive(Debug, PartialEq)]
enum Side {
    Left,
    Right,
}

/// Which gap the bridge crosses: all its polygon points and all pixels it added lie on one side
/// of the island (left of `left_edge` or right of `right_edge`).
fn side(b: &Bridge, two: &TwoTone, out: &Bridged, left_edge: f64, right_edge: f64) -> Side {
    let xs: Vec<f64> = b.polygon.iter().map(|p| p[0]).collect();
    let added: Vec<u32> = (0..two.bits.len())
        .filter(|&i| out.bits.data[i] && !two.bits.data[i])
        .map(|i| i as u32 % W)
        .collect();
    assert!(!added.is_empty());
    if xs.iter().all(|&x| x <= left_edge + 1.0) && added.iter().all(|&x| (x as f64) < left_edge) {
        Side::Left
    } else if xs.iter().all(|&x| x >= right_edge - 1.0)
        && added.iter().all(|&x| (x as f64) > right_edge)
    {
        Side::Right
    } else {
        panic!("bridge crosses neither side gap: polygon {:?}", b.polygon);
    }
}

/// Rectangle island [x0, x1) × [y0, y1) between frame bands x < fl and x >= fr.
fn two_gaps(
    (x0, x1, y0, y1): (u32, u32, u32, u32),
    (fl, fr): (u32, u32),
    left_gray: f32,
    right_gray: f32,
) -> TwoTone {
    scene(
        |x, y| x < fl || x >= fr || ((x0..x1).contains(&x) && (y0..y1).contains(&y)),
        move |x, _| if x < x0 { left_gray } else { right_gray },
    )
}

#[test]
fn raising_w_intensity_moves_the_bridge_from_a_dark_gap_to_a_light_one() {
    // Left gap: 10 px over black. Right gap: 20 px over gray 0.6 (ΣI = 20 × 0.16 = 3.2 < 10).
    let two = two_gaps((40, 60, 35, 75), (30, 80), 0.0, 0.6);
    let base = BridgeConfig {
        w_length: 1.0,
        ..Default::default()
    };
    let low = BridgeConfig {
        w_intensity: 0.05,
        ..base.clone()
    };
    let (b, out) = bridge(&two, &low);
    assert_eq!(
        side(&b, &two, &out, 40.0, 59.0),
        Side::Left,
        "short dark gap first"
    );
    let high = BridgeConfig {
        w_intensity: 20.0,
        ..base
    };
    let (b, out) = bridge(&two, &high);
    assert_eq!(
        side(&b, &two, &out, 40.0, 59.0),
        Side::Right,
        "light gap when ΣI weighs"
    );
    // The light gap's pixels are what the bridge covers: gray 0.6, not black.
    let covered: Vec<f32> = (0..two.bits.len())
        .filter(|&i| out.bits.data[i] && !two.bits.data[i])
        .map(|i| two.gray.data[i])
        .collect();
    assert!(covered.iter().all(|&g| (g - 0.6).abs() < 1e-6));
}

#[test]
fn raising_w_length_moves_the_bridge_to_the_shorter_gap() {
    // Left gap: 10 px over black. Right gap: 20 px over light gray 0.8 (ΣI = 0.8).
    let two = two_gaps((40, 60, 35, 75), (30, 80), 0.0, 0.8);
    let low = BridgeConfig {
        w_intensity: 1.0,
        w_length: 0.01,
        ..Default::default()
    };
    let (b, out) = bridge(&two, &low);
    assert_eq!(
        side(&b, &two, &out, 40.0, 59.0),
        Side::Right,
        "long light gap first"
    );
    assert!(b.length_px >= 19.0, "{}", b.length_px);
    let high = BridgeConfig {
        w_length: 50.0,
        ..low
    };
    let (b, out) = bridge(&two, &high);
    assert_eq!(
        side(&b, &two, &out, 40.0, 59.0),
        Side::Left,
        "short gap when L^α weighs"
    );
    assert!(b.length_px <= 11.0, "{}", b.length_px);
}

#[test]
fn raising_w_curvature_moves_the_bridge_from_a_curved_edge_to_a_straight_one() {
    // A "D": flat side facing left, a half disc of radius 20 facing right; both gaps 12 px.
    // The curved side's gap is lighter (0.6), so with curvature ignored the bridge goes there.
    let (cx, cy, r) = (50.0f64, 55.0f64, 20.0f64);
    let d = move |x: u32, y: u32| {
        let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
        px >= cx && (px - cx).powi(2) + (py - cy).powi(2) <= r * r
    };
    let two = scene(
        move |x, y| !(38..82).contains(&x) || d(x, y),
        |x, _| if x < 60 { 0.0 } else { 0.6 },
    );
    let low = BridgeConfig {
        w_curvature: 0.0,
        ..Default::default()
    };
    let (b, out) = bridge(&two, &low);
    assert_eq!(
        side(&b, &two, &out, 50.0, 50.0),
        Side::Right,
        "light curved gap first"
    );
    assert!(b.cost.curvature == 0.0);
    let high = BridgeConfig {
        w_curvature: 40.0,
        ..Default::default()
    };
    let (b, out) = bridge(&two, &high);
    assert_eq!(
        side(&b, &two, &out, 50.0, 50.0),
        Side::Left,
        "straight side when κ weighs"
    );
    // It starts on the flat side: every start point lies on the column x = 50.
    assert!((b.polygon[0][0] - 50.5).abs() < 1e-9 && (b.polygon[3][0] - 50.5).abs() < 1e-9);
}

#[test]
fn raising_w_variance_moves_the_bridge_away_from_a_place_whose_neighbours_are_much_worse() {
    // A small island (width 3 needed) between two 20 px gaps. The left gap is black but crossed
    // by one light row at the island's middle (kept a pixel off both edges so it does not steer
    // the neighbouring walks): the strip on that row is almost free, both its neighbours are
    // black. The right gap is an even dark gray whose strips each cost 0.95 of a black one: its
    // windows cost more on average than the window around the light row, but are even.
    let (x0, x1, y0, y1) = (60u32, 70u32, 50u32, 61u32);
    let (fl, fr) = (40u32, 90u32);
    let mid = (y0 + y1 - 1) / 2;
    let right_gray = 1.0 - 0.95f32.sqrt();
    let two = scene(
        move |x, y| x < fl || x >= fr || ((x0..x1).contains(&x) && (y0..y1).contains(&y)),
        move |x, y| {
            if x >= x1 {
                right_gray
            } else if y == mid && x > fl && x + 1 < x0 {
                0.95
            } else {
                0.0
            }
        },
    );
    let low = BridgeConfig {
        w_variance: 0.0,
        ..Default::default()
    };
    let (b, out) = bridge(&two, &low);
    assert_eq!(
        side(&b, &two, &out, 60.0, 69.0),
        Side::Left,
        "the light row first"
    );
    assert_eq!(b.width_px, 3);
    // The bridge covers the light row.
    assert!(out.bits.get(50, mid) && !two.bits.get(50, mid));
    assert!(b.cost.variance == 0.0);
    let high = BridgeConfig {
        w_variance: 50.0,
        ..Default::default()
    };
    let (b, out) = bridge(&two, &high);
    assert_eq!(
        side(&b, &two, &out, 60.0, 69.0),
        Side::Right,
        "even gap when σ² weighs"
    );
    assert!(!out.bits.get(50, mid));
    // Chosen for its evenness: its variance term is far below the light row's would be.
    assert!(b.cost.variance < 1.0, "{:?}", b.cost);
}
