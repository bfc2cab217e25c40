//! Against grblHAL itself (issue 46): its Simulator (grblHAL/Simulator with grblHAL/core, built
//! outside this repository, run with `-p PORT` for its raw TCP stream) answers the parser cases
//! of `grbl_parity.rs` and is streamed jobs by the same code as `stencil send --port tcp://`.
//!
//! Runs when `GRBLHAL_SIM` names the running simulator's `HOST:PORT` (e.g. `127.0.0.1:23023`);
//! otherwise each test says it was skipped. The simulator should have `$32=1` (laser mode) and
//! brisk motion settings (`$110`/`$111` 6000, `$120`/`$121` 1000) so the jobs do not crawl.
//! Start it fresh for each run: its socket mode was seen to stop reading after a few
//! connections, or a few hundred streamed lines on a busy machine (the sender then reports a
//! stall, or no answer, and stops as it stops any job).

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use stencil_grbl::{send, Firmware, Observer, Program, StreamConfig, TcpPort};

use crate::grbl_parity::CASES;

fn simulator() -> Option<String> {
    let addr = std::env::var("GRBLHAL_SIM").ok().filter(|a| !a.is_empty());
    if addr.is_none() {
        eprintln!("skipped: set GRBLHAL_SIM=HOST:PORT of a running grblHAL Simulator (-p PORT)");
    }
    addr
}

/// The parser cases grblHAL answers differently from Grbl 1.1h, as recorded on 2026-11-29
/// against the Simulator (grblHAL/Simulator with grblHAL/core 868991815d, build 20260817, its
/// default settings but `$32=1`, `$110`/`$111` 6000, `$120`/`$121` 1000): the line, Grbl
/// 1.1h's answer, grblHAL's. An answer that comes late (an arc or M0/M1 that waits) counts as
/// the answer; "nothing": none within 1.5 s nor 5 s after a cycle start (arcs of a large
/// radius). By kind: grblHAL reads the words Grbl does not know as unused (36, not 20); has
/// G59.1-G59.3, G92.2, M6/M7, tool numbers past 255, lines of 256 characters (no error:11),
/// G43.1 on any axis, `%`; checks arcs and probes in its own order (33/34/35 where Grbl
/// names another code, radius tolerance of its own).
const GRBLHAL_DIFFERS: &[(&str, &str, &str)] = &[
    ("%", "error:1", "ok"),
    ("G0X1E3", "error:20", "error:36"),
    ("G0X1A2", "error:20", "error:36"),
    ("G0X1B2", "error:20", "error:36"),
    ("G0X1C2", "error:20", "error:36"),
    ("D1", "error:20", "error:36"),
    ("H1", "error:20", "error:36"),
    ("O100", "error:20", "error:36"),
    ("G1X1Q1F10", "error:20", "error:36"),
    ("G5X1", "error:20", "error:22"),
    ("G81X1", "error:20", "error:22"),
    ("G59.1", "error:23", "ok"),
    ("G92.2", "error:20", "ok"),
    ("T256", "error:38", "ok"),
    ("G2X10I5P1", "error:36", "error:33"),
    ("G10X5", "error:28", "error:20"),
    ("G10L2P7X5", "error:29", "ok"),
    ("G53X1", "error:30", "error:33"),
    ("G92X0", "error:31", "ok"),
    ("G3X10R5", "ok", "error:33"),
    ("G2X10Y10R-10", "ok", "nothing"),
    ("G2X10R4", "error:34", "error:33"),
    ("G2X0Y0R5", "error:33", "error:34"),
    ("G2", "error:26", "error:35"),
    ("G2X10I4", "error:33", "ok"),
    ("G2X10I5.004", "error:33", "ok"),
    ("G2X200I100.04", "ok", "error:33"),
    ("G2X0Y0I5", "ok", "error:33"),
    ("G3X0Y0J5", "ok", "error:33"),
    ("G18G2Y10J5", "error:32", "error:35"),
    ("G20G2X1I0.5", "ok", "error:33"),
    ("X0I-5", "ok", "nothing"),
    ("G38.3X1F100", "ok", "error:33"),
    ("G38.4X1F100", "ok", "error:33"),
    ("G38.5X1F100", "ok", "error:33"),
    ("G38.2X0F100", "error:33", "ok"),
    ("G43.1X1", "error:37", "ok"),
    ("G43.1Z1X1", "error:37", "ok"),
    (
        "G0X1.000000000000000000000000000000000000000000000000000000000000000000000000000",
        "error:11",
        "ok",
    ),
    (
        "G1 X11111111111111111111111111111111111111111111111111111111111111111111111111111111 F100",
        "error:11",
        "ok",
    ),
    ("M7", "error:20", "ok"),
    ("M6", "error:20", "ok"),
    ("M48", "error:20", "ok"),
];

/// Read until a line is answered (`ok`, `error:N`) or `limit` passes; every line read.
fn answer(port: &mut TcpPort, limit: Duration) -> Vec<String> {
    let mut got = String::new();
    let end = Instant::now() + limit;
    let mut buf = [0u8; 512];
    stencil_grbl::BytePort::set_read_timeout(port, Duration::from_millis(20)).unwrap();
    loop {
        let lines: Vec<String> = got.split("\r\n").map(str::to_string).collect();
        let complete = &lines[..lines.len() - 1];
        if complete
            .iter()
            .any(|l| l == "ok" || l.starts_with("error:"))
            || Instant::now() > end
        {
            return complete.to_vec();
        }
        if let Ok(n) = port.read(&mut buf) {
            got.push_str(&String::from_utf8_lossy(&buf[..n]));
        }
    }
}

/// Ask `?` until the machine stands (`Idle`, or `Alarm`, which is then unlocked).
fn stand(port: &mut TcpPort) {
    let end = Instant::now() + Duration::from_secs(60);
    while Instant::now() < end {
        port.write_all(b"?").unwrap();
        let mut got = String::new();
        let mut buf = [0u8; 512];
        let t = Instant::now() + Duration::from_millis(300);
        while Instant::now() < t && !got.contains('>') {
            if let Ok(n) = port.read(&mut buf) {
                got.push_str(&String::from_utf8_lossy(&buf[..n]));
            }
        }
        if got.contains("<Idle") {
            return;
        }
        if got.contains("<Alarm") {
            port.write_all(b"$X\n").unwrap();
            answer(port, Duration::from_secs(2));
        }
        if got.contains("<Hold") {
            port.write_all(b"~").unwrap();
        }
    }
    panic!("the simulator does not come to rest");
}

/// grblHAL's answer to `line` after `setup`, from a reset machine with no G92 offset.
fn grblhal_answer(port: &mut TcpPort, setup: &str, line: &str) -> String {
    stand(port);
    port.write_all(&[0x18]).unwrap();
    std::thread::sleep(Duration::from_millis(200));
    let mut sink = [0u8; 4096];
    let _ = port.read(&mut sink);
    for l in std::iter::once("G92.1").chain(setup.lines()) {
        port.write_all(format!("{l}\n").as_bytes()).unwrap();
        answer(port, Duration::from_secs(10));
    }
    port.write_all(format!("{line}\n").as_bytes()).unwrap();
    let a = answer(port, Duration::from_millis(1500));
    match a
        .iter()
        .rev()
        .find(|l| *l == "ok" || l.starts_with("error:"))
    {
        Some(l) => l.clone(),
        None => {
            // M0 holds: the answer comes with cycle start.
            port.write_all(b"~").unwrap();
            let a = answer(port, Duration::from_secs(5));
            match a.last() {
                Some(l) => format!("{l} after ~"),
                None => "nothing".into(),
            }
        }
    }
}

#[test]
fn the_parser_cases_grblhal_answers_differently_are_the_recorded_ones() {
    let Some(addr) = simulator() else { return };
    let mut port = TcpPort::connect(&addr, Duration::from_secs(5)).unwrap();
    let mut differs = Vec::new();
    for &(setup, line, want, _) in CASES {
        let got = grblhal_answer(&mut port, setup, line);
        let got = got.trim_end_matches(" after ~").to_string();
        if got != want.trim_end_matches(" after ~") {
            differs.push((line, want, got));
        }
    }
    stand(&mut port);
    for (line, want, got) in &differs {
        eprintln!("{line:?}: Grbl 1.1h {want}, grblHAL {got}");
    }
    eprintln!(
        "{} of {} cases answered differently",
        differs.len(),
        CASES.len()
    );
    let recorded: Vec<(&str, &str, String)> = GRBLHAL_DIFFERS
        .iter()
        .map(|&(l, w, g)| (l, w, g.to_string()))
        .collect();
    assert_eq!(differs, recorded);
}

#[derive(Default)]
struct Notes(Vec<String>);
impl Observer for Notes {
    fn message(&mut self, text: &str) {
        self.0.push(text.to_string());
    }
}

#[test]
fn jobs_stream_to_grblhal_with_every_line_acknowledged_once() {
    let Some(addr) = simulator() else { return };
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    for name in [
        "third_party/lasergrbl.nc",
        "third_party/lightburn.gc",
        "grbl_sim/arc-square.nc",
    ] {
        let text = std::fs::read_to_string(dir.join(name)).unwrap();
        let job = Program::parse(name, &text).unwrap();
        let mut port = TcpPort::connect(&addr, Duration::from_secs(5)).unwrap();
        let cfg = StreamConfig {
            timeout: Duration::from_secs(20),
            ..StreamConfig::default()
        };
        let mut notes = Notes::default();
        let started = Instant::now();
        let sum = send(&mut port, &job, &cfg, None, &mut notes)
            .unwrap_or_else(|e| panic!("{name}: {e}\n{:?}", notes.0));
        eprintln!(
            "{name}: {} lines, {} bytes, at most {} in flight of {}, {:.1} s",
            sum.lines,
            sum.bytes,
            sum.max_in_flight,
            sum.rx_limit,
            started.elapsed().as_secs_f64()
        );
        assert_eq!(sum.info.firmware, Firmware::GrblHal, "{name}");
        assert_eq!(sum.lines, job.lines.len(), "{name}");
        // No answer without a line waiting for it, none lost.
        assert!(
            !notes.0.iter().any(|n| n.contains("no line waiting")),
            "{name}: {:?}",
            notes.0
        );
    }
}
