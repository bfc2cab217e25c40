//! `report.json`: what a run measured, for a person and for later commands (`check`, `gcode`).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::bridge::{Bridge, CostTerms, Via};
use crate::check::CheckReport;
use crate::tone::filter::FilterStats;
use crate::vector::VectorStats;

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
    /// `"walk"`, or `"search"` when no walk under `--max-bridge-length-px` left the island's group
    /// and it was joined by the cheapest path through the cut, of any length (absent in older
    /// reports: a walk).
    #[serde(default)]
    pub via: Via,
    /// Outline in pixel coordinates (so `stencil check` on an output folder knows the bridges).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub polygon_px: Vec<[f64; 2]>,
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
            via: b.via,
            polygon_px: b.polygon.clone(),
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
    /// The material profile used (name) and where it was read from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material_source: Option<String>,
    /// Physical size: millimetres per working pixel, the picture's size, the sheet margin, and
    /// the simplification tolerance used by the vectors.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mm_per_px: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub margin_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance_mm: Option<f64>,
    /// The material's limits in pixels as given to the stages (after the check's allowance).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_bridge_px: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub filter_radius_px: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vector: Option<VectorStats>,
    /// The width and connectivity check against the material.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub check: Option<CheckReport>,
    /// Files written, by name.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub files: Vec<String>,
    /// The G-code job (`--emit gcode`): machine, lengths, travel vs input order, time estimate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gcode: Option<crate::plan::GcodeSummary>,
}
