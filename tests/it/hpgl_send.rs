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
fn cut_segments(text: &str) -> Vec<([i64; 2], [i64; 2])> {
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
    // The run's own file and profile: the recovery goes ahead.
    std::fs::write(&plt, &text).unwrap();
    let (ok, out, err) = send(&plt, &["--recover", "--machine", "vinyl-hpgl"]);
    assert!(ok && out.contains("resuming from line"), "{out}{err}");
}
