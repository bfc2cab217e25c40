//! The streamer's session with one controller: connecting (banner, `$I`, alarm, homing), laser
//! mode, and the setup commands and status queries sent one at a time.

use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use super::config::HOMING_LIMIT;
use super::link::{BytePort, Link, LinkFault};
use super::{Control, ControllerInfo, LaserMode, MachineError, Observer, StreamConfig};
use crate::protocol::{self, MachineState, Reply, Status, RT_SOFT_RESET, RT_STATUS};
use crate::stall::StallWatch;
use stencil_gcode::limits::{PLANNER_BLOCKS, RX_BUFFER_BYTES};

/// The streamer's session with one controller.
pub(super) struct Session<'a, 'o> {
    pub(super) link: Link<'a>,
    pub(super) cfg: &'a StreamConfig,
    pub(super) obs: &'o mut dyn Observer,
    pub(super) controls: Option<&'a Receiver<Control>>,
    pub(super) port_name: String,
    pub(super) info: ControllerInfo,
    pub(super) last_status: Option<Status>,
    pub(super) started: Instant,
    pub(super) stall: StallWatch,
    /// Why the position may be lost, noted by a stop path that could not see the machine stand
    /// (taken by [`Session::halt`]).
    pub(super) unsure: Option<Box<str>>,
    /// Rescaling of S asked for by [`StreamConfig::rescale_power`]: (the job's S at its lowest,
    /// the controller's, factor).
    pub(super) power_map: Option<(f64, f64, f64)>,
}

impl<'a, 'o> Session<'a, 'o> {
    /// A session on `port`, not yet connected; a machine standing still in `Run` longer than
    /// `stall_bound` counts as stalled.
    pub(super) fn new(
        port: &'a mut dyn BytePort,
        cfg: &'a StreamConfig,
        controls: Option<&'a Receiver<Control>>,
        obs: &'o mut dyn Observer,
        stall_bound: Duration,
    ) -> Self {
        Session {
            port_name: port.describe(),
            link: Link::new(port, cfg.timeout),
            cfg,
            obs,
            controls,
            info: ControllerInfo::default(),
            last_status: None,
            started: Instant::now(),
            stall: StallWatch::new(stall_bound),
            unsure: None,
            power_map: None,
        }
    }
}

impl Session<'_, '_> {
    pub(super) fn lost(&self, f: LinkFault) -> MachineError {
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
    pub(super) fn connect(&mut self) -> Result<(), MachineError> {
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
        self.info.rx_buffer = RX_BUFFER_BYTES;
        self.info.planner_blocks = PLANNER_BLOCKS;
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
        self.read_settings()?;
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
        self.check_settings()?;
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

    pub(super) fn wait_welcome(
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
        self.info.settings = parse_settings(&replies);
        Ok(replies.iter().find_map(|r| match r {
            Reply::Other(o) => o.strip_prefix("$32=").map(|v| v.trim().to_string()),
            _ => None,
        }))
    }

    /// `$$` into [`ControllerInfo::settings`]; a controller that refuses it (in an alarm,
    /// a clone) leaves them unknown, and nothing is compared.
    fn read_settings(&mut self) -> Result<(), MachineError> {
        match self.command("$$") {
            Ok(replies) => self.info.settings = parse_settings(&replies),
            Err(MachineError::Setup { .. }) => self.info.settings.clear(),
            Err(e) => return Err(e),
        }
        Ok(())
    }

    /// Before a laser job: Grbl must be in laser mode (`$32=1`), or it pauses at every power
    /// change and fires through G0. Refuse, or set it when asked, and say which.
    pub(super) fn laser_mode(&mut self) -> Result<(), MachineError> {
        let set = match self.cfg.laser_mode {
            LaserMode::Ignore => return Ok(()),
            LaserMode::Require => false,
            LaserMode::Set => true,
        };
        let on = |v: &str| v.parse::<f64>().is_ok_and(|x| x != 0.0);
        // `$$` was read on connect; asked again only if it listed nothing.
        let listed = match self.info.setting(32) {
            Some(v) => Some(stencil_gcode::num(v)),
            None if self.info.settings.is_empty() => self.read_laser_mode()?,
            None => None,
        };
        match listed {
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
                        "laser mode was off ($32={v}): set $32=1 as asked; Grbl keeps it"
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
    pub(super) fn command(&mut self, cmd: &str) -> Result<Vec<Reply>, MachineError> {
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

    pub(super) fn query_status(&mut self, hinted: &mut bool) -> Result<Status, MachineError> {
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
}

/// `$N=V` lines of a `$$` answer.
fn parse_settings(replies: &[Reply]) -> Vec<(u32, f64)> {
    replies
        .iter()
        .filter_map(|r| match r {
            Reply::Other(o) => {
                let (k, v) = o.strip_prefix('$')?.split_once('=')?;
                Some((k.trim().parse().ok()?, v.trim().parse().ok()?))
            }
            _ => None,
        })
        .collect()
}
