//! The virtual plotter cutter of `send --dry-run`, `estimate` and `simulate`: it takes bytes as a
//! serial line delivers them into an input buffer of the profile's size, signals XON/XOFF or
//! drops CTS as the real one does, parses and runs every instruction of its dialect, refuses what
//! the real one would (an instruction it does not know, a coordinate off its cutting area, a
//! buffer overrun), keeps the tool's state and draws what it cut: for a drag knife, the path of
//! the blade's tip, dragged behind the holder's axis by the blade offset.

use std::collections::{BTreeMap, VecDeque};

use crate::command::{parse, Command};
use crate::profile::{Flow, Plotter, ToolKind};

/// XON (DC1): the plotter has room again.
pub const XON: u8 = 0x11;
/// XOFF (DC3): the plotter's buffer is nearly full.
pub const XOFF: u8 = 0x13;

/// Why the virtual cutter refused: what the real one would stop at (an error light, a lost
/// byte, a clipped cut).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Refusal {
    /// More bytes arrived than its buffer holds.
    #[error("buffer overrun: {got} bytes arrived with {free} free in its {size}-byte buffer")]
    Overrun {
        /// Bytes arriving.
        got: usize,
        /// Free space.
        free: usize,
        /// Buffer size.
        size: usize,
    },
    /// Text that is not HP-GL.
    #[error("instruction {index}: {what}")]
    Syntax {
        /// The instruction's number (from 1).
        index: usize,
        /// What is wrong.
        what: String,
    },
    /// An instruction this plotter does not know.
    #[error("instruction {index}: `{mnemonic}` is not an instruction of the {dialect} dialect")]
    Unknown {
        /// The instruction's number.
        index: usize,
        /// Its mnemonic.
        mnemonic: String,
        /// The dialect.
        dialect: &'static str,
    },
    /// A coordinate off the cutting area.
    #[error(
        "instruction {index}: point {x},{y} is off the cutting area (0..{max_x}, 0..{max_y} plotter units)"
    )]
    OffArea {
        /// The instruction's number.
        index: usize,
        /// The point.
        x: i64,
        /// The point.
        y: i64,
        /// The area's far corner.
        max_x: i64,
        /// The area's far corner.
        max_y: i64,
    },
    /// A parameter out of the plotter's range.
    #[error("instruction {index}: {what}")]
    Range {
        /// The instruction's number.
        index: usize,
        /// What is wrong.
        what: String,
    },
    /// One instruction longer than the whole buffer: it can never be taken in.
    #[error("an instruction longer than the {size}-byte buffer")]
    TooLong {
        /// Buffer size.
        size: usize,
    },
}

/// Time and lengths of a run, as the virtual cutter moves.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Timing {
    /// Whole job, s.
    pub total_s: f64,
    /// Moving with the tool down, s.
    pub cut_s: f64,
    /// Moving with the tool up, s.
    pub travel_s: f64,
    /// Length with the tool down, mm.
    pub cut_mm: f64,
    /// Length with the tool up, mm.
    pub travel_mm: f64,
}

/// Time to lower or lift the tool, s (a solenoid's stroke; our figure, not a maker's).
pub const TOOL_LIFT_S: f64 = 0.03;

/// The state of the virtual plotter cutter.
#[derive(Clone, Debug)]
pub struct Cutter {
    plotter: Plotter,
    buffer: VecDeque<u8>,
    /// Instructions run.
    pub executed: usize,
    /// Bytes run.
    pub executed_bytes: usize,
    /// The most bytes the buffer held.
    pub peak: usize,
    /// XOFFs sent (XON/XOFF), or times CTS dropped (RTS/CTS).
    pub stops: usize,
    xoff: bool,
    cts: bool,
    out: Vec<u8>,
    /// The head, plotter units.
    pub pos: [i64; 2],
    /// The tool is down.
    pub down: bool,
    /// The selected pen.
    pub pen: u32,
    /// Tool-down speed, cm/s (`None`: not set, the plotter's own).
    pub vs: Option<f64>,
    /// Blade force as set.
    pub fs: Option<i64>,
    /// The axis's path while the tool was down, mm: one polyline per stroke.
    pub strokes: Vec<Vec<[f64; 2]>>,
    /// A drag knife's tip path, mm (empty for a pen, or without a blade offset).
    pub tip: Vec<Vec<[f64; 2]>>,
    blade_offset_mm: f64,
    /// Where the blade's tip is against the axis, mm: it keeps its angle while lifted (taken to
    /// point along +X after switching on, as the writer assumes).
    tip_behind: [f64; 2],
    /// Instructions taken but not drawn (text, circles): mnemonic and count.
    pub not_drawn: BTreeMap<String, usize>,
    /// Time and lengths so far.
    pub timing: Timing,
    /// Buffer clears (`ESC.K`) received.
    pub clears: usize,
    /// What it ran, byte for byte, when kept (`Some`): the record a dry run can write out.
    pub log: Option<Vec<u8>>,
    /// Where the last instruction run starts in `log`: the one a power loss interrupts.
    last_run_at: usize,
}

impl Cutter {
    /// A cutter of this profile, just switched on: tool up at 0,0. A drag knife draws its tip
    /// `blade_offset_mm` behind its axis (0: the axis's path).
    pub fn new(plotter: &Plotter, blade_offset_mm: f64) -> Self {
        Cutter {
            plotter: plotter.clone(),
            buffer: VecDeque::new(),
            executed: 0,
            executed_bytes: 0,
            peak: 0,
            stops: 0,
            xoff: false,
            cts: true,
            out: Vec::new(),
            pos: [0, 0],
            down: false,
            pen: 0,
            vs: None,
            fs: None,
            strokes: Vec::new(),
            tip: Vec::new(),
            blade_offset_mm: if plotter.tool == ToolKind::Knife {
                blade_offset_mm
            } else {
                0.0
            },
            tip_behind: [-blade_offset_mm, 0.0],
            not_drawn: BTreeMap::new(),
            timing: Timing::default(),
            clears: 0,
            log: None,
            last_run_at: 0,
        }
    }

    /// Free bytes in the buffer.
    pub fn free(&self) -> usize {
        self.plotter.serial.buffer_bytes - self.buffer.len()
    }

    /// Whether the buffer is empty.
    pub fn idle(&self) -> bool {
        self.buffer.is_empty()
    }

    /// RTS/CTS: whether the line says "send".
    pub fn clear_to_send(&self) -> bool {
        self.plotter.serial.flow != Flow::RtsCts || self.cts
    }

    /// XON/XOFF bytes the plotter sent since the last call.
    pub fn take_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.out)
    }

    /// Bytes arriving on the line. A device-control `ESC.K` (clear the buffer) acts at once, as on
    /// HP's plotters: what is buffered is dropped. More bytes than the buffer holds is an overrun.
    pub fn receive(&mut self, bytes: &[u8]) -> Result<(), Refusal> {
        let mut rest = bytes;
        while let Some(k) = find(rest, b"\x1b.K") {
            self.take_in(&rest[..k])?;
            self.buffer.clear();
            self.clears += 1;
            rest = &rest[k + 3..];
        }
        self.take_in(rest)?;
        self.signal();
        Ok(())
    }

    fn take_in(&mut self, bytes: &[u8]) -> Result<(), Refusal> {
        let size = self.plotter.serial.buffer_bytes;
        if bytes.len() > self.free() {
            return Err(Refusal::Overrun {
                got: bytes.len(),
                free: self.free(),
                size,
            });
        }
        self.buffer.extend(bytes);
        self.peak = self.peak.max(self.buffer.len());
        Ok(())
    }

    /// XOFF below the headroom, XON when twice the headroom is free again; CTS likewise.
    fn signal(&mut self) {
        let head = self.plotter.serial.headroom_bytes;
        let free = self.free();
        match self.plotter.serial.flow {
            Flow::XonXoff => {
                if !self.xoff && free < head {
                    self.out.push(XOFF);
                    self.xoff = true;
                    self.stops += 1;
                } else if self.xoff && free >= 2 * head {
                    self.out.push(XON);
                    self.xoff = false;
                }
            }
            Flow::RtsCts => {
                if self.cts && free < head {
                    self.cts = false;
                    self.stops += 1;
                } else if !self.cts && free >= 2 * head {
                    self.cts = true;
                }
            }
        }
    }

    /// Run the next complete instruction in the buffer (up to its `;`); `Ok(false)` when there is
    /// none. A buffer holding one unfinished instruction that fills it is refused.
    pub fn step(&mut self) -> Result<bool, Refusal> {
        let Some(end) = self.buffer.iter().position(|&b| b == b';') else {
            if self.free() == 0 {
                return Err(Refusal::TooLong {
                    size: self.plotter.serial.buffer_bytes,
                });
            }
            return Ok(false);
        };
        let bytes: Vec<u8> = self.buffer.drain(..=end).collect();
        if let Some(log) = self.log.as_mut() {
            self.last_run_at = log.len();
            log.extend(&bytes);
        }
        self.run_bytes(&bytes)?;
        self.signal();
        Ok(true)
    }

    /// The serial line is gone (a pulled cable): the plotter runs on through every complete
    /// instruction it holds; an unfinished one at the end is dropped.
    pub fn line_lost(&mut self) -> Result<(), Refusal> {
        while self.step()? {}
        self.buffer.clear();
        Ok(())
    }

    /// The plotter lost power: what it held is gone, uncut, and the instruction it was running
    /// did not finish (it is taken out of the record: at most part of it was cut).
    pub fn power_lost(&mut self) {
        self.buffer.clear();
        if let Some(log) = self.log.as_mut() {
            log.truncate(self.last_run_at);
        }
        self.down = false;
    }

    /// The end of the stream: whatever is left (an instruction without its `;`) is run.
    pub fn finish(&mut self) -> Result<(), Refusal> {
        while self.step()? {}
        let bytes: Vec<u8> = self.buffer.drain(..).collect();
        self.run_bytes(&bytes)?;
        self.signal();
        Ok(())
    }

    fn run_bytes(&mut self, bytes: &[u8]) -> Result<(), Refusal> {
        let text = String::from_utf8_lossy(bytes);
        let parsed = parse(&text).map_err(|e| Refusal::Syntax {
            index: self.executed + 1,
            what: e.what,
        })?;
        for p in parsed {
            self.execute(&p.command)?;
            self.executed += 1;
        }
        self.executed_bytes += bytes.len();
        Ok(())
    }

    /// Run one instruction.
    pub fn execute(&mut self, c: &Command) -> Result<(), Refusal> {
        let index = self.executed + 1;
        let dialect = self.plotter.dialect;
        let mnemonic = match c {
            Command::Other(m, _) => m.as_str(),
            Command::Fs(_) => "FS",
            _ => "",
        };
        if !mnemonic.is_empty() && !dialect.accepts(mnemonic) {
            return Err(Refusal::Unknown {
                index,
                mnemonic: mnemonic.to_string(),
                dialect: dialect.name(),
            });
        }
        match c {
            Command::In => {
                self.lift();
                self.vs = None;
                self.fs = None;
            }
            Command::Sp(n) => {
                if *n > self.plotter.pens {
                    return Err(Refusal::Range {
                        index,
                        what: format!("SP{n}: this plotter has {} pen(s)", self.plotter.pens),
                    });
                }
                self.lift();
                self.pen = *n;
            }
            Command::Vs(v) => {
                let [lo, hi] = self.plotter.velocity_cm_s;
                if *v < lo - 1e-9 || *v > hi + 1e-9 {
                    return Err(Refusal::Range {
                        index,
                        what: format!("VS{v}: speeds are {lo} to {hi} cm/s"),
                    });
                }
                self.vs = Some(*v);
            }
            Command::Fs(f) => {
                let [lo, hi] = self.plotter.force_range;
                if (*f as f64) < lo || (*f as f64) > hi {
                    return Err(Refusal::Range {
                        index,
                        what: format!("FS{f}: forces are {lo} to {hi}"),
                    });
                }
                self.fs = Some(*f);
            }
            Command::Pa(pts) => self.move_through(pts, index)?,
            Command::Pu(pts) => {
                self.lift();
                self.move_through(pts, index)?;
            }
            Command::Pd(pts) => {
                if !self.down {
                    self.down = true;
                    self.timing.total_s += TOOL_LIFT_S;
                    let at = self.mm(self.pos);
                    self.strokes.push(vec![at]);
                    if self.blade_offset_mm > 0.0 {
                        // The blade goes down at the angle it was lifted at.
                        let b = self.tip_behind;
                        self.tip.push(vec![[at[0] + b[0], at[1] + b[1]]]);
                    }
                }
                self.move_through(pts, index)?;
            }
            Command::Other(m, _) => *self.not_drawn.entry(m.clone()).or_insert(0) += 1,
            Command::Device(_) => {}
        }
        Ok(())
    }

    fn lift(&mut self) {
        if self.down {
            self.down = false;
            self.timing.total_s += TOOL_LIFT_S;
        }
    }

    fn mm(&self, p: [i64; 2]) -> [f64; 2] {
        let u = self.plotter.units_per_mm;
        [p[0] as f64 / u, p[1] as f64 / u]
    }

    fn move_through(&mut self, pts: &[[i64; 2]], index: usize) -> Result<(), Refusal> {
        let [max_x, max_y] = self.plotter.max_units();
        for &q in pts {
            if q[0] < 0 || q[1] < 0 || q[0] > max_x || q[1] > max_y {
                return Err(Refusal::OffArea {
                    index,
                    x: q[0],
                    y: q[1],
                    max_x,
                    max_y,
                });
            }
            let (a, b) = (self.mm(self.pos), self.mm(q));
            let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
            let speed = if self.down {
                self.vs.unwrap_or(self.plotter.velocity_cm_s[1]) * 10.0
            } else {
                self.plotter.travel_mm_s
            };
            let t = move_time(len, speed, self.plotter.accel_mm_s2);
            self.timing.total_s += t;
            if self.down {
                self.timing.cut_s += t;
                self.timing.cut_mm += len;
                if let Some(s) = self.strokes.last_mut() {
                    s.push(b);
                }
                if self.blade_offset_mm > 0.0 {
                    self.drag_tip(a, b);
                }
            } else {
                self.timing.travel_s += t;
                self.timing.travel_mm += len;
            }
            self.pos = q;
        }
        Ok(())
    }

    /// The tip trails the axis at the blade offset: as the axis moves from `a` to `b`, the tip
    /// is pulled toward it along the line between them (a tractrix), in steps short against
    /// the offset.
    fn drag_tip(&mut self, a: [f64; 2], b: [f64; 2]) {
        let r = self.blade_offset_mm;
        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let steps = ((len / (r / 20.0)).ceil() as usize).clamp(1, 100_000);
        let mut tip = [a[0] + self.tip_behind[0], a[1] + self.tip_behind[1]];
        let line = self.tip.last_mut();
        let mut pts = Vec::with_capacity(steps);
        for k in 1..=steps {
            let t = k as f64 / steps as f64;
            let axis = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
            let d = ((axis[0] - tip[0]).powi(2) + (axis[1] - tip[1]).powi(2)).sqrt();
            if d > r {
                let f = (d - r) / d;
                tip = [
                    tip[0] + f * (axis[0] - tip[0]),
                    tip[1] + f * (axis[1] - tip[1]),
                ];
                pts.push(tip);
            }
        }
        if let Some(l) = line {
            l.extend(pts);
        }
        self.tip_behind = [tip[0] - b[0], tip[1] - b[1]];
    }
}

/// The time of one straight move from stand to stand: accelerate, cruise, brake (a triangle when
/// too short to reach `speed`).
pub fn move_time(len: f64, speed_mm_s: f64, accel: f64) -> f64 {
    if len <= 0.0 {
        return 0.0;
    }
    let ramp = speed_mm_s * speed_mm_s / accel;
    if len >= ramp {
        len / speed_mm_s + speed_mm_s / accel
    } else {
        2.0 * (len / accel).sqrt()
    }
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// A whole program run on a fresh cutter, as if streamed without flow trouble: what `estimate`,
/// `simulate` and the writer's own check use.
pub fn run_text(plotter: &Plotter, text: &str) -> Result<Cutter, Refusal> {
    run_text_with(plotter, text, 0.0)
}

/// [`run_text`] drawing a drag knife's tip `blade_offset_mm` behind its axis.
pub fn run_text_with(
    plotter: &Plotter,
    text: &str,
    blade_offset_mm: f64,
) -> Result<Cutter, Refusal> {
    let mut c = Cutter::new(plotter, blade_offset_mm);
    let parsed = parse(text).map_err(|e| Refusal::Syntax {
        index: 0,
        what: e.to_string(),
    })?;
    for p in parsed {
        c.execute(&p.command)?;
        c.executed += 1;
    }
    c.executed_bytes = text.len();
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::load;

    #[test]
    fn refuses_unknown_off_area_and_overrun() {
        let p = load("hp7475a").unwrap();
        let e = run_text(&p, "IN;SP1;FS40;").unwrap_err();
        assert!(
            matches!(e, Refusal::Unknown { ref mnemonic, .. } if mnemonic == "FS"),
            "{e}"
        );
        let e = run_text(&p, "IN;SP1;PU20000,10;").unwrap_err();
        assert!(matches!(e, Refusal::OffArea { x: 20000, .. }), "{e}");
        let e = run_text(&p, "IN;XY1;").unwrap_err();
        assert!(e.to_string().contains("XY"), "{e}");
        let mut c = Cutter::new(&p, 0.0);
        let big = vec![b' '; p.serial.buffer_bytes + 1];
        assert!(matches!(c.receive(&big), Err(Refusal::Overrun { .. })));
    }

    #[test]
    fn xoff_when_nearly_full_and_xon_when_drained() {
        let p = load("vinyl-hpgl").unwrap();
        let mut c = Cutter::new(&p, 0.0);
        let cmd = b"PU100,100;";
        while c.free() >= cmd.len() + p.serial.headroom_bytes {
            c.receive(cmd).unwrap();
            assert!(c.take_output().is_empty());
        }
        c.receive(cmd).unwrap();
        assert_eq!(c.take_output(), vec![XOFF]);
        while c.step().unwrap() {}
        assert_eq!(c.take_output(), vec![XON]);
        assert!(!c.down);
    }

    #[test]
    fn the_tip_trails_the_axis() {
        let p = load("vinyl-hpgl").unwrap();
        // A straight cut: the tip ends 0.25 mm behind the axis.
        let c = run_text_with(&p, "IN;PU400,400;PD800,400;", 0.25).unwrap();
        let t = *c.tip[0].last().unwrap();
        assert!(
            (t[0] - 19.75).abs() < 0.01 && (t[1] - 10.0).abs() < 1e-9,
            "{t:?}"
        );
    }
}
