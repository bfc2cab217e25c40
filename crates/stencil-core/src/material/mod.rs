//! Material profiles: what a sheet can hold (bridge and feature widths), how wide the tool cuts
//! (kerf), and how to cut it (laser, knife, pen or photo-etch, with that process's settings).
//!
//! A profile is a TOML file (see `profiles/materials/*.toml`; `stencil profiles` lists them).
//! It is validated once, here, at load: unknown fields, missing fields, negative or absurd numbers
//! and a missing process section are errors naming the file and the field. Everything downstream
//! (pipeline, check, G-code) can then trust a [`Material`].
//!
//! Without `--material`, [`DEFAULT_MATERIAL`] (cardstock) is used; `report.json` records which.

mod profile;
mod settings;

pub use profile::*;
pub use settings::{
    choose, cut_kind, has_settings, settings_for, Chosen, Kept, SettingsError, UserSettings,
    USER_SETTINGS_FILE,
};

#[cfg(test)]
mod tests;
