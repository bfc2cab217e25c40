//! Size, material, vector and export options of `stencil make`, and the `stencil profiles`
//! command.

use std::process::ExitCode;

use clap::{Args, ValueEnum};

use stencil_core::export::MaskConfig;
use stencil_core::material::DEFAULT_MATERIAL;
use stencil_core::material::{Material, Process};
use stencil_core::pipeline::{Emit, PhysicalConfig, Size};
use stencil_core::vector::VectorConfig;

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
}

/// Physical size, material and outputs.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Size, material and outputs")]
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
    /// picture): 0.001 to 1000.
    #[arg(long, default_value_t = 5.0, value_parser = super::bounds::margin_mm)]
    pub margin_mm: f64,
    /// Files to write, comma separated (report.json is always written).
    #[arg(long, value_enum, value_delimiter = ',', default_value = "png,svg")]
    pub emit: Vec<EmitKind>,
    /// Write the outputs even if bridges, webs or holes are thinner than the material allows
    /// (the violations are still listed in report.json).
    #[arg(long)]
    pub allow_thin: bool,
    /// Fail, writing nothing, if the clean-up and the bridges change more than PCT % of the
    /// picture's pixels (the `changed` figure `make` prints; 0..100).
    #[arg(long, value_name = "PCT", value_parser = parse_percent)]
    pub max_change: Option<f64>,
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
    /// The configuration, with `default_material` when --material is not given.
    pub fn to_config(&self, default_material: &str) -> anyhow::Result<PhysicalConfig> {
        // A named material is looked up (a path, ./profiles/materials/, shipped); without one the
        // shipped default, so the output does not depend on the folder the run starts in.
        let (material, source) = match self.material.as_deref() {
            Some(name) => Material::find(name)?,
            None => Material::find_default(default_material)?,
        };
        let has = |k: EmitKind| self.emit.contains(&k);
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
                dpi: self.mask_dpi,
                invert: self.mask_invert,
                mirror: self.mask_mirror,
                marks: self.mask_marks,
            },
            dxf_r12: self.dxf_r12,
        })
    }
}

/// `stencil profiles`.
#[derive(Args, Debug)]
pub struct ProfilesArgs {}

pub fn run_profiles(_: ProfilesArgs) -> anyhow::Result<ExitCode> {
    println!(
        "{:<20} {:<6} {:>8} {:>10} {:>11} {:>7}  settings",
        "material", "process", "thick", "bridge>=", "feature>=", "kerf"
    );
    for name in stencil_io::profile::known_names("materials", stencil_core::material::SHIPPED) {
        match Material::find(&name) {
            Ok((m, src)) => {
                let settings = match &m.process {
                    Process::Laser(l) => {
                        format!("{}% {} mm/min x{}", l.power_pct, l.speed_mm_min, l.passes)
                    }
                    Process::Knife(k) => {
                        format!("{} g {} mm/s x{}", k.force_g, k.speed_mm_s, k.passes)
                    }
                    Process::Pen(p) => {
                        format!("{} mm/min, {} mm pen", p.speed_mm_min, p.pen_width_mm)
                    }
                    Process::Etch(e) => format!(
                        "etch factor {}{}{}",
                        e.etch_factor,
                        if e.mirror { ", mirror" } else { "" },
                        if e.two_sided { ", two-sided" } else { "" }
                    ),
                };
                println!(
                    "{:<20} {:<6} {:>5} mm {:>7} mm {:>8} mm {:>4} mm  {}  [{}]",
                    m.name,
                    m.process.kind(),
                    m.thickness_mm,
                    m.min_bridge_mm,
                    m.min_feature_mm,
                    m.kerf_mm,
                    settings,
                    src.display()
                );
            }
            Err(e) => println!("{name:<20} error: {e}"),
        }
    }
    println!("default: {DEFAULT_MATERIAL} (as shipped); to use an edited copy, put it in ./profiles/materials/ and name it with --material, or pass its path");
    Ok(ExitCode::SUCCESS)
}
