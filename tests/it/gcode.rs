//! End-to-end checks of the G-code a user sends to a GRBL 1.1 machine, read back with an independent
//! parser (the `gcode` crate), not with our own interpreter.

use std::path::Path;
use std::process::Command;

use geo::{Coord, LineString, MultiPolygon, Polygon, Rect};
use stencil_gcode::estimate;
use stencil_gcode::interpret::interpret;
use stencil_gcode::machine::Motion;
use stencil_gcode::machine::{self, Machine, PenLift, Tool};
use stencil_gcode::CutLoops;
use stencil_gcode::{gcode_for, CutSettings, GcodeSummary, PlanConfig};

use crate::common::{arc_chords, one_way};

// ---- inputs -----------------------------------------------------------------------------------

fn circle(cx: f64, cy: f64, r: f64, n: usize) -> Polygon<f64> {
    let pts: Vec<(f64, f64)> = (0..=n)
        .map(|i| {
            let a = i as f64 / n as f64 * std::f64::consts::TAU;
            (cx + r * a.cos(), cy + r * a.sin())
        })
        .collect();
    Polygon::new(LineString::from(pts), vec![])
}

fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Polygon<f64> {
    Polygon::new(
        LineString::from(vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)]),
        vec![],
    )
}

fn sheet(w: f64, h: f64, cuts: Vec<Polygon<f64>>) -> CutLoops {
    let outline = Rect::new(Coord { x: 0.0, y: 0.0 }, Coord { x: w, y: h });
    CutLoops::drawn(outline, MultiPolygon(cuts))
}

/// A deterministic pseudo-random stream (no test depends on luck or on the clock).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Circles and squares on a jittered grid, listed in a shuffled order (like regions coming out of
/// a contour tracer in no useful order).
fn scattered(seed: u64, cols: usize, rows: usize) -> CutLoops {
    let mut r = Lcg(seed);
    let cell = 25.0;
    let mut cuts = Vec::new();
    for i in 0..cols {
        for j in 0..rows {
            let cx = cell * (i as f64 + 0.5) + (r.next() - 0.5) * 6.0;
            let cy = cell * (j as f64 + 0.5) + (r.next() - 0.5) * 6.0;
            let rad = 3.0 + r.next() * 5.0;
            if r.next() < 0.5 {
                cuts.push(circle(cx, cy, rad, 24 + (r.next() * 40.0) as usize));
            } else {
                cuts.push(rect(cx - rad, cy - rad, cx + rad, cy + rad));
            }
        }
    }
    // Fisher–Yates shuffle.
    for k in (1..cuts.len()).rev() {
        let m = (r.next() * (k + 1) as f64) as usize;
        cuts.swap(k, m.min(k));
    }
    sheet(cell * cols as f64, cell * rows as f64, cuts)
}

fn settings() -> CutSettings {
    CutSettings {
        power_pct: 60.0,
        speed_mm_min: 1500.0,
        passes: 1,
        blade_offset_mm: 0.0,
        air_assist: false,
    }
}

fn perimeter(p: &Polygon<f64>) -> f64 {
    let ring = |l: &LineString<f64>| {
        l.0.windows(2)
            .map(|w| ((w[1].x - w[0].x).powi(2) + (w[1].y - w[0].y).powi(2)).sqrt())
            .sum::<f64>()
    };
    ring(p.exterior()) + p.interiors().iter().map(ring).sum::<f64>()
}

// ---- reading the output back ------------------------------------------------------------------

#[derive(Default)]
struct ParseProblems(Vec<String>);

impl gcode::Callbacks for ParseProblems {
    fn unknown_content(&mut self, text: &str, span: gcode::Span) {
        self.0
            .push(format!("line {}: unknown '{text}'", span.line + 1));
    }
    fn unexpected_line_number(&mut self, n: f32, span: gcode::Span) {
        self.0
            .push(format!("line {}: line number N{n}", span.line + 1));
    }
    fn argument_without_a_command(&mut self, l: char, v: f32, span: gcode::Span) {
        self.0
            .push(format!("line {}: {l}{v} without a command", span.line + 1));
    }
    fn number_without_a_letter(&mut self, v: &str, span: gcode::Span) {
        self.0.push(format!("line {}: number {v}", span.line + 1));
    }
    fn letter_without_a_number(&mut self, v: &str, span: gcode::Span) {
        self.0.push(format!("line {}: letter {v}", span.line + 1));
    }
}

/// What the program does, as tracked from the independently parsed words.
#[derive(Debug, Default)]
struct Run {
    /// (from, to, rapid, tool_on) per XY or Z move; an arc as its chords.
    moves: Vec<([f64; 3], [f64; 3], bool, bool)>,
    /// Commands in order, as "G0", "M5", ...
    commands: Vec<String>,
    cut_mm: f64,
    travel_mm: f64,
    /// Lines whose first G1 (or G2/G3) came before any F.
    g1_without_f: Option<usize>,
}

/// Parse `text` with the `gcode` crate and simulate the modal state ourselves. `z_up` is the
/// lifted height of a Z tool (the tool counts as on when Z is below it).
fn run(text: &str, machine: &Machine) -> Run {
    let mut problems = ParseProblems::default();
    let mut r = Run::default();
    let mut pos = [0.0f64; 3];
    let mut motion = 0u32;
    let (mut spindle, mut s, mut f_seen) = (false, 0.0f64, false);
    let z_up = match machine.tool {
        Tool::Pen(PenLift::Z(z)) | Tool::Knife { z, .. } => Some(z.up_mm),
        _ => None,
    };
    // gcode 0.6 also hands the first command of a line, without its arguments, to the line before;
    // when it has arguments it comes again, whole, at the same byte offset: keep the last copy.
    let mut codes: Vec<gcode::GCode> = Vec::new();
    for line in gcode::full_parse_with_callbacks(text, &mut problems) {
        for code in line.gcodes() {
            if codes
                .last()
                .is_some_and(|c| c.span().start == code.span().start)
            {
                codes.pop();
            }
            codes.push(code.clone());
        }
    }
    {
        for code in &codes {
            let (mn, major) = (code.mnemonic(), code.major_number());
            r.commands.push(format!("{mn}{major}"));
            if let Some(v) = code.value_for('S') {
                s = v as f64;
            }
            if code.value_for('F').is_some() {
                f_seen = true;
            }
            match (mn, major) {
                (gcode::Mnemonic::Miscellaneous, 3 | 4) => spindle = true,
                (gcode::Mnemonic::Miscellaneous, 5) => spindle = false,
                (gcode::Mnemonic::General, 0..=3) => motion = major,
                (gcode::Mnemonic::General, 21 | 90 | 94) => continue,
                (gcode::Mnemonic::Miscellaneous, _) => continue,
                (m, n) => panic!("unexpected command {m}{n} in the output"),
            }
            let mut to = pos;
            let mut any = false;
            for (a, l) in ['X', 'Y', 'Z'].iter().enumerate() {
                if let Some(v) = code.value_for(*l) {
                    to[a] = v as f64;
                    any = true;
                }
            }
            if !any || mn != gcode::Mnemonic::General {
                continue;
            }
            if motion >= 1 && !f_seen && r.g1_without_f.is_none() {
                r.g1_without_f = Some(code.span().line + 1);
            }
            let tool_on = match z_up {
                Some(up) => to[2] < up - 1e-9 && pos[2] < up - 1e-9,
                None => spindle && s > 0.0,
            };
            if motion >= 2 {
                // An arc: I and J are the centre's offsets from the start (Grbl's XY plane);
                // both ends on one circle (Grbl's error:33 allows 0.005 mm), never a full turn
                // (its ends are apart), followed as chords 0.001 mm from the circle.
                let (i, j) = (
                    code.value_for('I').expect("an arc has I") as f64,
                    code.value_for('J').expect("an arc has J") as f64,
                );
                let c = [pos[0] + i, pos[1] + j];
                let r0 = i.hypot(j);
                let r1 = (to[0] - c[0]).hypot(to[1] - c[1]);
                assert!(
                    (r1 - r0).abs() <= 0.005 || (r1 - r0).abs() <= 0.001 * r0,
                    "line {}: arc ends {r0} and {r1} mm from the centre",
                    code.span().line + 1
                );
                assert!(to[0] != pos[0] || to[1] != pos[1], "a full-circle arc");
                assert!(
                    tool_on,
                    "line {}: an arc with the tool off",
                    code.span().line + 1
                );
                let (sweep, inner) = arc_chords([pos[0], pos[1]], [to[0], to[1]], c, motion == 3);
                r.cut_mm += r0 * sweep.abs();
                let mut at = pos;
                for p in inner.into_iter().map(|[x, y]| [x, y, to[2]]).chain([to]) {
                    r.moves.push((at, p, false, true));
                    at = p;
                }
                pos = to;
                continue;
            }
            let xy = ((to[0] - pos[0]).powi(2) + (to[1] - pos[1]).powi(2)).sqrt();
            if motion == 1 && tool_on {
                r.cut_mm += xy;
            } else {
                r.travel_mm += xy;
            }
            r.moves.push((pos, to, motion == 0, tool_on));
            pos = to;
        }
    }
    assert!(problems.0.is_empty(), "parser complaints: {:?}", problems.0);
    r
}

/// Every rule a Grbl 1.1 user relies on, checked on one program.
fn check_program(text: &str, machine: &Machine) -> Run {
    for (i, l) in text.lines().enumerate() {
        assert!(l.len() < 80, "line {} is {} chars: {l}", i + 1, l.len());
        assert!(!l.contains('('), "line {}: parenthesis comment: {l}", i + 1);
        if l.starts_with(';') {
            continue;
        }
        assert!(!l.contains(';'), "line {}: comment after code: {l}", i + 1);
        assert!(!l.trim().is_empty(), "line {}: empty line", i + 1);
        for word in l.split_whitespace() {
            let (letter, num) = word.split_at(1);
            assert!(
                "GMXYZSFIJ".contains(letter),
                "line {}: word {word} Grbl may not like",
                i + 1
            );
            assert!(
                num.parse::<f64>().is_ok(),
                "line {}: bad number {word}",
                i + 1
            );
            if let Some((_, dec)) = num.split_once('.') {
                assert!(
                    dec.len() <= 3,
                    "line {}: {word} has more than 3 decimals",
                    i + 1
                );
            }
            if letter == "G" {
                assert!(
                    ["0", "1", "2", "3", "21", "90", "94"].contains(&num),
                    "line {}: G{num} (only G0/G1 moves and G2/G3 arcs, no splines)",
                    i + 1
                );
            }
        }
    }
    assert!(text.lines().any(|l| l == "G21 G90 G94"), "G21 G90 header");
    let r = run(text, machine);
    assert_eq!(r.g1_without_f, None, "a G1 came before any F");
    let (bw, bh) = (machine.bed.width_mm, machine.bed.height_mm);
    for (from, to, rapid, on) in &r.moves {
        for p in [from, to] {
            assert!(
                p[0] >= -1e-3 && p[0] <= bw + 1e-3 && p[1] >= -1e-3 && p[1] <= bh + 1e-3,
                "move {from:?} -> {to:?} leaves the {bw} x {bh} bed"
            );
        }
        let moves_xy = (to[0] - from[0]).abs() > 1e-9 || (to[1] - from[1]).abs() > 1e-9;
        assert!(
            !(*rapid && *on && moves_xy),
            "tool on during G0 {from:?} -> {to:?}"
        );
    }
    // The end: the tool switched off with M5 (and air off with M9), the return move, M2.
    let last_m5 = r.commands.iter().rposition(|c| c == "M5").expect("an M5");
    let after: Vec<&str> = r.commands[last_m5 + 1..]
        .iter()
        .map(String::as_str)
        .filter(|c| *c != "M9")
        .collect();
    assert_eq!(
        after,
        vec!["G0", "M2"],
        "after the last M5 only the return and M2"
    );
    assert_eq!(text.lines().last(), Some("M2"), "the program ends with M2");
    let (_, end, rapid, on) = r.moves.last().unwrap();
    assert!(
        *rapid && !on && end[0] == 0.0 && end[1] == 0.0,
        "returns to X0 Y0"
    );
    r
}

fn make(geom: &CutLoops, machine: &Machine, cfg: &PlanConfig) -> (String, GcodeSummary) {
    gcode_for(geom, machine, cfg, &["test".into()]).unwrap()
}

// ---- tests ------------------------------------------------------------------------------------

#[test]
fn laser_output_obeys_grbl_rules_and_cuts_the_perimeter() {
    let m = machine::load(None).unwrap();
    let g = scattered(7, 8, 6);
    let (text, summary) = make(&g, &m, &PlanConfig::new(settings()));
    let r = check_program(&text, &m);
    let perim: f64 = g.cuts.0.iter().map(perimeter).sum();
    assert!(
        (r.cut_mm - perim).abs() / perim < 0.01,
        "cut {} mm vs perimeters {perim} mm",
        r.cut_mm
    );
    // The summary's numbers are the program's, not a separate guess.
    assert!((summary.path.cut_mm - r.cut_mm).abs() / perim < 0.01);
    assert!((summary.path.travel_mm - r.travel_mm).abs() < 0.05 * r.travel_mm + 1.0);
    assert!(
        text.contains("$32=1"),
        "laser mode documented in the header"
    );
    assert!(text.contains("M4 S0"), "dynamic power");
}

/// The cut paths of a run: each run of tool-on XY moves (an arc as its chords), as points.
fn cut_paths(r: &Run) -> Vec<Vec<[f64; 2]>> {
    let mut out: Vec<Vec<[f64; 2]>> = Vec::new();
    let mut open = false;
    for (from, to, rapid, on) in &r.moves {
        let xy = from[0] != to[0] || from[1] != to[1];
        if *on && !rapid && xy {
            if !open {
                out.push(vec![[from[0], from[1]]]);
                open = true;
            }
            out.last_mut().unwrap().push([to[0], to[1]]);
        } else if xy || !on {
            open = false;
        }
    }
    out
}

#[test]
fn arcs_on_every_machine_follow_the_loops_and_leave_the_job_where_it_was() {
    // Circles and squares on every shipped machine (origins on every corner, lasers, pens, a
    // knife), the outline cut: the arcs job, read back independently, cuts the same loops in
    // the same order within the fitting tolerance, and the job's box is the straight job's.
    let g = scattered(11, 4, 3);
    let tol = 0.02;
    for name in machine::builtin_names() {
        let m = machine::load(Some(name)).unwrap();
        let mut cfg = PlanConfig::new(settings());
        cfg.cut_outline = true;
        cfg.offset = [5.0, 5.0];
        let straight = stencil_gcode::plan(&g, &m, &cfg).unwrap();
        let (flat, _) = make(&g, &m, &cfg);
        cfg.arc_tolerance_mm = tol;
        let curved = stencil_gcode::plan(&g, &m, &cfg).unwrap();
        let (text, summary) = make(&g, &m, &cfg);
        for a in 0..2 {
            assert!(
                (curved.min[a] - straight.min[a]).abs() < 1e-9
                    && (curved.max[a] - straight.max[a]).abs() < 1e-9,
                "{name}: the job moved: {:?}..{:?} vs {:?}..{:?}",
                curved.min,
                curved.max,
                straight.min,
                straight.max
            );
        }
        let (rf, ra) = (check_program(&flat, &m), check_program(&text, &m));
        let arcs = text
            .lines()
            .filter(|l| l.starts_with("G2 ") || l.starts_with("G3 "))
            .count();
        if matches!(m.tool, Tool::Knife { .. }) {
            // A drag knife's path is its corners' swivels: straight, as before.
            assert_eq!(arcs, 0, "{name}");
            assert_eq!(text.lines().count(), flat.lines().count(), "{name}");
            continue;
        }
        assert!(arcs > 10, "{name}: {arcs} arcs");
        assert!(text.lines().count() < flat.lines().count(), "{name}");
        // The report's cut length is the arcs' (within the written numbers' rounding).
        assert!(
            (summary.path.cut_mm - ra.cut_mm).abs() < 1e-3 * ra.cut_mm,
            "{name}: {} vs {}",
            summary.path.cut_mm,
            ra.cut_mm
        );
        let (pa, pf) = (cut_paths(&ra), cut_paths(&rf));
        assert_eq!(pa.len(), pf.len(), "{name}");
        // The fit's tolerance, plus the written numbers' rounding (X, Y, I, J to 0.0005 mm).
        let limit = tol + 0.002;
        for (a, f) in pa.iter().zip(&pf) {
            let (af, fa) = (one_way(a, f), one_way(f, a));
            assert!(af <= limit && fa <= limit, "{name}: {af} / {fa} mm");
        }
    }
}

#[test]
fn every_shipped_machine_gets_a_valid_program() {
    let g = scattered(11, 4, 3);
    for name in machine::builtin_names() {
        let m = machine::load(Some(name)).unwrap();
        let mut s = settings();
        s.passes = 2;
        let mut cfg = PlanConfig::new(s);
        cfg.cut_outline = true;
        cfg.offset = [5.0, 5.0];
        // The shipped origin corner decides the default anchor; place that corner at 5,5.
        let (text, _) = make(&g, &m, &cfg);
        let r = check_program(&text, &m);
        let perim: f64 = g.cuts.0.iter().map(perimeter).sum::<f64>()
            + 2.0 * (g.outline.width() + g.outline.height());
        let overcut = match m.tool {
            Tool::Knife { overcut_mm, .. } => overcut_mm * (g.cuts.0.len() + 1) as f64,
            _ => 0.0,
        };
        let want = 2.0 * perim + overcut;
        assert!(
            (r.cut_mm - want).abs() / want < 0.01,
            "{name}: cut {} vs {want}",
            r.cut_mm
        );
        if let Tool::Pen(PenLift::Spindle { .. }) = m.tool {
            assert!(
                r.commands.iter().any(|c| c == "M3"),
                "{name}: pen down with M3"
            );
        }
    }
}

#[test]
fn drag_knife_compensation_stays_on_the_bed_and_adds_the_swivels() {
    let m = machine::load(Some("drag-knife")).unwrap();
    let g = scattered(3, 4, 4); // convex circles and squares
    let mut s = settings();
    s.blade_offset_mm = 0.5;
    let mut cfg = PlanConfig::new(s);
    cfg.cut_outline = true;
    // The outline at X0/Y0 would need the axis at -0.5 mm: refused, not clipped by soft limits.
    let e = gcode_for(&g, &m, &cfg, &[]).unwrap_err().to_string();
    assert!(
        e.contains("X -0.5") && e.contains("move it on the bed"),
        "{e}"
    );
    cfg.offset = [1.0, 1.0];
    let (text, _) = make(&g, &m, &cfg);
    let r = check_program(&text, &m);
    // Each convex loop turns 2π in total; the axis swings r·2π around its corners (chords of
    // 10° arcs are 0.03 % shorter), plus the overcut.
    let loops = g.cuts.0.len() + 1;
    let (overcut, blade) = match m.tool {
        Tool::Knife { overcut_mm, .. } => (overcut_mm, 0.5),
        _ => unreachable!(),
    };
    let perim: f64 = g.cuts.0.iter().map(perimeter).sum::<f64>()
        + 2.0 * (g.outline.width() + g.outline.height());
    let want = perim + loops as f64 * (blade * std::f64::consts::TAU + overcut);
    assert!(
        (r.cut_mm - want).abs() / want < 0.01,
        "cut {} vs {want} (perimeter alone {perim})",
        r.cut_mm
    );
    assert!(
        (r.cut_mm - perim).abs() / perim > 0.05,
        "compensation changes the path"
    );
}

#[test]
fn nested_shapes_cut_inside_first_and_the_outline_last() {
    let m = machine::load(None).unwrap();
    // A big region with a hole (an island, cut first), a small region, a medium one.
    let mut big = rect(10.0, 10.0, 90.0, 70.0);
    big.interiors_push(LineString::from(vec![
        (40.0, 30.0),
        (50.0, 30.0),
        (50.0, 40.0),
        (40.0, 40.0),
        (40.0, 30.0),
    ]));
    let g = sheet(
        150.0,
        100.0,
        vec![
            big,
            rect(100.0, 10.0, 110.0, 20.0),
            rect(100.0, 40.0, 140.0, 90.0),
        ],
    );
    let mut cfg = PlanConfig::new(settings());
    cfg.cut_outline = true;
    let (text, _) = make(&g, &m, &cfg);
    let r = check_program(&text, &m);
    // Group the cutting moves into loops (runs of tool-on moves between travels).
    let mut loops: Vec<Vec<[f64; 3]>> = Vec::new();
    let mut cutting = false;
    for (_, to, rapid, on) in &r.moves {
        if !rapid && *on {
            if !cutting {
                loops.push(Vec::new());
            }
            loops.last_mut().unwrap().push(*to);
            cutting = true;
        } else {
            cutting = false;
        }
    }
    let bbox = |l: &Vec<[f64; 3]>| {
        l.iter()
            .fold([f64::MAX, f64::MAX, f64::MIN, f64::MIN], |b, p| {
                [
                    b[0].min(p[0]),
                    b[1].min(p[1]),
                    b[2].max(p[0]),
                    b[3].max(p[1]),
                ]
            })
    };
    assert_eq!(loops.len(), 5);
    // Machine Y is up: sheet y 30..40 on a 100 mm sheet is 60..70.
    assert_eq!(
        bbox(&loops[0]),
        [40.0, 60.0, 50.0, 70.0],
        "the island's hole first"
    );
    assert_eq!(
        bbox(&loops[3]),
        [10.0, 30.0, 90.0, 90.0],
        "largest region last"
    );
    assert_eq!(
        bbox(&loops[4]),
        [0.0, 0.0, 150.0, 100.0],
        "outline after everything"
    );
}

#[test]
fn optimised_travel_is_shorter_than_the_input_order() {
    let m = machine::load(None).unwrap();
    for seed in [1, 2, 3] {
        let g = scattered(seed, 12, 10);
        let (text, s) = make(&g, &m, &PlanConfig::new(settings()));
        let r = check_program(&text, &m);
        assert!(
            s.path.travel_mm < 0.5 * s.path.naive_travel_mm,
            "seed {seed}: optimised {} vs input order {}",
            s.path.travel_mm,
            s.path.naive_travel_mm
        );
        // The travel the program really makes is the one reported.
        assert!(
            (r.travel_mm - s.path.travel_mm).abs() < 1e-2 * s.path.travel_mm,
            "seed {seed}: program travel {} vs reported {}",
            r.travel_mm,
            s.path.travel_mm
        );
    }
}

#[test]
fn square_time_matches_a_hand_calculation() {
    // A 50 mm square cut at F3000 (v = 50 mm/s), a = 500 mm/s², junction deviation δ = 0.01 mm,
    // starting and ending at rest at the origin.
    //
    // Corner (90°): cos θ = -u_prev·u = 0, sin(θ/2) = sqrt((1 - cos θ)/2) = 0.707107.
    // Grbl scales the junction acceleration to the junction direction (u - u_prev)/|..| =
    // (±0.7071, ±0.7071): a_j = 500 / 0.707107 = 707.107 mm/s².
    // v_j² = a_j·δ·sin(θ/2)/(1 - sin(θ/2)) = 707.107·0.01·0.707107/0.292893 = 17.0711,
    // v_j = 4.13171 mm/s.
    //
    // Side 1 (0 → v_j): accelerate 0→50: t = 50/500 = 0.1 s over 50²/(2·500) = 2.5 mm;
    //   brake 50→v_j: t = (50 - 4.13171)/500 = 0.091737 s over (2500 - 17.0711)/1000 = 2.48293 mm;
    //   cruise 50 - 2.5 - 2.48293 = 45.01707 mm at 50 mm/s = 0.900341 s; total 1.092078 s.
    // Sides 2, 3 (v_j → v_j): two ramps of 0.091737 s and 2.48293 mm each, cruise 45.03414 mm =
    //   0.900683 s; total 1.084157 s each.
    // Side 4 (v_j → 0): mirror of side 1, 1.092078 s.
    // Total: 2·1.092078 + 2·1.084157 = 4.352470 s (length ÷ feed would say 4.0 s).
    let (a, v, d, side): (f64, f64, f64, f64) = (500.0, 50.0, 0.01, 50.0);
    let sin_half = (0.5f64).sqrt();
    let a_j = a / sin_half;
    let vj = (a_j * d * sin_half / (1.0 - sin_half)).sqrt();
    let ramp_t = |v0: f64| (v - v0) / a;
    let ramp_d = |v0: f64| (v * v - v0 * v0) / (2.0 * a);
    let side_t = |v0: f64, v1: f64| ramp_t(v0) + ramp_t(v1) + (side - ramp_d(v0) - ramp_d(v1)) / v;
    let hand = side_t(0.0, vj) + 2.0 * side_t(vj, vj) + side_t(vj, 0.0);
    assert!((hand - 4.35247).abs() < 1e-4, "hand calculation {hand}");

    let program = "G21 G90\nM4 S1000\nG1 X50 Y0 F3000\nG1 X50 Y50\nG1 X0 Y50\nG1 X0 Y0\nM5\n";
    let limits = Motion {
        rapid_mm_min: 6000.0,
        max_feed_mm_min: 6000.0,
        accel_mm_s2: a,
        junction_deviation_mm: d,
        homing: false,
        axis_rate_mm_min: None,
        axis_accel_mm_s2: None,
        steps_per_mm: None,
        profile_steps_per_mm: None,
        idle_lock_ms: None,
    };
    let e = estimate(&interpret(program).unwrap(), &limits);
    assert!(
        (e.total_s - hand).abs() / hand < 0.02,
        "estimate {} s vs hand {hand} s",
        e.total_s
    );
    assert!((e.cut_mm - 200.0).abs() < 1e-9 && e.travel_mm == 0.0);
    // And the plain length ÷ feed would not pass this test.
    assert!((4.0 - hand).abs() / hand > 0.05);
}

#[test]
fn a_job_larger_than_the_bed_is_refused() {
    let m = machine::load(None).unwrap();
    let g = sheet(420.0, 300.0, vec![rect(10.0, 10.0, 50.0, 50.0)]);
    // With the sheet's outline cut, the whole sheet must be on the bed.
    let mut cfg = PlanConfig::new(settings());
    cfg.cut_outline = true;
    let e = gcode_for(&g, &m, &cfg, &[]).unwrap_err().to_string();
    assert!(
        e.contains("420.0 x 300.0 mm") && e.contains("400.0 x 400.0 mm"),
        "{e}"
    );
    // Without it, only what is cut counts: the 40 mm square, placed at the origin.
    let (text, s) = gcode_for(&g, &m, &PlanConfig::new(settings()), &[]).unwrap();
    assert!(text.contains("job 40 x 40 mm at X0..40 Y0..40"), "{text}");
    assert_eq!(s.path.loops, 1);
    let big = sheet(420.0, 300.0, vec![rect(0.0, 10.0, 410.0, 50.0)]);
    let e = gcode_for(&big, &m, &PlanConfig::new(settings()), &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("410.0 x 40.0 mm"), "{e}");
}

// ---- the command line -------------------------------------------------------------------------

fn stencil(args: &[&str], dir: &Path) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_stencil"))
        .args(args)
        .current_dir(dir)
        // No settings a developer kept in their own config folder.
        .env("STENCIL_CONFIG_DIR", common_empty_config())
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A config folder with nothing kept in it (it does not exist).
fn common_empty_config() -> std::path::PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("no-kept-settings")
}

const SVG: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="120mm" height="80mm" viewBox="0 0 120 80">
<path fill-rule="evenodd" d="M10 10 L50 10 L50 40 L10 40 Z M60 10 H110 V70 H60 Z M20 50 h20 v20 h-20 z"/>
</svg>"#;

#[test]
fn cli_writes_gcode_from_an_svg_and_estimates_it() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.svg"), SVG).unwrap();
    let (ok, out, err) = stencil(
        &[
            "gcode",
            "s.svg",
            "-o",
            "job.gcode",
            "--power",
            "50",
            "--speed",
            "1200",
        ],
        dir.path(),
    );
    assert!(ok, "{err}");
    assert!(out.contains("job.gcode") && out.contains("travel"), "{out}");
    let text = std::fs::read_to_string(dir.path().join("job.gcode")).unwrap();
    let m = machine::load(None).unwrap();
    let r = check_program(&text, &m);
    // 40x30 + 50x60 + 20x20 rectangles: perimeters 140 + 220 + 80 = 440 mm.
    assert!((r.cut_mm - 440.0).abs() < 0.01, "{}", r.cut_mm);
    let (ok, out, err) = stencil(&["estimate", "job.gcode"], dir.path());
    assert!(ok && out.contains("cut 440 mm"), "{out} {err}");
}

/// An open path is drawn as the line it is by a pen (it was closed and cut as a triangle), and
/// refused by a laser unless `--cut-open-paths`, which then cuts it open.
#[test]
fn open_paths_are_drawn_by_a_pen_and_refused_by_a_laser() {
    let dir = tempfile::tempdir().unwrap();
    let svg = r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">
<path d="M10 10 L50 10 L50 50" fill="none" stroke="black"/>
<rect x="60" y="60" width="10" height="10"/></svg>"#;
    std::fs::write(dir.path().join("o.svg"), svg).unwrap();
    let (ok, out, err) = stencil(
        &[
            "gcode",
            "o.svg",
            "-o",
            "pen.gcode",
            "--machine",
            "pen-a3",
            "--speed",
            "1000",
        ],
        dir.path(),
    );
    assert!(ok, "{err}");
    assert!(out.contains("1 loops and 1 open paths"), "{out}");
    let m = machine::load(Some("pen-a3")).unwrap();
    let text = std::fs::read_to_string(dir.path().join("pen.gcode")).unwrap();
    let r = check_program(&text, &m);
    // The line (40 + 40 mm, not closed back: that would add 56.6 mm) and the 40 mm square.
    assert!((r.cut_mm - 120.0).abs() < 0.01, "{}", r.cut_mm);
    let drawn: Vec<([f64; 3], [f64; 3])> = r
        .moves
        .iter()
        .filter(|m| m.3 && !m.2)
        .map(|m| (m.0, m.1))
        .collect();
    let has = |a: [f64; 2], b: [f64; 2]| {
        drawn.iter().any(|(f, t)| {
            let near = |p: &[f64; 3], q: [f64; 2]| {
                (p[0] - q[0]).abs() < 1e-3 && (p[1] - q[1]).abs() < 1e-3
            };
            (near(f, a) && near(t, b)) || (near(f, b) && near(t, a))
        })
    };
    // Only what is drawn is placed (the line and the square span sheet 10..70 in x and y), its
    // lower-left at the origin, y up on the bed: sheet (10, 10) is bed (0, 60).
    assert!(
        has([0.0, 60.0], [40.0, 60.0]) && has([40.0, 60.0], [40.0, 20.0]),
        "{drawn:?}"
    );
    assert!(
        !has([40.0, 20.0], [0.0, 60.0]),
        "the line is not closed: {drawn:?}"
    );

    let laser = [
        "gcode", "o.svg", "-o", "l.gcode", "--power", "50", "--speed", "1000",
    ];
    let (ok, _, err) = stencil(&laser, dir.path());
    assert!(
        !ok && err.contains("o.svg")
            && err.contains("1 open path")
            && err.contains("--cut-open-paths"),
        "{err}"
    );
    assert!(!dir.path().join("l.gcode").exists());
    let mut open = laser.to_vec();
    open.push("--cut-open-paths");
    let (ok, _, err) = stencil(&open, dir.path());
    assert!(ok, "{err}");
    let text = std::fs::read_to_string(dir.path().join("l.gcode")).unwrap();
    let r = check_program(&text, &machine::load(None).unwrap());
    assert!((r.cut_mm - 120.0).abs() < 0.01, "{}", r.cut_mm);
}

#[test]
fn cli_refuses_too_big_and_bad_inputs_with_clear_messages() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.svg"), SVG).unwrap();
    let base = [
        "gcode",
        "s.svg",
        "-o",
        "job.gcode",
        "--power",
        "50",
        "--speed",
        "1200",
    ];
    let with = |extra: &[&str]| {
        let mut v: Vec<&str> = base.to_vec();
        v.extend_from_slice(extra);
        stencil(&v, dir.path())
    };
    // Too big for the pen-servo bed (300 x 220) once moved to X 250.
    let (ok, _, err) = with(&["--machine", "pen-servo", "--offset", "250,0"]);
    assert!(
        !ok && err.contains("does not fit") && err.contains("300.0 x 220.0"),
        "{err}"
    );
    // The library says what to change; the command names the options that change it.
    assert!(
        err.contains("move it on the bed with --offset X,Y or --origin"),
        "{err}"
    );
    assert!(
        !dir.path().join("job.gcode").exists(),
        "no file after a refusal"
    );

    // Bad machine profiles name the file and the field.
    let bad = [
        (
            "typo.toml",
            "accel_mm_s2 = 500",
            "acceleration = 500",
            "acceleration",
        ),
        (
            "neg.toml",
            "width_mm = 300",
            "width_mm = -300",
            "bed.width_mm",
        ),
        ("s.toml", "s_max = 1000", "s_max = 0", "tool.s_max"),
    ];
    let good = r#"name = "x"
[bed]
width_mm = 300
height_mm = 300
[motion]
max_feed_mm_min = 3000
rapid_mm_min = 3000
accel_mm_s2 = 500
[tool]
kind = "laser"
s_max = 1000
"#;
    for (file, from, to, field) in bad {
        std::fs::write(dir.path().join(file), good.replace(from, to)).unwrap();
        let (ok, _, err) = with(&["--machine", file]);
        assert!(!ok, "{file} accepted");
        assert!(err.contains(file) && err.contains(field), "{file}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
    }
    let (ok, _, err) = with(&["--machine", "no-such-machine"]);
    assert!(!ok && err.contains("diode-400"), "{err}");

    // A G-code error names the line.
    std::fs::write(dir.path().join("bad.gcode"), "G21\nG1 X10\n").unwrap();
    let (ok, _, err) = stencil(&["estimate", "bad.gcode"], dir.path());
    assert!(!ok && err.contains("line 2"), "{err}");
}

// ---- the samples, through the whole pipeline ----------------------------------------------------

fn samples_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("samples")
}

/// Run `make` in memory on a sample at 150 mm wide with G-code for `machine`.
fn make_sample(name: &str, machine: &Machine, cut_outline: bool) -> stencil_core::pipeline::Made {
    use stencil_core::pipeline::{MakeConfig, PhysicalConfig, Size};
    let physical = PhysicalConfig {
        size: Size::WidthMm(150.0),
        // The samples are about the G-code here, not about the material check.
        allow_thin: true,
        ..Default::default()
    };
    let settings = stencil_core::material::settings_for(&physical.material, machine).unwrap();
    let mut plan = PlanConfig::new(settings);
    plan.cut_outline = cut_outline;
    let cfg = MakeConfig {
        input: samples_dir().join(format!("{name}.png")),
        physical,
        gcode: Some(stencil_gcode::GcodeConfig {
            machine: machine.clone(),
            plan,
            settings_from: String::new(),
        }),
        ..Default::default()
    };
    stencil_core::driver::run(&cfg).unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn samples_give_valid_programs_shorter_travel_and_their_perimeter() {
    let m = machine::load(None).unwrap();
    for name in ["rings", "letters", "blobs"] {
        let made = make_sample(name, &m, true);
        let text = made.gcode.as_deref().expect("G-code asked for");
        let r = check_program(text, &m);
        let g = &made.geometry;
        let o = g.outline;
        // Every loop is cut once per pass (cardstock on the 5.5 W diode: two).
        let settings = made.report.gcode.as_ref().unwrap().settings.unwrap();
        let passes = settings.passes as f64;
        let perim: f64 =
            passes * (g.cuts.0.iter().map(perimeter).sum::<f64>() + 2.0 * (o.width() + o.height()));
        assert!(
            (r.cut_mm - perim).abs() / perim < 0.01,
            "{name}: cut {} vs perimeter {perim}",
            r.cut_mm
        );
        // The tool paths are the design cuts moved half a kerf inward (cardstock: 0.15 mm).
        use geo::Area;
        let design_perim: f64 = g.design_cuts.0.iter().map(perimeter).sum();
        let shrunk = g.design_cuts.unsigned_area() - g.cuts.unsigned_area();
        let kerf = stencil_core::material::Material::default().kerf_mm;
        assert!(kerf > 0.0);
        let expected = design_perim * kerf / 2.0;
        assert!(
            (shrunk - expected).abs() / expected < 0.1,
            "{name}: kerf took {shrunk} mm², expected about {expected}"
        );
        let s = made.report.gcode.as_ref().expect("summary in the report");
        assert!(
            s.path.travel_mm < s.path.naive_travel_mm,
            "{name}: optimised {} vs input order {}",
            s.path.travel_mm,
            s.path.naive_travel_mm
        );
        assert!(
            s.estimate.total_s > perim / (settings.speed_mm_min / 60.0),
            "{name}: slower than feed"
        );
    }
}

#[test]
fn make_emit_gcode_and_gcode_from_the_folder() {
    let dir = tempfile::tempdir().unwrap();
    let sample = samples_dir().join("rings.png");
    let out = dir.path().join("rings");
    let (ok, stdout, err) = stencil(
        &[
            "make",
            sample.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--width-mm",
            "150",
            "--material",
            "cardstock",
            // The bridges' widths are not the point here.
            "--allow-thin",
            "--emit",
            "svg,gcode",
            "--machine",
            "diode-400",
        ],
        dir.path(),
    );
    assert!(ok, "{err}");
    assert!(
        stdout.contains("stencil.gcode") && stdout.contains("about"),
        "{stdout}"
    );
    let m = machine::load(None).unwrap();
    let text = std::fs::read_to_string(out.join("stencil.gcode")).unwrap();
    let r = check_program(&text, &m);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let g = &report["gcode"];
    assert_eq!(g["machine"], "diode-400");
    assert!((g["cut_mm"].as_f64().unwrap() - r.cut_mm).abs() < 0.01 * r.cut_mm);
    assert!(g["estimate"]["total_s"].as_f64().unwrap() > 0.0);
    assert!(report["files"]
        .as_array()
        .unwrap()
        .iter()
        .any(|f| f == "stencil.gcode"));
    // cardstock on the 5.5 W diode: its diode entry (48 % of $30=1000 at 1650 mm/min, two
    // passes), not the CO2 one (S200 F1500), and the report says so and where they came from.
    assert!(text.contains(" S480 F1650"), "diode settings used");
    assert!(!text.contains("S200"), "no CO2 settings on a diode");
    assert_eq!(g["settings"]["power_pct"], 48.0);
    assert_eq!(g["settings"]["speed_mm_min"], 1650.0);
    assert_eq!(g["settings"]["passes"], 2);
    let from = g["settings_from"].as_str().unwrap();
    assert!(
        from.contains("diode laser 5 W") && from.contains("lasertinkerer"),
        "{from}"
    );
    assert!(
        stdout.contains("48 % power, 1650 mm/min, 2 passes"),
        "{stdout}"
    );

    // The same folder again through `stencil gcode`, on another machine: material from the report.
    let (ok, _, err) = stencil(
        &[
            "gcode",
            out.to_str().unwrap(),
            "-o",
            "again.gcode",
            "--machine",
            "co2-600x400",
        ],
        dir.path(),
    );
    assert!(ok, "{err}");
    let again = std::fs::read_to_string(dir.path().join("again.gcode")).unwrap();
    // On the 40 W CO2: the CO2 entry, 20 % of $30=1000 at 1500 mm/min.
    assert!(again.contains("material cardstock") && again.contains(" S200 F1500"));
    let m2 = machine::load(Some("co2-600x400")).unwrap();
    let r2 = check_program(&again, &m2);
    // Read back from the SVG with the kerf applied again: the same cut length within 1 %, per
    // pass (two on the diode, one on the CO2).
    let per_pass = r.cut_mm / 2.0;
    assert!(
        (r2.cut_mm - per_pass).abs() / per_pass < 0.01,
        "{} vs {per_pass}",
        r2.cut_mm,
    );

    // A laser material on a knife: refused, nothing written.
    let (ok, _, err) = stencil(
        &[
            "gcode",
            out.to_str().unwrap(),
            "-o",
            "k.gcode",
            "--machine",
            "drag-knife",
        ],
        dir.path(),
    );
    assert!(
        !ok && err.contains("laser") && err.contains("knife"),
        "{err}"
    );
    assert!(!dir.path().join("k.gcode").exists());

    // A stencil larger than the bed fails the whole run: no folder, no files.
    let (ok, _, err) = stencil(
        &[
            "make",
            sample.to_str().unwrap(),
            "-o",
            "big",
            "--width-mm",
            "400",
            "--cut-outline",
            "--allow-thin",
            "--emit",
            "svg,gcode",
        ],
        dir.path(),
    );
    // 400 mm plus a 5 mm margin on each side (its outline is cut): 410 mm on the default
    // 400 x 400 mm bed, refused from the picture's header before any work, with the largest
    // width that fits.
    assert!(
        !ok && err.contains("400 x 400 mm with a 5 mm margin")
            && err.contains("bed of diode-400")
            && err.contains("--width-mm 390 or less")
            && err.contains("--margin-mm"),
        "{err}"
    );
    assert!(!dir.path().join("big").exists(), "nothing written");
    // Without the outline cut the margin does not count: 401 mm is refused naming 400.
    let (ok, _, err) = stencil(
        &[
            "make",
            sample.to_str().unwrap(),
            "-o",
            "big",
            "--width-mm",
            "401",
            "--emit",
            "svg,gcode",
        ],
        dir.path(),
    );
    assert!(!ok && err.contains("--width-mm 400 or less"), "{err}");
    assert!(!dir.path().join("big").exists(), "nothing written");

    // Machine options without --emit gcode are a mistake, said plainly.
    let (ok, _, err) = stencil(
        &[
            "make",
            sample.to_str().unwrap(),
            "-o",
            "x",
            "--machine",
            "diode-400",
        ],
        dir.path(),
    );
    assert!(!ok && err.contains("--emit"), "{err}");
}

// ---- any input, any shipped machine -------------------------------------------------------------

mod prop {
    use super::*;
    use proptest::prelude::*;
    use stencil_gcode::machine::Corner;
    use stencil_gcode::{Anchor, PlanError};

    fn anchor() -> impl Strategy<Value = Option<Anchor>> {
        prop_oneof![
            Just(None),
            Just(Some(Anchor::Center)),
            Just(Some(Anchor::Corner(Corner::TopRight))),
            Just(Some(Anchor::Corner(Corner::BottomLeft))),
            Just(Some(Anchor::Corner(Corner::TopLeft))),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

        /// Either the program is valid and cuts every loop `passes` times, or the job is refused
        /// because it really leaves the bed.
        #[test]
        fn valid_program_or_a_true_refusal(
            seed in 0u64..1000,
            cols in 1usize..6,
            rows in 1usize..5,
            machine_idx in 0usize..5,
            passes in 1u32..4,
            outline in any::<bool>(),
            anchor in anchor(),
            fx in -0.05f64..0.8,
            fy in -0.05f64..0.8,
        ) {
            let m = machine::load(Some(machine::builtin_names()[machine_idx])).unwrap();
            let g = scattered(seed, cols, rows);
            let mut s = settings();
            s.passes = passes;
            // Offsets as a fraction of the bed: mostly on it, sometimes over an edge.
            let offset = [fx * m.bed.width_mm, fy * m.bed.height_mm];
            let cfg = PlanConfig { anchor, offset, cut_outline: outline, cut_open_paths: false, settings: s, arc_tolerance_mm: 0.0, keep_feed: false };
            match gcode_for(&g, &m, &cfg, &[]) {
                Ok((text, _)) => {
                    let r = check_program(&text, &m);
                    let mut perim: f64 = g.cuts.0.iter().map(perimeter).sum();
                    let mut loops = g.cuts.0.len();
                    if outline {
                        perim += 2.0 * (g.outline.width() + g.outline.height());
                        loops += 1;
                    }
                    let overcut = match m.tool {
                        Tool::Knife { overcut_mm, .. } => overcut_mm * loops as f64,
                        _ => 0.0,
                    };
                    let want = passes as f64 * perim + overcut;
                    prop_assert!((r.cut_mm - want).abs() / want < 0.01, "cut {} vs {want}", r.cut_mm);
                }
                Err(PlanError::DoesNotFit { x0, x1, y0, y1, .. }) => {
                    // The sheet at that placement really sticks out of the bed.
                    let (bw, bh) = (m.bed.width_mm, m.bed.height_mm);
                    prop_assert!(x0 < 0.0 || y0 < 0.0 || x1 > bw || y1 > bh);
                    // The job is the sheet when its outline is cut, else what is cut (a
                    // knife's axis passes the cuts by up to its blade offset).
                    if outline {
                        prop_assert!((x1 - x0 - g.outline.width()).abs() < 1e-6);
                        prop_assert!((y1 - y0 - g.outline.height()).abs() < 1e-6);
                    } else {
                        let reach = 2.0 * s.blade_offset_mm + 1e-6;
                        prop_assert!(x1 - x0 <= g.outline.width() + reach);
                        prop_assert!(y1 - y0 <= g.outline.height() + reach);
                    }
                }
                Err(e) => prop_assert!(false, "unexpected error: {e}"),
            }
        }
    }
}

/// Grbl takes `?`, `!`, `~` and every byte above 0x7F out of the serial stream wherever they
/// stand, comments included (a `!` is a feed hold). The header names the picture's path and
/// the material's sources, so a file name with them must not put them in the job.
#[test]
fn the_job_holds_no_realtime_command_byte_even_in_its_comments() {
    let dir = tempfile::tempdir().unwrap();
    let name = "what?!~ caf\u{e9} 5\u{2013}20.png";
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("samples/rings.png"),
        dir.path().join(name),
    )
    .unwrap();
    let (ok, _, err) = stencil(
        &[
            "make",
            name,
            "-o",
            "out",
            "--machine",
            "diode-400",
            "--material",
            "cardstock",
            "--emit",
            "gcode",
        ],
        dir.path(),
    );
    assert!(ok, "{err}");
    let job = std::fs::read(dir.path().join("out/stencil.gcode")).unwrap();
    let text = String::from_utf8_lossy(&job);
    assert!(text.contains("what..- caf_ 5-20.png"), "{text}");
    for (i, line) in text.lines().enumerate() {
        assert!(
            line.bytes()
                .all(|b| b < 0x80 && !matches!(b, b'?' | b'!' | b'~')),
            "line {}: {line}",
            i + 1
        );
    }
}
