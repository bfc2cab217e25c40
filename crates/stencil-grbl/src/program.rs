//! A G-code program made ready for Grbl: cleaned and vetted line by line before anything is sent,
//! with its moves (for the time estimate) and the state preamble that resumes it mid-way.

use super::error::{MachineChange, MachineError};
use super::protocol;
use stencil_gcode::interpret::{self as gcode, CutRule, Modal, Move};
use stencil_gcode::limits::MAX_LINE_BYTES;
use stencil_gcode::num;

/// One line to send: its text as Grbl will see it, and where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct ProgramLine {
    /// 1-based line number in the file.
    pub number: usize,
    /// Cleaned text (no comments, no spaces, upper case), without the newline.
    pub text: String,
    /// The line makes a move (or might: lines our interpreter cannot read count as moves).
    pub motion: bool,
}

/// A program ready to stream: vetted, cleaned, with its moves for the time estimate.
#[derive(Clone, Debug)]
pub struct Program {
    /// File name for messages.
    pub name: String,
    /// The lines to stream, in order.
    pub lines: Vec<ProgramLine>,
    /// Moves as our interpreter reads them (lines it cannot read are skipped).
    pub moves: Vec<Move>,
    /// The program may end with the laser still switched on (no final M5, or lines our
    /// interpreter cannot follow): the streamer then sends M5 itself.
    pub may_end_laser_on: bool,
    /// The program may end with the coolant output (air assist) still on: the streamer then
    /// sends M9 itself.
    pub may_end_air_on: bool,
    /// Lines that would change the machine rather than cut: refused by `send` unless the person
    /// asked for them (`StreamConfig::allow_machine_commands`).
    pub machine_changes: Vec<MachineChange>,
    /// Read-only `$` queries (`$$`, `$#`, `$G`, `$I`, `$N`): left out of the stream.
    pub dropped: Vec<ProgramLine>,
    /// `%` lines left out (the program delimiters of other controllers; Grbl 1.1 answers them
    /// `error:1`, so senders strip them).
    pub dropped_percent: usize,
    /// Lines with M0: Grbl finishes the queued motion there and holds until cycle start (`~`).
    pub pauses: Vec<usize>,
    /// The parser state the program runs from: the controller's work systems and G92 as the
    /// job's placement leaves them ([`crate::placement::Placement`]); the power-on state when
    /// no placement is given. Its moves are machine coordinates from here.
    pub start: Modal,
    source: Vec<String>,
}

/// The N number a cleaned line starts with (`N120G1X5` → 120).
pub(crate) fn n_word(text: &str) -> Option<u32> {
    let rest = text.strip_prefix('N')?;
    let end = rest
        .find(|c: char| !c.is_ascii_digit())
        .unwrap_or(rest.len());
    rest[..end].parse().ok()
}

/// The read-only `$` queries: they change nothing, and a sender does not stream them.
const QUERIES: [&str; 5] = ["$$", "$#", "$G", "$I", "$N"];

/// What a cleaned line does to the machine itself, if anything (see [`MachineChange`]).
pub fn machine_change(clean: &str) -> Option<String> {
    if let Some(rest) = clean.strip_prefix('$') {
        if QUERIES.contains(&clean) {
            return None;
        }
        let what = match rest {
            "H" => "homes the machine ($H)".to_string(),
            "X" => "unlocks an alarm ($X)".to_string(),
            "C" => "switches check mode ($C)".to_string(),
            "SLP" => "puts Grbl to sleep ($SLP)".to_string(),
            r if r.starts_with("J=") => "jogs the machine ($J=)".to_string(),
            r if r.starts_with("RST=") => "erases Grbl's settings ($RST=)".to_string(),
            r if r.starts_with('N') && r[1..].contains('=') => {
                "stores a startup line ($Nx=)".to_string()
            }
            r => match r.split_once('=') {
                Some((k, _)) if k.parse::<u32>().is_ok() => format!("writes Grbl setting ${k}"),
                _ => format!("is a Grbl system command ({clean})"),
            },
        };
        return Some(what);
    }
    let words = gcode::words(clean, 0).ok()?;
    let g = |v: f64| words.iter().any(|&(l, x)| l == 'G' && (x - v).abs() < 1e-9);
    let l = words.iter().find(|(w, _)| *w == 'L').map(|&(_, v)| v);
    if g(10.0) && matches!(l, Some(x) if x == 2.0 || x == 20.0) {
        return Some("writes a stored work offset (G10 L2/L20)".to_string());
    }
    if g(28.1) || g(30.1) {
        return Some("stores a G28/G30 position (G28.1/G30.1)".to_string());
    }
    None
}

/// The rectangle of the cutting moves, mm, as the interpreter places them: machine coordinates
/// from a zero work offset, the job's own offsets (G10, G92, G54..G59) applied and arcs
/// followed to their true extent. The frame program traces it in the controller's work
/// coordinates, which are those when its work offset is zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extent {
    /// Lowest X and Y, mm.
    pub min: [f64; 2],
    /// Highest X and Y, mm.
    pub max: [f64; 2],
    /// Cutting moves that made it.
    pub moves: usize,
}

impl Extent {
    /// Size along X, mm.
    pub fn width(&self) -> f64 {
        self.max[0] - self.min[0]
    }
    /// Size along Y, mm.
    pub fn height(&self) -> f64 {
        self.max[1] - self.min[1]
    }
}

/// The extent of the cutting moves, by the rule the program itself shows
/// ([`CutRule::infer`], the rule `simulate` and `estimate` use); `None` when nothing cuts.
pub fn cut_extent(moves: &[Move]) -> Option<Extent> {
    cut_extent_with(moves, CutRule::infer(moves))
}

/// [`cut_extent`] by a given rule (a machine profile's, e.g. a servo pen drawing in G0).
pub fn cut_extent_with(moves: &[Move], rule: CutRule) -> Option<Extent> {
    let mut e: Option<Extent> = None;
    for m in moves.iter().filter(|m| rule.cuts(m)) {
        let x = e.get_or_insert(Extent {
            min: [m.from[0], m.from[1]],
            max: [m.from[0], m.from[1]],
            moves: 0,
        });
        for p in [m.from, m.to] {
            for (a, &v) in p.iter().take(2).enumerate() {
                x.min[a] = x.min[a].min(v);
                x.max[a] = x.max[a].max(v);
            }
        }
        x.moves += 1;
    }
    e
}

impl Program {
    /// Clean and vet a program before anything is sent: every line must fit Grbl's line buffer and
    /// hold only printable ASCII without real-time characters (which Grbl would act on mid-line).
    pub fn parse(name: &str, text: &str) -> Result<Program, MachineError> {
        Program::parse_from(name, text, Modal::default())
    }

    /// [`Program::parse`] from a given parser state: the controller's offsets once the job is
    /// placed, so that its moves (for the bed check, the frame, the estimate and a resume's
    /// position checks) are where the machine will go.
    pub fn parse_from(name: &str, text: &str, start: Modal) -> Result<Program, MachineError> {
        let mut lines = Vec::new();
        let mut moves = Vec::new();
        let mut modal = start;
        let mut unreadable = false;
        let (mut machine_changes, mut dropped) = (Vec::new(), Vec::new());
        let mut dropped_percent = 0;
        let mut pauses = Vec::new();
        let source: Vec<String> = text.lines().map(str::to_string).collect();
        for (i, raw) in source.iter().enumerate() {
            let number = i + 1;
            let clean = gcode::clean_line(raw);
            // `%` marks the start and end of a program in many CAM outputs; Grbl 1.1 does not
            // take it (error:1), so senders drop it.
            if clean == "%" {
                dropped_percent += 1;
                continue;
            }
            if clean.is_empty() {
                continue;
            }
            if let Some(c) = clean
                .chars()
                .find(|&c| !c.is_ascii_graphic() || protocol::is_realtime(c as u32 as u8))
            {
                return Err(MachineError::BadChar {
                    file: name.to_string(),
                    line: number,
                    ch: c,
                });
            }
            if clean.len() > MAX_LINE_BYTES {
                return Err(MachineError::LineTooLong {
                    file: name.to_string(),
                    line: number,
                    len: clean.len(),
                });
            }
            if QUERIES.contains(&clean.as_str()) {
                dropped.push(ProgramLine {
                    number,
                    text: clean,
                    motion: false,
                });
                continue;
            }
            if let Some(what) = machine_change(&clean) {
                machine_changes.push(MachineChange {
                    line: number,
                    text: clean.clone(),
                    what,
                });
            }
            let mut m = modal;
            let motion = match gcode::step(&mut m, &clean, number) {
                Ok(done) if moves.len() + done.moves.len() > gcode::MAX_MOVES => {
                    return Err(MachineError::Gcode {
                        file: name.to_string(),
                        cause: gcode::too_many_moves(number),
                    })
                }
                Ok(done) => {
                    modal = m;
                    if done.flow == Some(gcode::Flow::Pause) {
                        pauses.push(number);
                    }
                    let moved = !done.moves.is_empty();
                    moves.extend(done.moves);
                    moved
                }
                // A number no machine can do is refused before anything is sent; a line our
                // subset does not know is left for Grbl to judge.
                Err(cause) if cause.out_of_range => {
                    return Err(MachineError::Gcode {
                        file: name.to_string(),
                        cause,
                    })
                }
                Err(_) => {
                    unreadable = true;
                    !clean.starts_with('$')
                }
            };
            lines.push(ProgramLine {
                number,
                text: clean,
                motion,
            });
        }
        Ok(Program {
            name: name.to_string(),
            lines,
            moves,
            may_end_laser_on: modal.spindle_on || unreadable,
            may_end_air_on: modal.coolant || unreadable,
            machine_changes,
            dropped,
            dropped_percent,
            pauses,
            start,
            source,
        })
    }

    /// The job's start corner: the lowest X and Y of what it cuts (the extent a frame traces,
    /// [`cut_extent`]), in the job's coordinates; the lowest of all its moves
    /// when nothing cuts, the origin when nothing moves.
    pub fn start_corner(&self) -> [f64; 2] {
        // The moves are machine coordinates from the placed start: back to the job's own.
        let w = self.start.wco();
        if let Some(e) = cut_extent(&self.moves) {
            return [e.min[0] - w[0], e.min[1] - w[1]];
        }
        let points = self.moves.iter().flat_map(|m| [m.from, m.to]);
        let c = points.fold([f64::INFINITY; 2], |c, p| [c[0].min(p[0]), c[1].min(p[1])]);
        if c[0].is_finite() {
            [c[0] - w[0], c[1] - w[1]]
        } else {
            [0.0; 2]
        }
    }

    /// Lines in the file (comments and blank lines included): line numbers run 1..=this.
    pub fn source_lines(&self) -> usize {
        self.source.len()
    }

    /// Lines that restore, before line `from_line`, the state the program had built up, with the
    /// tool lift read from the program alone (see [`Program::resume_preamble_with`]).
    pub fn resume_preamble(&self, from_line: usize) -> Result<Vec<String>, MachineError> {
        self.resume_preamble_with(from_line, &ResumeLift::default())
    }

    /// Lines that restore, before line `from_line`, the state the program had built up: tool off
    /// (`M5`: laser off, a servo pen up), mm and absolute, then a tool on Z is lifted first
    /// (`G0 Z<up>`), travels in XY (`G0 X Y`), and is lowered only there at the plunge feed
    /// (`G1 Z<down> F<plunge>`): one `G0 X Y Z` would drag a knife left down through the sheet and
    /// push a blade from Z0 below the surface on the way. Then feed, motion mode, units, distance
    /// mode, coolant (air assist), and last the spindle/laser state (a servo pen goes down there).
    pub fn resume_preamble_with(
        &self,
        from_line: usize,
        lift: &ResumeLift,
    ) -> Result<Vec<String>, MachineError> {
        if from_line == 0 || from_line > self.source.len() {
            return Err(MachineError::FromLine {
                file: self.name.clone(),
                line: from_line,
                total: self.source.len(),
            });
        }
        let st = self.state_before(from_line)?;
        if from_line == 1 {
            return Ok(Vec::new());
        }
        let modal = st.modal;
        // The interpreter's position is in machine coordinates; the preamble moves in the
        // work coordinates of the line it resumes (the same when the job sets no offsets).
        let wco = modal.wco();
        let work = |a: usize| modal.pos[a] - wco[a];
        let mut out = vec!["M5".to_string(), "G21G90".to_string()];
        // The height to travel at: the profile's, or the highest Z the program itself had reached
        // (its own travel height), whichever is higher.
        let z_restore = st.used[2].then(|| {
            let up = lift.z_up_mm.map_or(st.max_z, |u| u.max(st.max_z));
            (up, work(2))
        });
        if let Some((up, _)) = z_restore {
            out.push(format!("G0Z{}", num(up)));
        }
        let mut travel = String::from("G0");
        for (a, letter) in "XY".chars().enumerate() {
            if st.used[a] {
                travel.push_str(&format!("{letter}{}", num(work(a))));
            }
        }
        if travel.len() > 2 {
            out.push(travel);
        }
        if let Some((up, z)) = z_restore {
            if z < up {
                match lift.plunge_mm_min.or(st.plunge_feed).or(modal.feed) {
                    Some(f) => out.push(format!("G1Z{}F{}", num(z), num(f))),
                    // The program never gave a feed: it only ever moved with G0.
                    None => out.push(format!("G0Z{}", num(z))),
                }
            }
        }
        if let Some(f) = modal.feed {
            out.push(format!("F{}", num(f)));
        }
        if modal.motion == 1 {
            out.push("G1".into());
        }
        if !modal.metric {
            out.push("G20".into());
        }
        if !modal.absolute {
            out.push("G91".into());
        }
        if modal.coolant {
            out.push("M8".into());
        }
        if modal.spindle_on {
            let m = if modal.dynamic { "M4" } else { "M3" };
            out.push(format!("{m}S{}", num(modal.s)));
        } else if modal.s > 0.0 {
            out.push(format!("S{}", num(modal.s)));
        }
        Ok(out)
    }

    /// The modal state the program has built up before line `before` (1-based), with what a
    /// restore needs to know about how it got there.
    pub fn state_before(&self, before: usize) -> Result<StateBefore, MachineError> {
        let mut st = StateBefore {
            modal: self.start,
            used: [false; 3],
            max_z: f64::NEG_INFINITY,
            plunge_feed: None,
        };
        for (i, raw) in self
            .source
            .iter()
            .enumerate()
            .take(before.saturating_sub(1))
        {
            let clean = gcode::clean_line(raw);
            if clean == "%" {
                continue;
            }
            let done = gcode::step(&mut st.modal, &clean, i + 1).map_err(|e| {
                MachineError::ResumeState {
                    file: self.name.clone(),
                    from_line: before,
                    cause: e,
                }
            })?;
            for (l, _) in gcode::words(&clean, i + 1).unwrap_or_default() {
                if let Some(a) = "XYZ".find(l) {
                    st.used[a] = true;
                }
            }
            for mv in done.moves {
                st.max_z = st.max_z.max(mv.to[2]).max(mv.from[2]);
                let z_only = mv.from[0] == mv.to[0] && mv.from[1] == mv.to[1];
                if z_only && mv.to[2] < mv.from[2] && !mv.rapid {
                    st.plunge_feed = Some(mv.feed);
                }
            }
        }
        if !st.max_z.is_finite() {
            st.max_z = st.modal.pos[2];
        }
        Ok(st)
    }
}

/// How the machine lifts its tool, as far as a resume needs it. The machine side knows no
/// profiles: the caller fills this from one (or leaves it empty, and the program is read).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ResumeLift {
    /// Z clear of the work (a pen or knife lifted), mm; the restore travels at this height or
    /// the highest Z the program reached before, whichever is higher.
    pub z_up_mm: Option<f64>,
    /// Feed for lowering the tool back to the resume line's Z, mm/min; without it, the feed of
    /// the program's last Z-only feed move down, else its feed.
    pub plunge_mm_min: Option<f64>,
}

/// The state a program has built up before some line (see [`Program::state_before`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StateBefore {
    /// The modal state (units, distance mode, feed, spindle, offsets).
    pub modal: Modal,
    /// Axes the program has named.
    pub used: [bool; 3],
    /// The highest Z any move reached (its own travel height); the current Z if none moved.
    pub max_z: f64,
    /// Feed of the last Z-only feed move down (a plunge).
    pub plunge_feed: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn job_refuses_long_lines_and_realtime_characters() {
        let long = format!("G1X1Y1 ; ok\n(c)\nG1X{}\n", "1".repeat(80));
        match Program::parse("a.gcode", &long) {
            Err(MachineError::LineTooLong {
                line: 3, len: 83, ..
            }) => {}
            other => panic!("{other:?}"),
        }
        let e = Program::parse("a.gcode", "G0X1\nG1X2?F100\n").unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
        // 79 characters fit Grbl's line buffer, 80 do not.
        assert!(Program::parse("a.gcode", &format!("G0X1.{}\n", "1".repeat(74))).is_ok());
        assert!(Program::parse("a.gcode", &format!("G0X1.{}\n", "1".repeat(75))).is_err());
        // A number no machine reaches is refused before anything is sent, naming its line.
        let e = Program::parse("a.gcode", &format!("G0X1\nG0X{}\n", "1".repeat(70))).unwrap_err();
        assert!(matches!(e, MachineError::Gcode { .. }), "{e}");
        assert!(
            e.to_string()
                .starts_with("a.gcode: line 2: X 1.111e69 is beyond"),
            "{e}"
        );
        // Comments and spaces do not count.
        let ok = format!("G1 X1 ({})\n", "c".repeat(100));
        let j = Program::parse("a.gcode", &ok).unwrap();
        assert_eq!(j.lines[0].text, "G1X1");
    }

    #[test]
    fn preamble_restores_state() {
        let p = "G21 G90\nM4 S300\nG0 X10 Y5\nG1 X20 F600\nG91\nX1\n";
        let j = Program::parse("p", p).unwrap();
        let pre = j.resume_preamble(6).unwrap();
        assert_eq!(
            pre,
            vec!["M5", "G21G90", "G0X20Y5", "F600", "G1", "G91", "M4S300"]
        );
        assert!(j.resume_preamble(1).unwrap().is_empty());
        assert!(j.resume_preamble(99).is_err());
        // Inches: travel in mm, feed in mm/min, then back to G20.
        let p = "G20\nG0 X1\nM3 S100\nG1 Y1 F10\nY2\n";
        let pre = Program::parse("p", p).unwrap().resume_preamble(5).unwrap();
        assert_eq!(
            pre,
            vec![
                "M5",
                "G21G90",
                "G0X25.4Y25.4",
                "F254",
                "G1",
                "G20",
                "M3S100"
            ]
        );
        // Running the preamble then the rest lands where the whole program does.
        let whole = gcode::interpret(p).unwrap();
        let mut m = Modal::default();
        for l in pre.iter().map(String::as_str).chain(["Y2"]) {
            gcode::step(&mut m, l, 0).unwrap();
        }
        assert_eq!(m.pos, whole.last().unwrap().to);
        assert!(m.spindle_on && !m.dynamic && !m.metric);
    }

    #[test]
    fn preamble_lifts_a_z_tool_before_travel_and_plunges_after() {
        // A knife job: travel at Z3, plunge to -0.3 at F300, cut at F1200, air on.
        let p = "G21 G90\nM8\nG0 Z3 F1200\nG0 X10 Y10\nG1 Z-0.3 F300\nG1 X20 F1200\nX30\n";
        let j = Program::parse("k", p).unwrap();
        assert_eq!(
            j.resume_preamble(7).unwrap(),
            vec![
                "M5",
                "G21G90",
                "G0Z3",
                "G0X20Y10",
                "G1Z-0.3F300",
                "F1200",
                "G1",
                "M8"
            ]
        );
        // The profile's up height wins when higher; its plunge feed is used.
        let lift = ResumeLift {
            z_up_mm: Some(5.0),
            plunge_mm_min: Some(150.0),
        };
        let pre = j.resume_preamble_with(7, &lift).unwrap();
        assert_eq!(pre[2..5], ["G0Z5", "G0X20Y10", "G1Z-0.3F150"]);
        // Resuming where the program had the tool up at Z3: back to its own Z3 after the travel.
        let pre = j.resume_preamble_with(5, &lift).unwrap();
        assert_eq!(pre[2..5], ["G0Z5", "G0X10Y10", "G1Z3F150"]);
        // Without the profile, the program's travel height: no Z move after the travel.
        let pre = j.resume_preamble(5).unwrap();
        assert_eq!(pre[2..5], ["G0Z3", "G0X10Y10", "F1200"]);
        // The program's state at a line.
        let st = j.state_before(7).unwrap();
        assert_eq!((st.max_z, st.plunge_feed), (3.0, Some(300.0)));
        assert!(st.modal.coolant);
        assert!(j.may_end_air_on && !j.may_end_laser_on);
    }

    #[test]
    fn preamble_numbers_are_the_writers_micrometres() {
        // The restore is written as the G-code writer writes numbers: mm to 3 decimals (Grbl's
        // own precision in mm), no trailing zeros, no `-0`.
        let p = "G21 G90\nG0 X1.23456 Y-0.00001 F600.00\nG1 X2\n";
        let pre = Program::parse("p", p).unwrap().resume_preamble(3).unwrap();
        assert_eq!(pre, vec!["M5", "G21G90", "G0X1.235Y0", "F600"]);
    }
}
