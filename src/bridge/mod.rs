//! Stages 3–5: bridge strips, their cost, the spanning tree over island groups, growing bridges.
//!
//! OWNER NOTE (remove when implemented): the public contract below is used by `pipeline.rs` and
//! `report.rs`; fields may be added, but keep these names.

use crate::islands::IslandMap;
use crate::raster::{BitGrid, TwoTone};

/// User weights and limits of the bridge optimizer, all in pixels (the pipeline converts mm).
#[derive(Clone, Debug)]
pub struct BridgeConfig {
    pub w_intensity: f64,
    pub w_length: f64,
    pub w_curvature: f64,
    pub w_variance: f64,
    /// Exponent of the length penalty, 1 < α < 2.
    pub alpha: f64,
    /// Walks longer than this are dropped.
    pub max_length_px: u32,
    pub min_width_px: u32,
    pub max_width_px: u32,
    /// If a grown bridge's real error exceeds its estimate by more than this fraction, halve it and
    /// add a support bridge.
    pub support_margin: f64,
}

impl Default for BridgeConfig {
    fn default() -> Self {
        BridgeConfig {
            w_intensity: 1.0,
            w_length: 1.0,
            w_curvature: 1.0,
            w_variance: 1.0,
            alpha: 1.5,
            max_length_px: 200,
            min_width_px: 3,
            max_width_px: 40,
            support_margin: 0.5,
        }
    }
}

/// The four terms of `C = w0·ΣI + w1·L^α + w2·κ + w3·σ²` (already weighted) and their sum.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct CostTerms {
    pub intensity: f64,
    pub length: f64,
    pub curvature: f64,
    pub variance: f64,
    pub total: f64,
}

/// One bridge: a run of neighbouring strips, drawn as material.
#[derive(Clone, Debug)]
pub struct Bridge {
    /// The two nodes it joins (0 = frame).
    pub nodes: [u32; 2],
    pub width_px: u32,
    pub length_px: f64,
    /// Cut pixels it turns into material.
    pub pixels: usize,
    pub cost: CostTerms,
    /// A second bridge added because the first one's real error exceeded its estimate.
    pub support: bool,
    /// Outline in pixel coordinates (x right, y down), from the end points of its outer strips.
    pub polygon: Vec<[f64; 2]>,
}

/// The bridged bit grid and its bridges.
#[derive(Clone, Debug)]
pub struct Bridged {
    pub bits: BitGrid,
    pub bridges: Vec<Bridge>,
}

#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    #[error("island {island} at pixel ({x}, {y}) could not be joined: {reason}")]
    Unreachable {
        island: u32,
        x: u32,
        y: u32,
        reason: String,
    },
}

/// Join every island to the frame with bridges.
pub fn connect(two: &TwoTone, map: &IslandMap, cfg: &BridgeConfig) -> Result<Bridged, BridgeError> {
    let _ = cfg;
    if map.island_count() == 0 {
        return Ok(Bridged {
            bits: two.bits.clone(),
            bridges: Vec::new(),
        });
    }
    let (x, y) = map.nodes[1].border.first().copied().unwrap_or((0, 0));
    Err(BridgeError::Unreachable {
        island: 1,
        x,
        y,
        reason: "bridging is not implemented yet".into(),
    })
}
