//! Jogging as Grbl 1.1 does it: `$J=` motions, and the jog cancel (0x85) that drops them.

use stencil_gcode::interpret::{self as gcode, Move};

use super::sim::{Sim, State};

impl Sim {
    /// The planner runs a jog (`$J=`): Grbl's `Jog` state.
    pub(super) fn jogging(&self) -> bool {
        self.planner.front().is_some_and(|b| b.jog)
    }

    /// `$J=...`: a jog motion, as Grbl 1.1 takes it (system.c, gcode.c, jog.c): only while Idle
    /// or already jogging (else `error:8`, so never in an alarm); its words through the shared
    /// parser's jog rules (F required, `error:22`; only G20/G21, G90/G91 and G53, `error:16`;
    /// S or T unused, `error:36`). The parser's modes are left as they were; its position moves
    /// to the jog's target, as Grbl's does.
    pub(super) fn jog(&mut self, cmd: &str, idx: usize) {
        let busy = self.pending.is_some() || self.planner.iter().any(|b| !b.jog) || self.hold;
        if self.state != State::Idle || self.check_mode || busy {
            return self.reply_error(8);
        }
        let Some(body) = cmd.strip_prefix("$J=") else {
            return self.reply_error(3);
        };
        // Checked as Grbl's gc_execute_line checks a jog (the shared parser, jog flag on);
        // a target no machine reaches is refused as travel exceeded.
        let (to, feed) = match gcode::jog(&self.modal, body, idx + 1) {
            Ok(j) => j,
            Err(e) if e.out_of_range => return self.reply_error(15),
            Err(e) => return self.reply_error(e.code),
        };
        let from = self.modal.pos;
        self.modal.pos = to;
        let mv = Move {
            from,
            to,
            feed,
            line: idx + 1,
            ..Move::default()
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
