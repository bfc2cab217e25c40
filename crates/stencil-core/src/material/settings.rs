//! Cut settings: what a material cuts with on a machine, from its profile's entry for the
//! machine's kind or from what the person kept (`stencil profiles set`).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use stencil_gcode::machine::{LaserSource, Machine, Tool};
use stencil_gcode::CutSettings;
use stencil_io::profile::{check_range, load_toml, ProfileError};

use super::profile::*;

/// Why a material has no cut settings for a machine (see [`settings_for`]). The `stencil` binary
/// adds what to do (`--emit mask`, `--material`, `--machine`, `--power`, `test-grid`...).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SettingsError {
    /// An etch material: it makes a mask, not a cut.
    #[error("material '{material}' is for photo-etching and has no cut settings for G-code")]
    EtchOnly {
        /// The material profile's name.
        material: String,
    },
    /// The material is set up for another tool than the machine has.
    #[error(
        "material '{material}' is set up for a {process} but machine '{machine}' has a {tool}"
    )]
    WrongTool {
        /// The material profile's name.
        material: String,
        /// The process it is set up for.
        process: ProcessKind,
        /// The machine profile's name.
        machine: String,
        /// The machine's tool (`laser`, `knife`, `pen`).
        tool: &'static str,
        /// The shipped material set up for that tool ([`default_for`]).
        suggested: &'static str,
    },
    /// A laser material with no settings for this kind of laser (a CO2 card setting is no use on
    /// a 5 W diode), and none kept for this machine.
    #[error(
        "material '{material}' has no cut settings for machine '{machine}' ({kind}); it has \
         settings for: {}",
        if have.is_empty() { "none".to_string() } else { have.join(", ") }
    )]
    NoSettings {
        /// The material profile's name.
        material: String,
        /// The machine profile's name.
        machine: String,
        /// The machine's kind as printed (`diode laser 5.5 W`).
        kind: String,
        /// The kinds the material has settings for, as printed (`CO2 laser 40 W or more`).
        have: Vec<String>,
    },
}

/// A job's cut settings and where they came from: a kept setting's file, or the material
/// profile's entry and its published source. `make` prints it and report.json records it, so a
/// job can be made again with the same numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct Chosen {
    /// The settings.
    pub settings: CutSettings,
    /// Where they came from, as printed.
    pub from: String,
}

/// A material's cut settings for a machine, from the profile alone (see [`choose`] for the
/// settings a person kept).
pub fn settings_for(material: &Material, machine: &Machine) -> Result<CutSettings, SettingsError> {
    choose(material, machine, &UserSettings::default()).map(|c| c.settings)
}

/// A material's cut settings for a machine: what the person kept for this material and machine
/// profile (`stencil profiles set`), else the material's entry for the machine's kind. The process
/// must match the machine's tool. A laser gets the entry for its source with the most power at or
/// below its own: a weaker laser's settings cut on a stronger one, never the other way round.
pub fn choose(
    material: &Material,
    machine: &Machine,
    user: &UserSettings,
) -> Result<Chosen, SettingsError> {
    let (base, from) = match (&material.process, &machine.tool) {
        (Process::Laser(l), Tool::Laser { .. }) => {
            let laser = |power_pct, speed_mm_min, passes| CutSettings {
                power_pct,
                speed_mm_min,
                passes,
                blade_offset_mm: 0.0,
                air_assist: l.air_assist.unwrap_or(machine.air_assist),
            };
            match (
                laser_entry(l, machine),
                user.find(&material.name, &machine.name),
            ) {
                (_, Some(k)) => (
                    laser(k.power_pct.unwrap_or(100.0), k.speed_mm_min, k.passes),
                    user.describe(k),
                ),
                (Some(c), None) => (
                    laser(c.power_pct, c.speed_mm_min, c.passes),
                    format!("{} for {}: {}", material.name, cut_kind(c), c.from),
                ),
                (None, None) => {
                    return Err(SettingsError::NoSettings {
                        material: material.name.clone(),
                        machine: machine.name.clone(),
                        kind: machine.kind().to_string(),
                        have: l.on.iter().map(cut_kind).collect(),
                    })
                }
            }
        }
        (Process::Knife(k), Tool::Knife { .. }) => (
            CutSettings {
                power_pct: 100.0,
                speed_mm_min: k.speed_mm_s * 60.0,
                passes: k.passes,
                blade_offset_mm: k.blade_offset_mm,
                air_assist: false,
            },
            format!("{}'s [knife] section", material.name),
        ),
        (Process::Pen(p), Tool::Pen(_)) => (
            CutSettings {
                power_pct: 100.0,
                speed_mm_min: p.speed_mm_min,
                passes: 1,
                blade_offset_mm: 0.0,
                air_assist: false,
            },
            format!("{}'s [pen] section", material.name),
        ),
        (Process::Etch(_), _) => {
            return Err(SettingsError::EtchOnly {
                material: material.name.clone(),
            })
        }
        (p, t) => {
            return Err(SettingsError::WrongTool {
                material: material.name.clone(),
                process: p.kind(),
                machine: machine.name.clone(),
                tool: t.kind(),
                suggested: default_for(&machine.tool),
            })
        }
    };
    // A kept knife or pen setting overrides the speed and passes (and nothing else).
    let (settings, from) = match (&machine.tool, user.find(&material.name, &machine.name)) {
        (Tool::Laser { .. }, _) | (_, None) => (base, from),
        (_, Some(k)) => (
            CutSettings {
                speed_mm_min: k.speed_mm_min,
                passes: k.passes,
                ..base
            },
            user.describe(k),
        ),
    };
    Ok(Chosen { settings, from })
}

/// The `[[laser.on]]` entry for a machine: a flat one (any laser), else the one for its source
/// with the most power at or below the machine's.
fn laser_entry<'a>(l: &'a LaserSettings, machine: &Machine) -> Option<&'a LaserCut> {
    if let Some(any) = l.on.iter().find(|c| c.laser.is_none()) {
        return Some(any);
    }
    let power = machine.laser?;
    l.on.iter()
        .filter(|c| c.laser == Some(power.source) && c.watts <= power.watts + 1e-9)
        .max_by(|a, b| a.watts.total_cmp(&b.watts))
}

/// An entry's kind as printed: `diode laser 5 W or more`, `any laser`.
pub fn cut_kind(c: &LaserCut) -> String {
    match c.laser {
        None => "any laser".into(),
        Some(src) => format!(
            "{} laser {} W or more",
            match src {
                LaserSource::Diode => "diode",
                LaserSource::Co2 => "CO2",
            },
            stencil_gcode::num(c.watts)
        ),
    }
}

/// Whether a material has cut settings for a machine (from its profile or kept by the person):
/// what `stencil profiles` lists.
pub fn has_settings(material: &Material, machine: &Machine, user: &UserSettings) -> bool {
    choose(material, machine, user).is_ok()
}

/// The file kept settings are written to, in the user's config folder
/// ([`stencil_io::profile::config_dir`]).
pub const USER_SETTINGS_FILE: &str = "cut-settings.toml";

/// Cut settings a person kept with `stencil profiles set` (what a test grid taught them), per
/// material and machine profile: they win over the material profile's settings for that machine.
/// Kept in one small TOML file in the user's config folder, which a person can read and edit.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UserSettings {
    /// Where they were read from (not written in the file).
    #[serde(skip)]
    pub path: Option<PathBuf>,
    #[serde(default, rename = "kept")]
    pub(crate) entries: Vec<Kept>,
}

/// One kept setting.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Kept {
    /// The material profile's name (`cardstock`).
    pub material: String,
    /// The machine profile's name (`diode-400`).
    pub machine: String,
    /// Laser power, % (lasers only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub power_pct: Option<f64>,
    /// Speed, mm/min.
    pub speed_mm_min: f64,
    /// Passes over each outline.
    pub passes: u32,
}

impl UserSettings {
    /// The kept settings in `dir/cut-settings.toml`; none when the file does not exist. Every
    /// entry is checked as a profile's are (the error names the file and the field).
    pub fn load_from(dir: &Path) -> Result<UserSettings, ProfileError> {
        let path = dir.join(USER_SETTINGS_FILE);
        if !path.exists() {
            return Ok(UserSettings {
                path: Some(path),
                entries: Vec::new(),
            });
        }
        let mut u: UserSettings = load_toml(&path)?;
        for (k, e) in u.entries.iter().enumerate() {
            e.check(&path, &format!("kept[{k}]."))?;
        }
        u.path = Some(path);
        Ok(u)
    }

    /// The kept settings in the user's config folder, none when there is no config folder.
    pub fn load() -> Result<UserSettings, ProfileError> {
        match stencil_io::profile::config_dir() {
            Some(dir) => UserSettings::load_from(&dir),
            None => Ok(UserSettings::default()),
        }
    }

    /// The entry for a material and machine profile.
    pub fn find(&self, material: &str, machine: &str) -> Option<&Kept> {
        self.entries
            .iter()
            .find(|e| e.material == material && e.machine == machine)
    }

    /// Keep `e`, replacing an entry for the same material and machine.
    pub fn set(&mut self, e: Kept) {
        self.entries
            .retain(|o| !(o.material == e.material && o.machine == e.machine));
        self.entries.push(e);
        self.entries
            .sort_by(|a, b| (&a.material, &a.machine).cmp(&(&b.material, &b.machine)));
    }

    /// The file's text: `header` (comment lines saying what it is; the command that writes it
    /// knows its own name), then the entries.
    pub fn to_toml(&self, header: &str) -> String {
        let body = toml::to_string(self).unwrap_or_default();
        format!("{header}\n{body}")
    }

    /// Where a kept entry is, as `make` prints it.
    fn describe(&self, k: &Kept) -> String {
        format!(
            "{} (kept for {} on {})",
            self.path
                .as_deref()
                .map_or_else(|| USER_SETTINGS_FILE.into(), |p| p.display().to_string()),
            k.material,
            k.machine
        )
    }
}

impl Kept {
    /// The numbers in the ranges a profile allows.
    pub(crate) fn check(&self, origin: &Path, prefix: &str) -> Result<(), ProfileError> {
        let range =
            |f, v, lo, hi, unit| check_range(origin, &format!("{prefix}{f}"), v, lo, hi, unit);
        if let Some(p) = self.power_pct {
            range("power_pct", p, 0.1, 100.0, "%")?;
        }
        range("speed_mm_min", self.speed_mm_min, 1.0, 100_000.0, "mm/min")?;
        range("passes", self.passes as f64, 1.0, 50.0, "passes")
    }
}
