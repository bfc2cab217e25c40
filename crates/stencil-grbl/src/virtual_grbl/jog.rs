//! Jogging as Grbl 1.1 does it: `$J=` motions, and the jog cancel (0x85) that drops them.

use stencil_gcode::interpret::{self as gcode, Move};

use super::sim::{Sim, State};

impl Sim {
    /// The planner runs a jog (`$J=`): Grbl's `Jog` state.
    pub(super) fn jogging(&self) -> bool {
        self.planner.front().is_some_and(|b| b.jog)
    }

    /// `$J=...`: a jog motion, as Grbl 1.1 takes it (system.c, gcode.c, jog.c): only while Idle
    /// or already jogging (else `error:8`, so never in an alarm), F required (`error:22`), only
    /// G20/G21, G90/G91 and G53 besides X/Y/Z, F and N (`error:16`). The parser's modes are
    /// left as they were; its position moves to the jog's target, as Grbl's does.
    pub(super) fn jog(&mut self, cmd: &str, idx: usize) {
        let busy = self.pending.is_some() || self.planner.iter().any(|b| !b.jog) || self.hold;
        if self.state != State::Idle || self.check_mode || busy {
            return self.reply_error(8);
        }
        let Some(body) = cmd.strip_prefix("$J=") else {
            return self.reply_error(3);
        };
        let words = match gcode::words(body, idx + 1) {
            Ok(w) => w,
            Err(e) => return self.reply_error(e.code),
        };
        let (mut metric, mut absolute, mut machine) =
            (self.modal.metric, self.modal.absolute, false);
        let (mut feed, mut target) = (None, [None::<f64>; 3]);
        for (l, v) in words {
            match l {
                'G' if v == 20.0 || v == 21.0 => metric = v == 21.0,
                'G' if v == 90.0 || v == 91.0 => absolute = v == 90.0,
                'G' if v == 53.0 => machine = true,
                'G' | 'M' => return self.reply_error(16),
                'F' => feed = Some(v),
                'X' => target[0] = Some(v),
                'Y' => target[1] = Some(v),
                'Z' => target[2] = Some(v),
                'N' => {}
                'S' | 'T' => return self.reply_error(36),
                _ => return self.reply_error(20),
            }
        }
        let unit = if metric { 1.0 } else { 25.4 };
        let Some(feed) = feed.filter(|f| *f > 0.0) else {
            return self.reply_error(22);
        };
        if target.iter().all(Option::is_none) {
            return self.reply_error(26);
        }
        let from = self.modal.pos;
        let mut to = from;
        for a in 0..3 {
            if let Some(v) = target[a] {
                // The parser's position is in machine coordinates.
                to[a] = match (machine, absolute) {
                    (true, _) => v * unit,
                    (false, true) => v * unit + self.wco[a],
                    (false, false) => from[a] + v * unit,
                };
            }
        }
        if to
            .iter()
            .any(|v| !v.is_finite() || v.abs() > gcode::MAX_COORD_MM)
        {
            return self.reply_error(15);
        }
        self.modal.pos = to;
        let mv = Move {
            from,
            to,
            rapid: false,
            feed: feed * unit,
            power: 0.0,
            spindle_s: 0.0,
            line: idx + 1,
        };
        if self.plan(mv, idx) {
            self.say("ok");
        } else {
            self.pending = Some((mv, idx));
        }
    }

    /// 0x85: stop the running jog where it is and drop the queued jog motions; the parser's
    /// position follows the machine's (Grbl's `gc_sync_position`). Ignored unless jogging.
    pub(super) fn jog_cancel(&mut self) {
        if !self.jogging() || self.state != State::Idle {
            return;
        }
        let pos = self.position();
        self.planner.retain(|b| !b.jog);
        if self.pending.is_some() {
            // A jog still waiting for a planner slot: dropped, but it was not answered yet.
            self.pending = None;
            self.say("ok");
        }
        self.modal.pos = pos;
    }
}
