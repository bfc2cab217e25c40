//! Where a job goes on the machine: its coordinates read as machine coordinates, from the
//! controller's work zero, or from where the head stands now (LightBurn's "start from: absolute
//! coordinates, user origin, current position").
//!
//! A G-code job names points in work coordinates; Grbl adds the work coordinate offset (the
//! selected G54..G59 plus G92) to reach the machine. So where a job lands depends on the
//! controller's offsets, and every check of it (the bed, the frame) must use the offsets the
//! controller really has. This module reads them (`$#`, `$G` and a status report, from a live
//! controller or from a dump a person saved) into a [`ControllerState`], and turns a
//! [`StartFrom`] choice into a [`Placement`]: the machine point of the job's X0 Y0, and the
//! parser state (an interpreter [`Modal`]) the job runs from, so its moves come out in machine
//! coordinates.

use std::path::Path;

use stencil_gcode::interpret::Modal;

use crate::protocol::{Reply, Status};

/// Where the job's X0 Y0 goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StartFrom {
    /// The job's coordinates are machine coordinates: X0 Y0 is the machine's origin (where
    /// homing puts it). Any work offset in X and Y is cancelled for the run with `G92`.
    Machine,
    /// The job's coordinates are the controller's work coordinates (G54..G59 and G92 as it
    /// holds them): nothing is sent, the offset is read and used by every check.
    WorkZero,
    /// The job's X0 Y0 is where the head stands when the run starts (`G92 X0 Y0` there).
    Current,
}

impl StartFrom {
    /// As the option is spelled.
    pub fn name(self) -> &'static str {
        match self {
            StartFrom::Machine => "machine",
            StartFrom::WorkZero => "work-zero",
            StartFrom::Current => "current",
        }
    }
}

impl std::str::FromStr for StartFrom {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "machine" | "absolute" => Ok(StartFrom::Machine),
            "work-zero" | "work" | "user-origin" => Ok(StartFrom::WorkZero),
            "current" | "current-position" => Ok(StartFrom::Current),
            _ => Err(format!(
                "'{s}' is not a start: use machine (the job's coordinates are the machine's), \
                 work-zero (the controller's work zero) or current (where the head stands)"
            )),
        }
    }
}

/// What a controller holds that decides where a job lands: its settings, work systems, G92,
/// tool length offset, the selected system and where the head is.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ControllerState {
    /// `$$`: setting number and value.
    pub settings: Vec<(u32, f64)>,
    /// `$#`: G54..G59, machine coordinates of each work zero.
    pub coords: [[f64; 3]; 6],
    /// `$#`: the G92 offset.
    pub g92: [f64; 3],
    /// `$#`: G43.1's tool length offset.
    pub tlo: f64,
    /// `$G`: the selected work system, G54..G59 as 0..5.
    pub coord_select: usize,
    /// A status report's machine position (`MPos`, or `WPos` + the offset), if one was given.
    pub position: Option<[f64; 3]>,
}

/// A controller-state dump that cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: line {line}: {what}")]
pub struct DumpError {
    /// The dump file.
    pub file: String,
    /// 1-based line in it.
    pub line: usize,
    /// What is wrong with that line.
    pub what: String,
}

/// Three finite numbers, `x,y,z`.
fn xyz(s: &str) -> Option<[f64; 3]> {
    crate::protocol::parse_list(s).filter(|p: &[f64; 3]| p.iter().all(|v| v.is_finite()))
}

impl ControllerState {
    /// The work coordinate offset in force (Grbl's `WCO:`): selected system + G92, TLO on Z.
    pub fn wco(&self) -> [f64; 3] {
        let c = self.coords[self.coord_select];
        [
            c[0] + self.g92[0],
            c[1] + self.g92[1],
            c[2] + self.g92[2] + self.tlo,
        ]
    }

    /// A setting as `$$` listed it.
    pub fn setting(&self, n: u32) -> Option<f64> {
        self.settings.iter().find(|(k, _)| *k == n).map(|&(_, v)| v)
    }

    /// Homing is enabled (`$22=1`), if `$$` said.
    pub fn homes(&self) -> Option<bool> {
        self.setting(22).map(|v| v != 0.0)
    }

    /// Take in one reply of `$$`, `$#`, `$G` or `?`; false if it is none of theirs.
    pub fn take(&mut self, reply: &Reply) -> bool {
        match reply {
            Reply::Other(l) => {
                let kv = l.strip_prefix('$').and_then(|r| r.split_once('='));
                match kv.map(|(k, v)| (k.parse::<u32>(), v.trim().parse::<f64>())) {
                    Some((Ok(k), Ok(v))) if v.is_finite() => {
                        self.settings.retain(|(n, _)| *n != k);
                        self.settings.push((k, v));
                        true
                    }
                    _ => false,
                }
            }
            Reply::Feedback(f) => self.take_feedback(f),
            Reply::Status(st) => {
                self.take_status(st);
                true
            }
            _ => false,
        }
    }

    fn take_feedback(&mut self, f: &str) -> bool {
        if let Some(gc) = f.strip_prefix("GC:") {
            for w in gc.split_whitespace() {
                if let Some(n) = w.strip_prefix('G').and_then(|n| n.parse::<usize>().ok()) {
                    if (54..=59).contains(&n) {
                        self.coord_select = n - 54;
                    }
                }
            }
            return true;
        }
        let Some((key, val)) = f.split_once(':') else {
            return false;
        };
        match key {
            "G54" | "G55" | "G56" | "G57" | "G58" | "G59" => {
                let k = key[1..].parse::<usize>().unwrap_or(54) - 54;
                xyz(val).map(|p| self.coords[k] = p).is_some()
            }
            "G92" => xyz(val).map(|p| self.g92 = p).is_some(),
            "TLO" => val
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .map(|v| self.tlo = v)
                .is_some(),
            // Known lines of `$#` that do not place a job.
            "G28" | "G30" | "PRB" => true,
            _ => false,
        }
    }

    /// A status report: the machine position (`WPos` is turned back with the offset: its
    /// `WCO:` if it has one, else the one `$#` gave).
    pub fn take_status(&mut self, st: &Status) {
        let wco = st.wco.unwrap_or_else(|| self.wco());
        self.position = match (st.mpos, st.wpos) {
            (Some(m), _) => Some(m),
            (None, Some(w)) => Some([w[0] + wco[0], w[1] + wco[1], w[2] + wco[2]]),
            (None, None) => self.position,
        };
    }

    /// Read a dump a person saved from their controller: the lines Grbl prints for `$$`, `$#`,
    /// and optionally `$G` and a status report (`?`), in any order. `ok`, blank lines, the
    /// banner, messages and `;`/`#` comments are skipped; any other line is refused, naming it.
    pub fn parse_dump(file: &Path, text: &str) -> Result<ControllerState, DumpError> {
        let mut st = ControllerState::default();
        let mut seen = false;
        for (i, raw) in text.lines().enumerate() {
            let l = raw.trim();
            // Some senders keep what was typed too (`$$`, `>>> $#`).
            let typed = l.trim_start_matches('>').trim();
            if l.is_empty()
                || l.starts_with(';')
                || l.starts_with('#')
                || matches!(typed, "$$" | "$#" | "$G" | "?")
            {
                continue;
            }
            // `$$` with the setting's description (as some senders print it): `$22=1 (homing)`.
            let l = l.split(" (").next().unwrap_or(l);
            let r = Reply::parse(l);
            match r {
                Reply::Ok | Reply::Welcome(..) | Reply::Message(_) => continue,
                _ if st.take(&r) => seen = true,
                _ => {
                    return Err(DumpError {
                        file: file.display().to_string(),
                        line: i + 1,
                        what: format!(
                            "`{}` is not a line Grbl prints for $$, $#, $G or ? (expected e.g. \
                             `$22=0`, `[G54:10.000,20.000,0.000]`, `[GC:G0 G54 G17 G21 G90 G94 \
                             M5 M9 T0 F0 S0]` or `<Idle|MPos:100.000,50.000,0.000|FS:0,0>`)",
                            raw.trim()
                        ),
                    })
                }
            }
        }
        if !seen {
            return Err(DumpError {
                file: file.display().to_string(),
                line: 1,
                what: "no settings, offsets or position in it: save what Grbl prints for $$ \
                       and $# (and ? for where the head is)"
                    .into(),
            });
        }
        Ok(st)
    }
}

/// Where a job goes: the choice, the machine point of the job's X0 Y0 (X, Y), and the parser
/// state it runs from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Which zero the job runs from.
    pub start_from: StartFrom,
    /// Machine coordinates of the job's X0 Y0 (the work offset in X and Y for the run).
    pub zero: [f64; 2],
    /// The controller's state once placed: its work systems and G92 (changed in X and Y to
    /// put the zero where it goes), `$12`, and the head where it is. Interpreting the job from
    /// this gives its moves in machine coordinates.
    pub modal: Modal,
}

impl Placement {
    /// Place a job on a controller in state `st`: the zero as `start` says, and the G92 that
    /// puts it there (the offset of the selected system is kept; G92 makes up the rest).
    pub fn new(start: StartFrom, st: &ControllerState) -> Placement {
        let wco = st.wco();
        let here = st.position.unwrap_or([0.0; 3]);
        let zero = match start {
            StartFrom::Machine => [0.0, 0.0],
            StartFrom::WorkZero => [wco[0], wco[1]],
            StartFrom::Current => [here[0], here[1]],
        };
        Placement::at(start, zero, st)
    }

    /// A placement whose zero is known (a journal's): `st`'s offsets with G92 made up to it.
    pub fn at(start: StartFrom, zero: [f64; 2], st: &ControllerState) -> Placement {
        let mut modal = Modal {
            coords: st.coords,
            g92: st.g92,
            tlo: st.tlo,
            coord_select: st.coord_select,
            pos: st.position.unwrap_or([0.0; 3]),
            ..Modal::default()
        };
        if let Some(t) = st.setting(12).filter(|t| *t > 0.0) {
            modal.arc_tolerance = t;
        }
        let sel = st.coords[st.coord_select];
        for a in 0..2 {
            modal.g92[a] = zero[a] - sel[a];
        }
        Placement {
            start_from: start,
            zero,
            modal,
        }
    }

    /// One line for the person: where the job's X0 Y0 is and why.
    pub fn describe(&self) -> String {
        let z = format!(
            "X{} Y{}",
            stencil_gcode::num(self.zero[0]),
            stencil_gcode::num(self.zero[1])
        );
        match self.start_from {
            StartFrom::Machine => {
                "the job's X0 Y0 is the machine's origin (start from machine coordinates)"
                    .to_string()
            }
            StartFrom::WorkZero => format!(
                "the job's X0 Y0 is the controller's work zero, G{} {}, at machine {z} (start \
                 from the work zero)",
                54 + self.modal.coord_select,
                if self.modal.g92[0] != 0.0 || self.modal.g92[1] != 0.0 {
                    "with G92"
                } else {
                    "as stored"
                }
            ),
            StartFrom::Current => format!(
                "the job's X0 Y0 is where the head stands, machine {z} (start from the current \
                 position)"
            ),
        }
    }
}

/// The `G92` that makes the controller's work zero (X, Y) `zero` with the head at machine
/// position `mpos`: G92 names the head's work position.
pub fn g92_for(zero: [f64; 2], mpos: [f64; 3]) -> String {
    format!(
        "G92X{}Y{}",
        stencil_gcode::num(mpos[0] - zero[0]),
        stencil_gcode::num(mpos[1] - zero[1])
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const DUMP: &str = "$$\n$0=10\n$12=0.004\n$22=0 (homing cycle, bool)\n$110=6000\nok\n\
        [G54:20.000,30.000,0.000]\n[G55:0.000,0.000,0.000]\n[G56:0.000,0.000,0.000]\n\
        [G57:0.000,0.000,0.000]\n[G58:0.000,0.000,0.000]\n[G59:0.000,0.000,0.000]\n\
        [G28:0.000,0.000,0.000]\n[G30:0.000,0.000,0.000]\n[G92:5.000,0.000,0.000]\n\
        [TLO:0.000]\n[PRB:0.000,0.000,0.000:0]\nok\n<Idle|MPos:100.000,50.000,0.000|FS:0,0>\n";

    #[test]
    fn a_dump_gives_settings_offsets_and_position() {
        let st = ControllerState::parse_dump(Path::new("d.txt"), DUMP).unwrap();
        assert_eq!(st.homes(), Some(false));
        assert_eq!(st.setting(12), Some(0.004));
        assert_eq!(st.wco(), [25.0, 30.0, 0.0]);
        assert_eq!(st.position, Some([100.0, 50.0, 0.0]));
        let p = Placement::new(StartFrom::WorkZero, &st);
        assert_eq!(p.zero, [25.0, 30.0]);
        assert_eq!(p.modal.wco(), [25.0, 30.0, 0.0]);
        let p = Placement::new(StartFrom::Current, &st);
        assert_eq!(p.modal.wco()[..2], [100.0, 50.0]);
        assert_eq!(g92_for(p.zero, [100.0, 50.0, 0.0]), "G92X0Y0");
        let p = Placement::new(StartFrom::Machine, &st);
        assert_eq!(p.modal.wco()[..2], [0.0, 0.0]);
        assert_eq!(p.modal.arc_tolerance, 0.004);
    }

    #[test]
    fn a_wrong_line_is_named() {
        let e = ControllerState::parse_dump(Path::new("d.txt"), "$22=1\nhello\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.what.contains("hello"));
        assert!(ControllerState::parse_dump(Path::new("d.txt"), "ok\n").is_err());
    }
}
