//! Jogging at the machine: keys move the head with Grbl's jog command (`$J=G91 G21 X.. F..`),
//! home it (`$H`), unlock it (`$X`) and set work zero (`G10 L20 P1 X0 Y0`).
//!
//! Keys come through [`JogKeys`], so a terminal in raw mode, a script (`--keys`) and key names
//! read from a pipe all drive the same [`Jogger`]; tests drive it against the virtual Grbl.
//! Jogs are Grbl's own `$J=` motions: Grbl refuses them in an alarm and checks them against soft
//! limits, a jog cancel (0x85) stops one at once, and they never fire the laser. Leaving ends
//! with the jog cancelled, the machine still, and `M5` / `M9` (laser and air off).

use std::io;
use std::time::Duration;

use super::error::MachineError;
use super::protocol::{self, MachineState, RT_JOG_CANCEL};
use crate::stream::{Console, Position};
use stencil_gcode::num;

/// A key, as far as jogging cares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JogKey {
    /// Arrow left: X−.
    Left,
    /// Arrow right: X+.
    Right,
    /// Arrow up: Y+.
    Up,
    /// Arrow down: Y−.
    Down,
    /// Z+.
    PageUp,
    /// Z−.
    PageDown,
    /// Any other key by its character (see [`JOG_KEY_HELP`]).
    Char(char),
    /// Quit.
    Esc,
    /// Quit.
    CtrlC,
    /// A jog key was let go (terminals that report releases): the running jog is cancelled.
    Released,
    /// Script only: wait until the machine stands still.
    Wait,
}

/// The keys, for help texts.
pub const JOG_KEY_HELP: &str = "arrows = jog X/Y, PgUp/PgDn = jog Z, 1/2/3 = step 0.1/1/10 mm, \
+/- = larger/smaller step, space = cancel jog, h = home ($H), u = unlock ($X), 0 = work zero \
X0 Y0 here, q / Esc / Ctrl-C = quit";

/// The names a script (`--keys`) or a pipe uses, one per key.
pub(crate) const KEY_NAMES: &str =
    "left, right, up, down, pgup, pgdn, 1, 2, 3, +, -, space, h, u, 0, \
release, wait, q, esc, ctrl-c";

/// A key by name (case-insensitive), as in `KEY_NAMES`.
pub fn parse_key(name: &str) -> Result<JogKey, String> {
    let n = name.trim().to_ascii_lowercase();
    Ok(match n.as_str() {
        "left" => JogKey::Left,
        "right" => JogKey::Right,
        "up" => JogKey::Up,
        "down" => JogKey::Down,
        "pgup" | "pageup" => JogKey::PageUp,
        "pgdn" | "pagedown" => JogKey::PageDown,
        "space" => JogKey::Char(' '),
        "esc" | "escape" => JogKey::Esc,
        "ctrl-c" => JogKey::CtrlC,
        "release" => JogKey::Released,
        "wait" => JogKey::Wait,
        s if s.chars().count() == 1 => JogKey::Char(s.chars().next().unwrap_or(' ')),
        _ => return Err(format!("'{name}' is not a key; use one of: {KEY_NAMES}")),
    })
}

/// A script of keys: names separated by commas or spaces.
pub fn parse_keys(script: &str) -> Result<Vec<JogKey>, String> {
    script
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(parse_key)
        .collect()
}

/// Where keys come from.
pub trait JogKeys {
    /// The next key, waiting at most `wait`; `Ok(None)` if none came. An error or the end of a
    /// script ends jogging as `q` does.
    fn next_key(&mut self, wait: Duration) -> io::Result<Option<JogKey>>;
}

/// Keys from a list (a `--keys` script, or a test).
pub struct Script(pub std::collections::VecDeque<JogKey>);

impl JogKeys for Script {
    fn next_key(&mut self, _wait: Duration) -> io::Result<Option<JogKey>> {
        self.0
            .pop_front()
            .map(Some)
            .ok_or_else(|| io::ErrorKind::UnexpectedEof.into())
    }
}

/// What a key does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Action {
    /// Jog one step along axis 0/1/2 (X/Y/Z) in direction `sign`.
    Jog {
        axis: usize,
        sign: f64,
    },
    Cancel,
    Home,
    Unlock,
    Zero,
    SetStep(usize),
    StepUp,
    StepDown,
    Wait,
    Quit,
    Nothing,
}

/// The key map.
pub(crate) fn action(key: JogKey) -> Action {
    let jog = |axis, sign| Action::Jog { axis, sign };
    match key {
        JogKey::Left => jog(0, -1.0),
        JogKey::Right => jog(0, 1.0),
        JogKey::Up => jog(1, 1.0),
        JogKey::Down => jog(1, -1.0),
        JogKey::PageUp => jog(2, 1.0),
        JogKey::PageDown => jog(2, -1.0),
        JogKey::Released | JogKey::Char(' ') => Action::Cancel,
        JogKey::Char('h') | JogKey::Char('H') => Action::Home,
        JogKey::Char('u') | JogKey::Char('U') => Action::Unlock,
        JogKey::Char('0') => Action::Zero,
        JogKey::Char(c @ '1'..='3') => Action::SetStep(c as usize - '1' as usize),
        // `=` is `+` without Shift on most keyboards.
        JogKey::Char('+') | JogKey::Char('=') => Action::StepUp,
        JogKey::Char('-') | JogKey::Char('_') => Action::StepDown,
        JogKey::Wait => Action::Wait,
        JogKey::Char('q') | JogKey::Char('Q') | JogKey::Esc | JogKey::CtrlC => Action::Quit,
        JogKey::Char(_) => Action::Nothing,
    }
}

/// The steps `1`, `2`, `3` choose, mm.
pub(crate) const STEPS_MM: [f64; 3] = [0.1, 1.0, 10.0];

/// How long homing may take before it counts as a silent machine.
pub(crate) const HOMING_LIMIT: Duration = Duration::from_secs(120);

/// How long to wait for a jog to finish before `0`, `h` or leaving.
const STILL_LIMIT: Duration = Duration::from_secs(60);

/// A jog session on an open [`Console`].
pub struct Jogger<'c, 'a> {
    pub(crate) console: &'c mut Console<'a>,
    /// The steps `+`/`-` walk through, ascending (the three of [`STEPS_MM`] plus `--step`).
    steps: Vec<f64>,
    step: usize,
    /// Jog feed, mm/min.
    pub feed_mm_min: f64,
    last: Option<Position>,
}

/// A jog session stopped by a fault: what happened, and what was done about the laser.
#[derive(Debug, thiserror::Error)]
#[error("{cause}; {laser}")]
pub struct JogError {
    /// What stopped the session.
    pub cause: Box<MachineError>,
    /// What was done to make sure the laser is off.
    pub laser: String,
}

impl<'c, 'a> Jogger<'c, 'a> {
    /// `step_mm` starts selected; `feed_mm_min` is the jog feed for every axis.
    pub fn new(console: &'c mut Console<'a>, step_mm: f64, feed_mm_min: f64) -> Self {
        let mut steps = STEPS_MM.to_vec();
        if !steps.iter().any(|s| (s - step_mm).abs() < 1e-9) {
            steps.push(step_mm);
            steps.sort_by(f64::total_cmp);
        }
        let step = steps
            .iter()
            .position(|s| (s - step_mm).abs() < 1e-9)
            .unwrap_or(1);
        Jogger {
            console,
            steps,
            step,
            feed_mm_min,
            last: None,
        }
    }

    pub(crate) fn step_mm(&self) -> f64 {
        self.steps[self.step]
    }

    /// The last status read.
    pub fn last(&self) -> Option<&Position> {
        self.last.as_ref()
    }

    /// Read the machine's status.
    pub(crate) fn refresh(&mut self) -> Result<&Position, MachineError> {
        let p = self.console.position()?;
        Ok(self.last.insert(p))
    }

    /// The status line: state, work position, step and feed.
    pub fn status_line(&self) -> String {
        let (state, w) = match &self.last {
            Some(p) => (p.status.state.to_string(), p.work),
            None => ("?".into(), [0.0; 3]),
        };
        let locked = if state == "Alarm" {
            " | locked: u unlocks, h homes"
        } else {
            ""
        };
        format!(
            "{state:<6} X{:>9.3} Y{:>9.3} Z{:>8.3} (work) | step {} mm | feed {} mm/min{locked}",
            w[0],
            w[1],
            w[2],
            num(self.step_mm()),
            num(self.feed_mm_min)
        )
    }

    fn jogging(&self) -> bool {
        self.last
            .as_ref()
            .is_some_and(|p| p.status.state == MachineState::Jog)
    }

    /// Grbl refused a command: say why in the user's terms; the session goes on.
    fn refused(&mut self, cmd: &str, code: u8) {
        let text = match (cmd, code) {
            ("$H", 5) => "homing is not enabled on this machine ($22=0): Grbl answers $H with \
                          error:5. Press u to unlock instead, or enable homing ($22=1) if the \
                          machine has limit switches"
                .to_string(),
            (c, 8) | (c, 9) if self.console.locked() => format!(
                "Grbl refused `{c}`: the machine is locked in alarm (error:{code}); press u to \
                 unlock ($X) or h to home ($H)"
            ),
            (c, 15) => format!(
                "Grbl refused `{c}`: the jog would leave the machine's travel (error:15, soft \
                 limits)"
            ),
            (c, code) => format!(
                "Grbl refused `{c}`: error:{code} ({})",
                protocol::error_meaning(code)
            ),
        };
        self.console.say(&text);
    }

    /// Send a command; a refusal is said and the session goes on; a link fault ends it.
    fn send(&mut self, cmd: &str) -> Result<bool, MachineError> {
        match self.console.command(cmd) {
            Ok(_) => Ok(true),
            Err(MachineError::Setup { code, .. }) => {
                self.refused(cmd, code);
                Ok(false)
            }
            Err(e) => Err(e),
        }
    }

    /// Do what `key` asks. `Ok(true)`: leave.
    pub fn press(&mut self, key: JogKey) -> Result<bool, MachineError> {
        match action(key) {
            Action::Jog { axis, sign } => {
                // Key repeat must not pile up jogs that run on after the key is let go: at most
                // one waits behind the running one.
                if let Some(p) = &self.last {
                    let queued = p.status.buffer.map(|(free, _)| {
                        self.console
                            .info()
                            .planner_blocks
                            .saturating_sub(free as usize)
                    });
                    if self.jogging() && queued.is_some_and(|q| q >= 2) {
                        return Ok(false);
                    }
                }
                let cmd = format!(
                    "$J=G91G21{}{}F{}",
                    ["X", "Y", "Z"][axis],
                    num(sign * self.step_mm()),
                    num(self.feed_mm_min)
                );
                self.send(&cmd)?;
            }
            Action::Cancel => {
                if self.jogging() {
                    self.console.realtime(RT_JOG_CANCEL)?;
                }
            }
            Action::Home => {
                self.still()?;
                self.console.say("homing ($H)...");
                match self.console.home(HOMING_LIMIT) {
                    Ok(()) => self.console.say("homed"),
                    Err(MachineError::Setup { code, .. }) => self.refused("$H", code),
                    Err(e) => return Err(e),
                }
            }
            Action::Unlock => {
                if self.send("$X")? {
                    self.console.say(
                        "unlocked ($X): the position may be wrong after an alarm; home if unsure",
                    );
                }
            }
            Action::Zero => {
                self.still()?;
                if self.send("G10L20P1X0Y0")? {
                    self.console.say("work zero set here (G10 L20 P1 X0 Y0)");
                }
            }
            Action::SetStep(i) => {
                if let Some(k) = self
                    .steps
                    .iter()
                    .position(|s| (s - STEPS_MM[i]).abs() < 1e-9)
                {
                    self.step = k;
                }
            }
            Action::StepUp => self.step = (self.step + 1).min(self.steps.len() - 1),
            Action::StepDown => self.step = self.step.saturating_sub(1),
            Action::Wait => self.still()?,
            Action::Quit => return Ok(true),
            Action::Nothing => {}
        }
        Ok(false)
    }

    /// Wait until the machine stands still (a jog done).
    fn still(&mut self) -> Result<(), MachineError> {
        let p = self.console.wait_still(STILL_LIMIT)?;
        self.last = Some(p);
        Ok(())
    }

    /// Leave: cancel a running jog, wait until the machine stands still, then `M5` and `M9`
    /// (laser and air off) unless it is locked in alarm (where they are off already). Says what
    /// was done.
    pub fn finish(&mut self) -> Result<String, MachineError> {
        self.refresh()?;
        if self.jogging() {
            self.console.realtime(RT_JOG_CANCEL)?;
        }
        self.still()?;
        if self.console.locked() {
            return Ok("machine locked in alarm: laser and air are off".into());
        }
        // Air first, so the laser's M5 is the last word.
        let air = self.send("M9")?;
        let laser = self.send("M5")?;
        Ok(match (air, laser) {
            (true, true) => "laser off (M5), air off (M9)".into(),
            _ => "M5/M9 were refused: make sure the laser and the air are off".into(),
        })
    }
}

/// Run a jog session until a quit key, the end of the keys, or a fault. `show` gets the status
/// line after every key and about five times a second meanwhile. A fault other than a lost port
/// stops the machine (soft reset, laser off).
pub fn jog_session(
    j: &mut Jogger<'_, '_>,
    keys: &mut dyn JogKeys,
    show: &mut dyn FnMut(&str),
) -> Result<String, JogError> {
    let result = (|| -> Result<String, MachineError> {
        j.refresh()?;
        show(&j.status_line());
        loop {
            match keys.next_key(Duration::from_millis(200)) {
                Ok(Some(k)) if j.press(k)? => break,
                Ok(_) => {}
                Err(_) => break,
            }
            j.refresh()?;
            show(&j.status_line());
        }
        let done = j.finish()?;
        show(&j.status_line());
        Ok(done)
    })();
    result.map_err(|cause| {
        let laser = match &cause {
            MachineError::Io { .. } | MachineError::PortLost { .. } => {
                "the port is gone: make sure the laser and the air are off".to_string()
            }
            _ => j.console.stop(),
        };
        JogError {
            cause: Box::new(cause),
            laser,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_names_and_map() {
        assert_eq!(
            parse_keys("right, right up,PgDn 0 q").unwrap(),
            [
                JogKey::Right,
                JogKey::Right,
                JogKey::Up,
                JogKey::PageDown,
                JogKey::Char('0'),
                JogKey::Char('q')
            ]
        );
        let e = parse_keys("right,jump").unwrap_err();
        assert!(e.contains("'jump'") && e.contains("pgup"), "{e}");
        assert_eq!(
            action(JogKey::Left),
            Action::Jog {
                axis: 0,
                sign: -1.0
            }
        );
        assert_eq!(action(JogKey::PageUp), Action::Jog { axis: 2, sign: 1.0 });
        assert_eq!(action(JogKey::Char('3')), Action::SetStep(2));
        assert_eq!(action(JogKey::Esc), Action::Quit);
        assert_eq!(action(JogKey::Released), Action::Cancel);
    }
}
