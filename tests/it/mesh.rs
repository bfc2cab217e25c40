//! The mesh path of stage 1, checked against geometry: where a sphere's outline and terminator
//! must fall, where a cube's silhouette is, that suggestive contours appear on a torus and a
//! wavy surface but not on a sphere; every sample mesh end to end; every bad file's error.

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::Vec3;
use stencil_core::tone::mesh::{self, render_mesh, LineMode, MeshConfig, RenderSize, Rendering};

use crate::shapes;

fn cfg(lines: LineMode) -> MeshConfig {
    MeshConfig {
        size: RenderSize::LongSide(400),
        supersample: 1,
        lines,
        specular: 0.0,
        ..MeshConfig::default()
    }
}

/// Pixel centres as (x, y, index).
fn pixels(r: &Rendering) -> impl Iterator<Item = (f32, f32, usize)> + '_ {
    let w = r.gray.width as usize;
    (0..r.gray.data.len()).map(move |i| ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5, i))
}

fn sphere() -> mesh::Mesh {
    shapes::uv_sphere(1.0, 192, 96)
}

#[test]
fn sphere_lit_from_the_camera_is_a_disc_of_the_analytic_radius() {
    let m = sphere();
    for fov in [Some(30.0), Some(60.0), None] {
        let mut c = cfg(LineMode::None);
        c.fov_deg = fov;
        // The light sits at the eye (orthographic: at infinity, well, 1000 radii away).
        c.light = [
            0.0,
            0.0,
            if fov.is_some() {
                c.eye_distance()
            } else {
                1000.0
            },
        ];
        let r = render_mesh(&m, &c).unwrap();
        let cam = r.camera;
        let centre = cam.project(Vec3::ZERO);
        // The outline of a sphere of radius 1 seen from distance d: f·tan(asin(1/d)), or f orthographic.
        let d = cam.eye.length();
        let expect = if cam.orthographic {
            cam.focal_px
        } else {
            cam.focal_px * (1.0 / d).asin().tan()
        };
        assert!(expect > 150.0, "the sphere fills the image: {expect}");
        let w = r.gray.width as usize;
        let bright = |i: usize| r.model.data[i] && r.shade.data[i] > 0.02;
        // The edge between a bright pixel and a dark 4-neighbour lies between their centres.
        let mut edges = 0;
        for (x, y, i) in pixels(&r) {
            if !bright(i) {
                continue;
            }
            for (j, dx, dy) in [
                (i - 1, -0.5, 0.0),
                (i + 1, 0.5, 0.0),
                (i - w, 0.0, -0.5),
                (i + w, 0.0, 0.5),
            ] {
                if bright(j) {
                    continue;
                }
                edges += 1;
                let (ex, ey) = (x + dx - centre.x, y + dy - centre.y);
                let rad = (ex * ex + ey * ey).sqrt();
                assert!(
                    (rad - expect).abs() <= 1.0,
                    "fov {fov:?}: edge at radius {rad}, outline radius {expect}"
                );
            }
        }
        assert!(
            edges as f32 > 4.0 * expect,
            "a closed outline, {edges} edge pixels"
        );
    }
}

#[test]
fn the_terminator_lies_where_the_light_puts_it() {
    let m = sphere();
    // A point light 2 radii to one side of the centre lights the cap x > 1/2 (the tangent cone
    // from the light touches the sphere on the plane x = r²/2r).
    for side in [1.0f32, -1.0] {
        let mut c = cfg(LineMode::None);
        c.fov_deg = None;
        c.light = [2.0 * side, 0.0, 0.0];
        let r = render_mesh(&m, &c).unwrap();
        let cam = r.camera;
        let centre = cam.project(Vec3::ZERO);
        let f = cam.focal_px;
        let (mut lit, mut dark) = (0, 0);
        for (x, y, i) in pixels(&r) {
            let (u, v) = ((x - centre.x) * side / f, (y - centre.y) / f);
            if u * u + v * v > 0.98 {
                continue; // the rim
            }
            let s = r.shade.data[i];
            if u > 0.5 + 1.0 / f {
                assert!(s > 0.0, "({x},{y}) is on the lit side of the terminator");
                lit += 1;
            } else if u < 0.5 - 1.0 / f {
                assert_eq!(s, 0.0, "({x},{y}) is on the dark side of the terminator");
                dark += 1;
            }
        }
        assert!(lit > 1000 && dark > 2 * lit, "{lit} {dark}");
    }
}

#[test]
fn sphere_silhouette_is_on_the_outline() {
    let r = render_mesh(&sphere(), &{
        let mut c = cfg(LineMode::Silhouette);
        c.fov_deg = None;
        c
    })
    .unwrap();
    let cam = r.camera;
    let centre = cam.project(Vec3::ZERO);
    let rho = cam.focal_px;
    let mut count = 0;
    for (x, y, i) in pixels(&r) {
        if r.lines.data[i] {
            count += 1;
            let rad = ((x - centre.x).powi(2) + (y - centre.y).powi(2)).sqrt();
            assert!(
                (rad - rho).abs() <= 3.0,
                "line pixel at radius {rad}, outline at {rho}"
            );
        }
    }
    assert!(count as f32 > 2.0 * std::f32::consts::TAU * rho, "{count}");
    // All the way round.
    let w = r.gray.width as usize;
    for k in 0..72 {
        let a = k as f32 * std::f32::consts::TAU / 72.0;
        let (x, y) = (
            centre.x + (rho - 0.5) * a.cos(),
            centre.y + (rho - 0.5) * a.sin(),
        );
        assert!(
            r.lines.data[y as usize * w + x as usize],
            "gap at {k}*5 degrees"
        );
    }
}

#[test]
fn cube_silhouette_is_its_outline_and_not_its_front_edge() {
    // Seen from 45° azimuth, level: the outline is a rectangle √2 wide and 1 high each way; the
    // vertical edge facing the camera is a crease, not a silhouette.
    let mut c = cfg(LineMode::Suggestive);
    c.fov_deg = None;
    c.azimuth_deg = 45.0;
    c.elevation_deg = 0.0;
    let r = render_mesh(&shapes::cube(1.0), &c).unwrap();
    let cam = r.camera;
    let centre = cam.project(Vec3::ZERO);
    let (hx, hy) = (2f32.sqrt() * cam.focal_px, cam.focal_px);
    let w = r.gray.width as usize;
    for (x, y, i) in pixels(&r) {
        let (dx, dy) = ((x - centre.x).abs(), (y - centre.y).abs());
        if r.lines.data[i] {
            assert!(
                (dx - hx).abs() <= 3.0 || (dy - hy).abs() <= 3.0,
                "line at ({x},{y}) is off the outline"
            );
        }
    }
    for t in 0..40 {
        let s = (t as f32 / 40.0) * 2.0 - 1.0;
        for (x, y) in [
            (centre.x + s * (hx - 2.0), centre.y - hy + 0.5),
            (centre.x + s * (hx - 2.0), centre.y + hy - 0.5),
            (centre.x - hx + 0.5, centre.y + s * (hy - 2.0)),
            (centre.x + hx - 0.5, centre.y + s * (hy - 2.0)),
        ] {
            assert!(
                r.lines.data[y as usize * w + x as usize],
                "outline gap at ({x},{y})"
            );
        }
    }
    // The front edge runs down the middle column: no line there.
    let col = centre.x as usize;
    let y0 = (centre.y - hy + 5.0) as usize;
    let y1 = (centre.y + hy - 5.0) as usize;
    assert!((y0..y1).all(|y| !r.lines.data[y * w + col]));
    assert!((y0..y1).all(|y| r.model.data[y * w + col]));
}

/// Line pixels drawn with suggestive contours but not with silhouettes alone.
fn suggestive_only(m: &mesh::Mesh, c: &MeshConfig) -> usize {
    let with = render_mesh(
        m,
        &MeshConfig {
            lines: LineMode::Suggestive,
            ..c.clone()
        },
    )
    .unwrap();
    let without = render_mesh(
        m,
        &MeshConfig {
            lines: LineMode::Silhouette,
            ..c.clone()
        },
    )
    .unwrap();
    with.lines
        .data
        .iter()
        .zip(&without.lines.data)
        .filter(|(a, b)| **a && !**b)
        .count()
}

#[test]
fn suggestive_contours_on_a_torus_and_a_wavy_surface_not_on_a_sphere() {
    let c = cfg(LineMode::Suggestive);
    let torus = suggestive_only(&shapes::torus(1.0, 0.4, 96, 48), &c);
    assert!(torus > 100, "torus: {torus} suggestive-contour pixels");
    let wavy = shapes::height_field(120, |x, z| 0.15 * (3.0 * x).sin() * (2.0 * z).cos());
    let grazing = MeshConfig {
        elevation_deg: 15.0,
        azimuth_deg: 10.0,
        ..c.clone()
    };
    let wavy = suggestive_only(&wavy, &grazing);
    assert!(wavy > 100, "wavy surface: {wavy} suggestive-contour pixels");
    for view in [(30.0, 20.0), (0.0, 0.0), (120.0, -40.0)] {
        let c = MeshConfig {
            azimuth_deg: view.0,
            elevation_deg: view.1,
            ..c.clone()
        };
        assert_eq!(suggestive_only(&sphere(), &c), 0, "sphere from {view:?}");
    }
}

#[test]
fn invert_swaps_the_model_tones_but_not_lines_or_background() {
    let m = shapes::torus(1.0, 0.4, 64, 24);
    let r = render_mesh(&m, &cfg(LineMode::Suggestive)).unwrap();
    let (a, _) = mesh::two_tone(&r, stencil_core::tone::Threshold::Level(128), false);
    let (b, _) = mesh::two_tone(&r, stencil_core::tone::Threshold::Level(128), true);
    for i in 0..a.bits.data.len() {
        if r.lines.data[i] {
            assert!(!a.bits.data[i] && !b.bits.data[i], "lines are cut");
        } else if !r.model.data[i] {
            assert!(
                a.bits.data[i] && b.bits.data[i],
                "the background is material"
            );
        } else {
            assert_ne!(a.bits.data[i], b.bits.data[i]);
        }
    }
    assert_eq!(*a.gray, r.gray);
}

fn samples() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("samples");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "obj"))
        .collect();
    v.sort();
    v
}

#[test]
fn samples_are_small_and_load() {
    let files = samples();
    assert!(files.len() >= 3);
    let total: u64 = files.iter().map(|p| p.metadata().unwrap().len()).sum();
    assert!(total < 1_000_000, "samples/*.obj take {total} bytes");
    for p in files {
        let m = mesh::load(&p).unwrap();
        assert!(m.is_closed(), "{}", p.display());
    }
}

fn stencil_bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_stencil"))
}

#[test]
fn every_sample_mesh_makes_a_stencil_without_floating_pieces() {
    for obj in samples() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        let run = stencil_bin()
            .arg("make")
            .arg(&obj)
            .arg("-o")
            .arg(&out)
            .args(["--size", "512"])
            .output()
            .unwrap();
        assert!(
            run.status.success(),
            "{}: {}",
            obj.display(),
            String::from_utf8_lossy(&run.stderr)
        );
        let stencil = image::open(out.join("stencil.png")).unwrap().to_luma8();
        let bits =
            stencil_core::raster::BitGrid::from_fn(stencil.width(), stencil.height(), |x, y| {
                stencil.get_pixel(x, y)[0] > 127
            });
        let map = stencil_core::islands::label(&bits);
        assert_eq!(map.island_count(), 0, "{}: floating pieces", obj.display());
        // The lines survive filtering and bridging: the centre of every line the renderer draws
        // (same settings, thin lines) is cut in the stencil, bar the few pixels bridges cross.
        let r = render_mesh(
            &mesh::load(&obj).unwrap(),
            &MeshConfig {
                size: RenderSize::LongSide(512),
                ..MeshConfig::default()
            },
        )
        .unwrap();
        assert_eq!(r.lines.width, stencil.width());
        let line_px = r.lines.data.iter().filter(|&&l| l).count();
        let cut = (0..line_px.max(1))
            .zip(r.lines.data.iter().enumerate().filter(|(_, &l)| l))
            .filter(|(_, (i, _))| !bits.data[*i])
            .count();
        assert!(
            cut as f64 > 0.9 * line_px as f64,
            "{}: only {cut} of {line_px} line pixels are cut",
            obj.display()
        );
        let gray = image::open(out.join("gray.png")).unwrap().to_luma8();
        assert_eq!(gray.dimensions(), stencil.dimensions());
        // The rendering has both light and dark parts of the model.
        assert!(gray.pixels().any(|p| p[0] < 60) && gray.pixels().any(|p| p[0] > 200));
    }
}

/// A bad file, the line its error must name (0 = none) and what the message must say.
fn bad_files(dir: &Path) -> Vec<(PathBuf, usize, &'static str)> {
    let cases: [(&str, Option<&str>, usize, &'static str); 6] = [
        ("missing.obj", None, 0, "cannot open"),
        (
            "short.obj",
            Some("v 0 0 0\nv 1 0 0\nv 0 1\nf 1 2 3\n"),
            3,
            "needs 3 number",
        ),
        (
            "word.obj",
            Some("v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n"),
            2,
            "not a number",
        ),
        (
            "index.obj",
            Some("v 0 0 0\nv 1 0 0\nv 0 1 0\n# a face\nf 1 2 7\n"),
            5,
            "only 3 vertices",
        ),
        (
            "nan.obj",
            Some("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n"),
            3,
            "not a finite number",
        ),
        ("empty.obj", Some("# nothing here\nv 0 0 0\n"), 0, "empty"),
    ];
    cases
        .into_iter()
        .map(|(name, text, line, what)| {
            let p = dir.join(name);
            if let Some(t) = text {
                std::fs::write(&p, t).unwrap();
            }
            (p, line, what)
        })
        .collect()
}

#[test]
fn bad_files_give_a_clear_error_naming_file_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    for (p, line, what) in bad_files(tmp.path()) {
        let e = mesh::render(&p, &MeshConfig::default(), Default::default(), false)
            .unwrap_err()
            .to_string();
        let name = p.display().to_string();
        assert!(e.contains(&name), "{e}");
        if line > 0 {
            assert!(e.starts_with(&format!("{name}:{line}: ")), "{e}");
        }
        assert!(e.contains(what), "{e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}

#[test]
fn bad_files_exit_non_zero_and_write_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    for (p, line, _) in bad_files(tmp.path()) {
        let out = tmp.path().join("out");
        let run = stencil_bin()
            .arg("make")
            .arg(&p)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        assert!(!run.status.success());
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(err.contains(&p.display().to_string()), "{err}");
        if line > 0 {
            assert!(err.contains(&format!(":{line}: ")), "{err}");
        }
        assert!(!out.exists(), "{} left {}", p.display(), out.display());
        let png = tmp.path().join("twotone.png");
        let run = stencil_bin()
            .arg("tone")
            .arg(&p)
            .arg("-o")
            .arg(&png)
            .output()
            .unwrap();
        assert!(!run.status.success());
        assert!(!png.exists());
    }
}

#[test]
fn bad_settings_name_their_flag() {
    for (args, flag) in [
        (vec!["--view", "30"], "--view"),
        (vec!["--view", "0,95"], "--view"),
        (vec!["--distance", "0.5"], "--distance"),
        (vec!["--fov", "180"], "--fov"),
        (vec!["--size", "10x10"], "--size"),
        (vec!["--size", "big"], "--size"),
        (vec!["--light", "1,2,3,4"], "--light"),
        (vec!["--light", "0,95"], "--light"),
        (vec!["--view", "sideways"], "--view"),
        (vec!["--up", "W"], "--up"),
        (vec!["--ambient", "1"], "--ambient"),
        (vec!["--fill", "1.5"], "--fill"),
        (vec!["--supersample", "9"], "--supersample"),
        (vec!["--line-px", "0"], "--line-px"),
        (vec!["--shininess", "0"], "--shininess"),
    ] {
        let tmp = tempfile::tempdir().unwrap();
        let png = tmp.path().join("t.png");
        let obj = Path::new(env!("CARGO_MANIFEST_DIR")).join("samples/torus.obj");
        let run = stencil_bin()
            .arg("tone")
            .arg(&obj)
            .arg("-o")
            .arg(&png)
            .args(&args)
            .output()
            .unwrap();
        assert!(!run.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(err.contains(flag), "{args:?}: {err}");
        assert!(!png.exists());
    }
}

#[test]
fn tone_writes_the_two_tone_of_a_mesh() {
    let tmp = tempfile::tempdir().unwrap();
    let png = tmp.path().join("t.png");
    let obj = Path::new(env!("CARGO_MANIFEST_DIR")).join("samples/torus.obj");
    let run = stencil_bin()
        .arg("tone")
        .arg(&obj)
        .arg("-o")
        .arg(&png)
        .args(["--size", "300x200", "--view", "-30,25"])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let img = image::open(&png).unwrap().to_luma8();
    assert_eq!(img.dimensions(), (300, 200));
    // Corners are the sheet around the model; the model has cut parts.
    assert_eq!(img.get_pixel(0, 0)[0], 255);
    assert!(img.pixels().filter(|p| p[0] == 0).count() > 1000);
}
