//! A resume after a stop, a sender crash or a power loss, decided from the controller's word:
//! its reported position against the journal's, before anything moves.

use super::session::Session;
use super::{MachineError, Program, Recovery};
use stencil_gcode::num;

/// How far (mm, in X and Y) the controller's position may be from the journal's and still be
/// the same place (a report is rounded to 3 decimals; a feed hold stops a little further on).
const SAME_PLACE_MM: f64 = 0.5;

impl Session<'_, '_> {
    /// Before the resume travels anywhere: a homed machine is trusted; a head the person put
    /// back at the job's start corner is told so (`G92`); otherwise the controller's position
    /// must match where the journal last saw the head, or the travel is refused
    /// ([`MachineError::PositionLost`]). A controller standing idle exactly where a line after
    /// the resume point ends ran on after the journal's last write (the sender crashed, Grbl
    /// did not): the resume moves there. Returns the line to resume from.
    pub(super) fn recover(
        &mut self,
        job: &Program,
        r: &Recovery,
        from: usize,
    ) -> Result<usize, MachineError> {
        if self.cfg.home_first {
            return Ok(from);
        }
        if let Some(c) = r.at_corner {
            let cmd = format!("G92X{}Y{}", num(c[0]), num(c[1]));
            self.command(&cmd)?;
            self.obs.message(&format!(
                "the head stands at the job's start corner, as you said: its work position is \
                 now X{} Y{} ({cmd}, until the next reset)",
                num(c[0]),
                num(c[1])
            ));
            return Ok(from);
        }
        let mut hinted = false;
        let st = self.query_status(&mut hinted)?;
        let Some(now) = st.position() else {
            return Ok(from);
        };
        if r.confirmed {
            self.obs.message(&format!(
                "the controller puts the head at X{} Y{}; you confirmed its coordinates are right",
                num(now[0]),
                num(now[1])
            ));
            return Ok(from);
        }
        // A placed job's moves are machine coordinates (its placement is in them): compared with
        // the machine position, which a reset's loss of G92 does not change. An unplaced job's
        // are its own coordinates: compared with the work position (without a WCO in this report
        // the offset is taken as none: a wrong guess matches no line end, and the resume stays
        // where the journal put it).
        let work = if job.start != stencil_gcode::interpret::Modal::default() {
            now
        } else {
            let wco = st.wco.unwrap_or([0.0; 3]);
            [now[0] - wco[0], now[1] - wco[1], now[2] - wco[2]]
        };
        let after = r.last_acked.unwrap_or(from).max(from.saturating_sub(1));
        // A board that lost its power (no homing) reads exactly machine zero: a line ending
        // there (a job's final return to the origin) proves nothing about having run on.
        let at_zero = now.iter().all(|v| v.abs() < 0.0005);
        let ended = job
            .moves
            .iter()
            .filter(|m| !at_zero && m.line >= after)
            .find(|m| (0..3).all(|a| (m.to[a] - work[a]).abs() < 0.01));
        match ended {
            Some(m) if r.follow && m.line + 1 > from => {
                self.obs.message(&format!(
                    "Grbl stands at X{} Y{}, where line {} ends: it ran on after the journal's \
                     last record, so the job resumes from line {} (not {from})",
                    num(work[0]),
                    num(work[1]),
                    m.line,
                    m.line + 1
                ));
                Ok(m.line + 1)
            }
            _ => {
                if let Some(then) = r.last_position {
                    if (now[0] - then[0]).hypot(now[1] - then[1]) > SAME_PLACE_MM {
                        return Err(MachineError::PositionLost {
                            port: self.port_name.clone(),
                            now: Box::new(now),
                            then: Box::new(then),
                            corner: job.start_corner(),
                        });
                    }
                }
                Ok(from)
            }
        }
    }
}
