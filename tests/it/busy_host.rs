//! A busy computer is not a lost reply (issue 39 item 1).
//!
//! On a loaded machine the sender reads late: lines it wrote after a `?` are in flight when it
//! reads that `?`'s report, which Grbl wrote before those lines arrived. The sender once took
//! such reports ("idle, buffers empty, yet lines unanswered") as lost `ok`s and stopped good jobs
//! (every dry run of a 3,225-line job with a dozen busy processes on two cores). Here both sides
//! lose the CPU at random, by injected pauses (repeatable by seed, unlike a real load): the
//! sender's port pauses before reads and writes, the virtual Grbl between its turns. Every run
//! must stream the whole job exactly, and a truly lost or garbled `ok` must still be caught.

use std::io::{self, Read, Write};
use std::time::Duration;

use serialport::TTYPort;
use stencil_grbl::{
    send, BytePort, Fault, FaultKind, MachineError, Program, Quiet, StreamConfig, Stutter,
    VirtualConfig, VirtualGrbl,
};

/// The sender's end of the link, on a computer that often gives its CPU to others: before a
/// read or a write, with a chance of one in `one_in`, it waits up to `longest` (as the
/// scheduler's time slices do to a process among a dozen busy ones).
struct Starved {
    inner: TTYPort,
    pause: Stutter,
    state: u64,
}

impl Starved {
    fn new(inner: TTYPort, seed: u64) -> Starved {
        Starved {
            inner,
            pause: pauses(seed),
            state: seed,
        }
    }
    fn nap(&mut self) {
        std::thread::sleep(self.pause.next_pause(&mut self.state));
    }
}

impl Read for Starved {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.nap();
        self.inner.read(buf)
    }
}

impl Write for Starved {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.nap();
        self.inner.write(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

impl BytePort for Starved {
    fn set_read_timeout(&mut self, t: Duration) -> io::Result<()> {
        BytePort::set_read_timeout(&mut self.inner, t)
    }
    fn describe(&self) -> String {
        "a starved pseudo-terminal".into()
    }
}

/// One pause in eight, up to 6 ms: long beside a line's round trip on a pty (tens of µs), so
/// the two sides drift apart all the time.
fn pauses(seed: u64) -> Stutter {
    Stutter {
        seed,
        one_in: 8,
        longest: Duration::from_millis(6),
    }
}

/// Status every 5 ms (the default is 250): many more reports cross lines in flight, so a rule
/// that takes a late report for a lost answer fires within the first second of a run.
fn cfg() -> StreamConfig {
    StreamConfig {
        boot_wait: Duration::from_millis(300),
        timeout: Duration::from_secs(10),
        poll_interval: Duration::from_millis(5),
        ..StreamConfig::default()
    }
}

fn starved_grbl(seed: u64, faults: Vec<Fault>) -> (VirtualGrbl, Starved) {
    let vcfg = VirtualConfig {
        stutter: Some(pauses(seed.wrapping_mul(31).wrapping_add(7))),
        faults,
        ..VirtualConfig::default()
    };
    let (vg, port) = VirtualGrbl::spawn(vcfg).unwrap();
    (vg, Starved::new(port, seed))
}

/// The G-code lines the machine took in, outside check mode.
fn received(vg: VirtualGrbl) -> Vec<String> {
    vg.stop()
        .received
        .iter()
        .filter(|l| !l.check_mode && !l.text.starts_with('$'))
        .map(|l| l.text.clone())
        .collect()
}

fn texts(job: &Program) -> Vec<String> {
    job.lines.iter().map(|l| l.text.clone()).collect()
}

/// Jobs for the runs: cutting moves (the planner fills and drains), and a job of lines that do
/// not move (`S` changes: Grbl idles with empty buffers the whole time, where the old rule
/// stopped a 200,000-line job).
fn jobs() -> Vec<Program> {
    let cutting = crate::common_job::job_text_scaled(6);
    let mut still = String::from("G21 G90\nM4 S0\n");
    for i in 0..1500 {
        still += &format!("S{}\n", 100 + i % 800);
    }
    still += "M5\n";
    vec![
        Program::parse("cutting.gcode", &cutting).unwrap(),
        Program::parse("still.gcode", &still).unwrap(),
    ]
}

#[test]
fn a_starved_sender_and_controller_stream_every_job_to_its_end() {
    for (j, job) in jobs().iter().enumerate() {
        assert!(job.lines.len() > 1000, "{}", job.lines.len());
        for seed in 0..3u64 {
            let seed = seed + 10 * j as u64;
            let (vg, mut port) = starved_grbl(seed, Vec::new());
            let run = send(&mut port, job, &cfg(), None, &mut Quiet);
            if let Err(e) = run {
                panic!("{} (seed {seed}): a good job stopped: {e}", job.name);
            }
            assert_eq!(received(vg), texts(job), "{} (seed {seed})", job.name);
        }
    }
}

#[test]
fn a_starved_sender_still_catches_a_lost_or_garbled_ok() {
    let job = &jobs()[0];
    let n = job.lines.len();
    for (seed, kind, at) in [
        (1, FaultKind::DropOk, n / 3),
        (2, FaultKind::GarbleOk, n / 2),
        (3, FaultKind::DropOk, n),
    ] {
        let fault = Fault {
            at_job_line: at,
            kind,
        };
        let (vg, mut port) = starved_grbl(seed, vec![fault]);
        let err = send(&mut port, job, &cfg(), None, &mut Quiet).unwrap_err();
        let msg = err.to_string();
        let MachineError::RepliesLost { lost, .. } = &err else {
            panic!("{kind:?}@{at}: {msg}")
        };
        // Answers are matched to lines in order, so one missing answer leaves the last line
        // waiting: one line, after every line went out.
        assert_eq!(lost.count, 1, "{kind:?}@{at}: {msg}");
        assert!(lost.all_sent, "{kind:?}@{at}: {msg}");
        let r = vg.stop();
        assert!(!r.laser_on, "{kind:?}@{at}: the laser was left on");
    }
}
