//! End to end: the SVG, rasterised, matches stencil.png; the DXF reads back as closed polylines in
//! mm with as many loops as the SVG; the etch mask has the right size and its switches work.

use std::path::{Path, PathBuf};

use resvg::tiny_skia;
use resvg::usvg;
use stencil_core::pipeline::{self, Emit, MakeConfig, PhysicalConfig};
use stencil_core::raster::BitGrid;
use stencil_core::report::Report;

/// Deterministic pseudo-random numbers (xorshift), so the pictures are the same on every run.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A picture with dark (cut) discs, ellipses and rotated bars on white, none enclosing material,
/// so it needs no bridges.
fn picture(seed: u64, w: u32, h: u32) -> BitGrid {
    let mut r = Rng(seed);
    let mut shapes: Vec<(f64, f64, f64, f64, f64)> = Vec::new(); // cx, cy, a, b, angle
    for _ in 0..200 {
        if shapes.len() == 14 {
            break;
        }
        let (a, b) = (8.0 + 30.0 * r.next(), 4.0 + 20.0 * r.next());
        let (cx, cy) = (
            a + 10.0 + (w as f64 - 2.0 * a - 20.0) * r.next(),
            a + 10.0 + (h as f64 - 2.0 * a - 20.0) * r.next(),
        );
        let ang = r.next() * std::f64::consts::PI;
        // Keep shapes apart by more than the filter can merge.
        if shapes
            .iter()
            .all(|s| ((s.0 - cx).powi(2) + (s.1 - cy).powi(2)).sqrt() > s.2 + a + 14.0)
        {
            shapes.push((cx, cy, a, b, ang));
        }
    }
    BitGrid::from_fn(w, h, |x, y| {
        let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
        !shapes.iter().any(|&(cx, cy, a, b, t)| {
            let (dx, dy) = (px - cx, py - cy);
            let u = dx * t.cos() + dy * t.sin();
            let v = -dx * t.sin() + dy * t.cos();
            (u / a).powi(2) + (v / b).powi(2) <= 1.0
        })
    })
}

/// The inputs: every PNG in samples/ (when the lead has added them), plus generated pictures.
fn inputs(dir: &Path) -> Vec<PathBuf> {
    let mut v = Vec::new();
    let samples = Path::new(env!("CARGO_MANIFEST_DIR")).join("samples");
    if let Ok(rd) = std::fs::read_dir(&samples) {
        for e in rd.flatten() {
            let p = e.path();
            if p.extension().is_some_and(|x| x.eq_ignore_ascii_case("png")) {
                v.push(p);
            }
        }
    }
    v.sort();
    for (i, (w, h)) in [(300u32, 220u32), (260, 260), (400, 180)]
        .into_iter()
        .enumerate()
    {
        let p = dir.join(format!("gen{i}.png"));
        std::fs::write(
            &p,
            stencil_core::export::png::encode_bits(&picture(7 + i as u64, w, h)),
        )
        .unwrap();
        v.push(p);
    }
    v
}

fn make(input: &Path, out: &Path, phys: PhysicalConfig) -> Report {
    let cfg = MakeConfig {
        input: input.to_path_buf(),
        out_dir: out.to_path_buf(),
        physical: PhysicalConfig {
            allow_thin: true,
            ..phys
        },
        ..Default::default()
    };
    stencil_core::driver::make(&cfg).unwrap_or_else(|e| panic!("{}: {e}", input.display()));
    serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap()
}

fn load_png_bits(p: &Path) -> BitGrid {
    let img = image::open(p).unwrap().to_luma8();
    BitGrid::from_u8(img.width(), img.height(), img.as_raw())
}

/// Rasterise the SVG's picture area at one pixel per working pixel: true = cut (black).
fn rasterise_svg(svg: &[u8], r: &Report) -> BitGrid {
    let tree = usvg::Tree::from_data(svg, &usvg::Options::default()).unwrap();
    let mm = r.mm_per_px.unwrap();
    let m_px = r.margin_mm.unwrap() / mm;
    let sheet_px = r.width_px as f64 + 2.0 * m_px;
    let s = sheet_px as f32 / tree.size().width();
    let mut pix = tiny_skia::Pixmap::new(r.width_px, r.height_px).unwrap();
    let t = tiny_skia::Transform::from_row(s, 0.0, 0.0, s, -m_px as f32, -m_px as f32);
    resvg::render(&tree, t, &mut pix.as_mut());
    BitGrid {
        width: r.width_px,
        height: r.height_px,
        data: pix
            .pixels()
            .iter()
            .map(|p| p.alpha() >= 128 && p.red() < 128 && p.blue() < 128)
            .collect(),
    }
}

fn iou(a: &BitGrid, b: &BitGrid) -> f64 {
    let (mut i, mut u) = (0usize, 0usize);
    for (x, y) in a.data.iter().zip(&b.data) {
        i += (*x && *y) as usize;
        u += (*x || *y) as usize;
    }
    if u == 0 {
        1.0
    } else {
        i as f64 / u as f64
    }
}

fn svg_cut_loops(svg: &str) -> usize {
    let start = svg.find("<g id=\"cut\"").unwrap();
    let end = start + svg[start..].find("</g>").unwrap();
    svg[start..end].matches('M').count()
}

fn phys(emit: Emit) -> PhysicalConfig {
    PhysicalConfig {
        emit,
        ..Default::default()
    }
}

const ALL: Emit = Emit {
    png: true,
    svg: true,
    dxf: true,
    mask: false,
};

#[test]
fn svg_matches_stencil_png_and_dxf_matches_svg() {
    let dir = tempfile::tempdir().unwrap();
    for input in inputs(dir.path()) {
        let out = dir.path().join(input.file_stem().unwrap());
        let r = make(&input, &out, phys(ALL));
        let png = load_png_bits(&out.join("stencil.png"));
        let cut_png = BitGrid {
            data: png.data.iter().map(|b| !b).collect(),
            ..png.clone()
        };
        let svg = std::fs::read(out.join("stencil.svg")).unwrap();
        let cut_svg = rasterise_svg(&svg, &r);
        let score = iou(&cut_png, &cut_svg);
        assert!(score >= 0.99, "{}: IoU {score}", input.display());
        // The SVG says its size in mm, with a matching viewBox.
        let text = String::from_utf8(svg).unwrap();
        let sheet_w = r.width_mm.unwrap() + 2.0 * r.margin_mm.unwrap();
        assert!((svg_width_mm(&text) - sheet_w).abs() < 1e-4, "{text:.300}");
        assert!(text.contains("fill-rule=\"evenodd\"") && text.contains("inkscape:label=\"CUT\""));

        // DXF: closed LWPOLYLINEs only, mm, same number of cut loops.
        let loops = svg_cut_loops(&text);
        assert!(loops > 0);
        let d = dxf::Drawing::load_file(out.join("stencil.dxf")).unwrap();
        assert_eq!(d.header.version, dxf::enums::AcadVersion::R2000);
        assert_eq!(
            d.header.default_drawing_units,
            dxf::enums::Units::Millimeters
        );
        assert_eq!(d.header.drawing_units, dxf::enums::DrawingUnits::Metric);
        let mut cut = 0;
        for e in d.entities() {
            match &e.specific {
                dxf::entities::EntityType::LwPolyline(p) => {
                    assert!(p.is_closed(), "open polyline on {}", e.common.layer);
                    for v in &p.vertices {
                        assert!(
                            v.x >= -1e-6 && v.x <= sheet_w + 1e-6,
                            "x {} outside the sheet",
                            v.x
                        );
                    }
                    if e.common.layer == "CUT" {
                        cut += 1;
                    } else {
                        assert_eq!(e.common.layer, "OUTLINE");
                    }
                }
                other => panic!("unexpected entity {other:?}"),
            }
        }
        assert_eq!(cut, loops, "{}", input.display());
    }
}

#[test]
fn dxf_r12_writes_closed_polylines_with_the_same_loops() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.png");
    std::fs::write(
        &input,
        stencil_core::export::png::encode_bits(&picture(3, 240, 200)),
    )
    .unwrap();
    let out = dir.path().join("o");
    make(
        &input,
        &out,
        PhysicalConfig {
            dxf_r12: true,
            ..phys(ALL)
        },
    );
    let text = std::fs::read_to_string(out.join("stencil.svg")).unwrap();
    let d = dxf::Drawing::load_file(out.join("stencil.dxf")).unwrap();
    assert_eq!(d.header.version, dxf::enums::AcadVersion::R12);
    let mut cut = 0;
    for e in d.entities() {
        match &e.specific {
            dxf::entities::EntityType::Polyline(p) => {
                assert!(p.is_closed());
                assert!(p.vertices().count() >= 3);
                cut += (e.common.layer == "CUT") as usize;
            }
            other => panic!("unexpected entity {other:?}"),
        }
    }
    assert_eq!(cut, svg_cut_loops(&text));
    let raw = String::from_utf8_lossy(&std::fs::read(out.join("stencil.dxf")).unwrap()).to_string();
    assert!(raw.contains("SEQEND") && !raw.contains("LWPOLYLINE"));
}

#[test]
fn width_mm_sets_the_size() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.png");
    std::fs::write(
        &input,
        stencil_core::export::png::encode_bits(&picture(5, 300, 150)),
    )
    .unwrap();
    let out = dir.path().join("o");
    let r = make(
        &input,
        &out,
        PhysicalConfig {
            size: pipeline::Size::WidthMm(120.0),
            ..phys(ALL)
        },
    );
    assert!((r.width_mm.unwrap() - 120.0).abs() < 1e-9);
    assert!((r.height_mm.unwrap() - 60.0).abs() < 1e-9);
    // 0.4 mm per picture pixel; the working pixel is that over the automatic supersampling.
    let k = r.scale_factor.unwrap() as f64;
    assert!(
        k > 1.0,
        "0.4 mm pixels are coarse for cardstock's 0.5 mm features"
    );
    assert!((r.mm_per_px.unwrap() * k - 0.4).abs() < 1e-12);
    assert!((r.mm_per_px.unwrap() * r.width_px as f64 - 120.0).abs() < 1e-9);
    assert_eq!(r.material.as_deref(), Some("cardstock"));
}

fn mask_bits(p: &Path) -> (u32, u32, Vec<bool>) {
    let img = image::open(p).unwrap().to_luma8();
    (
        img.width(),
        img.height(),
        img.as_raw().iter().map(|&v| v >= 128).collect(),
    )
}

#[test]
fn mask_size_invert_and_mirror() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.png");
    // One cut disc on the left half: asymmetric, so mirroring shows.
    let bits = BitGrid::from_fn(200, 100, |x, y| {
        ((x as f64 - 50.0).powi(2) + (y as f64 - 50.0).powi(2)).sqrt() > 20.0
    });
    std::fs::write(&input, stencil_core::export::png::encode_bits(&bits)).unwrap();
    let emit = Emit {
        png: false,
        svg: false,
        dxf: false,
        mask: true,
    };
    let mut runs = Vec::new();
    for (invert, mirror) in [(false, false), (true, false), (false, true)] {
        let out = dir.path().join(format!("m{invert}{mirror}"));
        let mut p = phys(emit);
        p.mask.dpi = 300.0;
        p.mask.invert = invert;
        p.mask.mirror = mirror;
        let r = make(&input, &out, p);
        let sheet = (r.width_mm.unwrap() + 10.0, r.height_mm.unwrap() + 10.0);
        let (w, h, data) = mask_bits(&out.join("mask.png"));
        assert_eq!(
            (w, h),
            (
                (sheet.0 / 25.4 * 300.0).round() as u32,
                (sheet.1 / 25.4 * 300.0).round() as u32
            )
        );
        let svg = std::fs::read_to_string(out.join("mask.svg")).unwrap();
        assert!((svg_width_mm(&svg) - sheet.0).abs() < 1e-4, "{svg:.300}");
        runs.push((w, h, data));
    }
    let (w, h, plain) = &runs[0];
    let px = |x_mm: f64, y_mm: f64| -> usize {
        let f = 300.0 / 25.4;
        ((y_mm + 5.0) * f) as usize * *w as usize + ((x_mm + 5.0) * f) as usize
    };
    // Default polarity: black where metal stays, white where it is etched through.
    assert!(plain[px(5.0, 5.0)], "disc centre (cut) is white");
    assert!(!plain[px(15.0, 5.0)], "metal is black");
    assert!(!plain[px(-4.0, 2.0)], "margin is metal");
    // Invert flips every pixel.
    assert!(plain.iter().zip(&runs[1].2).all(|(a, b)| a != b));
    // Mirror flips left-right.
    let mirrored = &runs[2].2;
    let mut same = 0;
    for y in 0..*h as usize {
        for x in 0..*w as usize {
            same += (plain[y * *w as usize + x]
                == mirrored[y * *w as usize + (*w as usize - 1 - x)]) as usize;
        }
    }
    assert!(
        same as f64 >= 0.999 * plain.len() as f64,
        "{same} of {}",
        plain.len()
    );
    assert!(plain != mirrored);
}

/// The `width="…mm"` of an SVG's root element, in mm (written with 4 decimals).
fn svg_width_mm(svg: &str) -> f64 {
    let start = svg.find("width=\"").expect("the SVG has a width") + "width=\"".len();
    let end = start + svg[start..].find("mm\"").expect("the width is in mm");
    svg[start..end].parse().expect("the width is a number")
}
