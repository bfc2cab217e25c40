//! A controller held open for commands one at a time: jogging, homing, unlocking, setting work
//! zero, and running a short program such as a frame.
//!
//! It is the streamer's own session (connect, `$I`, send-response commands, status queries, the
//! stop that switches the laser off) kept open between commands, so jog and frame meet the same
//! protocol code, the same faults and the same laser-off stop as `send`. Unlike `send`, a machine
//! locked in alarm is connected all the same: unlocking (`$X`) or homing (`$H`) it is what the
//! user came to do.

use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use super::config::{Control, StreamConfig};
use super::flight::Outgoing;
use super::link::BytePort;
use super::observe::{ControllerInfo, Observer, Summary};
use super::session::Session;
use crate::error::MachineError;
use crate::program::Program;
use crate::protocol::{MachineState, Reply, Status};

/// A status report with the work position worked out.
#[derive(Clone, Debug, PartialEq)]
pub struct Position {
    /// The report itself.
    pub status: Status,
    /// Machine position, mm (`MPos`, or `WPos` + offset).
    pub machine: [f64; 3],
    /// Work position, mm: what a program's coordinates mean (`WPos`, or `MPos` - `WCO`).
    pub work: [f64; 3],
    /// The work coordinate offset used (zero until Grbl has reported one).
    pub wco: [f64; 3],
}

/// An open session with a controller.
pub struct Console<'a> {
    s: Session<'a, 'a>,
    /// The last work coordinate offset Grbl reported (it sends `WCO:` only every few reports).
    wco: Option<[f64; 3]>,
    locked: bool,
}

/// The most status queries spent waiting for a `WCO:` field (Grbl 1.1 sends one at least every
/// 10 reports while idle, and in the first report after a reset).
const WCO_QUERIES: usize = 12;

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

impl<'a> Console<'a> {
    /// Connect: banner (waking a board that did not reset on open), `$I`, the machine's state.
    /// With `cfg.unlock` a locked machine is unlocked (`$X`); without it, it stays locked and
    /// [`Console::locked`] says so. A machine that is busy (running, holding) is refused.
    pub fn connect(
        port: &'a mut dyn BytePort,
        cfg: &'a StreamConfig,
        controls: Option<&'a Receiver<Control>>,
        obs: &'a mut dyn Observer,
    ) -> Result<Console<'a>, MachineError> {
        // No program to time here: a frame or a jog is a few long moves, whose position changes
        // in every report while they run, so only a machine standing still in Run for half a
        // minute (plus the margin) counts as stalled.
        let stall = crate::stall::stall_bound(Duration::from_secs(30));
        let mut s = Session::new(port, cfg, controls, obs, stall);
        let locked = match s.connect() {
            Ok(()) => false,
            Err(MachineError::Locked { alarm, .. }) => {
                let why = alarm
                    .map(|a| format!(" (ALARM:{a}: {})", crate::protocol::alarm_meaning(a)))
                    .unwrap_or_default();
                s.obs
                    .message(&format!("the machine is locked in alarm{why}"));
                true
            }
            Err(e) => return Err(e),
        };
        Ok(Console {
            s,
            wco: None,
            locked,
        })
    }

    /// What the controller said about itself.
    pub fn info(&self) -> &ControllerInfo {
        &self.s.info
    }

    /// Connecting found the machine running moves it was given before, and stopped them as asked
    /// ([`IfMoving::Stop`](super::config::IfMoving::Stop)): what it had queued did not all run.
    pub fn stopped_running(&self) -> bool {
        self.s.stopped_running
    }

    /// The machine was locked in alarm when last seen.
    pub fn locked(&self) -> bool {
        self.locked
    }

    /// The port's name, for messages.
    pub fn port_name(&self) -> &str {
        &self.s.port_name
    }

    /// Pass a message to the front end.
    pub fn say(&mut self, text: &str) {
        self.s.obs.message(text);
    }

    /// A fresh status report, with the work position. Waits for a `WCO:` field if none was seen
    /// yet and Grbl reports machine positions (`$10=1`, the default).
    pub fn position(&mut self) -> Result<Position, MachineError> {
        let mut hinted = false;
        let mut st = self.s.query_status(&mut hinted)?;
        let mut tries = 1;
        while st.wco.is_none() && self.wco.is_none() && st.wpos.is_none() && tries < WCO_QUERIES {
            std::thread::sleep(Duration::from_millis(20));
            st = self.s.query_status(&mut hinted)?;
            tries += 1;
        }
        self.wco = st.wco.or(self.wco);
        self.locked = st.state == MachineState::Alarm;
        let wco = self.wco.unwrap_or([0.0; 3]);
        let (machine, work) = match (st.mpos, st.wpos) {
            (Some(m), _) => (m, sub(m, wco)),
            (None, Some(w)) => (add(w, wco), w),
            (None, None) => ([0.0; 3], [0.0; 3]),
        };
        Ok(Position {
            status: st,
            machine,
            work,
            wco,
        })
    }

    /// What decides where a job lands: settings (`$$` as read on connect), work systems and
    /// G92 (`$#`), the selected system (`$G`) and the head's position (`?`).
    pub fn controller_state(&mut self) -> Result<crate::placement::ControllerState, MachineError> {
        self.s.controller_state()
    }

    /// Send one line and wait for its answer (`ok`): the replies that came before it.
    /// `error:N` comes back as [`MachineError::Setup`] naming the command and the code.
    pub fn command(&mut self, cmd: &str) -> Result<Vec<Reply>, MachineError> {
        let replies = self.s.command(cmd)?;
        if replies.iter().any(|r| matches!(r, Reply::Alarm(_))) {
            self.locked = true;
        }
        Ok(replies)
    }

    /// `$H`, waiting for its `ok` as long as homing may take (up to `limit`), polling the status
    /// meanwhile so a silent link is still noticed; clears the lock.
    pub fn home(&mut self, limit: Duration) -> Result<(), MachineError> {
        self.s.link.write(b"$H\n").map_err(|f| self.s.lost(f))?;
        let saved = std::mem::replace(&mut self.s.link.timeout, limit);
        let second = Duration::from_secs(1);
        let mut locked = false;
        let homed = self
            .s
            .poll(limit, second, second, &mut false, |s, r| match r {
                Reply::Ok => Some(Ok(())),
                Reply::Error(code) => Some(Err(code)),
                Reply::Alarm(code) => {
                    locked = true;
                    let meaning = crate::protocol::alarm_meaning(code);
                    s.obs.message(&format!("ALARM:{code} ({meaning})"));
                    None
                }
                _ => None,
            });
        self.locked |= locked;
        let port = self.s.port_name.clone();
        let result = match homed {
            Ok(Some(Ok(()))) => Ok(()),
            Ok(Some(Err(code))) => Err(MachineError::Setup {
                port,
                cmd: "$H".into(),
                code,
            }),
            Ok(None) => {
                let halt = self.s.halt(None, 1);
                Err(MachineError::Silent {
                    port,
                    secs: limit.as_secs_f64(),
                    halt,
                })
            }
            Err(f) => Err(self.s.lost(f)),
        };
        self.s.link.timeout = saved;
        result?;
        self.locked = false;
        Ok(())
    }

    /// Send a real-time byte (jog cancel, feed hold...).
    pub fn realtime(&mut self, byte: u8) -> Result<(), MachineError> {
        self.s.link.write(&[byte]).map_err(|f| self.s.lost(f))
    }

    /// Poll until the machine is no longer moving (Idle, or Alarm), at most `limit`.
    pub fn wait_still(&mut self, limit: Duration) -> Result<Position, MachineError> {
        let end = Instant::now() + limit;
        loop {
            let p = self.position()?;
            let moving = matches!(
                p.status.state,
                MachineState::Run | MachineState::Jog | MachineState::Home | MachineState::Hold(1)
            );
            if !moving || Instant::now() >= end {
                return Ok(p);
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// Stream a short program (a frame) with the streamer's flow control and stops: every line
    /// acknowledged, then wait until the machine is idle. Operator aborts (the `controls`
    /// channel), `error:N`, alarms, silence and a lost port end it as they end a job: feed hold,
    /// soft reset, laser off.
    pub fn run(&mut self, job: &Program) -> Result<Summary, MachineError> {
        let lines: Vec<Outgoing> = job.lines.iter().map(Outgoing::program).collect();
        let summary = self.s.stream(&lines, false, 1);
        if summary.is_err() {
            self.locked = matches!(&summary, Err(e) if e.halt().is_some_and(|h| h.locked));
        }
        summary
    }

    /// Stop now, as a job stops: feed hold, wait until the machine stands (or the deadline),
    /// soft reset, then `M9` and `M5` unless the reset left the machine locked. Says what was
    /// done about the laser, and whether the position may be lost.
    pub fn stop(&mut self) -> String {
        self.s.settle(None);
        let (laser, locked) = self.s.stop_laser();
        self.locked = locked;
        match self.s.unsure.take() {
            Some(why) => format!(
                "{laser}; the position may be lost: {why}: home the machine ($H) or set its \
                 zero again"
            ),
            None => laser,
        }
    }
}
