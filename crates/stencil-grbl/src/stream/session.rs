//! The streamer's session with one controller: connecting (banner, `$I`, alarm, homing), laser
//! mode, and the setup commands and status queries sent one at a time.

use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use super::config::{Control, LaserMode, StreamConfig};
use super::config::{IfMoving, HOMING_LIMIT};
use super::link::{BytePort, Link, LinkFault};
use super::observe::{ControllerInfo, Observer};
use crate::error::MachineError;
use crate::protocol::{self, Firmware, MachineState, Reply, Status, RT_SOFT_RESET, RT_STATUS};
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
    pub(super) started: Instant,
    pub(super) stall: StallWatch,
    /// Why the position may be lost, noted by a stop path that could not see the machine stand
    /// (taken by [`Session::halt`]).
    pub(super) unsure: Option<Box<str>>,
    /// Rescaling of S asked for by [`StreamConfig::rescale_power`]: (the job's S at its lowest,
    /// the controller's, factor).
    pub(super) power_map: Option<(f64, f64, f64)>,
    /// Connecting found the machine running moves it was given before and stopped them
    /// ([`IfMoving::Stop`]): what it had queued did not all run.
    pub(super) stopped_running: bool,
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
            started: Instant::now(),
            stall: StallWatch::new(stall_bound),
            unsure: None,
            power_map: None,
            stopped_running: false,
        }
    }
}

impl Session<'_, '_> {
    /// No answer within the timeout.
    pub(super) fn no_answer(&self) -> MachineError {
        MachineError::NoWelcome {
            port: self.port_name.clone(),
            secs: self.cfg.timeout.as_secs_f64(),
        }
    }

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

    /// Wait for the banner; a board that did not reset on open is asked what it is doing (`?`)
    /// before anything else: one still running moves it was given before is waited for, or
    /// stopped safely ([`IfMoving`]), never reset while it moves. A standing one is asked what
    /// it is (`$I`): grblHAL and FluidNC, which do not reset when a port opens and keep their
    /// state for the next sender, are never reset by connecting; Grbl is woken with a soft
    /// reset, as it expects.
    pub(super) fn connect(&mut self) -> Result<(), MachineError> {
        let mut alarm = None;
        let mut hinted = false;
        let mut banner = self.wait_welcome(self.cfg.boot_wait, &mut alarm, &mut hinted)?;
        let mut build = None;
        if banner.is_none() {
            banner = self.before_reset(&mut alarm, &mut hinted)?;
        }
        if banner.is_none() {
            let b = self.identify(Firmware::Grbl)?;
            if let (Some(fw @ (Firmware::GrblHal | Firmware::FluidNc)), Some(v)) =
                (b.firmware, b.version.clone())
            {
                self.obs.message(&format!(
                    "{fw} {v} answered without a banner (it does not reset when a port opens): \
                     connected without resetting it, its state and position kept"
                ));
                banner = Some((fw, v));
            }
            // Grbl's answer stands after the reset that wakes it: not asked twice.
            build = b.version.is_some().then_some(b);
        }
        if banner.is_none() {
            self.link
                .write(&[RT_SOFT_RESET])
                .map_err(|f| self.lost(f))?;
            banner = self.wait_welcome(self.cfg.timeout, &mut alarm, &mut hinted)?;
        }
        let Some((firmware, version)) = banner else {
            return Err(MachineError::NoWelcome {
                port: self.port_name.clone(),
                secs: (self.cfg.boot_wait + self.cfg.timeout).as_secs_f64(),
            });
        };
        // Build info: Grbl 1.1 and grblHAL tell their planner and buffer sizes here; older
        // firmware and clones may not, or may refuse `$I`: then the stock sizes stand, and
        // FluidNC's are read from its first status report.
        let build = match build {
            Some(b) => b,
            None => self.identify(firmware)?,
        };
        self.info.firmware = build.firmware.unwrap_or(firmware);
        self.info.version = match (&build.version, self.info.firmware) {
            (Some(v), Firmware::GrblHal | Firmware::FluidNc) => v.clone(),
            _ => version,
        };
        self.info.rx_buffer = RX_BUFFER_BYTES;
        self.info.planner_blocks = PLANNER_BLOCKS;
        let sized = build.sizes.is_some();
        if let Some((blocks, rx)) = build.sizes {
            self.info.planner_blocks = blocks;
            self.info.rx_buffer = rx;
        }
        self.read_settings()?;
        if self.info.firmware == Firmware::FluidNc {
            self.read_fluid_laser()?;
        }
        // The banner may be followed by the unlock hint: collect it with the status.
        let st = self.query_status(&mut hinted)?;
        if let (false, Some((blocks, rx)), MachineState::Idle) = (sized, st.buffer, &st.state) {
            // No sizes in `$I` (FluidNC): an idle controller's free space is all there is.
            self.info.planner_blocks = blocks as usize;
            self.info.rx_buffer = rx as usize;
        }
        if let Some(rx) = self.cfg.rx_buffer {
            self.info.rx_buffer = rx;
        }
        if st.mpg == Some(true) {
            return Err(MachineError::Busy {
                port: self.port_name.clone(),
                state: format!("{} (a pendant has control: MPG mode)", st.state),
            });
        }
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

    /// `$I` (a grblHAL that leaves its extended lines to `$I+` is asked that too): which
    /// firmware, its version and sizes. A controller that refuses it says nothing.
    fn identify(&mut self, banner: Firmware) -> Result<protocol::BuildInfo, MachineError> {
        let feedback = |replies: Vec<Reply>| -> Vec<String> {
            replies
                .into_iter()
                .filter_map(|r| match r {
                    Reply::Feedback(f) => Some(f),
                    _ => None,
                })
                .collect()
        };
        let mut lines = feedback(self.command_if_known("$I")?.unwrap_or_default());
        let b = protocol::build_info(lines.iter().map(String::as_str));
        let later = b.build.is_some_and(|d| d > protocol::GRBL_LAST_BUILD);
        if !b.newopt
            && b.firmware != Some(Firmware::FluidNc)
            && (later || banner == Firmware::GrblHal)
        {
            lines.extend(feedback(self.command_if_known("$I+")?.unwrap_or_default()));
            return Ok(protocol::build_info(lines.iter().map(String::as_str)));
        }
        Ok(b)
    }

    /// No banner came: the board did not reset when the port opened. Before the soft reset that
    /// wakes it, ask what it is doing: a machine still running moves (a sender that died mid-job)
    /// is waited for or stopped as the abort key stops a job, as [`StreamConfig::if_moving`] says;
    /// one held in a feed hold or at its door, which will not finish by itself, is left alone
    /// unless stopping was asked for. Returns the banner if one arrives meanwhile.
    fn before_reset(
        &mut self,
        alarm: &mut Option<u8>,
        hinted: &mut bool,
    ) -> Result<Option<(Firmware, String)>, MachineError> {
        let st = match self.first_report(alarm, hinted)? {
            Heard::Banner(v) => return Ok(Some(v)),
            Heard::Nothing => return Ok(None),
            Heard::Status(st) if !moving(&st.state) => return Ok(None),
            Heard::Status(st) => st,
        };
        let what = doing(&st);
        let held = matches!(st.state, MachineState::Hold(_) | MachineState::Door(_));
        match self.cfg.if_moving {
            // Homing ignores a feed hold: it is waited for whatever was asked.
            IfMoving::Stop if st.state != MachineState::Home => {
                self.obs.message(&format!(
                    "Grbl is still running moves it was given before this connection ({what}): \
                     stopping it as asked, as the abort key does: feed hold, wait until it \
                     stands, then a soft reset (from a completed hold its position is kept)"
                ));
                self.settle(None);
                if let Some(why) = self.unsure.take() {
                    self.obs.message(&format!(
                        "the position may be lost: {why}: home the machine ($H) or set its zero \
                         again before cutting"
                    ));
                }
                self.stopped_running = true;
                Ok(None)
            }
            IfMoving::Wait(_) if held => Err(MachineError::Running {
                port: self.port_name.clone(),
                state: what,
                waited_s: None,
            }),
            wait => {
                let limit = match wait {
                    IfMoving::Wait(d) => d,
                    IfMoving::Stop => HOMING_LIMIT,
                };
                self.obs.message(&format!(
                    "Grbl is still running moves it was given before this connection ({what}): \
                     another program's job, or the rest of one whose sender stopped. A soft \
                     reset now would lose its position (ALARM:3), so nothing is sent until it \
                     stands idle: waiting for it to finish (at most {} s)",
                    limit.as_secs()
                ));
                let done = self.wait_idle(limit, alarm, hinted)?;
                self.obs.message(&format!(
                    "the machine finished those moves: {}",
                    doing(&done)
                ));
                Ok(None)
            }
        }
    }

    /// Ask `?` (twice, half a second apart) and take the first answer: a status report, or a
    /// banner from a board that was only slow to boot.
    fn first_report(
        &mut self,
        alarm: &mut Option<u8>,
        hinted: &mut bool,
    ) -> Result<Heard, MachineError> {
        let half = Duration::from_millis(500);
        let heard = self.poll(half * 2, Duration::ZERO, half, hinted, |_, r| match r {
            Reply::Status(st) => Some(Heard::Status(st)),
            Reply::Welcome(fw, v) => Some(Heard::Banner((fw, v))),
            Reply::Alarm(a) => {
                *alarm = Some(a);
                None
            }
            _ => None,
        });
        match heard {
            Ok(h) => Ok(h.unwrap_or(Heard::Nothing)),
            Err(LinkFault::Silent(_)) => Ok(Heard::Nothing),
            Err(f) => Err(self.lost(f)),
        }
    }

    /// Poll (`?`, four times a second) until the machine no longer moves, at most `limit`;
    /// a machine that is put in a feed hold meanwhile will not finish, and is left as it is.
    fn wait_idle(
        &mut self,
        limit: Duration,
        alarm: &mut Option<u8>,
        hinted: &mut bool,
    ) -> Result<Status, MachineError> {
        let mut next_note = Instant::now() + Duration::from_secs(15);
        let mut last: Option<Status> = None;
        let every = Duration::from_millis(250);
        let done = self.poll(limit, Duration::ZERO, every, hinted, |s, r| match r {
            Reply::Status(st) if !moving(&st.state) => Some(Ok(st)),
            Reply::Status(st)
                if matches!(st.state, MachineState::Hold(_) | MachineState::Door(_)) =>
            {
                Some(Err(MachineError::Running {
                    port: s.port_name.clone(),
                    state: doing(&st),
                    waited_s: None,
                }))
            }
            Reply::Status(st) => {
                if Instant::now() >= next_note {
                    s.obs.message(&format!("still running: {}", doing(&st)));
                    next_note = Instant::now() + Duration::from_secs(15);
                }
                last = Some(st);
                None
            }
            Reply::Alarm(a) => {
                *alarm = Some(a);
                None
            }
            _ => None,
        });
        done.map_err(|f| self.lost(f))?.unwrap_or_else(|| {
            Err(MachineError::Running {
                port: self.port_name.clone(),
                state: last.as_ref().map_or_else(|| "Run".into(), doing),
                waited_s: Some(limit.as_secs_f64()),
            })
        })
    }

    /// `$H`, waiting for its `ok` as long as homing may take (the machine answers status queries
    /// meanwhile, in `Home`), at most [`HOMING_LIMIT`].
    fn home(&mut self) -> Result<(), MachineError> {
        self.obs
            .message("homing ($H) first: the position after a stop or power loss is not trusted");
        self.link.write(b"$H\n").map_err(|f| self.lost(f))?;
        let saved = std::mem::replace(&mut self.link.timeout, HOMING_LIMIT);
        let second = Duration::from_secs(1);
        let homed = self.poll(HOMING_LIMIT, second, second, &mut false, |_, r| match r {
            Reply::Ok => Some(None),
            Reply::Error(code) => Some(Some(format!(
                "error:{code} ({})",
                protocol::error_meaning(code)
            ))),
            Reply::Alarm(code) => Some(Some(format!(
                "ALARM:{code} ({})",
                protocol::alarm_meaning(code)
            ))),
            _ => None,
        });
        self.link.timeout = saved;
        let detail = match homed.map_err(|f| self.lost(f))? {
            Some(None) => None,
            Some(failed) => failed,
            None => Some(format!("no answer within {} s", HOMING_LIMIT.as_secs())),
        };
        if let Some(detail) = detail {
            let port = self.port_name.clone();
            return Err(MachineError::Homing { port, detail });
        }
        self.obs.message("homed");
        Ok(())
    }

    pub(super) fn wait_welcome(
        &mut self,
        limit: Duration,
        alarm: &mut Option<u8>,
        hinted: &mut bool,
    ) -> Result<Option<(Firmware, String)>, MachineError> {
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
                    Reply::Welcome(fw, v) => break Ok(Some((fw, v))),
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
        let replies = self.command_if_known("$$")?.unwrap_or_default();
        self.info.settings = parse_settings(&replies);
        Ok(())
    }

    /// FluidNC keeps its laser's power scale in the configuration file, not in `$30`/`$31`: its
    /// `$Config/Dump` (`$CD`) lists the `Laser:` spindle's `speed_map` (`0=0.000% 1000=100.000%`):
    /// the highest S is the full-power scale (`$30`), the highest S still at 0 % the minimum
    /// (`$31`). They stand in for the settings Grbl lists, so the power check compares them.
    fn read_fluid_laser(&mut self) -> Result<(), MachineError> {
        let Some(replies) = self.command_if_known("$CD")? else {
            return Ok(());
        };
        let lines: Vec<String> = replies
            .into_iter()
            .filter_map(|r| match r {
                Reply::Other(o) => Some(o),
                _ => None,
            })
            .collect();
        let Some(map) = protocol::laser_speed_map(lines.iter().map(String::as_str)) else {
            return Ok(());
        };
        let (max, min) = map;
        self.obs.message(&format!(
            "FluidNC's configuration file: a Laser spindle, speed_map S{} at full power, \
             S{} and below off",
            stencil_gcode::num(max),
            stencil_gcode::num(min)
        ));
        self.info.settings.retain(|(k, _)| *k != 30 && *k != 31);
        self.info.settings.extend([(30, max), (31, min)]);
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
            Some(_) if self.info.firmware == Firmware::FluidNc => {
                return Err(MachineError::FluidLaserOff {
                    port: self.port_name.clone(),
                })
            }
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

    /// [`Session::command`] for a command an old or reduced build may refuse: `None` when it did.
    pub(super) fn command_if_known(
        &mut self,
        cmd: &str,
    ) -> Result<Option<Vec<Reply>>, MachineError> {
        match self.command(cmd) {
            Ok(replies) => Ok(Some(replies)),
            Err(MachineError::Setup { .. }) => Ok(None),
            Err(e) => Err(e),
        }
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
        Err(self.no_answer())
    }

    /// Ask `?` until a status report comes (again every half second), at most the timeout.
    pub(super) fn query_status(&mut self, hinted: &mut bool) -> Result<Status, MachineError> {
        let every = Duration::from_millis(500);
        let st = self.poll(
            self.cfg.timeout,
            Duration::ZERO,
            every,
            hinted,
            |_, r| match r {
                Reply::Status(st) => Some(st),
                _ => None,
            },
        );
        st.map_err(|f| self.lost(f))?
            .ok_or_else(|| self.no_answer())
    }

    /// Read replies for at most `limit`, asking `?` after `first` and then every `every`, and
    /// hand each to `on` until it returns `Some`; `Ok(None)` when the time ran out. Grbl's
    /// messages go to the front end (`hinted` notes an unlock hint) instead.
    pub(super) fn poll<R>(
        &mut self,
        limit: Duration,
        first: Duration,
        every: Duration,
        hinted: &mut bool,
        mut on: impl FnMut(&mut Self, Reply) -> Option<R>,
    ) -> Result<Option<R>, LinkFault> {
        let end = Instant::now() + limit;
        let mut next_ask = Instant::now() + first;
        self.link.last_heard = Instant::now();
        while Instant::now() < end {
            if Instant::now() >= next_ask {
                self.link.write(&[RT_STATUS])?;
                next_ask = Instant::now() + every;
            }
            match self
                .link
                .line(Duration::from_millis(50))?
                .map(|l| Reply::parse(&l))
            {
                Some(Reply::Message(m)) => {
                    *hinted |= protocol::is_unlock_hint(&m);
                    self.obs.message(&format!("Grbl: {m}"));
                }
                Some(r) => {
                    if let Some(x) = on(self, r) {
                        return Ok(Some(x));
                    }
                }
                None => {}
            }
        }
        Ok(None)
    }
}

/// The first answer to a `?` on connecting (one, once: its size does not matter).
#[allow(clippy::large_enum_variant)]
enum Heard {
    Status(Status),
    Banner((Firmware, String)),
    Nothing,
}

/// The machine is carrying out (or holding) moves: a soft reset now would, or could, lose its
/// position, or throw away a job someone held.
fn moving(state: &MachineState) -> bool {
    matches!(
        state,
        MachineState::Run
            | MachineState::Jog
            | MachineState::Home
            | MachineState::Hold(_)
            | MachineState::Door(_)
    )
}

/// "Run at X12.000 Y3.500 Z0.000": a state and where the head is.
fn doing(st: &Status) -> String {
    match st.position() {
        Some(p) => format!("{} at X{:.3} Y{:.3} Z{:.3}", st.state, p[0], p[1], p[2]),
        None => st.state.to_string(),
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
