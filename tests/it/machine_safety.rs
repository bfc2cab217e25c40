//! Safety at the machine (issue 23): a stop never resets a moving machine, the controller's
//! settings are compared before any beam fires, a job file cannot change the machine, no wait
//! without end, and recovery from the controller's word. Everything runs against the virtual
//! Grbl, which shows each hazard: stale status around a hold (a USB adapter's latency, Grbl's
//! report-before-hold order, a deceleration in `Hold:1`), a dropped or garbled `ok`, a restart
//! at MPos 0, `$30`/`$110` values, `$` lines in a job.

use std::io::{self, Read, Write};
use std::sync::mpsc::channel;
use std::time::Duration;

use serialport::TTYPort;
use stencil_grbl::{
    send, BytePort, ClockRef, Control, Event, Expected, FaultKind, Journal, JournalWriter,
    MachineError, Pace, PowerScale, Program, Quiet, Record, Recovery, StreamConfig, VirtualConfig,
    VirtualGrbl,
};

use crate::common;
use crate::common_job;

fn cfg() -> StreamConfig {
    StreamConfig {
        boot_wait: Duration::from_millis(300),
        timeout: Duration::from_secs(5),
        ..StreamConfig::default()
    }
}

/// Run `f` on its own thread and give up after `secs`: the old sender waited forever on some of
/// these, and a test must fail, not hang.
fn within<T: Send + 'static>(secs: u64, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(Duration::from_secs(secs))
        .unwrap_or_else(|_| panic!("no end within {secs} s: the sender waits forever"))
}

fn alarms(r: &Record) -> Vec<u8> {
    r.events
        .iter()
        .filter_map(|e| match e {
            Event::Alarm(c) => Some(*c),
            _ => None,
        })
        .collect()
}

/// Many short fast moves, as raster and LaserGRBL-style jobs are: the link cannot keep the
/// planner fed, so it runs dry for moments and reports `Idle` mid-job.
fn starving_job(n: usize) -> String {
    let mut s = String::from("G21G90\nM4S300\nG1F6000\n");
    for i in 0..n {
        let x = 10.0 + (i % 400) as f64 * 0.05;
        let y = 10.0 + (i / 400) as f64 * 0.2 + (i % 2) as f64 * 0.05;
        s += &format!("G1X{x:.3}Y{y:.3}\n");
    }
    s + "M5\n"
}

#[test]
fn an_abort_at_any_instant_resets_only_a_standing_machine() {
    // The machine as the issue saw it: paced at 115200 baud, reports 16 ms late through the USB
    // adapter, a planner that runs dry mid-job. The old stop accepted the first `Idle` it read
    // after the `!`, which could be a report made before the hold: the reset then came while
    // the head decelerated (ALARM:3, position lost).
    let job = Program::parse("starve.gcode", &starving_job(3000)).unwrap();
    let mut unsure = 0;
    for (k, delay_ms) in [150u64, 233, 310, 377, 452, 520, 611, 700]
        .into_iter()
        .enumerate()
    {
        let vcfg = VirtualConfig {
            pace: Pace::Timed { speedup: 1.0 },
            baud: Some(115_200),
            latency: Duration::from_millis(20),
            ..VirtualConfig::default()
        };
        let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
        // Polled often, so that a report asked for before the abort is usually still on the
        // wire when the `!` goes out.
        let c = StreamConfig {
            poll_interval: Duration::from_millis(30),
            ..cfg()
        };
        let (tx, rx) = channel();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(400 + delay_ms));
            let _ = tx.send(Control::Abort);
        });
        let err = send(&mut port, &job, &c, Some(&rx), &mut Quiet).unwrap_err();
        let MachineError::Aborted { halt } = &err else {
            panic!("abort {k}: {err}")
        };
        let r = vg.stop();
        assert!(alarms(&r).is_empty(), "abort {k}: {:?}: {err}", alarms(&r));
        assert!(!r.laser_on && !r.air_on, "abort {k}");
        // The hold was seen complete: the stop keeps the position and says nothing of a loss.
        unsure += usize::from(halt.position_unsure.is_some());
        let hold = r.events.iter().position(|e| *e == Event::Realtime(b'!'));
        let reset = r.events.iter().position(|e| *e == Event::SoftReset);
        assert!(hold < reset, "abort {k}: reset before hold");
    }
    assert_eq!(unsure, 0);
}

/// The capture: a status report Grbl made just before it handled the feed hold, still
/// on the wire when the `!` went out (`<Idle>` at 9.459795 s, `!` at 9.460560, `<Hold:1>` at
/// 9.460730). This port hands the sender such a report right after its `!`, in front of
/// whatever the controller really says.
struct StaleOnHold {
    inner: TTYPort,
    line: &'static [u8],
    stale: Vec<u8>,
}

impl Read for StaleOnHold {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if !self.stale.is_empty() {
            let n = self.stale.len().min(buf.len());
            buf[..n].copy_from_slice(&self.stale[..n]);
            self.stale.drain(..n);
            return Ok(n);
        }
        self.inner.read(buf)
    }
}

impl Write for StaleOnHold {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if buf.contains(&b'!') {
            self.stale.extend_from_slice(self.line);
        }
        self.inner.write(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

impl BytePort for StaleOnHold {
    fn set_read_timeout(&mut self, t: Duration) -> io::Result<()> {
        BytePort::set_read_timeout(&mut self.inner, t)
    }
    fn describe(&self) -> String {
        "stale".into()
    }
}

#[test]
fn a_report_made_before_the_hold_never_lets_the_reset_through() {
    // Long cuts at 1200 mm/min: the head is always moving when the abort comes.
    let job = Program::parse("j.gcode", &common_job::job_text_scaled(1)).unwrap();
    // A stale `Idle`, and a `Hold:0` left from an earlier hold the operator had resumed.
    let stale: [&'static [u8]; 2] = [
        b"<Idle|MPos:10.000,10.000,0.000|Bf:15,128|FS:0,0>\r\n",
        b"<Hold:0|MPos:10.000,10.000,0.000|Bf:15,128|FS:0,0>\r\n",
    ];
    for (delay_ms, line) in [
        (300u64, stale[0]),
        (700, stale[1]),
        (1100, stale[0]),
        (900, stale[1]),
    ] {
        let vcfg = VirtualConfig {
            pace: Pace::Timed { speedup: 1.0 },
            ..VirtualConfig::default()
        };
        let (vg, host) = VirtualGrbl::spawn(vcfg).unwrap();
        let mut port = StaleOnHold {
            inner: host,
            line,
            stale: Vec::new(),
        };
        let (tx, rx) = channel();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(delay_ms));
            let _ = tx.send(Control::Abort);
        });
        let err = send(&mut port, &job, &cfg(), Some(&rx), &mut Quiet).unwrap_err();
        let MachineError::Aborted { halt } = &err else {
            panic!("{err}")
        };
        let r = vg.stop();
        // The old stop took the stale `Idle` and reset a decelerating head: ALARM:3.
        assert!(
            alarms(&r).is_empty(),
            "after {delay_ms} ms: {:?}: {err}",
            alarms(&r)
        );
        assert!(halt.position_unsure.is_none(), "{err}");
        assert!(!halt.locked, "{err}");
    }
}

#[test]
fn a_hold_that_never_completes_resets_at_the_deadline_and_says_the_position_may_be_lost() {
    // A frozen machine answers `Run` forever (its feed hold never reports Hold:0 here, because
    // it is stuck): the stall watch stops it, and with no standstill seen the stop says so.
    let job = Program::parse("j.gcode", &common_job::job_text_scaled(1)).unwrap();
    let vcfg = VirtualConfig {
        pace: Pace::Timed { speedup: 50.0 },
        settings: vec![(110, "600".into()), (120, "600".into())],
        ..common::faulty(FaultKind::Silence, 40)
    };
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let c = StreamConfig {
        timeout: Duration::from_secs(1),
        ..cfg()
    };
    let err = within(60, move || {
        send(&mut port, &job, &c, None, &mut Quiet).unwrap_err()
    });
    let halt = err.halt().expect("a stop with a halt").clone();
    let msg = err.to_string();
    assert!(matches!(err, MachineError::Silent { .. }), "{msg}");
    assert!(halt.position_unsure.is_some(), "{msg}");
    assert!(
        msg.contains("the position may be lost") && msg.contains("home the machine ($H)"),
        "{msg}"
    );
    let r = vg.stop();
    // Even a silent controller got the hold before the reset, and the laser is off.
    let hold = r.events.iter().position(|e| *e == Event::Realtime(b'!'));
    let reset = r.events.iter().position(|e| *e == Event::SoftReset);
    assert!(hold.is_some() && hold < reset, "{:?}", r.events);
    assert!(!r.laser_on);
}

fn stencil() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_stencil"))
}

#[cfg(unix)]
#[test]
fn sigterm_sighup_and_sigint_stop_the_machine_like_the_abort_key_and_are_named() {
    for sig in ["TERM", "HUP", "INT"] {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("job.gcode");
        std::fs::write(&file, common_job::job_text_scaled(1)).unwrap();
        let jpath = stencil_grbl::journal_path(&file);
        let child = stencil()
            .args(["send", "--dry-run", "--realtime"])
            .arg(&file)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // Once the job is cutting (its journal shows progress), the signal.
        let mut cutting = false;
        for _ in 0..600 {
            if Journal::read(&jpath).is_ok_and(|j| j.last_acked_line.is_some()) {
                cutting = true;
                break;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        assert!(cutting, "SIG{sig}: no progress within 30 s");
        let ok = std::process::Command::new("kill")
            .args([format!("-{sig}"), child.id().to_string()])
            .status()
            .unwrap()
            .success();
        assert!(ok);
        let out = within(60, move || child.wait_with_output().unwrap());
        let (so, se) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert!(!out.status.success(), "SIG{sig}: {so}{se}");
        assert!(
            se.contains(&format!("stopped by SIG{sig}")) && se.contains("resume from line"),
            "SIG{sig}: {se}"
        );
        assert!(
            se.contains("laser and air off (soft reset"),
            "SIG{sig}: {se}"
        );
        assert!(
            so.contains("laser off, air off") && so.contains("alarms: none"),
            "SIG{sig}: {so}"
        );
        let j = Journal::read(&jpath).unwrap();
        assert_eq!(j.state, stencil_grbl::RunState::Stopped, "SIG{sig}");
        // Issue 39, item 7: the signal is named, not taken for the operator's abort key.
        let why = j.stop_reason.unwrap_or_default();
        assert!(
            why.starts_with(&format!("stopped by SIG{sig}")),
            "SIG{sig}: {why}"
        );
        assert!(!se.contains("by the operator"), "SIG{sig}: {se}");
    }
}

fn stencil_job() -> String {
    // As `stencil make` writes it for diode-400: its header says $30=1000 $31=0.
    let mut s = String::from(
        "; stencil 0.1.0 for diode-400: test\n; $30=1000 $31=0; power 20 % = S200; feed 1500 mm/min; passes 1\nG21G90\n",
    );
    s += "M4S0\nG0X10Y10\nS200\nG1X20Y10F1500\nG1X20Y20\nS0\nM5\n";
    s
}

fn laser_expect(text: &str, job: &Program) -> Expected {
    let fires = job.moves.iter().any(|m| m.power > 0.0);
    assert!(fires && text.contains("$30=1000"));
    Expected {
        profile: "diode-400".into(),
        power: Some(PowerScale {
            s_max: 1000.0,
            s_min: 0.0,
            source: "read from its header".into(),
        }),
        rapid_mm_min: Some(6000.0),
        accel_mm_s2: Some(1000.0),
        junction_mm: Some(0.01),
        bed_mm: Some([400.0, 400.0]),
    }
}

#[derive(Default)]
struct Notes(Vec<String>);
impl stencil_grbl::Observer for Notes {
    fn message(&mut self, text: &str) {
        self.0.push(text.to_string());
    }
}

#[test]
fn a_power_scale_that_differs_is_refused_or_rescaled_before_the_beam() {
    let text = stencil_job();
    let job = Program::parse("j.gcode", &text).unwrap();
    let grbl = |s: &[(u32, &str)]| VirtualConfig {
        settings: s.iter().map(|&(k, v)| (k, v.to_string())).collect(),
        ..VirtualConfig::default()
    };
    let c = StreamConfig {
        expect: laser_expect(&text, &job),
        ..cfg()
    };
    // $30=255: the job's S200 (20 %) would burn at 78 %.
    let (vg, mut port) = VirtualGrbl::spawn(grbl(&[(30, "255")])).unwrap();
    let err = send(&mut port, &job, &c, None, &mut Quiet).unwrap_err();
    let msg = err.to_string();
    assert!(
        matches!(err, MachineError::PowerScale { setting: 30, .. }),
        "{msg}"
    );
    assert!(
        msg.contains("$30=255") && msg.contains("$30=1000") && msg.contains("78 %"),
        "{msg}"
    );
    let r = vg.stop();
    assert_eq!(r.run_lines(), ["$I", "$$"], "something was sent");
    assert!(r.moves.is_empty());
    // $31 differs: refused the same way.
    let (_vg, mut port) = VirtualGrbl::spawn(grbl(&[(31, "100")])).unwrap();
    let err = send(&mut port, &job, &c, None, &mut Quiet).unwrap_err();
    assert!(
        matches!(err, MachineError::PowerScale { setting: 31, .. }),
        "{err}"
    );
    // Asked to rescale: every S goes out on the controller's scale, and the run says so.
    let (vg, mut port) = VirtualGrbl::spawn(grbl(&[(30, "255")])).unwrap();
    let c2 = StreamConfig {
        rescale_power: true,
        ..c.clone()
    };
    let mut notes = Notes::default();
    send(&mut port, &job, &c2, None, &mut notes).unwrap();
    let r = vg.stop();
    let s_words: Vec<&str> = r
        .run_lines()
        .into_iter()
        .filter(|l| l.starts_with('S') || l.starts_with("M4"))
        .collect();
    assert_eq!(s_words, ["M4S0", "S51", "S0"]);
    assert!(
        notes.0.iter().any(|n| n.contains("rescaled")),
        "{:?}",
        notes.0
    );
    // The profile's own values pass silently.
    let (vg, mut port) = VirtualGrbl::spawn(grbl(&[])).unwrap();
    let mut notes = Notes::default();
    send(&mut port, &job, &c, None, &mut notes).unwrap();
    assert!(vg.stop().run_lines().contains(&"S200"));
    assert!(
        !notes.0.iter().any(|n| n.contains("differs")),
        "{:?}",
        notes.0
    );
}

#[test]
fn rates_accelerations_and_travel_are_compared_with_the_profile() {
    let text = stencil_job();
    let job = Program::parse("j.gcode", &text).unwrap();
    let c = StreamConfig {
        expect: laser_expect(&text, &job),
        ..cfg()
    };
    let grbl = |s: &[(u32, &str)]| VirtualConfig {
        settings: s.iter().map(|&(k, v)| (k, v.to_string())).collect(),
        homing: false,
        ..VirtualConfig::default()
    };
    // Slow rates and acceleration: reported, naming the setting, both values and the field.
    let (_vg, mut port) =
        VirtualGrbl::spawn(grbl(&[(110, "1200"), (120, "200"), (130, "300")])).unwrap();
    let mut notes = Notes::default();
    send(&mut port, &job, &c, None, &mut notes).unwrap();
    let all = notes.0.join("\n");
    assert!(
        all.contains("$110=1200") && all.contains("rapid_mm_min = 6000"),
        "{all}"
    );
    assert!(
        all.contains("$120=200") && all.contains("accel_mm_s2 = 1000"),
        "{all}"
    );
    // Travel short of the bed with soft limits and homing off: a warning.
    assert!(all.contains("$130=300") && all.contains("400 mm"), "{all}");
    // With soft limits on, refused before anything moves.
    let (vg, mut port) = VirtualGrbl::spawn(grbl(&[(130, "300"), (20, "1")])).unwrap();
    let err = send(&mut port, &job, &c, None, &mut Quiet).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, MachineError::TravelShort { .. }), "{msg}");
    assert!(
        msg.contains("$130=300") && msg.contains("soft limits"),
        "{msg}"
    );
    assert!(vg.stop().moves.is_empty());
}

#[test]
fn cli_dry_run_checks_the_settings_from_the_profile() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("job.gcode");
    std::fs::write(&file, stencil_job()).unwrap();
    let run = |extra: &[&str]| {
        let o = stencil()
            .args(["send", "--dry-run"])
            .arg(&file)
            .args(extra)
            .output()
            .unwrap();
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr),
        )
    };
    // The virtual Grbl starts from diode-400's values: a plain dry run passes.
    let (ok, out) = run(&[]);
    assert!(ok, "{out}");
    assert!(!out.contains("differs"), "{out}");
    let (ok, out) = run(&["--dry-run-setting", "$30=255"]);
    assert!(!ok, "{out}");
    assert!(
        out.contains("$30=255") && out.contains("--rescale-power"),
        "{out}"
    );
    assert!(
        out.contains("the job was written for $30=1000 (read from its header)"),
        "{out}"
    );
    let (ok, out) = run(&["--dry-run-setting", "$30=255", "--rescale-power"]);
    assert!(ok && out.contains("rescaled"), "{out}");
    // Issue 39, item 7: the scale and where it was read, worded once.
    assert!(
        out.contains("the job's is $30=1000 $31=0 (read from its header)")
            && !out.contains("(the job ("),
        "{out}"
    );
}

#[test]
fn a_job_cannot_change_the_machine_unless_allowed() {
    let base = stencil_job();
    for (extra, what) in [
        ("$32=0", "writes Grbl setting $32"),
        ("$J=G91X1000Y1000F3000", "jogs the machine"),
        ("$C", "switches check mode"),
        ("$H", "homes the machine"),
        ("$X", "unlocks an alarm"),
        ("$N0=G20", "stores a startup line"),
        ("$RST=*", "erases Grbl's settings"),
        ("$SLP", "puts Grbl to sleep"),
        ("G10 L2 P1 X380 Y380", "writes a stored work offset"),
        ("G10 L20 P1 X0", "writes a stored work offset"),
        ("G28.1", "stores a G28/G30 position"),
    ] {
        let text = base.replacen("G21G90\n", &format!("G21G90\n{extra}\n"), 1);
        let job = Program::parse("j.gcode", &text).unwrap();
        let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
        let err = send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap_err();
        let msg = err.to_string();
        assert!(
            matches!(err, MachineError::MachineCommands { .. }),
            "{extra}: {msg}"
        );
        assert!(
            msg.contains("line 4") && msg.contains(what),
            "{extra}: {msg}"
        );
        // Refused before anything reached the controller.
        assert!(vg.stop().received.is_empty(), "{extra}");
    }
    // Read-only queries are left out of the stream with a note.
    let text = base.replacen("G21G90\n", "G21G90\n$$\n$G\n", 1);
    let job = Program::parse("j.gcode", &text).unwrap();
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    let mut notes = Notes::default();
    send(&mut port, &job, &cfg(), None, &mut notes).unwrap();
    let r = vg.stop();
    assert!(!r.run_lines().contains(&"$G"));
    assert_eq!(r.run_lines().iter().filter(|l| **l == "$$").count(), 1);
    assert!(
        notes.0.iter().any(|n| n.contains("line 5 `$G`")),
        "{:?}",
        notes.0
    );
    // Allowed, a `$C` in the job still ends: the sender does not wait for an Idle that check
    // mode never reports.
    let text = base.replacen("S0\nM5\n", "S0\nM5\n$C\nG0X1\n", 1);
    let job = Program::parse("j.gcode", &text).unwrap();
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    let c = StreamConfig {
        allow_machine_commands: true,
        ..cfg()
    };
    within(30, move || {
        send(&mut port, &job, &c, None, &mut Quiet).unwrap()
    });
    drop(vg);
}

#[test]
fn estimate_simulate_and_frame_name_the_lines_that_change_the_machine() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("job.gcode");
    let text = stencil_job().replacen("G21G90\n", "G21G90\n$32=0\n", 1);
    std::fs::write(&file, text).unwrap();
    for cmd in [
        vec!["estimate"],
        vec!["simulate", "-o"],
        vec!["frame", "--dry-run"],
    ] {
        let mut c = stencil();
        c.arg(cmd[0]).arg(&file);
        if cmd[0] == "simulate" {
            c.arg("-o").arg(dir.path().join("sim.png"));
        } else if cmd.len() > 1 {
            c.arg(cmd[1]);
        }
        let o = c.output().unwrap();
        let se = String::from_utf8_lossy(&o.stderr);
        assert!(
            se.contains("line 4 `$32=0` writes Grbl setting $32"),
            "{}: {se}",
            cmd[0]
        );
    }
}

#[test]
fn a_lost_or_garbled_ok_ends_the_run_instead_of_waiting_forever() {
    let text = common_job::job_text_scaled(1);
    let job = Program::parse("j.gcode", &text).unwrap();
    let last = job
        .lines
        .iter()
        .filter(|l| !l.text.starts_with('$'))
        .count();
    for (kind, at) in [(FaultKind::DropOk, last), (FaultKind::GarbleOk, 30)] {
        let (vg, mut port) = VirtualGrbl::spawn(common::faulty(kind, at)).unwrap();
        let j = job.clone();
        let err = within(60, move || {
            send(&mut port, &j, &cfg(), None, &mut Quiet).unwrap_err()
        });
        let msg = err.to_string();
        let MachineError::RepliesLost { lost, halt, .. } = &err else {
            panic!("{kind:?}: {msg}")
        };
        assert_eq!(lost.count, 1, "{kind:?}: {msg}");
        // Every line went out and Grbl ran them: it says the job most likely finished.
        assert!(lost.all_sent, "{kind:?}: {msg}");
        assert!(
            msg.contains("most likely run to its end"),
            "{kind:?}: {msg}"
        );
        assert!(halt.position_unsure.is_none(), "{kind:?}: {msg}");
        let r = vg.stop();
        assert!(!r.laser_on && alarms(&r).is_empty(), "{kind:?}");
    }
}

/// A byte port that dies after `lines` newlines were written: the sender crashes (its writes
/// and reads fail), while the controller behind it runs on with what it received.
struct Crashing {
    inner: TTYPort,
    lines: usize,
}

impl Read for Crashing {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.lines == 0 {
            return Err(io::Error::new(io::ErrorKind::BrokenPipe, "sender crashed"));
        }
        self.inner.read(buf)
    }
}

impl Write for Crashing {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = buf.iter().filter(|&&b| b == b'\n').count();
        if self.lines == 0 || n > self.lines {
            self.lines = 0;
            return Err(io::Error::new(io::ErrorKind::BrokenPipe, "sender crashed"));
        }
        self.lines -= n;
        self.inner.write(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

impl BytePort for Crashing {
    fn set_read_timeout(&mut self, t: Duration) -> io::Result<()> {
        BytePort::set_read_timeout(&mut self.inner, t)
    }
    fn describe(&self) -> String {
        "crashing".into()
    }
}

fn wait_idle(vg: &VirtualGrbl) {
    for _ in 0..400 {
        if vg.record().state == "Idle" {
            return;
        }
        std::thread::sleep(Duration::from_millis(25));
    }
    panic!("the virtual Grbl never went idle");
}

#[test]
fn after_a_sender_crash_the_resume_follows_the_controller_not_the_stale_journal() {
    let dir = tempfile::tempdir().unwrap();
    let text = common_job::job_text_scaled(1);
    let job = Program::parse("j.gcode", &text).unwrap();
    let jpath = dir.path().join("j.gcode.journal");
    let vcfg = VirtualConfig {
        pace: Pace::Timed { speedup: 20.0 },
        ..VirtualConfig::default()
    };
    let (vg, host) = VirtualGrbl::spawn(vcfg).unwrap();
    // Setup lines ($I, $$), then 120 program lines; the journal is written once at the start
    // and then no more (its period is long): stale, as the 2-second-old journal.
    let mut port = Crashing {
        inner: host,
        lines: 122,
    };
    let started = Journal::new(
        std::path::Path::new("j.gcode"),
        text.as_bytes(),
        &job,
        "diode-400",
        1,
    );
    let mut quiet = Quiet;
    let mut writer = JournalWriter::new(
        &mut quiet,
        started,
        jpath.clone(),
        &job,
        ClockRef::default(),
        Duration::from_secs(3600),
    );
    let result = send(&mut port, &job, &cfg(), None, &mut writer);
    assert!(result.is_err());
    // A crash writes nothing more: the journal on disk is the stale one.
    drop(writer);
    wait_idle(&vg);
    let j = Journal::read(&jpath).unwrap();
    let proposal = j.proposal(&job).line;
    let before = vg.record().received.len();
    let received_first: Vec<String> = vg
        .record()
        .run_lines()
        .iter()
        .map(|s| s.to_string())
        .collect();
    let mut host = port.inner;
    let c = StreamConfig {
        from_line: proposal,
        recovery: Some(Recovery {
            last_position: j.last_position,
            last_acked: j.last_acked_line,
            follow: true,
            ..Recovery::default()
        }),
        ..cfg()
    };
    let mut notes = Notes::default();
    send(&mut host, &job, &c, None, &mut notes).unwrap();
    let r = vg.stop();
    // Every program line ran once: what Grbl had when the sender died, then the rest.
    let first: Vec<&str> = received_first
        .iter()
        .map(String::as_str)
        .filter(|l| !l.starts_with('$'))
        .collect();
    let resumed: Vec<&str> = r.received[before..]
        .iter()
        .map(|l| l.text.as_str())
        .filter(|l| !l.starts_with('$'))
        .collect();
    let texts: Vec<&str> = job.lines.iter().map(|l| l.text.as_str()).collect();
    assert_eq!(first, texts[..first.len()]);
    let pre = resumed.len() - (texts.len() - first.len());
    assert_eq!(resumed[pre..], texts[first.len()..], "{:?}", notes.0);
    assert!(
        proposal < job.lines[first.len()].number,
        "the journal was not stale"
    );
    assert!(
        notes
            .0
            .iter()
            .any(|n| n.contains("ran on after the journal")),
        "{:?}",
        notes.0
    );
}

#[test]
fn after_a_power_loss_the_resume_waits_for_the_person_and_the_corner() {
    let text = common_job::job_text_scaled(1);
    let job = Program::parse("j.gcode", &text).unwrap();
    let vcfg = VirtualConfig {
        homing: false,
        ..common::faulty(FaultKind::PowerLoss, 80)
    };
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let mut last_pos = None;
    struct Pos<'a>(&'a mut Option<[f64; 3]>);
    impl stencil_grbl::Observer for Pos<'_> {
        fn progress(&mut self, p: &stencil_grbl::Progress) {
            *self.0 = p.position.or(*self.0);
        }
    }
    let err = send(&mut port, &job, &cfg(), None, &mut Pos(&mut last_pos)).unwrap_err();
    assert!(matches!(err, MachineError::Restarted { .. }), "{err}");
    let halt = err.halt().unwrap().clone();
    assert!(halt.position_unsure.is_some(), "{err}");
    let then = last_pos.expect("a position was reported");
    assert!(then[0] > 1.0, "{then:?}");
    // The controller now says MPos 0,0,0: the resume refuses to travel.
    let before = vg.record().moves.len();
    let rec = Recovery {
        last_position: Some(then),
        last_acked: halt.last_acked,
        ..Recovery::default()
    };
    let c = StreamConfig {
        from_line: halt.resume_from,
        recovery: Some(rec.clone()),
        ..cfg()
    };
    let err = send(&mut port, &job, &c, None, &mut Quiet).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, MachineError::PositionLost { .. }), "{msg}");
    assert!(
        msg.contains("X0.000 Y0.000") && msg.contains("nothing was moved"),
        "{msg}"
    );
    assert_eq!(vg.record().moves.len(), before, "the head moved");
    // The person jogged the head to the job's start corner: work coordinates are set there
    // (G92), and the resume runs in the same place relative to the head.
    let corner = job.start_corner();
    let c = StreamConfig {
        recovery: Some(Recovery {
            at_corner: Some(corner),
            ..rec
        }),
        ..c
    };
    send(&mut port, &job, &c, None, &mut Quiet).unwrap();
    let r = vg.stop();
    assert!(r.run_lines().iter().any(|l| l.starts_with("G92X")));
    let st = job.state_before(halt.resume_from).unwrap().modal;
    let travel = r.moves[before..]
        .iter()
        .find(|m| m.moves_xy())
        .expect("a travel");
    // Machine zero is where the corner is now: the travel goes to (target - corner).
    assert!(
        (travel.to[0] - (st.pos[0] - corner[0])).abs() < 1e-6,
        "{travel:?}"
    );
    assert!(
        (travel.to[1] - (st.pos[1] - corner[1])).abs() < 1e-6,
        "{travel:?}"
    );
}

/// Issue 39, item 7: a job allowed to change the machine that turns laser mode off (`$32=0`)
/// runs the rest with the beam on through travel and stops: `send` says so, naming the line,
/// before anything streams.
#[test]
fn an_allowed_laser_mode_off_in_a_job_is_warned_before_streaming() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("job.gcode");
    let text = stencil_job().replacen("G0X10Y10\n", "G0X10Y10\n$32=0\n", 1);
    let line = text.lines().position(|l| l == "$32=0").unwrap() + 1;
    std::fs::write(&file, &text).unwrap();
    let o = stencil()
        .args(["send", "--dry-run", "--allow-machine-commands"])
        .arg(&file)
        .output()
        .unwrap();
    let (so, se) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert!(o.status.success(), "{so}{se}");
    let warning = se
        .find(&format!("line {line} `$32=0` turns Grbl's laser mode off"))
        .unwrap_or_else(|| panic!("no warning: {se}"));
    assert!(
        se.contains("keeping it on through G0 travel and wherever motion stops"),
        "{se}"
    );
    // Said before the controller was even reached.
    let connected = se.find("connected to").unwrap_or_else(|| panic!("{se}"));
    assert!(warning < connected, "{se}");
    // The job without it: no such warning.
    std::fs::write(&file, stencil_job()).unwrap();
    let o = stencil()
        .args(["send", "--dry-run", "--allow-machine-commands"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(o.status.success());
    assert!(!String::from_utf8_lossy(&o.stderr).contains("laser mode off"));
}

// ---- issue 39 item 2: connecting to a machine that is still running ---------------------------

/// A board still running the rest of a job whose sender died (no banner when the port opens):
/// a few long moves at the machine's pace, about `secs` seconds in all.
fn mid_job(secs: f64) -> VirtualConfig {
    // 60 mm at 1200 mm/min is 3 s a line.
    let n = (secs / 3.0).ceil().max(1.0) as usize;
    let mut text = String::from("G21G90\nM4S0\nG1X60F1200\n");
    for i in 1..n {
        text.push_str(if i % 2 == 1 { "G1X0\n" } else { "G1X60\n" });
    }
    VirtualConfig {
        pace: Pace::Timed { speedup: 1.0 },
        mid_job: Some(text),
        ..VirtualConfig::default()
    }
}

#[test]
fn connecting_to_a_moving_machine_waits_for_it_and_never_resets_it_while_it_moves() {
    let job = Program::parse("j.gcode", "G21G90\nG0X10\n").unwrap();
    let (vg, port) = VirtualGrbl::spawn(mid_job(2.0)).unwrap();
    let mut notes = Notes::default();
    let result = within(60, move || {
        let mut port = port;
        let r = send(&mut port, &job, &cfg(), None, &mut notes);
        (r.map(|_| ()).map_err(|e| e.to_string()), notes)
    });
    let (result, notes) = result;
    result.unwrap();
    let r = vg.stop();
    assert!(alarms(&r).is_empty(), "alarms {:?}", alarms(&r));
    // The old job's three lines ran to their end before the first reset went out.
    let first_reset = r.events.iter().position(|e| *e == Event::SoftReset);
    let reset = first_reset.expect("an idle machine is still woken with a reset");
    for i in 0..3 {
        assert!(
            r.events[..reset].contains(&Event::Line(i)),
            "{:?}",
            r.events
        );
    }
    assert!(r.executed.contains(&2), "the old job's last move ran");
    assert!(
        notes.0.iter().any(|n| n.contains("still running moves")
            && n.contains("Run at X")
            && n.contains("waiting for it to finish")),
        "{:?}",
        notes.0
    );
    assert!(
        notes.0.iter().any(|n| n.contains("finished those moves")),
        "{:?}",
        notes.0
    );
    // And then the new job ran.
    assert!(r.run_lines().contains(&"G0X10"), "{:?}", r.run_lines());
}

#[test]
fn a_moving_machine_is_waited_for_within_a_bound_held_ones_are_left_or_stopped_safely() {
    use stencil_grbl::IfMoving;
    let job = Program::parse("j.gcode", "G21G90\nG0X10\n").unwrap();
    // Longer than the wait allows: refused, nothing sent, not reset.
    let (vg, mut port) = VirtualGrbl::spawn(mid_job(30.0)).unwrap();
    let c = StreamConfig {
        if_moving: IfMoving::Wait(Duration::from_millis(1500)),
        ..cfg()
    };
    let err = send(&mut port, &job, &c, None, &mut Quiet).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, MachineError::Running { .. }), "{msg}");
    assert!(
        msg.contains("still running")
            && msg.contains("nothing was sent")
            && msg.contains("ALARM:3"),
        "{msg}"
    );
    let r = vg.record();
    assert!(!r.events.contains(&Event::SoftReset), "{:?}", r.events);
    assert!(!r.run_lines().contains(&"G0X10"));
    assert_eq!(r.state, "Run");
    // Stopped as asked: feed hold, standstill, then the reset; no alarm, position kept.
    let c = StreamConfig {
        if_moving: IfMoving::Stop,
        ..cfg()
    };
    let mut notes = Notes::default();
    send(&mut port, &job, &c, None, &mut notes).unwrap();
    let r = vg.stop();
    assert!(alarms(&r).is_empty(), "alarms {:?}", alarms(&r));
    let hold = r
        .events
        .iter()
        .position(|e| *e == Event::Realtime(b'!'))
        .expect("a feed hold first");
    let reset = r
        .events
        .iter()
        .position(|e| *e == Event::SoftReset)
        .unwrap();
    assert!(hold < reset, "{:?}", r.events);
    assert!(
        notes.0.iter().any(|n| n.contains("stopping it as asked")),
        "{:?}",
        notes.0
    );
    assert!(r.run_lines().contains(&"G0X10"));

    // Held mid-job (someone pressed feed hold; it will not finish by itself): left alone.
    let (vg, mut port) = VirtualGrbl::spawn(mid_job(30.0)).unwrap();
    std::thread::sleep(Duration::from_millis(300));
    port.write_all(b"!").unwrap();
    let err = send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap_err();
    let msg = err.to_string();
    assert!(
        matches!(err, MachineError::Running { waited_s: None, .. }) && msg.contains("Hold"),
        "{msg}"
    );
    assert!(msg.contains("cycle start"), "{msg}");
    let r = vg.record();
    assert!(!r.events.contains(&Event::SoftReset), "{:?}", r.events);
    // With the stop asked for: reset from the completed hold, no alarm.
    let c = StreamConfig {
        if_moving: IfMoving::Stop,
        ..cfg()
    };
    send(&mut port, &job, &c, None, &mut Quiet).unwrap();
    let r = vg.stop();
    assert!(alarms(&r).is_empty(), "alarms {:?}", alarms(&r));
}

// ---- issue 39 item 3: a two-pass job resumed after a sender crash -----------------------------

/// Squares each cut twice: every point of a second pass is also a point of the first.
fn two_pass_job() -> String {
    let mut s = String::from("G21 G90\nM4 S0\n");
    for k in 0..4 {
        let (x0, y0) = (5.0 + 15.0 * k as f64, 5.0);
        let (x1, y1) = (x0 + 10.0, y0 + 10.0);
        s.push_str(&format!("G0 X{x0} Y{y0}\n"));
        for _ in 0..2 {
            s.push_str(&format!(
                "G1 X{x1} Y{y0} S500 F1200\nG1 X{x1} Y{y1}\nG1 X{x0} Y{y1}\nG1 X{x0} Y{y0}\n"
            ));
        }
    }
    s.push_str("M5\n");
    s
}

#[test]
fn after_a_crash_a_two_pass_job_resumes_after_the_last_line_grbl_ran_at_every_kill_point() {
    let dir = tempfile::tempdir().unwrap();
    let text = two_pass_job();
    let job = Program::parse("j.gcode", &text).unwrap();
    let texts: Vec<&str> = job.lines.iter().map(|l| l.text.as_str()).collect();
    for kill in [6, 9, 10, 13, 15, 18, 22, 26, 29, 33] {
        let jpath = dir.path().join(format!("j{kill}.gcode.journal"));
        let vcfg = VirtualConfig {
            pace: Pace::Timed { speedup: 20.0 },
            ..VirtualConfig::default()
        };
        let (vg, host) = VirtualGrbl::spawn(vcfg).unwrap();
        // $I and $$, then `kill` program lines, then the sender dies.
        let mut port = Crashing {
            inner: host,
            lines: 2 + kill,
        };
        let started = Journal::new(
            std::path::Path::new("j.gcode"),
            text.as_bytes(),
            &job,
            "diode-400",
            1,
        );
        let mut quiet = Quiet;
        // The journal's periodic rewrite never comes (a crash right after one): stale, but for
        // the lines sent, which are recorded before they go out.
        let mut writer = JournalWriter::new(
            &mut quiet,
            started,
            jpath.clone(),
            &job,
            ClockRef::default(),
            Duration::from_secs(3600),
        );
        assert!(send(&mut port, &job, &cfg(), None, &mut writer).is_err());
        drop(writer);
        // The lines written before the crash are on their way through the pty: the board has
        // them once it has read them (a busy machine may take a while), then runs them out.
        let has_all = || {
            let r = vg.record();
            let got = r.run_lines().iter().filter(|l| !l.starts_with('$')).count();
            got >= kill
        };
        for _ in 0..400 {
            if has_all() {
                break;
            }
            std::thread::sleep(Duration::from_millis(25));
        }
        wait_idle(&vg);
        let j = Journal::read(&jpath).unwrap();
        let received: Vec<String> = vg
            .record()
            .run_lines()
            .iter()
            .filter(|l| !l.starts_with('$'))
            .map(|s| s.to_string())
            .collect();
        assert_eq!(received.len(), kill);
        // The last line sent, or the one the crash kept from going (named before it goes).
        let sent = j.last_sent_line.expect("the lines sent are journalled");
        assert!(
            sent == job.lines[kill - 1].number || sent == job.lines[kill].number,
            "{j:?}"
        );
        let before = vg.record().received.len();
        let mut host = port.inner;
        let c = StreamConfig {
            from_line: j.proposal(&job).line,
            recovery: Some(Recovery {
                last_position: j.last_position,
                last_acked: j.last_acked_line,
                follow: true,
                last_sent: j.last_sent_line,
                grbl_stopped: j.grbl_stopped,
                ..Recovery::default()
            }),
            ..cfg()
        };
        let mut notes = Notes::default();
        send(&mut host, &job, &c, None, &mut notes)
            .unwrap_or_else(|e| panic!("kill after {kill} lines: {e}"));
        let r = vg.stop();
        // Every program line ran once: what Grbl had when the sender died, then the rest.
        let resumed: Vec<&str> = r.received[before..]
            .iter()
            .map(|l| l.text.as_str())
            .filter(|l| !l.starts_with('$'))
            .collect();
        let pre = resumed.len() - (texts.len() - kill);
        assert_eq!(
            resumed[pre..],
            texts[kill..],
            "kill after {kill} lines: {:?}",
            notes.0
        );
        assert!(alarms(&r).is_empty());
    }
}

/// Without the journal's last line sent (a journal from before it was kept), a head at a
/// corner that both passes reach cannot tell which pass ran: refused, naming the lines, and
/// nothing moves.
#[test]
fn a_resume_the_controller_cannot_decide_is_refused_naming_the_candidates() {
    let text = two_pass_job();
    let job = Program::parse("j.gcode", &text).unwrap();
    let vcfg = VirtualConfig {
        pace: Pace::Timed { speedup: 20.0 },
        ..VirtualConfig::default()
    };
    let (vg, host) = VirtualGrbl::spawn(vcfg).unwrap();
    let mut port = Crashing {
        inner: host,
        lines: 2 + 13,
    };
    assert!(send(&mut port, &job, &cfg(), None, &mut Quiet).is_err());
    // Until the lines it had received have all run.
    let mut moves = usize::MAX;
    while vg.record().moves.len() != moves || vg.record().state != "Idle" {
        moves = vg.record().moves.len();
        std::thread::sleep(Duration::from_millis(300));
    }
    let mut host = port.inner;
    let c = StreamConfig {
        from_line: 4,
        recovery: Some(Recovery {
            follow: true,
            ..Recovery::default()
        }),
        ..cfg()
    };
    let err = send(&mut host, &job, &c, None, &mut Quiet).unwrap_err();
    let msg = err.to_string();
    match &err {
        MachineError::ResumeAmbiguous { resume, .. } => {
            assert!(resume.len() >= 2, "{msg}");
            for l in resume {
                assert!(msg.contains(&l.to_string()), "{msg}");
            }
        }
        _ => panic!("{msg}"),
    }
    assert!(msg.contains("nothing was moved"), "{msg}");
    assert_eq!(vg.stop().moves.len(), moves, "the head moved");
}
