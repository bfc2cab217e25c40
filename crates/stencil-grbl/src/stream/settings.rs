//! Grbl's settings against what the job and the machine profile expect, before any beam fires:
//! the power scale (`$30`, `$31`), the rates and accelerations the estimate is made with, and
//! the travel the bed needs.

use super::config::PowerScale;
use super::session::Session;
use crate::error::MachineError;
use stencil_gcode::num;

/// How far a rate or acceleration may differ from the profile before it is reported (a
/// profile rounds what `$$` lists).
const MOTION_TOLERANCE: f64 = 0.02;

impl Session<'_, '_> {
    /// Compare `$$` with [`Expected`](super::config::Expected). A power scale that differs is
    /// refused (or, asked, every S is rescaled: [`Session::power_map`]); rates, accelerations
    /// and junction deviation that differ are reported (a front end's estimate uses the
    /// controller's); max travel short of the bed is refused under soft limits or homing, else
    /// reported.
    pub(super) fn check_settings(&mut self) -> Result<(), MachineError> {
        if self.info.settings.is_empty() {
            if self.cfg.expect != super::config::Expected::default() {
                self.obs.message(
                    "the controller did not list its settings ($$): its power scale, rates and \
                     travel could not be compared with the job",
                );
            }
            return Ok(());
        }
        if let Some(p) = self.cfg.expect.power.clone() {
            self.check_power(&p)?;
        }
        self.check_motion();
        self.check_travel()
    }

    fn check_power(&mut self, p: &PowerScale) -> Result<(), MachineError> {
        let (Some(c_max), c_min) = (self.info.setting(30), self.info.setting(31).unwrap_or(0.0))
        else {
            return Ok(());
        };
        let differs = |a: f64, b: f64| (a - b).abs() > 1e-6 * a.abs().max(b.abs()).max(1.0);
        let (setting, controller, job) = if differs(c_max, p.s_max) {
            (30, c_max, p.s_max)
        } else if differs(c_min, p.s_min) {
            (31, c_min, p.s_min)
        } else {
            return Ok(());
        };
        let refuse = |example: String| MachineError::PowerScale {
            port: self.port_name.clone(),
            setting,
            controller,
            job,
            written_for: p.source.clone(),
            example,
        };
        if c_max <= c_min {
            return Err(refuse(format!(
                "the controller's $30={} is not above its $31={}",
                num(c_max),
                num(c_min)
            )));
        }
        // What the job's 20 % becomes on this controller.
        let s20 = p.s_min + 0.2 * (p.s_max - p.s_min);
        let frac = ((s20 - c_min) / (c_max - c_min)).clamp(0.0, 1.0);
        let example = format!(
            "S{} means 20 % to the job and {:.0} % to the controller",
            num(s20),
            frac * 100.0
        );
        if !self.cfg.rescale_power {
            return Err(refuse(example));
        }
        let k = (c_max - c_min) / (p.s_max - p.s_min);
        self.power_map = Some((p.s_min, c_min, k));
        self.obs.message(&format!(
            "the controller's power scale is $30={} $31={}, the job's is $30={} $31={} ({}): \
             every S is rescaled to the controller's scale as asked (S{} is sent as S{})",
            num(c_max),
            num(c_min),
            num(p.s_max),
            num(p.s_min),
            p.source,
            num(s20),
            num(c_min + (s20 - p.s_min) * k)
        ));
        Ok(())
    }

    fn check_motion(&mut self) {
        let e = self.cfg.expect.clone();
        let pairs = [
            (110, e.rapid_mm_min, "X max rate", "rapid_mm_min", "mm/min"),
            (111, e.rapid_mm_min, "Y max rate", "rapid_mm_min", "mm/min"),
            (120, e.accel_mm_s2, "X acceleration", "accel_mm_s2", "mm/s²"),
            (121, e.accel_mm_s2, "Y acceleration", "accel_mm_s2", "mm/s²"),
            (
                11,
                e.junction_mm,
                "junction deviation",
                "junction_deviation_mm",
                "mm",
            ),
        ];
        for (n, want, what, field, unit) in pairs {
            let (Some(want), Some(have)) = (want, self.info.setting(n)) else {
                continue;
            };
            if (have - want).abs() > MOTION_TOLERANCE * want.abs().max(1e-9) {
                self.obs.message(&format!(
                    "the controller's ${n}={} ({what}, {unit}) differs from machine profile {}'s \
                     {field} = {}: the time estimate uses the controller's value; set ${n}={} \
                     or change the profile's {field} to match",
                    num(have),
                    e.profile,
                    num(want),
                    num(want)
                ));
            }
        }
    }

    fn check_travel(&mut self) -> Result<(), MachineError> {
        let Some(bed) = self.cfg.expect.bed_mm else {
            return Ok(());
        };
        let on = |v: Option<f64>| v.is_some_and(|v| v != 0.0);
        let why = match (on(self.info.setting(20)), on(self.info.setting(22))) {
            (true, _) => Some("soft limits are on ($20=1)"),
            (_, true) => Some("homing is on ($22=1)"),
            _ => None,
        };
        for (axis, n, size) in [('X', 130, bed[0]), ('Y', 131, bed[1])] {
            let Some(travel) = self.info.setting(n) else {
                continue;
            };
            if travel + 1e-6 >= size {
                continue;
            }
            match why {
                Some(why) => {
                    return Err(MachineError::TravelShort {
                        port: self.port_name.clone(),
                        axis,
                        setting: n,
                        travel,
                        bed: size,
                        profile: self.cfg.expect.profile.clone(),
                        why: why.to_string(),
                    })
                }
                None => self.obs.message(&format!(
                    "the controller's ${n}={} ({axis} max travel) is less than machine profile \
                     {}'s bed ({} mm): with soft limits and homing off Grbl does not enforce it, \
                     but check the profile's bed size or set ${n}={}",
                    num(travel),
                    self.cfg.expect.profile,
                    num(size),
                    num(size)
                )),
            }
        }
        Ok(())
    }

    /// A line with its S word rescaled to the controller's power scale, when asked.
    pub(super) fn rescaled(&self, text: &str) -> String {
        match self.power_map {
            Some((job_min, c_min, k)) => rescale_s(text, |s| c_min + (s - job_min) * k),
            None => text.to_string(),
        }
    }
}

/// `text` (a cleaned line: upper case, no spaces or comments) with every S value mapped by `f`;
/// `$` lines are left alone.
pub(crate) fn rescale_s(text: &str, f: impl Fn(f64) -> f64) -> String {
    if text.starts_with('$') {
        return text.to_string();
    }
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len() + 4);
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'S' {
            let start = i + 1;
            let mut j = start;
            while j < b.len() && (b[j].is_ascii_digit() || matches!(b[j], b'.' | b'-' | b'+')) {
                j += 1;
            }
            if let Ok(v) = text[start..j].parse::<f64>() {
                out.push('S');
                out.push_str(&num(f(v).max(0.0)));
                i = j;
                continue;
            }
        }
        out.push(b[i] as char);
        i += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::rescale_s;

    #[test]
    fn s_words_are_rescaled_and_nothing_else() {
        let k = |s: f64| s * 0.255;
        assert_eq!(rescale_s("G1X10S200F1500", k), "G1X10S51F1500");
        assert_eq!(rescale_s("M4S1000", k), "M4S255");
        assert_eq!(rescale_s("G1X1Y2", k), "G1X1Y2");
        assert_eq!(rescale_s("$30=1000", k), "$30=1000");
    }
}
