//! Writing `make`'s files: encoded in memory, then written all or nothing into the output folder.

use std::path::{Path, PathBuf};

use super::outputs::Made;
use super::source::is_mesh_path;
use crate::error::Error;
use crate::export::{self, dxf, mask, png, svg};
use crate::request::{MakeConfig, PhysicalConfig};

/// Files `make` writes, by name, encoded in memory: the ones `emit` asks for, then report.json
/// (which lists them). The masks' description goes into `made.report` as they are encoded.
pub(crate) fn encode_outputs(
    made: &mut Made,
    phys: &PhysicalConfig,
) -> Result<Vec<(String, Vec<u8>)>, Error> {
    let tt = &made.twotone;
    let geom = &made.geometry;
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    if phys.emit.png && is_mesh_path(Path::new(&made.report.input)) {
        // The grayscale rendering: what the bridge cost's intensity term reads.
        files.push((
            "gray.png".into(),
            png::encode_gray(tt.gray.width, tt.gray.height, &tt.gray.to_u8()),
        ));
    }
    if phys.emit.png {
        files.push(("twotone.png".into(), png::encode_bits(&tt.bits)));
        let bits = &made.bridged.bits;
        // A gobo's PNGs show its round sheet and rim, as the vector files do.
        match crate::gobo::SheetPx::of(geom, bits.width, bits.height) {
            Some(sheet) => {
                files.push(("stencil.png".into(), png::encode_bits(&sheet.bits(bits))));
                let dropped: Vec<u32> = (made.dropped_px.iter())
                    .map(|&i| sheet.index(i, bits.width))
                    .collect();
                files.push((
                    "preview.png".into(),
                    png::preview(
                        &sheet.gray(&tt.gray),
                        &sheet.bits(&made.picture),
                        &sheet.bits(&tt.bits),
                        &sheet.bits(bits),
                        &dropped,
                    ),
                ));
            }
            None => {
                files.push(("stencil.png".into(), png::encode_bits(bits)));
                files.push((
                    "preview.png".into(),
                    png::preview(&tt.gray, &made.picture, &tt.bits, bits, &made.dropped_px),
                ));
            }
        }
    }
    if phys.emit.svg {
        files.push((
            "stencil.svg".into(),
            svg::encode(geom, phys.vector.arc_tolerance_mm()),
        ));
    }
    if phys.emit.dxf {
        files.push((
            "stencil.dxf".into(),
            dxf::encode(geom, phys.dxf_r12, phys.vector.arc_tolerance_mm())?,
        ));
    }
    let mut mask_report = None;
    if phys.emit.mask {
        let mut m = phys.mask;
        m.mirror |= phys.material.etch().is_some_and(|e| e.mirror);
        let etch = mask::Etch::of(&phys.material);
        let (masks, r) = mask::mask_files(geom, &m, etch)?;
        files.extend(masks);
        mask_report = Some(r);
    }
    if let Some(text) = &made.gcode {
        files.push(("stencil.gcode".into(), text.as_bytes().to_vec()));
    }
    if let Some(text) = &made.hpgl {
        files.push(("stencil.plt".into(), text.as_bytes().to_vec()));
    }
    made.report.mask = mask_report;
    let mut report = made.report.clone();
    report.files = files.iter().map(|(n, _)| n.clone()).collect();
    report.files.push("report.json".into());
    let json = serde_json::to_vec_pretty(&report).map_err(|e| export::ExportError::Encode {
        path: PathBuf::from("report.json"),
        msg: e.to_string(),
    })?;
    files.push(("report.json".into(), json));
    Ok(files)
}

pub use crate::export::OUTPUT_NAMES;

/// What `make` writes for a result computed elsewhere (the studio's kept stages), by `make`'s
/// own rules: the same files, all or nothing, [`OUTPUT_NAMES`] it did not write removed.
pub fn write(cfg: &MakeConfig, made: Made) -> Result<(Made, export::Replaced), Error> {
    write_with(cfg, || Ok(made), |m| encode_outputs(m, &cfg.physical))
}

/// Write what `compute` makes (a stencil, a set), as `encode` encodes it, into `cfg.out_dir` by
/// `make`'s rules: the folder made first (so a run fails before its work), all or nothing, every
/// name `make` owns ([`OUTPUT_NAMES`], a set's folders) that it did not write removed.
pub(crate) fn write_with<T>(
    cfg: &MakeConfig,
    compute: impl FnOnce() -> Result<T, Error>,
    encode: impl FnOnce(&mut T) -> Result<Vec<(String, Vec<u8>)>, Error>,
) -> Result<(T, export::Replaced), Error> {
    let existed = cfg.out_dir.is_dir();
    export::prepare_dir(&cfg.out_dir)?;
    let result = compute().and_then(|mut made| {
        if let Some(p) = &cfg.progress {
            p.stage("write");
        }
        let files = encode(&mut made)?;
        // Every name make owns, a set's layer folders included: a one-layer run leaves none.
        let replaced = export::write_files(&cfg.out_dir, &files, export::owned_names())?;
        Ok((made, replaced))
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
