//! The operator's commands while a job runs, passed on as Grbl's real-time bytes.

use super::config::Control;
use super::flight::Flight;
use super::session::Session;
use crate::error::MachineError;
use crate::protocol::{RT_FEED_HOLD, RT_RESUME};

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
