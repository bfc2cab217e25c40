//! Size, material, vector, check and export options of `stencil make`, and the `stencil check`
//! and `stencil profiles` commands.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, ValueEnum};

use stencil_core::check::CheckReport;
use stencil_core::export::mask::MaskConfig;
use stencil_core::pipeline::{self, Emit, PhysicalConfig, Size, Timings};
use stencil_core::material::DEFAULT_MATERIAL;
use stencil_core::material::{Material, Process};
use stencil_core::raster::BitGrid;
use stencil_core::report::Report;
use stencil_core::vector::VectorConfig;

use super::progress::StageBar;

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

fn size(width_mm: Option<f64>, dpi: Option<f64>) -> Size {
    match (width_mm, dpi) {
        (Some(w), _) => Size::WidthMm(w),
        (None, Some(d)) => Size::Dpi(d),
        _ => Size::Default,
    }
}

impl PhysicalArgs {
    /// The configuration, with `default_material` when --material is not given.
    pub fn to_config(&self, default_material: &str) -> anyhow::Result<PhysicalConfig> {
        let (material, source) =
            Material::find(self.material.as_deref().unwrap_or(default_material))?;
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

/// At most this many violations are listed one per line; the rest are counted by kind.
pub const LISTED_VIOLATIONS: usize = 30;

/// Print the check's findings, one violation per line up to [`LISTED_VIOLATIONS`], then a count
/// of the rest by kind; `all_in` says where the whole list is.
pub fn print_check(c: &CheckReport, all_in: &str) {
    let f = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3} mm"));
    println!(
        "check against '{}' (bridges >= {} mm, webs and holes >= {} mm): {} piece(s); narrowest bridge {}, web {}, hole {}",
        c.material,
        c.min_bridge_mm,
        c.min_feature_mm,
        c.pieces,
        f(c.narrowest_bridge_mm),
        f(c.narrowest_web_mm),
        f(c.narrowest_hole_mm)
    );
    for v in c.violations.iter().take(LISTED_VIOLATIONS) {
        let conf = match v.confirmed_by_opening {
            Some(true) => " (confirmed by opening)",
            Some(false) => " (not confirmed by the raster opening)",
            None => "",
        };
        println!("  {v}{conf}");
    }
    let rest = &c.violations[c.violations.len().min(LISTED_VIOLATIONS)..];
    if !rest.is_empty() {
        let mut by_kind: Vec<(String, usize)> = Vec::new();
        for v in rest {
            let k = v.kind.to_string();
            match by_kind.iter_mut().find(|(n, _)| *n == k) {
                Some((_, count)) => *count += 1,
                None => by_kind.push((k, 1)),
            }
        }
        let kinds: Vec<String> = by_kind.iter().map(|(k, n)| format!("{n} {k}")).collect();
        println!(
            "  ... and {} more ({}); {all_in}",
            rest.len(),
            kinds.join(", ")
        );
    }
}

/// `stencil check INPUT`.
#[derive(Args, Debug)]
#[command(after_help = "\
Examples:
  stencil check out/rings                 # an output folder: material, size and bridges from its report.json
  stencil check stencil.png --material mylar-0.19 --width-mm 200
Exits 0 only when the stencil is one piece and every bridge, web and hole is wide enough.")]
pub struct CheckArgs {
    /// A stencil PNG (white = material) or an output folder of `stencil make`.
    pub input: PathBuf,
    /// Material profile (default: the one the folder's report.json names, else cardstock).
    #[arg(long)]
    pub material: Option<String>,
    /// Width of the picture in mm (default: from report.json, else 0.1 mm per pixel). At most
    /// 10 m (10000 mm) on the picture's longer side, with pixels of at least 0.001 mm.
    #[arg(long, conflicts_with = "dpi", value_parser = super::bounds::positive)]
    pub width_mm: Option<f64>,
    /// Pixels per inch (instead of --width-mm); at most 25400.
    #[arg(long, value_parser = super::bounds::positive)]
    pub dpi: Option<f64>,
    /// Simplification tolerance in mm (default: from report.json, else 0.05): 0 or 0.001 to 10.
    #[arg(long, value_parser = super::bounds::tolerance_mm)]
    pub tolerance_mm: Option<f64>,
    /// Refuse stencil pictures with more pixels than this (checked from the header, before
    /// decoding). The default, 100 megapixels, checks in seconds and under 1 GB; at most
    /// 200000000.
    #[arg(long, default_value_t = stencil_core::limits::CHECK_DEFAULT_MAX_PIXELS, value_parser = super::bounds::max_pixels)]
    pub max_pixels: u64,
    /// Print the check report as JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

fn load_bits(path: &Path, max_pixels: u64) -> anyhow::Result<BitGrid> {
    let g = stencil_core::tone::image::load_gray(path, max_pixels)?;
    Ok(BitGrid {
        width: g.width,
        height: g.height,
        data: g.data.iter().map(|&v| v >= 0.5).collect(),
    })
}

/// A `stencil make` output folder's report.json.
pub fn read_report(folder: &Path) -> anyhow::Result<Report> {
    let rp = folder.join("report.json");
    let text = stencil_io::read_text(&rp, stencil_core::limits::MAX_REPORT_BYTES, "stencil report")
        .with_context(|| {
            format!(
                "{}: is this a `stencil make` output folder?",
                folder.display()
            )
        })?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a stencil report", rp.display()))
}

pub fn run_check(a: CheckArgs) -> anyhow::Result<ExitCode> {
    let bar = StageBar::start();
    bar.set("read");
    let (png, report): (PathBuf, Option<Report>) = if a.input.is_dir() {
        (a.input.join("stencil.png"), Some(read_report(&a.input)?))
    } else {
        (a.input.clone(), None)
    };
    let bits = load_bits(&png, a.max_pixels).with_context(|| {
        if report.is_some() {
            format!(
                "{}: cannot read the folder's stencil.png (make writes it with --emit png)",
                a.input.display()
            )
        } else {
            format!("{}: cannot read the stencil picture", png.display())
        }
    })?;
    let name = a
        .material
        .clone()
        .or_else(|| report.as_ref().and_then(|r| r.material.clone()))
        .unwrap_or_else(|| DEFAULT_MATERIAL.to_string());
    let (material, _) = Material::find(&name)?;
    let from_report = report.is_some() && a.width_mm.is_none() && a.dpi.is_none();
    let phys = PhysicalConfig {
        size: match (a.width_mm, a.dpi, report.as_ref().and_then(|r| r.mm_per_px)) {
            (None, None, Some(mm)) => Size::Dpi(25.4 / mm),
            (w, d, _) => size(w, d),
        },
        ..Default::default()
    };
    let scale = phys.scale(bits.width, bits.height).with_context(|| {
        if from_report {
            format!(
                "{}: report.json's mm_per_px is not a size stencil accepts (give --width-mm or --dpi)",
                a.input.display()
            )
        } else {
            png.display().to_string()
        }
    })?;
    let report_value = |what: &str, v: Option<f64>, ok: fn(f64) -> Result<f64, String>| {
        v.map(|v| {
            ok(v).map_err(|e| anyhow::anyhow!("{}: report.json's {what}: {e}", a.input.display()))
        })
        .transpose()
    };
    let tolerance_mm = match a.tolerance_mm {
        Some(t) => t,
        None => report_value(
            "tolerance_mm",
            report.as_ref().and_then(|r| r.tolerance_mm),
            super::bounds::tolerance_value,
        )?
        .unwrap_or(0.05),
    };
    let margin_mm = report_value(
        "margin_mm",
        report.as_ref().and_then(|r| r.margin_mm),
        super::bounds::margin_value,
    )?
    .unwrap_or(5.0);
    let vcfg = VectorConfig {
        scale,
        kerf_mm: material.kerf_mm,
        tolerance_mm,
        margin_mm,
        ..Default::default()
    };
    let bridges: Option<Vec<Vec<[f64; 2]>>> = report
        .as_ref()
        .map(|r| r.bridges.iter().map(|b| b.polygon_px.clone()).collect());
    // A bridge drawn far off the stencil belongs to another picture (or a damaged report), and
    // its coordinates would reach the geometry code unchecked.
    let reach = f64::from(bits.width.max(bits.height));
    for (i, poly) in bridges.iter().flatten().enumerate() {
        if let Some(p) = poly.iter().find(|p| {
            !p.iter()
                .all(|v| v.is_finite() && (-reach..=2.0 * reach).contains(v))
        }) {
            anyhow::bail!(
                "{}: report.json's bridge {} has a point at ({}, {}) px, far outside the {}x{} px \
                 stencil.png; the report does not belong to this stencil (run make again)",
                a.input.display(),
                i + 1,
                stencil_core::limits::num(p[0]),
                stencil_core::limits::num(p[1]),
                bits.width,
                bits.height
            );
        }
    }
    let mut timer = Timings(Default::default(), Some(bar.clone()));
    let (_, _, chk) =
        pipeline::vectorize_and_check(&bits, bridges.as_deref(), &vcfg, &material, &mut timer)
            .with_context(|| png.display().to_string())?;
    bar.finish();
    if a.json {
        println!("{}", serde_json::to_string_pretty(&chk)?);
    } else {
        println!(
            "{}: {}x{} px at {:.4} mm/px",
            png.display(),
            bits.width,
            bits.height,
            scale.mm_per_px
        );
        print_check(&chk, "`stencil check --json` lists them all");
        println!("{}", if chk.passed() { "OK" } else { "FAILED" });
    }
    Ok(if chk.passed() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
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
    println!("default: {DEFAULT_MATERIAL}; copy a profile into ./profiles/materials/ to edit it, or pass a path to --material");
    Ok(ExitCode::SUCCESS)
}
