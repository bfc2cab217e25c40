//! Grbl's main loop over the receive buffer: the line buffer (comments, spaces and block delete
//! dropped, 79 characters at most), then each line answered through the shared interpreter.

use std::time::Instant;

use stencil_gcode::interpret as gcode;
use stencil_gcode::limits::MAX_LINE_BYTES;

use super::lock;
use super::record::{Event, Received};
use super::sim::{Sim, State};

/// Where the line buffer is in a comment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Comment {
    None,
    Paren,
    Semicolon,
}

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
                    match self.settings.iter_mut().find(|(n, _)| *n == k) {
                        Some(e) => e.1 = v,
                        None => self.settings.push((k, v)),
                    }
                }
                self.done(idx);
            }
            if let Some((mv, idx)) = self.pending.take() {
                if !self.plan(mv, idx) {
                    self.pending = Some((mv, idx));
                    return;
                }
                self.say("ok");
                continue;
            }
            let Some(b) = self.rx.pop_front() else {
                return;
            };
            // As Grbl fills its line buffer: comments, spaces, control characters and block
            // delete never enter it; what is left must fit 79 characters.
            if b == b'\n' || b == b'\r' {
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
        if clean.starts_with("G10") {
            return self.set_work_offset(&clean, idx);
        }
        if clean.starts_with("G92") {
            return self.set_g92(&clean, idx);
        }
        let mut modal = self.modal;
        match gcode::step(&mut modal, &clean, idx + 1) {
            Err(e) => self.reply_error(e.code),
            Ok(mv) => {
                self.modal = modal;
                match mv {
                    Some(mv) if !self.check_mode => {
                        if self.plan(mv, idx) {
                            self.say("ok");
                        } else {
                            self.pending = Some((mv, idx));
                        }
                    }
                    _ => self.done(idx),
                }
            }
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
