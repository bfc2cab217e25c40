//! `stencil frame` and `send --frame` against the virtual Grbl: the head traces the bounding box
//! of the cutting moves and comes back, the beam is off (or dim in M4, per the profile) while it
//! does and off after, the tool stays up for pen and knife, and every stop path ends dark.

use crate::common;

use std::process::Command;
use std::sync::mpsc::channel;
use std::time::Duration;

use stencil_grbl::{
    cut_extent, frame, Console, Control, Event, Extent, FaultKind, FrameError, FrameTool,
    PlannedMove, Program, Quiet, Record, StreamConfig, VirtualConfig, VirtualGrbl,
};

/// A third-party style laser job: travel far out before and after, cuts in X 20..60 Y 30..70.
const JOB: &str = "G21 G90\nG0 X150 Y150\nG0 X20 Y30\nM4 S600\nG1 X60 F1200\nG1 Y70\nG1 X20\n\
G1 Y30\nM5\nG0 X20 Y30\nM4 S600\nG1 X35 Y45\nM5\nG0 X0 Y0\n";

fn cfg() -> StreamConfig {
    StreamConfig {
        boot_wait: Duration::from_millis(300),
        timeout: Duration::from_secs(5),
        ..StreamConfig::default()
    }
}

fn extent() -> Extent {
    cut_extent(&Program::parse("job.gcode", JOB).unwrap().moves).unwrap()
}

/// Frame on a fresh virtual Grbl whose head first travels to `start` (work coordinates).
fn frame_from(
    start: [f64; 2],
    tool: FrameTool,
    vcfg: VirtualConfig,
) -> (Result<[f64; 3], String>, Record, usize) {
    let (vg, mut host) = VirtualGrbl::spawn(vcfg).unwrap();
    let (_tx, rx) = channel::<Control>();
    let mut quiet = Quiet;
    let c = cfg();
    let mut console = Console::connect(&mut host, &c, Some(&rx), &mut quiet).unwrap();
    console
        .command(&format!("G0X{}Y{}", start[0], start[1]))
        .unwrap();
    console.wait_still(Duration::from_secs(5)).unwrap();
    let before = vg.record().moves.len();
    let r = frame(&mut console, extent(), tool, 3000.0)
        .map(|f| f.end)
        .map_err(|e| e.to_string());
    drop(console);
    (r, vg.stop(), before)
}

fn xy(p: [f64; 3]) -> [f64; 2] {
    [p[0], p[1]]
}

fn corners() -> Vec<[f64; 2]> {
    vec![
        [20.0, 30.0],
        [60.0, 30.0],
        [60.0, 70.0],
        [20.0, 70.0],
        [20.0, 30.0],
    ]
}

#[test]
fn the_extent_is_that_of_the_cutting_moves_only() {
    let e = extent();
    assert_eq!((e.min, e.max), ([20.0, 30.0], [60.0, 70.0]));
}

#[test]
fn a_dark_frame_visits_the_corners_and_returns_with_the_beam_off() {
    let (end, r, before) = frame_from(
        [5.0, 7.0],
        FrameTool::Laser { s: 0.0, z: None },
        VirtualConfig::default(),
    );
    assert_eq!(end.unwrap(), [5.0, 7.0, 0.0]);
    let moves: Vec<&PlannedMove> = r.moves[before..].iter().filter(|m| m.moves_xy()).collect();
    let visited: Vec<[f64; 2]> = moves.iter().map(|m| xy(m.to)).collect();
    let mut want = corners();
    want.push([5.0, 7.0]);
    assert_eq!(visited, want);
    assert!(
        moves.iter().all(|m| !m.beam),
        "the beam fired while framing dark"
    );
    assert!(!r.laser_on);
    assert_eq!(xy(r.position), [5.0, 7.0]);
    let last: Vec<&str> = r.run_lines().into_iter().rev().take(2).collect();
    assert_eq!(last, ["M5S0", "M9"]);
}

#[test]
fn a_dim_frame_lights_the_beam_only_along_the_frame() {
    let (end, r, before) = frame_from(
        [0.0, 0.0],
        FrameTool::Laser { s: 10.0, z: None },
        VirtualConfig::default(),
    );
    assert_eq!(end.unwrap(), [0.0, 0.0, 0.0]);
    let moves: Vec<&PlannedMove> = r.moves[before..].iter().filter(|m| m.moves_xy()).collect();
    let beams: Vec<bool> = moves.iter().map(|m| m.beam).collect();
    // Travel to the corner dark, four sides lit, travel back dark.
    assert_eq!(beams, [false, true, true, true, true, false]);
    let lines = r.run_lines();
    assert!(lines.contains(&"M4S10"), "{lines:?}");
    assert!(!lines.iter().any(|l| l.starts_with("M3")), "{lines:?}");
    assert!(!r.laser_on);
}

#[test]
fn pen_and_knife_frames_keep_the_tool_up() {
    let (end, r, before) = frame_from(
        [0.0, 0.0],
        FrameTool::ZUp { up_mm: 3.0 },
        VirtualConfig::default(),
    );
    assert_eq!(xy(end.unwrap()), [0.0, 0.0]);
    let moves = &r.moves[before..];
    // Lifted before any X/Y move, and never lowered.
    assert_eq!(moves[0].to, [0.0, 0.0, 3.0]);
    for m in moves.iter().filter(|m| m.moves_xy()) {
        assert!(m.from[2] == 3.0 && m.to[2] == 3.0, "{m:?}");
        assert!(!m.spindle_on);
    }
    let (_, r, before) = frame_from([0.0, 0.0], FrameTool::SpindlePen, VirtualConfig::default());
    assert!(r.moves[before..].iter().all(|m| !m.spindle_on));
}

fn assert_dark_after_stop(r: &Record) {
    assert!(!r.laser_on, "laser on after the stop");
    assert!(
        r.events.contains(&Event::SoftReset) || r.closed,
        "no soft reset: {:?}",
        &r.events[r.events.len().saturating_sub(6)..]
    );
}

#[test]
fn every_stop_path_while_framing_ends_with_the_beam_off() {
    // The frame's 4th G-code line is its first side (after G21.., M5S0, G0 to the corner).
    for (kind, want) in [
        (FaultKind::Error(20), "rejected"),
        (FaultKind::Alarm(1), "ALARM:1"),
        (FaultKind::ClosePort, "port"),
        (FaultKind::Silence, "not answered"),
    ] {
        // One G-code line (the G0 to the start) ran before the frame.
        let vcfg = common::faulty(kind, 1 + 5);
        let mut c = cfg();
        // Only the silent controller waits out the timeout: the others end on their own event,
        // and a short timeout there would race a busy machine's scheduler (a closed port seen
        // late reads as silence).
        c.timeout = Duration::from_millis(if matches!(kind, FaultKind::Silence) {
            800
        } else {
            20_000
        });
        let (vg, mut host) = VirtualGrbl::spawn(vcfg).unwrap();
        let (_tx, rx) = channel::<Control>();
        let mut quiet = Quiet;
        let mut console = Console::connect(&mut host, &c, Some(&rx), &mut quiet).unwrap();
        console.command("G0X1Y1").unwrap();
        let e = frame(
            &mut console,
            extent(),
            FrameTool::Laser { s: 10.0, z: None },
            3000.0,
        )
        .unwrap_err();
        drop(console);
        let m = e.to_string();
        assert!(m.contains(want), "{kind:?}: {m}");
        assert!(
            !m.contains("--from-line"),
            "a frame has no resume line: {m}"
        );
        assert_dark_after_stop(&vg.stop());
    }
    // The operator aborts (a / q / Esc / Ctrl-C).
    let (vg, mut host) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    let (tx, rx) = channel::<Control>();
    let mut quiet = Quiet;
    let c = cfg();
    let mut console = Console::connect(&mut host, &c, Some(&rx), &mut quiet).unwrap();
    tx.send(Control::Abort).unwrap();
    let e = frame(
        &mut console,
        extent(),
        FrameTool::Laser { s: 10.0, z: None },
        3000.0,
    )
    .unwrap_err();
    drop(console);
    assert!(matches!(e, FrameError::Aborted { .. }), "{e}");
    assert!(e.to_string().contains("laser and air off"), "{e}");
    assert_dark_after_stop(&vg.stop());
}

#[test]
fn a_locked_machine_is_not_framed() {
    let vcfg = VirtualConfig {
        pace: stencil_grbl::Pace::Timed { speedup: 1.0 },
        ..VirtualConfig::default()
    };
    let (vg, mut host) = VirtualGrbl::spawn(vcfg).unwrap();
    // A reset while moving leaves Grbl locked (ALARM:3).
    {
        use std::io::Write;
        host.write_all(b"G1X100F60\n").unwrap();
        std::thread::sleep(Duration::from_millis(200));
        host.write_all(&[0x18]).unwrap();
        std::thread::sleep(Duration::from_millis(200));
    }
    let (_tx, rx) = channel::<Control>();
    let mut quiet = Quiet;
    let c = cfg();
    let mut console = Console::connect(&mut host, &c, Some(&rx), &mut quiet).unwrap();
    let moves = vg.record().moves.len();
    let e = frame(
        &mut console,
        extent(),
        FrameTool::Laser { s: 0.0, z: None },
        3000.0,
    )
    .unwrap_err();
    drop(console);
    assert!(matches!(e, FrameError::Locked { .. }), "{e}");
    assert!(e.to_string().contains("unlock it ($X)"), "{e}");
    assert_eq!(vg.stop().moves.len(), moves, "a locked machine moved");
}

fn stencil() -> Command {
    Command::new(env!("CARGO_BIN_EXE_stencil"))
}

#[test]
fn cli_frames_refuses_off_bed_jobs_and_asks_before_sending() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("job.gcode");
    std::fs::write(&job, JOB).unwrap();
    let j = job.to_str().unwrap();
    let out = stencil().args(["frame", j, "--dry-run"]).output().unwrap();
    let so = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(so.contains("X 20.00..60.00 Y 30.00..70.00"), "{so}");
    assert!(
        so.contains("6 moves, 0 with the beam on; laser off"),
        "{so}"
    );
    // A profile with frame_power_pct: M4 at that share of s_max, lit only along the frame.
    let diode = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/profiles/machines/diode-400.toml"
    ))
    .unwrap()
    .replace("frame_power_pct = 0", "frame_power_pct = 1.5");
    let prof = dir.path().join("dim.toml");
    std::fs::write(&prof, diode).unwrap();
    let out = stencil()
        .args(["frame", j, "--dry-run", "--machine", prof.to_str().unwrap()])
        .output()
        .unwrap();
    let (so, se) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(
        so.contains("6 moves, 4 with the beam on; laser off"),
        "{so}{se}"
    );
    assert!(se.contains("laser dim at S15 (M4)"), "{se}");
    // Off the bed of a 300 x 220 mm plotter.
    let far = dir.path().join("far.gcode");
    std::fs::write(&far, JOB.replace("X60", "X360")).unwrap();
    let out = stencil()
        .args([
            "frame",
            far.to_str().unwrap(),
            "--dry-run",
            "--machine",
            "pen-servo",
        ])
        .output()
        .unwrap();
    let se = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        se.contains("the bed of pen-servo is 300 mm wide")
            && se.contains("X 0..300")
            && se.contains("360"),
        "{se}"
    );
    // Nothing that cuts: nothing to frame.
    let travel = dir.path().join("travel.gcode");
    std::fs::write(&travel, "G0 X10 Y10\nG0 X0 Y0\n").unwrap();
    let out = stencil()
        .args(["frame", travel.to_str().unwrap(), "--dry-run"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("nothing to frame"));
    // send --frame without a terminal to ask on: refused before anything moves.
    let out = stencil()
        .args(["send", j, "--dry-run", "--frame"])
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    let se = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        se.contains("stdin is not a terminal") && se.contains("--yes"),
        "{se}"
    );
    assert!(out.stdout.is_empty());
    // With --yes: framed, then the job streamed.
    let out = stencil()
        .args(["send", j, "--dry-run", "--frame", "--yes"])
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    let se = String::from_utf8_lossy(&out.stderr);
    let so = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{se}");
    assert!(se.contains("framed on the virtual Grbl"), "{se}");
    assert!(
        so.contains("sent 14 lines") && so.contains("laser off"),
        "{so}"
    );
}

/// Issue 39 item 4: a laser job focused at Z5 that travels at Z0 is framed around what its beam
/// cuts, at its own Z; a travel off the bed is refused by `frame` as by `estimate`.
#[test]
fn a_laser_job_with_its_own_z_is_framed_at_that_z_and_bed_checked_as_estimate_does() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("z5.gcode");
    std::fs::write(
        &job,
        "G21 G90\nG0 Z5\nM4 S0\nG0 X10 Y10\nG1 X20 S500 F1200\nG1 Y20\nM5\nG0 X0 Y0 Z0\n",
    )
    .unwrap();
    let out = stencil()
        .args(["frame", job.to_str().unwrap(), "--dry-run"])
        .output()
        .unwrap();
    let (so, se) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{so}{se}");
    assert!(
        so.contains("the job cuts within X 10.00..20.00 Y 10.00..20.00"),
        "{so}{se}"
    );
    assert!(se.contains("at the job's Z5.000"), "{se}");

    // A travel off the bed: refused before anything moves, by both commands.
    let off = dir.path().join("off.gcode");
    std::fs::write(
        &off,
        "G21 G90\nG0 Z5\nM4 S0\nG0 X-30 Y10\nG0 X10 Y10\nG1 X20 S500 F1200\nM5\n",
    )
    .unwrap();
    for cmd in [&["frame", "--dry-run"][..], &["estimate"][..]] {
        let out = stencil()
            .arg(cmd[0])
            .arg(&off)
            .args(&cmd[1..])
            .output()
            .unwrap();
        let se = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{cmd:?}: {se}");
        assert!(se.contains("X -30.0 mm at line 4"), "{cmd:?}: {se}");
    }
}
