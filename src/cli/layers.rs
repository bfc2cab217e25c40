//! `stencil make`'s layer options: a picture in several layers, the paper's fill-in layer, and
//! registration marks.

use std::process::ExitCode;

use clap::Args;

use stencil_core::layers::{self, Layered, LayersConfig, MAX_LAYERS};
use stencil_core::pipeline::MakeConfig;

use super::progress::StageBar;

fn parse_color(s: &str) -> Result<[u8; 3], String> {
    let h = s.trim().trim_start_matches('#');
    let bad = || format!("'{s}' is not a colour: use #rrggbb (e.g. #2a4b8d)");
    if h.len() != 6 || !h.chars().all(|c| c.is_ascii_hexdigit()) {
        return Err(bad());
    }
    let v = |i: usize| u8::from_str_radix(&h[i..i + 2], 16).map_err(|_| bad());
    Ok([v(0)?, v(2)?, v(4)?])
}

/// Layer options.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Layers")]
pub struct LayerArgs {
    /// Cut the picture as N stencils (2 to 6) sprayed one over another, light to dark: the
    /// picture is posterised into N tones over the surface (its lightest tone) — a colour picture
    /// by k-means in CIELAB, a gray one by multi-level Otsu thresholds — and layer k cuts every
    /// part at its tone or darker. Writes OUT/layer-1/ … OUT/layer-N/ (each what make writes for
    /// one stencil), OUT/composite.png (the painted result) and OUT/report.json (layers, colours,
    /// painting order, likeness, hidden bridges). Every sheet gets registration marks.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(2..=MAX_LAYERS as i64))]
    pub layers: Option<u32>,
    /// With --layers: the gray levels (0..255, one per layer, comma-separated) instead of the
    /// automatic ones; layer k cuts what is darker than its level (the highest level is the first
    /// layer). Works on the picture's gray, even for a colour picture.
    #[arg(
        long,
        value_name = "L1,L2,...",
        value_delimiter = ',',
        requires = "layers"
    )]
    pub levels: Vec<u8>,
    /// Paint colours, light to dark, comma-separated #rrggbb: one per layer, or one more with the
    /// surface's colour first (default: the tones' own colours). They colour composite.png.
    #[arg(long, value_name = "#RGB,...", value_delimiter = ',', value_parser = parse_color)]
    pub colors: Vec<[u8; 3]>,
    /// Also cut the paper's fill-in layer: a second stencil in OUT/fill-in/ that paints what the
    /// first stencil's bridges hide (registered to it by marks on both sheets). With --layers,
    /// the report says how much of each layer's bridging a later layer hides instead.
    #[arg(long)]
    pub fill_in: bool,
}

impl LayerArgs {
    /// The set asked for, if any: layers, a fill-in, or (one layer) registration marks for a mask.
    pub fn config(&self, marks: bool) -> Option<LayersConfig> {
        if self.layers.is_none() && !self.fill_in && !marks {
            return None;
        }
        Some(LayersConfig {
            count: self.layers.unwrap_or(1),
            levels: self.levels.clone(),
            colors: self.colors.clone(),
            fill_in: self.fill_in && self.layers.is_none(),
        })
    }
}

/// Run and write a set, then say what was made.
pub fn make_set(
    cfg: MakeConfig,
    lc: &LayersConfig,
    fill_in_asked: bool,
) -> anyhow::Result<ExitCode> {
    let bar = StageBar::start();
    let cfg = MakeConfig {
        progress: Some(bar.clone()),
        ..cfg
    };
    let result = layers::make(&cfg, lc);
    bar.finish();
    let (set, replaced) = result.map_err(|e| super::make::make_error(&cfg, e))?;
    print_set(&cfg, &set, fill_in_asked);
    if !replaced.removed.is_empty() {
        println!(
            "removed an earlier run's {} file(s) this run does not write",
            replaced.removed.len()
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn print_set(cfg: &MakeConfig, set: &Layered, fill_in_asked: bool) {
    let r = &set.report;
    let first = &set.layers[0];
    println!(
        "{}: {} layer(s) ({}), {:.1} x {:.1} mm at {:.3} mm/px, material {}",
        cfg.out_dir.display(),
        r.layers.len(),
        serde_json::to_value(r.method)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default(),
        first.geometry.width_mm,
        first.geometry.height_mm,
        first.scale.mm_per_px,
        cfg.physical.material.name,
    );
    println!(
        "surface {}; registration marks: 4 crosses and 2 pin holes in a {:.1} mm band around the picture",
        r.surface_color, r.marks.band_mm
    );
    for l in &r.layers {
        let folder = if l.folder.is_empty() { "." } else { &l.folder };
        println!(
            "  {folder}: level {}, paint {}, cuts {:.1} %, {} islands, {} bridges, {} bridge px of which {:.0} % hidden by later layers{}",
            l.level,
            l.color,
            l.cut_pct,
            l.islands,
            l.bridges,
            l.bridge_px,
            l.hidden_pct,
            if l.check_passed { "" } else { " (CHECK FAILED)" }
        );
    }
    if let Some(f) = &r.fill_in {
        println!(
            "  fill-in: paints {} of the first stencil's {} bridge px ({:.1} %), and {} px the picture leaves unpainted{}",
            f.covered_px,
            f.bridge_px,
            f.covered_pct,
            f.overpainted_px,
            if f.check_passed {
                ""
            } else {
                " (CHECK FAILED)"
            }
        );
    } else if fill_in_asked && r.layers.len() > 1 {
        println!(
            "  (--fill-in with --layers: the hidden share above is what later layers paint over)"
        );
    }
    println!(
        "composite: {:.1} % of the picture painted in its posterised tone, mean ΔE {:.1}, likeness {:.3} (the posterised picture's: {:.3}); paint in the order {}",
        r.composite.tone_agreement_pct,
        r.composite.mean_delta_e,
        r.composite.likeness,
        r.composite.posterised_likeness,
        r.painting_order.join(", ")
    );
}

/// For a `make` folder holding a set (layer folders, a fill-in): settle the folder, then run
/// `each` on every stencil folder in painting order under a heading. `None` for a folder of one
/// stencil (the caller reads it as ever). Exits as the first folder that did not succeed.
pub fn each_stencil(
    dir: &std::path::Path,
    mut each: impl FnMut(std::path::PathBuf) -> anyhow::Result<ExitCode>,
) -> Option<anyhow::Result<ExitCode>> {
    if !dir.is_dir() {
        return None;
    }
    if let Err(e) = super::program::settle(dir) {
        return Some(Err(e));
    }
    let folders = layers::stencil_folders(dir);
    if folders.len() == 1 && folders[0] == dir {
        return None;
    }
    let mut code = ExitCode::SUCCESS;
    for f in folders {
        println!("== {} ==", f.display());
        match each(f) {
            Ok(c) if c != ExitCode::SUCCESS && code == ExitCode::SUCCESS => code = c,
            Ok(_) => {}
            Err(e) => return Some(Err(e)),
        }
    }
    Some(Ok(code))
}
