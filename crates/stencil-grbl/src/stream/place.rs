//! Reading where a job will land from the controller (`$$` as read on connect, `$#`, `$G`, a
//! status report), and putting the job's zero where its placement says (`G92`).

use super::session::Session;
use crate::error::MachineError;
use crate::placement::{g92_for, ControllerState};
use crate::protocol::Reply;

/// How close (mm) the controller's work zero must be to the placement's to be left alone (a
/// report is rounded to 3 decimals).
const SAME_ZERO_MM: f64 = 0.0015;

impl Session<'_, '_> {
    /// The controller's settings, work systems, G92, selected system and head position. A
    /// controller that refuses `$#` or `$G` (an old or reduced build) leaves those at zero and
    /// G54.
    pub(super) fn controller_state(&mut self) -> Result<ControllerState, MachineError> {
        let mut st = ControllerState {
            settings: self.info.settings.clone(),
            ..ControllerState::default()
        };
        for cmd in ["$#", "$G"] {
            for r in self.command_if_known(cmd)?.unwrap_or_default() {
                st.take(&r);
            }
        }
        let mut hinted = false;
        let status = self.query_status(&mut hinted)?;
        st.take(&Reply::Status(status));
        Ok(st)
    }

    /// Put the job's X0 Y0 at machine `zero` (X, Y): if the controller's work zero is elsewhere,
    /// a `G92` naming the head's work position moves it there (G92 lasts until a reset, which
    /// is why a recovery sends it again from the journal).
    pub(super) fn place(&mut self, zero: [f64; 2]) -> Result<(), MachineError> {
        let st = self.controller_state()?;
        let wco = st.wco();
        if (wco[0] - zero[0]).abs() < SAME_ZERO_MM && (wco[1] - zero[1]).abs() < SAME_ZERO_MM {
            return Ok(());
        }
        let Some(mpos) = st.position else {
            return Ok(());
        };
        let cmd = g92_for(zero, mpos);
        self.command(&cmd)?;
        self.obs.message(&format!(
            "the job's X0 Y0 put at machine X{} Y{} ({cmd}, until the next reset)",
            stencil_gcode::num(zero[0]),
            stencil_gcode::num(zero[1])
        ));
        Ok(())
    }
}
