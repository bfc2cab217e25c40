//! The simulated board: its state, the main loop, the wire (paced at the baud rate, both ways)
//! and the record it publishes after every turn.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use stencil_gcode::interpret::{Modal, Move};

use super::config::{FaultKind, Pace, VirtualConfig};
use super::record::{lock, Record};
use super::storage::{Card, CardRun, Upload};
use super::wire::Wire;
use crate::protocol::{self, Firmware};

/// The controller's alarm state (motion states follow from the planner and the hold).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum State {
    Idle,
    Alarm,
    /// Alarm that waits for a soft reset before anything else (hard/soft limit).
    Critical,
}

/// What a line waits for before its `ok`, once its motion is queued.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Wait {
    /// G4 P: the queue runs out, then the dwell.
    Dwell(f64),
    /// G38.x (380 + x): the probe move runs out; no probe is wired.
    Probe(u16),
    /// M0: the queue runs out, then a hold until cycle start.
    Pause { held: bool },
    /// M2/M30: the queue runs out, then `[MSG:Pgm End]`.
    End,
    /// G4 at the machine's pace: its standing-still block is queued.
    Dwelling,
}

/// A line waiting, and which line it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct WaitFor {
    pub(super) wait: Wait,
    pub(super) idx: usize,
    /// The line queued motion (recorded as executed when that has run).
    pub(super) moved: bool,
}

/// Where the line buffer is in a comment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Comment {
    None,
    Paren,
    Semicolon,
}

/// A move in the planner queue.
pub(super) struct Block {
    pub(super) mv: Move,
    /// The line's N number, if it has one (reported as `Ln:`).
    pub(super) n: Option<u32>,
    /// Index into the record's `received`.
    pub(super) idx: usize,
    pub(super) remaining_s: f64,
    pub(super) duration_s: f64,
    /// A `$J=` jog: shown as `Jog`, dropped by a jog cancel (0x85).
    pub(super) jog: bool,
    /// The line's last block (an arc has one per chord): its line has run when this has.
    pub(super) last: bool,
}

/// The simulated controller, run on its own thread.
pub(super) struct Sim {
    pub(super) cfg: VirtualConfig,
    pub(super) port: Option<Wire>,
    pub(super) shared: Arc<Mutex<Record>>,
    pub(super) byte_time: Option<Duration>,
    pub(super) wire_in: VecDeque<(Instant, u8)>,
    pub(super) in_clock: Instant,
    pub(super) wire_out: VecDeque<(Instant, Vec<u8>)>,
    pub(super) out_clock: Instant,
    pub(super) rx: VecDeque<u8>,
    pub(super) line_buf: Vec<u8>,
    pub(super) line_overflow: bool,
    pub(super) comment: Comment,
    /// A setting being written to EEPROM: until when, and its line (answered when done).
    pub(super) eeprom: Option<(Instant, usize)>,
    /// A motion line taken from the buffer, waiting for a planner slot (its `ok` waits too).
    pub(super) pending: Option<(Move, usize)>,
    /// The rest of `pending`'s line: an arc's further chords.
    pub(super) pending_rest: VecDeque<Move>,
    /// What the line being queued waits for before its `ok` (a dwell, M0, a probe, M2).
    pub(super) line_wait: Option<Wait>,
    /// A line whose motion is queued, waiting for the queue to run out before its `ok`.
    pub(super) waiting: Option<WaitFor>,
    pub(super) planner: VecDeque<Block>,
    pub(super) modal: Modal,
    pub(super) state: State,
    pub(super) check_mode: bool,
    /// A feed hold is in force (Grbl's `Hold` state): `hold_decel` says whether the head is
    /// still slowing down (`Hold:1`) or stands (`Hold:0`).
    pub(super) hold: bool,
    /// Seconds of deceleration left and in all, while a hold brings a moving head to rest.
    pub(super) hold_decel: Option<(f64, f64)>,
    /// A feed hold byte arrived and waits for the next real-time pass (after any status report
    /// asked for in the same pass, as protocol_exec_rt_system orders them).
    pub(super) rt_hold: bool,
    /// The answer to the line being run goes wrong this way (an injected fault).
    pub(super) ok_fault: Option<FaultKind>,
    pub(super) silent: bool,
    pub(super) status_requested: bool,
    pub(super) reports: u64,
    pub(super) job_lines: usize,
    pub(super) last_tick: Instant,
    /// Grbl settings as `$$` lists them (number, value text).
    pub(super) settings: Vec<(u32, String)>,
    /// A `$N=V` setting waiting for its EEPROM write.
    pub(super) setting_pending: Option<(u32, String)>,
    /// Feed, rapid, spindle override %.
    pub(super) ov: [u32; 3],
    /// The next status report carries `Ov:` (Grbl sends it at once after a change).
    pub(super) ov_changed: bool,
    pub(super) frozen: bool,
    /// Work coordinate offset (G54): `modal.pos` is in work coordinates, planner blocks and
    /// reports in machine coordinates.
    pub(super) wco: [f64; 3],
    /// The next status report carries `WCO:` (Grbl sends it at once after a change).
    pub(super) wco_changed: bool,
    /// Lines of a job it was running before the host connected ([`VirtualConfig::mid_job`]),
    /// fed into the receive buffer as it frees.
    pub(super) backlog: VecDeque<u8>,
    /// Answers still owed to the sender that is gone: not heard by this host.
    pub(super) unheard: usize,
    /// Homed since it started (grblHAL reports it as `H:`).
    pub(super) homed: bool,
    /// The files on its card (grblHAL and FluidNC builds).
    pub(super) card: Card,
    /// A file arriving over the stream.
    pub(super) upload: Option<Upload>,
    /// The job it runs from its card.
    pub(super) card_run: Option<CardRun>,
    /// The last line as it came, case and slashes kept (a card command's file name).
    pub(super) last_raw: String,
    /// The line being received, as it comes.
    pub(super) raw_line: Vec<u8>,
}

impl Sim {
    pub(super) fn new(cfg: VirtualConfig, port: Wire, shared: Arc<Mutex<Record>>) -> Sim {
        let now = Instant::now();
        let byte_time = cfg
            .baud
            .filter(|&b| b > 0)
            .map(|b| Duration::from_secs_f64(10.0 / b as f64));
        let settings = cfg.initial_settings();
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
            pending_rest: VecDeque::new(),
            line_wait: None,
            waiting: None,
            planner: VecDeque::new(),
            modal: Modal::default(),
            state: State::Idle,
            check_mode: false,
            hold: false,
            hold_decel: None,
            rt_hold: false,
            ok_fault: None,
            silent: false,
            status_requested: false,
            reports: 0,
            job_lines: 0,
            last_tick: now,
            settings,
            setting_pending: None,
            ov: [100; 3],
            ov_changed: false,
            frozen: false,
            wco: [0.0; 3],
            wco_changed: false,
            backlog: VecDeque::new(),
            unheard: 0,
            homed: false,
            card: Card::new(),
            upload: None,
            card_run: None,
            last_raw: String::new(),
            raw_line: Vec::new(),
        };
        sim.apply_settings();
        if let Some(st) = sim.cfg.start.clone() {
            sim.modal.coords = st.coords;
            sim.modal.g92 = st.g92;
            sim.modal.tlo = st.tlo;
            sim.modal.coord_select = st.coord_select.min(5);
            sim.modal.pos = st.position.unwrap_or([0.0; 3]);
            sim.sync_wco();
        }
        match sim.cfg.mid_job.clone() {
            // Running since long before this host opened the port: no banner now.
            Some(text) => {
                let mut bytes = text.into_bytes();
                if bytes.last() != Some(&b'\n') {
                    bytes.push(b'\n');
                }
                sim.unheard = bytes.iter().filter(|&&b| b == b'\n').count();
                sim.backlog = bytes.into();
            }
            // grblHAL and FluidNC boards do not reset when a port opens: no banner then.
            None if sim.cfg.firmware == Firmware::Grbl => sim.boot_banner(),
            None => {}
        }
        sim.publish();
        sim
    }

    pub(super) fn run(&mut self, stop: &AtomicBool) {
        let mut buf = [0u8; 512];
        let mut stutter = self.cfg.stutter.map(|s| (s, s.seed));
        while !stop.load(Ordering::SeqCst) && self.port.is_some() {
            if let Some((s, state)) = stutter.as_mut() {
                std::thread::sleep(s.next_pause(state));
            }
            let now = Instant::now();
            self.deliver(now);
            self.advance(now);
            self.process_lines();
            self.card_tick();
            self.rt_pass();
            self.flush_out(Instant::now());
            self.publish();
            let wait = self.next_wait();
            let Some(port) = self.port.as_mut() else {
                break;
            };
            match port.read(&mut buf, wait) {
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
                // The host end is closed or not open: wait for it (or for stop).
                Err(_) => std::thread::sleep(Duration::from_millis(5)),
            }
        }
    }

    fn next_wait(&self) -> Duration {
        let now = Instant::now();
        let mut wait = Duration::from_millis(20);
        // Until the next byte lands, the next line goes out, or the EEPROM write ends.
        let next = [
            self.wire_in.front().map(|w| w.0),
            self.wire_out.front().map(|w| w.0),
        ];
        for t in next.into_iter().chain([self.eeprom.map(|e| e.0)]).flatten() {
            wait = wait.min(t.saturating_duration_since(now));
        }
        if let (Pace::Timed { .. }, false) = (self.cfg.pace, self.planner.is_empty()) {
            wait = wait.min(Duration::from_millis(2));
        }
        wait
    }

    /// Move bytes that have finished crossing the wire into the receive buffer (or act on them).
    fn deliver(&mut self, now: Instant) {
        while self.rx.len() < self.cfg.rx_buffer {
            let Some(b) = self.backlog.pop_front() else {
                break;
            };
            self.rx.push_back(b);
        }
        while let Some(&(t, b)) = self.wire_in.front() {
            if t > now {
                break;
            }
            self.wire_in.pop_front();
            if self.eeprom.is_some_and(|(until, _)| t < until) {
                lock(&self.shared).eeprom_lost_bytes += 1;
                continue;
            }
            if self.card_byte(b) {
                continue;
            }
            if protocol::is_realtime(b) {
                self.realtime(b);
                continue;
            }
            // While it runs a job from its card, the host's lines are dropped.
            if self.card_run.is_some() {
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

    /// Queue a line for the host (`\r\n` ended, as Grbl sends), paced at the baud rate if set.
    pub(super) fn say(&mut self, line: &str) {
        if self.silent {
            return;
        }
        if self.unheard > 0 && (line == "ok" || line.starts_with("error:")) {
            self.unheard -= 1;
            return;
        }
        let line = match (line, self.ok_fault) {
            ("ok", Some(FaultKind::DropOk)) => {
                self.ok_fault = None;
                return;
            }
            ("ok", Some(FaultKind::GarbleOk)) => {
                self.ok_fault = None;
                "okM"
            }
            (l, _) => l,
        };
        let mut bytes = line.as_bytes().to_vec();
        bytes.extend_from_slice(b"\r\n");
        let now = Instant::now() + self.cfg.latency;
        let at = match self.byte_time {
            Some(bt) => {
                self.out_clock = self.out_clock.max(now) + bt * bytes.len() as u32;
                self.out_clock
            }
            None => self.out_clock.max(now),
        };
        self.out_clock = self.out_clock.max(at);
        self.wire_out.push_back((at, bytes));
    }

    pub(super) fn flush_out(&mut self, now: Instant) {
        let due = self.wire_out.iter().take_while(|(t, _)| *t <= now).count();
        let out: Vec<u8> = self.wire_out.drain(..due).flat_map(|(_, b)| b).collect();
        if out.is_empty() {
            return;
        }
        if let Some(port) = self.port.as_mut() {
            port.write_all(&out);
        }
    }

    pub(super) fn publish(&mut self) {
        let state = self.state_word(false);
        let mut r = lock(&self.shared);
        r.position = self.position();
        r.wco = self.wco;
        r.laser_on = self.modal.spindle_on && self.modal.s > 0.0;
        r.air_on = self.modal.coolant;
        r.laser_mode = self.laser_mode();
        r.overrides = self.ov;
        r.frozen = self.frozen;
        if r.state != state {
            r.state = state.to_string();
        }
    }
}
