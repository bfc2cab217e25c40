//! `stencil-studio`: the local page where a person steers `make` live.
//!
//! A small HTTP server on 127.0.0.1 ([`serve`]) with a JSON API (documented in the README) and
//! one embedded page that uses nothing else. Behind it, [`engine::Engine`] keeps every stage's
//! output and re-runs from the first stage whose inputs changed; its export goes through
//! `make`'s own writer ([`stencil_core::pipeline::write`]), so the files are `make`'s, byte for
//! byte, and the command line the page shows reproduces them.
//!
//! The crate knows no command-line syntax: the `stencil` binary hands it a [`Maker`] that lists
//! `make`'s options, turns their values into a [`stencil_core::MakeConfig`] and words errors, so
//! a bad value gets exactly `make`'s message.

#![forbid(unsafe_code)]

mod conn;
pub mod engine;
pub mod params;
mod server;

use stencil_core::{Error, MakeConfig};

pub use params::{Kind, OptionSpec, Params};
pub use server::{serve, Studio, StudioConfig};

/// What the studio needs from the command line: `make`'s options and their meaning.
pub trait Maker: Send + Sync + 'static {
    /// `make`'s options, all but the input and the output folder.
    fn options(&self) -> Vec<OptionSpec>;
    /// The configuration `stencil make ARGS` runs (`args` starts with the input and `-o DIR`),
    /// or the message `make` fails with.
    fn config(&self, args: &[String]) -> Result<MakeConfig, String>;
    /// The set `stencil make ARGS` cuts instead of one stencil (`--layers`, `--fill-in`,
    /// registration marks for a mask), or `None` for one stencil. The studio shows a set as
    /// `make` computes it and exports it with `make`'s own set writer.
    fn set(&self, args: &[String]) -> Result<Option<stencil_core::layers::LayersConfig>, String> {
        let _ = args;
        Ok(None)
    }
    /// A pipeline error in `make`'s words.
    fn describe(&self, cfg: &MakeConfig, e: Error) -> String;
}
