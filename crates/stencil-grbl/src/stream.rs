//! Streaming a G-code program to Grbl over any byte port.
//!
//! The same code runs against a serial port and against the virtual Grbl on a pty, so the tests
//! exercise exactly what `stencil send` does. Flow control is Grbl's character counting (at most
//! rx buffer − 1 bytes in flight, each line counted with its `\n`), or send-response as a fallback.
//! Every way a stream can stop early ends with a soft reset (laser off), an `M5` when the controller
//! accepts one, and the line to resume from.

use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

pub mod console;

pub use super::error::{CheckRejection, Halt, MachineError};
pub use super::program::{Program, ProgramLine, ResumeLift};
use super::protocol::{
    self, MachineState, Reply, Status, PLANNER_BLOCKS_DEFAULT, RT_FEED_HOLD, RT_RESUME,
    RT_SOFT_RESET, RT_STATUS, RX_BUFFER_DEFAULT,
};
use super::stall::{self, ClockRef, StallWatch};

/// A byte link to a controller: read with a timeout, write. Implemented for serial ports and ptys.
pub trait BytePort: Read + Write + Send {
    /// How long a `read` may block before failing with `TimedOut`.
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()>;
    /// The port's name for messages.
    fn describe(&self) -> String;
}

impl BytePort for TTYPort {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        SerialPort::set_timeout(self, timeout).map_err(io::Error::from)
    }
    fn describe(&self) -> String {
        SerialPort::name(self).unwrap_or_else(|| "pseudo-terminal".into())
    }
}

impl BytePort for Box<dyn SerialPort> {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.set_timeout(timeout).map_err(io::Error::from)
    }
    fn describe(&self) -> String {
        self.name().unwrap_or_else(|| "serial port".into())
    }
}

/// How lines are paced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlowControl {
    /// Keep the receive buffer as full as Grbl allows (fast; the normal mode).
    CharacterCounting,
    /// One line at a time, each waiting for its `ok` (slow; for boards that overflow).
    SendResponse,
}

/// Commands from the operator while a job runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    FeedHold,
    Resume,
    /// Stop now: soft reset, laser off, report the resume line.
    Abort,
    /// Change a feed or power override (Grbl's real-time bytes; the job keeps running).
    Override(Override),
}

/// The overrides an operator changes while cutting: feed and spindle (laser power) in 10 %
/// steps within Grbl's 10..200 %, or back to 100 %.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Override {
    FeedPlus10,
    FeedMinus10,
    FeedReset,
    PowerPlus10,
    PowerMinus10,
    PowerReset,
}

impl Override {
    /// Grbl's real-time byte for it.
    pub fn byte(self) -> u8 {
        match self {
            Override::FeedPlus10 => protocol::RT_FEED_OV_PLUS_10,
            Override::FeedMinus10 => protocol::RT_FEED_OV_MINUS_10,
            Override::FeedReset => protocol::RT_FEED_OV_RESET,
            Override::PowerPlus10 => protocol::RT_SPINDLE_OV_PLUS_10,
            Override::PowerMinus10 => protocol::RT_SPINDLE_OV_MINUS_10,
            Override::PowerReset => protocol::RT_SPINDLE_OV_RESET,
        }
    }
}

/// What to do about Grbl's laser mode (`$32`) before a job.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LaserMode {
    /// Not a laser job: leave `$32` alone.
    #[default]
    Ignore,
    /// A laser job: read `$$` and refuse if `$32=0`.
    Require,
    /// A laser job: read `$$` and set `$32=1` if it is off (`--set-laser-mode`).
    Set,
}

/// The longest a homing cycle may take before the sender gives up on it.
pub const HOMING_LIMIT: Duration = Duration::from_secs(300);

/// Streaming settings.
#[derive(Clone, Debug)]
pub struct StreamConfig {
    pub flow: FlowControl,
    /// Receive buffer size to count against; `None` = ask Grbl (`$I`), else 128.
    pub rx_buffer: Option<usize>,
    /// A controller that says nothing for this long (while being polled) is reported as silent.
    pub timeout: Duration,
    /// How long to wait for the banner of a board that resets when the port opens, before sending
    /// a soft reset to wake it.
    pub boot_wait: Duration,
    /// Status poll period (Grbl asks for 5 Hz or less).
    pub poll_interval: Duration,
    /// Send `$X` if the machine is locked in alarm.
    pub unlock: bool,
    /// Run the whole program through `$C` check mode first; refuse to cut if any line errors.
    pub check_first: bool,
    /// Start at this 1-based line of the file, after restoring the modal state it needs.
    pub from_line: usize,
    /// How the tool is lifted for the travel to a resume point (from the machine profile).
    pub lift: ResumeLift,
    /// The machine's G0 rate, mm/min (from its profile), for the stall bound; `None` = time G0
    /// at the job's slowest feed (a looser bound).
    pub rapid_mm_min: Option<f64>,
    /// Time for stall detection (a test's clock, or the system's).
    pub clock: ClockRef,
    /// Check (or set) laser mode before anything is sent.
    pub laser_mode: LaserMode,
    /// Home (`$H`) after connecting, before anything else moves: a recovery after a crash or a
    /// power loss cannot trust the machine's position. Also clears the alarm a homing machine
    /// boots in.
    pub home_first: bool,
}

impl Default for StreamConfig {
    fn default() -> Self {
        StreamConfig {
            flow: FlowControl::CharacterCounting,
            rx_buffer: None,
            timeout: Duration::from_secs(10),
            boot_wait: Duration::from_millis(2500),
            poll_interval: Duration::from_millis(250),
            unlock: false,
            check_first: false,
            from_line: 1,
            lift: ResumeLift::default(),
            rapid_mm_min: None,
            clock: ClockRef::default(),
            laser_mode: LaserMode::Ignore,
            home_first: false,
        }
    }
}

/// What the controller told us on connect.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ControllerInfo {
    pub version: String,
    pub rx_buffer: usize,
    pub planner_blocks: usize,
    /// The machine was in alarm and `$X` unlocked it.
    pub unlocked: bool,
}

/// Where a running job stands.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Progress {
    /// Program lines acknowledged (the resume preamble not counted) and in total.
    pub acked: usize,
    pub total: usize,
    pub last_acked_line: Option<usize>,
    /// First file line that may not have run yet (acknowledged lines can still wait in the
    /// planner): the remaining-time estimate starts here.
    pub unexecuted_from: usize,
    pub state: Option<MachineState>,
    pub position: Option<[f64; 3]>,
    /// Feed, rapid and spindle overrides in percent, as the last `Ov:` field said (Grbl sends it
    /// every few reports and right after a change).
    pub overrides: Option<[u32; 3]>,
    /// The N number Grbl last reported executing (`Ln:`, firmware built with line numbers).
    pub status_line: Option<u32>,
    pub elapsed: Duration,
}

/// Things a front end may show. Every method has a do-nothing default.
pub trait Observer {
    fn connected(&mut self, _info: &ControllerInfo) {}
    /// A `[MSG:..]` or other text from the controller, or a note from the streamer.
    fn message(&mut self, _text: &str) {}
    /// The check-mode pass (true) or the real run (false) begins.
    fn phase(&mut self, _checking: bool, _total: usize) {}
    fn progress(&mut self, _p: &Progress) {}
}

/// An observer that shows nothing.
pub struct Quiet;
impl Observer for Quiet {}

/// What a finished stream did.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    pub lines: usize,
    /// Program bytes written (lines with their newlines, without the preamble).
    pub bytes: u64,
    /// From the first program byte to the last acknowledgement.
    pub elapsed: Duration,
    pub rx_limit: usize,
    /// Most bytes ever in flight.
    pub max_in_flight: usize,
    /// From the start of streaming until the machine was idle with every line done.
    pub total: Duration,
    pub info: ControllerInfo,
}

enum LinkFault {
    Lost(String),
    Silent(f64),
}

/// Line-oriented reading and raw writing, with silence detection.
struct Link<'a> {
    port: &'a mut dyn BytePort,
    buf: Vec<u8>,
    last_heard: Instant,
    timeout: Duration,
}

impl Link<'_> {
    fn write(&mut self, bytes: &[u8]) -> Result<(), LinkFault> {
        self.port
            .write_all(bytes)
            .and_then(|_| self.port.flush())
            .map_err(|e| LinkFault::Lost(e.to_string()))
    }

    /// The next complete line, waiting at most `wait`; `None` if none came.
    fn line(&mut self, wait: Duration) -> Result<Option<String>, LinkFault> {
        loop {
            if let Some(i) = self.buf.iter().position(|&b| b == b'\n') {
                let raw: Vec<u8> = self.buf.drain(..=i).collect();
                let s = String::from_utf8_lossy(&raw).trim().to_string();
                if s.is_empty() {
                    continue;
                }
                return Ok(Some(s));
            }
            let silent = self.last_heard.elapsed();
            if silent > self.timeout {
                return Err(LinkFault::Silent(silent.as_secs_f64()));
            }
            let wait = wait
                .min(self.timeout - silent)
                .max(Duration::from_millis(1));
            self.port
                .set_read_timeout(wait)
                .map_err(|e| LinkFault::Lost(e.to_string()))?;
            let mut chunk = [0u8; 1024];
            match self.port.read(&mut chunk) {
                Ok(0) => return Ok(None),
                Ok(n) => {
                    self.last_heard = Instant::now();
                    self.buf.extend_from_slice(&chunk[..n]);
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::TimedOut
                            | io::ErrorKind::WouldBlock
                            | io::ErrorKind::Interrupted
                    ) =>
                {
                    return Ok(None)
                }
                Err(e) => return Err(LinkFault::Lost(e.to_string())),
            }
        }
    }
}

/// Estimates which acknowledged moves have really run: Grbl acknowledges a line when it is
/// queued, and the status report's free planner blocks tell how many still wait.
struct Tracker {
    planner_blocks: usize,
    acked_motion: Vec<usize>,
    motion_at_status: usize,
    planner_used_at_status: usize,
}

impl Tracker {
    fn status(&mut self, st: &Status) {
        self.motion_at_status = self.acked_motion.len();
        self.planner_used_at_status = match (&st.state, st.buffer) {
            (MachineState::Idle, _) => 0,
            (_, Some((free, _))) => self.planner_blocks.saturating_sub(free as usize),
            (_, None) => self.planner_blocks,
        };
    }
    /// The earliest acknowledged move that may not have finished.
    fn first_unexecuted(&self) -> Option<usize> {
        let n = self.acked_motion.len();
        let unexec = self.planner_used_at_status + (n - self.motion_at_status.min(n));
        if unexec == 0 || n == 0 {
            None
        } else {
            Some(self.acked_motion[n.saturating_sub(unexec)])
        }
    }
}

struct Outgoing {
    /// File line (the resume point for preamble lines).
    number: usize,
    text: String,
    motion: bool,
    preamble: bool,
}

/// A Grbl system command (`$x=value`, `$H`, `$X`...), not G-code.
fn is_system(line: &str) -> bool {
    line.starts_with('$')
}

/// The streamer's session with one controller.
struct Session<'a, 'o> {
    link: Link<'a>,
    cfg: &'a StreamConfig,
    obs: &'o mut dyn Observer,
    controls: Option<&'a Receiver<Control>>,
    port_name: String,
    info: ControllerInfo,
    last_status: Option<Status>,
    started: Instant,
    stall: StallWatch,
}

/// Stream `job` to the controller on `port` and wait until every line is acknowledged.
///
/// Connects (banner, `$I`, alarm check), optionally vets the job in check mode, restores the
/// modal state for `--from-line`, then streams with status polling. Any fault stops the machine
/// (soft reset, laser off) and returns an error carrying the resume line ([`MachineError::halt`]).
pub fn send(
    port: &mut dyn BytePort,
    job: &Program,
    cfg: &StreamConfig,
    controls: Option<&Receiver<Control>>,
    obs: &mut dyn Observer,
) -> Result<Summary, MachineError> {
    let preamble = job.resume_preamble_with(cfg.from_line.max(1), &cfg.lift)?;
    let stall = stall::stall_bound(stall::slowest_step(job, cfg.rapid_mm_min));
    let mut s = Session::new(port, cfg, controls, obs, stall);
    s.connect()?;
    s.laser_mode()?;
    let rx_limit = s.info.rx_buffer.saturating_sub(1).max(1);
    for l in &job.lines {
        if l.text.len() + 1 > rx_limit && cfg.flow == FlowControl::CharacterCounting {
            return Err(MachineError::LineExceedsBuffer {
                file: job.name.clone(),
                line: l.number,
                len: l.text.len() + 1,
                rx: s.info.rx_buffer,
            });
        }
    }
    let from = cfg.from_line.max(1);
    let body: Vec<Outgoing> = job
        .lines
        .iter()
        .filter(|l| l.number >= from)
        .map(|l| Outgoing {
            number: l.number,
            text: l.text.clone(),
            motion: l.motion,
            preamble: false,
        })
        .collect();
    let resume_point = body.first().map(|l| l.number).unwrap_or(from);
    let mut lines: Vec<Outgoing> = preamble
        .into_iter()
        .map(|text| Outgoing {
            number: resume_point,
            text,
            motion: false,
            preamble: true,
        })
        .collect();
    lines.extend(body);
    if cfg.check_first {
        // With the preamble, so a resumed job is checked in the state it will run in.
        s.check(job, &lines)?;
    }
    let restore: Vec<&str> = lines
        .iter()
        .filter(|l| l.preamble)
        .map(|l| l.text.as_str())
        .collect();
    if !restore.is_empty() {
        s.obs.message(&format!(
            "resuming at line {from}: restoring the machine state with {}",
            restore.join(" ")
        ));
    }
    s.obs
        .phase(false, lines.iter().filter(|l| !l.preamble).count());
    let summary = s.stream(&lines, false, rx_limit, resume_point)?;
    if job.may_end_laser_on {
        s.obs
            .message("the program ends without switching the laser off: sending M5");
        s.command("M5")?;
    }
    if job.may_end_air_on {
        s.obs
            .message("the program ends without switching the air (coolant) off: sending M9");
        s.command("M9")?;
    }
    Ok(summary)
}

impl<'a, 'o> Session<'a, 'o> {
    /// A session on `port`, not yet connected; a machine standing still in `Run` longer than
    /// `stall_bound` counts as stalled.
    fn new(
        port: &'a mut dyn BytePort,
        cfg: &'a StreamConfig,
        controls: Option<&'a Receiver<Control>>,
        obs: &'o mut dyn Observer,
        stall_bound: Duration,
    ) -> Self {
        Session {
            port_name: port.describe(),
            link: Link {
                port,
                buf: Vec::new(),
                last_heard: Instant::now(),
                timeout: cfg.timeout,
            },
            cfg,
            obs,
            controls,
            info: ControllerInfo::default(),
            last_status: None,
            started: Instant::now(),
            stall: StallWatch::new(stall_bound),
        }
    }
}

impl Session<'_, '_> {
    fn lost(&self, f: LinkFault) -> MachineError {
        match f {
            LinkFault::Lost(detail) => MachineError::Io {
                port: self.port_name.clone(),
                detail,
            },
            LinkFault::Silent(secs) => MachineError::NoWelcome {
                port: self.port_name.clone(),
                secs,
            },
        }
    }

    /// Wait for the banner; wake a board that did not reset on open with a soft reset.
    fn connect(&mut self) -> Result<(), MachineError> {
        let mut alarm = None;
        let mut hinted = false;
        let mut version = self.wait_welcome(self.cfg.boot_wait, &mut alarm, &mut hinted)?;
        if version.is_none() {
            self.link
                .write(&[RT_SOFT_RESET])
                .map_err(|f| self.lost(f))?;
            version = self.wait_welcome(self.cfg.timeout, &mut alarm, &mut hinted)?;
        }
        let Some(version) = version else {
            return Err(MachineError::NoWelcome {
                port: self.port_name.clone(),
                secs: (self.cfg.boot_wait + self.cfg.timeout).as_secs_f64(),
            });
        };
        self.info.version = version;
        self.info.rx_buffer = RX_BUFFER_DEFAULT;
        self.info.planner_blocks = PLANNER_BLOCKS_DEFAULT;
        // Build info: Grbl 1.1 tells its planner and buffer sizes here; older firmware and
        // clones may not, or may refuse `$I`: then the stock sizes stand.
        let replies = match self.command("$I") {
            Ok(r) => r,
            Err(MachineError::Setup { .. }) => Vec::new(),
            Err(e) => return Err(e),
        };
        for r in &replies {
            if let Reply::Feedback(f) = r {
                if let Some((blocks, rx)) = protocol::parse_opt(f) {
                    self.info.planner_blocks = blocks;
                    self.info.rx_buffer = rx;
                }
            }
        }
        if let Some(rx) = self.cfg.rx_buffer {
            self.info.rx_buffer = rx;
        }
        // The banner may be followed by the unlock hint: collect it with the status.
        let st = self.query_status(&mut hinted)?;
        match st.state {
            MachineState::Idle => {}
            // A machine with homing switches boots locked: homing is what unlocks it.
            MachineState::Alarm if self.cfg.home_first => {}
            MachineState::Alarm => {
                if !self.cfg.unlock {
                    return Err(MachineError::Locked {
                        port: self.port_name.clone(),
                        alarm,
                    });
                }
                self.obs
                    .message("the machine was locked in alarm: unlocking with $X as asked");
                self.command("$X")?;
                self.info.unlocked = true;
            }
            other => {
                return Err(MachineError::Busy {
                    port: self.port_name.clone(),
                    state: other.to_string(),
                })
            }
        }
        if self.cfg.home_first {
            self.home()?;
        }
        self.obs.connected(&self.info);
        Ok(())
    }

    /// `$H`, waiting for its `ok` as long as homing may take (the machine answers status queries
    /// meanwhile, in `Home`), at most [`HOMING_LIMIT`].
    fn home(&mut self) -> Result<(), MachineError> {
        self.obs
            .message("homing ($H) first: the position after a stop or power loss is not trusted");
        self.link.write(b"$H\n").map_err(|f| self.lost(f))?;
        let end = Instant::now() + HOMING_LIMIT;
        let saved = self.link.timeout;
        self.link.timeout = HOMING_LIMIT;
        self.link.last_heard = Instant::now();
        let mut next_ask = Instant::now() + Duration::from_secs(1);
        let result = loop {
            if Instant::now() >= end {
                break Err(MachineError::Homing {
                    port: self.port_name.clone(),
                    detail: format!("no answer within {} s", HOMING_LIMIT.as_secs()),
                });
            }
            if Instant::now() >= next_ask {
                if let Err(f) = self.link.write(&[RT_STATUS]) {
                    break Err(self.lost(f));
                }
                next_ask = Instant::now() + Duration::from_secs(1);
            }
            match self.link.line(Duration::from_millis(50)) {
                Ok(Some(l)) => match Reply::parse(&l) {
                    Reply::Ok => break Ok(()),
                    Reply::Error(code) => {
                        break Err(MachineError::Homing {
                            port: self.port_name.clone(),
                            detail: format!("error:{code} ({})", protocol::error_meaning(code)),
                        })
                    }
                    Reply::Alarm(code) => {
                        break Err(MachineError::Homing {
                            port: self.port_name.clone(),
                            detail: format!("ALARM:{code} ({})", protocol::alarm_meaning(code)),
                        })
                    }
                    Reply::Message(m) => self.obs.message(&format!("Grbl: {m}")),
                    _ => {}
                },
                Ok(None) => {}
                Err(f) => break Err(self.lost(f)),
            }
        };
        self.link.timeout = saved;
        result?;
        self.obs.message("homed");
        Ok(())
    }

    fn wait_welcome(
        &mut self,
        limit: Duration,
        alarm: &mut Option<u8>,
        hinted: &mut bool,
    ) -> Result<Option<String>, MachineError> {
        let end = Instant::now() + limit;
        // The board may have been quiet for long before we opened it: only our own wait counts.
        self.link.last_heard = Instant::now();
        let saved = self.link.timeout;
        self.link.timeout = limit + Duration::from_secs(1);
        let result = loop {
            let now = Instant::now();
            if now >= end {
                break Ok(None);
            }
            match self.link.line(end - now) {
                Ok(Some(l)) => match Reply::parse(&l) {
                    Reply::Welcome(v) => break Ok(Some(v)),
                    Reply::Alarm(a) => *alarm = Some(a),
                    Reply::Message(m) => {
                        *hinted |= protocol::is_unlock_hint(&m);
                        self.obs.message(&format!("Grbl: {m}"));
                    }
                    _ => {}
                },
                Ok(None) => {}
                Err(LinkFault::Silent(_)) => break Ok(None),
                Err(f) => break Err(self.lost(f)),
            }
        };
        self.link.timeout = saved;
        result
    }

    /// `$32` as `$$` lists it (`None`: not listed, as on Grbl before 1.1).
    fn read_laser_mode(&mut self) -> Result<Option<String>, MachineError> {
        let replies = self.command("$$")?;
        Ok(replies.iter().find_map(|r| match r {
            Reply::Other(o) => o.strip_prefix("$32=").map(|v| v.trim().to_string()),
            _ => None,
        }))
    }

    /// Before a laser job: Grbl must be in laser mode (`$32=1`), or it pauses at every power
    /// change and fires through G0. Refuse, or set it when asked, and say which.
    fn laser_mode(&mut self) -> Result<(), MachineError> {
        let set = match self.cfg.laser_mode {
            LaserMode::Ignore => return Ok(()),
            LaserMode::Require => false,
            LaserMode::Set => true,
        };
        let on = |v: &str| v.parse::<f64>().is_ok_and(|x| x != 0.0);
        match self.read_laser_mode()? {
            None => self.obs.message(
                "the controller does not list $32 (laser mode) in $$: make sure it is a laser \
                 build in laser mode, or the beam stays on through G0 moves",
            ),
            Some(v) if on(&v) => self.obs.message("laser mode is on ($32=1)"),
            Some(v) if !set => {
                return Err(MachineError::LaserModeOff {
                    port: self.port_name.clone(),
                    value: v,
                })
            }
            Some(v) => {
                self.command("$32=1")?;
                match self.read_laser_mode()? {
                    Some(now) if on(&now) => self.obs.message(&format!(
                        "laser mode was off ($32={v}): set $32=1 as asked (--set-laser-mode); \
                         Grbl keeps it"
                    )),
                    now => {
                        return Err(MachineError::LaserModeNotSet {
                            port: self.port_name.clone(),
                            value: now.unwrap_or_else(|| "(not listed)".into()),
                        })
                    }
                }
            }
        }
        Ok(())
    }

    /// Send one setup command and wait for its answer (send-response).
    fn command(&mut self, cmd: &str) -> Result<Vec<Reply>, MachineError> {
        self.link
            .write(format!("{cmd}\n").as_bytes())
            .map_err(|f| self.lost(f))?;
        let mut got = Vec::new();
        let end = Instant::now() + self.cfg.timeout;
        self.link.last_heard = Instant::now();
        while Instant::now() < end {
            match self.link.line(Duration::from_millis(50)) {
                Ok(Some(l)) => match Reply::parse(&l) {
                    Reply::Ok => return Ok(got),
                    Reply::Error(code) => {
                        return Err(MachineError::Setup {
                            port: self.port_name.clone(),
                            cmd: cmd.to_string(),
                            code,
                        })
                    }
                    Reply::Message(m) => {
                        self.obs.message(&format!("Grbl: {m}"));
                        got.push(Reply::Message(m));
                    }
                    r => got.push(r),
                },
                Ok(None) => {}
                Err(f) => return Err(self.lost(f)),
            }
        }
        Err(MachineError::NoWelcome {
            port: self.port_name.clone(),
            secs: self.cfg.timeout.as_secs_f64(),
        })
    }

    fn query_status(&mut self, hinted: &mut bool) -> Result<Status, MachineError> {
        let end = Instant::now() + self.cfg.timeout;
        let mut next_ask = Instant::now();
        self.link.last_heard = Instant::now();
        while Instant::now() < end {
            if Instant::now() >= next_ask {
                self.link.write(&[RT_STATUS]).map_err(|f| self.lost(f))?;
                next_ask = Instant::now() + Duration::from_millis(500);
            }
            match self.link.line(Duration::from_millis(50)) {
                Ok(Some(l)) => match Reply::parse(&l) {
                    Reply::Status(st) => {
                        self.last_status = Some(st.clone());
                        return Ok(st);
                    }
                    Reply::Message(m) => {
                        *hinted |= protocol::is_unlock_hint(&m);
                        self.obs.message(&format!("Grbl: {m}"));
                    }
                    _ => {}
                },
                Ok(None) => {}
                Err(f) => return Err(self.lost(f)),
            }
        }
        Err(MachineError::NoWelcome {
            port: self.port_name.clone(),
            secs: self.cfg.timeout.as_secs_f64(),
        })
    }

    /// Run the lines through `$C` check mode; refuse if any errors.
    fn check(&mut self, job: &Program, body: &[Outgoing]) -> Result<(), MachineError> {
        self.obs
            .message("checking the program in Grbl's check mode ($C)");
        self.command("$C")?;
        self.obs.phase(true, body.len());
        // Grbl refuses `$` commands in check mode (error:8): they are not G-code to vet.
        let skipped = body.iter().filter(|l| is_system(&l.text)).count();
        if skipped > 0 {
            self.obs.message(&format!(
                "{skipped} `$` command line(s) are not checked (Grbl does not run them in check mode)"
            ));
        }
        let lines: Vec<Outgoing> = body
            .iter()
            .filter(|l| !is_system(&l.text))
            .map(|l| Outgoing {
                number: l.number,
                text: l.text.clone(),
                motion: false,
                preamble: l.preamble,
            })
            .collect();
        let rx_limit = self.info.rx_buffer.saturating_sub(1).max(1);
        let rejected = match self.stream_inner(&lines, true, rx_limit, 1) {
            Ok(run) => run.rejected,
            Err(e) => return Err(e),
        };
        // Leaving check mode soft-resets Grbl: wait for its banner.
        self.command("$C")?;
        let (mut alarm, mut hinted) = (None, false);
        if self
            .wait_welcome(self.cfg.timeout, &mut alarm, &mut hinted)?
            .is_none()
        {
            return Err(MachineError::NoWelcome {
                port: self.port_name.clone(),
                secs: self.cfg.timeout.as_secs_f64(),
            });
        }
        if !rejected.is_empty() {
            return Err(MachineError::CheckFailed {
                file: job.name.clone(),
                rejected,
            });
        }
        self.obs
            .message("check mode passed: every line was accepted");
        Ok(())
    }

    fn stream(
        &mut self,
        lines: &[Outgoing],
        checking: bool,
        rx_limit: usize,
        start_line: usize,
    ) -> Result<Summary, MachineError> {
        let run = self.stream_inner(lines, checking, rx_limit, start_line)?;
        Ok(Summary {
            lines: run.acked,
            bytes: run.bytes,
            elapsed: run.elapsed,
            rx_limit,
            max_in_flight: run.max_in_flight,
            total: self.started.elapsed(),
            info: self.info.clone(),
        })
    }

    fn stream_inner(
        &mut self,
        lines: &[Outgoing],
        checking: bool,
        rx_limit: usize,
        start_line: usize,
    ) -> Result<Run, MachineError> {
        let mut f = Flight {
            lines,
            start_line,
            in_flight: VecDeque::new(),
            in_flight_bytes: 0,
            acked_total: 0,
            run: Run::default(),
            tracker: Tracker {
                planner_blocks: self.info.planner_blocks,
                acked_motion: Vec::new(),
                motion_at_status: 0,
                planner_used_at_status: 0,
            },
            progress: Progress {
                total: lines.iter().filter(|l| !l.preamble).count(),
                unexecuted_from: start_line,
                ..Progress::default()
            },
        };
        let mut next = 0usize;
        let mut last_poll = Instant::now() - self.cfg.poll_interval;
        let mut first_byte: Option<Instant> = None;
        let mut finished = false;
        self.link.last_heard = Instant::now();
        self.started = Instant::now();

        loop {
            if let Some(rx) = self.controls {
                while let Ok(c) = rx.try_recv() {
                    let byte = match c {
                        Control::FeedHold => RT_FEED_HOLD,
                        Control::Resume => RT_RESUME,
                        Control::Override(o) => o.byte(),
                        Control::Abort => {
                            self.settle(&mut f);
                            let halt = self.halt(f.run.last_acked, f.resume_at(None));
                            return Err(MachineError::Aborted { halt });
                        }
                    };
                    if let Err(e) = self.link.write(&[byte]) {
                        return Err(self.fault(e, &f));
                    }
                    match c {
                        Control::FeedHold => self
                            .obs
                            .message("feed hold (!): press r to resume, a to abort"),
                        Control::Resume => self.obs.message("resuming (~)"),
                        // The new values show in the progress line from the next `Ov:`.
                        _ => {}
                    }
                }
            }
            // Fill Grbl's receive buffer.
            while next < lines.len() {
                let len = lines[next].text.len() + 1;
                // `$` commands (settings written to EEPROM, homing...) go alone: Grbl stops
                // listening to the port while it writes EEPROM, so nothing may follow them until
                // they are answered.
                let after_system = f
                    .in_flight
                    .back()
                    .is_some_and(|&(i, _)| is_system(&lines[i].text));
                let fits = match self.cfg.flow {
                    _ if after_system => false,
                    _ if is_system(&lines[next].text) => f.in_flight.is_empty(),
                    FlowControl::CharacterCounting => f.in_flight_bytes + len <= rx_limit,
                    FlowControl::SendResponse => f.in_flight.is_empty(),
                };
                if !fits {
                    break;
                }
                let mut bytes = Vec::with_capacity(len);
                bytes.extend_from_slice(lines[next].text.as_bytes());
                bytes.push(b'\n');
                if let Err(e) = self.link.write(&bytes) {
                    return Err(self.fault(e, &f));
                }
                if !lines[next].preamble {
                    first_byte.get_or_insert_with(Instant::now);
                    f.run.bytes += len as u64;
                }
                f.in_flight.push_back((next, len));
                f.in_flight_bytes += len;
                f.run.max_in_flight = f.run.max_in_flight.max(f.in_flight_bytes);
                next += 1;
            }
            // Done when every line is acknowledged and, for a real run, the machine has finished
            // moving (`ok` only means queued).
            if f.acked_total == lines.len() && (checking || finished) {
                break;
            }
            if last_poll.elapsed() >= self.cfg.poll_interval {
                if let Err(e) = self.link.write(&[RT_STATUS]) {
                    return Err(self.fault(e, &f));
                }
                last_poll = Instant::now();
            }
            let wait = self
                .cfg
                .poll_interval
                .saturating_sub(last_poll.elapsed())
                .min(Duration::from_millis(50));
            let line = match self.link.line(wait) {
                Ok(Some(l)) => l,
                Ok(None) => continue,
                Err(e) => return Err(self.fault(e, &f)),
            };
            match Reply::parse(&line) {
                Reply::Ok | Reply::Error(_) if f.in_flight.is_empty() => {
                    self.obs.message(&format!(
                        "Grbl answered `{line}` with no line waiting; ignored"
                    ));
                }
                Reply::Ok => {
                    f.ack();
                    if let Some(t) = first_byte {
                        f.run.elapsed = t.elapsed();
                    }
                    f.progress.elapsed = self.started.elapsed();
                    self.obs.progress(&f.progress);
                }
                Reply::Error(code) => {
                    let Some(l) = f.reject() else { continue };
                    if checking {
                        f.run.rejected.push(CheckRejection {
                            line: l.number,
                            text: l.text.clone(),
                            code,
                        });
                        continue;
                    }
                    self.settle(&mut f);
                    let halt = self.halt(f.run.last_acked, f.resume_at(Some(l.number)));
                    return Err(MachineError::Rejected {
                        line: l.number,
                        text: l.text.clone(),
                        code,
                        halt,
                    });
                }
                Reply::Alarm(code) => {
                    // Grbl has already stopped and dropped its planner: what it held is lost.
                    let halt = self.halt(f.run.last_acked, f.resume_at(None));
                    return Err(MachineError::Alarm { code, halt });
                }
                Reply::Welcome(_) => {
                    // Everything queued was lost with the reset; the laser is off.
                    let halt = Halt {
                        last_acked: f.run.last_acked,
                        resume_from: f.resume_at(None),
                        laser: "the controller reset itself, which turns the laser and the air off"
                            .into(),
                        locked: false,
                    };
                    return Err(MachineError::Restarted { halt });
                }
                Reply::Status(st) => {
                    finished |= f.acked_total == lines.len() && st.state == MachineState::Idle;
                    f.status(&st);
                    if !checking {
                        // Work is queued: lines in flight, or planner blocks in use (unknown
                        // without `Bf:`, then assumed).
                        let busy = !f.in_flight.is_empty()
                            || st
                                .buffer
                                .is_none_or(|(free, _)| (free as usize) < self.info.planner_blocks);
                        if let Some(stuck) = self.stall.observe(self.cfg.clock.0.now(), &st, busy) {
                            self.settle(&mut f);
                            let halt = self.halt(f.run.last_acked, f.resume_at(None));
                            return Err(MachineError::Stalled {
                                port: self.port_name.clone(),
                                still_s: stuck.still_for.as_secs_f64(),
                                bound_s: stuck.bound.as_secs_f64(),
                                position: stuck.position,
                                halt,
                            });
                        }
                    }
                    f.progress.elapsed = self.started.elapsed();
                    self.last_status = Some(st);
                    self.obs.progress(&f.progress);
                }
                Reply::Message(m) => self.obs.message(&format!("Grbl: {m}")),
                Reply::Feedback(fb) => self.obs.message(&format!("Grbl: [{fb}]")),
                Reply::Other(o) => self.obs.message(&format!("Grbl: {o}")),
            }
        }
        Ok(f.run)
    }

    /// Before stopping on purpose: feed hold (`!`) and wait until the machine has stopped, reading
    /// the acknowledgements still coming and a fresh status report. Stopping from a completed
    /// hold keeps Grbl's position (a reset while moving loses it: ALARM:3), and the report's free
    /// planner blocks tell exactly which acknowledged moves have not run.
    fn settle(&mut self, f: &mut Flight<'_>) {
        if self.link.write(&[RT_FEED_HOLD]).is_err() {
            return;
        }
        let end = Instant::now() + self.cfg.timeout.min(Duration::from_secs(5));
        let mut next_ask = Instant::now();
        while Instant::now() < end {
            if Instant::now() >= next_ask {
                if self.link.write(&[RT_STATUS]).is_err() {
                    return;
                }
                next_ask = Instant::now() + Duration::from_millis(200);
            }
            let Ok(Some(line)) = self.link.line(Duration::from_millis(50)) else {
                continue;
            };
            match Reply::parse(&line) {
                Reply::Ok if !f.in_flight.is_empty() => f.ack(),
                Reply::Error(_) if !f.in_flight.is_empty() => {
                    f.reject();
                }
                Reply::Status(st) => {
                    f.status(&st);
                    if matches!(
                        st.state,
                        MachineState::Hold(0) | MachineState::Idle | MachineState::Alarm
                    ) {
                        return;
                    }
                }
                Reply::Alarm(_) | Reply::Welcome(_) => return,
                _ => {}
            }
        }
    }

    fn fault(&mut self, e: LinkFault, f: &Flight<'_>) -> MachineError {
        let (last_acked, resume) = (f.run.last_acked, f.resume_at(None));
        match e {
            LinkFault::Lost(detail) => MachineError::PortLost {
                port: self.port_name.clone(),
                detail,
                halt: Halt {
                    last_acked,
                    resume_from: resume,
                    laser: "the laser could not be switched off from here: make sure it is off, \
                            and the air too (a board that lost its USB power is off)"
                        .into(),
                    locked: false,
                },
            },
            LinkFault::Silent(secs) => {
                let halt = self.halt(last_acked, resume);
                MachineError::Silent {
                    port: self.port_name.clone(),
                    secs,
                    halt,
                }
            }
        }
    }

    /// Stop the machine: soft reset (stops motion and the laser at once), wait for the banner,
    /// then `M5` unless the controller is locked in alarm (where the reset already did it).
    fn halt(&mut self, last_acked: Option<usize>, resume_from: usize) -> Halt {
        let (laser, locked) = self.stop_laser();
        Halt {
            last_acked,
            resume_from,
            laser,
            locked,
        }
    }

    /// What was done about the laser, and whether Grbl is now locked in alarm.
    fn stop_laser(&mut self) -> (String, bool) {
        if self.link.write(&[RT_SOFT_RESET]).is_err() {
            return (
                "the soft reset could not be sent: make sure the laser and the air are off".into(),
                false,
            );
        }
        let wait = self.cfg.timeout.min(Duration::from_secs(3));
        let (mut alarm, mut hinted) = (None, false);
        let welcomed = matches!(
            self.wait_welcome(wait, &mut alarm, &mut hinted),
            Ok(Some(_))
        );
        if !welcomed {
            // Air off, then the laser: M5 goes last, whatever else the board still takes.
            let _ = self.link.write(b"M9\nM5\n");
            return (
                "soft reset, M9 and M5 sent but Grbl did not answer: make sure the laser and the \
                 air are off"
                    .into(),
                false,
            );
        }
        // The unlock hint follows the banner when the reset left the machine locked.
        let end = Instant::now() + Duration::from_millis(300);
        while !hinted && Instant::now() < end {
            match self.link.line(Duration::from_millis(50)) {
                Ok(Some(l)) => match Reply::parse(&l) {
                    Reply::Message(m) => hinted |= protocol::is_unlock_hint(&m),
                    Reply::Alarm(a) => alarm = Some(a),
                    _ => {}
                },
                Ok(None) => {}
                Err(_) => break,
            }
        }
        if hinted || alarm.is_some() {
            return (
                "laser and air off (soft reset); the machine is locked: check it, then home it \
                 or unlock it (--unlock sends $X)"
                    .into(),
                true,
            );
        }
        // A soft reset already stops the spindle and the coolant; M9 (air assist) and M5 (laser)
        // say so to the controller's modal state too, air first so M5 is the last word.
        let air = self.command("M9").is_ok();
        match (air, self.command("M5").is_ok()) {
            (true, true) => (
                "laser and air off (soft reset, M9 and M5 acknowledged)".into(),
                false,
            ),
            (a, l) => (
                format!(
                    "laser and air off (soft reset; {} not acknowledged)",
                    match (a, l) {
                        (false, false) => "M9 and M5 were",
                        (false, _) => "M9 was",
                        _ => "M5 was",
                    }
                ),
                false,
            ),
        }
    }
}

/// The state of lines on their way to Grbl.
struct Flight<'l> {
    lines: &'l [Outgoing],
    start_line: usize,
    /// (index into `lines`, bytes) of lines sent and not yet answered, oldest first.
    in_flight: VecDeque<(usize, usize)>,
    in_flight_bytes: usize,
    /// Lines answered, preamble included.
    acked_total: usize,
    run: Run,
    tracker: Tracker,
    progress: Progress,
}

impl<'l> Flight<'l> {
    /// The oldest line in flight was answered: free its bytes.
    fn pop(&mut self) -> Option<&'l Outgoing> {
        let (idx, len) = self.in_flight.pop_front()?;
        self.in_flight_bytes -= len;
        Some(&self.lines[idx])
    }

    fn ack(&mut self) {
        let Some(l) = self.pop() else { return };
        self.acked_total += 1;
        if !l.preamble {
            self.run.acked += 1;
            self.run.last_acked = Some(l.number);
            if l.motion {
                self.tracker.acked_motion.push(l.number);
            }
        }
        self.progress.acked = self.run.acked;
        self.progress.last_acked_line = self.run.last_acked;
        self.progress.unexecuted_from = self.resume_at(None);
    }

    /// The oldest line in flight was rejected (in check mode it counts as answered).
    fn reject(&mut self) -> Option<&'l Outgoing> {
        let l = self.pop()?;
        self.acked_total += 1;
        if !l.preamble {
            self.run.acked += 1;
        }
        self.progress.acked = self.run.acked;
        Some(l)
    }

    fn status(&mut self, st: &Status) {
        self.tracker.status(st);
        self.progress.state = Some(st.state.clone());
        self.progress.position = st.position().or(self.progress.position);
        self.progress.overrides = st.overrides.or(self.progress.overrides);
        self.progress.status_line = st.line.or(self.progress.status_line);
        self.progress.unexecuted_from = self.resume_at(None);
    }

    /// Where to resume if the job stops now: the first line not acknowledged (or the rejected
    /// one), or an earlier acknowledged move that may still have been waiting in the planner.
    fn resume_at(&self, failed: Option<usize>) -> usize {
        let first_unanswered = failed
            .or_else(|| self.in_flight.front().map(|&(i, _)| self.lines[i].number))
            .or_else(|| self.lines.get(self.acked_total).map(|l| l.number))
            .unwrap_or_else(|| {
                self.lines
                    .last()
                    .map(|l| l.number + 1)
                    .unwrap_or(self.start_line)
            });
        self.tracker
            .first_unexecuted()
            .map_or(first_unanswered, |u| u.min(first_unanswered))
    }
}

#[derive(Default)]
struct Run {
    acked: usize,
    last_acked: Option<usize>,
    bytes: u64,
    elapsed: Duration,
    max_in_flight: usize,
    rejected: Vec<CheckRejection>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tracker_counts_planner_blocks() {
        let mut t = Tracker {
            planner_blocks: 15,
            acked_motion: (1..=20).collect(),
            motion_at_status: 0,
            planner_used_at_status: 0,
        };
        assert_eq!(t.first_unexecuted(), Some(1));
        let mut st = match Reply::parse("<Run|MPos:0,0,0|Bf:12,100>") {
            Reply::Status(s) => s,
            _ => unreachable!(),
        };
        t.status(&st);
        assert_eq!(t.first_unexecuted(), Some(18));
        t.acked_motion.push(21);
        assert_eq!(t.first_unexecuted(), Some(18));
        st.state = MachineState::Idle;
        t.status(&st);
        assert_eq!(t.first_unexecuted(), None);
        st.state = MachineState::Hold(0);
        st.buffer = None;
        t.status(&st);
        assert_eq!(t.first_unexecuted(), Some(7));
    }
}
