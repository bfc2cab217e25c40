//! `stencil gcode`, and the G-code part of `make --emit gcode`: its settings and its summary.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;

use stencil_core::material::Material;
use stencil_gcode::machine::{Machine, Tool};
use stencil_gcode::{self as plan, CutSettings, GcodeConfig, GcodeSummary};
use stencil_gcode::{format_duration, Feeding, Starve};

use super::machine_args::{CutArgs, MachineArgs};

/// Print what a job costs (shared by `make --emit gcode` and `gcode`).
pub fn print_summary(path: &Path, s: &GcodeSummary) {
    let e = &s.estimate;
    println!(
        "{}: {} ({}), {} loops{}; cut {:.0} mm, travel {:.0} mm (input order {:.0} mm); about {} \
         (cut {}, travel {})",
        path.display(),
        s.machine,
        s.tool,
        s.path.loops,
        match s.path.lines {
            0 => String::new(),
            n => format!(" and {n} open paths"),
        },
        s.path.cut_mm,
        s.path.travel_mm,
        s.path.naive_travel_mm,
        format_duration(e.total_s),
        format_duration(e.cut_s),
        format_duration(e.travel_s),
    );
    print_feeding(&s.feeding, s.tool == "laser");
    if let Some(c) = &s.settings {
        let power = if s.tool == "laser" {
            format!("{} % power, ", plan::num(c.power_pct))
        } else {
            String::new()
        };
        println!(
            "cut settings: {power}{} mm/min, {} pass{}{}",
            plan::num(c.speed_mm_min),
            c.passes,
            if c.passes == 1 { "" } else { "es" },
            s.settings_from
                .as_deref()
                .map(|f| format!("; from {f}"))
                .unwrap_or_default()
        );
    }
}

/// Places printed one a line before the rest are counted.
const PLACES_SHOWN: usize = 8;

/// Where a stretch of a program is: its lines and where the head goes, mm.
fn stretch(first: usize, last: usize, from: [f64; 2], to: [f64; 2]) -> String {
    format!(
        "  lines {first}-{last} (X{:.1} Y{:.1} to X{:.1} Y{:.1}",
        from[0], from[1], to[0], to[1]
    )
}

/// One place where the planner starves, for people: where, by how much, and what feed the
/// serial line keeps fed there.
pub fn starve_line(s: &Starve) -> String {
    format!(
        "{}, {:.0} mm): the feed ({} mm/min) uses {:.0} lines/s, the serial line brings {:.0}; \
         {:.2} s lost; it keeps up to about {} mm/min",
        stretch(s.first_line, s.last_line, s.from, s.to),
        s.length_mm,
        plan::num(s.feed_mm_min.round()),
        s.lines_per_s_needed,
        s.lines_per_s_link,
        s.lost_s,
        plan::num(s.fed_mm_min.floor()),
    )
}

/// Print `places`, at most [`PLACES_SHOWN`] of them, and how many more there are.
pub fn print_places<T>(places: &[T], line: impl Fn(&T) -> String) {
    for p in places.iter().take(PLACES_SHOWN) {
        println!("{}", line(p));
    }
    if places.len() > PLACES_SHOWN {
        println!("  ... and {} more", places.len() - PLACES_SHOWN);
    }
}

/// "1 place", "3 places".
pub fn places(n: usize) -> String {
    if n == 1 {
        "1 place".to_string()
    } else {
        format!("{n} places")
    }
}

/// Say where a written job would starve the planner and what was done about it: nothing when
/// it never starves.
pub fn print_feeding(f: &Feeding, laser: bool) {
    if f.is_quiet() {
        return;
    }
    let places = |n: usize| {
        if n == 1 {
            "1 place".to_string()
        } else {
            format!("{n} places")
        }
    };
    if !f.slowed.is_empty() {
        println!(
            "feed lowered in {} so that the serial line ({} baud) keeps the planner fed (it \
             would starve there and the head stutter, {:.2} s lost; --keep-feed keeps the \
             feed){}:",
            places(f.slowed.len()),
            f.baud,
            f.lost_s,
            if laser {
                "; the laser's power (M4) follows the speed"
            } else {
                ""
            },
        );
        print_places(&f.slowed, |s| {
            format!(
                "{}): {} mm/min instead of {}",
                stretch(s.first_line, s.last_line, s.from, s.to),
                plan::num(s.now_mm_min),
                plan::num(s.was_mm_min),
            )
        });
    }
    if !f.still.is_empty() {
        println!(
            "warning: the planner starves in {} (the serial line at {} baud brings the lines \
             slower than the feed uses them; the head stutters there; included in the time \
             above):",
            places(f.still.len()),
            f.baud,
        );
        print_places(&f.still, starve_line);
    }
}

/// `stencil gcode STENCIL_DIR_OR_SVG -o job.gcode`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "\
Examples:
  stencil gcode out/rings -o rings.gcode --machine diode-400
  stencil gcode drawing.svg --power 80 --speed 600 --passes 2 --cut-outline --offset 10,10
From a folder written by `stencil make`, reads stencil.svg and the material named in report.json.")]
pub struct GcodeArgs {
    /// A `stencil make` output folder (uses its stencil.svg and report.json) or an SVG file.
    pub input: PathBuf,
    /// The G-code file to write [default: stencil.gcode in the folder, or the SVG's name with .gcode].
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Material profile (name or .toml path) for power, speed and passes; default: the one recorded
    /// in report.json.
    #[arg(long, value_name = "NAME|FILE")]
    pub material: Option<String>,
    #[command(flatten)]
    pub cut: CutArgs,
    #[command(flatten)]
    pub machine: MachineArgs,
}

/// The G-code part of `make`: `Some` with `--emit gcode`; machine or cut options without it are a
/// mistake worth saying (the user expects a G-code file). Arcs are fitted within
/// `tolerance_mm`, the outline's own tolerance.
pub fn make_gcode_config(
    m: &MachineArgs,
    cut: &CutArgs,
    material: &Material,
    emit: bool,
    tolerance_mm: f64,
) -> anyhow::Result<Option<GcodeConfig>> {
    if !emit {
        if m.machine.is_some() || m.origin.is_some() || m.cut_outline || m.no_arcs || cut.any() {
            bail!(
                "machine and cut options only apply to G-code: add gcode to --emit \
                 (e.g. --emit png,svg,gcode)"
            );
        }
        return Ok(None);
    }
    let machine = m.machine()?;
    let (settings, settings_from) = chosen_settings(cut, Some(material), &machine)?;
    Ok(Some(GcodeConfig {
        plan: m.plan_config(settings, tolerance_mm),
        machine,
        settings_from,
    }))
}

/// The job's cut settings and where they came from: the flags over what the person kept for
/// this material and machine (`stencil profiles set`) or the material's entry for the machine's
/// kind. A material with no settings for this machine is refused (before anything is written)
/// unless the flags give them (--power and --speed for a laser, --speed otherwise).
pub fn chosen_settings(
    cut: &CutArgs,
    material: Option<&Material>,
    machine: &Machine,
) -> anyhow::Result<(CutSettings, String)> {
    let laser = matches!(machine.tool, Tool::Laser { .. });
    let flags_give = cut.speed.is_some() && (!laser || cut.power.is_some());
    let chosen = match (material, cut.covers_all(machine)) {
        (Some(m), false) => {
            let user = stencil_core::material::UserSettings::load()?;
            match stencil_core::material::choose(m, machine, &user) {
                Ok(c) => Some(c),
                Err(stencil_core::material::SettingsError::NoSettings { .. }) if flags_give => None,
                Err(e) => return Err(e.into()),
            }
        }
        _ => None,
    };
    let from = match &chosen {
        Some(c) if cut.any() => format!("{}, with command-line overrides", c.from),
        Some(c) => c.from.clone(),
        None => "the command line (--power/--speed/--passes)".into(),
    };
    let settings = cut.settings(chosen.map(|c| c.settings), machine)?;
    Ok((settings, from))
}

pub fn run_gcode(a: GcodeArgs) -> anyhow::Result<ExitCode> {
    // A half-finished `make` of the folder (or of the set a layer's folder is in) is settled
    // before anything in it is looked at.
    super::program::settle(&a.input)?;
    // A layered folder: a job in each layer's folder (and the fill-in's).
    if a.input.is_dir()
        && a.out.is_some()
        && stencil_core::tiles::stencil_folders(&a.input).len() > 1
    {
        bail!(
            "{}: a folder of several stencils gets one job in each stencil's folder; leave out -o",
            a.input.display()
        );
    }
    if let Some(r) = super::layers::each_stencil(&a.input, |f| {
        gcode_one(GcodeArgs {
            input: f,
            ..a.clone()
        })
    }) {
        return r;
    }
    gcode_one(a)
}

/// A job's input, read by `gcode` and `hpgl` alike: the drawing's cut loops (offset for the
/// material's kerf) and the material, from a stencil folder (its stencil.svg and report.json) or
/// an SVG file.
pub(super) struct JobInput {
    /// The SVG read.
    pub svg_path: PathBuf,
    /// The cut loops.
    pub geom: stencil_gcode::CutLoops,
    /// The material, when named or recorded.
    pub material: Option<Material>,
}

/// Where a job read from `input` goes by default: `name` in the folder, or the SVG's name with
/// `ext`.
pub(super) fn default_job_path(input: &Path, name: &str, ext: &str) -> PathBuf {
    if input.is_dir() {
        input.join(name)
    } else {
        input.with_extension(ext)
    }
}

/// Read a job's input (see [`JobInput`]) for writing `out`. `machine` loads the machine (after
/// the drawing is read) and says whether it is a laser (which needs --power without a material).
pub(super) fn read_job_input(
    input: &Path,
    out: &Path,
    material_arg: &Option<String>,
    machine_arg: &Option<String>,
    cut: &CutArgs,
    machine: &mut dyn FnMut() -> anyhow::Result<bool>,
) -> anyhow::Result<JobInput> {
    let (svg_path, dir) = if input.is_dir() {
        (input.join("stencil.svg"), Some(input.to_path_buf()))
    } else {
        (input.to_path_buf(), None)
    };
    if let Some(d) = &dir {
        super::program::settle(d)?;
    }
    let report_path = dir.as_ref().map(|d| d.join("report.json"));
    let mut inputs = vec![svg_path.as_path()];
    inputs.extend(report_path.as_deref());
    for p in [material_arg, machine_arg].into_iter().flatten() {
        inputs.push(Path::new(p));
    }
    stencil_io::check_output(out, &inputs)?;
    let text = stencil_io::read_text(&svg_path, stencil_io::Kind::Svg).with_context(|| {
        if dir.is_some() {
            format!(
                "{}: cannot read the stencil's SVG; run `stencil make` with SVG output first",
                svg_path.display()
            )
        } else {
            format!("{}: cannot read", svg_path.display())
        }
    })?;
    let drawing = stencil_gcode::read_svg(&text, &svg_path.display().to_string())?;
    for n in &drawing.notes {
        eprintln!("{}: note: {n}", svg_path.display());
    }
    let mut geom = drawing.geometry;
    let laser = machine()?;
    let material = match (material_arg, &dir) {
        (Some(m), _) => Some(Material::find(m)?.0),
        (None, Some(d)) if d.join("report.json").is_file() => {
            let r = super::check::read_report(d)?;
            super::check::material_of_report(&r, d).transpose()?
        }
        // The folder's report names the material; without it and without the settings on the
        // command line, say what is missing rather than only that a material is.
        (None, Some(d)) if cut.speed.is_none() || (laser && cut.power.is_none()) => {
            bail!(
                "{}: missing, so the folder does not say which material the stencil is for (its \
             kerf and cut settings): run `stencil make` again to write it, or name the material \
             (--material NAME) or give the settings (--speed{})",
                d.join("report.json").display(),
                if laser { ", --power" } else { "" }
            )
        }
        (None, _) => None,
    };

    // stencil.svg carries the design line; the tool path is offset by half the material's kerf.
    if let Some(m) = &material {
        geom.apply_kerf(m.kerf_mm)
            .with_context(|| format!("{}: the kerf offset", svg_path.display()))?;
    }
    Ok(JobInput {
        svg_path,
        geom,
        material,
    })
}

/// One stencil folder (or file).
fn gcode_one(a: GcodeArgs) -> anyhow::Result<ExitCode> {
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| default_job_path(&a.input, "stencil.gcode", "gcode"));
    let mut loaded = None;
    let JobInput {
        svg_path,
        geom,
        material,
    } = read_job_input(
        &a.input,
        &out,
        &a.material,
        &a.machine.machine,
        &a.cut,
        &mut || {
            let m = a.machine.machine()?;
            let laser = matches!(m.tool, Tool::Laser { .. });
            loaded = Some(m);
            Ok(laser)
        },
    )?;
    let machine = loaded.context("the machine profile was not loaded")?;
    let (settings, settings_from) = chosen_settings(&a.cut, material.as_ref(), &machine)?;
    let mut notes = vec![format!("from {}", svg_path.display())];
    if let Some(m) = &material {
        notes.push(format!("material {}, kerf {} mm", m.name, m.kerf_mm));
    }
    notes.push(format!("cut settings from {settings_from}"));
    // The drawing's curves were flattened within FLATTEN_TOLERANCE_MM: twice that finds them
    // again as arcs (and joins a polygon's runs of short segments into arcs).
    let cfg = a
        .machine
        .plan_config(settings, 2.0 * stencil_gcode::FLATTEN_TOLERANCE_MM);
    let (gcode, mut summary) = match plan::gcode_for(&geom, &machine, &cfg, &notes) {
        Err(e @ plan::PlanError::OpenPaths { .. }) => {
            bail!("{}: {}", svg_path.display(), super::errors::plan(&e))
        }
        r => r?,
    };
    summary.settings_from = Some(settings_from);
    stencil_io::write_atomic(&out, gcode.as_bytes())?;
    print_summary(&out, &summary);
    Ok(ExitCode::SUCCESS)
}
