//! Real-time commands, acted on as they arrive: status reports, feed hold and resume, soft
//! reset, overrides and the jog cancel.

use super::config::Pace;
use super::record::{lock, Event};
use super::sim::{Block, Comment, Sim, State};
use crate::protocol::{Firmware, RT_FEED_HOLD, RT_JOG_CANCEL, RT_RESUME, RT_SOFT_RESET, RT_STATUS};

impl Sim {
    pub(super) fn realtime(&mut self, b: u8) {
        lock(&self.shared).events.push(Event::Realtime(b));
        match b {
            RT_STATUS => self.status_requested = true,
            RT_FEED_HOLD => self.rt_hold = true,
            // Cycle start resumes only a completed hold, and not in the pass that holds.
            RT_RESUME if self.hold_decel.is_none() && !self.rt_hold => self.hold = false,
            RT_SOFT_RESET => self.soft_reset(),
            b @ 0x90..=0x9D => self.override_byte(b),
            RT_JOG_CANCEL => self.jog_cancel(),
            _ => {}
        }
    }

    /// One pass of Grbl's `protocol_exec_rt_system`: a status report asked for is written
    /// *before* a feed hold that arrived in the same pass is acted on, so a `?` sent with (or
    /// just after) a `!` can still describe the machine before the hold. A hold is ignored in
    /// an alarm and in check mode; from Idle it is complete at once (`Hold:0`), from motion the
    /// head slows down at `$120` first (`Hold:1`).
    pub(super) fn rt_pass(&mut self) {
        if std::mem::take(&mut self.status_requested) {
            self.status_report();
        }
        if std::mem::take(&mut self.rt_hold) && self.state == State::Idle && !self.check_mode {
            self.start_hold();
        }
    }

    fn start_hold(&mut self) {
        if self.hold {
            return;
        }
        self.hold = true;
        let Some(b) = self.planner.front() else {
            return;
        };
        if self.frozen || !matches!(self.cfg.pace, Pace::Timed { .. }) {
            return;
        }
        let mm_min = self.block_mm_min(b);
        let accel = self.setting(120).filter(|a| *a > 0.0).unwrap_or(1000.0);
        let t = mm_min / 60.0 / accel;
        if t > 0.0 {
            self.hold_decel = Some((t, t));
        }
    }

    /// A numeric setting as `$$` lists it.
    pub(super) fn setting(&self, n: u32) -> Option<f64> {
        self.settings
            .iter()
            .find(|(k, _)| *k == n)
            .and_then(|(_, v)| v.parse().ok())
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

    /// What a reset or a power loss forgets: the buffers, the queue, a hold, check mode, the
    /// overrides (back to 100 %, as Grbl does) and a line waiting for its `ok`.
    pub(super) fn forget(&mut self) {
        self.planner.clear();
        self.pending = None;
        self.rx.clear();
        self.line_buf.clear();
        self.raw_line.clear();
        self.hold = false;
        self.hold_decel = None;
        self.rt_hold = false;
        self.check_mode = false;
        self.ov = [100; 3];
        self.waiting = None;
        self.line_wait = None;
    }

    pub(super) fn soft_reset(&mut self) {
        // A completed feed hold keeps the position: only a reset while moving loses it.
        let moving = (!self.planner.is_empty() || self.pending.is_some())
            && (!self.hold || self.hold_decel.is_some());
        lock(&self.shared).events.push(Event::SoftReset);
        self.forget();
        self.backlog.clear();
        self.card_run = None;
        self.upload = None;
        self.unheard = 0;
        self.line_overflow = false;
        self.comment = Comment::None;
        self.eeprom = None;
        self.status_requested = false;
        self.ok_fault = None;
        self.frozen = false;
        self.setting_pending = None;
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
        self.boot_banner();
    }

    /// What Grbl prints when it starts: a blank line, the banner, and the unlock hint when it
    /// starts locked in alarm.
    pub(super) fn boot_banner(&mut self) {
        self.say("");
        self.say(match self.cfg.firmware {
            Firmware::Grbl => "Grbl 1.1h ['$' for help]",
            Firmware::GrblHal => "GrblHAL 1.1f ['$' or '$HELP' for help]",
            Firmware::FluidNc => "Grbl 3.7 [FluidNC v3.7.8 (virtual) '$' for help]",
        });
        if self.state == State::Alarm {
            self.say("[MSG:'$H'|'$X' to unlock]");
        }
    }

    /// The state as a status report names it. A frozen machine claims `Run` in its reports
    /// (`report`); the record shows what its planner holds.
    pub(super) fn state_word(&self, report: bool) -> &'static str {
        match self.state {
            State::Alarm | State::Critical => "Alarm",
            State::Idle if self.check_mode => "Check",
            State::Idle if self.hold && self.hold_decel.is_some() => "Hold:1",
            State::Idle if self.hold => "Hold:0",
            State::Idle if report && self.frozen => "Run",
            State::Idle if self.jogging() => "Jog",
            State::Idle if !self.planner.is_empty() => "Run",
            State::Idle => "Idle",
        }
    }

    /// How fast the block runs, mm/min, under the feed or rapid override.
    fn block_mm_min(&self, b: &Block) -> f64 {
        let [feed_ov, rapid_ov, _] = self.ov;
        if b.mv.rapid {
            self.cfg.rapid_mm_min * rapid_ov as f64 / 100.0
        } else {
            b.mv.feed * feed_ov as f64 / 100.0
        }
    }

    pub(super) fn status_report(&mut self) {
        self.reports += 1;
        let state = self.state_word(true);
        let p = self.position();
        let running = !self.planner.is_empty() && !self.hold && self.state == State::Idle;
        let [feed_ov, rapid_ov, spindle_ov] = self.ov;
        let (feed, speed) = match self.planner.front() {
            Some(b) if running => (self.block_mm_min(b), b.mv.power * spindle_ov as f64 / 100.0),
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
        if self.cfg.firmware == Firmware::GrblHal {
            // grblHAL: homed or not, with the axes that home; its name in the first report.
            let homed = self.homed && self.cfg.homing;
            s.push_str(if homed { "|H:1,7" } else { "|H:0,7" });
            if self.reports == 1 {
                s.push_str("|FW:grblHAL");
            }
        }
        if let Some(sd) = self.card_field() {
            s.push_str(&sd);
        }
        s.push('>');
        lock(&self.shared).status_reports += 1;
        self.say(&s);
    }
}
