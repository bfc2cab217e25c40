//! `stencil-studio`: the local page where a person steers `make` live.
//!
//! A small HTTP server on 127.0.0.1 ([`serve`]) with a JSON API (documented in the README) and
//! one embedded page that uses nothing else. Behind it, the [`Engine`] keeps every stage's
//! output and re-runs from the first stage whose inputs changed; its export goes through
//! `make`'s own writer, so the files are `make`'s, byte for byte, and the command line the page
//! shows reproduces them.
//!
//! The crate knows no command-line syntax: the `stencil` binary hands it a [`Maker`] that lists
//! `make`'s options, turns their values into a [`stencil_core::MakeConfig`] and words errors, so
//! a bad value gets exactly `make`'s message.
//!
//! A change through the engine re-runs only from the stage it touches:
//!
//! ```
//! use stencil_core::{tone::Threshold, MakeConfig};
//! use stencil_studio::Engine;
//!
//! let samples = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../samples");
//! let mut cfg = MakeConfig { input: samples.join("rings.png"), ..Default::default() };
//! let (mut engine, never) = (Engine::new(), || false);
//! engine.run(&cfg, &never)?;
//! cfg.tone.threshold = Threshold::Level(100);
//! let changed = engine.run(&cfg, &never)?;
//! assert_eq!(changed.ran.first(), Some(&"threshold"));
//! assert!(changed.refused.is_none() && !changed.report.bridges.is_empty());
//! # Ok::<(), stencil_studio::RunError>(())
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod conn;
mod engine;
mod maker;
mod outcome;
mod params;
mod server;
mod state;
mod studio;

pub use engine::{Computed, Engine, RunError};
pub use maker::{Configured, Maker};
pub use params::{Kind, OptionSpec};
pub use server::serve;
pub use studio::StudioConfig;
