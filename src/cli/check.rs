//! `stencil check`: a stencil PNG or a `make` output folder measured against a material, and the
//! check's findings as text (also printed by `make`).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;

use stencil_core::check::CheckReport;
use stencil_core::material::{Material, DEFAULT_MATERIAL};
use stencil_core::pipeline::{self, PhysicalConfig, Size, Timings};
use stencil_core::raster::BitGrid;
use stencil_core::report::Report;
use stencil_core::vector::VectorConfig;

use super::material::size;
use super::progress::StageBar;

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
#[derive(Args, Debug, Clone)]
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
    /// Width of the picture in mm (default: from report.json, else the PNG's own resolution,
    /// else 0.1 mm per pixel, said). At most 10 m (10000 mm) on the picture's longer side, with
    /// pixels of at least 0.001 mm.
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
    let g = stencil_core::tone::load_gray(path, max_pixels)?;
    Ok(BitGrid {
        width: g.width,
        height: g.height,
        data: g.data.iter().map(|&v| v >= 0.5).collect(),
    })
}

/// A `stencil make` output folder's report.json.
pub fn read_report(folder: &Path) -> anyhow::Result<Report> {
    let rp = folder.join("report.json");
    let text = stencil_io::read_text(&rp, stencil_io::Kind::Report).with_context(|| {
        format!(
            "{}: is this a `stencil make` output folder?",
            folder.display()
        )
    })?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a stencil report", rp.display()))
}

pub fn run_check(a: CheckArgs) -> anyhow::Result<ExitCode> {
    // A half-finished `make` of the folder (or of the set a layer's file or folder is in) is
    // settled before anything in it is looked at.
    super::program::settle(&a.input)?;
    // A layered folder: each layer (and the fill-in) in turn.
    if let Some(r) = super::layers::each_stencil(&a.input, |f| {
        check_one(CheckArgs {
            input: f,
            ..a.clone()
        })
    }) {
        return r;
    }
    check_one(a)
}

/// One stencil folder (or file).
fn check_one(a: CheckArgs) -> anyhow::Result<ExitCode> {
    let bar = StageBar::start();
    bar.set("read");
    let (png, report): (PathBuf, Option<Report>) = if a.input.is_dir() {
        super::program::settle(&a.input)?;
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
    // A gobo's stencil.png is drawn on its round sheet: the picture is its middle.
    let bits = match report.as_ref().filter(|r| r.gobo.is_some()) {
        Some(r) => {
            stencil_core::gobo::picture_of_sheet(&bits, r.width_px, r.height_px).unwrap_or(bits)
        }
        None => bits,
    };
    stencil_core::check::bound_pieces(&bits)
        .map_err(|e| anyhow::anyhow!("{}: {e}", png.display()))?;
    let material = match (
        &a.material,
        report.as_ref().map(|r| material_of_report(r, &a.input)),
    ) {
        (Some(name), _) => Material::find(name)?.0,
        (None, Some(Some(found))) => found?,
        (None, _) => Material::find_default(DEFAULT_MATERIAL)?.0,
    };
    let from_report = report.is_some() && a.width_mm.is_none() && a.dpi.is_none();
    // A bare picture with no size given: its own resolution, else 0.1 mm per pixel, said.
    let no_size = report.is_none() && a.width_mm.is_none() && a.dpi.is_none();
    let own_mm = no_size
        .then(|| stencil_core::tone::png_mm_per_px(&png))
        .flatten();
    let phys = PhysicalConfig {
        size: match (
            a.width_mm,
            a.dpi,
            report.as_ref().and_then(|r| r.mm_per_px).or(own_mm),
        ) {
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
    let (tolerance_mm, margin_mm) = tolerance_and_margin(&a, report.as_ref())?;
    let vcfg = VectorConfig {
        scale,
        kerf_mm: material.kerf_mm,
        tolerance_mm,
        margin_mm,
        // A folder is judged as make judged it: the outlines of the files it wrote.
        arcs: report.as_ref().and_then(|r| r.arcs).unwrap_or(true),
        ..Default::default()
    };
    let bridges = report_bridges(&a.input, report.as_ref(), &bits)?;
    let mut timer = Timings::new(Some(bar.clone()));
    let (_, _, chk) =
        pipeline::vectorize_and_check(&bits, bridges.as_deref(), &vcfg, &material, &mut timer)
            .with_context(|| png.display().to_string())?;
    bar.finish();
    if a.json {
        println!("{}", serde_json::to_string_pretty(&chk)?);
    } else {
        let whence = match (no_size, own_mm) {
            (false, _) => String::new(),
            (true, Some(_)) => format!(
                " (the PNG's own resolution, {:.0} dpi)",
                25.4 / scale.mm_per_px
            ),
            (true, None) => {
                " (assumed: the picture states no resolution; give --dpi or --width-mm)".to_string()
            }
        };
        println!(
            "{}: {}x{} px at {:.4} mm/px{whence}",
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

/// The vector tolerance (--tolerance-mm, else the report's, else 0.05 mm) and the margin (the
/// report's, else 5 mm); a report's value out of range is refused, naming it.
fn tolerance_and_margin(a: &CheckArgs, report: Option<&Report>) -> anyhow::Result<(f64, f64)> {
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
            report.and_then(|r| r.tolerance_mm),
            super::bounds::tolerance_value,
        )?
        .unwrap_or(0.05),
    };
    let margin_mm = report_value(
        "margin_mm",
        report.and_then(|r| r.margin_mm),
        super::bounds::margin_value,
    )?
    .unwrap_or(5.0);
    Ok((tolerance_mm, margin_mm))
}

/// The bridges' outlines of a folder's report, in pixels. A bridge drawn far off the stencil
/// belongs to another picture (or a damaged report), and its coordinates would reach the
/// geometry code unchecked: refused.
fn report_bridges(
    input: &Path,
    report: Option<&Report>,
    bits: &BitGrid,
) -> anyhow::Result<Option<Vec<Vec<[f64; 2]>>>> {
    let bridges: Option<Vec<Vec<[f64; 2]>>> =
        report.map(|r| r.bridges.iter().map(|b| b.polygon_px.clone()).collect());
    let reach = f64::from(bits.width.max(bits.height));
    for (i, poly) in bridges.iter().flatten().enumerate() {
        if let Some(p) = poly.iter().find(|p| {
            !p.iter()
                .all(|v| v.is_finite() && (-reach..=2.0 * reach).contains(v))
        }) {
            anyhow::bail!(
                "{}: report.json's bridge {} has a point at ({}, {}) px, far outside the {}x{} px \
                 stencil.png; the report does not belong to this stencil (run make again)",
                input.display(),
                i + 1,
                stencil_core::limits::num(p[0]),
                stencil_core::limits::num(p[1]),
                bits.width,
                bits.height
            );
        }
    }
    Ok(bridges)
}

/// The material a `make` folder's report.json carries: its values (checked like a profile file),
/// or, in a report from before they were written, a shipped or `./profiles/` material by name.
/// Never a file the report names: a received folder names materials, not files, so a report whose
/// material is a path (`/etc/passwd`, `../../x.toml`) is refused without opening anything.
/// `None` when the report names no material.
pub fn material_of_report(r: &Report, folder: &Path) -> Option<anyhow::Result<Material>> {
    let rp = folder.join("report.json");
    if let Some(v) = &r.material_values {
        let origin = PathBuf::from(format!("{} (material_values)", rp.display()));
        return Some(Material::from_values(v.clone(), &origin).map_err(anyhow::Error::from));
    }
    let name = r.material.as_deref()?;
    let plain = !name.is_empty()
        && !name.starts_with('.')
        && !name.ends_with(".toml")
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if !plain {
        return Some(Err(anyhow::anyhow!(
            "{}: the material is given as \"{}\", which is not a material name; a received folder \
             names its material, never a file to read: name one with --material",
            rp.display(),
            stencil_io::excerpt(name)
        )));
    }
    let found = if r
        .material_source
        .as_deref()
        .is_some_and(|s| s.starts_with("<embedded>"))
    {
        Material::find_default(name)
    } else {
        Material::find(name)
    };
    Some(found.map(|(m, _)| m).map_err(anyhow::Error::from))
}
