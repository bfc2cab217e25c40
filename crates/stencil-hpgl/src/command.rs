//! HP-GL instructions as data: the ones the writer emits, written one per line; and a parser of
//! any HP-GL text into instructions, for the virtual cutter, `estimate` and `simulate`.
//!
//! HP-GL syntax: a two-letter mnemonic (either case), then parameters separated by commas or
//! spaces, ended by `;` (or by the next mnemonic). Whitespace and line ends between instructions
//! are ignored. Device-control sequences start with ESC `.` and a letter (`ESC.K` clears the
//! buffer on HP plotters and the cutters that copy them).

use std::fmt;

/// One instruction.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// `IN`: initialise (pen up, defaults, absolute plotting).
    In,
    /// `SP n`: select pen (tool) `n`; 0 puts the pen away.
    Sp(u32),
    /// `VS v`: speed with the pen (knife) down, cm/s.
    Vs(f64),
    /// `FS f`: blade force, in the plotter's units.
    Fs(i64),
    /// `PA`: absolute plotting, with optional points.
    Pa(Vec<[i64; 2]>),
    /// `PU`: pen up, then move through the points.
    Pu(Vec<[i64; 2]>),
    /// `PD`: pen down, then move through the points.
    Pd(Vec<[i64; 2]>),
    /// Any other instruction: its mnemonic (upper case) and parameters as written.
    Other(String, String),
    /// A device-control sequence `ESC . c ...` (its letter).
    Device(char),
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let pts = |f: &mut fmt::Formatter<'_>, m: &str, p: &[[i64; 2]]| {
            f.write_str(m)?;
            for (i, q) in p.iter().enumerate() {
                if i > 0 {
                    f.write_str(",")?;
                }
                write!(f, "{},{}", q[0], q[1])?;
            }
            f.write_str(";")
        };
        match self {
            Command::In => f.write_str("IN;"),
            Command::Sp(n) => write!(f, "SP{n};"),
            Command::Vs(v) => write!(f, "VS{};", stencil_gcode::num(*v)),
            Command::Fs(v) => write!(f, "FS{v};"),
            Command::Pa(p) => pts(f, "PA", p),
            Command::Pu(p) => pts(f, "PU", p),
            Command::Pd(p) => pts(f, "PD", p),
            Command::Other(m, a) => write!(f, "{m}{a};"),
            Command::Device(c) => write!(f, "\x1b.{c}"),
        }
    }
}

/// Why a text is not HP-GL a plotter takes, with where.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("line {line}: {what}")]
pub struct ParseError {
    /// The line (from 1).
    pub line: usize,
    /// What is wrong.
    pub what: String,
}

/// An instruction and where it starts.
#[derive(Clone, Debug, PartialEq)]
pub struct Parsed {
    /// The instruction.
    pub command: Command,
    /// Its line (from 1).
    pub line: usize,
    /// Its byte offset in the text.
    pub offset: usize,
    /// Its length in bytes, up to and including its terminator.
    pub len: usize,
}

/// Largest parameter count of one instruction (a sanity bound: a runaway file is refused).
const MAX_PARAMS: usize = 1 << 16;

/// Parse HP-GL text into instructions. Refuses what is not HP-GL: a byte that starts no
/// mnemonic, a parameter that is not a number where numbers go, an odd number of coordinates.
/// Which mnemonics a plotter knows is not decided here (see the profile's dialect).
pub fn parse(text: &str) -> Result<Vec<Parsed>, ParseError> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    let mut line = 1;
    while i < b.len() {
        let c = b[i];
        if c == b'\n' {
            line += 1;
            i += 1;
            continue;
        }
        if c.is_ascii_whitespace() || c == b';' || c == 0x11 || c == 0x13 {
            i += 1;
            continue;
        }
        let start = i;
        if c == 0x1b {
            // ESC . letter, then parameters up to ':' (or none).
            if b.get(i + 1) != Some(&b'.') || !b.get(i + 2).is_some_and(u8::is_ascii_alphabetic) {
                return Err(ParseError {
                    line,
                    what: "ESC not followed by `.` and a letter (a device-control sequence)".into(),
                });
            }
            let letter = b[i + 2] as char;
            i += 3;
            // Sequences with parameters end in ':'; the ones without end right here.
            if matches!(letter, 'H' | 'I' | 'M' | 'N' | '@') {
                while i < b.len() && b[i] != b':' {
                    i += 1;
                }
                i += 1;
            }
            out.push(Parsed {
                command: Command::Device(letter.to_ascii_uppercase()),
                line,
                offset: start,
                len: i.min(b.len()) - start,
            });
            continue;
        }
        if !(c.is_ascii_alphabetic() && b.get(i + 1).is_some_and(u8::is_ascii_alphabetic)) {
            return Err(ParseError {
                line,
                what: format!(
                    "`{}` where an instruction (two letters) should start",
                    stencil_io::excerpt(&String::from_utf8_lossy(&b[i..(i + 12).min(b.len())]))
                ),
            });
        }
        let m = String::from_utf8_lossy(&b[i..i + 2]).to_ascii_uppercase();
        i += 2;
        let pstart = i;
        // Label text runs to the label terminator (ETX by default), not to ';'.
        let end_byte = if m == "LB" { 0x03 } else { b';' };
        while i < b.len() && b[i] != end_byte {
            if end_byte == b';' && b[i].is_ascii_alphabetic() && !matches!(b[i], b'e' | b'E') {
                break;
            }
            i += 1;
        }
        let params = &text[pstart..i];
        let cmd_line = line;
        line += params.matches('\n').count();
        if i < b.len() && b[i] == end_byte {
            i += 1;
        }
        let command = command(&m, params).map_err(|what| ParseError {
            line: cmd_line,
            what,
        })?;
        out.push(Parsed {
            command,
            line: cmd_line,
            offset: start,
            len: i - start,
        });
    }
    Ok(out)
}

/// The numbers of a parameter list.
fn numbers(m: &str, params: &str) -> Result<Vec<f64>, String> {
    let v: Vec<&str> = params
        .split(|c: char| c == ',' || c.is_ascii_whitespace())
        .filter(|s| !s.is_empty())
        .collect();
    if v.len() > MAX_PARAMS {
        return Err(format!("{m} has more than {MAX_PARAMS} parameters"));
    }
    v.iter()
        .map(|s| {
            s.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("{m}: `{}` is not a number", stencil_io::excerpt(s)))
        })
        .collect()
}

fn command(m: &str, params: &str) -> Result<Command, String> {
    let points = |v: Vec<f64>| -> Result<Vec<[i64; 2]>, String> {
        if v.len() % 2 == 1 {
            return Err(format!(
                "{m} has {} coordinates: they come in X,Y pairs",
                v.len()
            ));
        }
        if v.iter().any(|x| x.abs() > 1e9) {
            return Err(format!("{m}: a coordinate beyond any plotter's range"));
        }
        Ok(v.chunks(2)
            .map(|c| [c[0].round() as i64, c[1].round() as i64])
            .collect())
    };
    let one = |v: Vec<f64>| -> Result<Option<f64>, String> {
        match v.len() {
            0 => Ok(None),
            1 => Ok(Some(v[0])),
            n => Err(format!("{m} takes one number, not {n}")),
        }
    };
    Ok(match m {
        "IN" => {
            one(numbers(m, params)?)?;
            Command::In
        }
        "SP" => {
            let v = one(numbers(m, params)?)?.unwrap_or(0.0);
            if !(0.0..=1e6).contains(&v) {
                return Err(format!("SP{v}: pen numbers are 0 or more"));
            }
            Command::Sp(v as u32)
        }
        "VS" => match one(numbers(m, params)?)? {
            Some(v) if v > 0.0 => Command::Vs(v),
            Some(v) => return Err(format!("VS{v}: the speed must be above 0")),
            // VS alone: the plotter's default speed.
            None => Command::Other("VS".into(), String::new()),
        },
        "FS" => match one(numbers(m, params)?)? {
            Some(v) if v >= 0.0 => Command::Fs(v.round() as i64),
            Some(v) => return Err(format!("FS{v}: the force must not be negative")),
            None => Command::Other("FS".into(), String::new()),
        },
        "PA" => Command::Pa(points(numbers(m, params)?)?),
        "PU" => Command::Pu(points(numbers(m, params)?)?),
        "PD" => Command::Pd(points(numbers(m, params)?)?),
        _ => Command::Other(m.to_string(), params.to_string()),
    })
}

/// A program's text: each instruction on its own line (HP-GL ignores line ends between
/// instructions, and a person can read it).
pub fn to_text(commands: &[Command]) -> String {
    let mut s = String::new();
    for c in commands {
        s.push_str(&c.to_string());
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_reads_other_spellings() {
        let cmds = vec![
            Command::In,
            Command::Sp(1),
            Command::Vs(40.0),
            Command::Fs(80),
            Command::Pu(vec![[10, 20]]),
            Command::Pd(vec![[30, 20], [30, 40]]),
            Command::Pu(vec![]),
        ];
        let text = to_text(&cmds);
        let back: Vec<Command> = parse(&text)
            .unwrap()
            .into_iter()
            .map(|p| p.command)
            .collect();
        assert_eq!(back, cmds);
        // Lower case, spaces, no terminators between instructions.
        let p = parse("in;sp1 pu 10 20pd30,20,30,40\n").unwrap();
        assert_eq!(p.len(), 4);
        assert_eq!(p[3].command, Command::Pd(vec![[30, 20], [30, 40]]));
    }

    #[test]
    fn refuses_what_is_not_hpgl() {
        let e = parse("IN;\nPD10,20,30;").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.what.contains("pairs"), "{e}");
        assert!(parse("G1 X10 Y10\n").is_err());
        assert!(parse("IN;PU1,-;")
            .unwrap_err()
            .what
            .contains("not a number"));
    }
}
