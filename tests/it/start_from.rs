//! Issue 26 item 4, where the job goes: `--start-from machine|work-zero|current` on send and
//! frame (estimate with `--head-at`), the bed check on the controller's real work offset, the
//! placement kept in the journal and put back by a recovery after a stop (whose reset clears
//! G92), and dry runs started from a person's saved `$$`/`$#` dump. Everything runs against the
//! virtual Grbl and looks at where its beam went, in machine coordinates.

use std::path::Path;

use crate::common::{stderr, stencil, tmp};
use stencil_grbl::{
    send, ControllerState, Fault, FaultKind, MachineError, Placement, Program, Quiet, Recovery,
    StartFrom, StreamConfig, VirtualConfig, VirtualGrbl,
};

/// A 40 x 20 mm laser job with an arc, drawn from its own X0 Y0 (as `stencil make` places a
/// job with the default --offset 0,0): cuts X 0..40, Y 0..20.
const JOB: &str = "G21 G90\nM4 S0 F1000\nG0 X0 Y0\nG1 X40 S500\nG1 Y20\nG2 X0 Y20 I-20 J0\n\
                   G1 Y0\nM5\nG0 X0 Y0\n";

/// What a person saves from their controller: `$$` (here only a few lines of it), `$#`, `$G`
/// and a status report.
fn dump(homing: u8, laser: u8, g54: [f64; 2], head: [f64; 2]) -> String {
    format!(
        "$$\n$11=0.010\n$12=0.002\n$22={homing}\n$30=1000\n$31=0\n$32={laser}\n$110=6000\n\
         $111=6000\n$120=1000\n$121=1000\n$130=400\n$131=400\nok\n$#\n[G54:{:.3},{:.3},0.000]\n\
         [G55:0.000,0.000,0.000]\n[G56:0.000,0.000,0.000]\n[G57:0.000,0.000,0.000]\n\
         [G58:0.000,0.000,0.000]\n[G59:0.000,0.000,0.000]\n[G28:0.000,0.000,0.000]\n\
         [G30:0.000,0.000,0.000]\n[G92:0.000,0.000,0.000]\n[TLO:0.000]\n\
         [PRB:0.000,0.000,0.000:0]\nok\n[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]\nok\n\
         <Idle|MPos:{:.3},{:.3},0.000|FS:0,0>\n",
        g54[0], g54[1], head[0], head[1]
    )
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

/// The "beam cut within machine X a..b Y c..d" line of a dry run, as numbers.
fn cut_box(out: &str) -> [f64; 4] {
    let l = out
        .lines()
        .find_map(|l| l.strip_prefix("virtual Grbl: the beam cut within machine "))
        .unwrap_or_else(|| panic!("no cut box in: {out}"));
    let n: Vec<f64> = l
        .split_whitespace()
        .filter(|t| t.contains(".."))
        .flat_map(|t| t.split("..").map(|v| v.parse::<f64>().unwrap()))
        .collect();
    [n[0], n[1], n[2], n[3]]
}

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn current_position_puts_the_job_where_the_head_stands() {
    let d = tmp();
    let job = write(d.path(), "j.gcode", JOB);
    let st = write(
        d.path(),
        "state.txt",
        &dump(0, 1, [0.0, 0.0], [100.0, 50.0]),
    );
    let o = stencil(&[
        "send",
        &job,
        "--dry-run",
        "--controller-state",
        &st,
        "--start-from",
        "current",
    ]);
    let out = stdout(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        out.contains("where the head stands, machine X100 Y50"),
        "{out}"
    );
    assert_eq!(cut_box(&out), [100.0, 140.0, 50.0, 70.0], "{out}");
    // The estimate has no controller: the head's place is given on the command line, and the
    // bed check follows it (X 390 + 40 leaves a 400 mm bed).
    let o = stencil(&[
        "estimate",
        &job,
        "--start-from",
        "current",
        "--head-at",
        "100,50",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = stencil(&[
        "estimate",
        &job,
        "--start-from",
        "current",
        "--head-at",
        "390,10",
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("job reaches X 430.0 mm at line 4"),
        "{}",
        stderr(&o)
    );
    let o = stencil(&["estimate", &job, "--start-from", "current"]);
    assert!(
        !o.status.success() && stderr(&o).contains("--head-at"),
        "{}",
        stderr(&o)
    );
    // Frame traces the same place: the job's 0..40 at the head's 100..140.
    let o = stencil(&[
        "frame",
        &job,
        "--dry-run",
        "--controller-state",
        &st,
        "--start-from",
        "current",
    ]);
    let all = format!("{}{}", stdout(&o), stderr(&o));
    assert!(o.status.success(), "{all}");
    assert!(
        all.contains("machine X 100.00..140.00 Y 50.00..70.00"),
        "{all}"
    );
}

#[test]
fn the_bed_check_uses_the_controllers_work_offset() {
    let d = tmp();
    let job = write(d.path(), "j.gcode", JOB);
    // G54 at X380: the job's X 0..40 lands at 380..420 on a 400 mm bed.
    let st = write(
        d.path(),
        "state.txt",
        &dump(0, 1, [380.0, 10.0], [0.0, 0.0]),
    );
    for cmd in ["send", "frame"] {
        let o = stencil(&[cmd, &job, "--dry-run", "--controller-state", &st]);
        let err = format!("{}{}", stdout(&o), stderr(&o));
        assert!(!o.status.success(), "{cmd}: accepted");
        assert!(
            err.contains("X 420.0 mm")
                && err.contains("work zero, G54")
                && err.contains("X380 Y10"),
            "{cmd}: {err}"
        );
        assert!(!stdout(&o).contains("sent "), "{cmd}");
    }
    // The same controller, the job from machine coordinates: on the bed, cut at 0..40 (its
    // G54 cancelled for the run by G92).
    let o = stencil(&[
        "send",
        &job,
        "--dry-run",
        "--controller-state",
        &st,
        "--start-from",
        "machine",
    ]);
    let out = stdout(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(cut_box(&out), [0.0, 40.0, 0.0, 20.0], "{out}");
}

#[test]
fn a_saved_dump_drives_the_dry_run() {
    let d = tmp();
    let job = write(d.path(), "j.gcode", JOB);
    // No homing ($22=0): the default is the work zero, G54 at 20,30, said before it starts.
    let st = write(d.path(), "state.txt", &dump(0, 1, [20.0, 30.0], [5.0, 5.0]));
    let o = stencil(&["send", &job, "--dry-run", "--controller-state", &st]);
    let out = stdout(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        out.contains(
            "the job's X0 Y0 is the controller's work zero, G54 as stored, at machine X20 Y30"
        ),
        "{out}"
    );
    assert_eq!(cut_box(&out), [20.0, 60.0, 30.0, 50.0], "{out}");
    // Its $$ is the simulated Grbl's: laser mode off ($32=0) there is refused as on a machine.
    let off = write(d.path(), "off.txt", &dump(0, 0, [20.0, 30.0], [5.0, 5.0]));
    let o = stencil(&["send", &job, "--dry-run", "--controller-state", &off]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("$32"), "{}", stderr(&o));
    // A line Grbl does not print is named with its line number.
    let bad = write(d.path(), "bad.txt", "$22=0\n[G54:1,2,3]\nG54 is at 1,2\n");
    let o = stencil(&["send", &job, "--dry-run", "--controller-state", &bad]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("bad.txt: line 3: `G54 is at 1,2`"),
        "{}",
        stderr(&o)
    );
    // A machine that homes ($22=1) starts from machine coordinates by default.
    let homes = write(d.path(), "homes.txt", &dump(1, 1, [20.0, 30.0], [0.0, 0.0]));
    let o = stencil(&[
        "send",
        &job,
        "--dry-run",
        "--controller-state",
        &homes,
        "--unlock",
    ]);
    let out = stdout(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.contains("the machine's origin"), "{out}");
    assert_eq!(cut_box(&out), [0.0, 40.0, 0.0, 20.0], "{out}");
}

/// On one virtual Grbl: a run placed at the head (100, 50) stops at an error (the stop's soft
/// reset clears G92, so the work zero falls back to G54's 0, 0); the resume with the placement
/// the journal kept puts it back, and the rest of the job is cut at 100.. again. Without it the
/// rest would be cut at 0..
#[test]
fn a_recovery_after_a_stop_restores_the_placement() {
    let st =
        ControllerState::parse_dump(Path::new("d"), &dump(0, 1, [0.0; 2], [100.0, 50.0])).unwrap();
    let p = Placement::new(StartFrom::Current, &st);
    let job = Program::parse_from("j.gcode", JOB, p.modal).unwrap();
    for restore in [true, false] {
        let vcfg = VirtualConfig {
            homing: false,
            start: Some(st.clone()),
            faults: vec![Fault {
                at_job_line: 6,
                kind: FaultKind::Error(33),
            }],
            ..VirtualConfig::default()
        };
        let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
        let cfg = StreamConfig {
            place_zero: Some(p.zero),
            ..StreamConfig::default()
        };
        let err = send(&mut port, &job, &cfg, None, &mut Quiet).unwrap_err();
        assert!(matches!(err, MachineError::Rejected { .. }), "{err}");
        let from = err.halt().unwrap().resume_from;
        let before = vg.record().moves.len();
        assert!(vg.record().wco[..2] == [0.0, 0.0], "the reset keeps G92");
        let cfg = StreamConfig {
            from_line: from,
            place_zero: restore.then_some(p.zero),
            recovery: Some(Recovery {
                confirmed: true,
                ..Recovery::default()
            }),
            ..StreamConfig::default()
        };
        send(&mut port, &job, &cfg, None, &mut Quiet).unwrap();
        let r = vg.stop();
        let cut: Vec<_> = r.moves[before..].iter().filter(|m| m.beam).collect();
        assert!(!cut.is_empty());
        let min_x = cut
            .iter()
            .map(|m| m.to[0].min(m.from[0]))
            .fold(f64::MAX, f64::min);
        if restore {
            assert!(min_x >= 100.0 - 1e-6, "resumed cut at X {min_x}");
        } else {
            assert!(
                min_x < 50.0,
                "without the placement the cut falls to X {min_x}"
            );
        }
    }
}

/// The same through the command line: the journal of a stopped run keeps where its zero was,
/// and `--recover` says it puts it back.
#[test]
fn the_journal_keeps_the_placement_for_recover() {
    let d = tmp();
    let job = write(d.path(), "j.gcode", JOB);
    let st = write(
        d.path(),
        "state.txt",
        &dump(0, 1, [0.0, 0.0], [100.0, 50.0]),
    );
    let o = stencil(&[
        "send",
        &job,
        "--dry-run",
        "--controller-state",
        &st,
        "--start-from",
        "current",
        "--dry-run-fault",
        "error:33@6",
    ]);
    assert!(!o.status.success());
    let journal = std::fs::read_to_string(format!("{job}.journal")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&journal).unwrap();
    assert_eq!(v["placement"]["start_from"], "current", "{journal}");
    assert_eq!(v["placement"]["zero_mm"], serde_json::json!([100.0, 50.0]));
    // A fresh board (G92 gone) with the head back where the stop left it, its coordinates
    // confirmed: the zero goes back to 100, 50 and the rest is cut there.
    let again = write(
        d.path(),
        "again.txt",
        &dump(0, 1, [0.0, 0.0], [140.0, 70.0]),
    );
    let o = stencil(&[
        "send",
        &job,
        "--dry-run",
        "--controller-state",
        &again,
        "--recover",
        "--position-confirmed",
    ]);
    let out = stdout(&o);
    assert!(o.status.success(), "{}{out}", stderr(&o));
    assert!(
        out.contains("where the head stands, machine X100 Y50"),
        "{out}"
    );
    let b = cut_box(&out);
    assert!(b[0] >= 100.0 && b[2] >= 50.0, "{out}");
}

/// `simulate` reads a job as `send` places it (issue 26): with the work zero 300 mm right of
/// where the head stands, the picture shows the travel from the head to the job, and the cut at
/// its far end; from machine zero the cut spans the picture.
#[test]
fn simulate_places_the_job_as_send_does() {
    let d = tmp();
    let job = write(d.path(), "job.gcode", JOB);
    let state = write(d.path(), "state.txt", &dump(0, 1, [300.0, 0.0], [0.0, 0.0]));
    let red_columns = |name: &str, args: &[&str]| -> (f64, f64) {
        let png = d.path().join(name);
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_stencil"))
            .arg("simulate")
            .arg(&job)
            .arg("-o")
            .arg(&png)
            .args(args)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}{}", stdout(&out), stderr(&out));
        let img = image::open(&png).unwrap().to_rgb8();
        let cols: Vec<u32> = img
            .enumerate_pixels()
            .filter(|(_, _, p)| p.0 == stencil_gcode::simulate::CUT_RGB)
            .map(|(x, _, _)| x)
            .collect();
        let w = f64::from(img.width());
        let lo = f64::from(*cols.iter().min().expect("something cut"));
        let hi = f64::from(*cols.iter().max().unwrap());
        (lo / w, hi / w)
    };
    let (lo, hi) = red_columns("machine.png", &["--start-from", "machine"]);
    assert!(
        lo < 0.05 && hi > 0.95,
        "from machine zero: cut over {lo}..{hi}"
    );
    let (lo, hi) = red_columns(
        "work.png",
        &["--start-from", "work-zero", "--controller-state", &state],
    );
    // Travel 0..300 mm, cut 300..340 mm: the cut is the last eighth of the picture.
    assert!(
        lo > 0.8 && hi > 0.95,
        "from the work zero: cut over {lo}..{hi}"
    );
}
