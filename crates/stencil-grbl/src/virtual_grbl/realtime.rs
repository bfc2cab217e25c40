//! Real-time commands, acted on as they arrive: status reports, feed hold and resume, soft
//! reset, overrides and the jog cancel.

use super::parser::Comment;
use super::sim::{Sim, State};
use super::{lock, Event};
use crate::protocol::{RT_FEED_HOLD, RT_JOG_CANCEL, RT_RESUME, RT_SOFT_RESET, RT_STATUS};

impl Sim {
    pub(super) fn realtime(&mut self, b: u8) {
        lock(&self.shared).events.push(Event::Realtime(b));
        match b {
            RT_STATUS => self.status_requested = true,
            RT_FEED_HOLD if self.state == State::Idle => self.hold = true,
            RT_RESUME => self.hold = false,
            RT_SOFT_RESET => self.soft_reset(),
            b @ 0x90..=0x9D => self.override_byte(b),
            RT_JOG_CANCEL => self.jog_cancel(),
            _ => {}
        }
    }

    /// Grbl's override bytes: feed 0x90 (100 %), 0x91/0x92 (±10), 0x93/0x94 (±1), 10..200 %;
    /// rapid 0x95/0x96/0x97 (100/50/25 %); spindle 0x99 (100 %), 0x9A/0x9B (±10), 0x9C/0x9D
    /// (±1), 10..200 %.
    fn override_byte(&mut self, b: u8) {
        let [f, r, s] = self.ov;
        let step = |v: u32, d: i32| (v as i32 + d).clamp(10, 200) as u32;
        self.ov = match b {
            0x90 => [100, r, s],
            0x91 => [step(f, 10), r, s],
            0x92 => [step(f, -10), r, s],
            0x93 => [step(f, 1), r, s],
            0x94 => [step(f, -1), r, s],
            0x95 => [f, 100, s],
            0x96 => [f, 50, s],
            0x97 => [f, 25, s],
            0x99 => [f, r, 100],
            0x9A => [f, r, step(s, 10)],
            0x9B => [f, r, step(s, -10)],
            0x9C => [f, r, step(s, 1)],
            0x9D => [f, r, step(s, -1)],
            _ => return,
        };
        self.ov_changed = true;
    }

    pub(super) fn soft_reset(&mut self) {
        // A completed feed hold keeps the position: only a reset while moving loses it.
        let moving = (!self.planner.is_empty() || self.pending.is_some()) && !self.hold;
        lock(&self.shared).events.push(Event::SoftReset);
        self.rx.clear();
        self.line_buf.clear();
        self.line_overflow = false;
        self.comment = Comment::None;
        self.eeprom = None;
        self.pending = None;
        self.planner.clear();
        self.hold = false;
        self.check_mode = false;
        self.frozen = false;
        self.setting_pending = None;
        // A reset brings the overrides back to 100 %, as Grbl does.
        self.ov = [100; 3];
        self.waiting = None;
        self.line_wait = None;
        self.modal = self.modal.after_reset();
        if moving && self.state == State::Idle {
            // Grbl: a reset during motion may have lost steps, so it locks until unlocked.
            self.say("ALARM:3");
            lock(&self.shared).events.push(Event::Alarm(3));
            self.state = State::Alarm;
        }
        if self.state == State::Critical {
            self.state = State::Alarm;
        }
        self.say("");
        self.say("Grbl 1.1h ['$' for help]");
        if self.state == State::Alarm {
            self.say("[MSG:'$H'|'$X' to unlock]");
        }
    }

    pub(super) fn status_report(&mut self) {
        self.reports += 1;
        let state = match self.state {
            State::Alarm | State::Critical => "Alarm".to_string(),
            State::Idle if self.check_mode => "Check".to_string(),
            State::Idle if self.hold => "Hold:0".to_string(),
            State::Idle if self.frozen => "Run".to_string(),
            State::Idle if self.jogging() => "Jog".to_string(),
            State::Idle if !self.planner.is_empty() => "Run".to_string(),
            State::Idle => "Idle".to_string(),
        };
        let p = self.position();
        let running = !self.planner.is_empty() && !self.hold && self.state == State::Idle;
        let [feed_ov, rapid_ov, spindle_ov] = self.ov;
        let (feed, speed) = match self.planner.front() {
            Some(b) if running => (
                if b.mv.rapid {
                    self.cfg.rapid_mm_min * rapid_ov as f64 / 100.0
                } else {
                    b.mv.feed * feed_ov as f64 / 100.0
                },
                b.mv.power * spindle_ov as f64 / 100.0,
            ),
            // A frozen machine still claims its programmed feed: nothing in the report gives
            // the stall away but the position standing still.
            _ if self.frozen && !self.hold => (self.modal.feed.unwrap_or(0.0), 0.0),
            _ => (0.0, 0.0),
        };
        let mut s = format!(
            "<{state}|MPos:{:.3},{:.3},{:.3}|Bf:{},{}|FS:{feed:.0},{speed:.0}",
            p[0],
            p[1],
            p[2],
            self.cfg.planner_blocks - self.planner.len(),
            self.cfg.rx_buffer - self.rx.len(),
        );
        if self.cfg.line_numbers {
            if let Some(n) = self.planner.front().and_then(|b| b.n) {
                s.push_str(&format!("|Ln:{n}"));
            }
        }
        // As Grbl: WCO every 10 reports and at once after a change; Ov every 10 reports and at
        // once after a change (never in the same report as WCO), with the accessory states
        // (spindle CW/CCW, flood) when any is on.
        // A change of overrides is reported at once, ahead of a periodic WCO.
        if self.wco_changed || (self.reports % 10 == 1 && !self.ov_changed) {
            self.wco_changed = false;
            let w = self.wco;
            s.push_str(&format!("|WCO:{:.3},{:.3},{:.3}", w[0], w[1], w[2]));
        } else if self.reports % 10 == 2 || self.ov_changed {
            self.ov_changed = false;
            s.push_str(&format!("|Ov:{feed_ov},{rapid_ov},{spindle_ov}"));
            let mut a = String::new();
            if self.modal.spindle_on {
                a.push(if self.modal.dynamic { 'C' } else { 'S' });
            }
            if self.modal.coolant {
                a.push('F');
            }
            if !a.is_empty() {
                s.push_str(&format!("|A:{a}"));
            }
        }
        s.push('>');
        lock(&self.shared).status_reports += 1;
        self.say(&s);
    }
}
