//! Grbl's `$` commands: build info, check mode, unlock, homing, parser state, the settings
//! (`$$`, and `$N=V` written to EEPROM) and jogs.

use std::time::{Duration, Instant};

use super::sim::{Sim, State};
use crate::protocol::Firmware;

/// How long writing one setting to EEPROM keeps the simulated Grbl deaf (a few ms on an AVR).
const EEPROM_WRITE: Duration = Duration::from_millis(20);

impl Sim {
    /// A `$` line: Grbl's system commands, answered at once (a setting when written).
    pub(super) fn system(&mut self, cmd: &str, idx: usize) {
        let idle = self.planner.is_empty() && self.pending.is_none();
        match cmd {
            "$CD" if self.cfg.firmware == Firmware::FluidNc => self.config_dump(idx),
            "$I" | "$I+" => self.build_info(cmd == "$I+", idx),
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
            c if self.card_command(c, idx) => {}
            _ => self.reply_error(3),
        }
    }

    /// `$I` as each firmware answers it; `$I+` is grblHAL's (Grbl and FluidNC refuse it).
    fn build_info(&mut self, extended: bool, idx: usize) {
        let (blocks, rx) = (self.cfg.planner_blocks, self.cfg.rx_buffer);
        match self.cfg.firmware {
            Firmware::Grbl | Firmware::FluidNc if extended => return self.reply_error(3),
            Firmware::Grbl => {
                self.say("[VER:1.1h.20190830:]");
                self.say(&format!("[OPT:V,{blocks},{rx}]"));
            }
            Firmware::GrblHal => {
                self.say("[VER:1.1f.20250731:]");
                self.say(&format!("[OPT:VNMSL,{blocks},{rx},3,0]"));
                self.say("[AXS:3:XYZ]");
                self.say("[NEWOPT:ENUMS,RT+,HOME,SED]");
                self.say("[FIRMWARE:grblHAL]");
            }
            Firmware::FluidNc => {
                // No sizes: FluidNC's option line keeps only Grbl's letters.
                self.say("[VER:3.7 FluidNC v3.7.8 (virtual) :]");
                self.say("[OPT:PHS]");
                self.say("[MSG:INFO: Machine virtual]");
            }
        }
        self.done(idx);
    }

    /// FluidNC's configuration file, as `$Config/Dump` prints it: a laser spindle (when `$32`
    /// is on) whose speed map goes to `$30`, or a PWM spindle.
    fn config_dump(&mut self, idx: usize) {
        let max = self.setting(30).unwrap_or(1000.0);
        let spindle = if self.laser_mode() { "Laser:" } else { "PWM:" };
        for l in [
            "board: virtual".to_string(),
            "name: virtual".into(),
            spindle.into(),
            "  pwm_hz: 5000".into(),
            "  output_pin: gpio.2".into(),
            format!("  speed_map: 0=0.000% {}=100.000%", stencil_gcode::num(max)),
            "  off_on_alarm: true".into(),
        ] {
            self.say(&l);
        }
        self.done(idx);
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
        self.homed = true;
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
        let proxy = |k: u32| matches!(k, 20..=23 | 30 | 32 | 100..=133);
        if self.cfg.firmware == Firmware::FluidNc && k.parse().is_ok_and(proxy) {
            // FluidNC's numbered settings mirror its configuration file: read-only.
            return self.reply_error(162);
        }
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
