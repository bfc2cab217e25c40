//! Sending an HP-GL program to a plotter with its flow control: in pieces no larger than the
//! room the plotter keeps after it says stop, each only while it says go (XON/XOFF) or holds the
//! handshake line up (RTS/CTS), so its buffer never overflows. The operator can pause (nothing
//! more is sent; the plotter finishes what it holds), resume, and abort: the plotter's buffer is
//! cleared (`ESC.K`) and the tool lifted (`PU;`) before the stream stops.

use std::io;
use std::time::Duration;

use crate::command::parse;
use crate::cutter::{Cutter, Refusal, XOFF, XON};
use crate::profile::{Flow, Plotter, Serial};

/// What stopped a stream.
#[derive(Debug, thiserror::Error)]
pub enum StreamError {
    /// The line failed.
    #[error("the serial line: {0}")]
    Io(#[from] io::Error),
    /// The (virtual) plotter refused.
    #[error("the plotter refused: {0}")]
    Refused(#[from] Refusal),
    /// The file is not HP-GL.
    #[error("{0}")]
    Parse(#[from] crate::command::ParseError),
    /// The resume line is past the file's end.
    #[error("line {line} is past the last instruction (line {last})")]
    FromLine {
        /// Asked.
        line: usize,
        /// The last instruction's line.
        last: usize,
    },
}

/// The serial line to a plotter, real or virtual.
pub trait Line {
    /// Send bytes (a real line may block while the plotter holds it).
    fn write(&mut self, bytes: &[u8]) -> Result<(), StreamError>;
    /// XON/XOFF bytes the plotter sent, without waiting (none where the system's driver does
    /// the flow control).
    fn signals(&mut self) -> Result<Vec<u8>, StreamError>;
    /// Whether the plotter lets us send (CTS); true where the system's driver does it.
    fn clear_to_send(&mut self) -> Result<bool, StreamError>;
    /// Wait a little for the plotter.
    fn wait(&mut self) -> Result<(), StreamError>;
    /// Wait until everything sent is out (a real line) or run (the virtual cutter).
    fn drain(&mut self) -> Result<(), StreamError>;
    /// Bytes written but still in the host's own output queue (not yet on the wire): they have
    /// not reached the plotter, so they count as not delivered.
    fn queued(&mut self) -> Result<usize, StreamError> {
        Ok(0)
    }
}

/// What the operator asks for while a program streams.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    /// Stop sending (the plotter finishes what it holds).
    Pause,
    /// Go on.
    Resume,
    /// Clear the plotter's buffer, lift the tool, stop.
    Abort,
}

/// How far a stream got.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Progress {
    /// Instructions sent.
    pub sent: usize,
    /// Instructions to send.
    pub total: usize,
    /// The line of the last instruction sent.
    pub line: usize,
    /// Bytes known to have reached the plotter (written, less what the host still queues).
    pub delivered_bytes: usize,
    /// The first instruction not known to be cut ([`not_known_cut`]): a resume starts here.
    pub resume_line: usize,
}

/// How a stream ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Every instruction sent.
    Done {
        /// Instructions sent.
        sent: usize,
        /// Times the plotter said stop and the stream waited.
        waits: usize,
    },
    /// Aborted: the buffer cleared and the tool lifted.
    Aborted {
        /// The line of the first instruction the plotter may not have run: resume there.
        resume_line: usize,
    },
}

/// What aborting sends: clear the plotter's buffer (acted on at once, not queued), then lift the
/// tool.
pub const ABORT: &[u8] = b"\x1b.KPU;";

/// A piece of a stream: bytes sent in one write.
#[derive(Clone, Debug, PartialEq)]
pub struct Piece {
    /// The bytes.
    pub bytes: Vec<u8>,
    /// The line of its first instruction of the file (0: only a resume's set-up).
    pub first_line: usize,
    /// The line of its last instruction of the file.
    pub last_line: usize,
    /// Instructions of the file it ends.
    pub count: usize,
    /// Each instruction of the file ending in it: the offset just past its last byte in
    /// `bytes`, and its line.
    pub ends: Vec<(usize, usize)>,
}

/// The instructions of `text` to send from line `from_line` (1: all), as pieces of at most `max`
/// bytes; a resume first sets the state the skipped part set (`IN`, pen, speed, force) and
/// travels, tool up, to where the first instruction sent starts.
pub fn pieces(text: &str, from_line: usize, max: usize) -> Result<Vec<Piece>, StreamError> {
    let parsed = parse(text)?;
    let last = parsed.last().map_or(0, |p| p.line);
    if from_line > 1 && from_line > last {
        return Err(StreamError::FromLine {
            line: from_line,
            last,
        });
    }
    let mut units: Vec<(Vec<u8>, usize)> = Vec::new();
    if from_line > 1 {
        use crate::command::Command;
        let mut setup: Vec<Command> = Vec::new();
        let mut at: Option<[i64; 2]> = None;
        for p in parsed.iter().take_while(|p| p.line < from_line) {
            match &p.command {
                Command::In => setup = vec![Command::In],
                c @ (Command::Sp(_) | Command::Vs(_) | Command::Fs(_)) => {
                    setup.retain(|s| std::mem::discriminant(s) != std::mem::discriminant(c));
                    setup.push(c.clone());
                }
                Command::Pa(v) | Command::Pu(v) | Command::Pd(v) => at = v.last().copied().or(at),
                _ => {}
            }
        }
        setup.push(Command::Pu(at.into_iter().collect()));
        for c in setup {
            units.push((c.to_string().into_bytes(), 0));
        }
    }
    for p in parsed.iter().filter(|p| p.line >= from_line) {
        units.push((text.as_bytes()[p.offset..p.offset + p.len].to_vec(), p.line));
    }
    let mut out: Vec<Piece> = Vec::new();
    for (u, line) in units {
        let count = usize::from(line > 0);
        match out.last_mut() {
            Some(p) if p.bytes.len() + u.len() <= max => {
                p.bytes.extend(&u);
                if line > 0 {
                    p.ends.push((p.bytes.len(), line));
                }
                if p.first_line == 0 {
                    p.first_line = line;
                }
                p.last_line = line.max(p.last_line);
                p.count += count;
            }
            _ if u.len() > max => {
                // One instruction longer than a piece: in byte pieces (the plotter assembles it).
                let chunks: Vec<&[u8]> = u.chunks(max).collect();
                let k = chunks.len();
                for (i, c) in chunks.into_iter().enumerate() {
                    let last = i + 1 == k && line > 0;
                    out.push(Piece {
                        bytes: c.to_vec(),
                        first_line: line,
                        last_line: line,
                        count: if i + 1 == k { count } else { 0 },
                        ends: if last {
                            vec![(c.len(), line)]
                        } else {
                            Vec::new()
                        },
                    });
                }
            }
            _ => out.push(Piece {
                ends: if line > 0 {
                    vec![(u.len(), line)]
                } else {
                    Vec::new()
                },
                bytes: u,
                first_line: line,
                last_line: line,
                count,
            }),
        }
    }
    Ok(out)
}

/// The line of the first instruction not known to be cut, when `delivered` bytes of a stream
/// have reached a plotter whose buffer holds `buffer` bytes; `ends` holds, in order, each
/// instruction sent: the stream offset just past its last byte, and its line.
///
/// A plotter acknowledges nothing: flow control says only that its buffer has room, and what
/// has left the buffer is not what was cut. Up to `buffer` bytes may wait uncut, so every byte
/// up to `delivered - buffer` has left the buffer; the last instruction ending there may still
/// be running (or the one after it, already partly taken in): only the ones before it are known
/// cut. A resume from the returned line may cut again what was cut (harmless: the blade runs in
/// its own groove); it never leaves a segment out. `from_line` when nothing is known cut.
pub fn not_known_cut(
    ends: &[(usize, usize)],
    delivered: usize,
    buffer: usize,
    from_line: usize,
) -> usize {
    let horizon = delivered.saturating_sub(buffer);
    // Instructions ending at or before the horizon: all but the last are known cut.
    let left = ends.partition_point(|&(end, _)| end <= horizon);
    match left.checked_sub(1) {
        Some(i) => ends[i].1.max(from_line),
        None => from_line,
    }
}

/// Stream `text` from `from_line` over `line` with the plotter's flow control, in pieces of at
/// most its headroom. `control` is asked for the operator's wishes before each piece and while
/// waiting; `progress` hears of each piece sent, with the line a resume would start from.
pub fn stream(
    text: &str,
    from_line: usize,
    serial: &Serial,
    line: &mut dyn Line,
    control: &mut dyn FnMut() -> Option<Control>,
    progress: &mut dyn FnMut(&Progress),
) -> Result<Outcome, StreamError> {
    let (flow, headroom) = (serial.flow, serial.headroom_bytes);
    let pieces = pieces(text, from_line, headroom.max(1))?;
    // Every instruction of the file sent: the stream offset past its last byte, its line.
    let mut ends: Vec<(usize, usize)> = Vec::new();
    let mut sent_bytes: usize = 0;
    let total: usize = pieces.iter().map(|p| p.count).sum();
    let (mut held, mut paused) = (false, false);
    let mut p = Progress {
        sent: 0,
        total,
        line: 0,
        delivered_bytes: 0,
        resume_line: from_line,
    };
    let mut waits = 0;
    for piece in pieces {
        loop {
            match control() {
                Some(Control::Pause) => paused = true,
                Some(Control::Resume) => paused = false,
                Some(Control::Abort) => {
                    line.write(ABORT)?;
                    line.drain()?;
                    // Everything written reached the plotter before the clear; what it held was
                    // dropped uncut, and what it was running may not have finished.
                    let resume_line =
                        not_known_cut(&ends, sent_bytes, serial.buffer_bytes, from_line);
                    return Ok(Outcome::Aborted { resume_line });
                }
                None => {}
            }
            for b in line.signals()? {
                match b {
                    XOFF => held = true,
                    XON => held = false,
                    _ => {}
                }
            }
            let go = !paused
                && match flow {
                    Flow::XonXoff => !held,
                    Flow::RtsCts => line.clear_to_send()?,
                };
            if go {
                break;
            }
            waits += 1;
            line.wait()?;
        }
        line.write(&piece.bytes)?;
        ends.extend(piece.ends.iter().map(|&(end, l)| (sent_bytes + end, l)));
        sent_bytes += piece.bytes.len();
        p.sent += piece.count;
        p.line = p.line.max(piece.last_line);
        // A port that cannot say what it still queues leaves the count where it was (known
        // short, never long): the reckoning is a help for a resume, not a condition of cutting.
        if let Ok(q) = line.queued() {
            p.delivered_bytes = sent_bytes.saturating_sub(q).max(p.delivered_bytes);
        }
        p.resume_line = not_known_cut(&ends, p.delivered_bytes, serial.buffer_bytes, from_line);
        progress(&p);
    }
    line.drain()?;
    Ok(Outcome::Done {
        sent: p.sent,
        waits,
    })
}

/// The virtual plotter cutter on the end of the line: every byte sent is delivered to it at once;
/// it runs one instruction each time the sender waits, and the rest when the stream drains.
pub struct VirtualLine {
    /// The cutter.
    pub cutter: Cutter,
    /// Run one instruction each time this many bytes have been sent (as a plotter cuts while it
    /// receives): 0 runs only when the sender waits, which fills the buffer.
    pub run_every_bytes: usize,
    since_run: usize,
    /// A failure to rehearse, if any.
    pub fault: Option<LineFault>,
    /// Instructions received (their `;`s).
    received: usize,
    /// The fault happened: every further use of the line fails.
    dead: Option<LineFaultKind>,
}

/// A failure the virtual line rehearses: when the plotter has received this many instructions
/// (counting their `;`), the line or the plotter fails.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineFault {
    /// The instruction (from 1, in the order sent) whose arrival is the last.
    pub at_instruction: usize,
    /// What fails.
    pub kind: LineFaultKind,
}

/// What fails.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineFaultKind {
    /// The port goes away (a pulled cable, a lost USB adapter): the plotter cuts on through
    /// what it holds.
    PortLost,
    /// The plotter loses power: what it holds is lost and what it was cutting stops half way.
    PowerLoss,
}

impl LineFaultKind {
    fn error(self) -> StreamError {
        let what = match self {
            LineFaultKind::PortLost => "the port went away (a pulled cable or a lost adapter)",
            LineFaultKind::PowerLoss => "the plotter stopped answering (it lost power)",
        };
        StreamError::Io(io::Error::new(io::ErrorKind::BrokenPipe, what))
    }
}

impl VirtualLine {
    /// A fresh virtual cutter of `plotter`, drawing a drag knife's tip `blade_offset_mm` behind
    /// its axis.
    pub fn new(plotter: &Plotter, blade_offset_mm: f64) -> Self {
        VirtualLine {
            cutter: Cutter::new(plotter, blade_offset_mm),
            run_every_bytes: 0,
            since_run: 0,
            fault: None,
            received: 0,
            dead: None,
        }
    }

    fn alive(&self) -> Result<(), StreamError> {
        match self.dead {
            Some(kind) => Err(kind.error()),
            None => Ok(()),
        }
    }
}

impl Line for VirtualLine {
    fn write(&mut self, mut bytes: &[u8]) -> Result<(), StreamError> {
        self.alive()?;
        let ends = bytes.iter().filter(|&&b| b == b';').count();
        let failing = self
            .fault
            .filter(|f| self.received + ends >= f.at_instruction);
        if let Some(f) = failing {
            // Delivered up to the end of the fault's instruction, then the failure.
            let k = f.at_instruction.saturating_sub(self.received);
            let cut = bytes
                .iter()
                .enumerate()
                .filter(|(_, &b)| b == b';')
                .nth(k.saturating_sub(1))
                .map_or(0, |(i, _)| i + 1);
            bytes = &bytes[..if k == 0 { 0 } else { cut }];
        }
        self.received += ends;
        self.cutter.receive(bytes)?;
        if let Some(f) = failing {
            match f.kind {
                LineFaultKind::PortLost => self.cutter.line_lost()?,
                LineFaultKind::PowerLoss => self.cutter.power_lost(),
            }
            self.dead = Some(f.kind);
            return Err(f.kind.error());
        }
        self.since_run += bytes.len();
        if self.run_every_bytes > 0 && self.since_run >= self.run_every_bytes {
            self.since_run = 0;
            self.cutter.step()?;
        }
        Ok(())
    }
    fn signals(&mut self) -> Result<Vec<u8>, StreamError> {
        self.alive()?;
        Ok(self.cutter.take_output())
    }
    fn clear_to_send(&mut self) -> Result<bool, StreamError> {
        self.alive()?;
        Ok(self.cutter.clear_to_send())
    }
    fn wait(&mut self) -> Result<(), StreamError> {
        self.alive()?;
        if !self.cutter.step()? {
            // Nothing complete to run, yet the sender is held: the plotter would hang here.
            return Err(Refusal::TooLong {
                size: self.cutter.free(),
            }
            .into());
        }
        Ok(())
    }
    fn drain(&mut self) -> Result<(), StreamError> {
        self.alive()?;
        self.cutter.finish()?;
        Ok(())
    }
}

/// A real serial port, its flow control done by the system's driver (XON/XOFF as `IXON`,
/// RTS/CTS as `CRTSCTS`): writes block while the plotter holds the line.
pub struct SerialLine {
    port: Box<dyn serialport::SerialPort>,
}

impl SerialLine {
    /// Open `path` at the plotter's baud rate and flow control, 8 data bits, no parity, 1 stop bit.
    pub fn open(path: &str, plotter: &Plotter) -> Result<Self, StreamError> {
        let flow = match plotter.serial.flow {
            Flow::XonXoff => serialport::FlowControl::Software,
            Flow::RtsCts => serialport::FlowControl::Hardware,
        };
        let port = serialport::new(path, plotter.serial.baud)
            .flow_control(flow)
            .timeout(Duration::from_millis(200))
            .open()
            .map_err(io::Error::from)?;
        Ok(SerialLine { port })
    }
}

impl Line for SerialLine {
    fn write(&mut self, mut bytes: &[u8]) -> Result<(), StreamError> {
        while !bytes.is_empty() {
            match self.port.write(bytes) {
                Ok(n) => bytes = &bytes[n..],
                // Held by the plotter (XOFF, or CTS low): keep trying.
                Err(e) if e.kind() == io::ErrorKind::TimedOut => continue,
                Err(e) => return Err(e.into()),
            }
        }
        Ok(())
    }
    fn signals(&mut self) -> Result<Vec<u8>, StreamError> {
        Ok(Vec::new())
    }
    fn clear_to_send(&mut self) -> Result<bool, StreamError> {
        Ok(true)
    }
    fn wait(&mut self) -> Result<(), StreamError> {
        std::thread::sleep(Duration::from_millis(20));
        Ok(())
    }
    fn drain(&mut self) -> Result<(), StreamError> {
        self.port.flush()?;
        Ok(())
    }
    fn queued(&mut self) -> Result<usize, StreamError> {
        Ok(self.port.bytes_to_write().map_err(io::Error::from)? as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::load;

    fn job(n: usize) -> String {
        let mut s = String::from("IN;\nSP1;\nVS20;\n");
        for i in 0..n {
            let (x, y) = (400 + (i % 100) as i64 * 10, 400 + (i / 100) as i64 * 10);
            s.push_str(&format!("PU{x},{y};\nPD{},{y};\n", x + 5));
        }
        s.push_str("PU0,0;\n");
        s
    }

    #[test]
    fn every_instruction_once_with_either_flow_control() {
        for name in ["vinyl-hpgl", "roland-camm"] {
            let p = load(name).unwrap();
            let text = job(500);
            let total = parse(&text).unwrap().len();
            let mut line = VirtualLine::new(&p, 0.0);
            let out = stream(&text, 1, &p.serial, &mut line, &mut || None, &mut |_| {}).unwrap();
            assert!(matches!(out, Outcome::Done { sent, waits } if sent == total && waits > 0));
            assert_eq!(line.cutter.executed, total, "{name}");
            assert!(line.cutter.peak <= p.serial.buffer_bytes);
            assert!(
                line.cutter.stops > 0,
                "{name}: the flow control never acted"
            );
            assert!(!line.cutter.down);
        }
    }

    #[test]
    fn abort_clears_and_lifts() {
        let p = load("vinyl-hpgl").unwrap();
        let text = job(500);
        let mut line = VirtualLine::new(&p, 0.0);
        let mut n = 0;
        let out = stream(
            &text,
            1,
            &p.serial,
            &mut line,
            &mut || {
                n += 1;
                (n == 40).then_some(Control::Abort)
            },
            &mut |_| {},
        )
        .unwrap();
        assert!(matches!(out, Outcome::Aborted { resume_line } if resume_line > 3));
        assert_eq!(line.cutter.clears, 1);
        assert!(!line.cutter.down);
        assert!(line.cutter.executed < parse(&text).unwrap().len());
    }

    #[test]
    fn resume_sets_up_and_travels_first() {
        let text = "IN;\nSP1;\nVS20;\nPU10,10;\nPD20,10;\nPU30,30;\nPD40,30;\n";
        let p = pieces(text, 6, 1000).unwrap();
        let s = String::from_utf8(p[0].bytes.clone()).unwrap();
        assert!(s.starts_with("IN;SP1;VS20;PU20,10;PU30,30;"), "{s}");
        assert!(pieces(text, 99, 1000).is_err());
    }
}
