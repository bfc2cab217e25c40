//! Grbl's `$` commands: build info, check mode, unlock, homing, parser state, the settings
//! (`$$`, and `$N=V` written to EEPROM) and jogs.

use std::time::{Duration, Instant};

use super::sim::{Sim, State};

/// How long writing one setting to EEPROM keeps the simulated Grbl deaf (a few ms on an AVR).
const EEPROM_WRITE: Duration = Duration::from_millis(20);

impl Sim {
    /// A `$` line: Grbl's system commands, answered at once (a setting when written).
    pub(super) fn system(&mut self, cmd: &str, idx: usize) {
        let idle = self.planner.is_empty() && self.pending.is_none();
        match cmd {
            "$I" => {
                self.say("[VER:1.1h.20190830:]");
                let opt = format!("[OPT:V,{},{}]", self.cfg.planner_blocks, self.cfg.rx_buffer);
                self.say(&opt);
                self.done(idx);
            }
            "$C" => self.toggle_check_mode(idx, idle),
            "$X" => {
                if self.state == State::Alarm {
                    self.state = State::Idle;
                    self.say("[MSG:Caution: Unlocked]");
                }
                self.done(idx);
            }
            "$H" => self.home(idx, idle),
            "$G" => {
                let gc = self.parser_state();
                self.say(&gc);
                self.done(idx);
            }
            "$$" => {
                for (k, v) in self.settings.clone() {
                    self.say(&format!("${k}={v}"));
                }
                self.done(idx);
            }
            "$#" => {
                for l in self.ngc_parameters() {
                    self.say(&l);
                }
                self.done(idx);
            }
            "$N" => {
                // No startup blocks are stored.
                self.say("$N0=");
                self.say("$N1=");
                self.done(idx);
            }
            c if c.starts_with("$J") => self.jog(c, idx),
            c if c[1..]
                .split_once('=')
                .is_some_and(|(k, v)| k.parse::<u32>().is_ok() && v.parse::<f64>().is_ok()) =>
            {
                self.write_setting(c, idx, idle)
            }
            _ => self.reply_error(3),
        }
    }

    /// `$C`: into check mode, or out of it (which soft-resets, as Grbl does); only while idle.
    fn toggle_check_mode(&mut self, idx: usize, idle: bool) {
        if !idle || self.state == State::Alarm {
            return self.reply_error(8);
        }
        if self.check_mode {
            self.say("[MSG:Disabled]");
            self.done(idx);
            self.soft_reset();
        } else {
            self.check_mode = true;
            self.say("[MSG:Enabled]");
            self.done(idx);
        }
    }

    /// `$H`: to machine zero (work coordinates keep their offset), clearing an alarm; `error:5`
    /// without homing, `error:8` while moving.
    fn home(&mut self, idx: usize, idle: bool) {
        if !self.cfg.homing {
            return self.reply_error(5);
        }
        if !idle {
            return self.reply_error(8);
        }
        self.modal.pos = [0.0; 3];
        self.state = State::Idle;
        self.done(idx);
    }

    /// `$G`'s report of the parser's modes.
    fn parser_state(&self) -> String {
        let m = &self.modal;
        format!(
            "[GC:G{} G{} G{} {} {} G{} {} M9 T0 F{} S{}]",
            stencil_gcode::interpret::motion_word(m.motion),
            54 + m.coord_select,
            17 + m.plane,
            if m.metric { "G21" } else { "G20" },
            if m.absolute { "G90" } else { "G91" },
            if m.inverse_time { 93 } else { 94 },
            match (m.spindle_on, m.dynamic) {
                (false, _) => "M5",
                (true, true) => "M4",
                (true, false) => "M3",
            },
            m.feed.unwrap_or(0.0),
            m.s
        )
    }

    /// `$N=V`: written to EEPROM, only while idle and not in check mode. Writing EEPROM stops
    /// Grbl's serial interrupt: bytes that arrive meanwhile are lost, and the `ok` comes when the
    /// write is done.
    fn write_setting(&mut self, cmd: &str, idx: usize, idle: bool) {
        if self.check_mode || !idle {
            return self.reply_error(8);
        }
        let (k, v) = cmd[1..].split_once('=').unwrap_or_default();
        self.setting_pending = k.parse().ok().map(|k| (k, v.to_string()));
        self.eeprom = Some((Instant::now() + EEPROM_WRITE, idx));
    }

    /// `$32` (laser mode) as the settings stand.
    pub(super) fn laser_mode(&self) -> bool {
        self.setting(32).is_some_and(|v| v != 0.0)
    }

    /// `$#`: the work systems G54..G59, the G28/G30 positions, G92, the tool length offset and
    /// the last probe, as Grbl's `report_ngc_parameters` prints them (mm, 3 decimals).
    fn ngc_parameters(&self) -> Vec<String> {
        let m = &self.modal;
        let xyz = |p: [f64; 3]| format!("{:.3},{:.3},{:.3}", p[0], p[1], p[2]);
        let mut out: Vec<String> = (0..6)
            .map(|k| format!("[G{}:{}]", 54 + k, xyz(m.coords[k])))
            .collect();
        out.push(format!("[G28:{}]", xyz(m.g28)));
        out.push(format!("[G30:{}]", xyz(m.g30)));
        out.push(format!("[G92:{}]", xyz(m.g92)));
        out.push(format!("[TLO:{:.3}]", m.tlo));
        // No probe is wired: no probe position was ever taken.
        out.push("[PRB:0.000,0.000,0.000:0]".into());
        out
    }
}
