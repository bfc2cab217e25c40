//! Grbl's main loop over the receive buffer: the line buffer (comments, spaces and block delete
//! dropped, 79 characters at most), then each line answered through the shared interpreter.

use std::time::Instant;

use stencil_gcode::interpret as gcode;
use stencil_gcode::limits::MAX_LINE_BYTES;

use stencil_gcode::interpret::Move;

use super::config::{put_setting, Pace};
use super::record::{lock, Event, Received};
use super::sim::{Block, Comment, Sim, State, Wait, WaitFor};

impl Sim {
    /// Pull lines out of the receive buffer and run them, as Grbl's main loop does: it stops
    /// pulling while a motion line waits for a free planner block.
    pub(super) fn process_lines(&mut self) {
        loop {
            if self.state == State::Critical || self.port.is_none() || self.frozen {
                return;
            }
            if let Some((until, idx)) = self.eeprom {
                if Instant::now() < until {
                    return;
                }
                self.eeprom = None;
                if let Some((k, v)) = self.setting_pending.take() {
                    put_setting(&mut self.settings, k, v);
                }
                self.done(idx);
            }
            self.sync_wco();
            if self.pending.is_none() {
                // A reset dropped the line these belonged to.
                self.pending_rest.clear();
            }
            if let Some((mv, idx)) = self.pending.take() {
                if !self.plan(mv, idx) {
                    self.pending = Some((mv, idx));
                    return;
                }
                // An arc's next chord, or the line's `ok` once all are queued.
                if let Some(next) = self.pending_rest.pop_front() {
                    self.pending = Some((next, idx));
                    continue;
                }
                self.finish_line(idx, true);
                continue;
            }
            if let Some(w) = self.waiting {
                if !self.finish_wait(w) {
                    return;
                }
                continue;
            }
            let Some(b) = self.rx.pop_front() else {
                return;
            };
            // The line as it came (bounded), for the file names of card commands.
            if b != b'\n' && b != b'\r' && self.raw_line.len() < 256 {
                self.raw_line.push(b);
            }
            // As Grbl fills its line buffer: comments, spaces, control characters and block
            // delete never enter it; what is left must fit 79 characters.
            if b == b'\n' || b == b'\r' {
                let as_came = std::mem::take(&mut self.raw_line);
                self.last_raw = String::from_utf8_lossy(&as_came).into_owned();
                let raw = std::mem::take(&mut self.line_buf);
                let overflow = std::mem::replace(&mut self.line_overflow, false);
                self.comment = Comment::None;
                self.line(String::from_utf8_lossy(&raw).into_owned(), overflow);
            } else if self.comment == Comment::Paren {
                if b == b')' {
                    self.comment = Comment::None;
                }
            } else if self.comment == Comment::Semicolon {
            } else if b == b'(' {
                self.comment = Comment::Paren;
            } else if b == b';' {
                self.comment = Comment::Semicolon;
            } else if b <= b' ' || b == b'/' {
            } else if self.line_buf.len() >= MAX_LINE_BYTES {
                self.line_overflow = true;
            } else {
                self.line_buf.push(b.to_ascii_uppercase());
            }
        }
    }

    fn line(&mut self, text: String, overflow: bool) {
        let idx = {
            let mut r = lock(&self.shared);
            r.received.push(Received {
                text: text.clone(),
                check_mode: self.check_mode,
            });
            let idx = r.received.len() - 1;
            r.events.push(Event::Line(idx));
            idx
        };
        let clean = gcode::clean_line(&text);
        if overflow {
            return self.reply_error(11);
        }
        if clean.is_empty() {
            return self.done(idx);
        }
        if clean.starts_with('$') {
            return self.system(&clean, idx);
        }
        if self.state == State::Alarm {
            return self.reply_error(9);
        }
        if !self.check_mode {
            self.job_lines += 1;
            if self.fire_fault() {
                return;
            }
        }
        let mut modal = self.modal;
        match gcode::step(&mut modal, &clean, idx + 1) {
            Err(e) => self.reply_error(e.code),
            Ok(done) => {
                self.modal = modal;
                self.sync_wco();
                self.run_line(done, idx);
            }
        }
    }

    /// Queue what a line does, as Grbl's executor does it: motion into the planner (an arc chord
    /// by chord), then a dwell, a probe, M0 or a program end after the queue has run out.
    fn run_line(&mut self, done: gcode::Executed, idx: usize) {
        self.line_wait = if self.check_mode {
            None
        } else if let Some(p) = done.probe {
            Some(Wait::Probe(p))
        } else if done.dwell_s > 0.0 {
            Some(Wait::Dwell(done.dwell_s))
        } else {
            match done.flow {
                Some(gcode::Flow::Pause) => Some(Wait::Pause { held: false }),
                Some(gcode::Flow::End) => Some(Wait::End),
                None => None,
            }
        };
        if self.check_mode && done.flow == Some(gcode::Flow::End) {
            self.say("[MSG:Pgm End]");
        }
        let mut moves = done.moves.into_iter();
        match moves.next() {
            Some(first) if !self.check_mode => {
                self.pending_rest = moves.collect();
                self.pending = Some((first, idx));
            }
            _ => self.finish_line(idx, false),
        }
    }

    /// The line's motion is queued: answer it, or first wait as it asks. A line that moved is
    /// recorded as executed when its last block has run, not here.
    fn finish_line(&mut self, idx: usize, moved: bool) {
        match self.line_wait.take() {
            None if moved => self.say("ok"),
            None => self.done(idx),
            Some(wait) => self.waiting = Some(WaitFor { wait, idx, moved }),
        }
    }

    /// A waiting line's `ok`, once what it waited for is over.
    fn answer_waited(&mut self, w: WaitFor) {
        self.waiting = None;
        if w.moved {
            self.say("ok");
        } else {
            self.done(w.idx);
        }
    }

    /// A line waiting for the queue to run out (Grbl's `protocol_buffer_synchronize`): true
    /// once it has been answered.
    fn finish_wait(&mut self, w: WaitFor) -> bool {
        let idle = self.planner.is_empty();
        match w.wait {
            Wait::Dwell(s) if idle => {
                match self.cfg.pace {
                    Pace::Timed { .. } => {
                        // The dwell runs as a block that stands still; `ok` when it is over.
                        self.dwell_block(s, w.idx);
                        self.waiting = Some(WaitFor {
                            wait: Wait::Dwelling,
                            ..w
                        });
                        return false;
                    }
                    Pace::Instant => self.answer_waited(w),
                }
                true
            }
            Wait::Dwelling if idle => {
                // The dwell block recorded the line as executed when it ran out.
                self.waiting = None;
                self.say("ok");
                true
            }
            Wait::Probe(p) if idle => {
                if p == 382 || p == 384 {
                    // No probe answers: the move ran its length without contact.
                    self.say("ALARM:5");
                    lock(&self.shared).events.push(Event::Alarm(5));
                    self.state = State::Alarm;
                }
                self.answer_waited(w);
                true
            }
            Wait::Pause { held: false } if idle => {
                // M0: a feed hold once the queue is empty; the `ok` comes with cycle start.
                self.hold = true;
                self.waiting = Some(WaitFor {
                    wait: Wait::Pause { held: true },
                    ..w
                });
                false
            }
            Wait::Pause { held: true } if !self.hold => {
                self.answer_waited(w);
                true
            }
            Wait::End if idle => {
                self.say("[MSG:Pgm End]");
                self.answer_waited(w);
                true
            }
            _ => false,
        }
    }

    /// G4 at the machine's pace: a block that stands still for `s` seconds.
    fn dwell_block(&mut self, s: f64, idx: usize) {
        let here = self.modal.pos;
        self.planner.push_back(Block {
            mv: Move {
                from: here,
                to: here,
                line: idx + 1,
                ..Move::default()
            },
            n: None,
            idx,
            remaining_s: s,
            duration_s: s,
            jog: false,
            last: true,
        });
    }

    /// The settings the parser reads: `$12`, the arc tolerance.
    pub(super) fn apply_settings(&mut self) {
        if let Some(t) = self.setting(12).filter(|t| *t > 0.0) {
            self.modal.arc_tolerance = t;
        }
    }

    /// Keep the reported work offset (`WCO:`) with the parser's, flagging a change for the next
    /// status report as Grbl does.
    pub(super) fn sync_wco(&mut self) {
        let w = self.modal.wco();
        if w != self.wco {
            self.wco = w;
            self.wco_changed = true;
        }
    }

    pub(super) fn done(&mut self, idx: usize) {
        lock(&self.shared).executed.push(idx);
        self.say("ok");
    }

    pub(super) fn reply_error(&mut self, code: u8) {
        self.say(&format!("error:{code}"));
    }
}
