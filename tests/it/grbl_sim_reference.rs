//! Issue 26 item 3: `stencil estimate` within 5 % of Grbl 1.1h's own planner and stepper timer.
//!
//! The reference times are recorded measurements, not computed here: each job was run through
//! grbl-sim (gnea/grbl 1.1h at bfb67f0 inside grbl/grbl-sim at 9bdd165, built outside this repo;
//! see docs/estimate-vs-grbl-sim.md) in its lockstep mode, where simulated time advances only
//! while the firmware waits on the simulated hardware, so the figure is the firmware's own step
//! timer time (first step to last step), the same on every run. The job was streamed through
//! grbl-sim's serial emulation at 115200 baud with the settings of `tests/fixtures/grbl_sim/
//! diode.settings` in its EEPROM. The estimate is given the same `$$` with `--controller-state`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn stencil() -> Command {
    Command::new(env!("CARGO_BIN_EXE_stencil"))
}

/// (fixture, grbl-sim's time in seconds, measured 2026-11-26 with `gsim_time.py`).
const REFERENCE: &[(&str, f64)] = &[
    // G1 X100, G1 Y100, a 180° G2 of r 50 mm, G1 Y0 at 3000 mm/min.
    ("grbl_sim/arc-square.nc", 9.335),
    // `stencil make samples/<name>.png --width-mm 30 --material copy-paper --emit gcode`:
    // 500 to 1717 lines of segments a few steps long, M4 laser mode.
    ("grbl_sim/stencil-blobs.gcode", 5.321),
    ("grbl_sim/stencil-letters.gcode", 6.140),
    ("grbl_sim/stencil-rings.gcode", 17.798),
    // Third-party jobs with arcs (tests/it/third_party.rs): Z moves at Z's own rate and
    // acceleration, M8/M9 and M3/M5 stops, inches, full circles.
    ("third_party/lightburn.gc", 16.633),
    ("third_party/lasergrbl.nc", 11.738),
    ("third_party/gcodetools.ngc", 28.979),
    ("third_party/vpype.gcode", 25.103),
    ("third_party/svg2gcode.gcode", 52.215),
];

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// The `(N.NN s)` of `stencil estimate`'s answer.
fn estimate_s(job: &Path, settings: &Path) -> f64 {
    let out = stencil()
        .arg("estimate")
        .arg(job)
        .arg("--controller-state")
        .arg(settings)
        .arg("--no-bed-check")
        .output()
        .unwrap();
    let so = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}: {so}{}",
        job.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    let line = so.lines().find(|l| l.contains(": about ")).unwrap();
    let open = line.find(" (").unwrap() + 2;
    let close = open + line[open..].find(" s)").unwrap();
    line[open..close].parse().unwrap()
}

#[test]
fn the_estimate_is_within_five_percent_of_grbl_sim() {
    let settings = fixture("grbl_sim/diode.settings");
    let mut report = String::new();
    let mut worst: f64 = 0.0;
    for &(name, reference) in REFERENCE {
        let est = estimate_s(&fixture(name), &settings);
        let diff = (est - reference) / reference;
        worst = worst.max(diff.abs());
        report.push_str(&format!(
            "{name}: estimate {est:.2} s, grbl-sim {reference:.3} s, {:+.1} %\n",
            diff * 100.0
        ));
    }
    assert!(worst <= 0.05, "more than 5 % off Grbl:\n{report}");
}
