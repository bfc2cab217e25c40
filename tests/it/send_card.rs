//! Jobs that survive the link (issue 46.4): `send --to-card` uploads the job to a grblHAL's or
//! FluidNC's card with the firmware's own transfer, checks it arrived whole, runs it there and
//! follows it; a link that drops while it runs does not stop the cut. Grbl 1.1h has no card.

use std::time::Duration;

use stencil_grbl::{
    send_to_card, watch_card, Event, Fault, FaultKind, Firmware, MachineError, Observer, Pace,
    Program, StreamConfig, TcpPort, VirtualConfig, VirtualGrbl,
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

/// 120 cuts: more than one 1024-byte packet, so the transfer numbers several.
fn job_text() -> String {
    let mut s = String::from("G21 G90\nM4 S0\nG0 X5 Y5\n");
    for i in 0..120 {
        let x = 5.0 + (i % 40) as f64 * 0.5;
        let y = 5.0 + (i / 40) as f64 * 2.0;
        s += &format!("G1 X{x:.2} Y{y:.2} S400 F3000\n");
    }
    s + "M5\n"
}

/// What the board ran after the command that started the card job.
fn ran_from_card<'a>(run: &[&'a str], start: &str) -> Vec<&'a str> {
    let at = run.iter().position(|l| *l == start).expect(start);
    run[at + 1..].to_vec()
}

#[test]
fn the_job_is_uploaded_checked_and_run_from_the_card_of_grblhal_and_fluidnc() {
    let text = job_text();
    let job = Program::parse("/tmp/ring job.gcode", &text).unwrap();
    let lines: Vec<&str> = job.lines.iter().map(|l| l.text.as_str()).collect();
    for (fw, start) in [
        (Firmware::GrblHal, "$F=RING_JOB.NC"),
        (Firmware::FluidNc, "$SDRUN=RING_JOB.NC"),
    ] {
        let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::dialect(fw)).unwrap();
        let mut notes = Notes::default();
        let sum = send_to_card(&mut port, &job, &cfg(), None, &mut notes).unwrap();
        let r = vg.stop();
        assert_eq!(sum.file, "ring_job.nc", "{fw}");
        assert_eq!(sum.lines, lines.len(), "{fw}");
        // Written to the card once, by the firmware's transfer.
        let files: Vec<&Event> = r
            .events
            .iter()
            .filter(|e| matches!(e, Event::CardFile(_)))
            .collect();
        assert_eq!(files, [&Event::CardFile("ring_job.nc".into())], "{fw}");
        // Checked (listed and read back), then every line ran once, in order, from the card.
        let run = r.run_lines();
        let (list, show) = match fw {
            Firmware::GrblHal => ("$F+", "$F<=RING_JOB.NC"),
            _ => ("$SDLIST", "$SDSHOW=RING_JOB.NC"),
        };
        assert!(run.contains(&list) && run.contains(&show), "{fw}: {run:?}");
        let card: Vec<&str> = ran_from_card(&run, start)
            .into_iter()
            .filter(|l| !l.is_empty())
            .collect();
        assert_eq!(card, lines, "{fw}");
        assert!(
            notes.0.iter().any(|n| n.contains("on the card whole")),
            "{fw}: {:?}",
            notes.0
        );
        assert!(
            notes.0.iter().any(|n| n.contains("is done")),
            "{fw}: {:?}",
            notes.0
        );
        assert!(!r.events.contains(&Event::SoftReset), "{fw}");
        assert!(!r.laser_on && r.state == "Idle", "{fw}");
    }
}

#[test]
fn grbl_has_no_card_and_nothing_is_sent() {
    let job = Program::parse("j.gcode", &job_text()).unwrap();
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::dialect(Firmware::Grbl)).unwrap();
    let err = send_to_card(&mut port, &job, &cfg(), None, &mut Notes::default()).unwrap_err();
    let r = vg.stop();
    assert!(matches!(err, MachineError::NoCard { .. }), "{err}");
    assert!(err.to_string().contains("stream the job instead"), "{err}");
    // Only the questions connecting asks: no transfer began.
    assert_eq!(r.run_lines(), ["$I", "$$"]);
    assert!(!r.events.iter().any(|e| matches!(e, Event::CardFile(_))));
}

#[test]
fn a_link_dropped_while_the_card_runs_the_job_does_not_stop_the_cut() {
    let text = job_text();
    let job = Program::parse("j.gcode", &text).unwrap();
    let lines: Vec<&str> = job.lines.iter().map(|l| l.text.as_str()).collect();
    for fw in [Firmware::GrblHal, Firmware::FluidNc] {
        let vcfg = VirtualConfig {
            pace: Pace::Timed { speedup: 20.0 },
            faults: vec![Fault {
                at_job_line: 40,
                kind: FaultKind::DropLink,
            }],
            ..VirtualConfig::dialect(fw)
        };
        let (vg, addr) = VirtualGrbl::spawn_tcp(vcfg).unwrap();
        let mut port = TcpPort::connect(&addr.to_string(), Duration::from_secs(5)).unwrap();
        let err = send_to_card(&mut port, &job, &cfg(), None, &mut Notes::default()).unwrap_err();
        assert!(
            matches!(err, MachineError::CardLinkLost { .. }),
            "{fw}: {err}"
        );
        assert!(err.to_string().contains("the cut goes on"), "{fw}: {err}");
        drop(port);
        // Reached again: followed to the end without a reset or a line sent.
        let mut port = TcpPort::connect(&addr.to_string(), Duration::from_secs(5)).unwrap();
        let mut notes = Notes::default();
        watch_card(&mut port, "j.nc", &cfg(), None, &mut notes).unwrap();
        let r = vg.stop();
        assert!(r.events.contains(&Event::LinkDropped), "{fw}");
        assert!(
            !r.events.contains(&Event::SoftReset),
            "{fw}: {:?}",
            r.events
        );
        let start = match fw {
            Firmware::GrblHal => "$F=J.NC",
            _ => "$SDRUN=J.NC",
        };
        let card: Vec<&str> = ran_from_card(&r.run_lines(), start)
            .into_iter()
            .filter(|l| !l.is_empty())
            .collect();
        assert_eq!(card, lines, "{fw}: every line of the card job ran");
        // And was carried out, not only read: the last cut's line executed.
        let last = r
            .received
            .iter()
            .rposition(|l| l.text == lines[lines.len() - 2]);
        assert!(r.executed.contains(&last.unwrap()), "{fw}");
        assert!(!r.laser_on && r.state == "Idle", "{fw}");
    }
}

/// `stencil send --to-card` on the virtual card over the network: uploaded, checked and run
/// there; the link dropped mid-cut, the board is reached again and the job followed to its end.
#[test]
fn send_to_card_runs_on_the_virtual_card_and_a_dropped_link_does_not_stop_the_cut() {
    let dir = crate::common::tmp();
    let file = dir.path().join("rings.gcode");
    std::fs::write(&file, job_text()).unwrap();
    for fw in ["grblhal", "fluidnc"] {
        let o = crate::common::stencil(&[
            "send",
            "--dry-run",
            "--dry-run-tcp",
            "--dry-run-firmware",
            fw,
            "--realtime",
            "--dry-run-fault",
            "drop-link@60",
            "--to-card",
            crate::common::s(&file),
        ]);
        let err = crate::common::stderr(&o);
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{fw}: {err}\n{out}");
        assert!(
            out.contains("rings.nc is on the card whole") && out.contains("read back"),
            "{fw}: {out}"
        );
        assert!(
            err.contains("dropped while the controller runs rings.nc from its card")
                && err.contains("it is not reset"),
            "{fw}: {err}"
        );
        assert!(
            out.contains("rings.nc ran to its end from the card") && out.contains("never reset"),
            "{fw}: {out}"
        );
        // The virtual board's own account: every cut ran (the beam's extent is the job's), idle,
        // laser off, no alarm.
        assert!(
            out.contains("state Idle") && out.contains("laser off") && out.contains("alarms: none"),
            "{fw}: {out}"
        );
        assert!(
            out.contains("the beam cut within machine X 5.000..24.500 Y 5.000..9.000"),
            "{fw}: {out}"
        );
    }
}

#[test]
fn send_to_card_refuses_grbl_which_has_no_card() {
    let dir = crate::common::tmp();
    let file = dir.path().join("j.gcode");
    std::fs::write(&file, job_text()).unwrap();
    let o = crate::common::stencil(&["send", "--dry-run", "--to-card", crate::common::s(&file)]);
    let err = crate::common::stderr(&o);
    assert!(!o.status.success());
    assert!(
        err.contains("Grbl 1.1h has no card to run a job from")
            && err.contains("stream the job instead (without --to-card)"),
        "{err}"
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(!out.contains("the beam cut"), "{out}");
}

#[test]
fn send_to_card_refuses_a_plotter_job_which_has_no_card_to_go_to() {
    let dir = crate::common::tmp();
    let file = dir.path().join("j.plt");
    std::fs::write(&file, "IN;SP1;PU0,0;PD400,0,400,400;PU;").unwrap();
    let o = crate::common::stencil(&["send", "--dry-run", "--to-card", crate::common::s(&file)]);
    let err = crate::common::stderr(&o);
    assert!(!o.status.success());
    assert!(
        err.contains("j.plt: --to-card runs a G-code job")
            && err.contains("send the HP-GL job without --to-card"),
        "{err}"
    );
}

/// Presses keys when the card run says how it stands: a feed hold once it runs, then resume
/// once it is held (or an abort once it runs).
struct Operator {
    keys: std::sync::mpsc::Sender<stencil_grbl::Control>,
    abort: bool,
    notes: Vec<String>,
}
impl Observer for Operator {
    fn message(&mut self, text: &str) {
        use stencil_grbl::Control;
        let first = |n: &[String], s: &str| !n.iter().any(|m| m.contains(s));
        if text.starts_with("card:") && text.ends_with("(Run)") && first(&self.notes, "(Run)") {
            let _ = self.keys.send(if self.abort {
                Control::Abort
            } else {
                Control::FeedHold
            });
        }
        if text.ends_with("(Hold:0)") && first(&self.notes, "(Hold:0)") {
            let _ = self.keys.send(Control::Resume);
        }
        self.notes.push(text.to_string());
    }
}

#[test]
fn pause_resume_and_abort_work_on_a_card_job() {
    let job = Program::parse("j.gcode", &job_text()).unwrap();
    let lines: Vec<&str> = job.lines.iter().map(|l| l.text.as_str()).collect();
    for fw in [Firmware::GrblHal, Firmware::FluidNc] {
        let vcfg = || VirtualConfig {
            pace: Pace::Timed { speedup: 1.0 },
            ..VirtualConfig::dialect(fw)
        };
        // Held while it runs, resumed once it stands: the job ends whole.
        let (vg, mut port) = VirtualGrbl::spawn(vcfg()).unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        let mut op = Operator {
            keys: tx,
            abort: false,
            notes: Vec::new(),
        };
        send_to_card(&mut port, &job, &cfg(), Some(&rx), &mut op).unwrap();
        let r = vg.stop();
        let held = op.notes.iter().position(|n| n.ends_with("(Hold:0)"));
        let resumed = op.notes.iter().position(|n| n.contains("resuming"));
        assert!(held.is_some() && resumed > held, "{fw}: {:?}", op.notes);
        assert!(r.events.contains(&Event::Realtime(b'!')), "{fw}");
        assert!(r.events.contains(&Event::Realtime(b'~')), "{fw}");
        let last = r
            .received
            .iter()
            .rposition(|l| l.text == lines[lines.len() - 2]);
        assert!(
            r.executed.contains(&last.unwrap()),
            "{fw}: the job ran to its end"
        );
        assert!(!r.laser_on && r.state == "Idle", "{fw}");

        // Aborted while it runs: held, reset, laser off, no alarm, the rest not cut.
        let (vg, mut port) = VirtualGrbl::spawn(vcfg()).unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        let mut op = Operator {
            keys: tx,
            abort: true,
            notes: Vec::new(),
        };
        let err = send_to_card(&mut port, &job, &cfg(), Some(&rx), &mut op).unwrap_err();
        let r = vg.stop();
        assert!(matches!(err, MachineError::Aborted { .. }), "{fw}: {err}");
        assert!(r.events.contains(&Event::SoftReset), "{fw}");
        let alarms = r.events.iter().any(|e| matches!(e, Event::Alarm(_)));
        assert!(!alarms && !r.laser_on, "{fw}: {:?}", r.events);
        let last = r
            .received
            .iter()
            .rposition(|l| l.text == lines[lines.len() - 2]);
        assert!(
            last.is_none_or(|i| !r.executed.contains(&i)),
            "{fw}: the card job went on after the abort"
        );
    }
}
