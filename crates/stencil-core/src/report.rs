//! `report.json`: what a run measured, for a person and for later commands (`check`, `gcode`).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::bridge::{Bridge, CostTerms, Via};
use crate::check::CheckReport;
use crate::raster::BitGrid;
use crate::tone::filter::FilterStats;
use crate::vector::VectorStats;

/// One bridge as reported.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct BridgeReport {
    /// The two nodes it joins (0 = frame).
    pub nodes: [u32; 2],
    /// Width at right angles to the bridge, at its narrowest, in working pixels (see
    /// [`Bridge::width_px`]).
    pub width_px: u32,
    /// Length along its strips, px.
    pub length_px: f64,
    /// Cut pixels it turned into material.
    pub(crate) pixels: usize,
    pub(crate) cost: CostTerms,
    /// A second bridge, added because the first one's real error exceeded its estimate.
    pub support: bool,
    /// `"walk"`, or `"search"` when no walk under `--max-bridge-length-px` left the island's group
    /// and it was joined by the cheapest path through the cut, of any length (absent in older
    /// reports: a walk).
    #[serde(default)]
    pub via: Via,
    /// Added after the tree for strength (an island's size, shape or sag asked for it; see
    /// `strength` in the report). Absent in older reports: false.
    #[serde(default)]
    pub strength: bool,
    /// `width_px` in millimetres on the sheet (`width_px` × `mm_per_px`). Absent from reports
    /// written before widths were in millimetres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width_mm: Option<f64>,
    /// Outline in pixel coordinates (so `stencil check` on an output folder knows the bridges).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub polygon_px: Vec<[f64; 2]>,
}

/// Without the scale: `width_mm` is left empty (the pipeline fills it in).
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
            strength: b.strength,
            width_mm: None,
            polygon_px: b.polygon.clone(),
        }
    }
}

/// How far the stencil is from the picture: what the two-tone clean-up and the bridges changed,
/// counted on three grids of the working size (material = light, the sheet that stays):
/// the picture thresholded (before any clean-up), the two-tone after the clean-up (`twotone.png`)
/// and the stencil after bridges (`stencil.png`). Each count comes with its share of the picture's
/// pixels in percent.
///
/// A pixel the clean-up cut and a bridge then filled counts in both `cleanup_removed` and
/// `bridges`, and not in `changed`: `changed` is the net difference, at most the sum of the others.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Fidelity {
    /// The picture's pixels at working size (the denominator of every `_pct`).
    pub(crate) pixels: usize,
    /// Material of the thresholded picture that the clean-up cut away.
    pub(crate) cleanup_removed_px: usize,
    /// The same, % of the picture.
    pub cleanup_removed_pct: f64,
    /// Cut of the thresholded picture that the clean-up filled with material.
    pub(crate) cleanup_added_px: usize,
    /// The same, % of the picture.
    pub cleanup_added_pct: f64,
    /// Material added after the two-tone (cut in the two-tone, material in the stencil): the
    /// bridges, and the clean-up around them and after them.
    pub(crate) bridges_px: usize,
    /// The same, % of the picture.
    pub bridges_pct: f64,
    /// Of `bridges_px`, what the clean-up after bridging added apart from every bridge (a neck
    /// widened, a pocket filled, joined to no bridge through added material); the rest is the
    /// sum of the bridges' `pixels`. Absent (0) in reports written before it was counted.
    #[serde(default)]
    pub(crate) apart_from_bridges_px: usize,
    #[serde(default)]
    pub(crate) apart_from_bridges_pct: f64,
    /// Pixels where the stencil differs from the thresholded picture, whatever changed them.
    pub(crate) changed_px: usize,
    /// The same, % of the picture.
    pub changed_pct: f64,
}

impl Fidelity {
    /// Count the changes between the thresholded picture, the cleaned two-tone and the stencil
    /// (three grids of the same size).
    pub(crate) fn measure(picture: &BitGrid, twotone: &BitGrid, stencil: &BitGrid) -> Fidelity {
        assert!(
            picture.len() == twotone.len() && twotone.len() == stencil.len(),
            "fidelity is measured on grids of the same size"
        );
        let (mut removed, mut added, mut bridges, mut changed) = (0, 0, 0, 0);
        for ((&p, &t), &s) in picture.data.iter().zip(&twotone.data).zip(&stencil.data) {
            removed += (p && !t) as usize;
            added += (!p && t) as usize;
            bridges += (!t && s) as usize;
            changed += (p != s) as usize;
        }
        let pixels = picture.len();
        let pct = |n: usize| share_pct(n, pixels);
        Fidelity {
            pixels,
            cleanup_removed_px: removed,
            cleanup_removed_pct: pct(removed),
            cleanup_added_px: added,
            cleanup_added_pct: pct(added),
            bridges_px: bridges,
            bridges_pct: pct(bridges),
            apart_from_bridges_px: 0,
            apart_from_bridges_pct: 0.0,
            changed_px: changed,
            changed_pct: pct(changed),
        }
    }

    /// Set how much of `bridges_px` no bridge holds (what [`crate::bridge::Bridged::recount`]
    /// returns): the grids alone cannot tell it.
    pub(crate) fn with_apart_from_bridges(self, px: usize) -> Fidelity {
        Fidelity {
            apart_from_bridges_px: px,
            apart_from_bridges_pct: share_pct(px, self.pixels),
            ..self
        }
    }
}

/// `n` of `pixels` in percent (0 for an empty picture).
pub(crate) fn share_pct(n: usize, pixels: usize) -> f64 {
    if pixels == 0 {
        0.0
    } else {
        100.0 * n as f64 / pixels as f64
    }
}

/// The whole report. Fields added by later stages are optional so older reports still load.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Report {
    /// The input file.
    pub(crate) input: String,
    /// Working width, px.
    pub width_px: u32,
    /// Working height, px.
    pub height_px: u32,
    /// The 8-bit threshold level used (after `otsu`, the level it chose); absent for a mesh.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub threshold_level: Option<u8>,
    /// How much the cleaned-up two-tone looks like the gray picture: SSIM at viewing distance
    /// (see `tone::likeness`), 1 = the same.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub likeness: Option<f64>,
    /// How `--threshold auto` chose the level: its likeness, the likeness at 128 and at Otsu's
    /// level, every level tried.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub threshold_choice: Option<crate::tone::LevelChoice>,
    /// Islands dropped (made cut) instead of bridged, because their cheapest bridge would have
    /// changed the picture more (see `bridge::drop`); absent when none was.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dropped_islands: Option<Vec<crate::bridge::drop::Dropped>>,
    /// What the topological filter removed.
    pub(crate) filter: FilterStats,
    /// What the design-rule regularisation changed (the default clean-up; absent when the user
    /// asked for the open-close filter with `--filter-radius`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) regularize: Option<crate::tone::regularize::RegularizeStats>,
    /// Islands before bridging.
    pub islands: usize,
    /// Every bridge drawn.
    pub bridges: Vec<BridgeReport>,
    /// Per island: bridges, span and sag estimate against the material's limit, why any were
    /// added for strength; totals (see `bridge::strength`). Absent in older reports.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strength: Option<crate::bridge::strength::StrengthReport>,
    /// What the user's bridge options did (`--min-island-mm2`, `--bridge-at`, `--keep-out`,
    /// `--no-bridge-near`). Absent when none was given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) user_bridges: Option<UserBridgesReport>,
    /// Whether the cut where the bridges can go had light places (see `bridge::Light`): without
    /// any, every way darkens the picture alike and the bridges take the shortest ways. Absent
    /// without islands, and in older reports.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bridge_light: Option<crate::bridge::Light>,
    /// Material pieces not joined to the frame after bridging: 0 for a valid stencil.
    pub floating_after: usize,
    /// What the clean-up and the bridges changed in the picture (absent in reports written before
    /// it was measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fidelity: Option<Fidelity>,
    /// Wall time per stage in milliseconds.
    pub timings_ms: BTreeMap<String, f64>,
    /// The material profile used (name) and where it was read from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<String>,
    /// Where the material profile was read from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material_source: Option<String>,
    /// The material's values themselves (as its profile file holds them): what `gcode` and
    /// `check` use for a folder, so that a received folder names a material, never a file to
    /// open (`material_source` is only a note of where the values were read).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material_values: Option<crate::material::MaterialValues>,
    /// Millimetres per working pixel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mm_per_px: Option<f64>,
    /// Working pixels per input pixel along each axis (the supersampling factor; 1 = none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale_factor: Option<u32>,
    /// How the factor was chosen, when it was automatic.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale_auto: Option<crate::tone::resolution::AutoScale>,
    /// The picture's width, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width_mm: Option<f64>,
    /// Its height, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height_mm: Option<f64>,
    /// The sheet margin, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub margin_mm: Option<f64>,
    /// The vectors' simplification tolerance, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance_mm: Option<f64>,
    /// Whether the outlines were fitted for files that carry arcs (false for a G-code job
    /// without them: `--no-arcs`, a machine without G2/G3, a drag knife), which decides the
    /// polygon the check judged; `stencil check` of the folder judges the same one. Absent in
    /// older reports: arcs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub arcs: Option<bool>,
    /// The material's limits in pixels as given to the stages (after the check's allowance).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) min_bridge_px: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) max_bridge_px: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) filter_radius_px: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) vector: Option<VectorStats>,
    /// The width and connectivity check against the material.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub check: Option<CheckReport>,
    /// Files written, by name.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(crate) files: Vec<String>,
    /// The G-code job (`--emit gcode`): machine, lengths, travel vs input order, time estimate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gcode: Option<stencil_gcode::GcodeSummary>,
    /// The HP-GL job (`--emit hpgl`): plotter, lengths, the virtual cutter's time.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hpgl: Option<stencil_hpgl::HpglSummary>,
    /// The photo-etch masks (`--emit mask`): files, dpi, polarity, mirroring, undercut
    /// compensation, and how much of the picture is clear.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mask: Option<crate::export::MaskReport>,
    /// The gobo (`--gobo`): its sizes and the table they come from, the picture's placement,
    /// the polarity, how much of the image area passes light, and the `--invert` warning.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gobo: Option<crate::gobo::GoboReport>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fidelity_counts_each_kind_of_change() {
        // Picture (thresholded), two-tone after the clean-up, stencil; one column per case.
        let picture = BitGrid::from_rows(&["##..###"]);
        let twotone = BitGrid::from_rows(&["#.#.#.."]);
        let stencil = BitGrid::from_rows(&["#.####."]);
        let f = Fidelity::measure(&picture, &twotone, &stencil);
        assert_eq!(f.pixels, 7);
        assert_eq!(f.cleanup_removed_px, 3, "columns 1, 5 and 6");
        assert_eq!(f.cleanup_added_px, 1, "column 2");
        assert_eq!(f.bridges_px, 2, "columns 3 and 5");
        // Column 5 was cut by the clean-up and filled again by a bridge: no net change.
        assert_eq!(f.changed_px, 4, "columns 1, 2, 3 and 6");
        assert!((f.changed_pct - 400.0 / 7.0).abs() < 1e-9);
        assert!((f.cleanup_removed_pct - 300.0 / 7.0).abs() < 1e-9);
        assert!((f.bridges_pct - 200.0 / 7.0).abs() < 1e-9);
    }

    #[test]
    fn a_report_without_fidelity_still_loads() {
        let mut json = serde_json::to_value(Report {
            fidelity: Some(Fidelity::default()),
            ..Default::default()
        })
        .unwrap();
        assert!(json.as_object_mut().unwrap().remove("fidelity").is_some());
        let r: Report = serde_json::from_value(json).unwrap();
        assert!(r.fidelity.is_none());
    }
}

/// What the user's bridge options did (see `bridge::constraints`).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct UserBridgesReport {
    /// `--min-island-mm2` and the islands it cut away: how many, their total area.
    pub min_island_mm2: f64,
    pub(crate) islands_cut_away: usize,
    pub(crate) cut_away_mm2: f64,
    /// Pixels of the working image no bridge could cross (`--keep-out`, `--no-bridge-near`).
    pub(crate) kept_out_px: usize,
    /// Each `--bridge-at` place: the point, the island taken, where its bridge starts and how far
    /// from the point, mm.
    pub(crate) bridge_at: Vec<BridgeAtReport>,
}

/// One `--bridge-at` place (mm from the picture's top left corner).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub(crate) struct BridgeAtReport {
    pub at_mm: [f64; 2],
    pub(crate) island: u32,
    pub(crate) start_mm: Option<[f64; 2]>,
    pub(crate) distance_mm: Option<f64>,
}
