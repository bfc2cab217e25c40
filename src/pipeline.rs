//! The whole job, stage by stage: input → two-tone → filter → islands → bridges → outputs.
//!
//! Stages are pure functions on plain data; this module times them, gathers the report and hands
//! the results to `export` at the very end, so a failure anywhere leaves no output behind.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::bridge::{self, BridgeConfig, Bridged};
use crate::export::{self, png};
use crate::islands;
use crate::raster::TwoTone;
use crate::report::Report;
use crate::tone::filter::{self, FilterConfig, FilterStats};
use crate::tone::mesh::{self, MeshConfig};
use crate::tone::{self, image::load_gray, ToneConfig};
use crate::Error;

/// Everything `stencil make` needs, as plain data (the CLI builds it; tests build it by hand).
#[derive(Clone, Debug, Default)]
pub struct MakeConfig {
    pub input: PathBuf,
    pub out_dir: PathBuf,
    pub tone: ToneConfig,
    pub mesh: MeshConfig,
    pub filter: FilterConfig,
    pub bridge: BridgeConfig,
}

/// Whether a path is a mesh (by extension) rather than a picture.
pub fn is_mesh(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"))
}

/// Stage timings, in milliseconds, keyed by stage name.
#[derive(Default)]
struct Timer(BTreeMap<String, f64>);

impl Timer {
    fn time<T>(&mut self, name: &str, f: impl FnOnce() -> T) -> T {
        let t = Instant::now();
        let r = f();
        self.0
            .insert(name.to_string(), t.elapsed().as_secs_f64() * 1e3);
        r
    }
}

/// The two-tone stage, from a picture or a mesh, before the topological filter.
/// Returns the two-tone and the threshold level used (pictures only).
pub fn two_tone(
    input: &Path,
    tone: &ToneConfig,
    mesh: &MeshConfig,
) -> Result<(TwoTone, Option<u8>), Error> {
    if is_mesh(input) {
        return Ok((
            mesh::render(input, mesh).map_err(tone::ToneError::from)?,
            None,
        ));
    }
    if !(1..=8).contains(&tone.scale) {
        return Err(tone::ToneError::BadScale(tone.scale).into());
    }
    let gray = load_gray(input, tone.max_pixels)?;
    let gray = tone::image::upsample(&gray, tone.scale);
    let (tt, level) = tone::threshold(gray, tone.threshold, tone.invert);
    Ok((tt, Some(level)))
}

/// What `make` computed, before anything is written.
pub struct Made {
    /// After the topological filter, before bridges.
    pub twotone: TwoTone,
    pub filter: FilterStats,
    pub bridged: Bridged,
    pub report: Report,
}

/// Run the pipeline in memory: nothing is written.
pub fn run(cfg: &MakeConfig) -> Result<Made, Error> {
    let mut timer = Timer::default();
    let (raw, level) = timer.time("tone", || two_tone(&cfg.input, &cfg.tone, &cfg.mesh))?;
    let (bits, filter_stats) = timer.time("filter", || filter::filter(&raw.bits, &cfg.filter));
    let twotone = TwoTone {
        bits,
        gray: raw.gray,
    };
    let map = timer.time("islands", || islands::label(&twotone.bits));
    let bridged = timer.time("bridge", || bridge::connect(&twotone, &map, &cfg.bridge))?;
    let after = timer.time("verify", || islands::label(&bridged.bits));
    if after.island_count() > 0 {
        let node = &after.nodes[1];
        let (x, y) = node.border.first().copied().unwrap_or((0, 0));
        return Err(Error::Floating {
            count: after.island_count(),
            x,
            y,
            area: node.area,
        });
    }
    let report = Report {
        input: cfg.input.display().to_string(),
        width_px: twotone.bits.width,
        height_px: twotone.bits.height,
        threshold_level: level,
        filter: filter_stats,
        islands: map.island_count(),
        bridges: bridged.bridges.iter().map(Into::into).collect(),
        floating_after: after.island_count(),
        timings_ms: timer.0,
    };
    Ok(Made {
        twotone,
        filter: filter_stats,
        bridged,
        report,
    })
}

/// Files `make` writes, by name, encoded in memory.
pub fn encode_outputs(made: &Made) -> Result<Vec<(String, Vec<u8>)>, Error> {
    let tt = &made.twotone;
    let report =
        serde_json::to_vec_pretty(&made.report).map_err(|e| export::ExportError::Encode {
            path: PathBuf::from("report.json"),
            msg: e.to_string(),
        })?;
    Ok(vec![
        ("twotone.png".into(), png::encode_bits(&tt.bits)),
        ("stencil.png".into(), png::encode_bits(&made.bridged.bits)),
        (
            "preview.png".into(),
            png::preview(&tt.gray, &tt.bits, &made.bridged.bits),
        ),
        ("report.json".into(), report),
    ])
}

/// `stencil make`: run the pipeline and write its outputs into `cfg.out_dir`, all or nothing.
pub fn make(cfg: &MakeConfig) -> Result<(Made, Vec<PathBuf>), Error> {
    let existed = cfg.out_dir.is_dir();
    export::prepare_dir(&cfg.out_dir)?;
    let result = run(cfg).and_then(|made| {
        let files = encode_outputs(&made)?;
        let written = export::write_files(&cfg.out_dir, &files)?;
        Ok((made, written))
    });
    if result.is_err() && !existed {
        // Leave no trace of a failed run: the folder we made is empty (remove_dir refuses otherwise).
        let _ = std::fs::remove_dir(&cfg.out_dir);
    }
    result
}

/// The default output folder for an input: `out/<input stem>/`.
pub fn default_out_dir(input: &Path) -> PathBuf {
    let stem = input
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "stencil".into());
    PathBuf::from("out").join(stem)
}
