//! Sending HP-GL to a plotter (issue 45, the remaining gaps): a run stopped by a dead port or a
//! plotter's power loss leaves a journal, and `--recover` finishes the job so that what the
//! virtual cutter cut over both runs is the uninterrupted job's drawing, no segment missing; the
//! journal refuses another file or profile and never opens a path it names. XON/XOFF over a
//! real pseudo-terminal, the virtual cutter on its far side.

use std::collections::BTreeSet;
use std::path::Path;

use crate::common::{s, stderr, stencil, tmp};

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A job of `n` cuts (a PU and a PD of three points each) on the generic cutter's area.
fn job(n: usize) -> String {
    let mut s = String::from("IN;\nSP1;\nVS20;\nFS80;\n");
    for i in 0..n {
        let (x, y) = (400 + (i % 100) as i64 * 60, 400 + (i / 100) as i64 * 60);
        s.push_str(&format!(
            "PU{x},{y};\nPD{},{},{},{y},{x},{y};\n",
            x + 20,
            y + 30,
            x + 40
        ));
    }
    s.push_str("PU0,0;\n");
    s
}

/// Every tool-down move an HP-GL record makes, in plotter units (read here, not by our parser).
pub(crate) fn cut_segments(text: &str) -> Vec<([i64; 2], [i64; 2])> {
    let mut at = [0i64, 0i64];
    let mut out = Vec::new();
    for ins in text.split(';') {
        let ins = ins.trim();
        if ins.len() < 2 {
            continue;
        }
        let (m, params) = ins.split_at(2);
        let nums: Vec<i64> = params
            .split(',')
            .filter(|t| !t.trim().is_empty())
            .map(|t| t.trim().parse().unwrap())
            .collect();
        match m {
            "PU" | "PD" => {
                let down = m == "PD";
                for q in nums.chunks(2) {
                    let to = [q[0], q[1]];
                    if down && to != at {
                        out.push((at, to));
                    }
                    at = to;
                }
            }
            _ => {}
        }
    }
    out
}

fn send(plt: &Path, args: &[&str]) -> (bool, String, String) {
    let mut all = vec!["send", s(plt), "--dry-run"];
    all.extend(args);
    let o = stencil(&all);
    (o.status.success(), stdout(&o), stderr(&o))
}

fn journal(plt: &Path) -> serde_json::Value {
    let j = stencil_grbl::journal_path(plt);
    serde_json::from_str(&std::fs::read_to_string(&j).unwrap()).unwrap()
}

#[test]
fn a_stopped_plotter_run_leaves_a_journal_and_recover_finishes_the_drawing() {
    let dir = tmp();
    let plt = dir.path().join("job.plt");
    let text = job(1500);
    std::fs::write(&plt, &text).unwrap();
    let rec = |name: &str| dir.path().join(name);
    let (ok, out, err) = send(
        &plt,
        &[
            "--machine",
            "vinyl-hpgl",
            "--dry-run-record",
            s(&rec("whole.rec")),
        ],
    );
    assert!(ok, "{out}{err}");
    let whole: BTreeSet<_> = cut_segments(&std::fs::read_to_string(rec("whole.rec")).unwrap())
        .into_iter()
        .collect();
    assert_eq!(whole.len(), 1500 * 3);
    // A finished run leaves no journal.
    assert!(!stencil_grbl::journal_path(&plt).exists());
    // No journal: --recover says so and sends nothing.
    let (ok, out, err) = send(&plt, &["--recover"]);
    assert!(
        !ok && err.contains("no journal") && !out.contains("sent "),
        "{out}{err}"
    );

    for (fault, says) in [
        ("close@1700", "the port went away"),
        ("power-loss@1700", "lost power"),
    ] {
        let first = rec("first.rec");
        let (ok, out, err) = send(
            &plt,
            &[
                "--machine",
                "vinyl-hpgl",
                "--dry-run-fault",
                fault,
                "--dry-run-record",
                s(&first),
            ],
        );
        assert!(!ok, "{fault}: {out}{err}");
        assert!(
            err.contains(says) && err.contains("--recover"),
            "{fault}: {err}"
        );
        let j = journal(&plt);
        assert_eq!(j["state"], "stopped", "{j}");
        assert_eq!(j["plotter"], "vinyl-hpgl");
        let resume = j["resume_from"].as_u64().unwrap() as usize;
        // Instruction 1700 is on line 1700: the resume is before it, by at most the buffer.
        assert!(
            resume < 1700 && resume > 1400,
            "{fault}: resume at {resume}"
        );
        assert!(err.contains(&format!("--from-line {resume}")), "{err}");
        let cut_first: BTreeSet<_> = cut_segments(&std::fs::read_to_string(&first).unwrap())
            .into_iter()
            .collect();
        assert!(
            cut_first.len() < whole.len() && cut_first.is_subset(&whole),
            "{fault}"
        );

        let second = rec("second.rec");
        let (ok, out, err) = send(&plt, &["--recover", "--dry-run-record", s(&second)]);
        assert!(ok, "{fault}: {out}{err}");
        assert!(
            out.contains(&format!("resuming from line {resume}"))
                && out.contains("known cut")
                && out.contains("stopped: "),
            "{fault}: {out}"
        );
        assert!(out.contains("tool up at the end"), "{out}");
        let second_text = std::fs::read_to_string(&second).unwrap();
        // Set up again, tool up, travel to where the resumed line starts, then on.
        assert!(
            second_text.starts_with("IN;SP1;VS20;FS80;PU"),
            "{second_text:.80}"
        );
        let cut_second: BTreeSet<_> = cut_segments(&second_text).into_iter().collect();
        let both: BTreeSet<_> = cut_first.union(&cut_second).copied().collect();
        let missing: Vec<_> = whole.difference(&both).take(5).collect();
        assert!(
            missing.is_empty(),
            "{fault}: segments never cut, e.g. {missing:?}"
        );
        assert_eq!(
            both, whole,
            "{fault}: the two runs' drawing is not the job's"
        );
        // Cut twice: only what the buffer may have held (1024 bytes: under 50 cuts here).
        let twice = cut_first.intersection(&cut_second).count();
        assert!(twice < 3 * 50, "{fault}: {twice} segments cut twice");
        assert!(!stencil_grbl::journal_path(&plt).exists());
    }
}

#[test]
fn plotter_recover_refuses_another_file_or_profile_and_opens_no_path_the_journal_names() {
    let dir = tmp();
    let plt = dir.path().join("job.plt");
    let text = job(400);
    std::fs::write(&plt, &text).unwrap();
    let (ok, ..) = send(
        &plt,
        &["--machine", "vinyl-hpgl", "--dry-run-fault", "close@500"],
    );
    assert!(!ok);
    let jpath = stencil_grbl::journal_path(&plt);
    let original = std::fs::read_to_string(&jpath).unwrap();
    let edit = |key: &str, value: &str| {
        let mut j: serde_json::Value = serde_json::from_str(&original).unwrap();
        j[key] = value.into();
        std::fs::write(&jpath, j.to_string()).unwrap();
    };
    for bad in ["/etc/passwd", "big.toml", "..\\evil", "x\u{1b}[2Jy"] {
        edit("plotter", bad);
        let (ok, out, err) = send(&plt, &["--recover"]);
        assert!(!ok, "{bad}: {out}{err}");
        assert!(
            err.contains("not a profile name") && err.contains("nothing was sent"),
            "{bad}: {err}"
        );
        assert!(
            !err.contains('\u{1b}') && !out.contains("virtual cutter"),
            "{out}{err:?}"
        );
    }
    // Another shipped plotter named in the journal: not the content the run used.
    edit("plotter", "roland-camm");
    let (ok, out, err) = send(&plt, &["--recover"]);
    assert!(
        !ok && err.contains("other settings") && err.contains("nothing was sent"),
        "{out}{err}"
    );
    // Another plotter named on the command line.
    std::fs::write(&jpath, &original).unwrap();
    let (ok, out, err) = send(&plt, &["--recover", "--machine", "roland-camm"]);
    assert!(
        !ok && err.contains("vinyl-hpgl") && err.contains("roland-camm"),
        "{out}{err}"
    );
    assert!(!out.contains("virtual cutter"), "{out}");
    // A G-code run's journal is not a plotter job's.
    let mut j: serde_json::Value = serde_json::from_str(&original).unwrap();
    j["format"] = "stencil-send-journal/1".into();
    std::fs::write(&jpath, j.to_string()).unwrap();
    let (ok, _, err) = send(&plt, &["--recover"]);
    assert!(!ok && err.contains("not a stencil send journal"), "{err}");
    // The file changed since the run: its line numbers are not the journal's.
    std::fs::write(&jpath, &original).unwrap();
    std::fs::write(&plt, format!("{text}PU10,10;\n")).unwrap();
    let (ok, out, err) = send(&plt, &["--recover"]);
    assert!(
        !ok && err.contains("different") && !out.contains("virtual cutter"),
        "{out}{err}"
    );
    // A run that did not end (the sender killed): said so, and resumed from its record.
    std::fs::write(&plt, &text).unwrap();
    let mut j: serde_json::Value = serde_json::from_str(&original).unwrap();
    j["state"] = "running".into();
    std::fs::write(&jpath, j.to_string()).unwrap();
    let (ok, out, err) = send(&plt, &["--recover"]);
    assert!(ok && out.contains("did not end"), "{out}{err}");
    // An abort leaves the journal too, with the line it printed.
    let (ok, _, err) = send(
        &plt,
        &["--machine", "vinyl-hpgl", "--dry-run-abort-at", "300"],
    );
    assert!(!ok, "{err}");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&jpath).unwrap()).unwrap();
    let line = j["resume_from"].as_u64().unwrap();
    assert!(err.contains(&format!("--from-line {line} ")), "{err}");
    assert!(j["stop_reason"].as_str().unwrap().contains("abort"), "{j}");
    // The run's own file and profile: the recovery goes ahead.
    let (ok, out, err) = send(&plt, &["--recover", "--machine", "vinyl-hpgl"]);
    assert!(
        ok && out.contains(&format!("resuming from line {line}")),
        "{out}{err}"
    );
    assert!(!jpath.exists());
}

/// Item 2: XON/XOFF over a real terminal line. `send --port` opens the slave side of a
/// pseudo-terminal as it would a plotter's serial port (the system's driver does the flow
/// control: IXON); the test plays the plotter on the master side with the virtual cutter, which
/// says XOFF when its buffer is nearly full and XON when it has room. The master runs in packet
/// mode, so the kernel reports when the sender's output is stopped; the XON is held past the
/// sender's 200 ms write timeout, and once the line has been quiet no byte may come until it.
/// A pseudo-terminal has no baud rate and buffers about 64 KiB in the kernel: what the sender
/// wrote before the stop took hold still arrives, and is fed to the cutter as it has room (so
/// an overrun cannot be judged here: the virtual line's tests judge that). RTS/CTS cannot be
/// tested on one: Linux pseudo-terminals have no modem lines (TIOCMGET fails, CRTSCTS does
/// nothing), which the test checks too.
/// Packet mode's first byte (Linux `<asm-generic/ioctls.h>`; not in the libc crate): data
/// follows, or the slave's output was stopped by its flow control.
#[cfg(target_os = "linux")]
const PKT_DATA: u8 = 0;
#[cfg(target_os = "linux")]
const PKT_STOP: u8 = 4;

#[cfg(target_os = "linux")]
#[test]
fn xon_xoff_over_a_pseudo_terminal_stops_and_restarts_the_sender() {
    use std::collections::VecDeque;
    use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};

    let dir = tmp();
    let plt = dir.path().join("job.plt");
    // Larger than what a pseudo-terminal buffers in the kernel (about 64 KiB), so the sender
    // must be stopped more than once.
    let text = job(2500);
    assert!(text.len() > 65536);
    std::fs::write(&plt, &text).unwrap();
    let (mut m, mut sl) = (-1, -1);
    let mut name = [0 as libc::c_char; 128];
    // SAFETY: openpty writes two descriptors and a NUL-terminated name of at most 128 bytes.
    let r = unsafe {
        libc::openpty(
            &mut m,
            &mut sl,
            name.as_mut_ptr(),
            std::ptr::null(),
            std::ptr::null(),
        )
    };
    assert_eq!(r, 0, "openpty: {}", std::io::Error::last_os_error());
    // SAFETY: both descriptors were just opened by openpty and are owned here alone.
    let (master, slave) = unsafe { (OwnedFd::from_raw_fd(m), OwnedFd::from_raw_fd(sl)) };
    // SAFETY: openpty wrote a NUL-terminated string.
    let path = unsafe { std::ffi::CStr::from_ptr(name.as_ptr()) }
        .to_str()
        .unwrap()
        .to_string();
    // No modem lines on a pseudo-terminal: RTS/CTS has nothing to act on.
    let mut bits: libc::c_int = 0;
    // SAFETY: TIOCMGET writes one c_int.
    let modem = unsafe { libc::ioctl(slave.as_raw_fd(), libc::TIOCMGET, &mut bits) };
    assert_eq!(
        modem, -1,
        "this kernel's pseudo-terminals have modem lines: test RTS/CTS too"
    );
    let one: libc::c_int = 1;
    // SAFETY: TIOCPKT reads one c_int.
    assert_eq!(
        unsafe { libc::ioctl(master.as_raw_fd(), libc::TIOCPKT, &one) },
        0
    );

    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_stencil"))
        .args(["send", s(&plt), "--machine", "vinyl-hpgl", "--port", &path])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let plotter = stencil_hpgl::profile::load("vinyl-hpgl").unwrap();
    let mut cutter = stencil_hpgl::cutter::Cutter::new(&plotter, 0.0);
    cutter.log = Some(Vec::new());
    let mut backlog: VecDeque<u8> = VecDeque::new();
    // XOFF written; the kernel said the sender is stopped; quiet polls since.
    let (mut xoff, mut stopped, mut quiet) = (false, false, 0);
    let (mut stops_seen, mut while_stopped, mut in_flight) = (0, 0usize, 0usize);
    let mut held: Vec<u8> = Vec::new();
    let mut buf = [0u8; 4096];
    let mut status = None;
    for _ in 0..200_000 {
        let mut pfd = libc::pollfd {
            fd: master.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        };
        // Idle, or an XON held back while the stop holds: wait for bytes (none may come).
        let wait = if (backlog.is_empty() && cutter.idle()) || (stopped && !held.is_empty()) {
            20
        } else {
            0
        };
        // SAFETY: one pollfd.
        let ready = unsafe { libc::poll(&mut pfd, 1, wait) };
        if ready > 0 && pfd.revents & libc::POLLIN != 0 {
            // SAFETY: reads into a buffer of its length.
            let n = unsafe { libc::read(master.as_raw_fd(), buf.as_mut_ptr().cast(), buf.len()) };
            if n > 0 {
                let n = n as usize;
                if buf[0] == PKT_DATA {
                    // Written before the stop took hold, still on its way: only until the
                    // line has been quiet; after that nothing may come until the XON.
                    if stopped && quiet >= 2 {
                        while_stopped += n - 1;
                    } else if stopped {
                        in_flight = in_flight.max(n - 1);
                    }
                    backlog.extend(&buf[1..n]);
                    quiet = 0;
                } else if buf[0] & PKT_STOP != 0 {
                    stopped = true;
                    stops_seen += 1;
                }
            }
        } else if stopped && wait > 0 {
            // A poll that waited 20 ms for nothing.
            quiet += 1;
        }
        // The plotter takes in what it has room for, and cuts one instruction.
        let take = backlog.len().min(cutter.free());
        let bytes: Vec<u8> = backlog.drain(..take).collect();
        cutter.receive(&bytes).unwrap();
        cutter.step().unwrap();
        held.extend(cutter.take_output());
        // XOFF at once; an XON only once the stop has held for a few quiet polls.
        while let Some(&b) = held.first() {
            let xon = b == stencil_hpgl::cutter::XON;
            // Held past the sender's 200 ms write timeout, which it must ride out.
            if xon && xoff && !(stopped && quiet >= 12) {
                break;
            }
            // SAFETY: writes one byte.
            assert_eq!(
                unsafe { libc::write(master.as_raw_fd(), [b].as_ptr().cast(), 1) },
                1
            );
            held.remove(0);
            xoff = !xon;
            if xon {
                stopped = false;
            }
        }
        if status.is_none() {
            status = child.try_wait().unwrap();
        }
        if status.is_some() && backlog.is_empty() && ready == 0 {
            break;
        }
    }
    cutter.finish().unwrap();
    let out = child.wait_with_output().unwrap();
    let (so, se) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{so}{se}");
    assert!(so.contains("xon-xoff flow control"), "{so}");
    drop(slave);
    // The kernel stopped the sender on XOFF (it set IXON), and nothing came while stopped.
    assert!(
        stops_seen > 1 && cutter.stops > 1,
        "never stopped: {stops_seen}"
    );
    assert_eq!(
        while_stopped, 0,
        "bytes arrived while the sender was stopped"
    );
    eprintln!(
        "pty: the sender was stopped {stops_seen} times; at most {in_flight} bytes came after a \
         stop, none once the line was quiet"
    );
    // Every instruction arrived once, in order: the cut is the file's.
    let total = text.lines().count();
    assert_eq!(cutter.executed, total);
    let log = String::from_utf8(cutter.log.take().unwrap()).unwrap();
    assert_eq!(cut_segments(&log), cut_segments(&text));
    assert!(!cutter.down);
}
