//! Profiles (materials, machines) read from TOML: the small loader every profile kind shares.
//! [`load_toml`] / [`parse_toml`] turn a file into a typed value with an error that names the file
//! and the field, and [`resolve`] finds a profile by name or path. Each kind validates its own
//! fields once at load (`stencil-core`'s materials, `stencil-gcode`'s machines).
//!
//! Where a name is looked up, in order (the first hit wins):
//! 1. a path to a `.toml` file (anything containing a `/` or ending in `.toml`);
//! 2. `./profiles/<kind>/<name>.toml` in the current directory (a user's edited copy);
//! 3. the copy embedded in the binary with `include_str!` (so an installed binary has them too).
//!
//! A run that names no profile uses the shipped default as embedded ([`embedded`]), in the library
//! and in the command alike: a copy in `./profiles/` is used only when named, so the output of a
//! run without `--material`/`--machine` does not depend on the folder it is started in.

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;

/// Errors reading or validating a profile. Every message names the file (or the name looked up)
/// and, where there is one, the field.
#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    #[error(transparent)]
    /// The file could not be read.
    Read(#[from] crate::read::ReadError),
    /// TOML syntax, a missing field, an unknown field or a wrong type (toml's message names the
    /// field and the line).
    #[error("{path}: {msg}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// toml's message.
        msg: String,
    },
    #[error("{path}: field `{field}` = {value}: {why}")]
    /// A value out of its range.
    Invalid {
        /// The file.
        path: PathBuf,
        /// The field, dotted (`tool.s_max`).
        field: String,
        /// Its value, as written.
        value: String,
        /// What is wrong with it.
        why: String,
    },
    #[error("unknown {kind} '{name}'; known: {}; or give a path to a .toml file", known.join(", "))]
    /// No profile of that name.
    Unknown {
        /// "material" or "machine".
        kind: String,
        /// The name looked up.
        name: String,
        /// The names there are.
        known: Vec<String>,
    },
}

/// A shipped profile, `shipped!("materials", "cardstock")`: its text embedded at build time from
/// `profiles/<kind>/<name>.toml` at the workspace root (the calling crate lives in `crates/<name>/`),
/// so an installed binary has every profile.
#[macro_export]
macro_rules! shipped {
    ($kind:literal, $name:literal) => {
        $crate::profile::Shipped {
            name: $name,
            text: include_str!(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../profiles/",
                $kind,
                "/",
                $name,
                ".toml"
            )),
        }
    };
}

/// A profile shipped with the crate: its name (the file stem) and its TOML text.
#[derive(Clone, Copy, Debug)]
pub struct Shipped {
    /// The file stem.
    pub name: &'static str,
    /// The TOML text.
    pub text: &'static str,
}

/// Read and parse a TOML file into `T`. At most [`Kind::Profile`](crate::Kind::Profile)'s cap (1
/// MiB) is read: a huge file or a device such as /dev/zero is refused instead of read forever.
pub fn load_toml<T: DeserializeOwned>(path: &Path) -> Result<T, ProfileError> {
    let text = crate::read::read_text(path, crate::read::Kind::Profile)?;
    parse_toml(&text, path)
}

/// Parse TOML text into `T`; `origin` is the file (or embedded name) for error messages.
pub fn parse_toml<T: DeserializeOwned>(text: &str, origin: &Path) -> Result<T, ProfileError> {
    toml::from_str(text).map_err(|e| ProfileError::Parse {
        path: origin.to_path_buf(),
        msg: where_and_why(text, &e),
    })
}

/// toml's error as "line L, column C: what", on one line. toml's own text quotes the offending
/// line of the file; that is not repeated: a file that is not a profile at all (`/etc/passwd`
/// given as `--material`) must not have its content printed.
fn where_and_why(text: &str, e: &toml::de::Error) -> String {
    let what = one_line(e.message());
    match e.span() {
        Some(span) => {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
            format!("line {line}, column {col}: {what}")
        }
        None => what,
    }
}

fn one_line(s: &str) -> String {
    s.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}

/// Whether a `--material` / `--machine` argument is a path rather than a name.
fn is_path(arg: &str) -> bool {
    arg.contains('/') || arg.contains('\\') || arg.ends_with(".toml")
}

/// The folder searched for a user's profiles: `profiles/<kind>/` in the current directory. (No
/// folder baked in at build time: the binary behaves the same wherever it was built; the shipped
/// profiles are embedded.)
fn search_dir(kind: &str) -> PathBuf {
    Path::new("profiles").join(kind)
}

/// Find a profile by name or path and parse it. Returns the value and where it came from (a path,
/// or `<embedded>/<kind>/<name>.toml`).
pub fn resolve<T: DeserializeOwned>(
    arg: &str,
    kind: &str,
    shipped: &[Shipped],
) -> Result<(T, PathBuf), ProfileError> {
    if is_path(arg) {
        let p = PathBuf::from(arg);
        return Ok((load_toml(&p)?, p));
    }
    let p = search_dir(kind).join(format!("{arg}.toml"));
    if p.is_file() {
        return Ok((load_toml(&p)?, p));
    }
    embedded(arg, kind, shipped)
}

/// The shipped profile `name` as embedded in the binary, whatever `./profiles/` holds: what a run
/// uses when the user names no profile, so that a run's output does not depend on the folder it
/// is started in. Its origin is `<embedded>/<kind>/<name>.toml`.
pub fn embedded<T: DeserializeOwned>(
    name: &str,
    kind: &str,
    shipped: &[Shipped],
) -> Result<(T, PathBuf), ProfileError> {
    if let Some(s) = shipped.iter().find(|s| s.name == name) {
        let origin = Path::new("<embedded>")
            .join(kind)
            .join(format!("{}.toml", s.name));
        return Ok((parse_toml(s.text, &origin)?, origin));
    }
    Err(ProfileError::Unknown {
        kind: kind.trim_end_matches('s').to_string(),
        name: name.to_string(),
        known: known_names(kind, shipped),
    })
}

/// Every profile name available: shipped ones plus `.toml` files in the search folder, sorted.
pub fn known_names(kind: &str, shipped: &[Shipped]) -> Vec<String> {
    let mut names: Vec<String> = shipped.iter().map(|s| s.name.to_string()).collect();
    for e in std::fs::read_dir(search_dir(kind))
        .into_iter()
        .flatten()
        .flatten()
    {
        let p = e.path();
        if p.extension().is_some_and(|x| x == "toml") {
            if let Some(stem) = p.file_stem().and_then(|s| s.to_str()) {
                names.push(stem.to_string());
            }
        }
    }
    names.sort();
    names.dedup();
    names
}

/// Check that a number lies in `lo..=hi` (finite); the error names the field and the range.
pub fn check_range(
    origin: &Path,
    field: &str,
    v: f64,
    lo: f64,
    hi: f64,
    unit: &str,
) -> Result<(), ProfileError> {
    if !v.is_finite() || v < lo || v > hi {
        let range = format!("{lo}..={hi} {unit}");
        let why = if v < 0.0 && lo >= 0.0 {
            format!("must not be negative (allowed {})", range.trim_end())
        } else {
            format!("out of range: allowed {}", range.trim_end())
        };
        return Err(ProfileError::Invalid {
            path: origin.to_path_buf(),
            field: field.to_string(),
            // 1e308 as written, not as 309 digits.
            value: if v != 0.0 && !(1e-4..1e9).contains(&v.abs()) {
                format!("{v:e}")
            } else {
                v.to_string()
            },
            why,
        });
    }
    Ok(())
}

/// The environment variable that points the user's config folder elsewhere (tests set it to a
/// temporary folder; a person can keep several setups apart).
pub const CONFIG_DIR_ENV: &str = "STENCIL_CONFIG_DIR";

/// The user's config folder for stencil, where settings a person keeps are written
/// (`stencil profiles set`): `$STENCIL_CONFIG_DIR`, else the platform's config folder with
/// `stencil` in it: `$XDG_CONFIG_HOME/stencil` or `~/.config/stencil` (Linux, BSD and, as most
/// command-line tools do, macOS), `%APPDATA%\stencil` (Windows). `None` when none of these is
/// set (no home folder): then nothing is kept.
pub fn config_dir() -> Option<PathBuf> {
    let var = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    if let Some(d) = var(CONFIG_DIR_ENV) {
        return Some(d);
    }
    if cfg!(windows) {
        return var("APPDATA").map(|d| d.join("stencil"));
    }
    var("XDG_CONFIG_HOME")
        .filter(|d| d.is_absolute())
        .or_else(|| var("HOME").map(|h| h.join(".config")))
        .map(|d| d.join("stencil"))
}
