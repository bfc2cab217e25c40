//! grblHAL and FluidNC beside Grbl 1.1h (issue 46): the sender knows which it talks to, never
//! resets one by connecting, counts against the buffer each reports, checks each one's laser
//! settings, and streams the same job to all three with every line acknowledged once.

use std::sync::mpsc::{channel, Sender};
use std::time::Duration;

use stencil_grbl::{
    send, Control, Event, Expected, Firmware, IfMoving, MachineError, Observer, Pace, PowerScale,
    Program, Progress, Record, StreamConfig, VirtualConfig, VirtualGrbl,
};

fn cfg() -> StreamConfig {
    StreamConfig {
        boot_wait: Duration::from_millis(300),
        timeout: Duration::from_secs(5),
        ..StreamConfig::default()
    }
}

#[derive(Default)]
struct Notes(Vec<String>);
impl Observer for Notes {
    fn message(&mut self, text: &str) {
        self.0.push(text.to_string());
    }
}

const ALL: [Firmware; 3] = [Firmware::Grbl, Firmware::GrblHal, Firmware::FluidNc];

/// A job of 200 short cuts: long enough to fill even grblHAL's 1024-byte buffer many times.
fn job_text() -> String {
    let mut s = String::from("G21 G90\nM4 S0\nG0 X5 Y5\n");
    for i in 0..200 {
        let x = 5.0 + (i % 50) as f64 * 0.5;
        let y = 5.0 + (i / 50) as f64 * 2.0;
        s += &format!("G1 X{x:.2} Y{y:.2} S400 F3000\n");
    }
    s + "M5\n"
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

#[test]
fn the_same_job_streams_to_grbl_grblhal_and_fluidnc_every_line_once() {
    let text = job_text();
    let job = Program::parse("j.gcode", &text).unwrap();
    let lines: Vec<&str> = job.lines.iter().map(|l| l.text.as_str()).collect();
    for fw in ALL {
        let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::dialect(fw)).unwrap();
        let mut notes = Notes::default();
        let sum = send(&mut port, &job, &cfg(), None, &mut notes).unwrap();
        let r = vg.stop();
        assert_eq!(sum.lines, lines.len(), "{fw}");
        // Identified, with the sizes each reports, and counted against them.
        assert_eq!(sum.info.firmware, fw);
        let (rx, blocks) = match fw {
            Firmware::Grbl => (128, 15),
            Firmware::GrblHal => (1024, 35),
            Firmware::FluidNc => (256, 16),
        };
        assert_eq!(
            (sum.info.rx_buffer, sum.info.planner_blocks),
            (rx, blocks),
            "{fw}"
        );
        assert_eq!(sum.rx_limit, rx - 1, "{fw}");
        assert!(
            sum.max_in_flight > 128 || fw == Firmware::Grbl,
            "{fw}: {sum:?}"
        );
        assert_eq!(r.overflow_bytes, 0, "{fw}");
        // Every job line arrived once, in order, after the sender's own queries.
        let run = r.run_lines();
        let first = run.iter().position(|l| *l == "G21G90").unwrap();
        assert_eq!(&run[first..], &lines[..], "{fw}");
        let setup = &run[..first];
        match fw {
            Firmware::Grbl => assert_eq!(setup, ["$I", "$$"]),
            Firmware::GrblHal => assert_eq!(setup, ["$I", "$$"]),
            Firmware::FluidNc => assert_eq!(setup, ["$I", "$$", "$CD"]),
        }
        // grblHAL and FluidNC were never reset: no banner asked for, none needed.
        let resets = r.events.iter().filter(|e| **e == Event::SoftReset).count();
        assert_eq!(resets, 0, "{fw}: {:?}", r.events);
        if fw != Firmware::Grbl {
            assert!(
                notes.0.iter().any(|n| n.contains("without resetting it")),
                "{fw}: {:?}",
                notes.0
            );
        }
        assert!(
            !r.laser_on && r.state == "Idle" && alarms(&r).is_empty(),
            "{fw}"
        );
    }
}

/// A board still running the rest of a job a sender that died gave it (no banner when the port
/// opens), at its pace: 60 mm at 1200 mm/min is 3 s a line.
fn running(fw: Firmware, lines: usize) -> VirtualConfig {
    let mut text = String::from("G21G90\nM4S0\nG1X60F1200\n");
    for i in 1..lines {
        text.push_str(if i % 2 == 1 { "G1X0\n" } else { "G1X60\n" });
    }
    VirtualConfig {
        pace: Pace::Timed { speedup: 1.0 },
        mid_job: Some(text),
        ..VirtualConfig::dialect(fw)
    }
}

#[test]
fn connecting_to_a_controller_running_a_job_does_not_stop_it() {
    let job = Program::parse("j.gcode", "G21G90\nG0X10\n").unwrap();
    for fw in [Firmware::GrblHal, Firmware::FluidNc] {
        // A running job the sender may not wait for: refused, and the job runs on untouched.
        let (vg, mut port) = VirtualGrbl::spawn(running(fw, 10)).unwrap();
        let c = StreamConfig {
            if_moving: IfMoving::Wait(Duration::from_millis(800)),
            ..cfg()
        };
        let err = send(&mut port, &job, &c, None, &mut Notes::default()).unwrap_err();
        assert!(matches!(err, MachineError::Running { .. }), "{fw}: {err}");
        let r = vg.stop();
        assert!(
            !r.events.contains(&Event::SoftReset),
            "{fw}: {:?}",
            r.events
        );
        assert!(
            !r.events.iter().any(|e| matches!(e, Event::Realtime(b'!'))),
            "{fw}: held"
        );
        assert!(!r.run_lines().contains(&"G0X10"), "{fw}");
        assert_eq!(r.state, "Run", "{fw}: the job was stopped");

        // One that ends soon: waited for, never reset, then the new job runs.
        let (vg, mut port) = VirtualGrbl::spawn(running(fw, 1)).unwrap();
        let mut notes = Notes::default();
        send(&mut port, &job, &cfg(), None, &mut notes).unwrap();
        let r = vg.stop();
        assert!(
            !r.events.contains(&Event::SoftReset),
            "{fw}: {:?}",
            r.events
        );
        assert!(r.executed.contains(&2), "{fw}: the old job's last move ran");
        assert!(r.run_lines().contains(&"G0X10"), "{fw}");
        assert!(alarms(&r).is_empty(), "{fw}");
        assert!(
            notes.0.iter().any(|n| n.contains("finished those moves")),
            "{fw}: {:?}",
            notes.0
        );
    }
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
fn an_abort_while_moving_stops_every_dialect_without_an_alarm() {
    let job = Program::parse("j.gcode", &job_text()).unwrap();
    for fw in ALL {
        let vcfg = VirtualConfig {
            pace: Pace::Timed { speedup: 20.0 },
            ..VirtualConfig::dialect(fw)
        };
        let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
        let (tx, rx) = channel();
        let mut obs = AbortAt { tx, at: Some(40) };
        let err = send(&mut port, &job, &cfg(), Some(&rx), &mut obs).unwrap_err();
        assert!(matches!(err, MachineError::Aborted { .. }), "{fw}: {err}");
        let r = vg.stop();
        assert!(alarms(&r).is_empty(), "{fw}: alarms {:?}", alarms(&r));
        assert!(!r.laser_on, "{fw}: laser left on");
        let hold = r.events.iter().position(|e| *e == Event::Realtime(b'!'));
        let reset = r.events.iter().rposition(|e| *e == Event::SoftReset);
        assert!(hold.is_some() && hold < reset, "{fw}: {:?}", r.events);
    }
}

fn laser_job() -> (String, StreamConfig) {
    let expect = Expected {
        power: Some(PowerScale {
            s_max: 1000.0,
            s_min: 0.0,
            source: "read from its header".into(),
        }),
        ..Expected::default()
    };
    let c = StreamConfig { expect, ..cfg() };
    ("G21G90\nM4S0\nG1X5F600S500\nM5\n".into(), c)
}

#[test]
fn fluidnc_laser_settings_come_from_its_configuration_file() {
    let (text, c) = laser_job();
    let job = Program::parse("j.gcode", &text).unwrap();
    // The speed map's full power differs from the job's $30: refused before the beam.
    let vcfg = VirtualConfig {
        settings: vec![(30, "255".into())],
        ..VirtualConfig::dialect(Firmware::FluidNc)
    };
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let mut notes = Notes::default();
    let err = send(&mut port, &job, &c, None, &mut notes).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, MachineError::PowerScale { .. }), "{msg}");
    assert!(
        notes
            .0
            .iter()
            .any(|n| n.contains("speed_map S255 at full power")),
        "{:?}",
        notes.0
    );
    let r = vg.stop();
    assert!(!r.run_lines().contains(&"G1X5F600S500"));
    // Laser mode off: FluidNC's $32 mirrors its configuration file, so setting it is not
    // offered; the message says where it is set.
    let vcfg = VirtualConfig {
        laser_mode: false,
        ..VirtualConfig::dialect(Firmware::FluidNc)
    };
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
    let c = StreamConfig {
        laser_mode: stencil_grbl::LaserMode::Require,
        ..c
    };
    let err = send(&mut port, &job, &c, None, &mut Notes::default()).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, MachineError::FluidLaserOff { .. }), "{msg}");
    assert!(
        msg.contains("config.yaml") && msg.contains("Laser:"),
        "{msg}"
    );
    let r = vg.stop();
    assert!(r.run_lines().iter().all(|l| !l.starts_with('G')));
    // grblHAL keeps Grbl's $30/$31/$32: the same check as Grbl's passes with its settings.
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::dialect(Firmware::GrblHal)).unwrap();
    send(&mut port, &job, &c, None, &mut Notes::default()).unwrap();
    assert!(vg.stop().run_lines().contains(&"G1X5F600S500"));
}

#[test]
fn over_tcp_every_dialect_streams_and_a_dropped_link_is_reported_and_recovered_without_reset() {
    use stencil_grbl::{Console, Fault, FaultKind, TcpPort};
    let text = job_text();
    let job = Program::parse("j.gcode", &text).unwrap();
    let lines: Vec<&str> = job.lines.iter().map(|l| l.text.as_str()).collect();
    for fw in ALL {
        // The whole job over the network.
        let (vg, addr) = VirtualGrbl::spawn_tcp(VirtualConfig::dialect(fw)).unwrap();
        let mut port = TcpPort::connect(&addr.to_string(), Duration::from_secs(5)).unwrap();
        assert_eq!(
            stencil_grbl::BytePort::describe(&port),
            format!("tcp://{addr}")
        );
        let sum = send(&mut port, &job, &cfg(), None, &mut Notes::default()).unwrap();
        drop(port);
        let r = vg.stop();
        assert_eq!(sum.lines, lines.len(), "{fw}");
        let run = r.run_lines();
        let first = run.iter().position(|l| *l == "G21G90").unwrap();
        assert_eq!(&run[first..], &lines[..], "{fw}");

        // The link drops at the 100th line, mid-cut: reported, with where to resume.
        let vcfg = VirtualConfig {
            pace: Pace::Timed { speedup: 20.0 },
            faults: vec![Fault {
                at_job_line: 100,
                kind: FaultKind::DropLink,
            }],
            ..VirtualConfig::dialect(fw)
        };
        let (vg, addr) = VirtualGrbl::spawn_tcp(vcfg).unwrap();
        let mut port = TcpPort::connect(&addr.to_string(), Duration::from_secs(5)).unwrap();
        let err = send(&mut port, &job, &cfg(), None, &mut Notes::default()).unwrap_err();
        let msg = err.to_string();
        assert!(matches!(err, MachineError::PortLost { .. }), "{fw}: {msg}");
        assert!(msg.contains("closed the network connection"), "{fw}: {msg}");
        let resume = err.halt().unwrap().resume_from;
        drop(port);
        // Reached again: it ran on (never reset, no alarm), is watched until it stands, and
        // the beam is switched off.
        let mut port = TcpPort::connect(&addr.to_string(), Duration::from_secs(5)).unwrap();
        let mut notes = Notes::default();
        let watch = cfg();
        let mut c = Console::connect(&mut port, &watch, None, &mut notes).unwrap();
        c.command("M5").unwrap();
        // One more exchange: the board has published what the M5 did.
        let stands = c.position().unwrap();
        assert_eq!(
            stands.status.state,
            stencil_grbl::MachineState::Idle,
            "{fw}"
        );
        drop(c);
        let r = vg.record();
        assert!(r.events.contains(&Event::LinkDropped), "{fw}");
        // Grbl 1.1h (no network of its own: behind a bridge) is woken with a reset once it
        // stands, as on a serial port; grblHAL and FluidNC are never reset.
        let reset_free = |r: &Record| fw == Firmware::Grbl || !r.events.contains(&Event::SoftReset);
        assert!(reset_free(&r), "{fw}: {:?}", r.events);
        assert!(alarms(&r).is_empty() && !r.laser_on, "{fw}");
        assert_eq!(r.state, "Idle");
        // The job resumes on the same connection from where the report said.
        let c = StreamConfig {
            from_line: resume,
            ..cfg()
        };
        let mut notes = Notes::default();
        send(&mut port, &job, &c, None, &mut notes).unwrap();
        let r = vg.stop();
        assert!(reset_free(&r), "{fw}: {:?}", r.events);
        let dropped = r
            .events
            .iter()
            .position(|e| *e == Event::LinkDropped)
            .unwrap();
        let after: Vec<&str> = r.events[dropped..]
            .iter()
            .filter_map(|e| match e {
                Event::Line(i) => Some(r.received[*i].text.as_str()),
                _ => None,
            })
            .collect();
        // Everything from the resume line on arrived once after the drop (the board's own
        // leftover lines ran before the resume; the resume's lines follow).
        let tail = &lines[job.lines.iter().position(|l| l.number >= resume).unwrap()..];
        let start = after.len() - tail.len();
        assert_eq!(&after[start..], tail, "{fw}");
        assert!(!r.laser_on && alarms(&r).is_empty(), "{fw}");
    }
}

#[test]
fn send_over_tcp_reports_a_dropped_link_and_makes_the_board_safe_without_resetting_it() {
    let dir = crate::common::tmp();
    let file = dir.path().join("j.gcode");
    std::fs::write(&file, job_text()).unwrap();
    let o = crate::common::stencil(&[
        "send",
        "--dry-run",
        "--dry-run-tcp",
        "--dry-run-firmware",
        "fluidnc",
        "--realtime",
        "--dry-run-fault",
        "drop-link@100",
        crate::common::s(&file),
    ]);
    let err = crate::common::stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("dropped mid-job") && err.contains("it is not reset"),
        "{err}"
    );
    assert!(
        err.contains("the controller closed the network connection"),
        "{err}"
    );
    assert!(
        err.contains("reached FluidNC 3.7.8 again") && err.contains("laser and air switched off"),
        "{err}"
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("alarms: none") && out.contains("laser off"),
        "{out}"
    );
    // A network port that is not HOST:PORT is refused before anything is opened.
    let o = crate::common::stencil(&["send", "--port", "tcp://board", crate::common::s(&file)]);
    let err = crate::common::stderr(&o);
    assert!(!o.status.success());
    assert!(
        err.contains("--port tcp://board") && err.contains("tcp://HOST:PORT"),
        "{err}"
    );
}

/// The job check plays Grbl 1.1h: on a grblHAL board the lines grblHAL answers differently (as
/// measured against its Simulator) are named before anything is sent; on Grbl they are not.
#[test]
fn the_job_check_names_what_grblhal_answers_differently() {
    let job = Program::parse("j.gcode", "G21G90\nG0X5\nM7\nG0X1A2\nM9\n").unwrap();
    for fw in [Firmware::GrblHal, Firmware::Grbl] {
        let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::dialect(fw)).unwrap();
        let mut notes = Notes::default();
        // The virtual board judges lines as Grbl 1.1h does: M7 is refused either way.
        let _ = send(&mut port, &job, &cfg(), None, &mut notes);
        drop(vg);
        let named: Vec<&String> = notes
            .0
            .iter()
            .filter(|n| n.starts_with("j.gcode: line"))
            .collect();
        if fw == Firmware::GrblHal {
            assert_eq!(named.len(), 2, "{:?}", notes.0);
            assert!(
                named[0].contains("line 3 `M7`: grblHAL accepts it"),
                "{named:?}"
            );
            assert!(
                named[1].contains("line 4 `G0X1A2`: grblHAL answers error:36"),
                "{named:?}"
            );
        } else {
            assert!(named.is_empty(), "{named:?}");
        }
    }
}
