//! `stencil send` at the machine (issue 14): a resume that lifts before it travels, the laser-mode
//! check, stall detection, overrides, air off in every stop path, and job recovery from the
//! journal. Everything streams through the virtual Grbl on a pseudo-terminal.

use std::time::Duration;

use geo::{Coord, LineString, MultiPolygon, Polygon, Rect};
use stencil::machine::stream::{send, Job, MachineError, Quiet, ResumeLift, StreamConfig};
use stencil::machine::virtual_grbl::{Fault, FaultKind, PlannedMove, Record};
use stencil::machine::{VirtualConfig, VirtualGrbl};
use stencil::plan::{gcode_for, CutSettings, PlanConfig};
use stencil::profile::machine::{self as machine_profile, Machine, PenLift, Tool};
use stencil::vector::CutGeometry;

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
    let geom = CutGeometry::from_cuts(120.0, 90.0, outline, MultiPolygon(cuts));
    let settings = CutSettings {
        power_pct: 100.0,
        speed_mm_min: 1200.0,
        passes: 1,
        blade_offset_mm: if matches!(machine.tool, Tool::Knife { .. }) {
            0.25
        } else {
            0.0
        },
    };
    gcode_for(&geom, machine, &PlanConfig::new(settings), &[])
        .unwrap()
        .0
}

/// What `stencil send` tells the streamer about the tool (see `cli/send.rs`).
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
fn tool_down_at(job: &Job, machine: &Machine, l: usize) -> bool {
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
    job: &Job,
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
        let job = Job::parse(&format!("{name}.gcode"), &text).unwrap();
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
        // Stopped by an error with the tool down in the first square, resumed in the last one:
        // the tool (a knife left at cutting depth) must come up before the long travel.
        let k = job.lines.iter().position(|l| l.number == down[3]).unwrap() + 1;
        let vcfg = VirtualConfig {
            faults: vec![Fault {
                at_job_line: k,
                kind: FaultKind::Error(20),
            }],
            ..VirtualConfig::default()
        };
        let (vg, mut port) = VirtualGrbl::spawn(vcfg).unwrap();
        let err = send(&mut port, &job, &cfg(), None, &mut Quiet).unwrap_err();
        assert!(matches!(err, MachineError::Rejected { .. }), "{err}");
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
