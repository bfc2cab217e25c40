//! Each stage's parameters in its own units (pixels), no paths: equal parameters give equal
//! outputs (what the studio's cache compares).

use crate::bridge::BridgeConfig;
use crate::material::Material;
use crate::tone::{self, filter::FilterConfig, mesh::MeshConfig, mesh::PartSizes};
use crate::units::Scale;
use crate::vector::VectorConfig;

/// What loading and rendering the input need, known before its size: a picture's pixel limit, or
/// a mesh's view, light, lines and size (the lines widened to survive the clean-up).
#[derive(Clone, Debug, PartialEq)]
pub enum SourceParams {
    /// A picture.
    Picture {
        /// The most pixels it may have.
        max_pixels: u64,
        /// The adjustments made to the picture as it is rendered (see [`tone::Adjust`]).
        adjust: tone::Adjust,
    },
    /// A mesh's view, light, lines and size.
    Mesh(MeshConfig),
}

/// The working resolution: how many times the picture was supersampled, and what a working pixel
/// measures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Working {
    /// Working pixels per input pixel along each axis (1 for a mesh, which renders at its own size).
    pub factor: u32,
    /// How the factor was chosen, when it was automatic (no `--scale`).
    pub auto: Option<tone::resolution::AutoScale>,
    /// Millimetres per working pixel.
    pub scale: Scale,
}

/// The threshold stage's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneParams {
    /// How gray becomes two tones.
    pub threshold: tone::Threshold,
    /// Make the dark parts material instead of the light.
    pub invert: bool,
    /// A cropped gobo's image area in working pixels (cx, cy, r): outside it, metal.
    pub keep_circle_px: Option<[f64; 3]>,
}

impl ToneParams {
    /// What of these parameters changes the gray the two-tone carries (not only its bits): the
    /// gobo's circle, outside which the gray is set to the metal's tone, and with it `invert`,
    /// which says what that tone is (see [`crate::pipeline::threshold`]). While this and the working gray stay,
    /// so does the two-tone's gray, and what is made of it alone ([`crate::pipeline::look`]).
    pub fn gray_key(&self) -> Option<([f64; 3], bool)> {
        self.keep_circle_px.map(|c| (c, self.invert))
    }
}

/// The clean-up's parameters: the design-rule regularisation to `min_width_px`, or (with an
/// explicit radius) the morphological filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CleanParams {
    /// The morphological filter.
    pub filter: FilterConfig,
    /// The regularisation's narrowest web or hole, px, when it runs (the automatic radius).
    pub regularize_px: Option<f64>,
    /// As in [`ToneParams`].
    pub invert: bool,
    /// `--threshold auto` on a picture: the clean-up searches the level (see [`crate::pipeline::clean`]).
    pub auto: bool,
}

/// The user's bridge places and keep-out areas in working pixels (see `bridge::constraints`).
#[derive(Clone, Debug, PartialEq)]
pub struct UserParams {
    /// `min_island_mm2` and the scale it is measured at.
    pub min_island_mm2: f64,
    /// Millimetres per working pixel.
    pub mm_per_px: f64,
}

/// The bridge stage's parameters: the bridge options in pixels for this material and scale (the
/// user's places and keep-out grid included), and the clean-up around the bridges.
#[derive(Clone, Debug, PartialEq)]
pub struct JoinParams {
    /// The bridge options, in pixels.
    pub bridge: BridgeConfig,
    /// Set when any of the user's bridge options was given (they are reported).
    pub user: Option<UserParams>,
    /// Pixels a keep-out option forbids (reported).
    pub kept_out_px: usize,
    /// After the regularisation: settle to this width and fill sealed pockets; else tidy with
    /// `tidy_radius`.
    pub settle_px: Option<f64>,
    /// The tidy's radius, px (without the regularisation).
    pub(crate) tidy_radius: u32,
    /// Millimetres per working pixel (the dropped islands are reported in mm).
    pub mm_per_px: f64,
    /// Drop an island when that changes the picture less than its cheapest bridge (see
    /// `bridge::drop`); false with `--keep-all-islands`.
    pub drop_islands: bool,
}

/// The vector stage's and the check's parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceParams {
    /// The vector stage's options.
    pub vector: VectorConfig,
    /// The material (its smallest widths for the check).
    pub material: Material,
    /// Widen the necks the check finds and trace again (after the regularisation).
    pub repair: bool,
}

/// Every stage's parameters after the source, from one [`crate::resolve::stage_params`]: pixels, not millimetres
/// (the scale is carried for the stages that write millimetres), no paths, nothing left to decide.
#[derive(Clone, Debug, PartialEq)]
pub struct StageParams {
    /// The working resolution.
    pub working: Working,
    /// The threshold's.
    pub tone: ToneParams,
    /// The clean-up's.
    pub clean: CleanParams,
    /// The bridges'.
    pub join: JoinParams,
    /// The tracing's and the check's.
    pub trace: TraceParams,
    /// A mesh's parts as its view draws them (`None` for a picture), for `make`'s warning.
    pub mesh_parts: Option<PartSizes>,
}
