//! What the regularisation is asked ([`RegularizeConfig`]) and what it changed
//! ([`RegularizeStats`]).

use serde::{Deserialize, Serialize};

/// Options of the regularisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RegularizeConfig {
    /// The narrowest web of material and hole of cut, in working pixels.
    pub min_width_px: f64,
    /// The gray level (0..1) the two-tone was cut at: a flip costs more the farther its gray is.
    pub threshold: f32,
    /// True when material is the dark side (`--invert`): only for the cost, which is symmetric.
    pub invert: bool,
}

/// What the regularisation changed, for the report.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub struct RegularizeStats {
    /// The disc's span in pixels: the required width rounded up to a whole number of pixels (an
    /// odd span is centred on a pixel, an even one on a pixel corner).
    pub(crate) disc_px: u32,
    /// Thin webs of material removed and widened, and thin holes of cut filled and widened.
    pub(crate) webs_removed: usize,
    pub(crate) webs_widened: usize,
    pub(crate) holes_filled: usize,
    pub(crate) holes_widened: usize,
    /// Material pixels that became cut, and cut pixels that became material (net, against the
    /// input two-tone).
    pub(crate) material_removed_px: usize,
    pub(crate) material_added_px: usize,
    /// Rounds of the cost-based phase and of the monotone phase.
    pub(crate) rounds: usize,
    pub(crate) monotone_rounds: usize,
}
