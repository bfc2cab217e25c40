//! Every way a stream stops early: settle in a feed hold, then a soft reset that switches the
//! laser and the air off, and the line to resume from.

use std::time::{Duration, Instant};

use super::flight::Flight;
use super::link::LinkFault;
use super::session::Session;
use super::{Halt, MachineError};
use crate::protocol::{self, MachineState, Reply, RT_FEED_HOLD, RT_SOFT_RESET, RT_STATUS};

impl Session<'_, '_> {
    /// Before stopping on purpose: feed hold (`!`) and wait until the machine has stopped, reading
    /// the acknowledgements still coming and a fresh status report. Stopping from a completed
    /// hold keeps Grbl's position (a reset while moving loses it: ALARM:3), and the report's free
    /// planner blocks tell exactly which acknowledged moves have not run.
    pub(super) fn settle(&mut self, f: &mut Flight<'_>) {
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

    pub(super) fn fault(&mut self, e: LinkFault, f: &Flight<'_>) -> MachineError {
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
    pub(super) fn halt(&mut self, last_acked: Option<usize>, resume_from: usize) -> Halt {
        let (laser, locked) = self.stop_laser();
        Halt {
            last_acked,
            resume_from,
            laser,
            locked,
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
