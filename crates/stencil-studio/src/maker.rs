//! What the studio needs from the command line ([`Maker`]): `make`'s options, their meaning and
//! `make`'s words for errors, so that this crate knows no command-line syntax.

use stencil_core::layers::LayersConfig;
use stencil_core::{Error, MakeConfig};

use crate::params::OptionSpec;

/// What the studio needs from the command line: `make`'s options and their meaning.
pub trait Maker: Send + Sync + 'static {
    /// `make`'s options, all but the input and the output folder.
    fn options(&self) -> Vec<OptionSpec>;
    /// The configuration `stencil make ARGS` runs (`args` starts with the input and `-o DIR`), and
    /// the set it cuts instead of one stencil (`--layers`, `--fill-in`, registration marks for a
    /// mask; the studio shows a set as `make` computes it and exports it with `make`'s own set
    /// writer); or the message `make` fails with.
    fn config(&self, args: &[String]) -> Result<(MakeConfig, Option<LayersConfig>), String>;
    /// A pipeline error in `make`'s words.
    fn describe(&self, cfg: &MakeConfig, e: Error) -> String;
}
