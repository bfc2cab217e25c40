//! The bridge stage's parameters, in pixels: the cost weights and limits, the user's places and
//! keep-out areas, and the strength rules' material numbers (a leaf: every bridge file reads it).

use std::sync::Arc;

use super::error::BridgeError;
use crate::raster::BitGrid;

/// User weights and limits of the bridge optimizer, all in pixels (the pipeline converts mm).
/// Each term is about 1 for a typical strip (see `cost`). The tree prices each pair of nodes by
/// its bridges as drawn (`measured`), and on that price the intensity error is nearly all that
/// matters: the defaults weigh it ten times the length and leave curvature and variance off. On
/// the shared photographs (`corpus.py --quality 3`), drawing every pair, the old defaults (length
/// 1, variance 1, both meant to keep the drawn bridge like its strips) made 0.853 of the
/// shortest-gap yardstick's intensity error, these 0.830 (0.844 with the screen `measured` uses
/// for time); any w2 > 0 moved bridges onto longer, darker strips.
/// Raise `w_curvature` to keep bridges off curved contour, `w_length` for shorter ones, at that
/// price.
#[derive(Clone, Debug, PartialEq)]
pub struct BridgeConfig {
    /// w0, default 2: intensity error ΣI (a typical-length strip over black = 1).
    pub w_intensity: f64,
    /// w1, default 0.2: length penalty L^α (a typical strip = 1).
    pub w_length: f64,
    /// w2, default 0: border curvature κ at the bridge (0 straight .. 1 round).
    pub w_curvature: f64,
    /// w3, default 0: relative variance σ² of the strip costs across the bridge's window.
    pub w_variance: f64,
    /// Exponent of the length penalty, 1 < α < 2; default 1.5.
    pub alpha: f64,
    /// Length limit of the walks, default 200 px: a preference, not a cut-off. Walks longer than
    /// this are dropped, so an island is joined by a strip under it when one exists; a group of
    /// islands left with none is joined by the cheapest path through the cut of any length
    /// (`search::search`, whose per-pixel length price is the L^α term's slope at this limit,
    /// see `cost::StepCost`), and its bridge is marked `Via::Search`.
    pub max_length_px: u32,
    /// Narrowest bridge, default 3 px: never thinner, even after halving, measured at right angles
    /// to it at its narrowest. `stencil make` sets it from the material's `min_bridge_mm` (see
    /// `PhysicalConfig::bridge_for`).
    pub min_width_px: u32,
    /// Widest bridge, default 40 px: none is drawn wider, at right angles to it. `stencil make`
    /// sets it from the material's `max_bridge_mm`.
    pub max_width_px: u32,
    /// Support trigger, default 0.5: when the real error (Σ (1 − gray)² over the cut pixels the
    /// grown bridge fills) exceeds (1 + margin) × the tree's estimate (its window's mean ΣI times its
    /// width), the bridge is halved (not below `min_width_px`) and a support bridge of that width is
    /// added at the next cheapest place between the same two nodes.
    pub support_margin: f64,
    /// Offer the shortest gaps between pieces as candidates besides the paper's walks (default
    /// true; see `gaps`). Off, the candidates are the paper's alone.
    pub gaps: bool,
    /// Where bridges may not go and where they should (see `constraints`).
    pub user: UserBridges,
    /// The strength rules after the tree (see `strength`): bridges per island, the material's
    /// stiffness and weight, its sag limit and the scale.
    pub strength: StrengthConfig,
}

impl Default for BridgeConfig {
    fn default() -> Self {
        BridgeConfig {
            w_intensity: 2.0,
            w_length: 0.2,
            w_curvature: 0.0,
            w_variance: 0.0,
            alpha: 1.5,
            max_length_px: 200,
            min_width_px: 3,
            max_width_px: 40,
            support_margin: 0.5,
            gaps: true,
            user: UserBridges::default(),
            strength: StrengthConfig::default(),
        }
    }
}

impl BridgeConfig {
    /// Check the settings a library caller (not only the CLI) may get wrong.
    pub(crate) fn validate(&self) -> Result<(), BridgeError> {
        let bad = |name, value: String, why| Err(BridgeError::BadSetting { name, value, why });
        for (name, w) in [
            ("w_intensity", self.w_intensity),
            ("w_length", self.w_length),
            ("w_curvature", self.w_curvature),
            ("w_variance", self.w_variance),
        ] {
            if !(w.is_finite() && w >= 0.0) {
                return bad(name, w.to_string(), "weights must be finite and >= 0");
            }
        }
        if !(self.alpha > 1.0 && self.alpha < 2.0) {
            return bad(
                "alpha",
                self.alpha.to_string(),
                "it must lie strictly between 1 and 2",
            );
        }
        if self.min_width_px < 1 || self.min_width_px > self.max_width_px {
            return bad(
                "min_width_px",
                self.min_width_px.to_string(),
                "it must be at least 1 and at most max_width_px",
            );
        }
        if self.max_length_px < 1 {
            return bad("max_length_px", "0".into(), "it must be at least 1 px");
        }
        if !(self.support_margin.is_finite() && self.support_margin >= 0.0) {
            return bad(
                "support_margin",
                self.support_margin.to_string(),
                "it must be a finite fraction >= 0",
            );
        }
        if let Err((name, v, why)) = self.strength.check() {
            return bad(name, v.to_string(), why);
        }
        Ok(())
    }
}

/// The four terms of `C = w0·ΣI + w1·L^α + w2·κ + w3·σ²` (already weighted) and their sum.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct CostTerms {
    pub(crate) intensity: f64,
    pub(crate) length: f64,
    /// `w2·κ`: how much the strip bends.
    pub curvature: f64,
    /// `w3·σ²`: how much the gray varies along it.
    pub variance: f64,
    pub(crate) total: f64,
}

/// The user's constraints on the working image, in pixels (`resolve` makes them from the
/// request's millimetres, once the scale is known).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UserBridges {
    /// Pixels no bridge may cross, the image's size.
    pub keep_out: Option<Arc<BitGrid>>,
    /// Places a bridge should start near, (x, y) in pixels.
    pub at: Vec<[f64; 2]>,
}

/// The material numbers and the scale the strength rules need (the pipeline fills them from the
/// material profile; the default is cardstock at 0.1 mm per pixel, what `stencil make` uses
/// without options).
#[derive(Clone, Debug, PartialEq)]
pub struct StrengthConfig {
    /// At least this many bridges for every island, spread apart (`--bridges-per-island`).
    pub per_island: u32,
    /// Millimetres per working pixel.
    pub mm_per_px: f64,
    /// The sheet's thickness, mm.
    pub thickness_mm: f64,
    /// The material's stiffness (Young's modulus), GPa.
    pub youngs_modulus_gpa: f64,
    /// The material's density, kg/m³.
    pub density_kg_m3: f64,
    /// The most an island may sag, mm.
    pub max_sag_mm: f64,
    /// Islands longer than this get at least two bridges, mm.
    pub two_bridges_above_mm: f64,
}

impl Default for StrengthConfig {
    fn default() -> Self {
        let s = crate::material::DEFAULT_STRENGTH;
        StrengthConfig {
            per_island: 1,
            mm_per_px: 0.1,
            thickness_mm: 0.3,
            youngs_modulus_gpa: s.youngs_modulus_gpa,
            density_kg_m3: s.density_kg_m3,
            max_sag_mm: s.max_sag_mm,
            two_bridges_above_mm: s.two_bridges_above_mm,
        }
    }
}

impl StrengthConfig {
    /// The sag estimate, mm, of an island whose span is `span_mm` (see the module notes):
    /// `5·ρ·g·L⁴ / (2·E·t²)`, in SI units then back to millimetres.
    pub(crate) fn sag_mm(&self, span_mm: f64) -> f64 {
        let (l, t) = (span_mm / 1e3, self.thickness_mm / 1e3);
        let e = self.youngs_modulus_gpa * 1e9;
        5.0 * self.density_kg_m3 * G * l.powi(4) / (2.0 * e * t * t) * 1e3
    }

    /// The longest span whose sag is within `max_sag_mm`.
    pub(crate) fn max_span_mm(&self) -> f64 {
        let (t, e) = (self.thickness_mm / 1e3, self.youngs_modulus_gpa * 1e9);
        let l4 = self.max_sag_mm / 1e3 * 2.0 * e * t * t / (5.0 * self.density_kg_m3 * G);
        l4.powf(0.25) * 1e3
    }

    /// The settings a library caller may get wrong, by name.
    pub(crate) fn check(&self) -> Result<(), (&'static str, f64, &'static str)> {
        if !(1..=MAX_PER_ISLAND).contains(&self.per_island) {
            return Err((
                "bridges_per_island",
                self.per_island as f64,
                "it must be 1 to 12",
            ));
        }
        for (name, v) in [
            ("mm_per_px", self.mm_per_px),
            ("thickness_mm", self.thickness_mm),
            ("youngs_modulus_gpa", self.youngs_modulus_gpa),
            ("density_kg_m3", self.density_kg_m3),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err((name, v, "it must be a finite number above 0"));
            }
        }
        // Infinite: that rule is off (a material with no strength data).
        for (name, v) in [
            ("max_sag_mm", self.max_sag_mm),
            ("two_bridges_above_mm", self.two_bridges_above_mm),
        ] {
            if v.is_nan() || v <= 0.0 {
                return Err((name, v, "it must be above 0 (infinite: the rule is off)"));
            }
        }
        Ok(())
    }
}

/// Most bridges `--bridges-per-island` may ask for.
pub const MAX_PER_ISLAND: u32 = 12;

/// Standard gravity, m/s².
pub(super) const G: f64 = 9.806_65;
