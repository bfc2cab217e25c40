//! `report.json`: what a run measured, for a person and for later commands (`check`, `gcode`).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::bridge::{Bridge, CostTerms};
use crate::tone::filter::FilterStats;

/// One bridge as reported.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct BridgeReport {
    /// The two nodes it joins (0 = frame).
    pub nodes: [u32; 2],
    pub width_px: u32,
    pub length_px: f64,
    /// Cut pixels it turned into material.
    pub pixels: usize,
    pub cost: CostTerms,
    pub support: bool,
}

impl From<&Bridge> for BridgeReport {
    fn from(b: &Bridge) -> Self {
        BridgeReport {
            nodes: b.nodes,
            width_px: b.width_px,
            length_px: b.length_px,
            pixels: b.pixels,
            cost: b.cost,
            support: b.support,
        }
    }
}

/// The whole report. Fields added by later stages are optional so older reports still load.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Report {
    /// The input file.
    pub input: String,
    pub width_px: u32,
    pub height_px: u32,
    /// The 8-bit threshold level used (after `otsu`, the level it chose); absent for a mesh.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub threshold_level: Option<u8>,
    /// What the topological filter removed.
    pub filter: FilterStats,
    /// Islands before bridging.
    pub islands: usize,
    pub bridges: Vec<BridgeReport>,
    /// Material pieces not joined to the frame after bridging: 0 for a valid stencil.
    pub floating_after: usize,
    /// Wall time per stage in milliseconds.
    pub timings_ms: BTreeMap<String, f64>,
}
