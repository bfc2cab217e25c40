//! Injected faults: an error, an alarm, silence, a pulled cable, a frozen planner.

use std::time::{Duration, Instant};

use super::config::FaultKind;
use super::record::{lock, Event};
use super::sim::{Sim, State};

impl Sim {
    /// The fault set for the current G-code line fires (once). True when that settles the line
    /// (answered with an error or an alarm, or never to be answered); a silenced controller still
    /// runs it.
    pub(super) fn fire_fault(&mut self) -> bool {
        let n = self.job_lines;
        let Some(pos) = self.cfg.faults.iter().position(|f| f.at_job_line == n) else {
            return false;
        };
        let f = self.cfg.faults.remove(pos);
        match f.kind {
            FaultKind::Error(code) => self.reply_error(code),
            FaultKind::Alarm(code) => self.alarm(code),
            FaultKind::Silence => {
                self.silent = true;
                return false;
            }
            FaultKind::ClosePort => self.close(),
            FaultKind::DropLink => {
                self.drop_link();
                return false;
            }
            FaultKind::Freeze => self.frozen = true,
            // The line runs; only its answer goes wrong.
            FaultKind::DropOk | FaultKind::GarbleOk => {
                self.ok_fault = Some(f.kind);
                return false;
            }
            FaultKind::PowerLoss => self.power_loss(),
        }
        true
    }

    /// Power gone and back: what Grbl keeps in EEPROM (settings, G54..G59) stays; everything
    /// else starts over, the position at machine zero wherever the head really is.
    fn power_loss(&mut self) {
        lock(&self.shared).events.push(Event::PowerLoss);
        self.forget();
        // Machine zero is wherever the head stands now; the work systems (EEPROM) stay, G92
        // and the modes go, as after a reset.
        self.modal = stencil_gcode::interpret::Modal {
            pos: [0.0; 3],
            ..self.modal.after_reset()
        };
        self.sync_wco();
        self.state = if self.cfg.homing {
            State::Alarm
        } else {
            State::Idle
        };
        self.boot_banner();
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

    /// The network link drops: the board runs on with what it holds, its answers to the host
    /// that is gone (this line's, and those of whole lines still in its buffer) go nowhere, a
    /// half-received line is thrown away, and the next host is taken. A pty has no such link:
    /// there it is the cable pulled ([`FaultKind::ClosePort`]).
    fn drop_link(&mut self) {
        if !self.port.as_mut().is_some_and(|w| w.drop_link()) {
            return self.close();
        }
        // A job run from the card fills the buffer from the card, not over the link.
        let whole = match self.card_run {
            Some(_) => self.rx.len(),
            None => self
                .rx
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(0, |i| i + 1),
        };
        self.rx.truncate(whole);
        self.unheard += 1 + self.rx.iter().filter(|&&b| b == b'\n').count();
        self.wire_out.clear();
        lock(&self.shared).events.push(Event::LinkDropped);
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
}
