//! The operator's commands while a job runs, passed on as Grbl's real-time bytes.

use super::flight::Flight;
use super::session::Session;
use super::MachineError;
use crate::protocol::{self, RT_FEED_HOLD, RT_RESUME};

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

impl Session<'_, '_> {
    /// Pass the operator's commands on as Grbl's real-time bytes; an abort stops the run (feed
    /// hold, soft reset, laser off).
    pub(super) fn apply_controls(&mut self, f: &mut Flight<'_>) -> Result<(), MachineError> {
        let Some(rx) = self.controls else {
            return Ok(());
        };
        while let Ok(c) = rx.try_recv() {
            let byte = match c {
                Control::FeedHold => RT_FEED_HOLD,
                Control::Resume => RT_RESUME,
                Control::Override(o) => o.byte(),
                Control::Abort => {
                    self.settle(Some(f));
                    let halt = self.halt(f.run.last_acked, f.resume_at(None));
                    return Err(MachineError::Aborted { halt });
                }
            };
            if let Err(e) = self.link.write(&[byte]) {
                return Err(self.fault(e, f));
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
        Ok(())
    }
}
