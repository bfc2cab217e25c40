//! Every way a stream stops early: settle in a feed hold, then a soft reset that switches the
//! laser and the air off, and the line to resume from.

use std::time::{Duration, Instant};

use super::flight::Flight;
use super::link::LinkFault;
use super::session::Session;
use crate::error::{Halt, MachineError};
use crate::protocol::{self, MachineState, Reply, RT_FEED_HOLD, RT_SOFT_RESET, RT_STATUS};

impl Session<'_, '_> {
    /// Before stopping on purpose: feed hold (`!`), then wait until the machine is known to
    /// stand, reading the acknowledgements still coming. A soft reset while the head moves
    /// loses Grbl's position (ALARM:3); from a completed hold it keeps it, and the report's free
    /// planner blocks tell exactly which acknowledged moves have not run. Without [`Standstill`]'s
    /// proof by the hold deadline the reset goes ahead, and the halt says the position may be lost.
    pub(super) fn settle(&mut self, f: Option<&mut Flight<'_>>) {
        if self.link.write(&[RT_FEED_HOLD]).is_err() {
            self.unsure = Some("the feed hold could not be sent".into());
            return;
        }
        let deadline = self.hold_deadline();
        match self.wait_standing(f, deadline) {
            Wait::Standing => {}
            Wait::PortFailed => {
                self.unsure = Some("the port failed while waiting for the hold".into());
            }
            Wait::Deadline => {
                self.unsure = Some(
                    format!(
                        "the machine did not report a completed feed hold within {:.1} s, so it \
                         was reset while it may still have been moving",
                        deadline.as_secs_f64()
                    )
                    .into(),
                );
            }
        }
    }

    /// A controller that stopped answering: still send the hold and give it its deadline (it
    /// may be deaf only on the way back), at most 3 s, then the reset follows.
    fn settle_silent(&mut self) {
        let _ = self.link.write(&[RT_FEED_HOLD]);
        let wait = self.hold_deadline().min(Duration::from_secs(3));
        if self.wait_standing(None, wait) != Wait::Standing {
            self.unsure = Some(
                "the controller stopped answering, so it could not say whether the machine stood \
                 before the reset"
                    .into(),
            );
        }
    }

    /// After a `!`: ask for status reports and read what comes (acknowledgements still due go
    /// to `f`) until [`Standstill`] accepts one, Grbl restarts, or `limit` passes. One question
    /// at a time: the next `?` goes out only once the last is answered (or after a while, in
    /// case a report was lost), so each report answers a `?` sent after the one before it
    /// arrived.
    fn wait_standing(&mut self, mut f: Option<&mut Flight<'_>>, limit: Duration) -> Wait {
        let end = Instant::now() + limit;
        let mut watch = Standstill::default();
        let mut asked = false;
        let mut last_ask = Instant::now() - Duration::from_secs(1);
        while Instant::now() < end {
            let since = last_ask.elapsed();
            if (!asked && since >= Duration::from_millis(20)) || since >= Duration::from_millis(250)
            {
                if self.link.write(&[RT_STATUS]).is_err() {
                    return Wait::PortFailed;
                }
                asked = true;
                last_ask = Instant::now();
            }
            let Ok(Some(line)) = self.link.line(Duration::from_millis(20)) else {
                continue;
            };
            match (Reply::parse(&line), f.as_deref_mut()) {
                (Reply::Ok, Some(f)) if !f.in_flight.is_empty() => f.ack(),
                (Reply::Error(_), Some(f)) if !f.in_flight.is_empty() => {
                    f.reject();
                }
                (Reply::Status(st), f) => {
                    asked = false;
                    if let Some(f) = f {
                        f.status(&st);
                        // The front end (and the journal) learns where the head came to rest.
                        self.obs.progress(&f.progress);
                    }
                    if watch.standing(&st) {
                        return Wait::Standing;
                    }
                }
                // Grbl restarted (power, its own reset): it stands, with nothing queued.
                (Reply::Alarm(_) | Reply::Welcome(..), _) => return Wait::Standing,
                _ => {}
            }
        }
        Wait::Deadline
    }

    /// How long a feed hold may take to bring the head to rest: the fastest the controller
    /// moves (`$110`/`$111`) over its gentlest acceleration (`$120`/`$121`), twice over, plus
    /// a second for the reports; 2..30 s (5 s when the settings are not known).
    fn hold_deadline(&self) -> Duration {
        let max = |a: u32, b: u32| self.info.setting(a).into_iter().chain(self.info.setting(b));
        let rate = max(110, 111).fold(f64::NAN, f64::max);
        let accel = max(120, 121).filter(|a| *a > 0.0).fold(f64::NAN, f64::min);
        if !(rate.is_finite() && accel.is_finite()) {
            return Duration::from_secs(5);
        }
        Duration::from_secs_f64((2.0 * rate / 60.0 / accel + 1.0).clamp(2.0, 30.0))
    }

    pub(super) fn fault(&mut self, e: LinkFault, f: &Flight<'_>) -> MachineError {
        let (last_acked, resume) = (f.run.last_acked, f.resume_at(None));
        match e {
            LinkFault::Lost(detail) => MachineError::PortLost {
                port: self.port_name.clone(),
                detail,
                halt: Halt {
                    last_acked,
                    resume_from: resume,
                    laser:
                        "nothing can be sent to the machine any more, so the laser could not be \
                            switched off from here: at the machine, press its stop button or \
                            switch it off, and make sure the laser and the air are off (a board \
                            that lost its USB power is off)"
                            .into(),
                    locked: false,
                    position_unsure: Some(
                        "the port went away while the machine may have been moving".into(),
                    ),
                },
            },
            LinkFault::Silent(secs) => {
                // The same way down as every stop: hold, wait (a silent controller will not
                // say it stands, so this runs into the deadline), reset, M9, M5.
                self.link.last_heard = Instant::now();
                self.settle_silent();
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
    pub(super) fn halt(&mut self, last_acked: Option<usize>, resume_from: usize) -> Halt {
        let (laser, locked) = self.stop_laser();
        Halt {
            last_acked,
            resume_from,
            laser,
            locked,
            position_unsure: self.unsure.take(),
        }
    }

    /// What was done about the laser, and whether Grbl is now locked in alarm.
    pub(super) fn stop_laser(&mut self) -> (String, bool) {
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
                 ($H) or unlock it ($X)"
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

/// How a wait for the machine to stand ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Wait {
    Standing,
    Deadline,
    PortFailed,
}

/// Watches status reports after a feed hold for proof that the machine stands.
///
/// Grbl's `protocol_exec_rt_system` writes a requested status report *before* it acts on a
/// feed hold handled in the same pass, and a report already on the wire when the `!` goes out
/// is older still: an `Idle` or `Run` read after the `!` says nothing about now (the issue's
/// `<Idle>`, then `<Hold:1>`: the head was moving). A `Hold` state can only come from a report
/// made after Grbl handled a hold; `Hold:0` means that hold is complete, and a hold from Idle
/// reports `Hold:0` at once. One `Hold:0` could still be left from an earlier hold the operator
/// resumed a moment ago, so two reports in a row must say `Hold:0` at the same position, the
/// second asked for after the first arrived. An alarm has already stopped the motion. A jog
/// is cancelled by a hold and ends in `Idle`, not `Hold`: once `Jog` was seen, two `Idle`
/// reports at the same position (newer than it) say the same.
#[derive(Default)]
pub(crate) struct Standstill {
    last_rest: Option<[f64; 3]>,
    jogged: bool,
}

impl Standstill {
    /// Feed the next status report; true once the machine is known to stand.
    pub(crate) fn standing(&mut self, st: &protocol::Status) -> bool {
        self.jogged |= st.state == MachineState::Jog;
        match st.state {
            MachineState::Alarm => true,
            MachineState::Hold(0) => self.at_rest(st),
            MachineState::Idle if self.jogged => self.at_rest(st),
            _ => {
                self.last_rest = None;
                false
            }
        }
    }

    /// A resting report: true when the one before it rested at the same position.
    fn at_rest(&mut self, st: &protocol::Status) -> bool {
        let pos = st.position().unwrap_or([f64::NAN; 3]);
        let same = self
            .last_rest
            .is_some_and(|p| p.iter().zip(pos).all(|(a, b)| (a - b).abs() < 1e-6));
        self.last_rest = Some(pos);
        same
    }
}
