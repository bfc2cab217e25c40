//! A G-code interpreter for the subset Grbl 1.1 runs: one place that turns program text into moves.
//!
//! Used by the time estimate (`plan`), the simulator and the virtual Grbl, so all three agree on
//! what a program does.

use crate::text::excerpt;

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
    let err = |code: u8, msg: String| GcodeError {
        line: line_no,
        code,
        msg,
        out_of_range: false,
    };
    let range = |what: &str, v: f64, max: f64, unit: &str| GcodeError {
        line: line_no,
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
    };
    let mut target = [None::<f64>; 3];
    let mut motion = None;
    for &(l, v) in &ws {
        match l {
            'G' => match v {
                v if v == 0.0 => motion = Some(0),
                v if v == 1.0 => motion = Some(1),
                v if v == 90.0 => modal.absolute = true,
                v if v == 91.0 => modal.absolute = false,
                v if v == 21.0 => modal.metric = true,
                v if v == 20.0 => modal.metric = false,
                // Plane selection, feed-rate mode, work coordinate systems, cancel modes: no motion.
                v if [17.0, 94.0, 54.0, 40.0, 49.0, 80.0].contains(&v) => {}
                v => {
                    return Err(err(
                        20,
                        format!("G{v} is not supported by this program subset"),
                    ))
                }
            },
            'M' => match v as u32 {
                3 | 4 => {
                    modal.spindle_on = true;
                    modal.dynamic = v as u32 == 4;
                }
                5 => modal.spindle_on = false,
                8 => modal.coolant = true,
                9 => modal.coolant = false,
                // Grbl ends a program (M2/M30) with the spindle and coolant off.
                2 | 30 => {
                    modal.spindle_on = false;
                    modal.coolant = false;
                }
                0 | 1 => {}
                _ => return Err(err(20, format!("M{v} is not supported"))),
            },
            'F' => {
                if v <= 0.0 {
                    return Err(err(4, "F must be positive".into()));
                }
                let f = if modal.metric { v } else { v * 25.4 };
                if f > MAX_FEED_MM_MIN {
                    return Err(range("feed", f, MAX_FEED_MM_MIN, " mm/min"));
                }
                modal.feed = Some(f);
            }
            'S' => {
                if v < 0.0 {
                    return Err(err(4, "S must not be negative".into()));
                }
                if v > MAX_S {
                    return Err(range("S", v, MAX_S, ""));
                }
                modal.s = v;
            }
            'X' => target[0] = Some(v),
            'Y' => target[1] = Some(v),
            'Z' => target[2] = Some(v),
            'N' => {}
            l => return Err(err(20, format!("word '{l}' is not supported"))),
        }
    }
    if let Some(m) = motion {
        modal.motion = m;
    }
    if target.iter().all(Option::is_none) {
        return Ok(None);
    }
    if modal.motion == 1 && modal.feed.is_none() {
        return Err(err(
            22,
            "G1 before any F: the feed rate is undefined".into(),
        ));
    }
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
                return Err(range(axis, to[a], MAX_COORD_MM, " mm"));
            }
        }
    }
    modal.pos = to;
    let rapid = modal.motion == 0;
    Ok(Some(Move {
        from,
        to,
        rapid,
        feed: modal.feed.unwrap_or(0.0),
        power: if modal.spindle_on && !rapid {
            modal.s
        } else {
            0.0
        },
        line: line_no,
    }))
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

    #[test]
    fn unsupported_g5_is_error_20() {
        assert_eq!(interpret("G5 X1").unwrap_err().code, 20);
    }
}
