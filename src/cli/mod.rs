//! Command-line definitions (clap derive) and the thin dispatch into the library.
//! Each area owns its argument struct in its own file; they are flattened into the commands here.

mod bounds;
mod check;
pub mod errors;
mod estimate;
mod frame;
mod gcode;
mod grid;
mod hpgl;
mod jog;
mod layers;
mod machine_args;
mod make;
mod make_args;
mod material;
mod mesh;
mod operator;
mod place;
mod port;
mod program;
mod progress;
mod send;
mod send_hpgl;
mod simulate;
mod studio;
mod tiles;

use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

/// Turn a picture or a 3D mesh into a stencil that holds together as one sheet.
#[derive(Parser, Debug)]
#[command(name = "stencil", version, about, propagate_version = true)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Run the whole pipeline on a picture or an OBJ mesh: two-tone, islands, bridges, outputs.
    Make(Box<make_args::MakeArgs>),
    /// Stop after the two-tone stage (after the topological filter) and write one PNG.
    Tone(make_args::ToneCmdArgs),
    /// Stream a G-code file to a Grbl 1.1 controller (or a simulated one with --dry-run).
    Send(send::SendArgs),
    /// Draw what a G-code file makes the machine do (PNG) and estimate its running time.
    Simulate(simulate::SimulateArgs),
    /// Check a stencil (PNG or output folder) against a material: one piece, bridge, web and hole
    /// widths. Exits 0 only when there are no violations.
    Check(check::CheckArgs),
    /// List the machines, the materials and which materials have cut settings for which machine;
    /// `profiles set` keeps settings a test grid taught you.
    Profiles(material::ProfilesArgs),
    /// Write G-code for a GRBL 1.1 laser, pen plotter or drag knife from a stencil folder or an SVG.
    Gcode(gcode::GcodeArgs),
    /// Write HP-GL for a plotter cutter (vinyl, Roland, Graphtec) or a pen plotter from a stencil
    /// folder or an SVG.
    Hpgl(hpgl::HpglArgs),
    /// Estimate how long any G-code file runs (Grbl-style acceleration and junction speeds).
    Estimate(estimate::EstimateArgs),
    /// Trace the outline of what a G-code file cuts (tool off or a dim laser), then come back.
    Frame(frame::FrameArgs),
    /// Jog the head with the arrow keys ($J=), home ($H), unlock ($X) and set work zero.
    Jog(jog::JogArgs),
    /// Write a grid of test squares over power x speed (laser), depth x speed (knife) or speed
    /// (pen), with a labelled SVG preview, to find the settings a material needs.
    TestGrid(grid::TestGridArgs),
    /// Serve a local page (127.0.0.1) that steers `make` live: every option, the images, the
    /// report, bridges to delete or pin, a keep-out brush, undo; export writes what `make` would.
    Studio(Box<studio::StudioArgs>),
}

/// What `make -h` shows, one line each: the options a first stencil needs. `--help` has them all,
/// as written on their fields (it runs to hundreds of lines).
const MAKE_SHORT: &[(&str, &str)] = &[
    ("input", "The picture (PNG, JPEG, BMP, TIFF) or mesh (OBJ)"),
    ("out", "Output folder [default: out/<input stem>/]"),
    (
        "width_mm",
        "Width on the sheet in mm [default: 0.1 mm per pixel]",
    ),
    (
        "dpi",
        "Pixels of the picture per inch (instead of --width-mm)",
    ),
    (
        "sheet",
        "Fit to a sheet of stock: A4, A3, LETTER or WxH in mm",
    ),
    (
        "material",
        "Material profile (see `stencil profiles`) [default: cardstock]",
    ),
    (
        "threshold",
        "Gray level that splits the two tones: 0-255, otsu or auto",
    ),
    (
        "invert",
        "Make the dark parts material instead of the light",
    ),
    (
        "emit",
        "Files to write, comma separated (report.json always)",
    ),
    (
        "machine",
        "The machine a G-code job is for (see `stencil profiles`)",
    ),
    (
        "layers",
        "A set of N stencils sprayed in turn, light to dark",
    ),
    (
        "gobo",
        "A round gobo for a lighting fixture: A, B, M, E or OD,IA in mm",
    ),
];

/// The command line as given: `make -h` lists the common options in a line each and says that
/// `--help` lists every one (issue 42: `-h` was 314 lines).
pub fn parse() -> Cli {
    let cmd = Cli::command().mut_subcommand("make", |c| {
        let all = c.get_arguments().filter(|a| !a.is_positional()).count();
        let example = c
            .get_after_help()
            .map(|s| s.to_string())
            .unwrap_or_default();
        c.mut_args(
            |a| match MAKE_SHORT.iter().find(|(id, _)| a.get_id() == *id) {
                Some((_, short)) => {
                    let long = a.get_long_help().or(a.get_help()).cloned();
                    let a = a.help(*short);
                    match long {
                        Some(long) => a.long_help(long),
                        None => a,
                    }
                }
                None if a.get_id() == "help" => a,
                None => a.hide_short_help(true),
            },
        )
        .after_long_help(example.clone())
        .after_help(format!(
            "{example}\n\nThe common options; `stencil make --help` lists all {all}, with the \
             rules each follows."
        ))
    });
    Cli::from_arg_matches(&cmd.get_matches()).unwrap_or_else(|e| e.exit())
}

pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Make(a) => make::run_make(*a),
        Command::Tone(a) => make::run_tone(a),
        Command::Send(a) => send::run_send(a),
        Command::Simulate(a) => simulate::run_simulate(a),
        Command::Check(a) => check::run_check(a),
        Command::Profiles(a) => material::run_profiles(a),
        Command::Gcode(a) => gcode::run_gcode(a),
        Command::Hpgl(a) => hpgl::run_hpgl(a),
        Command::Estimate(a) => estimate::run_estimate(a),
        Command::Frame(a) => frame::run_frame(a),
        Command::Jog(a) => jog::run_jog(a),
        Command::TestGrid(a) => grid::run_test_grid(a),
        Command::Studio(a) => studio::run_studio(*a, Cli::command()),
    }
}
