//! Size, material, vector and export options of `stencil make`, and the `stencil profiles`
//! command.

use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::{Args, Subcommand, ValueEnum};

use stencil_core::export::MaskConfig;
use stencil_core::material::DEFAULT_MATERIAL;
use stencil_core::material::{has_settings, Kept, Material, Process, UserSettings};
use stencil_core::pipeline::{Emit, PhysicalConfig, Size};
use stencil_core::vector::VectorConfig;
use stencil_gcode::machine::Tool;

/// A file kind for `--emit`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EmitKind {
    /// twotone.png, stencil.png and preview.png.
    Png,
    /// stencil.svg (mm, layers OUTLINE, CUT, BRIDGES).
    Svg,
    /// stencil.dxf (R2000 LWPOLYLINE, or R12 with --dxf-r12).
    Dxf,
    /// mask.png (1-bit) and mask.svg for photo-etch.
    Mask,
    /// stencil.gcode for the --machine (GRBL 1.1 laser, pen or knife), with a time estimate.
    Gcode,
    /// stencil.plt in HP-GL for the --machine (a plotter cutter or pen plotter), with the
    /// virtual cutter's time.
    Hpgl,
}

/// Physical size and material, and how far the stencil may stray from them.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Size and material")]
pub struct PhysicalArgs {
    /// Width of the picture on the sheet in mm (the height follows). Without it and without
    /// --dpi, one pixel of the picture is 0.1 mm (whatever --scale does to the working pixels).
    /// The picture may be at most 10 m (10000 mm) on its longer side, with pixels of at least
    /// 0.001 mm; with the default clean-up, the material's smallest feature may be at most 50
    /// working pixels wide (so at most 0.01 mm pixels for cardstock).
    #[arg(long, conflicts_with = "dpi", value_parser = super::bounds::positive)]
    pub width_mm: Option<f64>,
    /// Pixels of the picture per inch (instead of --width-mm); at most 25400 (0.001 mm pixels),
    /// and low enough that the picture is at most 10 m on its longer side.
    #[arg(long, value_parser = super::bounds::positive)]
    pub dpi: Option<f64>,
    /// Fit the picture to a sheet of stock you cut from (card, vinyl): A4, A3, LETTER or WxH in
    /// mm (e.g. 300x200). Without --width-mm/--dpi the picture is made as large as the sheet
    /// allows inside --margin-mm (the sheet turned a quarter turn if that is larger); with them,
    /// a picture too large for the sheet is refused before any work.
    #[arg(long, value_name = "A4|A3|LETTER|WxH", value_parser = stencil_core::fit::sheet)]
    pub sheet: Option<stencil_core::fit::Stock>,
    /// Make a gobo: a round sheet for a lighting fixture's gate. A letter size from Rosco's table
    /// (A 100 / 75, B 86 / 64.5, M 66 / 48, E 37.5 / 28 mm outside diameter / image area) or
    /// OD,IA in mm for any other (e.g. 53.3,38). The picture is inscribed in the image area
    /// (--gobo-crop fills it instead, metal outside its circle) and the rim is cut: a circle on
    /// the OUTLINE layer of the SVG and DXF, the last loop of the G-code, a groove in the masks.
    /// Light passes where the stencil is cut: a bright subject on a dark ground usually wants
    /// --invert (make warns when most of the image area would pass light).
    #[arg(long, value_name = "A|B|M|E|OD,IA", conflicts_with_all = ["width_mm", "dpi", "sheet"], value_parser = stencil_core::gobo::parse)]
    pub gobo: Option<stencil_core::gobo::Gobo>,
    /// With --gobo: fill the image area with the picture (its shorter side as wide as the image
    /// area) and leave metal outside the image area's circle, instead of fitting the whole
    /// picture inside it.
    #[arg(long, requires = "gobo")]
    pub gobo_crop: bool,
    /// Material profile: a shipped name (see `stencil profiles`), a name in
    /// ./profiles/materials/, or a path to a .toml file. Its minimum bridge and feature widths
    /// drive the bridges, the filter and the check. [default: cardstock; with --emit gcode, one
    /// set up for the machine's tool: cardstock for a laser, cardstock-knife for a drag knife,
    /// plotter-paper for a pen]
    #[arg(long, value_name = "NAME|FILE")]
    pub material: Option<String>,
    /// Largest distance (mm) simplification may move an outline: 0 (off) or 0.001 to 10.
    #[arg(long, default_value_t = 0.05, value_parser = super::bounds::tolerance_mm)]
    pub tolerance_mm: f64,
    /// Sheet left around the picture on every side, in mm (the sheet continues beyond the
    /// picture): 0.001 to 1000. It counts against a machine's bed or a --sheet only where
    /// something is cut or marked there (--cut-outline, --mask-marks, a --sheet's edge).
    #[arg(long, default_value_t = 5.0, value_parser = super::bounds::margin_mm)]
    pub margin_mm: f64,
    /// Write the outputs even if bridges, webs or holes are thinner than the material allows
    /// (the violations are still listed in report.json).
    #[arg(long)]
    pub allow_thin: bool,
    /// Fail, writing nothing, if the clean-up and the bridges change more than PCT % of the
    /// picture's pixels (the `changed` figure `make` prints; 0..100).
    #[arg(long, value_name = "PCT", value_parser = parse_percent)]
    pub max_change: Option<f64>,
}

/// The files `make` writes, and the photo-etch mask's form. A heading of their own after the
/// bridges, so `make --help` reads from the common options to the rare ones (issue 25 item 8).
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Outputs")]
pub struct OutputArgs {
    /// Files to write, comma separated (report.json is always written).
    #[arg(long, value_enum, value_delimiter = ',', default_value = "png,svg")]
    pub emit: Vec<EmitKind>,
    /// Write DXF R12 (POLYLINE/VERTEX/SEQEND) instead of R2000 LWPOLYLINEs, for old software.
    #[arg(long)]
    pub dxf_r12: bool,
    /// Resolution of mask.png in dots per inch: 25.4 to 25400.
    #[arg(long, default_value_t = 1200.0, value_parser = super::bounds::mask_dpi)]
    pub mask_dpi: f64,
    /// Mask polarity: clear where metal stays (negative-acting resist) instead of black.
    #[arg(long)]
    pub mask_invert: bool,
    /// Mirror the mask left-right (film emulsion side down). Etch profiles with `mirror = true`
    /// mirror it anyway.
    #[arg(long)]
    pub mask_mirror: bool,
    /// Add registration marks in the corners of the margin.
    #[arg(long)]
    pub mask_marks: bool,
}

fn parse_percent(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(p) if p.is_finite() && (0.0..=100.0).contains(&p) => Ok(p),
        _ => Err(format!(
            "'{s}' is not a percentage: use a number from 0 to 100"
        )),
    }
}

pub(super) fn size(width_mm: Option<f64>, dpi: Option<f64>) -> Size {
    match (width_mm, dpi) {
        (Some(w), _) => Size::WidthMm(w),
        (None, Some(d)) => Size::Dpi(d),
        _ => Size::Default,
    }
}

impl PhysicalArgs {
    /// The configuration, with the outputs `out` and `default_material` when --material is not
    /// given.
    pub fn to_config(
        &self,
        out: &OutputArgs,
        default_material: &str,
    ) -> anyhow::Result<PhysicalConfig> {
        // A named material is looked up (a path, ./profiles/materials/, shipped); without one the
        // shipped default, so the output does not depend on the folder the run starts in.
        let (material, source) = match self.material.as_deref() {
            Some(name) => Material::find(name)?,
            None => Material::find_default(default_material)?,
        };
        let has = |k: EmitKind| out.emit.contains(&k);
        Ok(PhysicalConfig {
            size: size(self.width_mm, self.dpi),
            material,
            material_source: source.display().to_string(),
            vector: VectorConfig {
                tolerance_mm: self.tolerance_mm,
                margin_mm: self.margin_mm,
                ..Default::default()
            },
            allow_thin: self.allow_thin,
            max_change_pct: self.max_change,
            emit: Emit {
                png: has(EmitKind::Png),
                svg: has(EmitKind::Svg),
                dxf: has(EmitKind::Dxf),
                mask: has(EmitKind::Mask),
            },
            mask: MaskConfig {
                dpi: out.mask_dpi,
                invert: out.mask_invert,
                mirror: out.mask_mirror,
                marks: out.mask_marks,
                // Set by `make` from --invert.
                tone_inverted: false,
            },
            dxf_r12: out.dxf_r12,
            gobo: self.gobo.clone().map(|g| stencil_core::gobo::Gobo {
                crop: self.gobo_crop,
                ..g
            }),
        })
    }
}

/// `stencil profiles`: list them, or keep cut settings (`set`).
#[derive(Args, Debug)]
#[command(after_help = "\
Without a subcommand: the machines (with their kind: a laser's source and power), the materials, \
and which materials have cut settings for which machine (from the material's profile, or kept \
with `profiles set`).")]
pub struct ProfilesArgs {
    #[command(subcommand)]
    pub action: Option<ProfilesAction>,
}

#[derive(Subcommand, Debug)]
pub enum ProfilesAction {
    /// Keep cut settings for a material on a machine (what `stencil test-grid` taught you): later
    /// jobs for that material and machine use them instead of the material profile's. Written to
    /// cut-settings.toml in your config folder ($STENCIL_CONFIG_DIR, else $XDG_CONFIG_HOME/stencil
    /// or ~/.config/stencil; %APPDATA%\stencil on Windows).
    Set(SetArgs),
}

/// `stencil profiles set MATERIAL --machine M --power P --speed S`.
#[derive(Args, Debug)]
#[command(
    after_help = "Example: stencil profiles set cardstock --machine diode-400 --power 80 \
--speed 900 --passes 2"
)]
pub struct SetArgs {
    /// The material profile (a name or a .toml path); the settings are kept under its name.
    pub material: String,
    /// The machine profile (a name or a .toml path); the settings are kept under its name.
    #[arg(long, value_name = "NAME|FILE")]
    pub machine: String,
    /// Laser power, % of full ($30): 0.1 to 100 (lasers only).
    #[arg(long, value_name = "PCT", value_parser = |s: &str| super::bounds::number_in(s, 0.1..=100.0, " %"))]
    pub power: Option<f64>,
    /// Cutting feed, mm/min: 1 to 100000, and at most the machine's max feed.
    #[arg(long, value_name = "MM_MIN", value_parser = |s: &str| super::bounds::number_in(s, 1.0..=100_000.0, " mm/min"))]
    pub speed: f64,
    /// Times each loop is cut: 1 to 50.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=50))]
    pub passes: u32,
}

pub fn run_profiles(a: ProfilesArgs) -> anyhow::Result<ExitCode> {
    match a.action {
        Some(ProfilesAction::Set(s)) => run_set(s),
        None => list_profiles(),
    }
}

/// How long `profiles set` waits for another run that is changing the kept settings (each holds
/// the lock for one read and write of a small file).
const SETTINGS_LOCK_WAIT: std::time::Duration = std::time::Duration::from_secs(30);

/// Check the settings against the material and the machine, then write them (replacing any kept
/// for the same pair).
fn run_set(a: SetArgs) -> anyhow::Result<ExitCode> {
    let (material, _) = Material::find(&a.material)?;
    let machine = stencil_gcode::machine::load(Some(&a.machine))?;
    let laser = matches!(machine.tool, Tool::Laser { .. });
    match (&material.process, laser, a.power) {
        (Process::Etch(_), _, _) => {
            return Err(stencil_core::material::SettingsError::EtchOnly {
                material: material.name.clone(),
            }
            .into())
        }
        (p, _, _) if p.kind().to_string() != machine.tool.kind() => {
            return Err(stencil_core::material::SettingsError::WrongTool {
                material: material.name.clone(),
                process: p.kind(),
                machine: machine.name.clone(),
                tool: machine.tool.kind(),
                suggested: stencil_core::material::default_for(&machine.tool),
            }
            .into())
        }
        (_, true, None) => bail!("--power PCT is needed for a laser ('{}')", machine.name),
        (_, false, Some(_)) => bail!(
            "--power: '{}' has a {}, which has no power; keep --speed and --passes",
            machine.name,
            machine.tool.kind()
        ),
        _ => {}
    }
    if a.speed > machine.motion.max_feed_mm_min {
        bail!(
            "--speed {} mm/min is above the max feed of '{}' ({} mm/min, motion.max_feed_mm_min)",
            a.speed,
            machine.name,
            machine.motion.max_feed_mm_min
        );
    }
    let Some(dir) = stencil_io::profile::config_dir() else {
        bail!(
            "no config folder to keep settings in: set HOME, XDG_CONFIG_HOME or {}",
            stencil_io::profile::CONFIG_DIR_ENV
        );
    };
    std::fs::create_dir_all(&dir)
        .with_context(|| format!("{}: cannot create the config folder", dir.display()))?;
    // Read, change and write the file under the config folder's lock: concurrent `profiles set`s
    // (a script keeping several pairs at once) each keep their pair instead of writing over
    // each other's from the same old file.
    let _lock = stencil_io::lock_folder(&dir, SETTINGS_LOCK_WAIT).map_err(|e| match e {
        stencil_io::WriteError::Busy { path } => anyhow::anyhow!(
            "{}: another stencil run has been changing the kept settings for {} s; nothing was \
             kept (run this again when it is done)",
            path.display(),
            SETTINGS_LOCK_WAIT.as_secs()
        ),
        e => e.into(),
    })?;
    let mut user = UserSettings::load_from(&dir)?;
    let kept = Kept {
        material: material.name.clone(),
        machine: machine.name.clone(),
        power_pct: a.power,
        speed_mm_min: a.speed,
        passes: a.passes,
    };
    let replaced = user.find(&kept.material, &kept.machine).cloned();
    user.set(kept);
    let path = dir.join(stencil_core::material::USER_SETTINGS_FILE);
    let header = "# Cut settings kept with `stencil profiles set MATERIAL --machine M --power P \
                  --speed S`,\n# per material and machine profile; they win over the material \
                  profile's settings.\n";
    stencil_io::write_atomic(&path, user.to_toml(header).as_bytes())?;
    println!(
        "kept for {} on {}: {}{} mm/min, {} pass{} in {}{}",
        material.name,
        machine.name,
        a.power
            .map(|p| format!("{p} % power, "))
            .unwrap_or_default(),
        a.speed,
        a.passes,
        if a.passes == 1 { "" } else { "es" },
        path.display(),
        if replaced.is_some() {
            " (replacing the ones kept before)"
        } else {
            ""
        }
    );
    println!(
        "`stencil make PICTURE --material {} --machine {} --emit gcode` now uses them",
        material.name, machine.name
    );
    Ok(ExitCode::SUCCESS)
}

/// A material's settings in one column: per kind of laser, or the knife's or pen's.
fn settings_text(m: &Material) -> String {
    match &m.process {
        Process::Laser(l) => {
            l.on.iter()
                .map(|c| {
                    format!(
                        "{}: {}% {} mm/min x{}",
                        stencil_core::material::cut_kind(c).replace(" laser", ""),
                        c.power_pct,
                        c.speed_mm_min,
                        c.passes
                    )
                })
                .collect::<Vec<_>>()
                .join("; ")
        }
        Process::Knife(k) => format!("{} g {} mm/s x{}", k.force_g, k.speed_mm_s, k.passes),
        Process::Pen(p) => format!("{} mm/min, {} mm pen", p.speed_mm_min, p.pen_width_mm),
        Process::Etch(e) => format!(
            "etch factor {}{}{}",
            e.etch_factor,
            if e.mirror { ", mirror" } else { "" },
            if e.two_sided { ", two-sided" } else { "" }
        ),
    }
}

/// The HP-GL plotters (`make --emit hpgl`, `stencil hpgl`): area, dialect, tool, serial line.
fn list_plotters() {
    println!();
    println!(
        "{:<20} {:>15}  {:<9} {:<6} serial (HP-GL: make --emit hpgl, stencil hpgl, send)",
        "plotter", "area", "dialect", "tool"
    );
    let names = stencil_io::profile::known_names("machines", stencil_hpgl::profile::SHIPPED);
    for name in names
        .into_iter()
        .filter(|n| stencil_hpgl::profile::is_plotter(n))
    {
        match stencil_hpgl::profile::load(&name) {
            Ok(p) => println!(
                "{:<20} {:>15}  {:<9} {:<6} {} baud, {}, {}-byte buffer{}",
                p.name,
                format!("{} x {} mm", p.bed.width_mm, p.bed.height_mm),
                p.dialect.name(),
                match p.tool {
                    stencil_hpgl::profile::ToolKind::Knife => "knife",
                    stencil_hpgl::profile::ToolKind::Pen => "pen",
                },
                p.serial.baud,
                p.serial.flow.name(),
                p.serial.buffer_bytes,
                if p.roll { ", roll-fed along X" } else { "" }
            ),
            Err(e) => println!("{name:<20} error: {e}"),
        }
    }
}

fn list_profiles() -> anyhow::Result<ExitCode> {
    let user = UserSettings::load()?;
    let mut machines = Vec::new();
    // The kind comes last: a machine row's second word is its bed, never a process name, so a
    // script that picks material rows by their second column (`laser`, `pen`, ...) as
    // `../shared/tools/corpus.py` does cannot take `pen-a3` for a material.
    println!("{:<20} {:>13}  {:<12} kind", "machine", "bed", "origin");
    for name in stencil_io::profile::known_names("machines", stencil_gcode::machine::SHIPPED)
        .into_iter()
        .filter(|n| !stencil_hpgl::profile::is_plotter(n))
    {
        match stencil_gcode::machine::load(Some(&name)) {
            Ok(m) => {
                println!(
                    "{:<20} {:>13}  {:<12} {}",
                    m.name,
                    format!("{} x {} mm", m.bed.width_mm, m.bed.height_mm),
                    m.bed.origin.name(),
                    m.kind()
                );
                machines.push(m);
            }
            Err(e) => println!("{name:<20} error: {e}"),
        }
    }
    println!();
    println!(
        "{:<20} {:<6} {:>8} {:>10} {:>11} {:>7}  settings",
        "material", "process", "thick", "bridge>=", "feature>=", "kerf"
    );
    let mut materials = Vec::new();
    for name in stencil_io::profile::known_names("materials", stencil_core::material::SHIPPED) {
        match Material::find(&name) {
            Ok((m, src)) => {
                println!(
                    "{:<20} {:<6} {:>5} mm {:>7} mm {:>8} mm {:>4} mm  {}  [{}]",
                    m.name,
                    m.process.kind(),
                    m.thickness_mm,
                    m.min_bridge_mm,
                    m.min_feature_mm,
                    m.kerf_mm,
                    settings_text(&m),
                    src.display()
                );
                materials.push(m);
            }
            Err(e) => println!("{name:<20} error: {e}"),
        }
    }
    println!();
    // Which material cuts on which machine: "yes" from its profile, "kept" from the user's file.
    let width = machines
        .iter()
        .map(|m| m.name.len())
        .max()
        .unwrap_or(4)
        .max(4);
    print!("{:<20}", "cut settings for");
    for m in &machines {
        print!(" {:>width$}", m.name);
    }
    println!();
    let none = UserSettings::default();
    for mat in materials.iter().filter(|m| m.etch().is_none()) {
        print!("{:<20}", mat.name);
        for m in &machines {
            let mark = if user.find(&mat.name, &m.name).is_some() && has_settings(mat, m, &user) {
                "kept"
            } else if has_settings(mat, m, &none) {
                "yes"
            } else {
                "-"
            };
            print!(" {mark:>width$}");
        }
        println!();
    }
    println!(
        "(yes: from the material's profile; kept: yours, from {}; -: none: refused unless \
         --power/--speed are given; find them with `stencil test-grid`, keep them with `stencil \
         profiles set`)",
        user.path.as_deref().map_or_else(
            || stencil_core::material::USER_SETTINGS_FILE.to_string(),
            |p| p.display().to_string()
        )
    );
    list_plotters();
    println!("default: {DEFAULT_MATERIAL} (as shipped); to use an edited copy, put it in ./profiles/materials/ and name it with --material, or pass its path");
    Ok(ExitCode::SUCCESS)
}
