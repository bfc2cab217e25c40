//! `stencil make`'s layer options (a picture in several layers, the paper's fill-in layer,
//! registration marks), and how the commands that read a `make` folder go through a set's.

use std::process::ExitCode;

use clap::Args;

use stencil_core::layers::{LayersConfig, MAX_LAYERS};

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
    /// painting order, likeness, hidden bridges). Every sheet gets registration marks. Fewer
    /// sheets when the picture has fewer tones each sheet would show (make says so); specks a
    /// sheet would hold on costly bridges are painted instead, and no sheet hangs more than three
    /// islands each on the next.
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
    let folders = stencil_core::tiles::stencil_folders(dir);
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
