//! What the studio needs from the command line ([`Maker`]): `make`'s options, their meaning and
//! `make`'s words for errors, so that this crate knows no command-line syntax.

use stencil_core::layers::LayersConfig;
use stencil_core::tiles::TilesConfig;
use stencil_core::{Error, MakeConfig};

use crate::params::OptionSpec;

/// What the studio needs from the command line: `make`'s options and their meaning.
pub trait Maker: Send + Sync + 'static {
    /// `make`'s options, all but the input and the output folder.
    fn options(&self) -> Vec<OptionSpec>;
    /// What `stencil make ARGS` runs (`args` starts with the input and `-o DIR`), or the message
    /// `make` fails with.
    fn config(&self, args: &[String]) -> Result<Configured, String>;
    /// A pipeline error in `make`'s words.
    fn describe(&self, cfg: &MakeConfig, e: Error) -> String;
}

/// What `stencil make ARGS` runs, as the [`Maker`] reads it.
pub struct Configured {
    /// The configuration of one stencil (of each, in a set or in tiles).
    pub cfg: MakeConfig,
    /// The set it cuts instead of one stencil (layers, a fill-in, registration marks for a
    /// mask): the studio shows a set as `make` computes it and exports it with `make`'s own
    /// set writer.
    pub set: Option<LayersConfig>,
    /// The tiles it cuts the stencil (or each layer) in: the studio shows the tiling's seams as
    /// `make` computes them and exports the tiles with `make`'s own tiles writer.
    pub tiles: Option<TilesConfig>,
}
