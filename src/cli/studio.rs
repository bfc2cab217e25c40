//! `stencil studio`: `make`'s options, served as a local page that steers them live (the
//! `stencil-studio` crate). This file tells the studio what `make`'s options are (from clap's
//! own definitions, so the page and the command line cannot drift apart) and words its errors
//! as `make` does.

use std::ffi::OsString;
use std::io::Write;
use std::process::ExitCode;
use std::sync::Arc;

use clap::{ArgAction, Args, FromArgMatches};
use serde_json::Value;
use stencil_core::MakeConfig;
use stencil_studio::{Configured, Kind, OptionSpec};

use super::make::{make_config, set_config, tiles_config, tiles_error};
use super::make_args::MakeArgs;

#[derive(Args, Debug)]
#[command(after_help = "\
Example:
  stencil studio samples/rings.png --material cardstock -o out/rings
  prints http://127.0.0.1:PORT/?token=... on its first line; open it in a browser. Each change
  shows at once; Export writes what `stencil make` would, and shows its command line.")]
pub struct StudioArgs {
    #[command(flatten)]
    pub make: MakeArgs,
    /// Port on 127.0.0.1 to listen on [default: any free port].
    #[arg(long, default_value_t = 0)]
    pub port: u16,
    /// Open the page in the desktop's browser (xdg-open).
    #[arg(long)]
    pub open: bool,
}

/// `make`'s options for the studio, from the `make` subcommand's clap definition in `cli`, the
/// whole command line's (given by the caller, which defines it), and the files they name, read
/// once while they stay (the picture's header, the keep-out picture).
struct CliMaker {
    cli: clap::Command,
    inputs: std::sync::Mutex<stencil_core::KeptInputs>,
}

/// Options of `make` the studio does not offer: the input and output folder are fixed when it
/// starts.
const NOT_OFFERED: &[&str] = &["out", "help", "version"];

fn make_command(cli: &clap::Command) -> clap::Command {
    cli.find_subcommand("make")
        .cloned()
        .unwrap_or_else(|| clap::Command::new("make"))
}

impl stencil_studio::Maker for CliMaker {
    fn options(&self) -> Vec<OptionSpec> {
        let cmd = make_command(&self.cli);
        cmd.get_arguments()
            .filter(|a| !a.is_positional())
            .filter_map(|a| {
                let name = a.get_long()?.to_string();
                if NOT_OFFERED.contains(&name.as_str()) {
                    return None;
                }
                let kind = kind(a);
                let choices = profile_choices(&name).unwrap_or_else(|| {
                    a.get_possible_values()
                        .iter()
                        .filter(|v| !v.is_hide_set())
                        .map(|v| v.get_name().to_string())
                        .collect()
                });
                Some(OptionSpec {
                    name,
                    kind,
                    default: if kind == Kind::Flag {
                        Vec::new()
                    } else {
                        a.get_default_values()
                            .iter()
                            .map(|v| v.to_string_lossy().into_owned())
                            .collect()
                    },
                    choices,
                    group: a.get_help_heading().unwrap_or("Output").to_string(),
                    help: a.get_help().map(|h| h.to_string()).unwrap_or_default(),
                })
            })
            .collect()
    }

    fn config(&self, args: &[String]) -> Result<Configured, String> {
        let mut kept = self.inputs.lock().unwrap_or_else(|e| e.into_inner());
        let a = parse_make(&self.cli, args)?;
        let one_line = |e: anyhow::Error| super::errors::one_line(&e);
        let cfg = make_config(&a, Some(&mut kept)).map_err(one_line)?;
        let tiles = tiles_config(&a).map_err(one_line)?;
        // In tiles, the layers asked for are the tiles' (as `make` runs them).
        let set = set_config(&a).filter(|_| tiles.is_none());
        Ok(Configured { cfg, set, tiles })
    }

    fn describe(&self, cfg: &MakeConfig, e: stencil_core::Error) -> String {
        super::errors::one_line(&tiles_error(cfg, e))
    }
}

/// How the page takes an option.
fn kind(a: &clap::Arg) -> Kind {
    match a.get_action() {
        ArgAction::SetTrue => Kind::Flag,
        // A list given with commas is one value, as on the command line.
        ArgAction::Append if a.get_value_delimiter().is_none() => Kind::List,
        _ => Kind::Value,
    }
}

/// `stencil make ARGS` parsed as the command line parses it.
fn parse_make(cli: &clap::Command, args: &[String]) -> Result<MakeArgs, String> {
    let argv = ["stencil", "make"]
        .into_iter()
        .map(String::from)
        .chain(args.iter().cloned());
    let m = cli.clone().try_get_matches_from(argv);
    match m.as_ref().map(|m| m.subcommand()) {
        Ok(Some(("make", m))) => {
            MakeArgs::from_arg_matches(m).map_err(|e| clap_message(&e.format(&mut cli.clone())))
        }
        Ok(_) => Err("not a make command".into()),
        Err(e) => Err(clap_message(e)),
    }
}

/// The page offers a material and a machine as lists: the shipped profiles and the user's own
/// (`.toml` files in the profile folders), as `stencil materials` / `stencil machines` list them.
/// A profile file given by path on the command line still works: the page adds the value it is
/// shown to the list.
fn profile_choices(name: &str) -> Option<Vec<String>> {
    match name {
        "material" => Some(stencil_io::profile::known_names(
            "materials",
            stencil_core::material::SHIPPED,
        )),
        "machine" => Some(stencil_io::profile::known_names(
            "machines",
            stencil_gcode::machine::SHIPPED,
        )),
        _ => None,
    }
}

/// clap's message without its "error: " and the closing hint, as one paragraph.
fn clap_message(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let first = text.split("\n\n").next().unwrap_or(&text).trim();
    first.strip_prefix("error: ").unwrap_or(first).to_string()
}

/// The option values given on the command line, as `/api/params` takes them.
fn given_options(cli: &clap::Command, args: &[OsString]) -> Value {
    let mut out = serde_json::Map::new();
    let matches = cli.clone().try_get_matches_from(args).ok();
    let Some(("studio", m)) = matches.as_ref().and_then(|m| m.subcommand()) else {
        return Value::Object(out);
    };
    for a in make_command(cli).get_arguments() {
        let (Some(long), id) = (a.get_long(), a.get_id().as_str()) else {
            continue;
        };
        if NOT_OFFERED.contains(&long)
            || m.value_source(id) != Some(clap::parser::ValueSource::CommandLine)
        {
            continue;
        }
        let raw: Vec<String> = m
            .get_raw(id)
            .map(|v| v.map(|s| s.to_string_lossy().into_owned()).collect())
            .unwrap_or_default();
        let v = match kind(a) {
            Kind::Flag => Value::from("true"),
            Kind::List => Value::from(raw),
            Kind::Value => Value::from(raw.join(",")),
        };
        out.insert(long.to_string(), v);
    }
    Value::Object(out)
}

/// `stencil studio`; `cli` is the whole command line's definition, whose `make` the page offers.
pub fn run_studio(a: StudioArgs, cli: clap::Command) -> anyhow::Result<ExitCode> {
    // Checked as `make` checks them, so a bad option fails here, before anything listens.
    make_config(&a.make, None)?;
    let cfg = stencil_studio::StudioConfig {
        input: a.make.input.clone(),
        out_dir: a.make.out_dir(),
        initial: given_options(&cli, &std::env::args_os().collect::<Vec<_>>()),
        port: a.port,
    };
    let open = a.open;
    stencil_studio::serve(
        Arc::new(CliMaker {
            cli,
            inputs: Default::default(),
        }),
        cfg,
        |url| {
            // The URL is the first line of stdout (scripts and tests read it).
            println!("{url}");
            let _ = std::io::stdout().flush();
            eprintln!("stencil studio: serving on 127.0.0.1 until Ctrl-C");
            if open {
                if let Err(e) = std::process::Command::new("xdg-open").arg(url).spawn() {
                    eprintln!("note: could not open a browser (xdg-open: {e}); open the URL above");
                }
            }
        },
    )
    .map_err(anyhow::Error::msg)?;
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use stencil_studio::Maker;

    #[test]
    fn every_make_option_is_offered_once() {
        let cli = <crate::cli::Cli as clap::CommandFactory>::command();
        let specs = CliMaker {
            cli,
            inputs: Default::default(),
        }
        .options();
        let names: Vec<&str> = specs.iter().map(|s| s.name.as_str()).collect();
        for n in [
            "threshold",
            "invert",
            "width-mm",
            "material",
            "bridge-at",
            "keep-out",
            "emit",
        ] {
            assert!(names.contains(&n), "{n} missing from {names:?}");
        }
        let mut sorted = names.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), names.len());
        let flag = specs.iter().find(|s| s.name == "invert").map(|s| s.kind);
        assert_eq!(flag, Some(Kind::Flag));
        let list = specs.iter().find(|s| s.name == "bridge-at").map(|s| s.kind);
        assert_eq!(list, Some(Kind::List));
    }
}
