//! `stencil make` and `stencil tone`: running them and saying what was made (their options are
//! `make_args.rs`'s).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use stencil_core::export;
use stencil_core::fit::{SizingError, Stock};
use stencil_core::layers::{Layered, LayersConfig};
use stencil_core::material::Material;
use stencil_core::pipeline::{self, MakeConfig};
use stencil_core::report::Fidelity;
use stencil_core::tone::{LevelChoice, ScaleCap, Threshold};
use stencil_core::Request;
use stencil_core::{resolve, resolve_picture, Note};
use stencil_core::{Inputs, KeptInputs};

use super::make_args::{ImageArgs, MakeArgs, ToneCmdArgs};
use super::material::EmitKind;
use super::progress::StageBar;

/// Above this share of the picture changed, `make` warns.
const WARN_CHANGE_PCT: f64 = 5.0;

/// What a user can do when the stencil strays from the picture (a gobo is made larger by its
/// image area: --gobo excludes --width-mm and --dpi).
fn change_hints(cfg: &MakeConfig) -> String {
    let larger = larger_hint(cfg);
    format!(
        "to keep closer to the picture, make it larger ({larger}), choose a material with a \
         smaller min_feature_mm (--material; `stencil profiles` lists them), move --threshold, \
         or supersample with --scale 2..4"
    )
}

/// How to make the picture larger: a gobo by its image area (--gobo excludes --width-mm and
/// --dpi), anything else by its size.
fn larger_hint(cfg: &MakeConfig) -> &'static str {
    if cfg.physical.gobo.is_some() {
        "a larger image area in --gobo OD,IA"
    } else {
        "--width-mm or --dpi"
    }
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
    let out_dir = a.out_dir();
    // The files it reads: the picture or mesh, the keep-out mask, the profiles given as paths.
    let mut inputs = vec![a.input.as_path()];
    inputs.extend(a.bridge.keep_out.as_deref());
    inputs.extend(
        [&a.physical.material, &a.machine.machine]
            .into_iter()
            .flatten()
            .map(Path::new),
    );
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

fn make_in(a: &MakeArgs) -> anyhow::Result<ExitCode> {
    let cfg = make_config(a, None)?;
    if let Some(tc) = tiles_config(a)? {
        return make_tiles(cfg, &tc);
    }
    if let Some(lc) = set_config(a) {
        return make_set(cfg, &lc, a.layers.fill_in);
    }
    let (cfg, result) = with_progress(cfg, stencil_core::driver::make);
    let (made, replaced) = result.map_err(|e| make_error(&cfg, e))?;
    print_made(&cfg, &made, &replaced);
    Ok(ExitCode::SUCCESS)
}

/// The tiles asked for, fitted to --sheet or else the machine's bed, with the layers or the
/// fill-in asked for (--mask-marks alone asks for what every tile has: registration marks).
pub(super) fn tiles_config(
    a: &MakeArgs,
) -> anyhow::Result<Option<stencil_core::tiles::TilesConfig>> {
    let set = set_config(a).filter(|lc| a.tiles.asked() && (lc.count >= 2 || lc.fill_in));
    let tc = a.tiles.config(a.physical.sheet.as_ref(), || {
        let m = a.machine.machine()?;
        Ok(Stock::Bed {
            machine: m.name.clone(),
            w_mm: m.bed.width_mm,
            h_mm: m.bed.height_mm,
        })
    })?;
    Ok(tc.map(|tc| stencil_core::tiles::TilesConfig { layers: set, ..tc }))
}

/// Run and write the tiles, then say what was made.
fn make_tiles(cfg: MakeConfig, tc: &stencil_core::tiles::TilesConfig) -> anyhow::Result<ExitCode> {
    let (cfg, result) = with_progress(cfg, |cfg| stencil_core::tiles::make(cfg, tc));
    let (t, replaced) = result.map_err(|e| tiles_error(&cfg, e))?;
    super::tiles::print(&cfg, &t);
    if !replaced.removed.is_empty() {
        println!(
            "removed an earlier run's {} file(s) this run does not write",
            replaced.removed.len()
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// A tiled run's error in `make`'s words (a tiling's own, with what to change; else any
/// stencil's).
pub(super) fn tiles_error(cfg: &MakeConfig, e: stencil_core::Error) -> anyhow::Error {
    match e {
        stencil_core::Error::Tiles(t) => {
            let help = super::tiles::help(&t);
            anyhow::anyhow!("{}: {t} ({help})", cfg.input.display())
        }
        e => make_error(cfg, e),
    }
}

/// `run(cfg)` with the progress line drawn while it runs; `cfg` comes back with it.
fn with_progress<T>(cfg: MakeConfig, run: impl FnOnce(&MakeConfig) -> T) -> (MakeConfig, T) {
    let bar = StageBar::start();
    let cfg = MakeConfig {
        progress: Some(bar.clone()),
        ..cfg
    };
    let result = run(&cfg);
    bar.finish();
    (cfg, result)
}

/// The set `make` cuts instead of one stencil, if any: layers, a fill-in, or registration marks
/// for a mask (every sheet registered).
pub(super) fn set_config(a: &MakeArgs) -> Option<stencil_core::layers::LayersConfig> {
    a.layers.config(mask_marks(a))
}

/// Registration marks on a mask, which cut the sheet's edge (so its margin counts).
fn mask_marks(a: &MakeArgs) -> bool {
    a.output.mask_marks && a.output.emit.contains(&EmitKind::Mask)
}

/// The pipeline's settings from the command line, each option checked in the order given here
/// (the first bad one is the one reported; the mesh's and the bridges' after the size, as
/// always), with the decisions `resolve` makes from the files it needs: read once here, its notes
/// printed; or, for the studio, kept in `kept` while the files stay, the notes not printed.
/// Without --material, a G-code job gets a material set up for the machine's tool.
pub(super) fn make_config(
    a: &MakeArgs,
    mut kept: Option<&mut KeptInputs>,
) -> anyhow::Result<MakeConfig> {
    let emit_gcode = a.output.emit.contains(&EmitKind::Gcode);
    let emit_hpgl = a.output.emit.contains(&EmitKind::Hpgl);
    if emit_gcode && emit_hpgl {
        anyhow::bail!(
            "--emit gcode and hpgl are for different machines (a GRBL machine, a plotter): emit \
             one, and write the other with `stencil gcode` or `stencil hpgl` from the folder"
        );
    }
    // An HP-GL job's plotter, seen as the planner sees machines (for its bed and default material).
    let machine = if emit_hpgl {
        Some(super::hpgl::plotter(&a.machine)?.planner_machine())
    } else {
        emit_gcode.then(|| a.machine.machine()).transpose()?
    };
    let default_material = match &machine {
        Some(m) => stencil_core::material::default_for(&m.tool),
        None => stencil_core::material::DEFAULT_MATERIAL,
    };
    let mut physical = a.physical.to_config(&a.output, default_material)?;
    physical.mask.tone_inverted = a.image.invert;
    let (mesh, bridge) = (a.mesh.to_config(), a.bridge.to_config());
    let request = Request {
        make: MakeConfig {
            out_dir: a.out_dir(),
            input: a.input.clone(),
            tone: a.image.to_config(),
            mesh: mesh.as_ref().ok().cloned().unwrap_or_default(),
            filter: a.filter.to_config(),
            bridge: bridge.as_ref().ok().cloned().unwrap_or_default(),
            places: a.bridge.places(),
            physical,
            ..MakeConfig::default()
        },
        // Tiles fit each tile to the sheet or bed, not the whole picture.
        sheet: a.physical.sheet.clone().filter(|_| !a.tiles.asked()),
        bed: machine
            .as_ref()
            .filter(|_| !a.tiles.asked())
            .map(|m| Stock::Bed {
                machine: m.name.clone(),
                w_mm: m.bed.width_mm,
                h_mm: m.bed.height_mm,
            }),
        margin_counts: a.machine.cut_outline || mask_marks(a),
        ..image_request(&a.image, a.bridge.keep_out.clone())
    };
    let inputs = match kept.as_deref_mut() {
        Some(k) => k.load(&request),
        None => Inputs::load(&request),
    };
    let (notes, cfg) = resolve(&request, &inputs);
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
    // With tiles, --machine alone names the bed they fit.
    let mut machine_args = a.machine.clone();
    if a.tiles.asked() && !emit_gcode && !emit_hpgl {
        machine_args.machine = None;
    }
    let hpgl = super::hpgl::make_hpgl_config(
        &machine_args,
        &a.cut,
        &a.plotter,
        &cfg.physical.material,
        emit_hpgl,
    )?;
    // The machine and cut options are the HP-GL job's when it is asked for.
    let mut gcode = match hpgl {
        Some(_) => None,
        None => super::gcode::make_gcode_config(
            &machine_args,
            &a.cut,
            &cfg.physical.material,
            emit_gcode,
            cfg.physical.vector.arc_tolerance_mm(),
        )?,
    };
    let mut cfg = cfg;
    if let Some(g) = &mut gcode {
        // A gobo is a disc: its rim is always cut, last.
        g.plan.cut_outline |= cfg.physical.gobo.is_some();
        // G-code without arcs (--no-arcs, the machine's profile, a drag knife): the outlines
        // are made straight within the whole tolerance, and every file carries those polygons,
        // the ones the check judges.
        cfg.physical.vector.arcs = g.plan.arc_tolerance_on(&g.machine) > 0.0;
    }
    if hpgl.is_some() {
        // HP-GL is straight segments: the outlines are made straight within the whole
        // tolerance, and every file carries those polygons, as for G-code without arcs.
        cfg.physical.vector.arcs = false;
    }
    Ok(MakeConfig { gcode, hpgl, ..cfg })
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

/// Run and write a set, then say what was made.
pub fn make_set(
    cfg: MakeConfig,
    lc: &LayersConfig,
    fill_in_asked: bool,
) -> anyhow::Result<ExitCode> {
    let (cfg, result) = with_progress(cfg, |cfg| stencil_core::layers::make(cfg, lc));
    let (set, replaced) = result.map_err(|e| make_error(&cfg, e))?;
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
    if let Some(asked) = r.layers_asked {
        println!(
            "the picture has fewer tones than the {asked} layers asked for: {} cut (each layer's paint must differ from the tone under it by {} of lightness or ΔE {}, on {} % of the picture)",
            r.layers.len(),
            stencil_core::layers::MIN_STEP_L,
            stencil_core::layers::MIN_STEP_DELTA_E,
            stencil_core::layers::MIN_TONE_PCT,
        );
    }
    for l in &r.layers {
        let folder = if l.folder.is_empty() { "." } else { &l.folder };
        println!(
            "  {folder}: level {}, paint {}, cuts {:.1} %, {} islands, {} bridges, {} bridge px of which {:.0} % hidden by later layers; longest chain of islands {}{}{}",
            l.level,
            l.color,
            l.cut_pct,
            l.islands,
            l.bridges,
            l.bridge_px,
            l.hidden_pct,
            l.longest_chain,
            if l.dropped_islands > 0 {
                format!(", {} islands painted rather than held", l.dropped_islands)
            } else {
                String::new()
            },
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

/// The level `otsu` or `auto` chose, and how alike the stencil is to the picture.
fn print_threshold(t: Threshold, level: u8, like: f64, choice: Option<&LevelChoice>) {
    match (t, choice) {
        (Threshold::Auto, Some(c)) => println!(
            "threshold: auto chose level {level} (likeness {:.3}; at 128: {:.3}, at Otsu's {}: \
             {:.3})",
            c.likeness, c.likeness_128, c.otsu_level, c.likeness_otsu
        ),
        (Threshold::ByPicture, Some(c)) => println!(
            "threshold: level {level}, the likeliest for a photo (likeness {:.3}; at 128: {:.3}, at \
             Otsu's {}: {:.3}); --threshold sets another",
            c.likeness, c.likeness_128, c.otsu_level, c.likeness_otsu
        ),
        (Threshold::Otsu | Threshold::Auto, _) => {
            println!("threshold: otsu chose level {level} (likeness {like:.3})")
        }
        _ => {}
    }
    if let Some([lo, hi]) = choice.and_then(|c| c.uneven_paper) {
        println!(
            "note: the paper's light varies across the picture ({:.0} % to {:.0} %), as on a page \
             in uneven light, where no one level shows it all: --local-threshold MM compares each \
             pixel with its surroundings instead (try 5)",
            lo * 100.0,
            hi * 100.0
        );
    }
}

/// What a successful run tells: the stencil in one line, its size and files, files of an earlier
/// run it removed, the working scale, the fidelity, long joins, strength, the check, the G-code.
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
    if let (Some(level), Some(like)) = (r.threshold_level, r.likeness) {
        print_threshold(cfg.tone.threshold, level, like, r.threshold_choice.as_ref());
    }
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
    if let Some(p) = made.mesh_parts.filter(|p| p.below_a_pixel > 0) {
        eprintln!(
            "warning: {}: {} of the mesh's {} parts come out smaller than a pixel and leave no \
             mark (a part far from the rest makes the view frame both, so everything shrinks): \
             remove stray parts, or raise the resolution",
            cfg.input.display(),
            p.below_a_pixel,
            p.parts
        );
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
        println!(
            "changed {:.2} % of the picture: {}",
            f.changed_pct,
            change_parts(f)
        );
        if f.changed_pct > WARN_CHANGE_PCT {
            eprintln!(
                "warning: more than {WARN_CHANGE_PCT} % of the picture changed; {}",
                change_hints(cfg)
            );
        }
    }
    print_long_joins(r, cfg.bridge.max_length_px);
    print_no_light_place(r);
    print_strength(r);
    super::check::print_check(&made.check, "report.json lists them all");
    if let Some(g) = &made.report.gcode {
        super::gcode::print_summary(&cfg.out_dir.join("stencil.gcode"), g);
    }
    if let Some(h) = &made.report.hpgl {
        super::hpgl::print_summary(&cfg.out_dir.join("stencil.plt"), h);
    }
    if let Some(g) = &made.report.gobo {
        print_gobo(g);
    }
    if let Some(m) = &made.report.mask {
        print_masks(m, larger_hint(cfg));
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
fn print_masks(m: &stencil_core::export::MaskReport, larger: &str) {
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
             will not be etched; make the picture larger ({larger}) or use a thinner metal",
            m.openings_closed,
            2.0 * m.undercut_compensation_mm
        );
    }
    if let Some(w) = &m.warning {
        eprintln!("warning: {w} (--invert)");
    }
}

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
    if let Some((a, cap)) = auto.and_then(|a| Some((a, a.capped_by?))) {
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
            "note: {:.3} mm working pixels need {}x supersampling, kept to {k}x by {by}; edges \
             may show the picture's pixels ({help})",
            a.target_mm_per_px, a.wanted
        );
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

/// A note when the cut where the bridges can go has no light place: there every way darkens the
/// picture alike, and the bridges take the shortest ones.
fn print_no_light_place(r: &stencil_core::report::Report) {
    if let Some(l) = r
        .bridge_light
        .filter(|l| !l.light_places && !r.bridges.is_empty())
    {
        println!(
            "note: no light place for a bridge: {} of the {} cut pixels the bridges could cross \
             are much lighter than the rest, so every way darkens the picture alike and the \
             bridges take the shortest ones (\"bridge_light\" in report.json)",
            l.light_px, l.near_islands_px
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
    let cfg = resolve_picture(&request, &Inputs::load(&request))
        .map_err(|e| sizing_words(&a.input, e))?;
    let cfg = MakeConfig {
        mesh: a.mesh.to_config()?,
        filter: a.filter.to_config(),
        ..cfg
    };
    let (cfg, result) = with_progress(cfg, stencil_core::driver::clean_two_tone);
    let cleaned = result.map_err(|e| super::errors::naming_input(&cfg.input, e))?;
    let tt = &cleaned.twotone;
    stencil_io::write_atomic(&a.out, &export::png::encode_bits(&tt.bits))
        .with_context(|| format!("writing the two-tone image for {}", a.input.display()))?;
    println!(
        "{}: {}x{} px",
        a.out.display(),
        tt.bits.width,
        tt.bits.height
    );
    print_threshold(
        cfg.tone.threshold,
        cleaned.level,
        cleaned.likeness,
        cleaned.choice.as_ref(),
    );
    Ok(ExitCode::SUCCESS)
}
