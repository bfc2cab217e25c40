//! A simulated Grbl 1.1h on a pseudo-terminal, for dry runs and tests.
//!
//! It speaks the real protocol on the far end of a pty pair, so `stencil send` runs exactly the same
//! code against it as against a board: welcome banner, a receive buffer of fixed size that drops
//! (and counts) overflowing bytes, `ok`/`error:N` per line through the shared G-code interpreter,
//! real-time `?` `!` `~` and soft reset, status reports whose position advances at the programmed
//! feeds through a planner queue (`ok` means queued, not executed), `$C`, `$I`, `$X`, `$H`, `$G`,
//! `$$`, jogs (`$J=`, refused in an alarm; 0x85 cancels them), `$H` (or `error:5` without
//! homing), `G10 L20/L2 P1` work offsets (reported as `WCO:`), and injected faults. It records
//! every line it received, what it executed and every move it planned, so a test can check the
//! machine got exactly the program, once each, in order, and where the head went.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

use stencil_gcode::interpret::{self as gcode, Modal, Move};
use super::protocol::{
    self, MAX_LINE_BYTES, PLANNER_BLOCKS_DEFAULT, RT_FEED_HOLD, RT_JOG_CANCEL, RT_RESUME,
    RT_SOFT_RESET, RT_STATUS, RX_BUFFER_DEFAULT,
};

/// How long writing one setting to EEPROM keeps the simulated Grbl deaf (a few ms on an AVR).
const EEPROM_WRITE: Duration = Duration::from_millis(20);

/// How the simulated machine spends time on motion (its pace; not a move).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pace {
    /// Moves complete the moment they are planned: a dry run goes as fast as the link allows.
    Instant,
    /// Moves take their length ÷ feed, divided by `speedup` (1.0 = as the machine would).
    Timed { speedup: f64 },
}

/// What goes wrong, for tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultKind {
    /// Answer `error:N` instead of running the line.
    Error(u8),
    /// Stop everything with `ALARM:N` when the line arrives (like a limit switch): motion and laser
    /// stop, buffers are dropped, and the controller waits for a soft reset, then stays locked.
    Alarm(u8),
    /// From this line on, read and act on everything but never answer.
    Silence,
    /// Close the port when this line arrives (a cable pulled; the board loses power, laser off).
    ClosePort,
    /// Freeze when this line arrives: the line is never answered, nothing more is taken from the
    /// receive buffer and nothing moves, yet status queries are still answered, in `Run` at a
    /// fixed position (a stalled planner or stepper driver: the firmware's serial interrupt
    /// lives on). A feed hold then reports a completed hold (nothing moves); a soft reset thaws
    /// it.
    Freeze,
}

/// A fault that fires once, when the `at_job_line`-th G-code line arrives (counting lines that are
/// not empty, not `$` commands, and not sent in check mode; 1-based).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fault {
    pub at_job_line: usize,
    pub kind: FaultKind,
}

/// The simulated controller's build.
#[derive(Clone, Debug)]
pub struct VirtualConfig {
    /// Receive buffer size in bytes (128 in stock Grbl); reported in `$I` as `[OPT:V,blocks,rx]`.
    pub rx_buffer: usize,
    pub planner_blocks: usize,
    pub pace: Pace,
    /// Pace the link at this baud rate (10 bits per byte, both directions); `None` = as fast as the
    /// pty goes.
    pub baud: Option<u32>,
    /// G0 rate, mm/min.
    pub rapid_mm_min: f64,
    pub faults: Vec<Fault>,
    /// Laser mode, `$32` (settable with `$32=0|1`): on, the beam never fires in G0 and M3/M4
    /// act as a laser; off, a switched-on spindle stays on through G0 moves too.
    pub laser_mode: bool,
    /// Report `Ln:` (the N number of the block being executed), as Grbl built with
    /// `USE_LINE_NUMBERS` does; stock Grbl does not.
    pub line_numbers: bool,
    /// Settings that differ from the simulated defaults (`$$` lists them), e.g. `(32, "0")`.
    pub settings: Vec<(u32, String)>,
    /// Homing enabled (`$22=1`): `$H` homes to machine zero and clears an alarm; disabled, `$H`
    /// answers `error:5` as Grbl does.
    pub homing: bool,
}

impl Default for VirtualConfig {
    fn default() -> Self {
        VirtualConfig {
            rx_buffer: RX_BUFFER_DEFAULT,
            planner_blocks: PLANNER_BLOCKS_DEFAULT,
            pace: Pace::Instant,
            baud: None,
            rapid_mm_min: 6000.0,
            faults: Vec::new(),
            laser_mode: true,
            line_numbers: false,
            settings: Vec::new(),
            homing: true,
        }
    }
}

/// One line the controller took out of its receive buffer.
#[derive(Clone, Debug, PartialEq)]
pub struct Received {
    /// The bytes of the line as received, without its terminator.
    pub text: String,
    /// Received while in `$C` check mode (parsed, never run).
    pub check_mode: bool,
}

/// Things that happened, in order.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// A line, as an index into [`Record::received`].
    Line(usize),
    Realtime(u8),
    SoftReset,
    Alarm(u8),
    Closed,
}

/// Everything the simulated machine saw and did.
#[derive(Clone, Debug, Default)]
pub struct Record {
    pub received: Vec<Received>,
    pub events: Vec<Event>,
    /// Indices into `received` of lines the machine finished (motion completed or command run).
    pub executed: Vec<usize>,
    /// Most bytes ever waiting in the receive buffer.
    pub max_rx_used: usize,
    /// Bytes dropped because the receive buffer was full.
    pub overflow_bytes: usize,
    /// Bytes lost because they arrived while Grbl wrote a `$x=` setting to its EEPROM.
    pub eeprom_lost_bytes: usize,
    /// Laser armed: M3/M4 active with S > 0.
    pub laser_on: bool,
    pub position: [f64; 3],
    pub state: String,
    pub closed: bool,
    /// Status reports sent (for checking the poll rate).
    pub status_reports: usize,
    /// Coolant output (M8; air assist on a laser) on.
    pub air_on: bool,
    /// Every move the planner accepted outside check mode (jogs too), in order, with the tool's
    /// state during it, in machine coordinates: what the head really went through (a test checks
    /// Z and the spindle during every XY move of a resume).
    pub moves: Vec<PlannedMove>,
    /// `$32` as it stands now.
    pub laser_mode: bool,
    /// Feed, rapid and spindle overrides in percent, as the last real-time bytes left them.
    pub overrides: [u32; 3],
    /// Frozen by [`FaultKind::Freeze`] (until a soft reset).
    pub frozen: bool,
    /// Work coordinate offset (G54, set with `G10 L20 P1` or `G10 L2 P1`): work = machine - WCO.
    pub wco: [f64; 3],
}

/// One move as the simulated planner took it (machine coordinates).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlannedMove {
    pub from: [f64; 3],
    pub to: [f64; 3],
    pub rapid: bool,
    /// M3/M4 on (a servo pen on the spindle output is down).
    pub spindle_on: bool,
    /// The beam fires during this move: spindle on with S > 0, and not a G0 or a jog in laser
    /// mode.
    pub beam: bool,
    /// Coolant (air assist) on during this move.
    pub air: bool,
    /// Index into [`Record::received`] of the line that made it.
    pub idx: usize,
}

impl PlannedMove {
    /// The move changes X or Y.
    pub fn moves_xy(&self) -> bool {
        self.from[0] != self.to[0] || self.from[1] != self.to[1]
    }
}

impl Record {
    /// The lines received outside check mode (what the machine was asked to run), in order.
    pub fn run_lines(&self) -> Vec<&str> {
        self.received
            .iter()
            .filter(|r| !r.check_mode)
            .map(|r| r.text.as_str())
            .collect()
    }
    pub fn soft_resets(&self) -> usize {
        self.events
            .iter()
            .filter(|e| **e == Event::SoftReset)
            .count()
    }
}

/// A running virtual Grbl. Dropping it stops the thread and closes its end of the pty.
pub struct VirtualGrbl {
    shared: Arc<Mutex<Record>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl VirtualGrbl {
    /// Start a virtual Grbl on a new pty pair; returns it and the host end to stream to.
    pub fn spawn(cfg: VirtualConfig) -> std::io::Result<(VirtualGrbl, TTYPort)> {
        let (master, host) = TTYPort::pair().map_err(std::io::Error::from)?;
        let shared = Arc::new(Mutex::new(Record::default()));
        let stop = Arc::new(AtomicBool::new(false));
        let mut sim = Sim::new(cfg, master, shared.clone());
        let stop2 = stop.clone();
        let thread = std::thread::Builder::new()
            .name("virtual-grbl".into())
            .spawn(move || sim.run(&stop2))?;
        Ok((
            VirtualGrbl {
                shared,
                stop,
                thread: Some(thread),
            },
            host,
        ))
    }

    /// A snapshot of what the machine saw so far.
    pub fn record(&self) -> Record {
        lock(&self.shared).clone()
    }

    /// Stop the machine and return its final record.
    pub fn stop(mut self) -> Record {
        self.halt();
        self.record()
    }

    fn halt(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for VirtualGrbl {
    fn drop(&mut self) {
        self.halt();
    }
}

/// The N number a line starts with (`N120G1X5` → 120).
fn line_number(text: &str) -> Option<u32> {
    let rest = text.strip_prefix('N').or_else(|| text.strip_prefix('n'))?;
    let end = rest
        .find(|c: char| !c.is_ascii_digit())
        .unwrap_or(rest.len());
    rest[..end].parse().ok()
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn lock(m: &Mutex<Record>) -> MutexGuard<'_, Record> {
    // A panic in the simulator thread must not hide its record from the test.
    m.lock().unwrap_or_else(|p| p.into_inner())
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum State {
    Idle,
    Alarm,
    /// Alarm that waits for a soft reset before anything else (hard/soft limit).
    Critical,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Comment {
    None,
    Paren,
    Semicolon,
}

struct Block {
    mv: Move,
    /// The line's N number, if it has one (reported as `Ln:`).
    n: Option<u32>,
    /// Index into the record's `received`.
    idx: usize,
    remaining_s: f64,
    duration_s: f64,
    /// A `$J=` jog: shown as `Jog`, dropped by a jog cancel (0x85).
    jog: bool,
}

struct Sim {
    cfg: VirtualConfig,
    port: Option<TTYPort>,
    shared: Arc<Mutex<Record>>,
    byte_time: Option<Duration>,
    wire_in: VecDeque<(Instant, u8)>,
    in_clock: Instant,
    wire_out: VecDeque<(Instant, Vec<u8>)>,
    out_clock: Instant,
    rx: VecDeque<u8>,
    line_buf: Vec<u8>,
    line_overflow: bool,
    comment: Comment,
    /// A setting being written to EEPROM: until when, and its line (answered when done).
    eeprom: Option<(Instant, usize)>,
    /// A motion line taken from the buffer, waiting for a planner slot (its `ok` waits too).
    pending: Option<(Move, usize)>,
    planner: VecDeque<Block>,
    modal: Modal,
    state: State,
    check_mode: bool,
    hold: bool,
    silent: bool,
    status_requested: bool,
    reports: u64,
    job_lines: usize,
    last_tick: Instant,
    /// Grbl settings as `$$` lists them (number, value text).
    settings: Vec<(u32, String)>,
    /// A `$N=V` setting waiting for its EEPROM write.
    setting_pending: Option<(u32, String)>,
    /// Feed, rapid, spindle override %.
    ov: [u32; 3],
    /// The next status report carries `Ov:` (Grbl sends it at once after a change).
    ov_changed: bool,
    frozen: bool,
    /// Work coordinate offset (G54): `modal.pos` is in work coordinates, planner blocks and
    /// reports in machine coordinates.
    wco: [f64; 3],
    /// The next status report carries `WCO:` (Grbl sends it at once after a change).
    wco_changed: bool,
}

impl Sim {
    fn new(cfg: VirtualConfig, port: TTYPort, shared: Arc<Mutex<Record>>) -> Sim {
        let now = Instant::now();
        let byte_time = cfg
            .baud
            .filter(|&b| b > 0)
            .map(|b| Duration::from_secs_f64(10.0 / b as f64));
        let mut sim = Sim {
            cfg,
            port: Some(port),
            shared,
            byte_time,
            wire_in: VecDeque::new(),
            in_clock: now,
            wire_out: VecDeque::new(),
            out_clock: now,
            rx: VecDeque::new(),
            line_buf: Vec::new(),
            line_overflow: false,
            comment: Comment::None,
            eeprom: None,
            pending: None,
            planner: VecDeque::new(),
            modal: Modal::default(),
            state: State::Idle,
            check_mode: false,
            hold: false,
            silent: false,
            status_requested: false,
            reports: 0,
            job_lines: 0,
            last_tick: now,
            settings: Vec::new(),
            setting_pending: None,
            ov: [100; 3],
            ov_changed: false,
            frozen: false,
            wco: [0.0; 3],
            wco_changed: false,
        };
        let rapid = format!("{:.3}", sim.cfg.rapid_mm_min);
        sim.settings = [
            (10, "2"),
            (11, "0.010"),
            (22, if sim.cfg.homing { "1" } else { "0" }),
            (30, "1000"),
            (31, "0"),
            (32, if sim.cfg.laser_mode { "1" } else { "0" }),
            (110, rapid.as_str()),
            (111, rapid.as_str()),
            (120, "1000.000"),
            (121, "1000.000"),
        ]
        .iter()
        .map(|&(k, v)| (k, v.to_string()))
        .collect();
        for (k, v) in sim.cfg.settings.clone() {
            match sim.settings.iter_mut().find(|(n, _)| *n == k) {
                Some(e) => e.1 = v,
                None => sim.settings.push((k, v)),
            }
        }
        sim.say("");
        sim.say("Grbl 1.1h ['$' for help]");
        sim.publish();
        sim
    }

    fn run(&mut self, stop: &AtomicBool) {
        let mut buf = [0u8; 512];
        while !stop.load(Ordering::SeqCst) && self.port.is_some() {
            let now = Instant::now();
            self.deliver(now);
            self.advance(now);
            self.process_lines();
            if self.status_requested {
                self.status_requested = false;
                self.status_report();
            }
            self.flush_out(Instant::now());
            self.publish();
            let wait = self.next_wait();
            let Some(port) = self.port.as_mut() else {
                break;
            };
            let _ = port.set_timeout(wait);
            match port.read(&mut buf) {
                Ok(0) => {}
                Ok(n) => {
                    let t = Instant::now();
                    for &b in &buf[..n] {
                        let at = match self.byte_time {
                            Some(bt) => {
                                self.in_clock = self.in_clock.max(t) + bt;
                                self.in_clock
                            }
                            None => t,
                        };
                        self.wire_in.push_back((at, b));
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                // The host end is closed or not open: wait for it (or for stop).
                Err(_) => std::thread::sleep(Duration::from_millis(5)),
            }
        }
    }

    fn next_wait(&self) -> Duration {
        let now = Instant::now();
        let mut wait = Duration::from_millis(20);
        if let Some(&(t, _)) = self.wire_in.front() {
            wait = wait.min(t.saturating_duration_since(now));
        }
        if let Some((t, _)) = self.wire_out.front() {
            wait = wait.min(t.saturating_duration_since(now));
        }
        if let Some((t, _)) = self.eeprom {
            wait = wait.min(t.saturating_duration_since(now));
        }
        if let (Pace::Timed { .. }, false) = (self.cfg.pace, self.planner.is_empty()) {
            wait = wait.min(Duration::from_millis(2));
        }
        wait
    }

    /// Move bytes that have finished crossing the wire into the receive buffer (or act on them).
    fn deliver(&mut self, now: Instant) {
        while let Some(&(t, b)) = self.wire_in.front() {
            if t > now {
                break;
            }
            self.wire_in.pop_front();
            if self.eeprom.is_some_and(|(until, _)| t < until) {
                lock(&self.shared).eeprom_lost_bytes += 1;
                continue;
            }
            if protocol::is_realtime(b) {
                self.realtime(b);
                continue;
            }
            if self.rx.len() >= self.cfg.rx_buffer {
                lock(&self.shared).overflow_bytes += 1;
            } else {
                self.rx.push_back(b);
                let used = self.rx.len();
                let mut r = lock(&self.shared);
                r.max_rx_used = r.max_rx_used.max(used);
            }
        }
    }

    fn realtime(&mut self, b: u8) {
        lock(&self.shared).events.push(Event::Realtime(b));
        match b {
            RT_STATUS => self.status_requested = true,
            RT_FEED_HOLD if self.state == State::Idle => self.hold = true,
            RT_RESUME => self.hold = false,
            RT_SOFT_RESET => self.soft_reset(),
            b @ 0x90..=0x9D => self.override_byte(b),
            RT_JOG_CANCEL => self.jog_cancel(),
            _ => {}
        }
    }

    /// Grbl's override bytes: feed 0x90 (100 %), 0x91/0x92 (±10), 0x93/0x94 (±1), 10..200 %;
    /// rapid 0x95/0x96/0x97 (100/50/25 %); spindle 0x99 (100 %), 0x9A/0x9B (±10), 0x9C/0x9D
    /// (±1), 10..200 %.
    fn override_byte(&mut self, b: u8) {
        let [f, r, s] = self.ov;
        let step = |v: u32, d: i32| (v as i32 + d).clamp(10, 200) as u32;
        self.ov = match b {
            0x90 => [100, r, s],
            0x91 => [step(f, 10), r, s],
            0x92 => [step(f, -10), r, s],
            0x93 => [step(f, 1), r, s],
            0x94 => [step(f, -1), r, s],
            0x95 => [f, 100, s],
            0x96 => [f, 50, s],
            0x97 => [f, 25, s],
            0x99 => [f, r, 100],
            0x9A => [f, r, step(s, 10)],
            0x9B => [f, r, step(s, -10)],
            0x9C => [f, r, step(s, 1)],
            0x9D => [f, r, step(s, -1)],
            _ => return,
        };
        self.ov_changed = true;
    }

    fn soft_reset(&mut self) {
        // A completed feed hold keeps the position: only a reset while moving loses it.
        let moving = (!self.planner.is_empty() || self.pending.is_some()) && !self.hold;
        lock(&self.shared).events.push(Event::SoftReset);
        self.rx.clear();
        self.line_buf.clear();
        self.line_overflow = false;
        self.comment = Comment::None;
        self.eeprom = None;
        self.pending = None;
        self.planner.clear();
        self.hold = false;
        self.check_mode = false;
        self.frozen = false;
        self.setting_pending = None;
        // A reset brings the overrides back to 100 %, as Grbl does.
        self.ov = [100; 3];
        let pos = self.modal.pos;
        self.modal = Modal {
            pos,
            ..Modal::default()
        };
        if moving && self.state == State::Idle {
            // Grbl: a reset during motion may have lost steps, so it locks until unlocked.
            self.say("ALARM:3");
            lock(&self.shared).events.push(Event::Alarm(3));
            self.state = State::Alarm;
        }
        if self.state == State::Critical {
            self.state = State::Alarm;
        }
        self.say("");
        self.say("Grbl 1.1h ['$' for help]");
        if self.state == State::Alarm {
            self.say("[MSG:'$H'|'$X' to unlock]");
        }
    }

    fn advance(&mut self, now: Instant) {
        let dt = now.saturating_duration_since(self.last_tick).as_secs_f64();
        self.last_tick = now;
        let Pace::Timed { speedup } = self.cfg.pace else {
            return;
        };
        if self.hold || self.frozen || self.state != State::Idle {
            return;
        }
        let mut budget = dt * speedup.max(1e-9);
        let [feed_ov, rapid_ov, _] = self.ov;
        while budget > 0.0 {
            let Some(b) = self.planner.front_mut() else {
                break;
            };
            // Overrides scale the rate: a block at 110 % takes 1/1.1 of its programmed time.
            let k = if b.mv.rapid { rapid_ov } else { feed_ov } as f64 / 100.0;
            if b.remaining_s > budget * k {
                b.remaining_s -= budget * k;
                break;
            }
            budget -= b.remaining_s / k;
            let done = self.planner.pop_front();
            if let Some(done) = done {
                lock(&self.shared).executed.push(done.idx);
            }
        }
    }

    /// The simulated tool position: the end of the last finished move, or part way along the
    /// current one.
    fn position(&self) -> [f64; 3] {
        match self.planner.front() {
            Some(b) => {
                let f = if b.duration_s > 0.0 {
                    1.0 - b.remaining_s / b.duration_s
                } else {
                    1.0
                };
                let mut p = [0.0; 3];
                for (a, v) in p.iter_mut().enumerate() {
                    *v = b.mv.from[a] + (b.mv.to[a] - b.mv.from[a]) * f;
                }
                p
            }
            None => add(self.modal.pos, self.wco),
        }
    }

    fn plan(&mut self, mv: Move, idx: usize) -> bool {
        if self.planner.len() >= self.cfg.planner_blocks {
            return false;
        }
        // Blocks run in machine coordinates: the work offset in force when the line was parsed.
        let mv = Move {
            from: add(mv.from, self.wco),
            to: add(mv.to, self.wco),
            ..mv
        };
        let laser_mode = self.laser_mode();
        let jog = {
            let mut r = lock(&self.shared);
            let jog = r
                .received
                .get(idx)
                .is_some_and(|l| l.text.starts_with("$J"));
            let m = &self.modal;
            r.moves.push(PlannedMove {
                from: mv.from,
                to: mv.to,
                rapid: mv.rapid,
                spindle_on: m.spindle_on,
                beam: m.spindle_on && m.s > 0.0 && !((mv.rapid || jog) && laser_mode),
                air: m.coolant,
                idx,
            });
            jog
        };
        match self.cfg.pace {
            Pace::Instant => lock(&self.shared).executed.push(idx),
            Pace::Timed { .. } => {
                let d = ((mv.to[0] - mv.from[0]).powi(2)
                    + (mv.to[1] - mv.from[1]).powi(2)
                    + (mv.to[2] - mv.from[2]).powi(2))
                .sqrt();
                let rate = if mv.rapid {
                    self.cfg.rapid_mm_min
                } else {
                    mv.feed
                };
                let t = if rate > 0.0 { d / rate * 60.0 } else { 0.0 };
                let n = lock(&self.shared)
                    .received
                    .get(idx)
                    .and_then(|r| line_number(&r.text));
                self.planner.push_back(Block {
                    mv,
                    n,
                    idx,
                    remaining_s: t,
                    duration_s: t,
                    jog,
                });
            }
        }
        true
    }

    /// Pull lines out of the receive buffer and run them, as Grbl's main loop does: it stops
    /// pulling while a motion line waits for a free planner block.
    fn process_lines(&mut self) {
        loop {
            if self.state == State::Critical || self.port.is_none() || self.frozen {
                return;
            }
            if let Some((until, idx)) = self.eeprom {
                if Instant::now() < until {
                    return;
                }
                self.eeprom = None;
                if let Some((k, v)) = self.setting_pending.take() {
                    match self.settings.iter_mut().find(|(n, _)| *n == k) {
                        Some(e) => e.1 = v,
                        None => self.settings.push((k, v)),
                    }
                }
                self.done(idx);
            }
            if let Some((mv, idx)) = self.pending.take() {
                if !self.plan(mv, idx) {
                    self.pending = Some((mv, idx));
                    return;
                }
                self.say("ok");
                continue;
            }
            let Some(b) = self.rx.pop_front() else {
                return;
            };
            // As Grbl fills its line buffer: comments, spaces, control characters and block
            // delete never enter it; what is left must fit 79 characters.
            if b == b'\n' || b == b'\r' {
                let raw = std::mem::take(&mut self.line_buf);
                let overflow = std::mem::replace(&mut self.line_overflow, false);
                self.comment = Comment::None;
                self.line(String::from_utf8_lossy(&raw).into_owned(), overflow);
            } else if self.comment == Comment::Paren {
                if b == b')' {
                    self.comment = Comment::None;
                }
            } else if self.comment == Comment::Semicolon {
            } else if b == b'(' {
                self.comment = Comment::Paren;
            } else if b == b';' {
                self.comment = Comment::Semicolon;
            } else if b <= b' ' || b == b'/' {
            } else if self.line_buf.len() >= MAX_LINE_BYTES {
                self.line_overflow = true;
            } else {
                self.line_buf.push(b.to_ascii_uppercase());
            }
        }
    }

    fn line(&mut self, text: String, overflow: bool) {
        let idx = {
            let mut r = lock(&self.shared);
            r.received.push(Received {
                text: text.clone(),
                check_mode: self.check_mode,
            });
            let idx = r.received.len() - 1;
            r.events.push(Event::Line(idx));
            idx
        };
        let clean = gcode::clean_line(&text);
        if overflow {
            return self.reply_error(11);
        }
        if clean.is_empty() {
            return self.done(idx);
        }
        if clean.starts_with('$') {
            return self.system(&clean, idx);
        }
        if self.state == State::Alarm {
            return self.reply_error(9);
        }
        if !self.check_mode {
            self.job_lines += 1;
            let n = self.job_lines;
            if let Some(pos) = self.cfg.faults.iter().position(|f| f.at_job_line == n) {
                let f = self.cfg.faults.remove(pos);
                match f.kind {
                    FaultKind::Error(code) => return self.reply_error(code),
                    FaultKind::Alarm(code) => return self.alarm(code),
                    FaultKind::Silence => self.silent = true,
                    FaultKind::ClosePort => return self.close(),
                    FaultKind::Freeze => {
                        self.frozen = true;
                        return;
                    }
                }
            }
        }
        if clean.starts_with("G10") {
            return self.set_work_offset(&clean, idx);
        }
        let mut modal = self.modal;
        match gcode::step(&mut modal, &clean, idx + 1) {
            Err(e) => self.reply_error(e.code),
            Ok(mv) => {
                self.modal = modal;
                match mv {
                    Some(mv) if !self.check_mode => {
                        if self.plan(mv, idx) {
                            self.say("ok");
                        } else {
                            self.pending = Some((mv, idx));
                        }
                    }
                    _ => self.done(idx),
                }
            }
        }
    }

    fn done(&mut self, idx: usize) {
        lock(&self.shared).executed.push(idx);
        self.say("ok");
    }

    fn reply_error(&mut self, code: u8) {
        self.say(&format!("error:{code}"));
    }

    fn alarm(&mut self, code: u8) {
        self.planner.clear();
        self.pending = None;
        self.rx.clear();
        self.hold = false;
        // An alarm kills the spindle and the coolant at once.
        self.modal.spindle_on = false;
        self.modal.coolant = false;
        self.state = State::Critical;
        lock(&self.shared).events.push(Event::Alarm(code));
        self.say(&format!("ALARM:{code}"));
        self.say("[MSG:Reset to continue]");
    }

    fn close(&mut self) {
        // Bytes already on the wire still arrive.
        self.flush_out(Instant::now() + Duration::from_secs(3600));
        // The board lost power: its outputs are off.
        self.modal.spindle_on = false;
        self.modal.coolant = false;
        self.planner.clear();
        {
            let mut r = lock(&self.shared);
            r.events.push(Event::Closed);
            r.closed = true;
        }
        self.publish();
        self.port = None;
    }

    fn system(&mut self, cmd: &str, idx: usize) {
        let idle = self.planner.is_empty() && self.pending.is_none();
        match cmd {
            "$I" => {
                self.say("[VER:1.1h.20190830:]");
                let opt = format!("[OPT:V,{},{}]", self.cfg.planner_blocks, self.cfg.rx_buffer);
                self.say(&opt);
                self.done(idx);
            }
            "$C" => {
                if !idle || self.state == State::Alarm {
                    return self.reply_error(8);
                }
                if self.check_mode {
                    self.say("[MSG:Disabled]");
                    self.done(idx);
                    self.soft_reset();
                } else {
                    self.check_mode = true;
                    self.say("[MSG:Enabled]");
                    self.done(idx);
                }
            }
            "$X" => {
                if self.state == State::Alarm {
                    self.state = State::Idle;
                    self.say("[MSG:Caution: Unlocked]");
                }
                self.done(idx);
            }
            "$H" => {
                if !self.cfg.homing {
                    return self.reply_error(5);
                }
                if !idle {
                    return self.reply_error(8);
                }
                // Homed: machine zero (work coordinates keep their offset).
                self.modal.pos = [-self.wco[0], -self.wco[1], -self.wco[2]];
                self.state = State::Idle;
                self.done(idx);
            }
            "$G" => {
                let m = &self.modal;
                let gc = format!(
                    "[GC:G{} G54 G17 {} {} G94 {} M9 T0 F{} S{}]",
                    m.motion,
                    if m.metric { "G21" } else { "G20" },
                    if m.absolute { "G90" } else { "G91" },
                    match (m.spindle_on, m.dynamic) {
                        (false, _) => "M5",
                        (true, true) => "M4",
                        (true, false) => "M3",
                    },
                    m.feed.unwrap_or(0.0),
                    m.s
                );
                self.say(&gc);
                self.done(idx);
            }
            "$$" => {
                let dump: Vec<String> = self
                    .settings
                    .iter()
                    .map(|(k, v)| format!("${k}={v}"))
                    .collect();
                for l in dump {
                    self.say(&l);
                }
                self.done(idx);
            }
            c if c.starts_with("$J") => self.jog(c, idx),
            c if c[1..]
                .split_once('=')
                .is_some_and(|(k, v)| k.parse::<u32>().is_ok() && v.parse::<f64>().is_ok()) =>
            {
                if self.check_mode || !idle {
                    return self.reply_error(8);
                }
                let (k, v) = c[1..].split_once('=').unwrap_or_default();
                self.setting_pending = k.parse().ok().map(|k| (k, v.to_string()));
                // Writing EEPROM stops Grbl's serial interrupt: bytes that arrive meanwhile are
                // lost, and the `ok` comes when the write is done.
                self.eeprom = Some((Instant::now() + EEPROM_WRITE, idx));
            }
            _ => self.reply_error(3),
        }
    }

    /// The planner runs a jog (`$J=`): Grbl's `Jog` state.
    fn jogging(&self) -> bool {
        self.planner.front().is_some_and(|b| b.jog)
    }

    /// `$J=...`: a jog motion, as Grbl 1.1 takes it (system.c, gcode.c, jog.c): only while Idle
    /// or already jogging (else `error:8`, so never in an alarm), F required (`error:22`), only
    /// G20/G21, G90/G91 and G53 besides X/Y/Z, F and N (`error:16`). The parser's modes are
    /// left as they were; its position moves to the jog's target, as Grbl's does.
    fn jog(&mut self, cmd: &str, idx: usize) {
        let busy = self.pending.is_some() || self.planner.iter().any(|b| !b.jog) || self.hold;
        if self.state != State::Idle || self.check_mode || busy {
            return self.reply_error(8);
        }
        let Some(body) = cmd.strip_prefix("$J=") else {
            return self.reply_error(3);
        };
        let words = match gcode::words(body, idx + 1) {
            Ok(w) => w,
            Err(e) => return self.reply_error(e.code),
        };
        let (mut metric, mut absolute, mut machine) =
            (self.modal.metric, self.modal.absolute, false);
        let (mut feed, mut target) = (None, [None::<f64>; 3]);
        for (l, v) in words {
            match l {
                'G' if v == 20.0 || v == 21.0 => metric = v == 21.0,
                'G' if v == 90.0 || v == 91.0 => absolute = v == 90.0,
                'G' if v == 53.0 => machine = true,
                'G' | 'M' => return self.reply_error(16),
                'F' => feed = Some(v),
                'X' => target[0] = Some(v),
                'Y' => target[1] = Some(v),
                'Z' => target[2] = Some(v),
                'N' => {}
                'S' | 'T' => return self.reply_error(36),
                _ => return self.reply_error(20),
            }
        }
        let unit = if metric { 1.0 } else { 25.4 };
        let Some(feed) = feed.filter(|f| *f > 0.0) else {
            return self.reply_error(22);
        };
        if target.iter().all(Option::is_none) {
            return self.reply_error(26);
        }
        let from = self.modal.pos;
        let mut to = from;
        for a in 0..3 {
            if let Some(v) = target[a] {
                to[a] = match (machine, absolute) {
                    (true, _) => v * unit - self.wco[a],
                    (false, true) => v * unit,
                    (false, false) => from[a] + v * unit,
                };
            }
        }
        if to
            .iter()
            .any(|v| !v.is_finite() || v.abs() > gcode::MAX_COORD_MM)
        {
            return self.reply_error(15);
        }
        self.modal.pos = to;
        let mv = Move {
            from,
            to,
            rapid: false,
            feed: feed * unit,
            power: 0.0,
            spindle_s: 0.0,
            line: idx + 1,
        };
        if self.plan(mv, idx) {
            self.say("ok");
        } else {
            self.pending = Some((mv, idx));
        }
    }

    /// 0x85: stop the running jog where it is and drop the queued jog motions; the parser's
    /// position follows the machine's (Grbl's `gc_sync_position`). Ignored unless jogging.
    fn jog_cancel(&mut self) {
        if !self.jogging() || self.state != State::Idle {
            return;
        }
        let pos = self.position();
        self.planner.retain(|b| !b.jog);
        if self.pending.is_some() {
            // A jog still waiting for a planner slot: dropped, but it was not answered yet.
            self.pending = None;
            self.say("ok");
        }
        for (a, p) in pos.iter().enumerate() {
            self.modal.pos[a] = p - self.wco[a];
        }
    }

    /// `G10 L20 P1 X.. Y..` (the current position becomes these work coordinates) and
    /// `G10 L2 P1 X..` (G54's offset itself). P0 is the active system, here always G54; P2..P6
    /// are taken and kept nowhere (nothing here selects them). The offset counts from the end
    /// of the queued motion, as Grbl (which waits for the queue to empty first) would see it.
    fn set_work_offset(&mut self, clean: &str, idx: usize) {
        let words = match gcode::words(clean, idx + 1) {
            Ok(w) => w,
            Err(e) => return self.reply_error(e.code),
        };
        let (mut l, mut p, mut axes) = (None, None, [None::<f64>; 3]);
        for (w, v) in words {
            match w {
                'G' if v == 10.0 => {}
                'L' => l = Some(v),
                'P' => p = Some(v),
                'X' => axes[0] = Some(v),
                'Y' => axes[1] = Some(v),
                'Z' => axes[2] = Some(v),
                _ => return self.reply_error(20),
            }
        }
        let Some(p) = p else {
            return self.reply_error(28);
        };
        let l20 = match l {
            Some(20.0) => true,
            Some(2.0) => false,
            _ => return self.reply_error(28),
        };
        if !(0.0..=6.0).contains(&p) || p.fract() != 0.0 {
            return self.reply_error(29);
        }
        if self.check_mode || p > 1.0 {
            return self.done(idx);
        }
        let unit = if self.modal.metric { 1.0 } else { 25.4 };
        for a in 0..3 {
            if let Some(v) = axes[a] {
                let machine = self.modal.pos[a] + self.wco[a];
                self.wco[a] = if l20 { machine - v * unit } else { v * unit };
                self.modal.pos[a] = machine - self.wco[a];
            }
        }
        self.wco_changed = true;
        self.done(idx);
    }

    fn status_report(&mut self) {
        self.reports += 1;
        let state = match self.state {
            State::Alarm | State::Critical => "Alarm".to_string(),
            State::Idle if self.check_mode => "Check".to_string(),
            State::Idle if self.hold => "Hold:0".to_string(),
            State::Idle if self.frozen => "Run".to_string(),
            State::Idle if self.jogging() => "Jog".to_string(),
            State::Idle if !self.planner.is_empty() => "Run".to_string(),
            State::Idle => "Idle".to_string(),
        };
        let p = self.position();
        let running = !self.planner.is_empty() && !self.hold && self.state == State::Idle;
        let [feed_ov, rapid_ov, spindle_ov] = self.ov;
        let (feed, speed) = match self.planner.front() {
            Some(b) if running => (
                if b.mv.rapid {
                    self.cfg.rapid_mm_min * rapid_ov as f64 / 100.0
                } else {
                    b.mv.feed * feed_ov as f64 / 100.0
                },
                b.mv.power * spindle_ov as f64 / 100.0,
            ),
            // A frozen machine still claims its programmed feed: nothing in the report gives
            // the stall away but the position standing still.
            _ if self.frozen && !self.hold => (self.modal.feed.unwrap_or(0.0), 0.0),
            _ => (0.0, 0.0),
        };
        let mut s = format!(
            "<{state}|MPos:{:.3},{:.3},{:.3}|Bf:{},{}|FS:{feed:.0},{speed:.0}",
            p[0],
            p[1],
            p[2],
            self.cfg.planner_blocks - self.planner.len(),
            self.cfg.rx_buffer - self.rx.len(),
        );
        if self.cfg.line_numbers {
            if let Some(n) = self.planner.front().and_then(|b| b.n) {
                s.push_str(&format!("|Ln:{n}"));
            }
        }
        // As Grbl: WCO every 10 reports and at once after a change; Ov every 10 reports and at
        // once after a change (never in the same report as WCO), with the accessory states
        // (spindle CW/CCW, flood) when any is on.
        // A change of overrides is reported at once, ahead of a periodic WCO.
        if self.wco_changed || (self.reports % 10 == 1 && !self.ov_changed) {
            self.wco_changed = false;
            let w = self.wco;
            s.push_str(&format!("|WCO:{:.3},{:.3},{:.3}", w[0], w[1], w[2]));
        } else if self.reports % 10 == 2 || self.ov_changed {
            self.ov_changed = false;
            s.push_str(&format!("|Ov:{feed_ov},{rapid_ov},{spindle_ov}"));
            let mut a = String::new();
            if self.modal.spindle_on {
                a.push(if self.modal.dynamic { 'C' } else { 'S' });
            }
            if self.modal.coolant {
                a.push('F');
            }
            if !a.is_empty() {
                s.push_str(&format!("|A:{a}"));
            }
        }
        s.push('>');
        lock(&self.shared).status_reports += 1;
        self.say(&s);
    }

    fn laser_mode(&self) -> bool {
        self.settings
            .iter()
            .find(|(k, _)| *k == 32)
            .is_some_and(|(_, v)| v.parse::<f64>().is_ok_and(|v| v != 0.0))
    }

    /// Queue a line for the host (`\r\n` ended, as Grbl sends), paced at the baud rate if set.
    fn say(&mut self, line: &str) {
        if self.silent {
            return;
        }
        let mut bytes = line.as_bytes().to_vec();
        bytes.extend_from_slice(b"\r\n");
        let now = Instant::now();
        let at = match self.byte_time {
            Some(bt) => {
                self.out_clock = self.out_clock.max(now) + bt * bytes.len() as u32;
                self.out_clock
            }
            None => now,
        };
        self.wire_out.push_back((at, bytes));
    }

    fn flush_out(&mut self, now: Instant) {
        let mut out = Vec::new();
        while let Some((t, _)) = self.wire_out.front() {
            if *t > now {
                break;
            }
            if let Some((_, b)) = self.wire_out.pop_front() {
                out.extend_from_slice(&b);
            }
        }
        if out.is_empty() {
            return;
        }
        if let Some(port) = self.port.as_mut() {
            let _ = port.set_timeout(Duration::from_millis(200));
            let _ = port.write_all(&out);
        }
    }

    fn publish(&mut self) {
        let pos = self.position();
        let laser = self.modal.spindle_on && self.modal.s > 0.0;
        let air = self.modal.coolant;
        let laser_mode = self.laser_mode();
        let state = match self.state {
            State::Idle if self.check_mode => "Check",
            State::Idle if self.hold => "Hold",
            State::Idle if self.jogging() => "Jog",
            State::Idle if !self.planner.is_empty() => "Run",
            State::Idle => "Idle",
            State::Alarm | State::Critical => "Alarm",
        };
        let mut r = lock(&self.shared);
        r.position = pos;
        r.wco = self.wco;
        r.laser_on = laser;
        r.air_on = air;
        r.laser_mode = laser_mode;
        r.overrides = self.ov;
        r.frozen = self.frozen;
        if r.state != state {
            r.state = state.to_string();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read_until(port: &mut TTYPort, needle: &str, limit: Duration) -> String {
        let mut got = String::new();
        let end = Instant::now() + limit;
        let mut buf = [0u8; 256];
        port.set_timeout(Duration::from_millis(20)).unwrap();
        while Instant::now() < end && !got.contains(needle) {
            if let Ok(n) = port.read(&mut buf) {
                got.push_str(&String::from_utf8_lossy(&buf[..n]));
            }
        }
        got
    }

    #[test]
    fn banner_ok_errors_and_status() {
        let (vg, mut host) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
        let s = read_until(&mut host, "for help]", Duration::from_secs(5));
        assert!(s.contains("Grbl 1.1h ['$' for help]"), "{s:?}");
        host.write_all(b"G1X1\n").unwrap();
        let s = read_until(&mut host, "\r\n", Duration::from_secs(5));
        assert_eq!(s, "error:22\r\n");
        host.write_all(b"G5X1\n$I\n").unwrap();
        let s = read_until(&mut host, "ok\r\n", Duration::from_secs(5));
        assert_eq!(
            s,
            "error:20\r\n[VER:1.1h.20190830:]\r\n[OPT:V,15,128]\r\nok\r\n"
        );
        host.write_all(b"G0X3Y4F100\n?").unwrap();
        let s = read_until(&mut host, ">", Duration::from_secs(5));
        assert!(
            s.starts_with("ok\r\n<Idle|MPos:3.000,4.000,0.000|"),
            "{s:?}"
        );
        // Comments and spaces do not count; 79 characters fit, 80 do not.
        let fits = format!("g0 x1. (a comment){}\n", "0".repeat(74));
        let long = format!("G0X1{}\n", "0".repeat(76));
        host.write_all(fits.as_bytes()).unwrap();
        assert_eq!(
            read_until(&mut host, "\r\n", Duration::from_secs(5)),
            "ok\r\n"
        );
        host.write_all(long.as_bytes()).unwrap();
        let s = read_until(&mut host, "\r\n", Duration::from_secs(5));
        assert_eq!(s, "error:11\r\n");
        let r = vg.stop();
        assert_eq!(r.run_lines()[..4], ["G1X1", "G5X1", "$I", "G0X3Y4F100"]);
        assert_eq!(r.run_lines()[4].len(), 79);
        assert_eq!(r.overflow_bytes, 0);
    }

    #[test]
    fn overrides_scale_feed_and_power_and_are_reported() {
        let cfg = VirtualConfig {
            pace: Pace::Timed { speedup: 1.0 },
            ..VirtualConfig::default()
        };
        let (vg, mut host) = VirtualGrbl::spawn(cfg).unwrap();
        read_until(&mut host, "for help]", Duration::from_secs(5));
        host.write_all(b"M3S500\nM8\nG1X100F600\n").unwrap();
        read_until(&mut host, "ok\r\nok\r\nok\r\n", Duration::from_secs(5));
        // +10 % twice, -10 % once on the feed; -10 % on the power; Ov comes at once.
        host.write_all(&[0x91, 0x91, 0x92, 0x9B, b'?']).unwrap();
        let s = read_until(&mut host, ">", Duration::from_secs(5));
        assert!(s.contains("|FS:660,450|"), "{s:?}");
        assert!(s.contains("|Ov:110,100,90|A:SF>"), "{s:?}");
        // Limits: 200 % at most; resets.
        host.write_all(&[0x91; 15]).unwrap();
        host.write_all(&[0x90, 0x99, b'?']).unwrap();
        let s = read_until(&mut host, ">", Duration::from_secs(5));
        assert!(s.contains("|FS:600,500|"), "{s:?}");
        for _ in 0..200 {
            if vg.record().overrides == [100; 3] {
                break;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        let r = vg.stop();
        assert_eq!(r.overrides, [100; 3]);
        assert!(r.air_on);
        let ov = r
            .events
            .iter()
            .filter(|e| matches!(e, Event::Realtime(b) if *b >= 0x90))
            .count();
        assert_eq!(ov, 4 + 15 + 2);
    }

    #[test]
    fn overrides_stop_at_their_limits() {
        let (vg, mut host) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
        read_until(&mut host, "for help]", Duration::from_secs(5));
        host.write_all(&[0x91; 15]).unwrap();
        host.write_all(&[0x9B; 15]).unwrap();
        host.write_all(b"?").unwrap();
        let s = read_until(&mut host, ">", Duration::from_secs(5));
        assert!(s.contains("|Ov:200,100,10"), "{s:?}");
        drop(vg);
    }

    #[test]
    fn overflowing_bytes_are_dropped_and_counted() {
        let cfg = VirtualConfig {
            rx_buffer: 16,
            pace: Pace::Timed { speedup: 1.0 },
            ..VirtualConfig::default()
        };
        let (vg, mut host) = VirtualGrbl::spawn(cfg).unwrap();
        read_until(&mut host, "for help]", Duration::from_secs(5));
        // A long move fills the one-block planner... here 15 blocks; then lines pile up in rx.
        let mut prog = String::from("G1X100F60\n");
        for i in 0..40 {
            prog.push_str(&format!("G1X{}\n", 100 + i));
        }
        host.write_all(prog.as_bytes()).unwrap();
        let end = Instant::now() + Duration::from_secs(5);
        while vg.record().overflow_bytes == 0 && Instant::now() < end {
            std::thread::sleep(Duration::from_millis(10));
        }
        let r = vg.stop();
        assert!(r.overflow_bytes > 0);
        assert!(r.max_rx_used <= 16);
    }

    #[test]
    fn reset_during_motion_locks_until_unlock() {
        let cfg = VirtualConfig {
            pace: Pace::Timed { speedup: 1.0 },
            ..VirtualConfig::default()
        };
        let (vg, mut host) = VirtualGrbl::spawn(cfg).unwrap();
        read_until(&mut host, "for help]", Duration::from_secs(5));
        host.write_all(b"M4S500\nG1X100F60\n").unwrap();
        read_until(&mut host, "ok\r\nok\r\n", Duration::from_secs(5));
        // `ok` means queued: the simulated planner starts the move (and the laser) a moment later.
        let t0 = std::time::Instant::now();
        while !vg.record().laser_on && t0.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(5));
        }
        assert!(vg.record().laser_on);
        host.write_all(&[RT_SOFT_RESET]).unwrap();
        let s = read_until(&mut host, "to unlock]", Duration::from_secs(5));
        assert!(s.contains("ALARM:3") && s.contains("Grbl 1.1h"), "{s:?}");
        // The record is a snapshot the simulator publishes after its replies: wait for it.
        let t0 = std::time::Instant::now();
        while vg.record().laser_on && t0.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(5));
        }
        assert!(!vg.record().laser_on);
        host.write_all(b"G0X1\n").unwrap();
        assert_eq!(
            read_until(&mut host, "\r\n", Duration::from_secs(5)),
            "error:9\r\n"
        );
        host.write_all(b"$X\nG0X1\n").unwrap();
        let s = read_until(&mut host, "ok\r\nok\r\n", Duration::from_secs(5));
        assert!(
            s.ends_with("[MSG:Caution: Unlocked]\r\nok\r\nok\r\n"),
            "{s:?}"
        );
        drop(vg);
    }
}
