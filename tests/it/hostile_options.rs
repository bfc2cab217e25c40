//! Hostile and absurd inputs (issue 12): numeric options of make, tone and check, huge picture
//! headers, truncated JPEGs, profiles that never end, output folders, and how errors are worded.
//! Each is refused with a non-zero exit (not a signal: no abort), no panic, and a message that
//! names the file or option and what to do. Inputs are made here, small.

use std::path::Path;
use std::process::Output;
use std::sync::{Arc, Mutex};

use crate::common::*;

/// The run failed by exiting (not killed by a signal, as an abort would be), without a panic, and
/// its message holds every needle. Returns stderr.
fn refused(o: &Output, needles: &[&str]) -> String {
    let err = stderr(o);
    assert!(!o.status.success(), "should fail: {err}");
    assert!(
        o.status.code().is_some(),
        "killed by a signal ({:?}): {err}",
        o.status
    );
    assert!(!err.contains("panicked"), "panic: {err}");
    for n in needles {
        assert!(err.contains(n), "message should contain {n:?}: {err}");
    }
    err
}

fn rings() -> std::path::PathBuf {
    samples().join("rings.png")
}

/// `make rings.png` into a fresh folder with `args`; asserts it is refused, with no output.
fn make_refused(args: &[&str], needles: &[&str]) -> String {
    let dir = tmp();
    let out = dir.path().join("out");
    let input = rings();
    let mut a = vec!["make", s(&input), "-o", s(&out)];
    a.extend_from_slice(args);
    let o = stencil(&a);
    let err = refused(&o, needles);
    assert!(
        files_in(&out).is_empty(),
        "{args:?} wrote {:?}",
        files_in(&out)
    );
    err
}

#[test]
fn sizes_outside_physical_sense_name_the_option_and_the_range() {
    // A 320 x 320 picture: --width-mm 0.32 .. 10000, --dpi 0.8128 .. 25400.
    for (args, needles) in [
        (
            &["--width-mm", "1e15"][..],
            &["--width-mm", "0.32 to 10000"][..],
        ),
        (&["--width-mm", "1e308"], &["--width-mm", "10 m"]),
        (&["--width-mm", "1e5"], &["--width-mm", "0.32 to 10000"]),
        (&["--width-mm", "1e-6"], &["--width-mm", "1 micron"]),
        (&["--dpi", "1e-300"], &["--dpi", "0.8128 to 25400"]),
        (&["--dpi", "1e-3"], &["--dpi", "0.8128 to 25400"]),
        (&["--dpi", "1e6"], &["--dpi", "0.8128 to 25400"]),
        (&["--dpi", "1e9"], &["--dpi", "0.8128 to 25400"]),
        (
            &["--scale", "8", "--width-mm", "1e6"],
            &["--width-mm", "0.32 to 10000"],
        ),
        (&["--width-mm", "nan"], &["--width-mm", "finite number > 0"]),
        (&["--dpi=-3"], &["--dpi", "finite number > 0"]),
        (&["--margin-mm", "1e300"], &["--margin-mm", "0.001 to 1000"]),
        (
            &["--margin-mm", "1e-300"],
            &["--margin-mm", "0.001 to 1000"],
        ),
        (
            &["--tolerance-mm", "1e-300"],
            &["--tolerance-mm", "0.001 to 10"],
        ),
        (
            &["--tolerance-mm", "1e300"],
            &["--tolerance-mm", "0.001 to 10"],
        ),
        (
            &["--mask-dpi", "1e-300", "--emit", "mask"],
            &["--mask-dpi", "25.4 to 25400"],
        ),
        (&["--max-pixels", "1e12"], &["--max-pixels", "200000000"]),
    ] {
        make_refused(args, needles);
    }
}

#[test]
fn pixels_too_fine_for_the_material_say_what_size_works() {
    // 320 px at 0.32 mm: 1 um pixels, cardstock's 0.5 mm feature 500 px (it ran for a minute).
    make_refused(
        &["--width-mm", "0.32"],
        &[
            "--width-mm 0.32",
            "500 pixels",
            "use --width-mm 3.2 or more",
        ],
    );
    // Fine enough as a picture, too fine once supersampled 8 times: lower --scale.
    make_refused(
        &["--width-mm", "20", "--scale", "8"],
        &["--scale 8", "use --scale 6 or less"],
    );
    // The bound itself is accepted: 50 px per 0.5 mm at --width-mm 3.2.
    let dir = tmp();
    let o = stencil(&[
        "make",
        s(&rings()),
        "-o",
        s(&dir.path().join("out")),
        "--width-mm",
        "3.2",
        "--allow-thin",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn filter_radius_is_bounded_by_the_picture() {
    make_refused(
        &["--filter-radius", "1000000"],
        &["--filter-radius 1000000", "0..=80"],
    );
    let dir = tmp();
    for r in ["1000000", "10000"] {
        let o = stencil(&[
            "tone",
            s(&rings()),
            "-o",
            s(&dir.path().join("t.png")),
            "--filter-radius",
            r,
        ]);
        refused(&o, &["rings.png", "--filter-radius", "0..=80"]);
    }
}

/// A `make` output folder of rings.png, for `check`.
fn made_folder(dir: &Path) -> std::path::PathBuf {
    let out = dir.join("made");
    let o = stencil(&["make", s(&rings()), "-o", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    out
}

#[test]
fn check_refuses_absurd_sizes_and_report_values() {
    let dir = tmp();
    let out = made_folder(dir.path());
    for (w, needle) in [("1e308", "0.32 to 10000"), ("1e12", "0.32 to 10000")] {
        let o = stencil(&["check", s(&out), "--width-mm", w]);
        refused(&o, &["--width-mm", needle]);
    }
    // A report.json whose numbers are absurd is refused, naming the field.
    let rp = out.join("report.json");
    let text = std::fs::read_to_string(&rp).unwrap();
    let mut r: serde_json::Value = serde_json::from_str(&text).unwrap();
    r["margin_mm"] = serde_json::json!(1e300);
    std::fs::write(&rp, serde_json::to_string(&r).unwrap()).unwrap();
    refused(
        &stencil(&["check", s(&out)]),
        &["margin_mm", "0.001 to 1000"],
    );
    r["margin_mm"] = serde_json::json!(5.0);
    let bridge = r["bridges"][0]["polygon_px"][0].clone();
    r["bridges"][0]["polygon_px"][0] = serde_json::json!([1e30, 1.0]);
    std::fs::write(&rp, serde_json::to_string(&r).unwrap()).unwrap();
    refused(
        &stencil(&["check", s(&out)]),
        &["report.json", "bridge 1", "1e30"],
    );
    r["bridges"][0]["polygon_px"][0] = bridge;
    r["mm_per_px"] = serde_json::json!(1e30);
    std::fs::write(&rp, serde_json::to_string(&r).unwrap()).unwrap();
    refused(
        &stencil(&["check", s(&out)]),
        &["report.json", "mm_per_px", "--width-mm"],
    );
}

#[test]
fn huge_headers_are_refused_before_decoding_whatever_max_pixels_says() {
    let dir = tmp();
    // 60000 x 60000 (3.6 gigapixels) in a few bytes: --max-pixels cannot be raised that far.
    let p = dir.path().join("huge.png");
    std::fs::write(&p, png_header_only(60_000, 60_000, 8, 6)).unwrap();
    let o = stencil(&[
        "tone",
        s(&p),
        "-o",
        s(&dir.path().join("t.png")),
        "--max-pixels",
        "3600000000",
    ]);
    refused(&o, &["--max-pixels", "200000000"]);
    // Within the highest --max-pixels, but 16-bit RGBA: 2.3 GB to decode, over the budget.
    std::fs::write(&p, png_header_only(15_000, 13_000, 16, 6)).unwrap();
    for cmd in ["tone", "check"] {
        let mut a = vec![cmd, s(&p), "--max-pixels", "200000000"];
        let t = dir.path().join("t.png");
        if cmd == "tone" {
            a.extend(["-o", s(&t)]);
        }
        refused(&stencil(&a), &["huge.png", "15000x13000", "GB to decode"]);
    }
    // Over the default limits of make (50 MP) and check (100 MP), from the header.
    std::fs::write(&p, png_header_only(8000, 7000, 8, 0)).unwrap();
    make_refused_input(&p, &["huge.png", "8000x7000", "--max-pixels"]);
    std::fs::write(&p, png_header_only(11_000, 10_000, 1, 0)).unwrap();
    let o = stencil(&["check", s(&p)]);
    refused(&o, &["huge.png", "11000x10000", "--max-pixels"]);
    assert!(
        help("check").contains("--max-pixels"),
        "check has the option it names"
    );
}

/// `make INPUT` refused, with no output.
fn make_refused_input(input: &Path, needles: &[&str]) {
    let dir = tmp();
    let out = dir.path().join("out");
    let o = stencil(&["make", s(input), "-o", s(&out)]);
    refused(&o, needles);
    assert!(files_in(&out).is_empty());
}

/// `stencil CMD --help`, its lines joined (clap wraps them).
fn help(cmd: &str) -> String {
    let o = stencil(&[cmd, "--help"]);
    String::from_utf8_lossy(&o.stdout)
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

#[test]
fn help_states_the_limits() {
    let make = help("make");
    for needle in [
        "50 megapixels",
        "200000000",
        "10 m",
        "0.001 mm",
        "a quarter",
    ] {
        assert!(make.contains(needle), "make --help should say {needle:?}");
    }
    assert!(help("check").contains("100 megapixels"));
    assert!(help("tone").contains("50 megapixels"));
}

#[test]
fn truncated_jpegs_are_refused() {
    let dir = tmp();
    let bytes = std::fs::read(samples().join("grace_hopper.jpg")).unwrap();
    let n = bytes.len();
    // Cut in the headers, early in the scan, in the middle, and two bytes short of the end.
    for cut in [200, 638, n / 10, n / 3, n / 2, n * 9 / 10, n - 2] {
        let p = dir.path().join(format!("cut{cut}.jpg"));
        std::fs::write(&p, &bytes[..cut]).unwrap();
        let o = stencil(&["tone", s(&p), "-o", s(&dir.path().join("t.png"))]);
        refused(&o, &[&format!("cut{cut}.jpg"), "truncated"]);
    }
    make_refused_input(
        &dir.path().join(format!("cut{}.jpg", n / 2)),
        &["truncated"],
    );
    // Bytes after the end marker are no harm.
    let p = dir.path().join("trailing.jpg");
    let mut long = bytes.clone();
    long.extend_from_slice(b"trailing bytes some programs add");
    std::fs::write(&p, &long).unwrap();
    let o = stencil(&["tone", s(&p), "-o", s(&dir.path().join("t.png"))]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn profiles_that_never_end_are_refused() {
    let dir = tmp();
    let big = dir.path().join("big.toml");
    std::fs::write(&big, " ".repeat(2 << 20)).unwrap();
    // A device is refused at once (not read up to the cap); a large file by its size.
    for (arg, why) in [("/dev/zero", "a device"), (s(&big), "1 MB")] {
        make_refused(&["--material", arg], &[arg, "profile", why]);
        make_refused(
            &["--emit", "png,gcode", "--machine", arg],
            &[arg, "profile", why],
        );
    }
}

/// The files in a folder and their bytes.
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    files_in(dir)
        .into_iter()
        .filter(|n| dir.join(n).is_file())
        .map(|n| {
            let b = std::fs::read(dir.join(&n)).unwrap();
            (n, b)
        })
        .collect()
}

#[test]
fn a_failed_write_keeps_the_previous_run() {
    let dir = tmp();
    let out = dir.path().join("out");
    let o = stencil(&["make", s(&rings()), "-o", s(&out), "--emit", "png"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = snapshot(&out);
    // stencil.svg cannot be put in place (a folder holds its name): refused before the run, so
    // the earlier files stay as they were (a failure inside the swap is tested by the kills of
    // tests/trust.rs and the swap's own fuzz).
    std::fs::create_dir_all(out.join("stencil.svg").join("inside")).unwrap();
    let o = stencil(&[
        "make",
        s(&rings()),
        "-o",
        s(&out),
        "--emit",
        "png,svg",
        "--threshold",
        "200",
    ]);
    let err = refused(&o, &["stencil.svg", "is a folder"]);
    assert!(!err.contains(".stencil-"), "a temp file's name: {err}");
    assert_eq!(snapshot(&out), before, "the previous run's files are back");
    assert!(
        files_in(&out).iter().all(|n| !n.starts_with(".stencil-")),
        "{:?}",
        files_in(&out)
    );
}

#[test]
fn make_removes_its_own_files_an_earlier_run_left() {
    let dir = tmp();
    let out = dir.path().join("out");
    let all = "png,svg,dxf,mask,gcode";
    let o = stencil(&["make", s(&rings()), "-o", s(&out), "--emit", all]);
    assert!(o.status.success(), "{}", stderr(&o));
    let first = files_in(&out);
    for n in &first {
        assert!(
            stencil_core::pipeline::OUTPUT_NAMES.contains(&n.as_str()),
            "{n} is not in OUTPUT_NAMES"
        );
    }
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let o = stencil(&["make", s(&rings()), "-o", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    for gone in ["stencil.gcode", "stencil.dxf", "mask.png", "mask.svg"] {
        assert!(
            !out.join(gone).exists(),
            "{gone} left beside the new outputs"
        );
        assert!(err.contains(gone), "not said: {err}");
    }
    assert!(err.contains("removed"), "{err}");
    assert!(
        out.join("notes.txt").exists(),
        "a file not of make's names stays"
    );
    assert!(out.join("stencil.svg").exists());
}

#[test]
fn os_errors_are_said_once() {
    let dir = tmp();
    let o = stencil(&[
        "make",
        s(&dir.path().join("nope.png")),
        "-o",
        s(&dir.path().join("o")),
    ]);
    let err = refused(&o, &["nope.png"]);
    assert_eq!(err.matches("os error 2").count(), 1, "{err}");
    let o = stencil(&["make", s(&rings()), "--material", "/no/such/profile.toml"]);
    let err = refused(&o, &["/no/such/profile.toml"]);
    assert_eq!(err.matches("os error 2").count(), 1, "{err}");
}

#[test]
fn decoder_messages_carry_no_rust_type_dumps() {
    let dir = tmp();
    // A PNG with its header twice: the decoder's message named the chunk as
    // "ChunkType { type: IHDR, critical: true, private: false, ... }".
    let mut png = png_header_only(4, 4, 8, 0);
    let ihdr = png_chunk(b"IHDR", &[0, 0, 0, 4, 0, 0, 0, 4, 8, 0, 0, 0, 0]);
    png.splice(8..8, ihdr);
    let p = dir.path().join("crc.png");
    std::fs::write(&p, &png).unwrap();
    let o = stencil(&["tone", s(&p), "-o", s(&dir.path().join("t.png"))]);
    let err = refused(&o, &["crc.png", "IHDR"]);
    assert!(!err.contains('{') && !err.contains("ChunkType"), "{err}");
}

#[test]
fn check_summarises_long_lists_of_violations() {
    let dir = tmp();
    // A one-pixel checkerboard inside a frame: thousands of violations.
    let p = dir.path().join("checker.png");
    ink_png(&p, 120, 120, |x, y| {
        (10..110).contains(&x) && (10..110).contains(&y) && (x + y) % 2 == 0
    });
    let o = stencil(&["check", s(&p)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(out.lines().count() < 40, "{} lines", out.lines().count());
    assert!(out.contains("more (") && out.contains("--json"), "{out}");
}

/// Records the stages `make` reports.
struct Stages(Mutex<Vec<String>>);

impl stencil_core::pipeline::Progress for Stages {
    fn stage(&self, name: &str) {
        self.0.lock().unwrap().push(name.to_string());
    }
}

#[test]
fn make_reports_its_stages_through_the_progress_hook() {
    let dir = tmp();
    let stages = Arc::new(Stages(Mutex::new(Vec::new())));
    let cfg = stencil_core::MakeConfig {
        input: rings(),
        out_dir: dir.path().join("out"),
        progress: Some(stages.clone()),
        ..Default::default()
    };
    stencil_core::make(&cfg).unwrap();
    let seen = stages.0.lock().unwrap().clone();
    assert_eq!(seen.first().map(String::as_str), Some("tone"), "{seen:?}");
    assert_eq!(seen.last().map(String::as_str), Some("write"), "{seen:?}");
    for s in ["filter", "islands", "bridge", "vector"] {
        assert!(seen.iter().any(|x| x == s), "{s} missing: {seen:?}");
    }
}

#[test]
fn progress_shows_on_a_terminal_only() {
    use std::io::Read;
    use std::os::fd::{FromRawFd, IntoRawFd};
    use std::process::{Command, Stdio};

    let dir = tmp();
    // stderr a pipe: nothing but results.
    let o = Command::new(env!("CARGO_BIN_EXE_stencil"))
        .args(["make", s(&rings()), "-o", s(&dir.path().join("a"))])
        .env("STENCIL_PROGRESS_AFTER_MS", "0")
        .output()
        .unwrap();
    assert!(o.status.success());
    assert!(!stderr(&o).contains("(tone)"), "{}", stderr(&o));
    // stderr a terminal (a pseudo-terminal): the stages show.
    let (master, slave) = serialport::TTYPort::pair().expect("a pseudo-terminal");
    // SAFETY: both descriptors were just handed over by into_raw_fd and are owned by these files.
    let mut master = unsafe { std::fs::File::from_raw_fd(master.into_raw_fd()) };
    let slave = unsafe { std::fs::File::from_raw_fd(slave.into_raw_fd()) };
    let reader = std::thread::spawn(move || {
        let mut seen = Vec::new();
        let mut buf = [0u8; 4096];
        // Ends with an error (EIO) once the child, the last holder of the slave, exits.
        while let Ok(n) = master.read(&mut buf) {
            if n == 0 {
                break;
            }
            seen.extend_from_slice(&buf[..n]);
        }
        String::from_utf8_lossy(&seen).into_owned()
    });
    let status = {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_stencil"));
        cmd.args(["make", s(&rings()), "-o", s(&dir.path().join("b"))])
            .env("STENCIL_PROGRESS_AFTER_MS", "0")
            .stdout(Stdio::null())
            .stderr(Stdio::from(slave));
        let mut child = cmd.spawn().unwrap();
        // Our copy of the slave goes with `cmd`, so the reader sees the end.
        drop(cmd);
        child.wait().unwrap()
    };
    assert!(status.success());
    let seen = reader.join().unwrap();
    // The line may first be drawn at any stage of this short run.
    let stages = [
        "(tone)",
        "(filter)",
        "(islands)",
        "(bridge)",
        "(tidy)",
        "(verify)",
        "(vector)",
        "(check)",
        "(fidelity)",
        "(write)",
    ];
    assert!(stages.iter().any(|st| seen.contains(st)), "{seen:?}");
}

/// Issue 39, item 5: `test-grid --depth=-1e308..0:2` exited 0 and wrote `G1 Z-inf` (the steps
/// between the ends overflowed); every range option's ends are now bounded by what a machine
/// takes, refused naming the option, and nothing is written.
#[test]
fn test_grid_ranges_beyond_any_machine_are_refused_by_name() {
    let dir = tmp();
    for (args, needles) in [
        (
            &[
                "--machine",
                "drag-knife",
                "--speed",
                "100",
                "--depth=-1e308..0:2",
            ][..],
            &["--depth", "-1e308..0:2", "-1000 to 1000 mm"][..],
        ),
        (
            &["--speed=-1e308..1e308:3"],
            &["--speed", "1 to 200000 mm/min"],
        ),
        (&["--power=1e308..0.5:2"], &["--power", "0.1 to 100 %"]),
    ] {
        let out = dir.path().join("grid.gcode");
        let mut a = vec!["test-grid", "-o", s(&out)];
        a.extend_from_slice(args);
        let err = refused(&stencil(&a), needles);
        assert!(!err.contains("-inf") && !err.contains("NaN"), "{err}");
        assert!(
            !out.exists() && !out.with_extension("svg").exists(),
            "{args:?}"
        );
    }
    // In range, the knife grid is written with finite depths.
    let out = dir.path().join("ok.gcode");
    let o = stencil(&[
        "test-grid",
        "--machine",
        "drag-knife",
        "--speed",
        "100",
        "--depth=-0.5..-0.1:2",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let g = std::fs::read_to_string(&out).unwrap();
    assert!(g.contains("Z-0.5") && !g.contains("inf"), "{g}");
}

/// `--offset 1e308,1e308` was refused for the bed as "the job (0.0 x 0.0 mm)": the offset swallowed
/// the job's size. It is refused as the offset it is, by name.
#[test]
fn an_offset_beyond_any_bed_is_refused_as_the_offset() {
    let dir = tmp();
    let svg = dir.path().join("sq.svg");
    std::fs::write(
        &svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="50mm" height="50mm" viewBox="0 0 50 50"><rect x="5" y="5" width="20" height="20"/></svg>"#,
    )
    .unwrap();
    let out = dir.path().join("sq.gcode");
    for off in ["1e308,1e308", "0,-20000"] {
        let err = refused(
            &stencil(&[
                "gcode",
                s(&svg),
                "-o",
                s(&out),
                "--power",
                "50",
                "--speed",
                "900",
                "--offset",
                off,
            ]),
            &["--offset", off, "beyond any machine's bed", "10000 mm"],
        );
        assert!(!err.contains("0.0 x 0.0"), "{err}");
        assert!(!out.exists());
        let grid = dir.path().join("g.gcode");
        refused(
            &stencil(&["test-grid", "-o", s(&grid), "--offset", off]),
            &["--offset", "beyond any machine's bed"],
        );
        assert!(!grid.exists());
    }
}
