//! A resume after a stop, a sender crash or a power loss, decided from the controller's word:
//! its reported position and planner state against the journal's, before anything moves.

use super::config::Recovery;
use super::session::Session;
use crate::error::MachineError;
use crate::program::Program;
use crate::protocol::MachineState;
use stencil_gcode::num;

/// How far (mm, in X and Y) the controller's position may be from the journal's and still be
/// the same place (a report is rounded to 3 decimals; a feed hold stops a little further on).
const SAME_PLACE_MM: f64 = 0.5;

impl Session<'_, '_> {
    /// Before the resume travels anywhere: a homed machine is trusted; a head the person put
    /// back at the job's start corner is told so (`G92`); otherwise the controller's position
    /// must tell where the job stands. Returns the line to resume from.
    ///
    /// After a stop that reset Grbl the journal's resume point stands, if the head is still
    /// where the journal last saw it. Otherwise Grbl may have run on after the journal's last
    /// record (the sender crashed, or its port went), through at most the journal's last line
    /// sent: the head stands at the end of a line between the journal's resume point and that
    /// line, and the job resumes after it. Which one is decided by what the controller says:
    /// idle, not stopped by this connection, it ran everything it received, so it stands at the
    /// end of the last line sent that moves; otherwise by the position alone, and a position
    /// several of those lines end at (a job that cuts the same path twice) is refused
    /// ([`MachineError::ResumeAmbiguous`]), never guessed.
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
        // A board that lost its power (no homing) reads exactly machine zero: a line ending
        // there (a job's final return to the origin) proves nothing about having run on.
        let at_zero = now.iter().all(|v| v.abs() < 0.0005);
        if r.follow && !r.grbl_stopped && !at_zero {
            let ran_all = st.state == MachineState::Idle && !r.cut_short && !self.stopped_running;
            if let Some(line) = self.ran_on(job, r, from, work, ran_all)? {
                return Ok(line);
            }
        }
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

    /// Where a controller that may have run on after the journal's last record stands in the
    /// job: `Some(line)` to resume from, `None` when the head is at no line's end or inside no
    /// line of those it may have run (the position checks follow).
    fn ran_on(
        &mut self,
        job: &Program,
        r: &Recovery,
        from: usize,
        work: [f64; 3],
        ran_all: bool,
    ) -> Result<Option<usize>, MachineError> {
        let tol = self.position_tolerance();
        let at = |p: [f64; 3]| (0..3).all(|a| (p[a] - work[a]).abs() <= tol);
        // The last line Grbl can have received; without the journal's word, any.
        let last = r.last_sent.filter(|&s| s + 1 >= from).unwrap_or(usize::MAX);
        // Where each line that moves leaves the head (an arc's last chord), in file order.
        let mut ends: Vec<(usize, [f64; 3])> = Vec::new();
        for m in &job.moves {
            match ends.last_mut() {
                Some(e) if e.0 == m.line => e.1 = m.to,
                _ => ends.push((m.line, m.to)),
            }
        }
        // Idle and not stopped by this connection: it ran everything it received, so it stands
        // where the last line sent that moves ends. If so, the planner and the position agree.
        // The journal names a line before it goes out, so the last one may not have gone.
        let mut agree: Vec<usize> = Vec::new();
        if ran_all && last != usize::MAX {
            agree = [last, last.saturating_sub(1)]
                .iter()
                .filter_map(|&s| ends.iter().rev().find(|e| e.0 <= s))
                .filter(|e| e.0 + 1 >= from && at(e.1))
                .map(|e| e.0)
                .collect();
            agree.dedup();
        }
        if let [line] = agree[..] {
            if line + 1 > from {
                self.obs.message(&format!(
                    "Grbl stands idle at X{} Y{}, where line {line} ends, the last line that \
                     moves of those sent before the sender stopped (up to line {last}): it ran \
                     everything it had received, so the job resumes from line {} (not {from})",
                    num(work[0]),
                    num(work[1]),
                    line + 1
                ));
            }
            return Ok(Some(line + 1));
        }
        // The position alone: every line that may have run last and ends there.
        let before_from = ends
            .iter()
            .rev()
            .find(|e| e.0 < from)
            .map_or(job.start.pos, |e| e.1);
        let mut resume: Vec<usize> = Vec::new();
        if at(before_from) {
            resume.push(from);
        }
        resume.extend(
            ends.iter()
                .filter(|e| e.0 >= from && e.0 <= last && at(e.1))
                .map(|e| e.0 + 1),
        );
        let mut inside = false;
        if resume.is_empty() {
            // Stopped partway through a line (a feed hold): that line runs again from its start.
            inside = true;
            for m in job
                .moves
                .iter()
                .filter(|m| m.line >= from && m.line <= last)
            {
                if on_segment(m.from, m.to, work, tol) && resume.last() != Some(&m.line) {
                    resume.push(m.line);
                }
            }
        }
        resume.dedup();
        match resume[..] {
            [] => Ok(None),
            [line] => {
                if line != from {
                    let how = if inside {
                        format!("inside line {line}: Grbl stopped partway through it")
                    } else {
                        format!(
                            "where line {} ends: it ran on after the journal's last record",
                            line - 1
                        )
                    };
                    self.obs.message(&format!(
                        "Grbl stands at X{} Y{}, {how}, so the job resumes from line {line} \
                         (not {from})",
                        num(work[0]),
                        num(work[1]),
                    ));
                }
                Ok(Some(line))
            }
            _ => Err(MachineError::ResumeAmbiguous {
                port: self.port_name.clone(),
                position: Box::new(work),
                resume,
                inside,
            }),
        }
    }

    /// How close a reported position must be to a line's end to be there: half a step of the
    /// coarsest axis (Grbl stands on whole steps, `$100`-`$102`), at least 0.01 mm.
    fn position_tolerance(&self) -> f64 {
        let coarse = (100..=102)
            .filter_map(|k| self.info.setting(k))
            .filter(|s| s.is_finite() && *s > 0.0)
            .map(|s| 0.5 / s)
            .fold(0.0, f64::max);
        (coarse + 0.002).max(0.01)
    }
}

/// `p` lies on the segment `a`-`b` (within `tol`), its end points excluded.
fn on_segment(a: [f64; 3], b: [f64; 3], p: [f64; 3], tol: f64) -> bool {
    let d: Vec<f64> = (0..3).map(|i| b[i] - a[i]).collect();
    let len2: f64 = d.iter().map(|x| x * x).sum();
    if len2 <= tol * tol {
        return false;
    }
    let t = (0..3).map(|i| (p[i] - a[i]) * d[i]).sum::<f64>() / len2;
    if t <= 0.0 || t >= 1.0 {
        return false;
    }
    let dist2: f64 = (0..3).map(|i| (a[i] + t * d[i] - p[i]).powi(2)).sum();
    let near_end = |q: [f64; 3]| (0..3).all(|i| (q[i] - p[i]).abs() <= tol);
    dist2 <= tol * tol && !near_end(a) && !near_end(b)
}
