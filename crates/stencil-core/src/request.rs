//! What `make` is asked ([`Request`]) and, decided, what the driver runs ([`MakeConfig`]).

use std::path::PathBuf;
use std::sync::Arc;

use crate::bridge::BridgeConfig;
use crate::export::mask::MaskConfig;
use crate::fit::Stock;
use crate::material::Material;
use crate::raster::Gray;
use crate::tone::filter::FilterConfig;
use crate::tone::mesh::MeshConfig;
use crate::tone::{ToneConfig, ToneError};
use crate::units::Size;
use crate::vector::VectorConfig;

pub use crate::timing::Progress;

/// The user's words, in their units: `make` holds what needs no decision as given (the size asked
/// for, the profiles as loaded: a bad name is an option error, said in the options' order).
#[derive(Clone, Debug, Default)]
pub struct Request {
    /// What needs no decision, as given.
    pub make: MakeConfig,
    /// The keep-out picture (see `bridge::constraints`).
    pub keep_out: Option<PathBuf>,
    /// The part of the picture kept: X, Y, W, H in mm of the whole picture as shown.
    pub crop_mm: Option<[f64; 4]>,
    /// The edge-preserving smoothing's reach, mm (0: off).
    pub smooth_mm: f64,
    /// The local threshold's neighbourhood, mm (0: off).
    pub local_threshold_mm: f64,
    /// A sheet of stock to fit the picture on.
    pub sheet: Option<Stock>,
    /// The bed of the machine a G-code job is for (a [`Stock::Bed`]).
    pub bed: Option<Stock>,
    /// Whether something is cut or marked at the sheet's edge, so the margin counts when fitting.
    pub margin_counts: bool,
}

/// What the driver runs: the request with every decision made and its files read, as plain data
/// ([`crate::resolve::resolve`] makes it; tests build it by hand).
#[derive(Clone, Debug, Default)]
pub struct MakeConfig {
    /// The picture or mesh to read.
    pub input: PathBuf,
    /// Where `make` writes its files.
    pub out_dir: PathBuf,
    /// How gray becomes two tones.
    pub tone: ToneConfig,
    /// How a mesh is drawn.
    pub mesh: MeshConfig,
    /// The clean-up.
    pub filter: FilterConfig,
    /// The bridges (the user's places in pixels are filled by `resolve` from [`Self::places`]).
    pub bridge: BridgeConfig,
    /// The user's bridge places and island options, in millimetres.
    pub places: BridgePlaces,
    /// The widest bridge asked for, px (else the material's `max_bridge_mm` decides).
    pub max_bridge_width_px: Option<u32>,
    /// Size, material, vectors, check and export.
    pub physical: PhysicalConfig,
    /// Also plan the G-code job (`--emit gcode`): written as stencil.gcode, summarised in the
    /// report. A job that does not fit the machine's bed fails the run before anything is written.
    pub gcode: Option<stencil_gcode::GcodeConfig>,
    /// Also write the job in HP-GL for a plotter cutter or pen plotter (`--emit hpgl`): written
    /// as stencil.plt from the same cut loops, summarised in the report.
    pub hpgl: Option<stencil_hpgl::HpglConfig>,
    /// Told each stage as it starts (see [`Progress`]).
    pub progress: Option<Arc<dyn Progress>>,
    /// The keep-out picture, read once (see [`KeepOut`]).
    pub keep_out: Option<KeepOut>,
}

/// A keep-out picture as read, with what tells its frame (see `resolve`'s `place_keep_out`).
#[derive(Clone, Debug)]
pub struct KeepOut {
    /// The picture, or why it could not be read: said when the stages reach it, after the input
    /// is read, where `make` has always said it.
    pub picture: Result<Arc<Gray>, Arc<ToneError>>,
    /// The whole input picture's size as shown (from its header; `None` when unreadable).
    pub whole_px: Option<(u32, u32)>,
}

/// The user's bridge places and island options as given: millimetres from the picture's top left
/// corner, x right, y down (as the report's positions).
#[derive(Clone, Debug, Default)]
pub struct BridgePlaces {
    /// `--no-bridge-near X,Y,R`: discs no bridge may cross.
    pub no_bridge_near_mm: Vec<[f64; 3]>,
    /// `--bridge-at X,Y`: places a bridge should start near.
    pub at_mm: Vec<[f64; 2]>,
    /// `--min-island-mm2`: islands smaller than this are cut away instead of bridged.
    pub min_island_mm2: f64,
    /// `--keep-all-islands`: bridge every island, never drop one whose bridge would change the
    /// picture more than dropping it (see `bridge::drop`).
    pub keep_all_islands: bool,
}

/// Which files `make` writes (report.json always). Default: `png,svg`: the images to look at and
/// the one vector file every laser and plotter program opens; DXF and masks on request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Emit {
    /// twotone.png, stencil.png, preview.png.
    pub png: bool,
    /// stencil.svg.
    pub svg: bool,
    /// stencil.dxf.
    pub dxf: bool,
    /// mask.png and mask.svg.
    pub mask: bool,
}

impl Default for Emit {
    fn default() -> Self {
        Emit {
            png: true,
            svg: true,
            dxf: false,
            mask: false,
        }
    }
}

/// Physical size, material, vectors, check and export options.
#[derive(Clone, Debug)]
pub struct PhysicalConfig {
    /// The stencil's size.
    pub size: Size,
    /// The material's profile.
    pub material: Material,
    /// Where the material profile came from (for the report).
    pub material_source: String,
    /// The vector stage's options.
    pub vector: VectorConfig,
    /// Write the outputs even when the check finds violations.
    pub allow_thin: bool,
    /// Fail (and write nothing) when the stencil differs from the thresholded picture in more
    /// than this percentage of its pixels (`--max-change`; finite, 0..=100). See
    /// [`crate::report::Fidelity`].
    pub max_change_pct: Option<f64>,
    /// Which files are written.
    pub emit: Emit,
    /// The masks' options.
    pub mask: MaskConfig,
    /// Write the DXF as R12 (else R2000).
    pub dxf_r12: bool,
    /// A gobo (`--gobo`): a round sheet, the picture at its centre (`size` is set to fit its
    /// image area), the rim cut (see [`crate::gobo`]).
    pub gobo: Option<crate::gobo::Gobo>,
}

impl Default for PhysicalConfig {
    fn default() -> Self {
        PhysicalConfig {
            size: Size::Default,
            material: Material::default(),
            material_source: format!(
                "<embedded>/materials/{}.toml",
                crate::material::DEFAULT_MATERIAL
            ),
            vector: VectorConfig::default(),
            allow_thin: false,
            max_change_pct: None,
            emit: Emit::default(),
            mask: MaskConfig::default(),
            dxf_r12: false,
            gobo: None,
        }
    }
}
