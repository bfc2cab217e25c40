//! What a layered set asks for ([`LayersConfig`]) and why a request for one is refused
//! ([`LayersError`]).

/// Most layers a set may have.
pub const MAX_LAYERS: u32 = 6;

/// What a layered (or registered) run asks for.
#[derive(Clone, Debug, Default)]
pub struct LayersConfig {
    /// Layers (1..=[`MAX_LAYERS`]).
    pub count: u32,
    /// One 8-bit level per layer (any order; light is at or above a level), or empty to choose.
    pub levels: Vec<u8>,
    /// Paint colours light to dark, one per layer, or one more with the surface first; empty to
    /// take the tones' own colours.
    pub colors: Vec<[u8; 3]>,
    /// With one layer: a second stencil that paints what the first one's bridges hide.
    pub fill_in: bool,
}

/// A layered run's errors, as data (the `stencil` binary words them with its options).
#[derive(Debug, thiserror::Error)]
pub enum LayersError {
    #[error("{0} layers: a set has 1 to {MAX_LAYERS}")]
    Count(u32),
    #[error("{given} level(s) for {count} layer(s): give one level per layer")]
    Levels { given: usize, count: u32 },
    #[error("the level {0} is given twice: each layer needs its own level")]
    SameLevel(u8),
    #[error("{given} colour(s) for {count} layer(s): give one per layer (light to dark), or one more with the surface's first")]
    Colors { given: usize, count: u32 },
    #[error("layers are cut from a picture, not a mesh")]
    Mesh,
    #[error("layers paint the picture's dark tones through the cuts; swapping the tones does not apply to them")]
    Invert,
    #[error("a keep-out picture is not supported with layers or registration marks (the sheet grows around the picture); use keep-out discs")]
    KeepOut,
    #[error("{path}: cannot read the picture's colours: {msg}")]
    Colour {
        path: std::path::PathBuf,
        msg: String,
    },
}
