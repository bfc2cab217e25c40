//! `stencil test-grid`: squares over power × speed (laser), depth × speed (drag knife) or speed
//! (pen), with an SVG preview beside the G-code, to find the settings a material needs.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;

use stencil_core::material::Material;
use stencil_gcode::machine::{self as machine_profile, Machine, Tool};
use stencil_gcode::num;
use stencil_gcode::{self as plan, CutSettings};
use stencil_gcode::{grid_gcode, grid_svg, plan_grid, Grid, GridSpec, RowKind, Steps};

/// Write a grid of test squares over power and speed, with a labelled SVG preview.
#[derive(Args, Debug)]
#[command(after_help = "\
Laser: rows vary the power, columns the speed. Drag knife: rows vary the blade depth (Z), \
columns the speed. Pen: one row over the speed. Ranges are FROM..TO:STEPS (e.g. 20..100:5) or one \
number; the defaults are the material's own power/speed from half to one and a half times \
(5 steps each) and, for a knife, its profile's depth +-0.2 mm. Each square's settings are in \
the G-code comment before it and written on it in the SVG. Cut it, pick the cleanest square, and \
write its numbers into the material profile.
Example: stencil test-grid --machine diode-400 --material cardstock -o grid.gcode")]
pub struct TestGridArgs {
    /// Machine profile (name or .toml path) [default: diode-400].
    #[arg(long, value_name = "NAME|FILE")]
    pub machine: Option<String>,
    /// Material profile whose settings the grid centres on (name or .toml path) [default for a
    /// laser: cardstock; a pen or knife without one needs --speed].
    #[arg(long, value_name = "NAME|FILE")]
    pub material: Option<String>,
    /// The G-code file to write; the preview goes beside it with .svg.
    #[arg(short, long, default_value = "grid.gcode")]
    pub output: PathBuf,
    /// Laser power per row, % (FROM..TO:STEPS), 0.1 to 100.
    #[arg(long, value_name = "RANGE", value_parser = |s: &str| steps_in(s, 0.1..=100.0, " %"))]
    pub power: Option<Steps>,
    /// Speed per column, mm/min (FROM..TO:STEPS), 1 to 200000.
    #[arg(long, value_name = "RANGE", value_parser = |s: &str| steps_in(s, stencil_gcode::bounds::FEED_MM_MIN, " mm/min"), allow_hyphen_values = true)]
    pub speed: Option<Steps>,
    /// Drag knife: blade depth per row, machine Z mm (FROM..TO:STEPS, e.g. -0.1..-0.5:5), -1000
    /// to 1000.
    #[arg(long, value_name = "RANGE", value_parser = |s: &str| steps_in(s, stencil_gcode::bounds::Z_MM, " mm"), allow_hyphen_values = true)]
    pub depth: Option<Steps>,
    /// Side of each square, mm (1 to 100).
    #[arg(long, default_value_t = 10.0, value_parser = |s: &str| super::bounds::number_in(s, 1.0..=100.0, " mm"))]
    pub size: f64,
    /// Gap between squares, mm (0 to 100).
    #[arg(long, default_value_t = 5.0, value_parser = |s: &str| super::bounds::number_in(s, 0.0..=100.0, " mm"))]
    pub gap: f64,
    /// Machine coordinates of the grid's lower-left corner, mm.
    #[arg(long, value_name = "X,Y", default_value = "5,5", value_parser = super::bounds::parse_offset, allow_hyphen_values = true)]
    pub offset: [f64; 2],
    /// Passes per square [default: the material's].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=plan::bounds::MAX_PASSES as i64))]
    pub passes: Option<u32>,
}

/// A range option (`FROM..TO:STEPS`) whose ends both lie in `range`: what a machine can take
/// (a value like -1e308 made the steps between the ends infinite, and `G1 Z-inf` was written).
fn steps_in(s: &str, range: std::ops::RangeInclusive<f64>, unit: &str) -> Result<Steps, String> {
    let r = Steps::parse(s)?;
    if [r.from, r.to].iter().all(|v| range.contains(v)) {
        Ok(r)
    } else {
        Err(format!(
            "'{s}' is out of range: each end must be from {} to {}{unit}",
            num(*range.start()),
            num(*range.end())
        ))
    }
}

/// Half to one and a half times `v`, in 5 steps, within `lo..=hi`.
fn around(v: f64, lo: f64, hi: f64) -> Steps {
    let r = |x: f64| (x * 10.0).round() / 10.0;
    Steps {
        from: r((v * 0.5).max(lo)),
        to: r((v * 1.5).min(hi)),
        steps: 5,
    }
}

fn describe(s: &Steps, unit: &str) -> String {
    match s.steps {
        1 => format!("{}{unit}", num(s.from)),
        n => format!("{}..{}{unit} in {n} steps", num(s.from), num(s.to)),
    }
}

pub fn run_test_grid(a: TestGridArgs) -> anyhow::Result<ExitCode> {
    let mut inputs: Vec<&std::path::Path> = Vec::new();
    inputs.extend(a.machine.as_deref().map(std::path::Path::new));
    inputs.extend(a.material.as_deref().map(std::path::Path::new));
    stencil_io::check_output(&a.output, &inputs)?;
    stencil_io::check_output(&a.output.with_extension("svg"), &inputs)?;
    let machine = machine_profile::load(a.machine.as_deref())?;
    check_tool_options(&a, &machine)?;
    // Without --material, the machine's tool picks one (as `make` does).
    let material = match &a.material {
        Some(m) => Material::find(m)?.0,
        None => Material::find_default(stencil_core::material::default_for(&machine.tool))?.0,
    };
    let base = base_settings(&a, &machine, &material)?;
    let max_feed = machine.motion.max_feed_mm_min;
    let speeds = a
        .speed
        .unwrap_or_else(|| around(base.speed_mm_min, 1.0, max_feed));
    let (row_kind, rows, row_text) = rows_for(&a, &machine, &base);
    let spec = GridSpec {
        row_kind,
        rows,
        speeds: speeds.values(),
        size_mm: a.size,
        gap_mm: a.gap,
        offset: a.offset,
        base,
    };
    let grid = plan_grid(&spec, &machine)?;
    let speed_text = format!("speed {}", describe(&speeds, " mm/min"));
    let layout = if row_text.is_empty() {
        format!("one row over {speed_text}")
    } else {
        format!("rows: {row_text}; columns: {speed_text}")
    };
    let notes = header_notes(&a, &grid, &layout, &material);
    let gcode = grid_gcode(&grid, &machine, &notes);
    let svg_path = a.output.with_extension("svg");
    if svg_path == a.output {
        bail!(
            "{}: the G-code file needs another extension than .svg (the preview is written beside it as .svg)",
            a.output.display()
        );
    }
    let title = format!("test grid on {}, {}: {layout}", machine.name, material.name);
    stencil_io::write_atomic(&svg_path, grid_svg(&grid, &machine, &title).as_bytes())
        .with_context(|| format!("{}: cannot write the preview", svg_path.display()))?;
    stencil_io::write_atomic(&a.output, gcode.as_bytes())?;
    println!(
        "wrote {} ({} squares, {layout}; {} x {} mm at X{} Y{} on {}) and {}",
        a.output.display(),
        grid.cells.len(),
        num(grid.size[0]),
        num(grid.size[1]),
        num(a.offset[0]),
        num(a.offset[1]),
        machine.name,
        svg_path.display()
    );
    let power = if matches!(machine.tool, Tool::Laser { .. }) {
        " --power P"
    } else {
        ""
    };
    println!(
        "cut it, then keep the cleanest square's settings for later jobs: stencil profiles set {} \
         --machine {}{power} --speed S [--passes N]",
        material.name, machine.name
    );
    Ok(ExitCode::SUCCESS)
}

/// Refuse a row option the machine's tool has no use for (--power without a laser, --depth
/// without a drag knife), saying what the grid varies instead, rather than ignoring it.
fn check_tool_options(a: &TestGridArgs, machine: &Machine) -> anyhow::Result<()> {
    let laser = matches!(machine.tool, Tool::Laser { .. });
    let knife = matches!(machine.tool, Tool::Knife { .. });
    if a.power.is_some() && !laser {
        bail!(
            "--power: '{}' has a {}, which has no power; the grid varies {}",
            machine.name,
            machine.tool.kind(),
            if knife {
                "the blade depth (--depth) and the speed (--speed)"
            } else {
                "the speed (--speed)"
            }
        );
    }
    if a.depth.is_some() && !knife {
        bail!(
            "--depth is for a drag knife; '{}' has a {}",
            machine.name,
            machine.tool.kind()
        );
    }
    Ok(())
}

/// The settings the grid centres on: the material's for this machine, or without them the middle
/// of --power and --speed; --passes overrides either. (A material is always there: the machine's
/// tool picks one when --material is not given.)
fn base_settings(
    a: &TestGridArgs,
    machine: &Machine,
    material: &Material,
) -> anyhow::Result<CutSettings> {
    let user = stencil_core::material::UserSettings::load()?;
    let mut base = match stencil_core::material::choose(material, machine, &user) {
        Ok(c) => c.settings,
        // No settings for this kind of machine yet: finding them is what the grid is for, from
        // the ranges given.
        Err(stencil_core::material::SettingsError::NoSettings { .. }) => {
            match (&a.power, &a.speed) {
                (Some(p), Some(s)) => CutSettings {
                    power_pct: (p.from + p.to) / 2.0,
                    speed_mm_min: (s.from + s.to) / 2.0,
                    passes: 1,
                    blade_offset_mm: 0.0,
                    air_assist: machine.air_assist,
                },
                _ => bail!(
                    "material '{}' has no settings for '{}' ({}) to centre the grid on: give the \
                     ranges to try with --power FROM..TO:STEPS and --speed FROM..TO:STEPS",
                    material.name,
                    machine.name,
                    machine.kind()
                ),
            }
        }
        Err(e) => return Err(e.into()),
    };
    base.passes = a.passes.unwrap_or(base.passes);
    Ok(base)
}

/// What the rows vary, by tool: power around the base for a laser, depth ±0.2 mm around the
/// profile's for a drag knife, nothing for a pen (one row); with the rows' values and their
/// description for the notes.
fn rows_for(
    a: &TestGridArgs,
    machine: &Machine,
    base: &CutSettings,
) -> (RowKind, Vec<f64>, String) {
    match machine.tool {
        Tool::Laser { .. } => {
            let p = a
                .power
                .unwrap_or_else(|| around(base.power_pct, 0.1, 100.0));
            (
                RowKind::Power,
                p.values(),
                format!("power {}", describe(&p, " %")),
            )
        }
        Tool::Knife { z, .. } => {
            let d = a.depth.unwrap_or(Steps {
                from: z.down_mm + 0.2,
                to: z.down_mm - 0.2,
                steps: 5,
            });
            (
                RowKind::Depth,
                d.values(),
                format!("depth Z {}", describe(&d, " mm")),
            )
        }
        Tool::Pen(_) => (RowKind::None, Vec::new(), String::new()),
    }
}

/// The G-code header's notes: the grid's size and place, its layout, and that each square sets
/// its own settings (the header's are the material's).
fn header_notes(a: &TestGridArgs, grid: &Grid, layout: &str, material: &Material) -> Vec<String> {
    vec![
        format!(
            "test grid: {} squares of {} mm, {} mm apart, {} x {} mm at X{} Y{}",
            grid.cells.len(),
            num(a.size),
            num(a.gap),
            num(grid.size[0]),
            num(grid.size[1]),
            num(a.offset[0]),
            num(a.offset[1])
        ),
        layout.to_string(),
        format!(
            "material {}: the header's settings are its own; each square sets its own, see the comment before it",
            material.name
        ),
    ]
}
