//! `stencil gcode`, the machine and cut options `make --emit gcode` shares, the bed check of
//! `send`, `estimate` and `simulate`, and the words a planning error gets on the command line.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;

use stencil_core::material::Material;
use stencil_gcode::format_duration;
use stencil_gcode::machine::{self as machine_profile, Machine, Tool};
use stencil_gcode::{self as plan, Anchor, CutSettings, GcodeConfig, GcodeSummary, PlanConfig};

/// `--offset X,Y`: a place on some bed. Beyond the largest bed a profile may have (10 m), no
/// job can be on the bed, and a number like 1e308 swallowed the job's size in the bed check
/// ("the job (0.0 x 0.0 mm)"), so it is refused here, as the offset it is.
pub(super) fn parse_offset(s: &str) -> Result<[f64; 2], String> {
    let bad = || format!("'{s}' is not an offset: use X,Y in mm, e.g. 10,20");
    let (x, y) = s.split_once(',').ok_or_else(bad)?;
    let x: f64 = x.trim().parse().map_err(|_| bad())?;
    let y: f64 = y.trim().parse().map_err(|_| bad())?;
    if !(x.is_finite() && y.is_finite()) {
        return Err(bad());
    }
    let far = *stencil_gcode::bounds::BED_MM.end();
    if x.abs() > far || y.abs() > far {
        return Err(format!(
            "'{s}' is beyond any machine's bed: X and Y must be within ±{far} mm (the largest bed \
             a machine profile may have)"
        ));
    }
    Ok([x, y])
}

/// Which machine, and where the job goes on its bed.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Machine (G-code)")]
pub struct MachineArgs {
    /// Machine profile: a name (diode-400, co2-600x400, pen-a3, pen-servo, drag-knife) or a path to a
    /// .toml file. Default: diode-400, a generic GRBL 1.1 diode laser with a 400 x 400 mm bed.
    #[arg(long, value_name = "NAME|FILE")]
    pub machine: Option<String>,
    /// The job point placed at --offset: bottom-left, bottom-right, top-left, top-right or center
    /// (as seen from above, rear at the top). Default: the corner at the machine's origin.
    #[arg(long, value_name = "CORNER", value_parser = |s: &str| s.parse::<Anchor>())]
    pub origin: Option<Anchor>,
    /// Where that point is, mm, in the job's coordinates: the machine's when `send`/`frame`
    /// start from machine coordinates; from the work zero or the head's position with
    /// `--start-from work-zero|current` (so 0,0 puts the job's corner right there).
    #[arg(long, value_name = "X,Y", default_value = "0,0", value_parser = parse_offset, allow_hyphen_values = true)]
    pub offset: [f64; 2],
    /// Also cut the sheet's outline (a rectangle), after everything inside it.
    #[arg(long)]
    pub cut_outline: bool,
    /// Cut a drawing's open paths (lines, shapes not closed with Z) with a laser or knife, as
    /// open cuts. A pen draws them anyway; without this a cutting tool refuses them.
    #[arg(long)]
    pub cut_open_paths: bool,
    /// Write straight G1 segments only, no G2/G3 arcs (for a controller or sender without arcs;
    /// a machine profile with `arcs = false` does the same). By default each loop is fitted with
    /// lines and arcs within the outline's tolerance (make: --tolerance-mm; gcode: 0.02 mm, twice
    /// the SVG reader's flattening). With make, the outlines are then made straight within the
    /// whole --tolerance-mm of the traced outline, and the SVG and DXF carry the same polygons,
    /// which are what the width check judged.
    #[arg(long)]
    pub no_arcs: bool,
}

impl MachineArgs {
    pub fn machine(&self) -> anyhow::Result<Machine> {
        Ok(machine_profile::load(self.machine.as_deref())?)
    }

    /// Where and how to cut; loops are written as arcs fitted within `arc_tolerance_mm` unless
    /// `--no-arcs`.
    pub fn plan_config(&self, settings: CutSettings, arc_tolerance_mm: f64) -> PlanConfig {
        PlanConfig {
            anchor: self.origin,
            offset: self.offset,
            cut_outline: self.cut_outline,
            cut_open_paths: self.cut_open_paths,
            settings,
            arc_tolerance_mm: if self.no_arcs { 0.0 } else { arc_tolerance_mm },
        }
    }
}

/// `--power`: as a material's `laser.power_pct`.
fn parse_power(s: &str) -> Result<f64, String> {
    super::number_in(s, 0.1..=100.0, " %")
}

/// `--speed`: what a machine profile's feeds may be (the machine's own max feed is checked when
/// the job is planned).
fn parse_speed(s: &str) -> Result<f64, String> {
    super::number_in(s, stencil_gcode::bounds::FEED_MM_MIN, " mm/min")
}

/// `--blade-offset`: as the planner accepts it.
fn parse_blade_offset(s: &str) -> Result<f64, String> {
    super::number_in(s, 0.0..=plan::bounds::MAX_BLADE_OFFSET_MM, " mm")
}

/// Cut settings given on the command line; each overrides the material's.
#[derive(Args, Debug, Clone, Default)]
#[command(next_help_heading = "Cut settings (override the material)")]
pub struct CutArgs {
    /// Laser power, % of full ($30): 0.1 to 100.
    #[arg(long, value_name = "PCT", value_parser = parse_power)]
    pub power: Option<f64>,
    /// Cutting feed, mm/min: 1 to 200000, and at most the machine's max feed.
    #[arg(long, value_name = "MM_MIN", value_parser = parse_speed)]
    pub speed: Option<f64>,
    /// Times each loop is cut: 1 to 100.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=plan::bounds::MAX_PASSES as i64))]
    pub passes: Option<u32>,
    /// Drag knife: how far the blade tip trails its axis, mm (0 = no corner compensation; at
    /// most 5).
    #[arg(long, value_name = "MM", value_parser = parse_blade_offset)]
    pub blade_offset: Option<f64>,
    /// Laser: air assist (on Grbl's coolant output) on with the beam, M8 before the first cut and
    /// M9 at the end: on or off [default: the material's air_assist, else the machine's].
    #[arg(long, value_name = "on|off", value_parser = clap::builder::BoolishValueParser::new())]
    pub air_assist: Option<bool>,
}

impl CutArgs {
    /// Whether the flags alone give every setting the tool uses (then no material is needed).
    pub fn covers_all(&self, machine: &Machine) -> bool {
        let laser = matches!(machine.tool, Tool::Laser { .. });
        self.speed.is_some() && self.passes.is_some() && (!laser || self.power.is_some())
    }

    /// Apply the overrides to `base` (from the material), or build settings from the flags alone
    /// (power only matters to a laser).
    pub fn settings(
        &self,
        base: Option<CutSettings>,
        machine: &Machine,
    ) -> anyhow::Result<CutSettings> {
        let laser = matches!(machine.tool, Tool::Laser { .. });
        let s = match base {
            Some(b) => CutSettings {
                power_pct: self.power.unwrap_or(b.power_pct),
                speed_mm_min: self.speed.unwrap_or(b.speed_mm_min),
                passes: self.passes.unwrap_or(b.passes),
                blade_offset_mm: self.blade_offset.unwrap_or(b.blade_offset_mm),
                air_assist: self.air_assist.unwrap_or(b.air_assist),
            },
            None => {
                let (power, Some(speed)) = (self.power.or((!laser).then_some(100.0)), self.speed)
                else {
                    bail!(
                        "no cut settings: name a material (--material) or give --speed MM_MIN{}",
                        if laser { " and --power PCT" } else { "" }
                    );
                };
                let Some(power) = power else {
                    bail!("no laser power: name a material (--material) or give --power PCT");
                };
                CutSettings {
                    power_pct: power,
                    speed_mm_min: speed,
                    passes: self.passes.unwrap_or(1),
                    blade_offset_mm: self.blade_offset.unwrap_or(0.0),
                    air_assist: self.air_assist.unwrap_or(laser && machine.air_assist),
                }
            }
        };
        Ok(s)
    }
}

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

impl CutArgs {
    fn any(&self) -> bool {
        self.power.is_some()
            || self.speed.is_some()
            || self.passes.is_some()
            || self.blade_offset.is_some()
            || self.air_assist.is_some()
    }
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
    super::send::settle(&a.input)?;
    // A layered folder: a job in each layer's folder (and the fill-in's).
    if a.input.is_dir()
        && a.out.is_some()
        && stencil_core::layers::stencil_folders(&a.input).len() > 1
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

/// One stencil folder (or file).
fn gcode_one(a: GcodeArgs) -> anyhow::Result<ExitCode> {
    let (svg_path, dir) = if a.input.is_dir() {
        (a.input.join("stencil.svg"), Some(a.input.clone()))
    } else {
        (a.input.clone(), None)
    };
    if let Some(d) = &dir {
        super::send::settle(d)?;
    }
    let out = a.out.clone().unwrap_or_else(|| match &dir {
        Some(d) => d.join("stencil.gcode"),
        None => svg_path.with_extension("gcode"),
    });
    let report_path = dir.as_ref().map(|d| d.join("report.json"));
    let mut inputs = vec![svg_path.as_path()];
    inputs.extend(report_path.as_deref());
    for p in [&a.material, &a.machine.machine].into_iter().flatten() {
        inputs.push(Path::new(p));
    }
    stencil_io::check_output(&out, &inputs)?;
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
    let machine = a.machine.machine()?;
    let material = match (&a.material, &dir) {
        (Some(m), _) => Some(Material::find(m)?.0),
        (None, Some(d)) if d.join("report.json").is_file() => {
            let r = super::check::read_report(d)?;
            super::check::material_of_report(&r, d).transpose()?
        }
        // The folder's report names the material; without it and without the settings on the
        // command line, say what is missing rather than only that a material is.
        (None, Some(d))
            if a.cut.speed.is_none()
                || (matches!(machine.tool, Tool::Laser { .. }) && a.cut.power.is_none()) =>
        {
            bail!(
                "{}: missing, so the folder does not say which material the stencil is for (its \
             kerf and cut settings): run `stencil make` again to write it, or name the material \
             (--material NAME) or give the settings (--speed{})",
                d.join("report.json").display(),
                if matches!(machine.tool, Tool::Laser { .. }) {
                    ", --power"
                } else {
                    ""
                }
            )
        }
        (None, _) => None,
    };

    // stencil.svg carries the design line; the tool path is offset by half the material's kerf.
    if let Some(m) = &material {
        geom.apply_kerf(m.kerf_mm)
            .with_context(|| format!("{}: the kerf offset", svg_path.display()))?;
    }
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
