//! The one G-code interpreter: Grbl 1.1h's parser and motion (the `grbl` module rewrites
//! `gc_execute_line`, `arc` cuts arcs as `mc_arc` does), turning program text into moves in
//! machine coordinates with every work offset applied.
//!
//! Used by the time estimate, the simulator, the bed check, framing, `send`'s preflight and the
//! virtual Grbl, so all of them agree with each other and with the machine on what a program does.

pub use crate::error::GcodeError;
pub use crate::grbl::motion_word;
pub use crate::modal::*;

/// Strip a `;` comment and `( )` comments, spaces, and upper-case: what Grbl keeps of a line.
pub fn clean_line(line: &str) -> String {
    let mut out = String::with_capacity(line.len());
    let mut in_paren = false;
    for c in line.chars() {
        match c {
            '(' => in_paren = true,
            ')' if in_paren => in_paren = false,
            ';' if !in_paren => break,
            c if in_paren || c.is_whitespace() || c.is_control() || c == '/' => {}
            c => out.push(c.to_ascii_uppercase()),
        }
    }
    out
}

/// Split a cleaned line into (letter, value) words, each read as Grbl reads it (a letter A–Z,
/// then a number: sign, digits, at most one point).
pub fn words(clean: &str, line_no: usize) -> Result<Vec<(char, f64)>, GcodeError> {
    let mut out = Vec::new();
    let mut i = 0;
    while let Some(w) = crate::word::next_word(clean, &mut i, line_no)? {
        out.push(w);
    }
    Ok(out)
}

/// Run one line against the modal state as Grbl 1.1h's parser does: `Err` with Grbl's error
/// code (and nothing changed) where Grbl answers `error:N`, else what the line did.
/// `$`-commands and empty lines do nothing here.
pub fn step(modal: &mut Modal, line: &str, line_no: usize) -> Result<Executed, GcodeError> {
    let clean = clean_line(line);
    if clean.is_empty() || clean.starts_with('$') {
        return Ok(Executed::default());
    }
    // Grbl's line buffer holds what is left after spaces and comments, 79 characters: a longer
    // line is refused whole (protocol.c's overflow flag, error:11), whatever its words say.
    if clean.len() > crate::limits::MAX_LINE_BYTES {
        return Err(crate::error::fail(
            line_no,
            11,
            format!(
                "the line is {} characters without spaces and comments; Grbl's line buffer \
                 holds {} (Grbl error:11)",
                clean.len(),
                crate::limits::MAX_LINE_BYTES
            ),
        ));
    }
    crate::grbl::execute(modal, &clean, line_no)
}

/// Which moves of a program cut (the laser fires, the pen draws, the blade is in the sheet),
/// decided from the program text alone, since a third-party file comes without a profile.
/// `stencil simulate`, `stencil estimate` and `make`'s summary all use this one rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CutRule {
    /// The tool is switched by the spindle output: a feed move (G1) with M3/M4 on and S > 0.
    /// In Grbl's laser mode the beam is dark in G0, so a rapid move never cuts.
    Spindle,
    /// A pen servo on the spindle output (`M3 S<down>` lowers it, `M5` raises it): any X/Y move
    /// with the spindle on and S > 0 draws, G0 too, since the pen stays down while it travels.
    /// Chosen by the machine profile ([`CutRule::for_spindle_pen`]); a file cannot say it.
    SpindlePen,
    /// A pen or knife on Z: an X/Y move cuts where Z is at or below `down_at_or_below` mm,
    /// G0 too (a blade left down drags through the sheet whatever the move is called).
    ZDown {
        /// The highest Z that cuts, mm.
        down_at_or_below: f64,
    },
    /// No spindle and only one Z level: feed moves in X/Y cut, rapid ones do not.
    Feed,
}

const Z_EPS: f64 = 1e-6;

impl CutRule {
    /// Infer the rule from the moves.
    ///
    /// - X/Y moves at two or more Z levels: a Z tool. With levels on both sides of zero, the
    ///   usual convention holds (work zero on the sheet's surface: Z <= 0 is down); otherwise the
    ///   levels split at their widest gap and the lower side is down (a plotter whose pen touches
    ///   at Z5 and lifts to Z10).
    /// - Otherwise, a program that powers the spindle during a feed move: a laser (or a servo
    ///   pen, see [`CutRule::for_spindle_pen`]).
    /// - Otherwise every feed move in X/Y cuts.
    pub fn infer(moves: &[Move]) -> CutRule {
        let mut levels: Vec<f64> = moves
            .iter()
            .filter(|m| moves_xy(m))
            .map(|m| m.from[2].min(m.to[2]))
            .collect();
        levels.sort_by(f64::total_cmp);
        levels.dedup_by(|a, b| (*a - *b).abs() < 1e-3);
        if levels.len() >= 2 {
            let (lo, hi) = (levels[0], levels[levels.len() - 1]);
            let down_at_or_below = if lo <= Z_EPS && hi > Z_EPS {
                0.0
            } else {
                // The level just below the widest gap.
                levels
                    .windows(2)
                    .max_by(|a, b| (a[1] - a[0]).total_cmp(&(b[1] - b[0])))
                    .map_or(lo, |w| w[0])
            };
            return CutRule::ZDown { down_at_or_below };
        }
        if moves.iter().any(|m| m.power > 0.0) {
            CutRule::Spindle
        } else {
            CutRule::Feed
        }
    }

    /// For a machine whose pen servo hangs on the spindle output: a program the file says is
    /// switched by the spindle draws in G0 too.
    pub fn for_spindle_pen(self) -> CutRule {
        match self {
            CutRule::Spindle => CutRule::SpindlePen,
            r => r,
        }
    }

    /// Whether this move cuts.
    pub fn cuts(&self, m: &Move) -> bool {
        match *self {
            CutRule::Spindle => !m.rapid && m.power > 0.0 && moves_xy(m),
            CutRule::SpindlePen => m.spindle_s > 0.0 && moves_xy(m),
            CutRule::ZDown { down_at_or_below } => {
                moves_xy(m) && m.from[2].min(m.to[2]) <= down_at_or_below + Z_EPS
            }
            CutRule::Feed => !m.rapid && moves_xy(m),
        }
    }
}

/// The move goes somewhere in X or Y (a plunge or a lift alone cuts nothing along the sheet).
fn moves_xy(m: &Move) -> bool {
    (m.to[0] - m.from[0]).abs() > 1e-12 || (m.to[1] - m.from[1]).abs() > 1e-12
}

/// How far a program's moves reach in X and Y, and the first line reaching each extreme: what
/// the bed check compares with a machine's bed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extent {
    /// The least X and Y reached, mm.
    pub min: [f64; 2],
    /// The greatest X and Y reached, mm.
    pub max: [f64; 2],
    /// The line of the move that reaches `min[axis]` / `max[axis]` (0: the start position).
    pub min_line: [usize; 2],
    /// The lines that reach the greatest X and Y.
    pub max_line: [usize; 2],
}

/// The extent of the moves, from where they start; `None` for a program without moves.
pub fn extent(moves: &[Move]) -> Option<Extent> {
    let first = moves.first()?;
    let mut e = Extent {
        min: [first.from[0], first.from[1]],
        max: [first.from[0], first.from[1]],
        min_line: [0; 2],
        max_line: [0; 2],
    };
    for m in moves {
        for a in 0..2 {
            if m.to[a] < e.min[a] {
                e.min[a] = m.to[a];
                e.min_line[a] = m.line;
            }
            if m.to[a] > e.max[a] {
                e.max[a] = m.to[a];
                e.max_line[a] = m.line;
            }
        }
    }
    Some(e)
}

/// A `$J=` jog's words (the text after `$J=`, cleaned) as Grbl 1.1h checks them against the
/// parser's state, which a jog does not change: F required, only G20/G21, G90/G91 and G53
/// (`error:16` for any other command), S and T unused (`error:36`). The target in machine
/// coordinates and the feed in mm/min, or Grbl's `error:N`.
pub fn jog(modal: &Modal, body: &str, line_no: usize) -> Result<([f64; 3], f64), GcodeError> {
    crate::grbl::jog(modal, body, line_no)
}

/// A whole program as Grbl runs it: every move (arcs as their chords) in machine coordinates,
/// and the time it stands still in dwells.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Program {
    /// The moves, in order.
    pub moves: Vec<Move>,
    /// G4 dwells, seconds in all.
    pub dwell_s: f64,
    /// Each G4 dwell: the index into `moves` of the first move after it, and its seconds (what
    /// is left of a job part-way through has the dwells still to come).
    pub dwells: Vec<(usize, f64)>,
    /// Lines with M0 (Grbl holds there until cycle start).
    pub pauses: Vec<usize>,
    /// Indices into `moves` of the moves Grbl starts from a standstill because it emptied its
    /// planner first (`protocol_buffer_synchronize`): after a spindle state change (M3/M4/M5),
    /// a coolant change (M8/M9), an S change without motion while the spindle is on, a dwell
    /// (G4), M0/M2/M30, a probe, and G10/G28.1/G30.1 (EEPROM writes). S changes on motion lines
    /// are taken as laser mode passes them (`$32=1`: no stop).
    pub stops: Vec<usize>,
}

/// Interpret a whole program from the power-on state.
pub fn interpret_program(text: &str) -> Result<Program, GcodeError> {
    interpret_from(text, Modal::default())
}

/// Interpret a whole program from a given state (a machine's offsets, `$12`).
pub fn interpret_from(text: &str, mut modal: Modal) -> Result<Program, GcodeError> {
    let mut p = Program::default();
    let mut pending_stop = false;
    for (i, line) in text.lines().enumerate() {
        let clean = clean_line(line);
        // `%` opens and closes a program in many CAM outputs; Grbl answers it error:1 and
        // senders strip it, so the job as run has no such line.
        if clean == "%" {
            continue;
        }
        let before = modal;
        let done = step(&mut modal, line, i + 1)?;
        if p.moves.len() + done.moves.len() > MAX_MOVES {
            return Err(too_many_moves(i + 1));
        }
        // Grbl's planner syncs for this line (gcode.c): before its own motion for the spindle,
        // coolant, S, a dwell and EEPROM writes; after it for program flow and probes.
        let spindle = |m: &Modal| (m.spindle_on, m.spindle_on && m.dynamic);
        let sync_before = spindle(&before) != spindle(&modal)
            || before.coolant != modal.coolant
            || (before.s != modal.s && before.spindle_on && done.moves.is_empty())
            || done.dwell_s > 0.0
            || before.coords != modal.coords
            || before.g28 != modal.g28
            || before.g30 != modal.g30;
        pending_stop |= sync_before;
        if pending_stop && !done.moves.is_empty() {
            if !p.moves.is_empty() {
                p.stops.push(p.moves.len());
            }
            pending_stop = false;
        }
        pending_stop |= done.flow.is_some() || done.probe.is_some();
        p.moves.extend(done.moves);
        p.dwell_s += done.dwell_s;
        if done.dwell_s > 0.0 {
            p.dwells.push((p.moves.len(), done.dwell_s));
        }
        if done.flow == Some(Flow::Pause) {
            p.pauses.push(i + 1);
        }
    }
    Ok(p)
}

/// A program that makes more than [`MAX_MOVES`] moves, refused at `line`.
pub fn too_many_moves(line: usize) -> GcodeError {
    GcodeError::out_of_range(
        line,
        format!("the program makes more than {MAX_MOVES} moves"),
    )
}

/// Interpret a whole program into its moves.
pub fn interpret(text: &str) -> Result<Vec<Move>, GcodeError> {
    interpret_program(text).map(|p| p.moves)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_program() {
        let p = "G21 G90\nG0 X1 Y1\nM4 S500\nG1 X2 F600 ; cut\nY2\n(comment) G1 X1\nM5\nG0 X0 Y0\n";
        let m = interpret(p).unwrap();
        assert_eq!(m.len(), 5);
        assert!(m[0].rapid && m[0].power == 0.0);
        assert_eq!(m[1].to, [2.0, 1.0, 0.0]);
        assert_eq!(m[1].power, 500.0);
        assert_eq!(m[2].to, [2.0, 2.0, 0.0]);
        assert_eq!(m[3].to, [1.0, 2.0, 0.0]);
        assert_eq!(m[3].line, 6);
        assert_eq!(m[4].power, 0.0);
    }

    #[test]
    fn g1_without_feed_is_error_22() {
        let e = interpret("G1 X1").unwrap_err();
        assert_eq!(e.code, 22);
        assert_eq!(e.line, 1);
    }

    #[test]
    fn numbers_beyond_any_machine_are_refused_by_line() {
        let huge = "9".repeat(400);
        // A number too large to be one never reaches the parser: its line overflows Grbl's
        // line buffer first (error:11), said without quoting it.
        for p in [format!("G0 X1\nG0 X{huge}"), format!("G1 F{huge} X1")] {
            let e = interpret(&p).unwrap_err();
            let m = e.to_string();
            assert_eq!(e.code, 11, "{m}");
            assert!(m.contains("line buffer") && m.len() < 200, "{m}");
        }
        for (p, want) in [
            ("G0 X2000000".to_string(), "X 2000000 is beyond"),
            ("G20\nG0 Y50000".to_string(), "Y 1270000 is beyond"),
            (
                "G91\nG0 Z600000\nG0 Z600000".to_string(),
                "Z 1200000 is beyond",
            ),
            ("G1 F2000000 X1".to_string(), "feed 2000000 is beyond"),
            ("M3 S2000000".to_string(), "S 2000000 is beyond"),
        ] {
            let e = interpret(&p).unwrap_err();
            assert!(e.out_of_range, "{p}: {e}");
            let m = e.to_string();
            let line = p.lines().count();
            assert!(m.starts_with(&format!("line {line}: ")), "{m}");
            assert!(
                m.contains(want) && !m.contains("Grbl error") && m.len() < 200,
                "{m}"
            );
        }
        assert!(interpret("G0 X999999 Y-999999").is_ok());
    }

    fn cut_mm(p: &str, rule: Option<CutRule>) -> f64 {
        let m = interpret(p).unwrap();
        let rule = rule.unwrap_or_else(|| CutRule::infer(&m));
        m.iter()
            .filter(|mv| rule.cuts(mv))
            .map(|mv| ((mv.to[0] - mv.from[0]).powi(2) + (mv.to[1] - mv.from[1]).powi(2)).sqrt())
            .sum()
    }

    #[test]
    fn one_cut_rule_per_tool() {
        // Laser: only G1 with the beam on and S > 0; G0 is dark even with M4 on.
        let laser = "M4 S0 F1000\nG1 X10\nG1 X20 S500\nG0 X30\nG1 X40\nM5\nG1 X50\n";
        assert_eq!(CutRule::infer(&interpret(laser).unwrap()), CutRule::Spindle);
        assert_eq!(cut_mm(laser, None), 20.0);
        // Knife on Z, work zero on the sheet: X/Y moves at Z <= 0 cut, G0 too (the blade drags).
        let knife = "G0 Z3\nG0 X10\nG1 Z-0.3 F300\nG1 X20 F1000\nG0 X25\nG0 Z3\nG0 X0\n";
        assert_eq!(
            CutRule::infer(&interpret(knife).unwrap()),
            CutRule::ZDown {
                down_at_or_below: 0.0
            }
        );
        assert_eq!(cut_mm(knife, None), 15.0);
        // A plotter whose pen touches at Z5 and lifts to Z12: split at the widest gap.
        let high = "G0 Z12\nG0 X10\nG1 Z5 F300\nG1 X20 F1000\nG1 Z12\nG1 X0\n";
        assert_eq!(
            CutRule::infer(&interpret(high).unwrap()),
            CutRule::ZDown {
                down_at_or_below: 5.0
            }
        );
        assert_eq!(cut_mm(high, None), 10.0);
        // A servo pen on the spindle output: the profile says so; a G0 with the pen down draws.
        let servo = "M5 F1000\nG0 X10\nM3 S1000\nG1 X20\nG0 X30\nM5\nG0 X0\n";
        let rule = CutRule::infer(&interpret(servo).unwrap());
        assert_eq!(rule, CutRule::Spindle);
        assert_eq!(cut_mm(servo, Some(rule)), 10.0);
        assert_eq!(cut_mm(servo, Some(rule.for_spindle_pen())), 20.0);
        // Neither spindle nor Z: feed moves cut.
        assert_eq!(cut_mm("G1 X10 F100\nG0 X0\n", None), 10.0);
    }

    #[test]
    fn program_end_resets_what_grbl_resets() {
        let mut m = Modal::default();
        for l in ["G91 G0 X1", "M4 S300", "M2"] {
            step(&mut m, l, 1).unwrap();
        }
        assert!(!m.spindle_on && m.absolute && m.motion == MOTION_LINEAR);
        assert_eq!(m.s, 300.0, "S is kept");
    }

    #[test]
    fn extent_names_the_lines_reaching_farthest() {
        let e = extent(&interpret("G0 X5 Y-2\nG1 X612 F100\nG0 X0 Y0\n").unwrap()).unwrap();
        assert_eq!((e.min, e.max), ([0.0, -2.0], [612.0, 0.0]));
        assert_eq!((e.min_line, e.max_line), ([0, 1], [2, 0]));
        assert_eq!(extent(&[]), None);
    }

    #[test]
    fn unsupported_g5_is_error_20() {
        assert_eq!(interpret("G5 X1").unwrap_err().code, 20);
    }
}
