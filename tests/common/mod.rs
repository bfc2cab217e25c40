//! Helpers shared by the end-to-end tests: make pictures, run the binary, read outputs back.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use stencil_core::raster::BitGrid;
use stencil_grbl::{Fault, FaultKind, VirtualConfig};

/// Write an 8-bit gray PNG.
pub fn write_gray_png(path: &Path, w: u32, h: u32, data: &[u8]) {
    image::save_buffer(path, data, w, h, image::ExtendedColorType::L8).unwrap();
}

/// A picture from a predicate: `true` = ink (dark, to be cut), on white paper.
pub fn ink_png(path: &Path, w: u32, h: u32, ink: impl Fn(u32, u32) -> bool) {
    let mut data = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            data.push(if ink(x, y) { 0 } else { 255 });
        }
    }
    write_gray_png(path, w, h, &data);
}

/// A picture anti-aliased as a scan or an export would be: `light` gives the gray (0 = ink, 1 =
/// paper) at a point in pixel coordinates, and each pixel averages 16 × 16 samples of it.
pub fn smooth_png(path: &Path, w: u32, h: u32, light: impl Fn(f64, f64) -> f64) {
    const N: u32 = 16;
    let mut data = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let mut sum = 0.0;
            for j in 0..N {
                for i in 0..N {
                    let sx = x as f64 + (i as f64 + 0.5) / N as f64;
                    let sy = y as f64 + (j as f64 + 0.5) / N as f64;
                    sum += light(sx, sy);
                }
            }
            data.push((sum / (N * N) as f64 * 255.0).round().clamp(0.0, 255.0) as u8);
        }
    }
    write_gray_png(path, w, h, &data);
}

/// Read an output PNG back as material bits (>= 128 is material).
pub fn read_bits(path: &Path) -> BitGrid {
    let img = image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_luma8();
    BitGrid::from_u8(img.width(), img.height(), img.as_raw())
}

/// Run the `stencil` binary.
pub fn stencil(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_stencil"))
        .args(args)
        // No settings a developer kept in their own config folder (`stencil profiles set`).
        .env(
            "STENCIL_CONFIG_DIR",
            Path::new(env!("CARGO_TARGET_TMPDIR")).join("no-kept-settings"),
        )
        .output()
        .expect("run stencil")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Files in a folder (names), sorted; empty if the folder does not exist.
pub fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = match std::fs::read_dir(dir) {
        Ok(rd) => rd
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect(),
        Err(_) => Vec::new(),
    };
    v.sort();
    v
}

/// Assert the stencil's validity as a user would see it in the PNGs: material is one 4-connected
/// piece joined to the frame (no floating islands), and the stencil differs from the two-tone only
/// where cut became material.
pub fn assert_valid_stencil(out: &Path) {
    let two = read_bits(&out.join("twotone.png"));
    let st = read_bits(&out.join("stencil.png"));
    assert_eq!((two.width, two.height), (st.width, st.height));
    let floating = stencil_core::islands::floating_count(&st);
    assert_eq!(
        floating,
        0,
        "{}: {floating} material pieces float",
        out.display()
    );
    for (i, (&a, &b)) in two.data.iter().zip(&st.data).enumerate() {
        assert!(
            !a || b,
            "{}: pixel {i} was material and became cut",
            out.display()
        );
    }
}

/// The number of material pixels bridges added.
pub fn added_pixels(out: &Path) -> usize {
    added_at(out).len()
}

/// The pixels the bridges added: material in stencil.png that twotone.png has as cut.
pub fn added_at(out: &Path) -> Vec<(u32, u32)> {
    let t = read_bits(&out.join("twotone.png"));
    let s = read_bits(&out.join("stencil.png"));
    let mut v = Vec::new();
    for y in 0..s.height {
        for x in 0..s.width {
            if s.get(x, y) && !t.get(x, y) {
                v.push((x, y));
            }
        }
    }
    v
}

pub fn report(out: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap()
}

pub fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

pub fn samples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("samples")
}

/// Pixels that differ between two grids of the same size (a count, so failures stay readable).
pub fn differing(a: &BitGrid, b: &BitGrid) -> usize {
    assert_eq!((a.width, a.height), (b.width, b.height), "sizes differ");
    a.data.iter().zip(&b.data).filter(|(x, y)| x != y).count()
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xedb8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// One PNG chunk: length, kind, body, CRC.
pub fn png_chunk(kind: &[u8; 4], body: &[u8]) -> Vec<u8> {
    let mut chunk = kind.to_vec();
    chunk.extend_from_slice(body);
    let mut out = (body.len() as u32).to_be_bytes().to_vec();
    out.extend_from_slice(&chunk);
    out.extend_from_slice(&crc32(&chunk).to_be_bytes());
    out
}

/// A PNG whose header claims `w` x `h` pixels (`depth` bits, PNG colour type `color`: 0 gray,
/// 2 RGB, 6 RGBA) over a few bytes of bogus pixel data, as a doctored real file would have: tiny
/// on disk, huge if decoded.
pub fn png_header_only(w: u32, h: u32, depth: u8, color: u8) -> Vec<u8> {
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = w.to_be_bytes().to_vec();
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[depth, color, 0, 0, 0]);
    png.extend(png_chunk(b"IHDR", &ihdr));
    png.extend(png_chunk(
        b"IDAT",
        &[0x78u8, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    ));
    png.extend(png_chunk(b"IEND", &[]));
    png
}

/// A stock virtual Grbl that fails once, with `kind`, when the `at`-th G-code line of the run
/// arrives (see [`Fault`]).
pub fn faulty(kind: FaultKind, at: usize) -> VirtualConfig {
    VirtualConfig {
        faults: vec![Fault {
            at_job_line: at,
            kind,
        }],
        ..VirtualConfig::default()
    }
}

/// The 4-connected pieces of the pixels of a `w` × `h` grid (row-major) for which `inside` holds:
/// a piece number per pixel (`u32::MAX` outside) and how many pieces there are. A plain flood
/// fill: scaffolding to read outputs, not the library's labelling under test.
pub fn pieces_of(w: usize, h: usize, inside: impl Fn(usize) -> bool) -> (Vec<u32>, usize) {
    let mut label = vec![u32::MAX; w * h];
    let mut count = 0u32;
    for start in 0..w * h {
        if label[start] != u32::MAX || !inside(start) {
            continue;
        }
        label[start] = count;
        let mut stack = vec![start];
        while let Some(i) = stack.pop() {
            let (x, y) = (i % w, i / w);
            let next = [
                (x > 0).then(|| i - 1),
                (x + 1 < w).then(|| i + 1),
                (y > 0).then(|| i - w),
                (y + 1 < h).then(|| i + w),
            ];
            for j in next.into_iter().flatten() {
                if label[j] == u32::MAX && inside(j) {
                    label[j] = count;
                    stack.push(j);
                }
            }
        }
        count += 1;
    }
    (label, count as usize)
}

/// Read from a virtual Grbl's port until `needle` has come (or 5 s have passed): what came.
pub fn read_until(port: &mut serialport::TTYPort, needle: &str) -> String {
    use std::io::Read;
    use std::time::{Duration, Instant};
    let mut got = String::new();
    let end = Instant::now() + Duration::from_secs(5);
    let mut buf = [0u8; 256];
    serialport::SerialPort::set_timeout(port, Duration::from_millis(10)).unwrap();
    while !got.contains(needle) && Instant::now() < end {
        if let Ok(n) = port.read(&mut buf) {
            got.push_str(&String::from_utf8_lossy(&buf[..n]));
        }
    }
    got
}

// ---- the studio's tests (tests/studio.rs, tests/studio_browser.rs) ----

/// Every file of two output folders equal (a set's layer folders too), each report.json but for
/// `timings_ms`.
pub fn same_outputs(a: &Path, b: &Path, what: &str) {
    let names = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            // The studio's keep-out paintings (`keep-out-painted-HASH.png`) are its, not make's.
            .filter(|n| !(n.starts_with("keep-out-painted") && n.ends_with(".png")))
            .collect();
        v.sort();
        v
    };
    assert_eq!(names(a), names(b), "{what}");
    for n in names(a) {
        if a.join(&n).is_dir() {
            same_outputs(&a.join(&n), &b.join(&n), &format!("{what}: {n}/"));
            continue;
        }
        let (x, y) = (
            std::fs::read(a.join(&n)).unwrap(),
            std::fs::read(b.join(&n)).unwrap(),
        );
        if n == "report.json" {
            let mut x: serde_json::Value = serde_json::from_slice(&x).unwrap();
            let mut y: serde_json::Value = serde_json::from_slice(&y).unwrap();
            x.as_object_mut().unwrap().remove("timings_ms");
            y.as_object_mut().unwrap().remove("timings_ms");
            assert_eq!(x, y, "{what}: report.json");
        } else {
            assert!(
                x == y,
                "{what}: {n} differs ({} vs {} bytes)",
                x.len(),
                y.len()
            );
        }
    }
}

/// Run the studio's command line with `make` into `dir` instead of the studio's folder.
pub fn make_as_shown(command: &str, dir: &Path) {
    let words: Vec<&str> = command.split(' ').collect();
    assert_eq!(&words[..2], ["stencil", "make"], "{command}");
    let mut args: Vec<String> = Vec::new();
    let mut i = 2;
    while i < words.len() {
        if words[i] == "-o" {
            args.push("-o".into());
            args.push(dir.display().to_string());
            i += 2;
            continue;
        }
        assert!(
            !words[i].starts_with('\''),
            "the test's paths need no quoting: {command}"
        );
        args.push(words[i].to_string());
        i += 1;
    }
    let o = Command::new(env!("CARGO_BIN_EXE_stencil"))
        .arg("make")
        .args(&args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{command}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// One loop of a G-code program as read back by [`gcode_loops`]: its motion lines' words
/// (`G`, `X`, `Y`, `I`, `J`, as written, in order), and its path as points: G1 ends, and G2/G3
/// arcs as chords at most 0.001 mm from their circle.
#[derive(Clone, Debug, Default)]
pub struct GcodeLoop {
    pub moves: Vec<String>,
    pub points: Vec<[f64; 2]>,
    /// How many of the moves are arcs.
    pub arcs: usize,
}

/// The loops of a G-code program (what each rapid move leads into, up to the next), read here
/// word by word, independently of the project's writer and interpreter: G0/G1/G2/G3 modal, X/Y
/// absolute (G90), arcs in the XY plane with I/J centre offsets from their start. An arc whose
/// ends are not on one circle (Grbl's error:33: more than 0.005 mm and 0.1 % of the radius
/// apart) or that would be a full turn panics.
pub fn gcode_loops(text: &str) -> Vec<GcodeLoop> {
    let mut loops: Vec<GcodeLoop> = Vec::new();
    let (mut motion, mut pos) = (0u8, [0.0f64; 2]);
    for (n, line) in text.lines().enumerate() {
        if line.starts_with(';') {
            continue;
        }
        let word = |c: char| {
            line.split_whitespace()
                .find_map(|w| w.strip_prefix(c).and_then(|v| v.parse::<f64>().ok()))
        };
        if let Some(g) = line
            .split_whitespace()
            .filter_map(|w| w.strip_prefix('G').and_then(|v| v.parse::<u8>().ok()))
            .find(|g| *g <= 3)
        {
            motion = g;
        }
        let (x, y) = (word('X'), word('Y'));
        if x.is_none() && y.is_none() {
            continue;
        }
        let to = [x.unwrap_or(pos[0]), y.unwrap_or(pos[1])];
        let words: Vec<&str> = line
            .split_whitespace()
            .filter(|w| w.starts_with(['G', 'X', 'Y', 'I', 'J']))
            .collect();
        match motion {
            0 => loops.push(GcodeLoop {
                points: vec![to],
                ..Default::default()
            }),
            1 => {
                if let Some(l) = loops.last_mut() {
                    l.moves.push(words.join(" "));
                    l.points.push(to);
                }
            }
            _ => {
                let (i, j) = (word('I').unwrap_or(0.0), word('J').unwrap_or(0.0));
                let c = [pos[0] + i, pos[1] + j];
                let r0 = i.hypot(j);
                let r1 = (to[0] - c[0]).hypot(to[1] - c[1]);
                let dr = (r1 - r0).abs();
                assert!(
                    dr <= 0.005 || dr <= 0.001 * r0,
                    "line {}: {line}: ends {r0} and {r1} mm from the centre",
                    n + 1
                );
                assert!(to != pos, "line {}: {line}: a full turn", n + 1);
                if let Some(l) = loops.last_mut() {
                    l.moves.push(words.join(" "));
                    l.arcs += 1;
                    l.points.extend(arc_chords(pos, to, c, motion == 3).1);
                    l.points.push(to);
                }
            }
        }
        pos = to;
    }
    loops
}

/// An arc from `from` to `to` about the centre `c` (counter-clockwise when `ccw`, G3), as its
/// signed sweep in radians and the points between its ends where chords of at most 0.001 mm
/// sagitta meet (the ends themselves not included): what both G-code readers draw an arc with.
pub fn arc_chords(from: [f64; 2], to: [f64; 2], c: [f64; 2], ccw: bool) -> (f64, Vec<[f64; 2]>) {
    let r0 = (from[0] - c[0]).hypot(from[1] - c[1]);
    let a0 = (from[1] - c[1]).atan2(from[0] - c[0]);
    let mut sweep = (to[1] - c[1]).atan2(to[0] - c[0]) - a0;
    let tau = std::f64::consts::TAU;
    if ccw && sweep <= 0.0 {
        sweep += tau;
    } else if !ccw && sweep >= 0.0 {
        sweep -= tau;
    }
    let step = 2.0 * (1.0 - 0.001 / r0.max(0.002)).acos();
    let k = (sweep.abs() / step).ceil().max(1.0) as usize;
    let inner = (1..k)
        .map(|m| {
            let a = a0 + sweep * m as f64 / k as f64;
            [c[0] + r0 * a.cos(), c[1] + r0 * a.sin()]
        })
        .collect();
    (sweep, inner)
}

/// The closed subpaths of SVG path data (`d`), read with kurbo (lines, arcs `A`, Béziers) and
/// flattened within `tol`: each subpath's points, its closing point not repeated.
pub fn svg_subpaths(d: &str, tol: f64) -> Vec<Vec<[f64; 2]>> {
    let path = kurbo::BezPath::from_svg(d).unwrap_or_else(|e| panic!("path data {d:.80}: {e}"));
    let mut out: Vec<Vec<[f64; 2]>> = Vec::new();
    kurbo::flatten(path, tol, |el| match el {
        kurbo::PathEl::MoveTo(p) => out.push(vec![[p.x, p.y]]),
        kurbo::PathEl::LineTo(p) => out.last_mut().unwrap().push([p.x, p.y]),
        kurbo::PathEl::ClosePath => {
            let r = out.last_mut().unwrap();
            if r.len() > 1 && r.first() == r.last() {
                r.pop();
            }
        }
        _ => unreachable!("flatten gives lines"),
    });
    out
}

/// The arc a DXF polyline vertex's bulge draws from `(x0, y0)` to `(x1, y1)`, from the bulge's
/// definition (`tan(sweep / 4)`, positive counter-clockwise), not with the writer's own code:
/// its centre, radius, start angle and sweep (radians).
pub fn bulge_arc(x0: f64, y0: f64, x1: f64, y1: f64, bulge: f64) -> ([f64; 2], f64, f64, f64) {
    let sweep = 4.0 * bulge.atan();
    let l = (x1 - x0).hypot(y1 - y0);
    let r = l / 2.0 / (sweep / 2.0).sin().abs();
    // Centre: on the chord's bisector, to the left for a counter-clockwise sweep under a half
    // turn.
    let (mx, my) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let (nx, ny) = (-(y1 - y0) / l, (x1 - x0) / l);
    let d = (r * r - l * l / 4.0).max(0.0).sqrt() * sweep.signum();
    let c = [mx + d * nx, my + d * ny];
    (c, r, (y0 - c[1]).atan2(x0 - c[0]), sweep)
}

/// The cut moves of a program read by the project's Grbl interpreter, loop by loop, as points
/// (an arc as Grbl's chords): a loop ends at a rapid move.
pub fn cut_loops(moves: &[stencil_gcode::interpret::Move]) -> Vec<Vec<[f64; 2]>> {
    let mut out: Vec<Vec<[f64; 2]>> = Vec::new();
    let mut open = false;
    for m in moves {
        let cuts = !m.rapid && m.power > 0.0 && (m.from[0] != m.to[0] || m.from[1] != m.to[1]);
        if cuts {
            if !open {
                out.push(vec![[m.from[0], m.from[1]]]);
                open = true;
            }
            out.last_mut().unwrap().push([m.to[0], m.to[1]]);
        } else if m.rapid {
            open = false;
        }
    }
    out
}

/// Distance from `p` to the segment `a`–`b` (the product's own measure).
pub use stencil_geom::ring::seg_dist;

/// Points along a polyline, at most `step` apart.
pub fn dense(path: &[[f64; 2]], step: f64) -> Vec<[f64; 2]> {
    let mut out = vec![path[0]];
    for w in path.windows(2) {
        let k = ((w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) / step)
            .ceil()
            .max(1.0) as usize;
        for i in 1..=k {
            let t = i as f64 / k as f64;
            out.push([
                w[0][0] + t * (w[1][0] - w[0][0]),
                w[0][1] + t * (w[1][1] - w[0][1]),
            ]);
        }
    }
    out
}

/// The largest distance from a point of the polyline `a` (every 0.01 mm) to the polyline `b`:
/// one way of the Hausdorff distance.
pub fn one_way(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    dense(a, 0.01)
        .iter()
        .map(|&p| {
            b.windows(2)
                .map(|w| seg_dist(p, w[0], w[1]))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}
