//! The width and connectivity check: thin bridges, webs and holes are flagged at the right place
//! with the right width; proper ones pass; the raster opening agrees.

use std::path::Path;
use std::process::Command;

use stencil_core::check::{CheckReport, ViolationKind};
use stencil_core::material::Material;
use stencil_core::pipeline::{self, Timings};
use stencil_core::raster::BitGrid;
use stencil_core::vector::VectorConfig;

const MM: f64 = 0.1; // mm per pixel in every fixture
const PX: f64 = MM; // "within a pixel"

fn rect(x0: u32, y0: u32, x1: u32, y1: u32) -> impl Fn(u32, u32) -> bool {
    move |x, y| x >= x0 && x < x1 && y >= y0 && y < y1
}

/// Frame, a cut ring around an island, and a horizontal bridge `w` px wide from the island's right
/// side (x = 130) to the cut's right edge (x = 160), centred on y = 80.
fn bridged(w: u32) -> BitGrid {
    let cut = rect(40, 30, 160, 130);
    let island = rect(70, 60, 130, 100);
    let bridge = rect(130, 80 - w / 2, 160, 80 - w / 2 + w);
    BitGrid::from_fn(200, 160, |x, y| !cut(x, y) || island(x, y) || bridge(x, y))
}

/// Two rectangular holes separated by a web `w` px wide starting at x = 90.
fn web(w: u32) -> BitGrid {
    let a = rect(40, 40, 90, 120);
    let b = rect(90 + w, 40, 150, 120);
    BitGrid::from_fn(200, 160, |x, y| !(a(x, y) || b(x, y)))
}

fn check(bits: &BitGrid, material: &str) -> CheckReport {
    let (m, _) = Material::find(material).unwrap();
    let vcfg = VectorConfig {
        scale: stencil_core::units::Scale { mm_per_px: MM },
        kerf_mm: m.kerf_mm,
        ..Default::default()
    };
    let (_, _, c) =
        pipeline::vectorize_and_check(bits, None, &vcfg, &m, &mut Timings::default()).unwrap();
    c
}

#[test]
fn a_thin_bridge_is_flagged_where_it_is_and_as_wide_as_it_is() {
    let c = check(&bridged(6), "cardstock");
    assert!(!c.passed());
    assert_eq!(c.violations.len(), 1, "{:#?}", c.violations);
    let v = &c.violations[0];
    assert_eq!(v.kind, ViolationKind::ThinBridge);
    let w = v.width_mm.unwrap();
    assert!((w - 0.6).abs() <= PX, "width {w}");
    assert!(v.x_mm >= 13.0 - PX && v.x_mm <= 16.0 + PX, "x {}", v.x_mm);
    assert!((v.y_mm - 8.0).abs() <= PX, "y {}", v.y_mm);
    assert_eq!(v.required_mm, 1.0);
    assert_eq!(v.confirmed_by_opening, Some(true));
}

#[test]
fn the_same_stencil_with_a_proper_bridge_passes() {
    let c = check(&bridged(12), "cardstock");
    assert!(c.passed(), "{:#?}", c.violations);
    let b = c.narrowest_bridge_mm.unwrap();
    assert!((b - 1.2).abs() <= PX, "narrowest bridge {b}");
    // A stricter material fails the same bridge.
    let c = check(&bridged(12), "mylar-0.19");
    assert_eq!(
        c.violations
            .iter()
            .filter(|v| v.kind == ViolationKind::ThinBridge)
            .count(),
        1
    );
}

#[test]
fn a_thin_web_is_flagged_and_a_proper_one_passes() {
    let c = check(&web(3), "cardstock");
    let webs: Vec<_> = c
        .violations
        .iter()
        .filter(|v| v.kind == ViolationKind::ThinWeb)
        .collect();
    assert_eq!(webs.len(), 1, "{:#?}", c.violations);
    let v = webs[0];
    assert!((v.width_mm.unwrap() - 0.3).abs() <= PX, "{v:?}");
    assert!((v.x_mm - 9.15).abs() <= PX, "{v:?}");
    assert!(v.y_mm >= 4.0 - PX && v.y_mm <= 12.0 + PX, "{v:?}");
    assert_eq!(v.required_mm, 0.5);
    assert_eq!(v.confirmed_by_opening, Some(true));
    let c = check(&web(6), "cardstock");
    assert!(c.passed(), "{:#?}", c.violations);
    assert!((c.narrowest_web_mm.unwrap() - 0.6).abs() <= PX);
}

#[test]
fn a_thin_hole_is_flagged() {
    let slot = rect(40, 50, 100, 53);
    let bits = BitGrid::from_fn(160, 120, |x, y| !slot(x, y));
    let c = check(&bits, "cardstock");
    assert_eq!(c.violations.len(), 1, "{:#?}", c.violations);
    let v = &c.violations[0];
    assert_eq!(v.kind, ViolationKind::ThinHole);
    assert!((v.width_mm.unwrap() - 0.3).abs() <= PX, "{v:?}");
    assert!(
        (v.y_mm - 5.15).abs() <= PX && v.x_mm > 4.0 && v.x_mm < 10.0,
        "{v:?}"
    );
}

#[test]
fn a_floating_island_is_flagged() {
    let cut = rect(40, 30, 160, 130);
    let island = rect(70, 60, 130, 100);
    let bits = BitGrid::from_fn(200, 160, |x, y| !cut(x, y) || island(x, y));
    let c = check(&bits, "cardstock");
    assert_eq!(c.pieces, 2);
    let f: Vec<_> = c
        .violations
        .iter()
        .filter(|v| v.kind == ViolationKind::Floating)
        .collect();
    assert_eq!(f.len(), 1);
    assert!(
        f[0].x_mm >= 7.0 - PX
            && f[0].x_mm <= 13.0 + PX
            && f[0].y_mm >= 6.0 - PX
            && f[0].y_mm <= 10.0 + PX,
        "{:?}",
        f[0]
    );
}

fn write_png(path: &Path, bits: &BitGrid) {
    std::fs::write(path, stencil_core::export::png::encode_bits(bits)).unwrap();
}

fn run(args: &[&str]) -> (bool, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_stencil"))
        .args(args)
        .output()
        .unwrap();
    (
        o.status.success(),
        format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        ),
    )
}

#[test]
fn check_command_exit_code_follows_the_violations() {
    let dir = tempfile::tempdir().unwrap();
    let thin = dir.path().join("thin.png");
    let good = dir.path().join("good.png");
    write_png(&thin, &bridged(6));
    write_png(&good, &bridged(12));
    let (ok, out) = run(&["check", thin.to_str().unwrap(), "--material", "cardstock"]);
    assert!(!ok, "{out}");
    assert!(out.contains("thin bridge at ("), "{out}");
    let (ok, out) = run(&["check", good.to_str().unwrap(), "--material", "cardstock"]);
    assert!(ok, "{out}");
}

/// A 1-px checkerboard at 1000 x 1000 (a picture `make` accepts) took over 20 s and 1.1 GB to
/// check; it breaks into a million pieces, over the limit, and is refused at once naming it.
#[test]
fn check_of_a_picture_in_a_million_pieces_is_refused_naming_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("checker.png");
    let bits = BitGrid {
        width: 1000,
        height: 1000,
        data: (0..1000 * 1000)
            .map(|i| (i % 1000 + i / 1000) % 2 == 0)
            .collect(),
    };
    write_png(&p, &bits);
    let (ok, out) = run(&["check", p.to_str().unwrap()]);
    assert!(!ok, "{out}");
    assert!(
        out.contains("checker.png")
            && out.contains("500000 separate pieces of material and 500000 of cut")
            && out.contains(&stencil_core::check::MAX_CHECK_PIECES.to_string()),
        "{out}"
    );
}

#[test]
fn check_on_an_output_folder_uses_the_material_of_its_report() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("web.png");
    write_png(&input, &web(10)); // 1.0 mm web: fine for cardstock, too thin for plywood (1.5 mm)
    let out = dir.path().join("out");
    let (ok, text) = run(&["make", input.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(ok, "{text}");
    let report: stencil_core::report::Report =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report.material.as_deref(), Some("cardstock"));
    assert!(report.check.as_ref().unwrap().passed());
    let (ok, text) = run(&["check", out.to_str().unwrap()]);
    assert!(ok && text.contains("'cardstock'"), "{text}");
    let (ok, text) = run(&["check", out.to_str().unwrap(), "--material", "plywood-3mm"]);
    assert!(!ok && text.contains("thin web"), "{text}");
}

/// `stencil check` of a folder judges the outlines the folder's files hold, as `make` judged
/// them: for a G-code job without arcs (`--no-arcs`), the straight outlines, not the arcs' finer
/// flattening (what it judged before report.json said which). Its findings are make's, with and
/// without arcs.
#[test]
fn check_on_a_folder_judges_the_outlines_make_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let input = Path::new(env!("CARGO_MANIFEST_DIR")).join("samples/grace_hopper.jpg");
    for arcs in [false, true] {
        let out = dir.path().join(format!("arcs-{arcs}"));
        let mut args = vec![
            "make",
            input.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--width-mm",
            "60",
            "--emit",
            "png,svg,gcode",
        ];
        if !arcs {
            args.push("--no-arcs");
        }
        let (ok, text) = run(&args);
        assert!(ok, "{text}");
        let report: stencil_core::report::Report =
            serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
        assert_eq!(report.arcs, Some(arcs));
        let made = report.check.unwrap();
        let o = Command::new(env!("CARGO_BIN_EXE_stencil"))
            .args(["check", out.to_str().unwrap(), "--json"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let checked: CheckReport = serde_json::from_slice(&o.stdout).unwrap();
        for (what, m, c) in [
            (
                "bridge",
                made.narrowest_bridge_mm,
                checked.narrowest_bridge_mm,
            ),
            ("web", made.narrowest_web_mm, checked.narrowest_web_mm),
            ("hole", made.narrowest_hole_mm, checked.narrowest_hole_mm),
        ] {
            // The folder's size comes back from report.json's mm per pixel: the same to a
            // rounding of the last bit.
            let (m, c) = (m.unwrap(), c.unwrap());
            assert!(
                (m - c).abs() < 1e-9 * m,
                "arcs {arcs}: narrowest {what} {m} vs {c}"
            );
        }
        assert_eq!(made.pieces, checked.pieces);
        assert_eq!(made.violations.len(), checked.violations.len());
    }
}

/// `check PICTURE.png` says the scale it judged at: the PNG's own resolution when it states one,
/// else 0.1 mm per pixel, said to be assumed (issue 42 item 4).
#[test]
fn a_bare_picture_is_checked_at_its_own_resolution_or_says_what_it_assumed() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (120u32, 80u32);
    let data: Vec<u8> = (0..w * h)
        .map(|i| if (i % w) / 30 % 2 == 0 { 0 } else { 255 })
        .collect();
    let write = |name: &str, dpm: Option<u32>| {
        let path = dir.path().join(name);
        let mut enc = png::Encoder::new(std::fs::File::create(&path).unwrap(), w, h);
        enc.set_color(png::ColorType::Grayscale);
        if let Some(p) = dpm {
            enc.set_pixel_dims(Some(png::PixelDimensions {
                xppu: p,
                yppu: p,
                unit: png::Unit::Meter,
            }));
        }
        enc.write_header().unwrap().write_image_data(&data).unwrap();
        path
    };
    let first_line = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_stencil"))
            .args(args)
            .output()
            .unwrap();
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .next()
            .unwrap_or("")
            .to_string()
    };
    // 300 dpi is 11811 pixels per metre: 0.0847 mm per pixel.
    let dpi300 = write("dpi300.png", Some(11811));
    let line = first_line(&["check", dpi300.to_str().unwrap()]);
    assert!(
        line.contains("120x80 px at 0.0847 mm/px (the PNG's own resolution, 300 dpi)"),
        "{line}"
    );
    let bare = write("bare.png", None);
    let line = first_line(&["check", bare.to_str().unwrap()]);
    assert!(
        line.contains("at 0.1000 mm/px (assumed: the picture states no resolution; give --dpi"),
        "{line}"
    );
    // Given a size, that is the scale, and nothing is said of where it came from.
    let line = first_line(&["check", dpi300.to_str().unwrap(), "--dpi", "100"]);
    assert!(line.ends_with("at 0.2540 mm/px"), "{line}");
}
