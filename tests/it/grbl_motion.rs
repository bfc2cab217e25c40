//! One model of the job (issue 26): work offsets, arcs and every motion line are read by one
//! interpreter in machine coordinates, so the bed check, `frame`, `estimate` and the virtual Grbl
//! see the same job the machine runs.

use std::io::Write;

use stencil_gcode::estimate_with;
use stencil_gcode::interpret::{extent, interpret, interpret_program, CutRule};
use stencil_gcode::machine;
use stencil_grbl::{cut_extent, VirtualConfig, VirtualGrbl};

use crate::common::read_until;

fn last_to(p: &str) -> [f64; 3] {
    interpret(p).unwrap().last().unwrap().to
}

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    (0..3).all(|k| (a[k] - b[k]).abs() < 1e-9)
}

#[test]
fn offsets_place_the_job_in_machine_coordinates() {
    // G10 L2: G54's origin at (380, 380); the job's X10..50 runs at X390..430.
    let p = "G10 L2 P1 X380 Y380\nM4 S500\nG1 X10 Y10 F1000\nG1 X50\nM5\n";
    let e = extent(&interpret(p).unwrap()).unwrap();
    assert_eq!(e.max, [430.0, 390.0]);
    assert_eq!(e.max_line[0], 4);
    // L20: the current position becomes the given work coordinate.
    assert!(close(
        last_to("G0 X100 Y50\nG10 L20 P1 X0 Y0\nG0 X10"),
        [110.0, 50.0, 0.0]
    ));
    // G92 shifts, G92.1 clears.
    assert!(close(last_to("G0 X100\nG92 X0\nG0 X10"), [110.0, 0.0, 0.0]));
    assert!(close(
        last_to("G0 X100\nG92 X0\nG92.1\nG0 X10"),
        [10.0, 0.0, 0.0]
    ));
    // G55 selects P2's origin; a program end goes back to G54 (G92 is kept).
    assert!(close(last_to("G10 L2 P2 X50\nG55 G0 X0"), [50.0, 0.0, 0.0]));
    assert!(close(
        last_to("G10 L2 P2 X50\nG55\nM2\nG0 X0"),
        [0.0, 0.0, 0.0]
    ));
    // G53: machine coordinates for one line, whatever the offsets and distance mode.
    assert!(close(
        last_to("G10 L2 P1 X380\nG91\nG53 G0 X5"),
        [5.0, 0.0, 0.0]
    ));
    // G43.1: the tool length offset shifts Z targets.
    assert!(close(last_to("G43.1 Z2\nG0 Z1"), [0.0, 0.0, 3.0]));
    // G28: via the intermediate point, then the named axes to the stored position (G28.1);
    // without axis words, all of them.
    let m = interpret("G0 X30 Y40\nG28.1\nG0 X0 Y0\nG28 X5\nG28").unwrap();
    assert!(close(m[2].to, [5.0, 0.0, 0.0]) && close(m[3].to, [30.0, 0.0, 0.0]));
    assert!(close(m[4].to, [30.0, 40.0, 0.0]));
    assert!(m[2].rapid && m[3].rapid && m[4].rapid);
    // Inches and incremental.
    assert!(close(last_to("G20 G91\nG0 X1\nG0 X1"), [50.8, 0.0, 0.0]));
}

#[test]
fn arcs_are_followed_to_their_true_extent() {
    // Clockwise half circle from (10, 315) over the top about (200, 315): it bulges to Y505.
    let p = "G0 X10 Y315\nM3 S100\nG2 X390 Y315 I190 J0 F1000\nM5\n";
    let moves = interpret(p).unwrap();
    let e = extent(&moves).unwrap();
    assert!((e.max[1] - 505.0).abs() < 0.01, "{:?}", e.max);
    assert_eq!((e.max_line[1], e.max[0]), (3, 390.0));
    let diode = machine::load(Some("diode-400")).unwrap();
    let off = diode.check_moves(&moves).unwrap_err().to_string();
    assert!(off.contains("Y 505.0 mm at line 3"), "{off}");
    // frame's box is the arc's, not its end points'.
    let f = cut_extent(&moves).unwrap();
    assert!((f.max[1] - 505.0).abs() < 0.01 && f.min[0] == 10.0 && f.max[0] == 390.0);
    // The planes: in G18 (ZX) an arc sweeps Z and X; in G19 (YZ), Y and Z.
    let zx = interpret("G18 G0 X10\nG2 X-10 I-10 F100").unwrap();
    let top = zx.iter().map(|m| m.to[2]).fold(f64::NEG_INFINITY, f64::max);
    let low = zx.iter().map(|m| m.to[2]).fold(f64::INFINITY, f64::min);
    assert!(top.max(-low) > 9.99 && zx.iter().all(|m| m.to[1] == 0.0));
    let yz = interpret("G19 G0 Y10\nG3 Y-10 J-10 F100").unwrap();
    assert!(yz.iter().all(|m| m.to[0] == 0.0));
    // G91 targets and offsets in inches: a half circle of radius 1 in, over the top.
    let inch = interpret("G20 G91\nG2 X2 I1 F10").unwrap();
    assert!(close(inch.last().unwrap().to, [50.8, 0.0, 0.0]));
    let bulge = inch
        .iter()
        .map(|m| m.to[1])
        .fold(f64::NEG_INFINITY, f64::max);
    assert!((bulge - 25.4).abs() < 0.01, "{bulge}");
}

#[test]
fn the_estimate_follows_arcs_dwells_and_inverse_time() {
    let diode = machine::load(Some("diode-400")).unwrap();
    // A full circle of radius 20 at 600 mm/min: 125.7 mm, 12.6 s and a little to accelerate.
    let circle = interpret("M3 S100\nG0 X20\nG2 X20 I-20 F600\nM5").unwrap();
    let e = estimate_with(&circle, &diode.motion, CutRule::infer(&circle));
    assert!((e.cut_mm - 125.66).abs() < 0.1, "{e:?}");
    assert!(e.cut_s > 12.56 && e.cut_s < 13.5, "{e:?}");
    // G93: F2 is half a minute for the move, whatever its length.
    let inv = interpret("G93 G1 X10 F2").unwrap();
    assert!((inv[0].feed - 20.0).abs() < 1e-9);
    let p = interpret_program("G4 P1.5\nG0 X1\nG4 P0.5\n%\n").unwrap();
    assert_eq!(p.dwell_s, 2.0);
}

#[test]
fn the_virtual_grbl_reports_offsets_and_cuts_arcs_as_grbl() {
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    read_until(&mut port, "for help]\r\n");
    port.write_all(b"G10L2P1X5Y5\nG0X1Y1\n").unwrap();
    read_until(&mut port, "ok\r\nok\r\n");
    port.write_all(b"?").unwrap();
    let s = read_until(&mut port, ">");
    assert!(
        s.contains("MPos:6.000,6.000,0.000") && s.contains("WCO:5.000,5.000,0.000"),
        "{s}"
    );
    port.write_all(b"G10L2P3X-7\nG28.1\n$#\n").unwrap();
    let s = read_until(&mut port, "[PRB");
    assert!(
        s.contains(
            "[G54:5.000,5.000,0.000]\r\n[G55:0.000,0.000,0.000]\r\n[G56:-7.000,0.000,0.000]"
        ),
        "{s}"
    );
    assert!(
        s.contains("[G28:6.000,6.000,0.000]") && s.contains("[G92:0.000,0.000,0.000]"),
        "{s}"
    );
    read_until(&mut port, "ok\r\n");
    port.write_all(b"G92X0Y0\n$G\n?").unwrap();
    let s = read_until(&mut port, ">");
    assert!(s.contains("[GC:G0 G54 G17 G21 G90 G94 M5"), "{s}");
    assert!(s.contains("WCO:6.000,6.000,0.000"), "{s}");
    // A full circle of radius 10 about (16, 6) machine: 157 chords at $12 = 0.002.
    port.write_all(b"G2X0Y0I10F600\n").unwrap();
    read_until(&mut port, "ok\r\n");
    let r = vg.stop();
    let arc: Vec<_> = r.moves.iter().filter(|m| !m.rapid).collect();
    assert_eq!(arc.len(), 157);
    let right = arc
        .iter()
        .map(|m| m.to[0])
        .fold(f64::NEG_INFINITY, f64::max);
    assert!((right - 26.0).abs() < 0.01, "{right}");
    assert_eq!(arc.last().unwrap().to, [6.0, 6.0, 0.0]);
    // The arc is one line, executed once.
    let arc_line = r
        .received
        .iter()
        .position(|l| l.text.starts_with("G2"))
        .unwrap();
    assert_eq!(r.executed.iter().filter(|&&i| i == arc_line).count(), 1);

    // $12 = 0.1: coarser chords, as Grbl cuts them.
    let cfg = VirtualConfig {
        settings: vec![(12, "0.1".into())],
        ..VirtualConfig::default()
    };
    let (vg, mut port) = VirtualGrbl::spawn(cfg).unwrap();
    read_until(&mut port, "for help]\r\n");
    port.write_all(b"G2X0Y0I10F600\n").unwrap();
    read_until(&mut port, "ok\r\n");
    // floor(0.5 · 2π · 10 / sqrt(0.1 · 19.9)) = 22.
    assert_eq!(vg.stop().moves.len(), 22);
}

#[test]
fn the_spindle_runs_at_s_clamped_to_its_settings() {
    // $30 = 1000 (the virtual Grbl's max): S5000 runs, and is reported, at 1000.
    let cfg = VirtualConfig {
        pace: stencil_grbl::Pace::Timed { speedup: 1.0 },
        ..VirtualConfig::default()
    };
    let (vg, mut port) = VirtualGrbl::spawn(cfg).unwrap();
    read_until(&mut port, "for help]\r\n");
    port.write_all(b"M3S5000\nG1X100F600\n").unwrap();
    read_until(&mut port, "ok\r\nok\r\n");
    port.write_all(b"?").unwrap();
    let s = read_until(&mut port, ">");
    assert!(s.contains("|FS:600,1000"), "{s}");
    port.write_all(&[0x18]).unwrap();
    drop(vg);
}
