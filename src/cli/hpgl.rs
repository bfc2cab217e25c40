//! `stencil hpgl`, and the HP-GL part of `make --emit hpgl`: plotter cutters and pen plotters.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;

use stencil_core::material::{Material, Process};
use stencil_gcode::format_duration;
use stencil_hpgl::profile::{self as plotter_profile, Plotter};
use stencil_hpgl::{HpglConfig, HpglSummary};

use super::gcode::{chosen_settings, default_job_path, read_job_input, JobInput};
use super::machine_args::{CutArgs, MachineArgs};

/// The plotter options besides the machine's: the blade force and the pen.
#[derive(Args, Debug, Clone, Default)]
#[command(next_help_heading = "Plotter (HP-GL)")]
pub struct PlotterArgs {
    /// Blade force, grams, written as FS in the plotter's units [default: the material's
    /// force_g]: 1 to 2000.
    #[arg(long, value_name = "G", value_parser = |s: &str| super::bounds::number_in(s, 1.0..=2000.0, " g"))]
    pub force: Option<f64>,
    /// The pen (tool holder) to select with SP: 1 to the plotter's pen count [default: 1].
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub pen: u32,
    /// Cut a weeding box around the job, MM outside its cuts [default: 5], last: the sheet
    /// around it then lifts away in one piece. 0.5 to 100.
    #[arg(long, value_name = "MM", num_args = 0..=1, default_missing_value = "5",
          value_parser = |s: &str| super::bounds::number_in(s, 0.5..=100.0, " mm"))]
    pub weed_box: Option<f64>,
    /// Cut weeding lines MM apart [default: 40] across every cut-out area wider or taller than
    /// that, so a large hole's waste lifts out in pieces. Only ever inside a hole, never across
    /// the stencil. 5 to 1000.
    #[arg(long, value_name = "MM", num_args = 0..=1, default_missing_value = "40",
          value_parser = |s: &str| super::bounds::number_in(s, 5.0..=1000.0, " mm"))]
    pub weed_lines: Option<f64>,
}

impl PlotterArgs {
    /// The weeding aids asked for.
    fn weeding(&self) -> stencil_hpgl::weed::Weeding {
        stencil_hpgl::weed::Weeding {
            box_margin_mm: self.weed_box,
            line_spacing_mm: self.weed_lines,
        }
    }
}

/// `stencil hpgl STENCIL_DIR_OR_SVG -o job.plt`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "\
Examples:
  stencil hpgl out/rings -o rings.plt --machine vinyl-hpgl
  stencil hpgl drawing.svg --machine roland-camm --speed 1200 --force 90
From a folder written by `stencil make`, reads stencil.svg and the material named in report.json.
Plotters: vinyl-hpgl, roland-camm, graphtec-hpgl, hp7475a (`stencil profiles` lists them).")]
pub struct HpglArgs {
    /// A `stencil make` output folder (uses its stencil.svg and report.json) or an SVG file.
    pub input: PathBuf,
    /// The HP-GL file to write [default: stencil.plt in the folder, or the SVG's name with .plt].
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Material profile (name or .toml path) for speed, passes, blade offset and force; default:
    /// the one recorded in report.json.
    #[arg(long, value_name = "NAME|FILE")]
    pub material: Option<String>,
    #[command(flatten)]
    pub cut: CutArgs,
    #[command(flatten)]
    pub machine: MachineArgs,
    #[command(flatten)]
    pub plotter: PlotterArgs,
}

/// The plotter `--machine` names: an HP-GL profile, or an error saying what a G-code machine is
/// for.
pub fn plotter(m: &MachineArgs) -> anyhow::Result<Plotter> {
    let Some(name) = m.machine.as_deref() else {
        bail!(
            "HP-GL needs a plotter: name one with --machine (vinyl-hpgl, roland-camm, \
             graphtec-hpgl, hp7475a; `stencil profiles` lists them)"
        );
    };
    if !plotter_profile::is_plotter(name) && stencil_gcode::machine::load(Some(name)).is_ok() {
        bail!(
            "--machine {name} is a GRBL machine, which takes G-code (--emit gcode, `stencil \
             gcode`); HP-GL is for a plotter (vinyl-hpgl, roland-camm, graphtec-hpgl, hp7475a)"
        );
    }
    Ok(plotter_profile::load(name)?)
}

/// The blade force: the flag, else the material's knife force.
fn force_g(p: &PlotterArgs, material: Option<&Material>) -> Option<f64> {
    p.force.or(material.and_then(|m| match &m.process {
        Process::Knife(k) => Some(k.force_g),
        _ => None,
    }))
}

/// The HP-GL part of `make`: `Some` with `--emit hpgl`.
pub fn make_hpgl_config(
    m: &MachineArgs,
    cut: &CutArgs,
    p: &PlotterArgs,
    material: &Material,
    emit: bool,
) -> anyhow::Result<Option<HpglConfig>> {
    if !emit {
        if p.force.is_some() || p.pen != 1 || p.weed_box.is_some() || p.weed_lines.is_some() {
            bail!(
                "--force, --pen, --weed-box and --weed-lines only apply to HP-GL: add hpgl to \
                 --emit (e.g. --emit png,hpgl)"
            );
        }
        return Ok(None);
    }
    let plotter = plotter(m)?;
    let machine = plotter.planner_machine();
    let (settings, settings_from) = chosen_settings(cut, Some(material), &machine)?;
    Ok(Some(HpglConfig {
        plan: m.plan_config(settings, 0.0),
        force_g: force_g(p, Some(material)),
        pen: p.pen,
        plotter,
        settings_from,
        weeding: p.weeding(),
    }))
}

/// Print what a job costs (shared by `make --emit hpgl` and `hpgl`).
pub fn print_summary(path: &Path, s: &HpglSummary) {
    let e = &s.estimate;
    println!(
        "{}: {} ({} {}), {} loops{}; cut {:.0} mm, travel {:.0} mm (input order {:.0} mm); \
         {} instructions; about {} on the virtual cutter (cut {}, travel {}){}",
        path.display(),
        s.plotter,
        s.dialect,
        s.tool,
        s.path.loops,
        match s.path.lines {
            0 => String::new(),
            n => format!(" and {n} open paths"),
        },
        s.path.cut_mm,
        s.path.travel_mm,
        s.path.naive_travel_mm,
        s.commands,
        format_duration(e.total_s),
        format_duration(e.cut_s),
        format_duration(e.travel_s),
        if s.rotated {
            "; turned a quarter turn so its long side runs with the media feed"
        } else {
            ""
        },
    );
    if s.weed_lines > 0 || s.weed_box {
        println!(
            "weeding: {} line(s) inside cut-out areas{}",
            s.weed_lines,
            if s.weed_box {
                ", a box around the job"
            } else {
                ""
            }
        );
    }
    if let Some(c) = &s.settings {
        println!(
            "cut settings: {} mm/s, {} pass{}, blade offset {} mm{}{}",
            stencil_gcode::num(c.speed_mm_min / 60.0),
            c.passes,
            if c.passes == 1 { "" } else { "es" },
            stencil_gcode::num(c.blade_offset_mm),
            s.force.map(|f| format!(", FS{f}")).unwrap_or_default(),
            s.settings_from
                .as_deref()
                .map(|f| format!("; from {f}"))
                .unwrap_or_default()
        );
    }
}

pub fn run_hpgl(a: HpglArgs) -> anyhow::Result<ExitCode> {
    super::program::settle(&a.input)?;
    if let Some(r) = super::layers::each_stencil(&a.input, |f| {
        if a.out.is_some() {
            bail!(
                "{}: a folder of several stencils gets one job in each stencil's folder; leave out -o",
                a.input.display()
            );
        }
        hpgl_one(HpglArgs {
            input: f,
            ..a.clone()
        })
    }) {
        return r;
    }
    hpgl_one(a)
}

fn hpgl_one(a: HpglArgs) -> anyhow::Result<ExitCode> {
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| default_job_path(&a.input, "stencil.plt", "plt"));
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
            loaded = Some(plotter(&a.machine)?);
            Ok(false)
        },
    )?;
    let plotter = loaded.context("the plotter profile was not loaded")?;
    let machine = plotter.planner_machine();
    let (settings, settings_from) = chosen_settings(&a.cut, material.as_ref(), &machine)?;
    let cfg = HpglConfig {
        plan: a.machine.plan_config(settings, 0.0),
        force_g: force_g(&a.plotter, material.as_ref()),
        pen: a.plotter.pen,
        plotter,
        settings_from,
        weeding: a.plotter.weeding(),
    };
    let (text, summary) = match stencil_hpgl::hpgl_for(&geom, &cfg) {
        Err(stencil_hpgl::HpglError::Plan(e)) => {
            bail!("{}: {}", svg_path.display(), super::errors::plan(&e))
        }
        r => r?,
    };
    stencil_io::write_atomic(&out, text.as_bytes())?;
    print_summary(&out, &summary);
    Ok(ExitCode::SUCCESS)
}
