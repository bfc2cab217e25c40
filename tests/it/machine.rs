//! End-to-end: the real `send` path streaming to the virtual Grbl on a pseudo-terminal, faults and
//! resuming, check mode, and the `stencil send` / `stencil simulate` commands as a user runs them.

use std::process::Command;
use std::sync::mpsc::{channel, Sender};
use std::time::Duration;

use stencil_grbl::{
    send, Control, Event, FaultKind, FlowControl, MachineError, Observer, Pace, Program, Progress,
    Quiet, Record, StreamConfig, VirtualConfig, VirtualGrbl,
};

use crate::common::faulty;
use crate::common_job;
use common_job::job_text_scaled;

/// The standard test job (~270 lines).
fn job_text() -> String {
    job_text_scaled(1)
}

fn job() -> Program {
    Program::parse("test.gcode", &job_text()).unwrap()
}

fn cfg() -> StreamConfig {
    StreamConfig {
        boot_wait: Duration::from_millis(300),
        // How long a line may wait for its answer before the sender calls the replies lost.
        // Generous on purpose: the virtual Grbl runs in this process's threads, and on a
        // 2-core machine under load 15 a 5 s limit once lost replies mid-job. Tests about
        // lost replies set their own short limit.
        timeout: Duration::from_secs(30),
        ..StreamConfig::default()
    }
}

/// The G-code lines (not `$` commands) received outside check mode, from record index `from`.
fn program_received(r: &Record, from: usize) -> Vec<String> {
    r.received[from..]
        .iter()
        .filter(|l| !l.check_mode && !l.text.starts_with('$'))
        .map(|l| l.text.clone())
        .collect()
}

fn texts(job: &Program, from_line: usize) -> Vec<String> {
    job.lines
        .iter()
        .filter(|l| l.number >= from_line)
        .map(|l| l.text.clone())
        .collect()
}

/// The file line of the k-th (1-based) G-code line of the job.
fn file_line(job: &Program, k: usize) -> usize {
    job.lines[k - 1].number
}

/// Every job line before `resume` reached the machine and finished there (no gap when resuming).
fn assert_ran_everything_before(job: &Program, r: &Record, resume: usize) {
    let first_run: Vec<(usize, &str)> = r
        .received
        .iter()
        .enumerate()
        .filter(|(_, l)| !l.check_mode && !l.text.starts_with('$'))
        .map(|(i, l)| (i, l.text.as_str()))
        .collect();
    for (k, jl) in job
        .lines
        .iter()
        .take_while(|l| l.number < resume)
        .enumerate()
    {
        let (idx, text) = first_run[k];
        assert_eq!(text, jl.text, "line {}", jl.number);
        assert!(
            r.executed.contains(&idx),
            "line {} was acknowledged but never ran, yet resume starts at {resume}",
            jl.number
        );
    }
}

fn laser_stopped_after_fault(r: &Record) {
    assert!(!r.laser_on, "laser still on: {:?}", r.state);
    assert!(
        r.events.contains(&Event::SoftReset) || r.closed,
        "no soft reset recorded: {:?}",
        &r.events[r.events.len().saturating_sub(5)..]
    );
}

#[test]
fn streams_the_program_once_each_in_order_without_overflow() {
    let job = job();
    assert!(job.lines.len() > 250);
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    let sum = send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap();
    let r = vg.stop();
    assert_eq!(program_received(&r, 0), texts(&job, 1));
    assert_eq!(sum.lines, job.lines.len());
    assert_eq!(r.overflow_bytes, 0);
    assert!(r.max_rx_used <= 127, "{}", r.max_rx_used);
    assert!(sum.max_in_flight <= 127);
    // Character counting really keeps several lines in flight (not one at a time).
    assert!(sum.max_in_flight > 60, "{}", sum.max_in_flight);
    assert!(!r.laser_on);
    assert_eq!(r.position, [0.0; 3]);
}

#[test]
fn tiny_buffer_and_slow_machine_never_overflow() {
    let job = job();
    let vcfg = VirtualConfig {
        rx_buffer: 32,
        pace: Pace::Timed { speedup: 40.0 },
        ..VirtualConfig::default()
    };
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let sum = send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap();
    // The streamer learnt the buffer size from `$I`.
    assert_eq!(sum.info.rx_buffer, 32);
    assert_eq!(sum.rx_limit, 31);
    let r = vg.stop();
    assert_eq!(program_received(&r, 0), texts(&job, 1));
    assert_eq!(r.overflow_bytes, 0);
    assert!(r.max_rx_used <= 31, "{}", r.max_rx_used);
    // The machine was slower than the link: the buffer really filled up.
    assert!(r.max_rx_used >= 16, "{}", r.max_rx_used);
    assert!(r.status_reports > 0);
}

#[test]
fn send_response_sends_one_line_at_a_time() {
    let job = job();
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    let c = StreamConfig {
        flow: FlowControl::SendResponse,
        ..cfg()
    };
    let sum = send(&mut port, &job, &c, None, &mut Quiet).unwrap();
    let r = vg.stop();
    assert_eq!(program_received(&r, 0), texts(&job, 1));
    let longest = job.lines.iter().map(|l| l.text.len() + 1).max().unwrap();
    assert!(sum.max_in_flight <= longest);
}

#[test]
fn error_on_a_line_stops_safely_and_resume_finishes_the_job() {
    let job = job();
    let k = 120;
    let vcfg = faulty(FaultKind::Error(22), k);
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let err = send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap_err();
    let line = file_line(&job, k);
    let msg = err.to_string();
    let MachineError::Rejected { line: l, code, .. } = &err else {
        panic!("{err}")
    };
    assert_eq!((*l, *code), (line, 22));
    assert!(msg.contains(&format!("line {line}")), "{msg}");
    assert!(msg.contains(&job.lines[k - 1].text), "{msg}");
    assert!(msg.contains("feed"), "meaning of error 22 missing: {msg}");
    let halt = err.halt().unwrap();
    assert_eq!(halt.resume_from, line);
    assert!(msg.contains(&format!("resume from line {line}")), "{msg}");
    let r = vg.record();
    laser_stopped_after_fault(&r);
    assert_eq!(r.received.last().unwrap().text, "M5");
    assert_ran_everything_before(&job, &r, halt.resume_from);

    // Resume: the machine gets the state preamble, then each line from the resume point once.
    let before = r.received.len();
    let c = StreamConfig {
        from_line: halt.resume_from,
        ..cfg()
    };
    send(&mut port, &job, &c, None, &mut Quiet).unwrap();
    let r = vg.stop();
    let mut expected = job.resume_preamble(line).unwrap();
    expected.extend(texts(&job, line));
    assert_eq!(program_received(&r, before), expected);
    assert!(!r.laser_on);
    assert_eq!(r.position, [0.0; 3]);
}

#[test]
fn alarm_mid_job_stops_locks_and_resume_unlocks() {
    let job = job();
    let k = 150;
    let vcfg = faulty(FaultKind::Alarm(1), k);
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let err = send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, MachineError::Alarm { code: 1, .. }), "{msg}");
    assert!(msg.contains("ALARM:1") && msg.contains("limit"), "{msg}");
    let halt = err.halt().unwrap().clone();
    assert_eq!(halt.last_acked, Some(file_line(&job, k - 1)));
    // Grbl dropped its planner: acknowledged moves since the last status report may be lost.
    assert!(halt.resume_from <= file_line(&job, k));
    let r = vg.record();
    laser_stopped_after_fault(&r);
    assert!(r.events.contains(&Event::Alarm(1)));
    assert_eq!(r.state, "Alarm");
    assert_ran_everything_before(&job, &r, halt.resume_from);

    // Still locked: a plain send refuses and says how to unlock.
    let before = r.received.len();
    let err = send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap_err();
    assert!(matches!(err, MachineError::Locked { .. }), "{err}");
    assert!(err.to_string().contains("unlock it ($X)"), "{err}");

    let c = StreamConfig {
        from_line: halt.resume_from,
        unlock: true,
        ..cfg()
    };
    send(&mut port, &job, &c, None, &mut Quiet).unwrap();
    let r = vg.stop();
    let setup: Vec<&str> = r.received[before..]
        .iter()
        .filter(|l| l.text.starts_with('$'))
        .map(|l| l.text.as_str())
        .collect();
    // Each connection reads the build ($I) and the settings ($$, compared with the job's).
    assert_eq!(setup, ["$I", "$$", "$I", "$$", "$X"]);
    let mut expected = job.resume_preamble(halt.resume_from).unwrap();
    expected.extend(texts(&job, halt.resume_from));
    assert_eq!(program_received(&r, before), expected);
}

#[test]
fn silent_controller_is_reported_with_the_last_acknowledged_line() {
    let job = job();
    let k = 90;
    let vcfg = faulty(FaultKind::Silence, k);
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let c = StreamConfig {
        timeout: Duration::from_secs(1),
        ..cfg()
    };
    let err = send(&mut port, &job, &c, None, &mut Quiet).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, MachineError::Silent { .. }), "{msg}");
    let halt = err.halt().unwrap().clone();
    assert_eq!(halt.last_acked, Some(file_line(&job, k - 1)));
    assert!(halt.resume_from <= file_line(&job, k));
    assert!(
        msg.contains(&format!(
            "last acknowledged line {}",
            file_line(&job, k - 1)
        )),
        "{msg}"
    );
    // The M5 sent blindly after the reset is on its way: give the machine a moment to read it.
    for _ in 0..200 {
        if vg.record().received.last().is_some_and(|l| l.text == "M5") {
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let r = vg.stop();
    laser_stopped_after_fault(&r);
    assert_eq!(r.received.last().unwrap().text, "M5");
    assert_ran_everything_before(&job, &r, halt.resume_from);

    // A power-cycled controller finishes the job from the resume line.
    let (vg2, mut port2) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    let c = StreamConfig {
        from_line: halt.resume_from,
        ..cfg()
    };
    send(&mut port2, &job, &c, None, &mut Quiet).unwrap();
    let r2 = vg2.stop();
    let mut expected = job.resume_preamble(halt.resume_from).unwrap();
    expected.extend(texts(&job, halt.resume_from));
    assert_eq!(program_received(&r2, 0), expected);
    assert_eq!(r2.position, [0.0; 3]);
}

#[test]
fn vanished_port_is_reported_with_the_resume_line() {
    let job = job();
    let k = 60;
    let vcfg = faulty(FaultKind::ClosePort, k);
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let err = send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, MachineError::PortLost { .. }), "{msg}");
    let halt = err.halt().unwrap().clone();
    // Answers still in the kernel buffer when the port hangs up cannot be read: the last
    // acknowledgement we saw is at or before the real one.
    let last = halt.last_acked.unwrap();
    assert!(last <= file_line(&job, k - 1), "{msg}");
    assert!(
        msg.contains(&format!("last acknowledged line {last}")),
        "{msg}"
    );
    assert!(halt.resume_from <= file_line(&job, k));
    assert!(
        msg.contains("make sure the laser and the air are off"),
        "{msg}"
    );
    let r = vg.stop();
    laser_stopped_after_fault(&r);
    assert_ran_everything_before(&job, &r, halt.resume_from);

    let (vg2, mut port2) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    let c = StreamConfig {
        from_line: halt.resume_from,
        ..cfg()
    };
    send(&mut port2, &job, &c, None, &mut Quiet).unwrap();
    let mut expected = job.resume_preamble(halt.resume_from).unwrap();
    expected.extend(texts(&job, halt.resume_from));
    assert_eq!(program_received(&vg2.stop(), 0), expected);
}

/// Sends operator commands at chosen moments of a run.
struct Operator {
    tx: Sender<Control>,
    abort_at: Option<usize>,
    hold_at: Option<usize>,
    held: bool,
    resumed: bool,
}

impl Observer for Operator {
    fn progress(&mut self, p: &Progress) {
        if self.abort_at.is_some_and(|a| p.acked >= a) {
            self.abort_at = None;
            self.tx.send(Control::Abort).unwrap();
        }
        if self.hold_at.is_some_and(|h| p.acked >= h) {
            self.hold_at = None;
            self.tx.send(Control::FeedHold).unwrap();
        }
        if !self.held && matches!(p.state, Some(stencil_grbl::MachineState::Hold(_))) {
            self.held = true;
        }
        if self.held && !self.resumed {
            self.resumed = true;
            self.tx.send(Control::Resume).unwrap();
        }
    }
}

#[test]
fn abort_while_moving_stops_and_resume_leaves_no_gap() {
    let job = job();
    let vcfg = VirtualConfig {
        pace: Pace::Timed { speedup: 20.0 },
        ..VirtualConfig::default()
    };
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let (tx, rx) = channel();
    let mut op = Operator {
        tx,
        abort_at: Some(80),
        hold_at: None,
        held: true,
        resumed: true,
    };
    let err = send(&mut port, &job, &cfg(), Some(&rx), &mut op).unwrap_err();
    assert!(matches!(err, MachineError::Aborted { .. }), "{err}");
    let halt = err.halt().unwrap().clone();
    let r = vg.record();
    laser_stopped_after_fault(&r);
    // Acknowledged moves may still have been waiting in the planner: resume covers them, and
    // (stopping from a completed feed hold) starts exactly at the first move that did not finish.
    assert_ran_everything_before(&job, &r, halt.resume_from);
    let first_unfinished = r
        .received
        .iter()
        .enumerate()
        .filter(|(_, l)| !l.text.starts_with('$'))
        .zip(&job.lines)
        .find(|((i, _), _)| !r.executed.contains(i))
        .map(|(_, jl)| jl.number)
        .unwrap();
    assert_eq!(halt.resume_from, first_unfinished);
    assert!(halt.resume_from < halt.last_acked.unwrap());
    // Reset from a completed hold keeps the position: no ALARM:3, no unlock needed.
    assert!(!r.events.contains(&Event::Alarm(3)), "{err}");
    assert!(err.to_string().contains("M5 acknowledged"), "{err}");

    let before = r.received.len();
    let c = StreamConfig {
        from_line: halt.resume_from,
        ..cfg()
    };
    send(&mut port, &job, &c, None, &mut Quiet).unwrap();
    let r = vg.stop();
    let mut expected = job.resume_preamble(halt.resume_from).unwrap();
    expected.extend(texts(&job, halt.resume_from));
    assert_eq!(program_received(&r, before), expected);
    assert_eq!(r.position, [0.0; 3]);
}

#[test]
fn feed_hold_and_resume_from_the_operator() {
    let job = job();
    let vcfg = VirtualConfig {
        pace: Pace::Timed { speedup: 40.0 },
        ..VirtualConfig::default()
    };
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let (tx, rx) = channel();
    let mut op = Operator {
        tx,
        abort_at: None,
        hold_at: Some(40),
        held: false,
        resumed: false,
    };
    send(&mut port, &job, &cfg(), Some(&rx), &mut op).unwrap();
    assert!(op.held && op.resumed);
    let r = vg.stop();
    let hold = r.events.iter().position(|e| *e == Event::Realtime(b'!'));
    let resume = r.events.iter().position(|e| *e == Event::Realtime(b'~'));
    assert!(hold.is_some() && resume > hold, "{hold:?} {resume:?}");
    assert_eq!(program_received(&r, 0), texts(&job, 1));
}

#[test]
fn check_mode_refuses_a_bad_file_and_names_the_line() {
    let mut text = job_text();
    text = text.replacen("G21 G90\n", "G21 G90\nG1 X3 Y3\n", 1);
    text.push_str("G5 X1\n");
    let bad = Program::parse("bad.gcode", &text).unwrap();
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    let c = StreamConfig {
        check_first: true,
        ..cfg()
    };
    let err = send(&mut port, &bad, &c, None, &mut Quiet).unwrap_err();
    let MachineError::CheckFailed { rejected, .. } = &err else {
        panic!("{err}")
    };
    let got: Vec<(usize, u8)> = rejected.iter().map(|e| (e.line, e.code)).collect();
    let last = text.lines().count();
    assert_eq!(got, vec![(3, 22), (last, 20)]);
    let msg = err.to_string();
    assert!(msg.contains("line 3 `G1X3Y3`: error:22"), "{msg}");
    let r = vg.stop();
    // Nothing ran outside check mode.
    assert!(program_received(&r, 0).is_empty());

    // A good file passes the check and is then cut.
    let job = job();
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    send(&mut port, &job, &c, None, &mut Quiet).unwrap();
    let r = vg.stop();
    let checked: Vec<&str> = r
        .received
        .iter()
        .filter(|l| l.check_mode && !l.text.starts_with('$'))
        .map(|l| l.text.as_str())
        .collect();
    assert_eq!(checked.len(), job.lines.len());
    assert_eq!(program_received(&r, 0), texts(&job, 1));
}

#[test]
fn a_job_that_leaves_the_laser_on_is_followed_by_m5() {
    let text = job_text().replace("M5\n", "");
    let job = Program::parse("no-m5.gcode", &text).unwrap();
    assert!(job.may_end_laser_on);
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap();
    let r = vg.stop();
    assert!(!r.laser_on);
    assert_eq!(r.received.last().unwrap().text, "M5");
    // Our usual jobs end with M5: nothing is added.
    assert!(!self::job().may_end_laser_on);
}

#[test]
fn settings_lines_go_alone_and_percent_lines_are_dropped() {
    // A `$32=1` (laser mode) written mid-job: Grbl stops listening while it writes EEPROM, so
    // nothing may travel behind it; `%` program markers are not sent at all.
    let text = job_text().replacen("G21 G90\n", "%\nG21 G90\n$32=1\n", 1) + "%\n";
    let job = Program::parse("settings.gcode", &text).unwrap();
    assert!(job.lines.iter().all(|l| l.text != "%"));
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    // A job that writes a setting is refused unless the person allows it (issue 23).
    let c = StreamConfig {
        check_first: true,
        ..cfg()
    };
    let refused = send(&mut port, &job, &c, None, &mut Quiet).unwrap_err();
    assert!(
        refused
            .to_string()
            .contains("line 4 `$32=1` writes Grbl setting $32"),
        "{refused}"
    );
    let c = StreamConfig {
        allow_machine_commands: true,
        ..c
    };
    send(&mut port, &job, &c, None, &mut Quiet).unwrap();
    let r = vg.stop();
    assert_eq!(r.eeprom_lost_bytes, 0);
    assert_eq!(r.overflow_bytes, 0);
    let run: Vec<&str> = r
        .run_lines()
        .into_iter()
        .filter(|l| *l != "$I" && *l != "$C" && *l != "$$")
        .collect();
    let expected: Vec<&str> = job.lines.iter().map(|l| l.text.as_str()).collect();
    assert_eq!(run, expected);
}

#[test]
fn a_port_without_grbl_is_reported_not_waited_on_forever() {
    // Nobody answers on the far end of this pty.
    let (_far, mut port) = serialport::TTYPort::pair().unwrap();
    let c = StreamConfig {
        boot_wait: Duration::from_millis(200),
        timeout: Duration::from_millis(500),
        ..StreamConfig::default()
    };
    let err = send(&mut port, &job(), &c, None, &mut Quiet).unwrap_err();
    assert!(matches!(err, MachineError::NoWelcome { .. }), "{err}");
    assert!(err.to_string().contains("baud rate"), "{err}");
}

/// `stencil_gcode`'s G-code for a sample, as `make --emit gcode` writes it.
fn planned_sample(name: &str) -> String {
    use stencil_core::pipeline::{MakeConfig, PhysicalConfig, Size};
    use stencil_gcode::{GcodeConfig, PlanConfig};
    let machine = stencil_gcode::machine::load(None).unwrap();
    let physical = PhysicalConfig {
        size: Size::WidthMm(150.0),
        // Bridge widths are not the point here.
        allow_thin: true,
        ..Default::default()
    };
    let settings = stencil_core::material::settings_for(&physical.material, &machine).unwrap();
    let cfg = MakeConfig {
        input: std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("samples")
            .join(format!("{name}.png")),
        physical,
        gcode: Some(GcodeConfig {
            machine,
            plan: PlanConfig::new(settings),
            settings_from: String::new(),
        }),
        ..Default::default()
    };
    stencil_core::driver::run(&cfg).unwrap().gcode.unwrap()
}

#[test]
fn a_job_planned_from_a_sample_streams_exactly_and_resumes_after_an_error() {
    let text = planned_sample("rings");
    let job = Program::parse("rings.gcode", &text).unwrap();
    assert!(job.lines.len() > 100, "{}", job.lines.len());
    assert!(!job.may_end_laser_on);

    // Straight through, 128-byte buffer.
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap();
    let r = vg.stop();
    assert_eq!(program_received(&r, 0), texts(&job, 1));
    assert_eq!(r.overflow_bytes, 0);
    assert!(!r.laser_on);

    // Rejected half way (checked first), then resumed: the rest arrives once each, after the
    // preamble our interpreter computed from the planner's own output.
    let k = job.lines.len() / 2;
    let vcfg = faulty(FaultKind::Error(20), k);
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let c = StreamConfig {
        check_first: true,
        ..cfg()
    };
    let err = send(&mut port, &job, &c, None, &mut Quiet).unwrap_err();
    let halt = err.halt().unwrap().clone();
    assert_eq!(halt.resume_from, file_line(&job, k), "{err}");
    let r = vg.record();
    laser_stopped_after_fault(&r);
    let before = r.received.len();
    let c = StreamConfig {
        from_line: halt.resume_from,
        ..cfg()
    };
    send(&mut port, &job, &c, None, &mut Quiet).unwrap();
    let r = vg.stop();
    let mut expected = job.resume_preamble(halt.resume_from).unwrap();
    expected.extend(texts(&job, halt.resume_from));
    assert_eq!(program_received(&r, before), expected);
    // The resumed machine ends where the whole program ends.
    let whole = stencil_gcode::interpret::interpret(&text).unwrap();
    assert_eq!(r.position, whole.last().unwrap().to);
}

fn stencil() -> Command {
    Command::new(env!("CARGO_BIN_EXE_stencil"))
}

#[test]
fn cli_dry_run_and_simulate() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("job.gcode");
    std::fs::write(&file, job_text()).unwrap();
    let out = stencil()
        .args(["send", "--dry-run"])
        .arg(&file)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    let so = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{so}\n{err}");
    assert!(so.contains(&format!("{} lines", job().lines.len())), "{so}");

    let png = dir.path().join("sim.png");
    let out = stencil()
        .arg("simulate")
        .arg(&file)
        .arg("-o")
        .arg(&png)
        .output()
        .unwrap();
    let so = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{so}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(so.contains("estimated time"), "{so}");
    let img = image::open(&png).unwrap().to_rgb8();
    assert!(img
        .pixels()
        .any(|p| p.0 == stencil_gcode::simulate::CUT_RGB));
    assert!(img
        .pixels()
        .any(|p| p.0 == stencil_gcode::simulate::TRAVEL_RGB));

    // No port and no dry run: a clear error.
    let out = stencil().arg("send").arg(&file).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--port") && err.contains("--dry-run"), "{err}");

    // A bad line is refused before anything is sent, naming file and line.
    let bad = dir.path().join("long.gcode");
    std::fs::write(&bad, format!("G0 X0\nG1 X{} F100\n", "1".repeat(90))).unwrap();
    let out = stencil()
        .args(["send", "--dry-run"])
        .arg(&bad)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("long.gcode") && err.contains("line 2"),
        "{err}"
    );
}
