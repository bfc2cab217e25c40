//! The library's errors in the words of this command line: the library says what is wrong, with the
//! numbers; here each message gains the option that changes it (`--width-mm`, `-o`,
//! `--allow-thin`...). [`describe`] is what `main` prints for every error and cause.

use std::error::Error as StdError;
use std::path::Path;

use stencil_core::bridge::BridgeError;
use stencil_core::check::CheckError;
use stencil_core::export::ExportError;
use stencil_core::limits::{self, num, FinerFix, SizeError};
use stencil_core::material::SettingsError;
use stencil_core::tone::mesh::{MeshError, MeshSetting};
use stencil_core::tone::ToneError;
use stencil_core::units::{Scale, Size};
use stencil_core::vector::VectorError;
use stencil_gcode::{Fit, PlanError};

/// One error (not its causes) as the user reads it: the library's errors worded with the options
/// that change them, any other error as it displays itself.
pub fn describe(e: &(dyn StdError + 'static)) -> String {
    (e.downcast_ref().map(core))
        .or_else(|| e.downcast_ref().map(size))
        .or_else(|| e.downcast_ref().map(vector))
        .or_else(|| e.downcast_ref().map(export))
        .or_else(|| e.downcast_ref().map(check))
        .or_else(|| e.downcast_ref().map(settings))
        .or_else(|| e.downcast_ref().map(bridge))
        .or_else(|| e.downcast_ref().map(plan))
        .or_else(|| e.downcast_ref().map(tone))
        .or_else(|| e.downcast_ref().map(mesh))
        .unwrap_or_else(|| e.to_string())
}

/// An error and its causes on one line, outermost first, each said once: the line ends at the
/// library's first error, which words its own cause (`{path}: cannot open: {reason}`); a context
/// added here is followed by its cause. (What `main` prints after "error: ", and the studio's
/// API returns.)
pub fn one_line(e: &anyhow::Error) -> String {
    let mut out = Vec::new();
    for cause in e.chain() {
        out.push(describe(cause));
        if words_its_cause(cause) {
            break;
        }
    }
    out.join(": ")
}

/// The library's errors that can have a cause (an io error): each words it into its message.
fn words_its_cause(e: &(dyn StdError + 'static)) -> bool {
    e.is::<stencil_core::Error>()
        || e.is::<ToneError>()
        || e.is::<MeshError>()
        || e.is::<ExportError>()
        || e.is::<stencil_io::ReadError>()
        || e.is::<stencil_io::WriteError>()
        || e.is::<stencil_io::profile::ProfileError>()
}

/// An error of `make`'s pipeline that names the input: as it is when it is about the input (most
/// are, from the stage that read it), else with the input in front.
pub fn naming_input(input: &Path, e: stencil_core::Error) -> anyhow::Error {
    if e.subject() == Some(input) {
        e.into()
    } else {
        anyhow::anyhow!("{}: {}", input.display(), core(&e))
    }
}

/// An error of `make`'s pipeline.
pub fn core(e: &stencil_core::Error) -> String {
    use stencil_core::Error;
    match e {
        Error::Limit(e) => size(e),
        Error::Vector(e) => vector(e),
        Error::Export(e) => export(e),
        Error::Check(e) => check(e),
        Error::Plan(e) => plan(e),
        Error::Bridge(e) => bridge(e),
        Error::Tone(e) => tone(e),
        Error::KeepOut(e) => tone(e),
        Error::Thin { .. } => format!(
            "{e}; widen the design, choose another --material, or pass --allow-thin to write the \
             outputs anyway"
        ),
        e => e.to_string(),
    }
}

/// The option that set the picture's size, and its value (`None` for the default size).
fn size_flag(size: Size) -> Option<(&'static str, f64)> {
    match size {
        Size::Default => None,
        Size::WidthMm(v) => Some(("--width-mm", v)),
        Size::Dpi(v) => Some(("--dpi", v)),
    }
}

/// The option that set the picture's size, with its value.
fn size_option(size: Size) -> String {
    size_flag(size).map_or("the default size".into(), |(f, v)| {
        format!("{f} {}", num(v))
    })
}

fn size(e: &SizeError) -> String {
    match *e {
        SizeError::NotPositive { size } => match size_flag(size) {
            Some((option, value)) => {
                format!("{option} {value} is not a size: use a finite number > 0")
            }
            None => e.to_string(),
        },
        SizeError::OutOfRange {
            size,
            width_px,
            height_px,
            width_mm,
            height_mm,
            mm_per_px,
            range,
        } => {
            let option = match size {
                Size::Default => format!(
                    "the default size of {} mm per pixel",
                    Scale::default().mm_per_px
                ),
                _ => size_option(size),
            };
            let accepted = match (size_flag(size), range) {
                (Some((flag, _)), Some((lo, hi))) => {
                    format!("use {flag} {} to {} for this picture", num(lo), num(hi))
                }
                (None, Some((lo, hi))) => {
                    format!(
                        "give --width-mm {} to {} for this picture",
                        num(lo),
                        num(hi)
                    )
                }
                (_, None) => "no size fits a picture of this shape: crop or resize it".to_string(),
            };
            format!(
                "{option} makes the {width_px}x{height_px} px picture {} x {} mm with pixels of {} \
                 mm; {}; {accepted}",
                num(width_mm),
                num(height_mm),
                num(mm_per_px),
                limits::out_of_range_reason(mm_per_px)
            )
        }
        SizeError::TooFine {
            size,
            factor,
            mm_per_px,
            feature_mm,
            feature_px,
            fix,
        } => {
            let (option, fix) = match fix {
                FinerFix::ScaleAtMost(k) => (
                    format!("--scale {factor}"),
                    format!("use --scale {k} or less"),
                ),
                FinerFix::DpiAtMost(d) => (
                    size_option(size),
                    format!(
                        "use --dpi {} or less (or a picture with fewer pixels)",
                        num(d)
                    ),
                ),
                FinerFix::WidthMmAtLeast(w) => (
                    size_option(size),
                    format!(
                        "use --width-mm {} or more (or a picture with fewer pixels)",
                        num(w)
                    ),
                ),
            };
            format!(
                "{option}: working pixels of {} mm make the material's smallest feature \
                 ({feature_mm} mm) {} pixels wide, more than the {} stencil works with (the \
                 clean-up's time grows with its square); {fix}",
                num(mm_per_px),
                num(feature_px),
                limits::MAX_PX_PER_FEATURE
            )
        }
        SizeError::FilterRadius {
            radius,
            width,
            height,
            max,
        } => format!(
            "--filter-radius {radius} is larger than this {width}x{height} px working image \
             allows: use 0..={max} (a quarter of its shorter side)"
        ),
    }
}

fn vector(e: &VectorError) -> String {
    match e {
        VectorError::Tolerance(v) => {
            format!("--tolerance-mm must be a finite number >= 0, got {v}")
        }
        VectorError::Margin(v) => format!(
            "--margin-mm must be a finite number > 0 (the sheet continues beyond the picture), \
             got {v}"
        ),
        e => e.to_string(),
    }
}

fn export(e: &ExportError) -> String {
    match e {
        ExportError::CreateDir { .. } => format!("{e}; choose another with -o"),
        ExportError::MaskDpi(dpi) => {
            format!("mask.png: cannot encode: --mask-dpi must be > 0, got {dpi}")
        }
        ExportError::MaskTooLarge { .. } => format!("{e}; lower --mask-dpi"),
        e => e.to_string(),
    }
}

fn check(e: &CheckError) -> String {
    match e {
        CheckError::Coordinate {
            x_mm,
            y_mm,
            problem,
        } => format!(
            "the width check cannot triangulate the outline: its point ({x_mm}, {y_mm}) mm is \
             {problem}; check the size (--width-mm, --dpi, --margin-mm)"
        ),
        e => e.to_string(),
    }
}

fn settings(e: &SettingsError) -> String {
    match e {
        SettingsError::EtchOnly { .. } => {
            format!("{e}; use --emit mask, or choose a laser, knife or pen material")
        }
        SettingsError::WrongTool {
            tool, suggested, ..
        } => format!(
            "{e}; choose a matching --material (for a {tool}: {suggested}, or see `stencil \
             profiles`) or --machine, or give --power, --speed and --passes"
        ),
        SettingsError::NoSettings {
            material, machine, ..
        } => format!(
            "{e}. Nothing was written. Find settings with `stencil test-grid --machine {machine} \
             --material {material}`, cut it, and keep the best square's with `stencil profiles \
             set {material} --machine {machine} --power P --speed S`; or give --power and \
             --speed for this job (`stencil profiles` lists which materials have settings for \
             which machine)"
        ),
    }
}

/// A size that does not fit, with the options that change it.
pub fn fit(e: &stencil_core::fit::FitError) -> String {
    use stencil_core::fit::FitError;
    match e {
        FitError::TooLarge {
            margin_mm,
            largest_width_mm,
            ..
        } => {
            let margin = if *margin_mm > 0.0 {
                ", or a smaller --margin-mm (it counts: the sheet's edge is cut or marked)"
            } else {
                " (--margin-mm does not count: nothing is cut at the sheet's edge)"
            };
            format!(
                "{e}: give --width-mm {} or less{margin}; nothing was done",
                (largest_width_mm * 10.0).floor() / 10.0
            )
        }
        FitError::MarginTooLarge { .. } => format!("{e}: give a smaller --margin-mm"),
    }
}

/// A planning error in the words of the command line: the library says what to change, this adds
/// the option that changes it.
pub fn plan(e: &PlanError) -> String {
    let hint = match e {
        PlanError::Empty => {
            return "nothing to cut: the geometry has no cut regions (and --cut-outline is off)"
                .into()
        }
        PlanError::DoesNotFit { fix: Fit::Move, .. } => " with --offset X,Y or --origin",
        PlanError::OpenPaths { .. } => {
            " with --cut-open-paths, or draw them with a pen (--machine pen-a3)"
        }
        PlanError::DoesNotFit {
            fix: Fit::ShrinkGrid,
            ..
        } => " (--size, --gap, --offset)",
        _ => "",
    };
    format!("{e}{hint}")
}

/// A bridge stage error, with the options that set what it names.
fn bridge(e: &BridgeError) -> String {
    match e {
        BridgeError::KeptOut { .. } => {
            format!("{e} (--keep-out, --no-bridge-near, --min-island-mm2)")
        }
        e => e.to_string(),
    }
}

/// Reading the picture or rendering the mesh: the pixel limit is --max-pixels, the factor --scale.
fn tone(e: &ToneError) -> String {
    match e {
        ToneError::TooLarge {
            path,
            width,
            height,
            mp,
            limit_mp,
        } => format!(
            "{}: {width}x{height} pixels ({mp:.1} megapixels) is above the limit of {limit_mp:.1} \
             megapixels; downscale the image or raise --max-pixels (at most {})",
            path.display(),
            limits::MAX_PIXELS_CEILING
        ),
        ToneError::TooMuchMemory {
            path,
            width,
            height,
            gb,
            limit_gb,
        } => format!(
            "{}: {width}x{height} pixels would need {gb:.1} GB to decode, more than the \
             {limit_gb:.1} GB stencil allows whatever --max-pixels says; downscale the image",
            path.display()
        ),
        ToneError::BadScale(k) => format!("--scale {k} is out of range: use 1 to 8"),
        ToneError::ScaleTooLarge {
            path,
            factor,
            width,
            height,
            mp,
            limit_mp,
        } => format!(
            "{}: --scale {factor} makes {width}x{height} working pixels ({mp:.1} megapixels), \
             above the limit of {limit_mp:.1} megapixels; lower --scale (or leave it out to let \
             stencil choose) or raise --max-pixels",
            path.display()
        ),
        ToneError::Mesh(e) => mesh(e),
        e => e.to_string(),
    }
}

fn mesh(e: &MeshError) -> String {
    match e {
        MeshError::Setting(s) => mesh_setting(s),
        e => e.to_string(),
    }
}

/// A render setting with the option that sets it.
fn mesh_setting(s: &MeshSetting) -> String {
    match *s {
        MeshSetting::View {
            azimuth_deg,
            elevation_deg,
        } => format!(
            "--view: {azimuth_deg},{elevation_deg} is not a view: azimuth any finite angle, \
             elevation -90..90 degrees"
        ),
        MeshSetting::Distance(d) => format!(
            "--distance: {d} must be above 1 and at most 1000 bounding radii (the camera stays \
             outside the model)"
        ),
        MeshSetting::Fov(f) => {
            format!("--fov: {f} degrees is not a lens: use 0.5..170 or --ortho")
        }
        MeshSetting::TooSmall { width, height } => {
            format!("--size: {width}x{height} is too small: at least 16 pixels a side")
        }
        MeshSetting::Supersample(k) => out_of_range("--supersample", k, "1 to 4"),
        MeshSetting::TooMuchWork {
            width,
            height,
            supersample,
            megapixels,
            limit_megapixels,
        } => format!(
            "--size: {width}x{height} at --supersample {supersample} is {megapixels:.0} \
             megapixels of work, above the limit of {limit_megapixels:.0}: lower --size or \
             --supersample"
        ),
        MeshSetting::Light(l) => {
            format!("--light: {l:?} must be three finite numbers (bounding radii)")
        }
        MeshSetting::Specular(v) => out_of_range("--specular", v, "0 (matte) to 10"),
        MeshSetting::Ambient(v) => {
            out_of_range("--ambient", v, "0 (none) up to but not including 1")
        }
        MeshSetting::Fill(v) => {
            out_of_range("--fill", v, "0 (none) to 1 (as strong as the key light)")
        }
        MeshSetting::Shininess(v) => out_of_range("--shininess", v, "1 to 10000"),
        MeshSetting::LinePx(v) => out_of_range("--line-px", v, "0.5 to 64 pixels"),
        MeshSetting::ContourThreshold(v) => {
            format!("--contour-threshold: {v} must be a finite number >= 0")
        }
    }
}

/// `--option: VALUE is out of range: use RANGE`.
fn out_of_range(option: &str, v: impl std::fmt::Display, range: &str) -> String {
    format!("{option}: {v} is out of range: use {range}")
}

/// A time as "2026-11-26 17:03 UTC" (no time zone database: the civil date from the day count,
/// after Howard Hinnant's `civil_from_days`).
pub fn utc(t: std::time::SystemTime) -> String {
    let s = t
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() as i64);
    let (days, secs) = (s.div_euclid(86_400), s.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02} UTC",
        secs / 3600,
        secs % 3600 / 60
    )
}

/// `--crop` reaching outside the picture (all in mm at the size the picture is made).
pub fn crop_outside(crop: [f64; 4], picture_mm: [f64; 2], mm_per_px: f64) -> String {
    format!(
        "--crop {},{},{},{}: the rectangle reaches outside the picture, which is {:.1} x {:.1} mm \
         at this size ({mm_per_px:.3} mm per pixel); give X,Y,W,H within it (or change \
         --width-mm / --dpi, which set the size the crop is measured at)",
        num(crop[0]),
        num(crop[1]),
        num(crop[2]),
        num(crop[3]),
        picture_mm[0],
        picture_mm[1]
    )
}

/// A failed `make` in full: the error, then what the output folder holds. The earlier run's files
/// are moved into `previous/` ([`stencil_io::set_aside`]) so that `send` cannot stream them as
/// this run's job; the message says which files, from when, and where they are. A run refused
/// because another run is writing the folder leaves that run's files alone.
pub fn after_failed_make(dir: &Path, e: anyhow::Error) -> anyhow::Error {
    use stencil_io::WriteError;
    let busy = |w: &WriteError| matches!(w, WriteError::Busy { .. });
    let is_busy = e.chain().any(|c| {
        c.downcast_ref::<WriteError>().is_some_and(busy)
            || matches!(
                c.downcast_ref::<stencil_core::Error>(),
                Some(stencil_core::Error::Export(ExportError::Write(w))) if busy(w)
            )
    });
    if is_busy {
        return e;
    }
    let note = match stencil_io::set_aside(dir, stencil_core::layers::owned_names()) {
        Ok(None) => return e,
        Ok(Some(s)) => format!(
            "nothing of this run was written; the earlier run's files in {} ({}{}) were moved to \
             {}/ so that they are not taken for this run's result",
            dir.display(),
            s.names.join(", "),
            s.made
                .map_or(String::new(), |t| format!(", made {}", utc(t))),
            s.into.display()
        ),
        Err(w) => format!(
            "nothing of this run was written; {} still holds an earlier run's files, which are \
             not this run's result (moving them aside failed: {w})",
            dir.display()
        ),
    };
    anyhow::anyhow!("{}; {note}", one_line(&e))
}

/// A size refused in a gobo's `make`, in the words of `--gobo`: the picture's size came from the
/// gobo's image area (--gobo excludes --width-mm, which the size error would otherwise advise),
/// so the advice is the image areas that work for this picture. `None` for an error the gobo's
/// size did not cause (its wording is right as it is).
pub fn gobo_size(input: &Path, g: &stencil_core::gobo::Gobo, e: &SizeError) -> Option<String> {
    let (pixel_mm, problem, least_width_mm) = match e {
        SizeError::OutOfRange {
            size: Size::WidthMm(_),
            mm_per_px,
            range,
            ..
        } => (
            *mm_per_px,
            limits::out_of_range_reason(*mm_per_px),
            range.map(|(lo, _)| lo),
        ),
        SizeError::TooFine {
            size: Size::WidthMm(_),
            mm_per_px,
            feature_mm,
            feature_px,
            fix: FinerFix::WidthMmAtLeast(w),
            ..
        } => (
            *mm_per_px,
            format!(
                "that makes the material's smallest feature ({feature_mm} mm) {} pixels wide, \
                 more than the {} stencil works with",
                num(*feature_px),
                limits::MAX_PX_PER_FEATURE
            ),
            Some(*w),
        ),
        _ => return None,
    };
    let given = match &g.letter {
        Some(l) => l.clone(),
        None => format!("{},{}", num(g.od_mm), num(g.ia_mm)),
    };
    let (w, h) = stencil_core::tone::picture_size(input).ok()?;
    // Image area per mm of the picture's width, as the gobo places it.
    let ia_per_mm = g.ia_mm / g.picture_width_mm(w, h);
    let max_od = stencil_core::gobo::MAX_OD_MM;
    let fix = match least_width_mm.map(|lo| lo * ia_per_mm) {
        Some(ia) if ia < max_od => {
            // Rounded up to 4 significant digits, so that the value printed works.
            let p = 10f64.powi(3 - ia.log10().floor() as i32);
            let ia = (ia * p).ceil() / p;
            format!(
                "give --gobo OD,IA with an image area IA of at least {} mm (and an outside \
                 diameter OD above IA, at most {} mm), or use a picture with fewer pixels",
                num(ia),
                num(max_od)
            )
        }
        _ => format!(
            "no gobo up to {} mm fits this picture: use a picture with fewer pixels",
            num(max_od)
        ),
    };
    Some(format!(
        "{}: --gobo {given}{}: the {} mm image area makes the {w}x{h} px picture's pixels {} mm; \
         {problem}; {fix}",
        input.display(),
        if g.crop { " --gobo-crop" } else { "" },
        num(g.ia_mm),
        num(pixel_mm),
    ))
}

#[cfg(test)]
mod time_tests {
    #[test]
    fn utc_dates() {
        let t = |s: u64| super::utc(std::time::UNIX_EPOCH + std::time::Duration::from_secs(s));
        assert_eq!(t(0), "1970-01-01 00:00 UTC");
        assert_eq!(t(951_782_400), "2000-02-29 00:00 UTC");
        assert_eq!(t(1_795_700_000), "2026-11-26 13:33 UTC");
    }
}
