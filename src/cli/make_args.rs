//! `make`'s and `tone`'s options as clap parses them, and the stage settings they say (picture,
//! clean-up, bridges); running and printing are `make.rs`'s.

use std::path::PathBuf;

use clap::Args;

use stencil_core::bridge::BridgeConfig;
use stencil_core::tone::{FilterConfig, Threshold, ToneConfig};
use stencil_core::BridgePlaces;

use super::layers::LayerArgs;
use super::machine_args::{CutArgs, MachineArgs};
use super::material::{OutputArgs, PhysicalArgs};
use super::mesh::MeshArgs;

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
    /// [default: a photo at the level 'auto' chooses, printed beside the likeness at 128 and at
    /// Otsu's; two-tone art (a scanned drawing, a logo) at its own tones, 128 for black and white;
    /// a rendered mesh, or with --local-threshold, at 128]
    #[arg(long, value_parser = parse_threshold)]
    pub threshold: Option<Threshold>,
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
    #[arg(long, default_value_t = 1.0, value_parser = |s: &str| parse_in(s, 0.1, 10.0, "gamma"))]
    pub gamma: f64,
    /// Edge-preserving smoothing (bilateral filter): the distance in mm over which similar tones
    /// are averaged; edges between different tones are kept. 0 = off.
    #[arg(long, value_name = "MM", default_value_t = 0.0, value_parser = parse_length)]
    pub smooth: f64,
    /// Abstraction strength 0..1 (after DeCarlo and Santella 2002): small regions of similar tone
    /// are merged into their neighbours before thresholding, so the stencil keeps the picture's
    /// large shapes instead of its speckle. 0 = off; 0.3 to 0.6 suits most photos.
    #[arg(long = "abstract", value_name = "S", default_value_t = 0.0, value_parser = |s: &str| parse_in(s, 0.0, 1.0, "the strength"))]
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
    /// The places and island options, in the user's millimetres.
    pub fn places(&self) -> BridgePlaces {
        BridgePlaces {
            no_bridge_near_mm: self.no_bridge_near.clone(),
            at_mm: self.bridge_at.clone(),
            min_island_mm2: self.min_island_mm2,
            keep_all_islands: self.keep_all_islands,
        }
    }

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
    pub plotter: super::hpgl::PlotterArgs,
    #[command(flatten)]
    pub layers: LayerArgs,
    #[command(flatten)]
    pub tiles: super::tiles::TileArgs,
}

impl MakeArgs {
    /// The output folder: -o, or the default beside the input.
    pub fn out_dir(&self) -> PathBuf {
        (self.out.clone()).unwrap_or_else(|| stencil_core::pipeline::default_out_dir(&self.input))
    }
}

impl ImageArgs {
    pub fn to_config(&self) -> ToneConfig {
        ToneConfig {
            threshold: self.threshold.unwrap_or(Threshold::ByPicture),
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
    pub fn to_config(&self) -> FilterConfig {
        FilterConfig {
            radius: self.filter_radius.unwrap_or(FilterConfig::default().radius),
            min_speck_px: self.min_speck_px,
            auto_radius: self.filter_radius.is_none(),
        }
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
