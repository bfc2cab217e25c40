//! `stencil send` at the machine (issue 14): a resume that lifts before it travels, the laser-mode
//! check, stall detection, overrides, air off in every stop path, and job recovery from the
//! journal. Everything streams through the virtual Grbl on a pseudo-terminal.

use std::time::Duration;

use geo::{Coord, LineString, MultiPolygon, Polygon, Rect};
use stencil_grbl::{
    send, Clock, ClockRef, Control, Event, FaultKind, Journal, Key, KeySource, LaserMode,
    MachineError, Observer, Pace, PlannedMove, Program, Progress, Quiet, Record, ResumeLift,
    RunState, StreamConfig, VirtualConfig, VirtualGrbl,
};

use crate::common::faulty;
use stencil_gcode::machine::{self as machine_profile, Machine, PenLift, Tool};
use stencil_gcode::CutLoops;
use stencil_gcode::{gcode_for, CutSettings, PlanConfig};

fn cfg() -> StreamConfig {
    StreamConfig {
        boot_wait: Duration::from_millis(300),
        timeout: Duration::from_secs(5),
        ..StreamConfig::default()
    }
}

fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Polygon<f64> {
    Polygon::new(
        LineString::from(vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)]),
        vec![],
    )
}

/// A job as `stencil make` writes it for `machine`: four squares spread over 120 × 90 mm.
fn planned(machine: &Machine) -> String {
    let cuts = vec![
        rect(10.0, 10.0, 30.0, 30.0),
        rect(90.0, 10.0, 110.0, 30.0),
        rect(90.0, 60.0, 110.0, 80.0),
        rect(10.0, 60.0, 30.0, 80.0),
    ];
    let outline = Rect::new(Coord { x: 0.0, y: 0.0 }, Coord { x: 120.0, y: 90.0 });
    let geom = CutLoops::drawn(outline, MultiPolygon(cuts));
    let settings = CutSettings {
        power_pct: 100.0,
        speed_mm_min: 1200.0,
        passes: 1,
        blade_offset_mm: if matches!(machine.tool, Tool::Knife { .. }) {
            0.25
        } else {
            0.0
        },
        air_assist: false,
    };
    // Placed away from the origin, so a resume travels in XY to the first cut.
    let mut cfg = PlanConfig::new(settings);
    cfg.offset = [5.0, 5.0];
    gcode_for(&geom, machine, &cfg, &[]).unwrap().0
}

/// What `stencil send` tells the streamer about the tool (see `src/cli/send/mod.rs`).
fn lift_of(machine: &Machine) -> ResumeLift {
    match machine.tool {
        Tool::Pen(PenLift::Z(z)) | Tool::Knife { z, .. } => ResumeLift {
            z_up_mm: Some(z.up_mm),
            plunge_mm_min: Some(z.plunge_mm_min),
        },
        _ => ResumeLift::default(),
    }
}

/// The tool is down (cutting or drawing) when line `l` starts.
fn tool_down_at(job: &Program, machine: &Machine, l: usize) -> bool {
    let m = job.state_before(l).unwrap().modal;
    match machine.tool {
        Tool::Pen(PenLift::Z(z)) | Tool::Knife { z, .. } => m.pos[2] < z.up_mm,
        _ => m.spindle_on,
    }
}

/// Moves the virtual Grbl planned for the received lines from index `from` on whose line is one of
/// the first `n` G-code lines received there (the restore preamble).
fn preamble_moves(r: &Record, from: usize, n: usize) -> Vec<PlannedMove> {
    let idx: Vec<usize> = (from..r.received.len())
        .filter(|&i| !r.received[i].check_mode && !r.received[i].text.starts_with('$'))
        .take(n)
        .collect();
    r.moves
        .iter()
        .filter(|m| idx.contains(&m.idx))
        .copied()
        .collect()
}

/// Checks one resume's restore moves on `machine`: travel in XY only with the tool up (at or above
/// the up height and never below zero for a Z tool; spindle off for a servo pen), then the tool
/// back down where the program had it (a Z tool by a Z-only feed move at the plunge feed).
fn assert_safe_restore(
    machine: &Machine,
    job: &Program,
    from: usize,
    moves: &[PlannedMove],
    what: &str,
) {
    let st = job.state_before(from).unwrap();
    let xy: Vec<&PlannedMove> = moves.iter().filter(|m| m.moves_xy()).collect();
    assert_eq!(xy.len(), 1, "{what}: one XY travel expected: {moves:?}");
    match machine.tool {
        Tool::Pen(PenLift::Z(z)) | Tool::Knife { z, .. } => {
            for m in &xy {
                assert!(
                    m.from[2] >= z.up_mm - 1e-9 && m.to[2] >= z.up_mm - 1e-9,
                    "{what}: XY travel with the tool below Z{}: {m:?}",
                    z.up_mm
                );
            }
            // Nothing on the way goes down (so nothing goes below zero from a machine at Z0);
            // only the final plunge lowers the tool, to the cut depth.
            let (last, before) = moves.split_last().unwrap();
            for m in before {
                assert!(
                    m.to[2] >= m.from[2],
                    "{what}: the tool went down on the way: {m:?}"
                );
                assert!(m.to[2] >= 0.0, "{what}: below zero on the way: {m:?}");
            }
            assert!(
                !last.moves_xy() && !last.rapid,
                "{what}: no plunge at the end: {last:?}"
            );
            assert_eq!(last.to[2], st.modal.pos[2], "{what}");
            assert!(last.from[2] >= z.up_mm - 1e-9, "{what}: {last:?}");
            let r = job.resume_preamble_with(from, &lift_of(machine)).unwrap();
            let plunge = format!("G1Z{}F{}", st.modal.pos[2], z.plunge_mm_min);
            assert!(r.contains(&plunge), "{what}: {r:?} lacks {plunge}");
        }
        Tool::Pen(PenLift::Spindle { .. }) => {
            for m in &xy {
                assert!(
                    !m.spindle_on,
                    "{what}: the servo pen was down during travel: {m:?}"
                );
            }
        }
        Tool::Laser { .. } => unreachable!(),
    }
    // At the resume point the tool is where the program had it.
    let xy = xy[0];
    assert_eq!(
        [xy.to[0], xy.to[1]],
        [st.modal.pos[0], st.modal.pos[1]],
        "{what}"
    );
}

#[test]
fn resume_lifts_travels_then_plunges_for_pen_knife_and_servo() {
    for name in ["pen-a3", "drag-knife", "pen-servo"] {
        let machine = machine_profile::load(Some(name)).unwrap();
        let text = planned(&machine);
        let job = Program::parse(&format!("{name}.gcode"), &text).unwrap();
        let down: Vec<usize> = job
            .lines
            .iter()
            .map(|l| l.number)
            .filter(|&l| l > 1 && tool_down_at(&job, &machine, l))
            .collect();
        assert!(down.len() >= 16, "{name}: {}", down.len());
        // Resume points in the first, a middle and the last square.
        let picks = [down[2], down[down.len() / 2], down[down.len() - 2]];
        let lift = lift_of(&machine);
        for &from in &picks {
            // A fresh machine at X0 Y0 Z0.
            let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
            let c = StreamConfig {
                from_line: from,
                lift,
                ..cfg()
            };
            send(&mut port, &job, &c, None, &mut Quiet).unwrap();
            let r = vg.stop();
            let n = job.resume_preamble_with(from, &lift).unwrap().len();
            let what = format!("{name}, fresh machine, from line {from}");
            assert_safe_restore(&machine, &job, from, &preamble_moves(&r, 0, n), &what);
            // The rest of the job ran once each after it.
            let body: Vec<&str> = job
                .lines
                .iter()
                .filter(|l| l.number >= from)
                .map(|l| l.text.as_str())
                .collect();
            let got: Vec<&str> = r
                .run_lines()
                .into_iter()
                .filter(|l| !l.starts_with('$'))
                .collect();
            assert_eq!(&got[n..], &body[..], "{what}");
        }
        // Stopped by an alarm (a limit switch) with the tool down in the first square, resumed in
        // the last one: the tool (a knife left at cutting depth) must come up before the long
        // travel. (An alarm drops the buffered lines at once, so the stop is where it happened.)
        let k = job.lines.iter().position(|l| l.number == down[3]).unwrap() + 1;
        let vcfg = faulty(FaultKind::Alarm(1), k);
        let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
        let err = send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap_err();
        assert!(matches!(err, MachineError::Alarm { .. }), "{err}");
        let r = vg.record();
        if let Tool::Knife { z, .. } | Tool::Pen(PenLift::Z(z)) = machine.tool {
            assert!(
                r.position[2] < z.up_mm,
                "{name}: the tool should be left down: {:?}",
                r.position
            );
        }
        let before = r.received.len();
        let from = picks[2];
        let c = StreamConfig {
            from_line: from,
            lift,
            unlock: true,
            ..cfg()
        };
        send(&mut port, &job, &c, None, &mut Quiet).unwrap();
        let r = vg.stop();
        let n = job.resume_preamble_with(from, &lift).unwrap().len();
        let what = format!("{name}, tool left down, from line {from}");
        assert_safe_restore(&machine, &job, from, &preamble_moves(&r, before, n), &what);
        assert!(!r.laser_on, "{what}");

        // Third-party G-code, no profile: the program's own travel height and plunge feed.
        if let Tool::Knife { z, .. } | Tool::Pen(PenLift::Z(z)) = machine.tool {
            let inferred = job.resume_preamble(from).unwrap();
            let profiled = job.resume_preamble_with(from, &lift).unwrap();
            assert_eq!(inferred, profiled, "{name}");
            assert_eq!(inferred[2], format!("G0Z{}", z.up_mm), "{name}");
        }
    }
}

// ---- every stop path: laser and air off -------------------------------------------------------

use crate::common_job;

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{channel, Sender};
use std::sync::Arc;

/// The standard test job with air assist: M8 after the laser is armed, M9 before the end.
fn air_job() -> Program {
    let text = common_job::job_text_scaled(1)
        .replacen("M4 S0\n", "M4 S0\nM8\n", 1)
        .replacen("M5\nG0 X0 Y0\n", "M9\nM5\nG0 X0 Y0\n", 1);
    Program::parse("air.gcode", &text).unwrap()
}

/// A clock that jumps `step` seconds each time it is read: stall bounds pass in a few status
/// reports, and nothing depends on how fast the test machine is.
struct StepClock {
    t: AtomicU64,
    step: u64,
}
impl Clock for StepClock {
    fn now(&self) -> Duration {
        Duration::from_secs(self.t.fetch_add(self.step, Ordering::SeqCst))
    }
}

fn step_clock(step: u64) -> ClockRef {
    ClockRef(Arc::new(StepClock {
        t: AtomicU64::new(0),
        step,
    }))
}

/// Lines the machine received after its last soft reset.
fn after_last_reset(r: &Record) -> Vec<String> {
    let k = r
        .events
        .iter()
        .rposition(|e| *e == Event::SoftReset)
        .expect("no soft reset");
    r.events[k..]
        .iter()
        .filter_map(|e| match e {
            Event::Line(i) => Some(r.received[*i].text.clone()),
            _ => None,
        })
        .collect()
}

/// The air was really on during the job (so "off at the stop" means something), and is off now.
fn air_was_on_and_is_off(r: &Record, what: &str) {
    assert!(
        r.moves.iter().any(|m| m.air),
        "{what}: the air never came on"
    );
    assert!(!r.air_on, "{what}: air still on");
    assert!(!r.laser_on, "{what}: laser still on");
}

/// Aborts (as Ctrl-C does) once `at` lines are acknowledged.
struct AbortAt {
    tx: Sender<Control>,
    at: Option<usize>,
}
impl Observer for AbortAt {
    fn progress(&mut self, p: &Progress) {
        if self.at.is_some_and(|a| p.acked >= a) {
            self.at = None;
            self.tx.send(Control::Abort).unwrap();
        }
    }
}

#[test]
fn every_stop_path_ends_with_laser_and_air_off() {
    let job = air_job();
    assert!(!job.may_end_air_on);

    // error:N - soft reset, then M9 and M5 (M5 last).
    let (vg, mut port) = VirtualGrbl::spawn(faulty(FaultKind::Error(22), 60)).unwrap();
    let err = send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap_err();
    assert!(matches!(err, MachineError::Rejected { .. }), "{err}");
    assert!(err.to_string().contains("M9 and M5 acknowledged"), "{err}");
    let r = vg.stop();
    air_was_on_and_is_off(&r, "error");
    assert_eq!(after_last_reset(&r), ["M9", "M5"], "error");

    // ALARM:N - the alarm and the reset kill both; G-code is locked out.
    let (vg, mut port) = VirtualGrbl::spawn(faulty(FaultKind::Alarm(1), 60)).unwrap();
    let err = send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap_err();
    assert!(matches!(err, MachineError::Alarm { .. }), "{err}");
    assert!(err.to_string().contains("laser and air off"), "{err}");
    air_was_on_and_is_off(&vg.stop(), "alarm");

    // The port vanishes (the board lost power): nothing can be sent; the message says to check.
    let (vg, mut port) = VirtualGrbl::spawn(faulty(FaultKind::ClosePort, 60)).unwrap();
    let err = send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap_err();
    assert!(matches!(err, MachineError::PortLost { .. }), "{err}");
    assert!(err.to_string().contains("air"), "{err}");
    air_was_on_and_is_off(&vg.stop(), "port lost");

    // Silent controller: reset, then M9 and M5 sent blind.
    let (vg, mut port) = VirtualGrbl::spawn(faulty(FaultKind::Silence, 60)).unwrap();
    let c = StreamConfig {
        timeout: Duration::from_secs(1),
        ..cfg()
    };
    let err = send(&mut port, &job, &c, None, &mut Quiet).unwrap_err();
    assert!(matches!(err, MachineError::Silent { .. }), "{err}");
    for _ in 0..200 {
        if vg.record().received.last().is_some_and(|l| l.text == "M5") {
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let r = vg.stop();
    air_was_on_and_is_off(&r, "silent");
    assert_eq!(after_last_reset(&r), ["M9", "M5"], "silent");

    // Operator abort (a / q / Esc / Ctrl-C) while moving.
    let vcfg = VirtualConfig {
        pace: Pace::Timed { speedup: 20.0 },
        ..VirtualConfig::default()
    };
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let (tx, rx) = channel();
    let mut op = AbortAt { tx, at: Some(60) };
    let err = send(&mut port, &job, &cfg(), Some(&rx), &mut op).unwrap_err();
    assert!(matches!(err, MachineError::Aborted { .. }), "{err}");
    let r = vg.stop();
    air_was_on_and_is_off(&r, "abort");
    assert_eq!(after_last_reset(&r), ["M9", "M5"], "abort");

    // Stall (frozen in Run while answering status).
    let (vg, mut port) = VirtualGrbl::spawn(faulty(FaultKind::Freeze, 60)).unwrap();
    let c = StreamConfig {
        clock: step_clock(10),
        ..cfg()
    };
    let err = send(&mut port, &job, &c, None, &mut Quiet).unwrap_err();
    assert!(matches!(err, MachineError::Stalled { .. }), "{err}");
    let r = vg.stop();
    air_was_on_and_is_off(&r, "stall");
    assert_eq!(after_last_reset(&r), ["M9", "M5"], "stall");

    // A job that ends with the air still on gets M9 after it.
    let text = common_job::job_text_scaled(1).replacen("M4 S0\n", "M4 S0\nM8\n", 1);
    let open_air = Program::parse("open-air.gcode", &text).unwrap();
    assert!(open_air.may_end_air_on);
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    send(&mut port, &open_air, &cfg(), None, &mut Quiet).unwrap();
    let r = vg.stop();
    air_was_on_and_is_off(&r, "job without M9");
    assert_eq!(r.received.last().unwrap().text, "M9");
}

#[test]
fn a_machine_frozen_in_run_is_a_stall_stopped_with_the_resume_line() {
    let job = common_job::job_text_scaled(1);
    let job = Program::parse("frozen.gcode", &job).unwrap();
    let k = 90;
    let (vg, mut port) = VirtualGrbl::spawn(faulty(FaultKind::Freeze, k)).unwrap();
    let c = StreamConfig {
        clock: step_clock(1),
        rapid_mm_min: Some(6000.0),
        ..cfg()
    };
    let err = send(&mut port, &job, &c, None, &mut Quiet).unwrap_err();
    let msg = err.to_string();
    let MachineError::Stalled {
        still_s,
        bound_s,
        halt,
        ..
    } = &err
    else {
        panic!("{msg}")
    };
    // The bound is the job's own: its longest move (a 10 mm square side in 5 segments at
    // 1200 mm/min is 0.1 s; the longest is a G0 of ~58 mm at 6000 mm/min, 0.58 s) x 1.5 + 5 s.
    let slowest = stencil_grbl::slowest_step(&job, Some(6000.0)).as_secs_f64();
    assert!((0.5..0.7).contains(&slowest), "{slowest}");
    assert!((*bound_s - (slowest * 1.5 + 5.0)).abs() < 1e-6, "{bound_s}");
    assert!(*still_s > *bound_s, "{msg}");
    // The frozen line never ran: resume there (or before).
    let frozen_line = job.lines[k - 1].number;
    assert!(halt.resume_from <= frozen_line, "{msg}");
    assert!(halt.last_acked.unwrap() < frozen_line, "{msg}");
    assert!(
        msg.contains(&format!("resume from line {}", halt.resume_from)),
        "{msg}"
    );
    assert!(msg.contains("stall"), "{msg}");
    let r = vg.stop();
    // Feed hold, then soft reset; then laser off.
    let hold = r
        .events
        .iter()
        .rposition(|e| *e == Event::Realtime(b'!'))
        .unwrap();
    let reset = r
        .events
        .iter()
        .rposition(|e| *e == Event::SoftReset)
        .unwrap();
    assert!(hold < reset);
    assert!(!r.frozen && !r.laser_on);
    assert_eq!(after_last_reset(&r).last().map(String::as_str), Some("M5"));

    // A slow machine that keeps moving is never a stall, whatever the clock says.
    let vcfg = VirtualConfig {
        pace: Pace::Timed { speedup: 30.0 },
        ..VirtualConfig::default()
    };
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let c = StreamConfig {
        clock: step_clock(1),
        rapid_mm_min: Some(6000.0),
        ..cfg()
    };
    send(&mut port, &job, &c, None, &mut Quiet).unwrap();
    drop(vg);
}

// ---- laser mode ($32) -------------------------------------------------------------------------

fn laser_off_grbl() -> VirtualConfig {
    VirtualConfig {
        settings: vec![(32, "0".into())],
        ..VirtualConfig::default()
    }
}

#[test]
fn a_laser_job_is_refused_without_laser_mode_or_sets_it_when_asked() {
    let job = Program::parse("laser.gcode", &common_job::job_text_scaled(1)).unwrap();

    // Why it matters, on the simulated machine: with $32=0 the beam stays on through G0 moves.
    let (vg, mut port) = VirtualGrbl::spawn(laser_off_grbl()).unwrap();
    send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap();
    let r = vg.stop();
    assert!(
        r.moves.iter().any(|m| m.rapid && m.beam),
        "no dark-move burn modelled"
    );

    // Refused before anything is sent, naming the setting and the fix.
    let (vg, mut port) = VirtualGrbl::spawn(laser_off_grbl()).unwrap();
    let c = StreamConfig {
        laser_mode: LaserMode::Require,
        ..cfg()
    };
    let err = send(&mut port, &job, &c, None, &mut Quiet).unwrap_err();
    assert!(matches!(err, MachineError::LaserModeOff { .. }), "{err}");
    let msg = err.to_string();
    assert!(msg.contains("$32=0") && msg.contains("Set $32=1"), "{msg}");
    let r = vg.stop();
    assert_eq!(r.run_lines(), ["$I", "$$"], "something was sent");
    assert!(!r.laser_mode);

    // With --set-laser-mode: $32=1 is written (alone, before the job), then the job runs dark
    // in every G0.
    let (vg, mut port) = VirtualGrbl::spawn(laser_off_grbl()).unwrap();
    let c = StreamConfig {
        laser_mode: LaserMode::Set,
        ..cfg()
    };
    let mut notes = Notes::default();
    send(&mut port, &job, &c, None, &mut notes).unwrap();
    let r = vg.stop();
    assert!(r.laser_mode);
    assert_eq!(r.run_lines()[..4], ["$I", "$$", "$32=1", "$$"]);
    assert_eq!(r.eeprom_lost_bytes, 0);
    assert!(!r.moves.iter().any(|m| m.rapid && m.beam));
    assert!(
        notes.0.iter().any(|n| n.contains("set $32=1")),
        "{:?}",
        notes.0
    );

    // Already on: checked and left alone.
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    let c = StreamConfig {
        laser_mode: LaserMode::Set,
        ..cfg()
    };
    send(&mut port, &job, &c, None, &mut Quiet).unwrap();
    let r = vg.stop();
    assert!(!r.run_lines().contains(&"$32=1"));
    assert_eq!(r.run_lines()[..2], ["$I", "$$"]);
}

/// Collects the streamer's messages.
#[derive(Default)]
struct Notes(Vec<String>);
impl Observer for Notes {
    fn message(&mut self, text: &str) {
        self.0.push(text.to_string());
    }
}

fn stencil() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_stencil"))
}

#[test]
fn cli_laser_mode_check_in_a_dry_run() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("laser.gcode");
    std::fs::write(&file, common_job::job_text_scaled(1)).unwrap();
    let run = |args: &[&str]| {
        let out = stencil()
            .arg("send")
            .arg(&file)
            .args(args)
            .output()
            .unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).to_string(),
            String::from_utf8_lossy(&out.stderr).to_string(),
        )
    };
    let (ok, so, se) = run(&["--dry-run", "--dry-run-setting", "$32=0"]);
    assert!(!ok, "{so}{se}");
    assert!(
        se.contains("$32=0") && se.contains("--set-laser-mode"),
        "{se}"
    );
    assert!(!so.contains("sent "), "{so}");
    let (ok, so, se) = run(&[
        "--dry-run",
        "--dry-run-setting",
        "$32=0",
        "--set-laser-mode",
    ]);
    assert!(ok, "{so}{se}");
    assert!(se.contains("set $32=1"), "{se}");
    assert!(so.contains("$32=1"), "{so}");
    // A pen machine's job is not a laser job: $32 is left alone.
    let (ok, so, se) = run(&[
        "--dry-run",
        "--dry-run-setting",
        "$32=0",
        "--machine",
        "pen-servo",
    ]);
    assert!(ok, "{so}{se}");
    assert!(so.contains("$32=0"), "{so}");
    // A bad setting is named.
    let (ok, _, se) = run(&["--dry-run", "--dry-run-setting", "32"]);
    assert!(!ok && se.contains("$N=VALUE"), "{se}");
}

// ---- overrides from keys ----------------------------------------------------------------------

/// Keys typed by a test: each one once the observer has opened its gate (phase), then the
/// source ends.
struct TypedKeys {
    keys: Vec<(u64, Key)>,
    phase: Arc<AtomicU64>,
}
impl KeySource for TypedKeys {
    fn next_key(&mut self, wait: Duration) -> std::io::Result<Option<Key>> {
        let Some(&(gate, k)) = self.keys.first() else {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        };
        if self.phase.load(Ordering::SeqCst) < gate {
            std::thread::sleep(wait.min(Duration::from_millis(5)));
            return Ok(None);
        }
        self.keys.remove(0);
        Ok(Some(k))
    }
}

/// Records the overrides the progress line would show, and opens the key gates: phase 1 once
/// 30 lines are acknowledged, phase 2 once the first keys' overrides were reported.
struct Watch {
    phase: Arc<AtomicU64>,
    shown: Vec<String>,
}
impl Observer for Watch {
    fn progress(&mut self, p: &Progress) {
        if p.acked >= 30 {
            self.phase.fetch_max(1, Ordering::SeqCst);
        }
        if let Some(ov) = p.overrides {
            let t = stencil_grbl::overrides_text(ov);
            if t == "Ov F120% S90%" {
                self.phase.fetch_max(2, Ordering::SeqCst);
            }
            if self.shown.last() != Some(&t) {
                self.shown.push(t);
            }
        }
    }
}

#[test]
fn override_keys_during_send_reach_grbl_and_show_in_progress() {
    let job = Program::parse("ov.gcode", &common_job::job_text_scaled(3)).unwrap();
    let vcfg = VirtualConfig {
        pace: Pace::Timed { speedup: 20.0 },
        ..VirtualConfig::default()
    };
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let phase = Arc::new(AtomicU64::new(0));
    let typed = vec![
        (1, Key::Char('+')),
        (1, Key::Char('+')),
        (1, Key::Char('[')),
        (2, Key::Char('0')),
        (2, Key::Char('-')),
        (2, Key::Char(']')),
    ];
    let mut source = TypedKeys {
        keys: typed,
        phase: phase.clone(),
    };
    let (tx, rx) = channel();
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let stop2 = stop.clone();
    let pump = std::thread::spawn(move || stencil_grbl::pump(&mut source, &tx, &stop2));
    let mut watch = Watch {
        phase,
        shown: Vec::new(),
    };
    send(&mut port, &job, &cfg(), Some(&rx), &mut watch).unwrap();
    stop.store(true, Ordering::SeqCst);
    pump.join().unwrap();
    let r = vg.stop();
    let bytes: Vec<u8> = r
        .events
        .iter()
        .filter_map(|e| match e {
            Event::Realtime(b) if *b >= 0x90 => Some(*b),
            _ => None,
        })
        .collect();
    assert_eq!(bytes, [0x91, 0x91, 0x9B, 0x90, 0x99, 0x92, 0x9A]);
    // The progress line showed Grbl's own Ov: after each burst of keys.
    assert!(
        watch.shown.contains(&"Ov F120% S90%".to_string()),
        "{:?}",
        watch.shown
    );
    assert!(
        watch.shown.contains(&"Ov F90% S110%".to_string()),
        "{:?}",
        watch.shown
    );
    assert_eq!(r.overrides, [90, 100, 110]);
    // Overrides change no line: the program arrived whole, once.
    let got: Vec<&str> = r
        .run_lines()
        .into_iter()
        .filter(|l| !l.starts_with('$'))
        .collect();
    let want: Vec<&str> = job.lines.iter().map(|l| l.text.as_str()).collect();
    assert_eq!(got, want);
}

// ---- job recovery: the journal and --recover ---------------------------------------------------

fn run_send(file: &std::path::Path, args: &[&str]) -> (bool, String, String) {
    let out = stencil().arg("send").arg(file).args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).to_string(),
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}

/// "sent N lines" from `send`'s summary.
fn lines_sent(stdout: &str) -> usize {
    let rest = stdout
        .lines()
        .find_map(|l| l.strip_prefix("sent "))
        .expect(stdout);
    rest.split(' ').next().unwrap().parse().expect(stdout)
}

#[test]
fn a_run_whose_port_dies_leaves_a_journal_and_recover_resumes_from_it() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("job.gcode");
    let text = common_job::job_text_scaled(1);
    std::fs::write(&file, &text).unwrap();
    let job = Program::parse("job.gcode", &text).unwrap();
    let jpath = stencil_grbl::journal_path(&file);

    // No journal yet: --recover says so, and sends nothing.
    let (ok, so, se) = run_send(&file, &["--dry-run", "--recover"]);
    assert!(
        !ok && se.contains("no journal") && !so.contains("sent "),
        "{so}{se}"
    );

    let k = 120;
    let (ok, so, se) = run_send(
        &file,
        &["--dry-run", "--dry-run-fault", &format!("close@{k}")],
    );
    assert!(!ok, "{so}{se}");
    assert!(se.contains("went away") && se.contains("--recover"), "{se}");
    let j = Journal::read(&jpath).unwrap();
    assert_eq!(j.state, RunState::Stopped);
    assert!(j.stop_reason.as_deref().unwrap().contains("went away"));
    let dead = job.lines[k - 1].number;
    let acked = j.last_acked_line.unwrap();
    assert!(acked < dead, "{acked} {dead}");
    assert!(j.resume_from <= acked + 1, "{j:?}");
    assert_eq!(j.machine, "diode-400");
    // The modal state recorded is the program's before the resume line.
    let st = job.state_before(j.resume_from).unwrap().modal;
    assert_eq!(j.modal.position_mm, st.pos);
    assert_eq!(j.modal.feed_mm_min, st.feed);
    assert_eq!(j.modal.spindle, if st.spindle_on { "M4" } else { "M5" });
    // The hint printed at the stop matches the journal.
    assert!(
        se.contains(&format!("--from-line {}", j.resume_from)),
        "{se}"
    );

    // --recover --dry-run: a new virtual Grbl starts at machine zero, as a board without
    // homing does after a power loss (issue 23): the journal last saw the head elsewhere, so
    // nothing moves until the person says where the head is.
    let (ok, so, se) = run_send(&file, &["--dry-run", "--recover"]);
    assert!(!ok, "{so}{se}");
    assert!(
        se.contains("no longer knows where the head is") && se.contains("nothing was moved"),
        "{se}"
    );
    assert!(
        se.contains("--head-at-corner") && se.contains("--position-confirmed"),
        "{se}"
    );
    assert!(!so.lines().any(|l| l.starts_with("sent ")), "{so}");
    assert!(
        so.contains("virtual Grbl: ") && so.contains("alarms: none"),
        "{so}"
    );
    // Confirmed: says what it knows, resumes from the proposed line.
    let (ok, so, se) = run_send(&file, &["--dry-run", "--recover", "--position-confirmed"]);
    assert!(ok, "{so}{se}");
    assert!(
        so.contains(&format!("last acknowledged line: {acked}")),
        "{so}"
    );
    assert!(so.contains("acknowledged means queued"), "{so}");
    assert!(
        so.contains(&format!("resuming from line {}", j.resume_from)),
        "{so}"
    );
    let rest = job
        .lines
        .iter()
        .filter(|l| l.number >= j.resume_from)
        .count();
    assert_eq!(lines_sent(&so), rest, "{so}");
    assert!(
        se.contains(&format!("resuming at line {}", j.resume_from)),
        "{se}"
    );
    // A finished job leaves no journal.
    assert!(!jpath.exists());

    // A journal for another version of the file is refused, naming both, and nothing is sent.
    let (ok, ..) = run_send(
        &file,
        &["--dry-run", "--dry-run-fault", &format!("close@{k}")],
    );
    assert!(!ok);
    std::fs::write(&file, format!("{text}; edited\n")).unwrap();
    let (ok, so, se) = run_send(&file, &["--dry-run", "--recover"]);
    assert!(!ok, "{so}{se}");
    assert!(
        se.contains("different") && se.contains("job.gcode.journal"),
        "{se}"
    );
    assert!(
        se.contains("nothing was sent") && !so.contains("sent "),
        "{so}{se}"
    );
    // Not a journal at all.
    std::fs::write(&jpath, "{\"hello\": 1}").unwrap();
    let (ok, _, se) = run_send(&file, &["--dry-run", "--recover"]);
    assert!(!ok && se.contains("not a stencil send journal"), "{se}");
}

#[test]
fn a_killed_sender_leaves_a_running_journal_that_recover_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("job.gcode");
    let text = common_job::job_text_scaled(1);
    std::fs::write(&file, &text).unwrap();
    let jpath = stencil_grbl::journal_path(&file);
    // Paced like the machine (about 20 s): killed once the journal shows progress.
    let mut child = stencil()
        .args(["send", "--dry-run", "--realtime"])
        .arg(&file)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut seen = None;
    for _ in 0..600 {
        if let Ok(j) = Journal::read(&jpath) {
            // Progress, and where a status report put the head (the journal is written as
            // each line goes out, before any report may have come).
            if j.last_acked_line.is_some() && j.last_position.is_some_and(|p| p[0] > 0.5) {
                seen = Some(j);
                break;
            }
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let j = seen.expect("no journal with progress within 30 s");
    let j2 = Journal::read(&jpath).unwrap();
    assert_eq!(j2.state, RunState::Running, "{j2:?}");
    assert!(j2.last_acked_line >= j.last_acked_line);
    // The killed run's virtual Grbl went with it: the new one stands at machine zero, which
    // the journal's last position contradicts, so the resume waits for the person's word.
    let (ok, so, se) = run_send(&file, &["--dry-run", "--recover"]);
    assert!(
        !ok && se.contains("no longer knows where the head is"),
        "{so}{se}"
    );
    let (ok, so, se) = run_send(&file, &["--dry-run", "--recover", "--position-confirmed"]);
    assert!(ok, "{so}{se}");
    assert!(so.contains("did not end"), "{so}");
    assert!(
        so.contains(&format!("resuming from line {}", j2.resume_from)),
        "{so}"
    );
}

#[test]
fn recover_homes_first_when_the_profile_says_the_machine_homes() {
    let dir = tempfile::tempdir().unwrap();
    let profile = dir.path().join("homing-laser.toml");
    let diode = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("profiles/machines/diode-400.toml"),
    )
    .unwrap();
    let homing = diode
        .replace("name = \"diode-400\"", "name = \"homing-laser\"")
        .replace("homing = false", "homing = true");
    assert!(homing.contains("homing = true"));
    std::fs::write(&profile, homing).unwrap();
    let file = dir.path().join("job.gcode");
    std::fs::write(&file, common_job::job_text_scaled(1)).unwrap();
    let p = profile.to_str().unwrap();
    let (ok, ..) = run_send(
        &file,
        &[
            "--dry-run",
            "--machine",
            p,
            "--dry-run-fault",
            "error:20@100",
        ],
    );
    assert!(!ok);
    // The journal names the profile by name and content, never by the path it was read from:
    // a recovery does not open files a journal names, so this one must be named again.
    let jpath = stencil_grbl::journal_path(&file);
    let j = Journal::read(&jpath).unwrap();
    assert_eq!(j.machine, "homing-laser");
    assert!(j.machine_fnv1a64.is_some(), "{j:?}");
    let (ok, so, se) = run_send(&file, &["--dry-run", "--recover"]);
    assert!(!ok, "{so}{se}");
    assert!(
        se.contains("`homing-laser`")
            && se.contains("--machine")
            && se.contains("nothing was sent"),
        "{se}"
    );
    assert!(!so.contains("virtual Grbl"), "{so}");
    // Another profile than the run's is refused, naming both.
    let (ok, so, se) = run_send(&file, &["--dry-run", "--recover", "--machine", "diode-400"]);
    assert!(!ok, "{so}{se}");
    assert!(
        se.contains("homing-laser") && se.contains("diode-400") && se.contains("nothing was sent"),
        "{se}"
    );
    // The run's own profile, named: the recovery homes first as it says.
    let (ok, so, se) = run_send(&file, &["--dry-run", "--recover", "--machine", p]);
    assert!(ok, "{so}{se}");
    assert!(so.contains("homes") && se.contains("homed"), "{so}{se}");

    // In the streamer: $H goes right after connecting, before the restore; an alarm-locked
    // machine is homed, not refused.
    let job = Program::parse("job.gcode", &common_job::job_text_scaled(1)).unwrap();
    let (vg, mut port) = VirtualGrbl::spawn(faulty(FaultKind::Alarm(1), 50)).unwrap();
    assert!(send(&mut port, &job, &cfg(), None, &mut Quiet).is_err());
    let before = vg.record().received.len();
    let c = StreamConfig {
        from_line: 100,
        home_first: true,
        ..cfg()
    };
    send(&mut port, &job, &c, None, &mut Quiet).unwrap();
    let r = vg.stop();
    let got: Vec<&str> = r.received[before..]
        .iter()
        .map(|l| l.text.as_str())
        .collect();
    assert_eq!(got[..4], ["$I", "$$", "$H", "M5"], "{got:?}");
}

/// Issue 39, item 4: text from a file (a G-code header's "from" and "material" lines, a journal's
/// stop reason, file and machine) is printed with its control characters written out, so that
/// an escape sequence in a received job cannot retitle, clear or recolour the terminal.
#[test]
fn file_text_is_printed_without_terminal_escapes() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("job.gcode");
    let evil = "\u{1b}]0;pwned\u{7}\u{1b}[2J\u{1b}[8m\u{9b}31m";
    let text = format!(
        "; stencil 0.1.0 for diode-400: test\n; from {evil}photo.png\n; material {evil}card\n"
    ) + &common_job::job_text_scaled(1);
    std::fs::write(&file, &text).unwrap();
    let clean = |what: &str, so: &str, se: &str| {
        for out in [so, se] {
            assert!(
                !out.contains('\u{1b}') && !out.contains('\u{7}') && !out.contains('\u{9b}'),
                "{what}: a control character was printed raw: {out:?}"
            );
        }
    };
    for cmd in ["estimate", "simulate"] {
        let mut c = stencil();
        c.arg(cmd).arg(&file);
        if cmd == "simulate" {
            c.arg("-o").arg(dir.path().join("sim.png"));
        }
        let o = c.output().unwrap();
        let (so, se) = (
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr),
        );
        clean(cmd, &so, &se);
        assert!(o.status.success(), "{cmd}: {so}{se}");
    }
    let (ok, so, se) = run_send(&file, &["--dry-run", "--dry-run-fault", "close@40"]);
    assert!(!ok, "{so}{se}");
    clean("send", &so, &se);
    // The origin line shows the header's text, its escapes written out.
    assert!(se.contains("from \\u{1b}]0;pwned\\u{7}"), "{se}");
    // A journal (a file, maybe received with the job) whose text carries escapes.
    let jpath = stencil_grbl::journal_path(&file);
    let mut j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&jpath).unwrap()).unwrap();
    j["stop_reason"] = format!("{evil}the port went away").into();
    j["file"] = format!("{evil}job.gcode").into();
    j["modal"]["units"] = format!("{evil}G21").into();
    std::fs::write(&jpath, serde_json::to_string(&j).unwrap()).unwrap();
    let (_, so, se) = run_send(&file, &["--dry-run", "--recover"]);
    clean("send --recover", &so, &se);
    assert!(
        so.contains("stopped: \\u{1b}]0;pwned\\u{7}") && so.contains("the port went away"),
        "{so}"
    );
}

/// Issue 39 item 4: a journal's `"machine"` is a profile name, never a path to open; a journal
/// naming another profile than the one the run used (or whose content changed) is refused
/// before anything is sent.
#[test]
fn recover_never_opens_a_path_the_journal_names_and_refuses_another_profile() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("job.gcode");
    std::fs::write(&file, common_job::job_text_scaled(1)).unwrap();
    let (ok, ..) = run_send(&file, &["--dry-run", "--dry-run-fault", "error:20@60"]);
    assert!(!ok);
    let jpath = stencil_grbl::journal_path(&file);
    let original = std::fs::read_to_string(&jpath).unwrap();
    let j = Journal::read(&jpath).unwrap();
    assert_eq!(j.machine, "diode-400");
    let edit = |machine: &str| {
        let mut j2 = j.clone();
        j2.machine = machine.to_string();
        std::fs::write(&jpath, serde_json::to_string(&j2).unwrap()).unwrap();
    };
    // A path (or anything not a name) is not opened: refused, saying what to do.
    for bad in ["/etc/passwd", "big-bed.toml", "..\\evil", "x\u{1b}[2Jy"] {
        edit(bad);
        let (ok, so, se) = run_send(&file, &["--dry-run", "--recover"]);
        assert!(!ok, "{bad}: {so}{se}");
        assert!(
            se.contains("not a profile name") && se.contains("nothing was sent"),
            "{bad}: {se}"
        );
        assert!(!se.contains('\u{1b}'), "an escape printed raw: {se:?}");
        assert!(!so.contains("virtual Grbl"), "{bad}: {so}");
    }
    // Another shipped profile, named in the journal: its content is not the run's.
    edit("co2-600x400");
    let (ok, so, se) = run_send(&file, &["--dry-run", "--recover"]);
    assert!(!ok, "{so}{se}");
    assert!(
        se.contains("co2-600x400")
            && se.contains("other settings")
            && se.contains("nothing was sent"),
        "{se}"
    );
    // The run's own profile, by name: the recovery goes ahead.
    std::fs::write(&jpath, original).unwrap();
    let (ok, so, se) = run_send(&file, &["--dry-run", "--recover", "--position-confirmed"]);
    assert!(ok, "{so}{se}");
}

/// Issue 39 item 4: a saved controller state with a setting no Grbl can hold is refused by
/// `estimate`, naming the setting, instead of timing the job as 0 s (NaN).
#[test]
fn estimate_refuses_absurd_controller_settings_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("e.gcode");
    std::fs::write(&job, "G21 G90\nG1 X10 F600\n").unwrap();
    for (setting, name) in [
        ("$100=1e308", "$100=1e308"),
        ("$120=0", "$120=0"),
        ("$110=-5", "$110=-5"),
    ] {
        let st = dir.path().join("state.txt");
        std::fs::write(&st, format!("$110=6000\n{setting}\n")).unwrap();
        let out = stencil()
            .args(["estimate", job.to_str().unwrap(), "--controller-state"])
            .arg(&st)
            .output()
            .unwrap();
        let (so, se) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert!(!out.status.success(), "{setting}: {so}{se}");
        assert!(
            se.contains(name) && se.contains("state.txt") && !so.contains("NaN"),
            "{setting}: {so}{se}"
        );
    }
    let st = dir.path().join("state.txt");
    std::fs::write(&st, "$100=80\n$110=6000\n$120=1000\n").unwrap();
    let out = stencil()
        .args(["estimate", job.to_str().unwrap(), "--controller-state"])
        .arg(&st)
        .output()
        .unwrap();
    assert!(out.status.success());
}
