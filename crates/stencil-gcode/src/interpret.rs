//! A G-code interpreter for the subset Grbl 1.1 runs: one place that turns program text into moves.
//!
//! Used by the time estimate (`plan`), the simulator and the virtual Grbl, so all three agree on
//! what a program does.

use stencil_io::excerpt;

/// One straight move, in millimetres, absolute machine coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Move {
    pub from: [f64; 3],
    pub to: [f64; 3],
    /// G0: travel at the machine's rapid rate, laser off.
    pub rapid: bool,
    /// Programmed feed in mm/min (for G1); for G0 the last F seen (unused by Grbl).
    pub feed: f64,
    /// Spindle/laser S value while moving; 0 when the spindle is off (M5) or the move is G0.
    pub power: f64,
    /// The spindle output's S while this move runs, G0 or not; 0 when the spindle is off. A laser
    /// in laser mode stays dark in G0 (`power` is 0), but a pen servo on the spindle output stays
    /// down: [`CutRule`] tells the two apart.
    pub spindle_s: f64,
    /// 1-based line number in the program text.
    pub line: usize,
}

/// Modal state carried from line to line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Modal {
    pub pos: [f64; 3],
    /// 0 = G0, 1 = G1.
    pub motion: u8,
    pub absolute: bool,
    pub metric: bool,
    pub feed: Option<f64>,
    pub s: f64,
    /// M3/M4 on, M5 off.
    pub spindle_on: bool,
    /// The last spindle command was M4 (laser mode: power scaled with speed) rather than M3.
    pub dynamic: bool,
    /// Coolant output on (M8, flood: air assist on a laser), off with M9.
    pub coolant: bool,
}

impl Default for Modal {
    fn default() -> Self {
        Modal {
            pos: [0.0; 3],
            motion: 0,
            absolute: true,
            metric: true,
            feed: None,
            s: 0.0,
            spindle_on: false,
            dynamic: false,
            coolant: false,
        }
    }
}

/// The largest coordinate (absolute value, mm, after inches are converted) a program may reach:
/// 1 km, more than any machine's travel. Beyond it estimates overflow into nonsense (a 400-digit
/// number reads as infinity).
pub const MAX_COORD_MM: f64 = 1e6;

/// The largest feed (mm/min) and S value a program may give: far above any machine's.
pub const MAX_FEED_MM_MIN: f64 = 1e6;
pub const MAX_S: f64 = 1e6;

/// A line the interpreter cannot run, with Grbl's error code where Grbl has one.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("line {line}: {msg}{}", if *out_of_range { String::new() } else { format!(" (Grbl error:{code})") })]
pub struct GcodeError {
    pub line: usize,
    pub code: u8,
    pub msg: String,
    /// A number beyond what any machine can do ([`MAX_COORD_MM`], [`MAX_FEED_MM_MIN`],
    /// [`MAX_S`]), or not finite: the program is refused whole, not passed on to Grbl.
    pub out_of_range: bool,
}

/// Strip a `;` comment and `( )` comments, spaces, and upper-case: what Grbl keeps of a line.
pub fn clean_line(line: &str) -> String {
    let mut out = String::with_capacity(line.len());
    let mut in_paren = false;
    for c in line.chars() {
        match c {
            '(' => in_paren = true,
            ')' if in_paren => in_paren = false,
            ';' if !in_paren => break,
            c if in_paren || c.is_whitespace() || c.is_control() => {}
            c => out.push(c.to_ascii_uppercase()),
        }
    }
    out
}

/// Split a cleaned line into (letter, value) words.
pub fn words(clean: &str, line_no: usize) -> Result<Vec<(char, f64)>, GcodeError> {
    let mut out = Vec::new();
    let b = clean.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let letter = b[i] as char;
        if !letter.is_ascii_alphabetic() {
            return Err(GcodeError {
                line: line_no,
                code: 1,
                msg: format!("expected a letter at '{}'", excerpt(&clean[i..])),
                out_of_range: false,
            });
        }
        let start = i + 1;
        let mut j = start;
        while j < b.len() && (b[j].is_ascii_digit() || b[j] == b'.' || b[j] == b'-' || b[j] == b'+')
        {
            j += 1;
        }
        let text = &clean[start..j];
        let v: f64 = text.parse().map_err(|_| GcodeError {
            line: line_no,
            code: 2,
            msg: format!("'{letter}' has no valid number"),
            out_of_range: false,
        })?;
        if !v.is_finite() {
            return Err(GcodeError {
                line: line_no,
                code: 2,
                msg: format!(
                    "the number after '{letter}' ({}) is too large to be a number",
                    excerpt(text)
                ),
                out_of_range: true,
            });
        }
        out.push((letter, v));
        i = j;
    }
    Ok(out)
}

/// Run one line against the modal state; return the move it makes, if any.
/// `$`-commands and empty lines do nothing here.
pub fn step(modal: &mut Modal, line: &str, line_no: usize) -> Result<Option<Move>, GcodeError> {
    let clean = clean_line(line);
    if clean.is_empty() || clean.starts_with('$') {
        return Ok(None);
    }
    let ws = words(&clean, line_no)?;
    let mut line_words = LineWords::default();
    for &(l, v) in &ws {
        match l {
            'G' => g_word(modal, &mut line_words, v, line_no)?,
            'M' => m_word(modal, &mut line_words, v, line_no)?,
            'F' => f_word(modal, v, line_no)?,
            'S' => s_word(modal, v, line_no)?,
            'X' => line_words.target[0] = Some(v),
            'Y' => line_words.target[1] = Some(v),
            'Z' => line_words.target[2] = Some(v),
            'N' => {}
            l => return Err(refused(line_no, 20, format!("word '{l}' is not supported"))),
        }
    }
    if let Some(m) = line_words.motion {
        modal.motion = m;
    }
    if line_words.target.iter().all(Option::is_none) {
        if line_words.program_end {
            end_program(modal);
        }
        return Ok(None);
    }
    if modal.motion == 1 && modal.feed.is_none() {
        return Err(refused(
            line_no,
            22,
            "G1 before any F: the feed rate is undefined".into(),
        ));
    }
    let from = modal.pos;
    let to = resolve_target(modal, &line_words.target, line_no)?;
    modal.pos = to;
    let rapid = modal.motion == 0;
    let spindle_s = if modal.spindle_on { modal.s } else { 0.0 };
    let mv = Move {
        from,
        to,
        rapid,
        feed: modal.feed.unwrap_or(0.0),
        power: if rapid { 0.0 } else { spindle_s },
        spindle_s,
        line: line_no,
    };
    if line_words.program_end {
        end_program(modal);
    }
    Ok(Some(mv))
}

/// What one line asks for that takes effect only once all its words are read: the axis words
/// (as written, in the line's units and distance mode), the motion mode and a program end.
/// Grbl applies a line's words as a block, not left to right, so `X10 G0` moves in G0.
#[derive(Default)]
struct LineWords {
    target: [Option<f64>; 3],
    motion: Option<u8>,
    program_end: bool,
}

/// A line Grbl itself would refuse, with Grbl's error code.
fn refused(line: usize, code: u8, msg: String) -> GcodeError {
    GcodeError {
        line,
        code,
        msg,
        out_of_range: false,
    }
}

/// A number beyond [`MAX_COORD_MM`], [`MAX_FEED_MM_MIN`] or [`MAX_S`]: the program is refused
/// whole. Huge values are shown in scientific notation so the message stays one short line.
fn beyond(line: usize, what: &str, v: f64, max: f64, unit: &str) -> GcodeError {
    GcodeError {
        line,
        code: 2,
        msg: format!(
            "{what} {} is beyond what any machine does (at most {max}{unit})",
            if v.abs() < 1e9 {
                v.to_string()
            } else {
                format!("{v:.3e}")
            }
        ),
        out_of_range: true,
    }
}

/// A `G` word: motion mode (G0/G1, applied after the line), distance mode (G90/G91) and units
/// (G21/G20) at once; the modal groups that never move the tool are accepted and ignored.
fn g_word(
    modal: &mut Modal,
    line_words: &mut LineWords,
    v: f64,
    line_no: usize,
) -> Result<(), GcodeError> {
    match v {
        0.0 => line_words.motion = Some(0),
        1.0 => line_words.motion = Some(1),
        90.0 => modal.absolute = true,
        91.0 => modal.absolute = false,
        21.0 => modal.metric = true,
        20.0 => modal.metric = false,
        // Plane selection, feed-rate mode, work coordinate systems, cancel modes: no motion.
        v if [17.0, 94.0, 54.0, 40.0, 49.0, 80.0].contains(&v) => {}
        v => {
            return Err(refused(
                line_no,
                20,
                format!("G{v} is not supported by this program subset"),
            ))
        }
    }
    Ok(())
}

/// An `M` word: spindle (M3/M4/M5, M4 being laser mode), coolant (M8/M9, air assist on a laser)
/// and program end (M2/M30, applied after the line's motion, as Grbl does).
fn m_word(
    modal: &mut Modal,
    line_words: &mut LineWords,
    v: f64,
    line_no: usize,
) -> Result<(), GcodeError> {
    match v as u32 {
        3 | 4 => {
            modal.spindle_on = true;
            modal.dynamic = v as u32 == 4;
        }
        5 => modal.spindle_on = false,
        8 => modal.coolant = true,
        9 => modal.coolant = false,
        2 | 30 => line_words.program_end = true,
        0 | 1 | 7 => {}
        _ => return Err(refused(line_no, 20, format!("M{v} is not supported"))),
    }
    Ok(())
}

/// An `F` word: the feed, kept in mm/min whatever the line's units, so every later move and the
/// estimate read one unit.
fn f_word(modal: &mut Modal, v: f64, line_no: usize) -> Result<(), GcodeError> {
    if v <= 0.0 {
        return Err(refused(line_no, 4, "F must be positive".into()));
    }
    let f = if modal.metric { v } else { v * 25.4 };
    if f > MAX_FEED_MM_MIN {
        return Err(beyond(line_no, "feed", f, MAX_FEED_MM_MIN, " mm/min"));
    }
    modal.feed = Some(f);
    Ok(())
}

/// An `S` word: the spindle/laser value, used by the following moves while the spindle is on.
fn s_word(modal: &mut Modal, v: f64, line_no: usize) -> Result<(), GcodeError> {
    if v < 0.0 {
        return Err(refused(line_no, 4, "S must not be negative".into()));
    }
    if v > MAX_S {
        return Err(beyond(line_no, "S", v, MAX_S, ""));
    }
    modal.s = v;
    Ok(())
}

/// The line's axis words as an absolute position in mm: inches converted, G91 offsets added to
/// the current position, unnamed axes kept. Refuses a position beyond [`MAX_COORD_MM`].
fn resolve_target(
    modal: &Modal,
    target: &[Option<f64>; 3],
    line_no: usize,
) -> Result<[f64; 3], GcodeError> {
    let unit = if modal.metric { 1.0 } else { 25.4 };
    let from = modal.pos;
    let mut to = from;
    for a in 0..3 {
        if let Some(v) = target[a] {
            to[a] = if modal.absolute {
                v * unit
            } else {
                from[a] + v * unit
            };
            if to[a].abs() > MAX_COORD_MM {
                let axis = ["X", "Y", "Z"][a];
                return Err(beyond(line_no, axis, to[a], MAX_COORD_MM, " mm"));
            }
        }
    }
    Ok(to)
}

/// `M2` / `M30`: what Grbl 1.1 resets at a program end (gcode.c, `PROGRAM_FLOW_COMPLETED`):
/// G1, G90, G94, spindle off (M5) and coolant off (M9); F and S are kept.
fn end_program(modal: &mut Modal) {
    modal.motion = 1;
    modal.absolute = true;
    modal.spindle_on = false;
    modal.coolant = false;
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
    ZDown { down_at_or_below: f64 },
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
    pub min: [f64; 2],
    pub max: [f64; 2],
    /// The line of the move that reaches `min[axis]` / `max[axis]` (0: the start position).
    pub min_line: [usize; 2],
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

/// Interpret a whole program into its moves.
pub fn interpret(text: &str) -> Result<Vec<Move>, GcodeError> {
    let mut modal = Modal::default();
    let mut moves = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if let Some(m) = step(&mut modal, line, i + 1)? {
            moves.push(m);
        }
    }
    Ok(moves)
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
        for (p, want) in [
            (format!("G0 X1\nG0 X{huge}"), "too large"),
            (format!("G1 F{huge} X1"), "too large"),
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
        assert!(!m.spindle_on && m.absolute && m.motion == 1);
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
