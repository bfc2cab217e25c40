//! What a layered set asks for ([`LayersConfig`]); why a request for one is refused is
//! `crate::error::LayersError`.

/// What a layered (or registered) run asks for.
#[derive(Clone, Debug, Default)]
pub struct LayersConfig {
    /// Layers (1..=[`crate::limits::MAX_LAYERS`]).
    pub count: u32,
    /// One 8-bit level per layer (any order; light is at or above a level), or empty to choose.
    pub levels: Vec<u8>,
    /// Paint colours light to dark, one per layer, or one more with the surface first; empty to
    /// take the tones' own colours.
    pub colors: Vec<[u8; 3]>,
    /// With one layer: a second stencil that paints what the first one's bridges hide.
    pub fill_in: bool,
}
