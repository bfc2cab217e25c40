//! `stencil make` and `stencil tone`.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;

use stencil_core::bridge::BridgeConfig;
use stencil_core::export;
use stencil_core::fit::{SizingError, Stock};
use stencil_core::inputs::{Inputs, Kept};
use stencil_core::material::Material;
use stencil_core::pipeline::{self, MakeConfig};
use stencil_core::report::Fidelity;
use stencil_core::request::Request;
use stencil_core::resolve::{self, Note};
use stencil_core::tone::{FilterConfig, ScaleCap, Threshold, ToneConfig};

use super::gcode::{CutArgs, MachineArgs};
use super::material::{EmitKind, OutputArgs, PhysicalArgs};
use super::mesh::MeshArgs;
use super::progress::StageBar;

fn parse_threshold(s: &str) -> Result<Threshold, String> {
    if s.eq_ignore_ascii_case("otsu") {
        return Ok(Threshold::Otsu);
    }
    if s.eq_ignore_ascii_case("auto") {
        return Ok(Threshold::Auto);
    }
    let bad = || {
        format!(
            "'{s}' is not a threshold: use a level 0..255, a fraction 0.0..1.0, 'otsu' or 'auto'"
        )
    };
    if s.contains('.') {
        // A fraction of full intensity (the natural unit for a rendered mesh).
        let f: f64 = s.parse().map_err(|_| bad())?;
        if !(0.0..=1.0).contains(&f) {
            return Err(bad());
        }
        return Ok(Threshold::Level((f * 255.0).round() as u8));
    }
    s.parse::<u8>().map(Threshold::Level).map_err(|_| bad())
}

fn parse_alpha(s: &str) -> Result<f64, String> {
    let a: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if a > 1.0 && a < 2.0 {
        Ok(a)
    } else {
        Err(format!(
            "alpha must be between 1 and 2 (exclusive), got {a}"
        ))
    }
}

/// `N` comma-separated millimetre values (a position within ±10 m, a radius above 0).
fn parse_mm<const N: usize>(s: &str) -> Result<[f64; N], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != N {
        return Err(format!(
            "'{s}' should be {N} numbers in mm separated by commas ({})",
            if N == 2 { "X,Y" } else { "X,Y,R" }
        ));
    }
    let mut out = [0.0; N];
    for (k, p) in parts.iter().enumerate() {
        let v: f64 = p
            .parse()
            .map_err(|_| format!("'{p}' in '{s}' is not a number"))?;
        if !v.is_finite() || v.abs() > stencil_core::limits::MAX_PICTURE_MM {
            return Err(format!(
                "'{p}' in '{s}' is not a position on a sheet (mm, within ±10 m)"
            ));
        }
        out[k] = v;
    }
    if N == 3 && out[2] <= 0.0 {
        return Err(format!("the radius in '{s}' must be above 0 mm"));
    }
    Ok(out)
}

/// A number within `lo..=hi` (finite).
fn parse_in(s: &str, lo: f64, hi: f64, what: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{what} must be {lo} to {hi}, got {s}"))
    }
}

fn parse_percent(s: &str) -> Result<f64, String> {
    parse_in(s, -100.0, 100.0, "a percentage")
}

fn parse_gamma(s: &str) -> Result<f64, String> {
    parse_in(s, 0.1, 10.0, "gamma")
}

fn parse_strength(s: &str) -> Result<f64, String> {
    parse_in(s, 0.0, 1.0, "the strength")
}

fn parse_length(s: &str) -> Result<f64, String> {
    parse_in(s, 0.0, 1000.0, "a length in mm")
}

fn parse_turn(s: &str) -> Result<u8, String> {
    match s {
        "0" => Ok(0),
        "90" => Ok(1),
        "180" => Ok(2),
        "270" => Ok(3),
        _ => Err(format!(
            "'{s}' is not a quarter turn: use 0, 90, 180 or 270"
        )),
    }
}

/// `X,Y,W,H` in mm: a corner within ±10 m, a width and height above 0.
fn parse_crop(s: &str) -> Result<[f64; 4], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let v: Option<Vec<f64>> = parts.iter().map(|p| p.parse::<f64>().ok()).collect();
    match v.as_deref() {
        Some(&[x, y, w, h])
            if [x, y, w, h].iter().all(|v| v.is_finite())
                && x >= 0.0
                && y >= 0.0
                && w > 0.0
                && h > 0.0
                && x + w <= 1e4
                && y + h <= 1e4 =>
        {
            Ok([x, y, w, h])
        }
        _ => Err(format!(
            "'{s}' should be X,Y,W,H in mm (the corner from the picture's top left, then the \
             width and height, all at least 0 and the size above 0)"
        )),
    }
}

fn parse_area(s: &str) -> Result<f64, String> {
    let a: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if a.is_finite() && (0.0..=1e8).contains(&a) {
        Ok(a)
    } else {
        Err(format!("an area must be 0 to 1e8 mm², got {s}"))
    }
}

fn parse_weight(s: &str) -> Result<f64, String> {
    let w: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if w.is_finite() && w >= 0.0 {
        Ok(w)
    } else {
        Err(format!("a weight must be a finite number >= 0, got {s}"))
    }
}

/// Two-tone options for pictures.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Picture")]
pub struct ImageArgs {
    /// Level at and above which a pixel is light (material): 0..255, a fraction such as 0.5 of full
    /// intensity, 'otsu' to pick it from the histogram, or 'auto': the level whose stencil, after
    /// the clean-up this material needs, looks most like the picture (SSIM of the two blurred to
    /// viewing distance; report.json's threshold_choice lists every level tried). Both print the
    /// level chosen. Applies to pictures and rendered meshes ('auto' is 'otsu' for a mesh).
    #[arg(long, default_value = "128", value_parser = parse_threshold)]
    pub threshold: Threshold,
    /// Swap the tones: dark parts become material instead of light ones (the paper's reverse
    /// stencil). `--lit` is the same switch.
    #[arg(long, alias = "lit")]
    pub invert: bool,
    /// Supersample: upsample the picture smoothly by this factor (1..8) before thresholding, so
    /// edges follow the picture rather than its pixels; the working image has this many times
    /// the pixels across, the picture keeps its size in mm. 1 turns supersampling off.
    /// [default: automatic: the smallest factor that makes a working pixel at most a fifth of the
    /// material's smallest feature and at most twice --tolerance-mm, within 16 megapixels and
    /// --max-pixels; none at the default 0.1 mm per pixel with cardstock]
    #[arg(long)]
    pub scale: Option<u32>,
    /// Refuse pictures with more pixels than this (checked from the header, before decoding),
    /// and working images (after --scale) larger than this. The default, 50 megapixels, runs
    /// `make` in under 10 s and about 1.3 GB on two cores; at most 200000000 (about 25 s and
    /// 4.5 GB in make, a minute in tone).
    /// Whatever it says, a picture whose decoding needs more than 2 GiB is refused.
    #[arg(long, default_value_t = stencil_core::limits::DEFAULT_MAX_PIXELS, value_parser = super::bounds::max_pixels)]
    pub max_pixels: u64,
    /// Keep only this part of the picture: X,Y,W,H in mm of the picture as shown (after its EXIF
    /// orientation, at the size --width-mm or --dpi gives the whole picture), from its top left
    /// corner. Done before everything else: the stencil is the cropped part at that same scale,
    /// and --bridge-at and --no-bridge-near refer to the cropped picture.
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_crop)]
    pub crop: Option<[f64; 4]>,
    /// Turn the picture clockwise by 90, 180 or 270 degrees (after --crop).
    #[arg(long, value_name = "DEGREES", default_value = "0", value_parser = parse_turn)]
    pub rotate: u8,
    /// Brighten (up to 100) or darken (down to -100): percent of full scale added to every pixel.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = parse_percent)]
    pub brightness: f64,
    /// More (up to 100: twice) or less (down to -100: flat gray) contrast about mid-gray, percent.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = parse_percent)]
    pub contrast: f64,
    /// Gamma, 0.1..10: above 1 lifts the midtones (a dark face opens up), below 1 sinks them; black
    /// and white stay.
    #[arg(long, default_value_t = 1.0, value_parser = parse_gamma)]
    pub gamma: f64,
    /// Edge-preserving smoothing (bilateral filter): the distance in mm over which similar tones
    /// are averaged; edges between different tones are kept. 0 = off.
    #[arg(long, value_name = "MM", default_value_t = 0.0, value_parser = parse_length)]
    pub smooth: f64,
    /// Abstraction strength 0..1 (after DeCarlo and Santella 2002): small regions of similar tone
    /// are merged into their neighbours before thresholding, so the stencil keeps the picture's
    /// large shapes instead of its speckle. 0 = off; 0.3 to 0.6 suits most photos.
    #[arg(long = "abstract", value_name = "S", default_value_t = 0.0, value_parser = parse_strength)]
    pub abstraction: f64,
    /// Local (adaptive) threshold: compare each pixel with the mean of its surroundings (a
    /// Gaussian of this many mm) rather than with one level for the whole picture; --threshold
    /// then sets the offset (128 = the local mean). Shows detail in both shadows and highlights.
    /// 0 = off.
    #[arg(long, value_name = "MM", default_value_t = 0.0, value_parser = parse_length)]
    pub local_threshold: f64,
}

/// Clean-up options.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Clean-up")]
pub struct FilterArgs {
    /// Instead of the default design-rule regularisation (every web and hole made at least the
    /// material's min_feature_mm wide, each thin feature removed or widened, whichever changes the
    /// picture less), apply the old morphological opening then closing by a disc of this radius in
    /// pixels (0 = off) and --min-speck-px, as given (the width check still applies). At most a
    /// quarter of the working image's shorter side.
    #[arg(long)]
    pub filter_radius: Option<u32>,
    /// With --filter-radius: material or cut pieces smaller than this many pixels flip tone.
    #[arg(long, default_value_t = 8)]
    pub min_speck_px: usize,
}

/// Bridge optimizer options (the paper's cost C = w0·ΣI + w1·L^α + w2·κ + w3·σ²).
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Bridges")]
pub struct BridgeArgs {
    /// w0: weight of the intensity error ΣI, how dark the gray source is under the bridge
    /// (normalised: 1 = a strip of this image's typical length over black).
    #[arg(long, default_value_t = BridgeConfig::default().w_intensity, value_parser = parse_weight)]
    pub w_intensity: f64,
    /// w1: weight of the length penalty L^alpha (normalised: 1 = this image's typical strip).
    #[arg(long, default_value_t = BridgeConfig::default().w_length, value_parser = parse_weight)]
    pub w_length: f64,
    /// w2: weight of the island border's curvature at the bridge, κ from 0 (straight) to 1 (tight
    /// bend); raise it to keep bridges off curves that carry the shape.
    #[arg(long, default_value_t = BridgeConfig::default().w_curvature, value_parser = parse_weight)]
    pub w_curvature: f64,
    /// w3: weight of σ², how unevenly the strips across the bridge's width cost (variance over
    /// squared mean); raise it to avoid spots whose neighbours are much worse.
    #[arg(long, default_value_t = BridgeConfig::default().w_variance, value_parser = parse_weight)]
    pub w_variance: f64,
    /// Exponent of the length penalty, strictly between 1 and 2.
    #[arg(long, default_value_t = BridgeConfig::default().alpha, value_parser = parse_alpha)]
    pub alpha: f64,
    /// Preferred longest bridge, in pixels: walks through the cut longer than this are dropped, so
    /// an island is bridged under it where it can be. An island with no walk under it is still
    /// joined, by the cheapest path through the cut of any length (a note says so, and the bridge
    /// is marked "via": "search" in report.json).
    #[arg(long, default_value_t = BridgeConfig::default().max_length_px)]
    pub max_bridge_length_px: u32,
    /// Narrowest bridge, in pixels, if wider than the material's min_bridge_mm. A bridge's width is
    /// ⌈√A / 4⌉ px for the area A of the smaller island it joins (√A / 4 mm for its area in mm²,
    /// whatever the size), clamped to the narrowest..widest range.
    #[arg(long, default_value_t = BridgeConfig::default().min_width_px)]
    pub min_bridge_width_px: u32,
    /// Widest bridge, in pixels. Default: the material's max_bridge_mm (4 × min_bridge_mm unless
    /// the profile says otherwise). With --allow-thin, both pixel widths are taken exactly as
    /// given, even below the material's minimum (the check then reports the thin bridges).
    #[arg(long)]
    pub max_bridge_width_px: Option<u32>,
    /// If a grown bridge's real error (Σ(1 − gray)² over the pixels it fills) exceeds its estimate
    /// (its window's mean strip ΣI × width) by more than this fraction, halve its width and add a
    /// support bridge at the next cheapest place.
    #[arg(long, default_value_t = BridgeConfig::default().support_margin)]
    pub support_margin: f64,
    /// Offer only the paper's gradient walks as bridge candidates, not also the straight
    /// shortest gaps between neighbouring pieces (for comparison with the paper's method).
    #[arg(long)]
    pub walks_only: bool,
    /// At least this many bridges for every island (1 to 12), spread apart: at least 90° (or
    /// 360°/N when N > 4) from each other as seen from the island's centre, where the island's
    /// shape allows. Islands also get more where their size or sag asks (see the material's
    /// two_bridges_above_mm and max_sag_mm).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=stencil_core::bridge::MAX_PER_ISLAND as i64))]
    pub bridges_per_island: u32,
    /// A picture marking where no bridge may go (a face, a signature): dark (under half gray) =
    /// keep out. Any size: it is scaled to the picture. With --crop or --rotate, one the size of
    /// the whole picture is cropped and turned with it; any other size is taken as the stencil's
    /// frame (the cropped, turned picture, as the studio paints it). An island that can only be
    /// joined through the dark areas is an error naming it.
    #[arg(long, value_name = "MASK")]
    pub keep_out: Option<std::path::PathBuf>,
    /// A bridge from the island under (or nearest) this point, as close to it as the material
    /// allows: X,Y in mm from the picture's top left corner (x right, y down). Repeatable.
    #[arg(long, value_name = "X,Y", value_parser = parse_mm::<2>)]
    pub bridge_at: Vec<[f64; 2]>,
    /// No bridge within R mm of X,Y (mm from the picture's top left corner). Repeatable.
    #[arg(long, value_name = "X,Y,R", value_parser = parse_mm::<3>)]
    pub no_bridge_near: Vec<[f64; 3]>,
    /// Islands smaller than this many mm² are cut away instead of bridged (specks); counted in
    /// report.json and shown in the preview as material cut away. Default 0: none.
    #[arg(long, value_name = "A", default_value_t = 0.0, value_parser = parse_area)]
    pub min_island_mm2: f64,
    /// Bridge every island. By default an island is dropped (cut away) when that changes the
    /// picture less than the cheapest bridge that could hold it (a speck of highlight on a dark
    /// field); dropped islands are listed in report.json and shown yellow in preview.png.
    #[arg(long)]
    pub keep_all_islands: bool,
}

impl BridgeArgs {
    pub fn to_config(&self) -> anyhow::Result<BridgeConfig> {
        let max = self.max_bridge_width_px.unwrap_or(u32::MAX);
        anyhow::ensure!(
            self.min_bridge_width_px >= 1 && self.min_bridge_width_px <= max,
            "--min-bridge-width-px ({}) must be at least 1 and at most --max-bridge-width-px ({})",
            self.min_bridge_width_px,
            max
        );
        Ok(BridgeConfig {
            w_intensity: self.w_intensity,
            w_length: self.w_length,
            w_curvature: self.w_curvature,
            w_variance: self.w_variance,
            alpha: self.alpha,
            max_length_px: self.max_bridge_length_px,
            min_width_px: self.min_bridge_width_px,
            support_margin: self.support_margin,
            gaps: !self.walks_only,
            user: stencil_core::bridge::UserBridges {
                no_bridge_near_mm: self.no_bridge_near.clone(),
                at_mm: self.bridge_at.clone(),
                min_island_mm2: self.min_island_mm2,
                keep_all_islands: self.keep_all_islands,
                ..Default::default()
            },
            strength: stencil_core::bridge::StrengthConfig {
                per_island: self.bridges_per_island,
                ..Default::default()
            },
            ..BridgeConfig::default()
        })
    }
}

/// `make --help`'s first heading: what is read and where the files go.
const INPUT_HEADING: &str = "Input and output folder";

#[derive(Args, Debug)]
#[command(after_help = "\
Example:
  stencil make samples/rings.png -o out/rings --threshold otsu --w-curvature 2
  writes out/rings/twotone.png, stencil.png, preview.png, stencil.svg and report.json; every island
  is joined to the frame, by a longer path through the cut where no bridge is short enough.
  stencil make samples/rings.png --material mylar-0.19 --width-mm 200 --emit png,svg,dxf,mask
  sizes it to 200 mm, takes bridge and feature widths from the profile (see `stencil profiles`;
  default: cardstock) and fails if the check finds a bridge, web or hole too thin for it.
  stencil make samples/rings.png --material cardstock --emit png,svg,gcode --machine diode-400
  also writes stencil.gcode for a GRBL 1.1 laser and prints its time estimate.")]
pub struct MakeArgs {
    /// The picture (PNG, JPEG, BMP, TIFF) or mesh (OBJ) to make a stencil from.
    #[arg(help_heading = INPUT_HEADING)]
    pub input: PathBuf,
    /// Output folder [default: out/<input stem>/]. Its stencil files are replaced all at once; a
    /// run that fails moves the earlier run's files into previous/ in it, so that they are not
    /// taken for this run's result. Your own files in it are left alone.
    #[arg(short, long, help_heading = INPUT_HEADING)]
    pub out: Option<PathBuf>,
    // `--help` shows the headings in the order of these fields: the common options first.
    #[command(flatten)]
    pub physical: PhysicalArgs,
    #[command(flatten)]
    pub image: ImageArgs,
    #[command(flatten)]
    pub filter: FilterArgs,
    #[command(flatten)]
    pub mesh: MeshArgs,
    #[command(flatten)]
    pub bridge: BridgeArgs,
    #[command(flatten)]
    pub output: OutputArgs,
    #[command(flatten)]
    pub machine: MachineArgs,
    #[command(flatten)]
    pub cut: CutArgs,
    #[command(flatten)]
    pub layers: super::layers::LayerArgs,
}

impl ImageArgs {
    fn to_config(&self) -> ToneConfig {
        ToneConfig {
            threshold: self.threshold,
            invert: self.invert,
            scale: self.scale,
            max_pixels: self.max_pixels,
            // The millimetres are made pixels by `resolve`.
            adjust: stencil_core::tone::Adjust {
                quarter_turns: self.rotate,
                brightness: (self.brightness / 100.0) as f32,
                contrast: (1.0 + self.contrast / 100.0) as f32,
                gamma: self.gamma as f32,
                abstraction: self.abstraction as f32,
                ..Default::default()
            },
        }
    }
}

impl FilterArgs {
    fn to_config(&self) -> FilterConfig {
        FilterConfig {
            radius: self.filter_radius.unwrap_or(FilterConfig::default().radius),
            min_speck_px: self.min_speck_px,
            auto_radius: self.filter_radius.is_none(),
        }
    }
}

/// Above this share of the picture changed, `make` warns.
const WARN_CHANGE_PCT: f64 = 5.0;

/// What a user can do when the stencil strays from the picture (a gobo is made larger by its
/// image area: --gobo excludes --width-mm and --dpi).
fn change_hints(cfg: &MakeConfig) -> String {
    let larger = if cfg.physical.gobo.is_some() {
        "a larger image area in --gobo OD,IA"
    } else {
        "--width-mm or --dpi"
    };
    format!(
        "to keep closer to the picture, make it larger ({larger}), choose a material with a \
         smaller min_feature_mm (--material; `stencil profiles` lists them), move --threshold, \
         or supersample with --scale 2..4"
    )
}

/// The fidelity figures on one line.
fn change_line(f: &Fidelity) -> String {
    format!(
        "changed {:.2} % of the picture: {}",
        f.changed_pct,
        change_parts(f)
    )
}

/// What changed it, stage by stage.
fn change_parts(f: &Fidelity) -> String {
    format!(
        "clean-up removed {:.2} % material, added {:.2} %; bridges {:.2} %",
        f.cleanup_removed_pct, f.cleanup_added_pct, f.bridges_pct
    )
}

/// `stencil make`. The output folder is checked first (an output over an input, or over what is
/// not a file, is refused with the folder untouched). A run that fails after that leaves nothing
/// that could be taken for its result: the earlier run's files are moved into `previous/` (see
/// [`stencil_io::set_aside`]; a person's own files stay where they are), and the error says so
/// and when they were made.
pub fn run_make(a: MakeArgs) -> anyhow::Result<ExitCode> {
    let out_dir = a
        .out
        .clone()
        .unwrap_or_else(|| pipeline::default_out_dir(&a.input));
    let inputs = make_inputs(&a);
    let inputs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
    stencil_io::check_output_dir(&out_dir, stencil_core::layers::owned_names(), &inputs)?;
    make_in(&a)
        .map_err(|e| gobo_words(&a, e))
        .map_err(|e| super::errors::after_failed_make(&out_dir, e))
}

/// A size error raised while the run is set up (before the pipeline, whose errors
/// [`make_error`] words), in the words of --gobo when the gobo's size caused it.
fn gobo_words(a: &MakeArgs, e: anyhow::Error) -> anyhow::Error {
    let Some(g) = &a.physical.gobo else {
        return e;
    };
    let g = stencil_core::gobo::Gobo {
        crop: a.physical.gobo_crop,
        ..g.clone()
    };
    let size = e.chain().find_map(|c| {
        c.downcast_ref::<stencil_core::limits::SizeError>().or(
            match c.downcast_ref::<stencil_core::Error>() {
                Some(stencil_core::Error::Limit(s)) => Some(s),
                _ => None,
            },
        )
    });
    match size.and_then(|s| super::errors::gobo_size(&a.input, &g, s)) {
        Some(words) => anyhow::anyhow!(words),
        None => e,
    }
}

/// The files a `make` reads: the picture or mesh, the keep-out mask, and the material and machine
/// profiles given as paths.
fn make_inputs(a: &MakeArgs) -> Vec<PathBuf> {
    let mut v = vec![a.input.clone()];
    v.extend(a.bridge.keep_out.clone());
    for p in [&a.physical.material, &a.machine.machine]
        .into_iter()
        .flatten()
    {
        v.push(PathBuf::from(p));
    }
    v
}

fn make_in(a: &MakeArgs) -> anyhow::Result<ExitCode> {
    let cfg = make_config(a, None)?;
    if let Some(lc) = set_config(a) {
        return super::layers::make_set(cfg, &lc, a.layers.fill_in);
    }
    let bar = StageBar::start();
    let cfg = MakeConfig {
        progress: Some(bar.clone()),
        ..cfg
    };
    let result = stencil_core::driver::make(&cfg);
    bar.finish();
    let (made, replaced) = result.map_err(|e| make_error(&cfg, e))?;
    print_made(&cfg, &made, &replaced);
    Ok(ExitCode::SUCCESS)
}

/// The set `make` cuts instead of one stencil, if any: layers, a fill-in, or registration marks
/// for a mask (every sheet registered).
pub(super) fn set_config(a: &MakeArgs) -> Option<stencil_core::layers::LayersConfig> {
    let marks = a.output.mask_marks && a.output.emit.contains(&EmitKind::Mask);
    a.layers.config(marks)
}

/// The pipeline's settings from the command line, each option checked in the order given here
/// (the first bad one is the one reported; the mesh's and the bridges' after the size, as
/// always), with the decisions `resolve` makes from the files it needs: read once here, its notes
/// printed; or, for the studio, kept in `kept` while the files stay, the notes not printed.
/// Without --material, a G-code job gets a material set up for the machine's tool.
pub(super) fn make_config(a: &MakeArgs, mut kept: Option<&mut Kept>) -> anyhow::Result<MakeConfig> {
    let emit_gcode = a.output.emit.contains(&EmitKind::Gcode);
    let machine = if emit_gcode {
        Some(a.machine.machine()?)
    } else {
        None
    };
    let default_material = match &machine {
        Some(m) => stencil_core::material::default_for(&m.tool),
        None => stencil_core::material::DEFAULT_MATERIAL,
    };
    let mut physical = a.physical.to_config(&a.output, default_material)?;
    physical.mask.tone_inverted = a.image.invert;
    let (mesh, bridge) = (a.mesh.to_config(), a.bridge.to_config());
    let marks = a.output.mask_marks && a.output.emit.contains(&EmitKind::Mask);
    let request = Request {
        make: MakeConfig {
            out_dir: a
                .out
                .clone()
                .unwrap_or_else(|| pipeline::default_out_dir(&a.input)),
            input: a.input.clone(),
            tone: a.image.to_config(),
            mesh: mesh.as_ref().ok().cloned().unwrap_or_default(),
            filter: a.filter.to_config(),
            bridge: bridge.as_ref().ok().cloned().unwrap_or_default(),
            physical,
            ..MakeConfig::default()
        },
        sheet: a.physical.sheet.clone(),
        bed: machine.as_ref().map(|m| Stock::Bed {
            machine: m.name.clone(),
            w_mm: m.bed.width_mm,
            h_mm: m.bed.height_mm,
        }),
        margin_counts: a.machine.cut_outline || marks,
        ..image_request(&a.image, a.bridge.keep_out.clone())
    };
    let inputs = match kept.as_deref_mut() {
        Some(k) => k.load(&request),
        None => Inputs::load(&request),
    };
    let (notes, cfg) = resolve::resolve(&request, &inputs);
    if kept.is_none() {
        for n in &notes {
            println!("note: {}: {}", a.input.display(), note(n));
        }
    }
    let (mesh, bridge) = (mesh?, bridge?);
    let cfg = MakeConfig {
        mesh,
        bridge,
        max_bridge_width_px: a.bridge.max_bridge_width_px,
        ..cfg.map_err(|e| sizing_words(&a.input, e))?
    };
    let mut gcode = super::gcode::make_gcode_config(
        &a.machine,
        &a.cut,
        &cfg.physical.material,
        emit_gcode,
        cfg.physical.vector.arc_tolerance_mm(),
    )?;
    if let (Some(g), Some(_)) = (&mut gcode, &cfg.physical.gobo) {
        // A gobo is a disc: its rim is always cut, last.
        g.plan.cut_outline = true;
    }
    let mut cfg = cfg;
    if let Some(g) = &gcode {
        // G-code without arcs (--no-arcs, the machine's profile, a drag knife): the outlines
        // are made straight within the whole tolerance, and every file carries those polygons,
        // the ones the check judges.
        cfg.physical.vector.arcs = g.plan.arc_tolerance_on(&g.machine) > 0.0;
    }
    Ok(MakeConfig { gcode, ..cfg })
}

/// The picture's options measured in mm, as the request carries them.
fn image_request(i: &ImageArgs, keep_out: Option<PathBuf>) -> Request {
    Request {
        keep_out,
        crop_mm: i.crop,
        smooth_mm: i.smooth,
        local_threshold_mm: i.local_threshold,
        ..Request::default()
    }
}

/// A note of `resolve`'s, in this command's words.
fn note(n: &Note) -> String {
    match n {
        Note::Etched {
            material,
            given_mm,
            need_mm,
            undercut_mm,
        } => format!(
            "webs and holes at least {need_mm:.3} mm, not {given_mm} mm as {material} says: the \
             masks are drawn {undercut_mm:.3} mm smaller on every side for the etch's undercut, \
             and a narrower opening would not be etched at all"
        ),
        Note::Fitted {
            width_mm,
            height_mm,
            from_mm,
            stock,
            turned,
        } => {
            let why = match stock {
                Stock::Sheet { .. } => format!(
                    "fitted to {stock}{}",
                    if *turned { " turned sideways" } else { "" }
                ),
                Stock::Bed { .. } => format!(
                    "at 0.1 mm per pixel it would be {:.1} x {:.1} mm, larger than {stock}; \
                     scaled down to fit",
                    from_mm[0], from_mm[1]
                ),
            };
            format!("{width_mm:.1} x {height_mm:.1} mm ({why}; --width-mm sets the size)")
        }
    }
}

/// A decision that could not be made, in this command's words (any other error as it is).
fn sizing_words(input: &std::path::Path, e: stencil_core::Error) -> anyhow::Error {
    let stencil_core::Error::Sizing(s) = e else {
        return e.into();
    };
    let input = input.display();
    match s {
        SizingError::GoboMesh => anyhow::anyhow!(
            "{input}: --gobo takes a picture: a mesh is drawn at its own size (render it to a PNG \
             with `stencil tone`, then make the gobo from that)"
        ),
        SizingError::GoboBed {
            gobo,
            od_mm,
            bed:
                Stock::Bed {
                    machine,
                    w_mm,
                    h_mm,
                }
                | Stock::Sheet {
                    name: machine,
                    w_mm,
                    h_mm,
                },
        } => anyhow::anyhow!(
            "a {gobo} gobo is {od_mm} mm across, larger than the {w_mm} x {h_mm} mm bed of {machine}: \
             choose a smaller --gobo"
        ),
        SizingError::Fit(e) => anyhow::anyhow!("{input}: {}", super::errors::fit(&e)),
        SizingError::CropOutside {
            crop_mm,
            picture_mm,
            mm_per_px,
        } => anyhow::anyhow!(super::errors::crop_outside(crop_mm, picture_mm, mm_per_px)),
    }
}

/// A failed run in this command's words: the fidelity limit with what helps, any other error
/// naming the input.
pub(super) fn make_error(cfg: &MakeConfig, e: stencil_core::Error) -> anyhow::Error {
    // A gobo's size is set by --gobo, not --width-mm (which --gobo excludes).
    if let (Some(g), stencil_core::Error::Limit(s)) = (&cfg.physical.gobo, &e) {
        if let Some(words) = super::errors::gobo_size(&cfg.input, g, s) {
            return anyhow::anyhow!(words);
        }
    }
    match e {
        stencil_core::Error::TooMuchChange {
            fidelity,
            limit_pct,
        } => anyhow::anyhow!(
            "{}: {:.2} % of the picture changed, over the --max-change limit of {limit_pct} %, \
             so nothing was written ({}); {}",
            cfg.input.display(),
            fidelity.changed_pct,
            change_parts(&fidelity),
            change_hints(cfg),
        ),
        // Another run is writing the folder: said as it is (kept as its type, so that the failed
        // run does not move that run's files aside).
        stencil_core::Error::Export(export::ExportError::Write(
            w @ stencil_io::WriteError::Busy { .. },
        )) => anyhow::Error::new(w),
        stencil_core::Error::Plan(p) => {
            anyhow::anyhow!("{}: {}", cfg.input.display(), super::errors::plan(&p))
        }
        e => super::errors::naming_input(&cfg.input, e),
    }
}

/// What a successful run tells: the stencil in one line, its size and files, files of an earlier
/// run it removed, the working scale, the fidelity, long joins, strength, the check, the G-code.
/// The level `otsu` or `auto` chose, and how alike the stencil is to the picture.
fn print_threshold(cfg: &MakeConfig, r: &stencil_core::report::Report) {
    let (Some(level), Some(like)) = (r.threshold_level, r.likeness) else {
        return;
    };
    match (&cfg.tone.threshold, &r.threshold_choice) {
        (Threshold::Auto, Some(c)) => println!(
            "threshold: auto chose level {level} (likeness {:.3}; at 128: {:.3}, at Otsu's {}: \
             {:.3})",
            c.likeness, c.likeness_128, c.otsu_level, c.likeness_otsu
        ),
        (Threshold::Otsu | Threshold::Auto, _) => {
            println!("threshold: otsu chose level {level} (likeness {like:.3})")
        }
        _ => {}
    }
}

fn print_made(cfg: &MakeConfig, made: &pipeline::Made, replaced: &export::Replaced) {
    let r = &made.report;
    let total_ms: f64 = r.timings_ms.values().sum();
    println!(
        "{}: {}x{} px, {} islands, {} bridges ({} support), {} floating; {:.0} ms",
        cfg.out_dir.display(),
        r.width_px,
        r.height_px,
        r.islands,
        r.bridges.len(),
        r.bridges.iter().filter(|b| b.support).count(),
        r.floating_after,
        total_ms
    );
    println!(
        "{:.1} x {:.1} mm at {:.3} mm/px, material {}; files: {}",
        made.geometry.width_mm,
        made.geometry.height_mm,
        made.scale.mm_per_px,
        cfg.physical.material.name,
        file_names(&replaced.written)
    );
    print_threshold(cfg, r);
    if let Some(d) = &r.dropped_islands {
        let area: f64 = d.iter().map(|i| i.area_mm2).sum();
        let listed: Vec<String> = d
            .iter()
            .take(5)
            .map(|i| {
                format!(
                    "{:.1},{:.1} ({:.1} mm²)",
                    i.at_mm[0], i.at_mm[1], i.area_mm2
                )
            })
            .collect();
        println!(
            "dropped {} island(s), {area:.1} mm² in all, where a bridge would change the picture \
             more than cutting them away (yellow in preview.png; --keep-all-islands bridges \
             them): at {}{}",
            d.len(),
            listed.join(", "),
            if d.len() > 5 { ", ..." } else { "" }
        );
    }
    if made.geometry.design_cuts.0.is_empty() {
        eprintln!(
            "warning: {}: the stencil is blank: nothing is cut (see the preview; for a mesh, \
             check its parts and the view)",
            cfg.input.display()
        );
    }
    if let Some(mesh) = pipeline::is_mesh_path(&cfg.input)
        .then(|| stencil_core::tone::mesh::load(&cfg.input).ok())
        .flatten()
    {
        let p = stencil_core::tone::mesh::part_sizes(&mesh, &cfg.mesh);
        if p.below_a_pixel > 0 {
            eprintln!(
                "warning: {}: {} of the mesh's {} parts come out smaller than a pixel and leave \
                 no mark (a part far from the rest makes the view frame both, so everything \
                 shrinks): remove stray parts, or raise the resolution",
                cfg.input.display(),
                p.below_a_pixel,
                p.parts
            );
        }
    }
    if let Some(turn) = stencil_core::tone::orientation_note(&cfg.input) {
        eprintln!(
            "note: {}: its EXIF orientation was applied: the picture is {turn}, as a viewer \
             shows it",
            cfg.input.display()
        );
    }
    if !replaced.removed.is_empty() {
        eprintln!(
            "note: removed {} from an earlier run in {} (this run did not write {}; --emit says which files to write)",
            file_names(&replaced.removed),
            cfg.out_dir.display(),
            if replaced.removed.len() == 1 { "it" } else { "them" },
        );
    }
    print_working_scale(r);
    if let Some(f) = &r.fidelity {
        println!("{}", change_line(f));
        if f.changed_pct > WARN_CHANGE_PCT {
            eprintln!(
                "warning: more than {WARN_CHANGE_PCT} % of the picture changed; {}",
                change_hints(cfg)
            );
        }
    }
    print_long_joins(r, cfg.bridge.max_length_px);
    print_strength(r);
    super::check::print_check(&made.check, "report.json lists them all");
    if let Some(g) = &made.report.gcode {
        super::gcode::print_summary(&cfg.out_dir.join("stencil.gcode"), g);
    }
    if let Some(g) = &made.report.gobo {
        print_gobo(g);
    }
    if let Some(m) = &made.report.mask {
        print_masks(m);
    }
}

/// The gobo: its size and where it comes from, the picture's placement, the polarity, and the
/// warning when most of the image area would pass light.
fn print_gobo(g: &stencil_core::gobo::GoboReport) {
    println!(
        "gobo {}{} mm outside diameter, {} mm image area ({}): the picture {} ({:.1} x {:.1} mm) \
         at its centre, the rim cut; {}; {:.0} % of the image area passes light",
        g.letter
            .as_deref()
            .map(|l| format!("{l}: "))
            .unwrap_or_default(),
        g.od_mm,
        g.ia_mm,
        g.table.as_deref().map_or("as given", |_| "Rosco's size"),
        if g.placement == "cropped" {
            "fills the image area, metal outside its circle"
        } else {
            "inscribed in the image area"
        },
        g.picture_mm[0],
        g.picture_mm[1],
        g.polarity,
        g.clear_pct
    );
    if let Some(w) = &g.warning {
        eprintln!("warning: {w} (--invert)");
    }
}

/// What the etch masks are: files, side and mirroring, dpi, polarity, the undercut compensation
/// and what it closed, and the warning when most of the picture is clear.
fn print_masks(m: &stencil_core::export::MaskReport) {
    for s in &m.masks {
        println!(
            "mask {}{}: {}, {} at {} dpi; {}{}",
            s.side,
            if s.side == "back" {
                " (mirrored against the front: lay it on the other face)"
            } else {
                ""
            },
            s.png,
            s.svg,
            m.dpi,
            m.polarity,
            if s.mirrored {
                "; mirrored left-right"
            } else {
                "; right-reading"
            }
        );
    }
    if m.undercut_compensation_mm > 0.0 {
        println!(
            "mask openings drawn {:.3} mm smaller on every side for the etch's undercut (thickness \
             / etch factor{})",
            m.undercut_compensation_mm,
            if m.masks.len() == 2 { ", half from each side" } else { "" }
        );
    }
    if m.openings_closed > 0 {
        eprintln!(
            "warning: the undercut compensation closes {} opening(s) narrower than {:.3} mm: they \
             will not be etched; make the picture larger (--width-mm) or use a thinner metal",
            m.openings_closed,
            2.0 * m.undercut_compensation_mm
        );
    }
    if let Some(w) = &m.warning {
        eprintln!("warning: {w} (--invert)");
    }
}

/// File names, comma separated.
fn file_names(paths: &[std::path::PathBuf]) -> String {
    paths
        .iter()
        .filter_map(|p| p.file_name())
        .map(|n| n.to_string_lossy())
        .collect::<Vec<_>>()
        .join(", ")
}

/// One line when the picture was supersampled, or when a cap kept it coarser than the material
/// and the tolerance ask for.
fn print_working_scale(r: &stencil_core::report::Report) {
    let (Some(k), Some(mm)) = (r.scale_factor, r.mm_per_px) else {
        return;
    };
    let auto = r.scale_auto.as_ref();
    if k > 1 {
        let why = if auto.is_some() {
            "so edges follow the picture"
        } else {
            "as --scale asked"
        };
        println!("supersampled {k}x ({mm:.3} mm per working pixel) {why}");
    }
    if let Some(a) = auto {
        if let Some(cap) = a.capped_by {
            // The library names the cap; the pixel limit is this command's --max-pixels.
            let (by, help) = match cap {
                ScaleCap::MaxFactor => (cap.to_string(), "use a picture with more pixels"),
                ScaleCap::Memory => (
                    cap.to_string(),
                    "use a picture with more pixels, or give --scale",
                ),
                ScaleCap::MaxPixels => ("--max-pixels".to_string(), "raise --max-pixels"),
            };
            println!(
                "note: {:.3} mm working pixels need {}x supersampling, kept to {k}x by {by}; \
                 edges may show the picture's pixels ({help})",
                a.target_mm_per_px, a.wanted
            );
        }
    }
}

/// How many islands needed extra bridges for strength, and a warning naming the islands some
/// rule could not be met for (the sheet is still one piece: these are advice, not errors).
fn print_strength(r: &stencil_core::report::Report) {
    let Some(s) = &r.strength else {
        return;
    };
    if !(s.max_span_mm.is_finite() || s.two_bridges_above_mm.is_finite()) {
        println!(
            "strength: not judged: material '{}' gives no strength data (youngs_modulus_gpa, \
             density_kg_m3, max_sag_mm, two_bridges_above_mm); add them to its profile to have \
             islands held against sagging",
            r.material.as_deref().unwrap_or("?")
        );
        return;
    }
    println!(
        "strength: {} of {} islands needed extra bridges for strength ({} bridges added); sag \
         limit {} mm = spans up to {:.0} mm",
        s.islands_with_extra,
        s.islands.len(),
        s.extra_bridges,
        s.islands.first().map_or(0.0, |i| i.limit_mm),
        s.max_span_mm
    );
    let notes: Vec<&str> = s.islands.iter().filter_map(|i| i.note.as_deref()).collect();
    if !notes.is_empty() {
        eprintln!(
            "warning: {} island(s) not held as the material asks (strength in report.json): {}{}",
            notes.len(),
            notes[..notes.len().min(3)].join("; "),
            if notes.len() > 3 { "; ..." } else { "" }
        );
    }
}

/// A note when some island had no walk under the length limit and was joined by the search.
fn print_long_joins(r: &stencil_core::report::Report, limit: u32) {
    let searched: Vec<_> = r
        .bridges
        .iter()
        .filter(|b| b.via == stencil_core::bridge::Via::Search && !b.support)
        .collect();
    if let Some(longest) = searched.iter().map(|b| b.length_px).reduce(f64::max) {
        println!(
            "note: {} island group(s) had no bridge under --max-bridge-length-px ({limit} px) and \
             were joined by the cheapest path through the cut instead (longest {longest:.0} px; \
             \"via\": \"search\" in report.json)",
            searched.len()
        );
    }
}

/// `stencil tone INPUT -o twotone.png`.
#[derive(Args, Debug)]
pub struct ToneCmdArgs {
    /// The picture or OBJ mesh.
    pub input: PathBuf,
    /// The PNG to write (255 = material, 0 = cut).
    #[arg(short, long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub image: ImageArgs,
    #[command(flatten)]
    pub mesh: MeshArgs,
    #[command(flatten)]
    pub filter: FilterArgs,
    /// Width of the picture on the sheet in mm, as for `make` (it sets the working resolution
    /// and the clean-up's widths in pixels).
    #[arg(long, conflicts_with = "dpi", value_parser = super::bounds::positive)]
    pub width_mm: Option<f64>,
    /// Pixels of the picture per inch (instead of --width-mm), as for `make`.
    #[arg(long, value_parser = super::bounds::positive)]
    pub dpi: Option<f64>,
    /// Material profile, as for `make` (its smallest feature sets the clean-up) [default:
    /// cardstock]
    #[arg(long)]
    pub material: Option<String>,
}

/// `stencil tone`: the two-tone `make` would bridge for the same picture, size and material (its
/// twotone.png), written alone.
pub fn run_tone(a: ToneCmdArgs) -> anyhow::Result<ExitCode> {
    let mut inputs = vec![a.input.as_path()];
    inputs.extend(a.material.as_deref().map(std::path::Path::new));
    stencil_io::check_output(&a.out, &inputs)?;
    let (material, source) = match a.material.as_deref() {
        Some(name) => Material::find(name)?,
        None => Material::find_default(stencil_core::material::DEFAULT_MATERIAL)?,
    };
    let physical = pipeline::PhysicalConfig {
        size: super::material::size(a.width_mm, a.dpi),
        material,
        material_source: source.display().to_string(),
        ..pipeline::PhysicalConfig::default()
    };
    let request = Request {
        make: MakeConfig {
            input: a.input.clone(),
            tone: a.image.to_config(),
            physical,
            ..MakeConfig::default()
        },
        ..image_request(&a.image, None)
    };
    let cfg = resolve::resolve_picture(&request, &Inputs::load(&request))
        .map_err(|e| sizing_words(&a.input, e))?;
    let bar = StageBar::start();
    let cfg = MakeConfig {
        mesh: a.mesh.to_config()?,
        filter: a.filter.to_config(),
        progress: Some(bar.clone()),
        ..cfg
    };
    let result = stencil_core::driver::clean_two_tone(&cfg);
    bar.finish();
    let tt = result.map_err(|e| super::errors::naming_input(&cfg.input, e))?;
    stencil_io::write_atomic(&a.out, &export::png::encode_bits(&tt.bits))
        .with_context(|| format!("writing the two-tone image for {}", a.input.display()))?;
    println!(
        "{}: {}x{} px",
        a.out.display(),
        tt.bits.width,
        tt.bits.height
    );
    Ok(ExitCode::SUCCESS)
}
