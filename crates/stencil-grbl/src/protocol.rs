//! The Grbl 1.1 serial protocol: what the controller says, what its numbers mean, and the real-time
//! bytes a host may send at any moment. Shared by the streamer and the virtual Grbl so both speak
//! exactly the same dialect.

use std::fmt;

/// Real-time command: ask for a status report (never enters the receive buffer).
pub(crate) const RT_STATUS: u8 = b'?';
/// Real-time command: feed hold (decelerate to a stop, keep the job).
pub(crate) const RT_FEED_HOLD: u8 = b'!';
/// Real-time command: cycle start / resume after a feed hold.
pub(crate) const RT_RESUME: u8 = b'~';
/// Real-time command: soft reset (stops motion and the spindle/laser at once, flushes all buffers).
pub(crate) const RT_SOFT_RESET: u8 = 0x18;
/// Real-time command: cancel the running jog (decelerate to a stop and drop the queued jog
/// motions); ignored unless the machine is in the `Jog` state.
pub(crate) const RT_JOG_CANCEL: u8 = 0x85;

/// Real-time command: feed override back to 100 %.
pub(crate) const RT_FEED_OV_RESET: u8 = 0x90;
/// Real-time command: feed override +10 % (at most 200 %).
pub(crate) const RT_FEED_OV_PLUS_10: u8 = 0x91;
/// Real-time command: feed override −10 % (at least 10 %).
pub(crate) const RT_FEED_OV_MINUS_10: u8 = 0x92;
/// Real-time command: spindle (laser power) override back to 100 %.
pub(crate) const RT_SPINDLE_OV_RESET: u8 = 0x99;
/// Real-time command: spindle (laser power) override +10 % (at most 200 %).
pub(crate) const RT_SPINDLE_OV_PLUS_10: u8 = 0x9A;
/// Real-time command: spindle (laser power) override −10 % (at least 10 %).
pub(crate) const RT_SPINDLE_OV_MINUS_10: u8 = 0x9B;

/// True for bytes Grbl acts on immediately instead of buffering them: `?`, `!`, `~`, 0x18 and the
/// extended set (0x80 and up: safety door, jog cancel, overrides).
pub(crate) fn is_realtime(b: u8) -> bool {
    matches!(b, RT_STATUS | RT_FEED_HOLD | RT_RESUME | RT_SOFT_RESET) || b >= 0x80
}

/// Machine state from a status report.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum MachineState {
    /// Standing, ready for a job.
    #[default]
    Idle,
    /// Running moves.
    Run,
    /// Feed hold; 0 = complete (stopped), 1 = still decelerating.
    Hold(u8),
    /// Jogging.
    Jog,
    /// Locked in alarm: home (`$H`) or unlock (`$X`).
    Alarm,
    /// Safety door, with Grbl's sub-state.
    Door(u8),
    /// Check mode (`$C`): lines are parsed, nothing moves.
    Check,
    /// Homing.
    Home,
    /// Asleep (`$SLP`): only a soft reset wakes it.
    Sleep,
    /// A state word this program does not know (newer firmware): kept verbatim.
    Other(String),
}

impl MachineState {
    pub(crate) fn parse(s: &str) -> MachineState {
        let (word, sub) = match s.split_once(':') {
            Some((w, n)) => (w, n.parse::<u8>().ok()),
            None => (s, None),
        };
        match word {
            "Idle" => MachineState::Idle,
            "Run" => MachineState::Run,
            "Hold" => MachineState::Hold(sub.unwrap_or(0)),
            "Jog" => MachineState::Jog,
            "Alarm" => MachineState::Alarm,
            "Door" => MachineState::Door(sub.unwrap_or(0)),
            "Check" => MachineState::Check,
            "Home" => MachineState::Home,
            "Sleep" => MachineState::Sleep,
            _ => MachineState::Other(s.to_string()),
        }
    }
}

impl fmt::Display for MachineState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MachineState::Idle => f.write_str("Idle"),
            MachineState::Run => f.write_str("Run"),
            MachineState::Hold(n) => write!(f, "Hold:{n}"),
            MachineState::Jog => f.write_str("Jog"),
            MachineState::Alarm => f.write_str("Alarm"),
            MachineState::Door(n) => write!(f, "Door:{n}"),
            MachineState::Check => f.write_str("Check"),
            MachineState::Home => f.write_str("Home"),
            MachineState::Sleep => f.write_str("Sleep"),
            MachineState::Other(s) => f.write_str(s),
        }
    }
}

/// A parsed `<State|MPos:...|FS:...|...>` report. Fields Grbl leaves out (they depend on `$10` and
/// on how often it refreshes them) are `None`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Status {
    /// The state.
    pub state: MachineState,
    /// Machine position, mm (or work position plus the last `WCO` when Grbl reports `WPos`).
    pub mpos: Option<[f64; 3]>,
    /// Work position, mm, when Grbl reports it (`WPos`).
    pub wpos: Option<[f64; 3]>,
    /// Work coordinate offset (sent every few reports).
    pub wco: Option<[f64; 3]>,
    /// Current feed, mm/min.
    pub feed: Option<f64>,
    /// Current spindle speed (laser power).
    pub speed: Option<f64>,
    /// Free planner blocks and free receive-buffer bytes (`Bf:`).
    pub buffer: Option<(u32, u32)>,
    /// Line number being executed (`Ln:`, only with N words).
    pub line: Option<u32>,
    /// Feed, rapid and spindle overrides in percent (`Ov:`).
    pub overrides: Option<[u32; 3]>,
}

impl Status {
    /// The best position we know: machine position, or work position plus offset.
    pub fn position(&self) -> Option<[f64; 3]> {
        self.mpos.or(self.wpos)
    }
}

/// `N` comma-separated numbers (more are ignored); `None` if fewer, or one does not read.
pub(crate) fn parse_list<T: std::str::FromStr + Copy + Default, const N: usize>(
    s: &str,
) -> Option<[T; N]> {
    let mut out = [T::default(); N];
    let mut it = s.split(',');
    for v in out.iter_mut() {
        *v = it.next()?.trim().parse().ok()?;
    }
    Some(out)
}

fn parse_status(body: &str) -> Option<Status> {
    let mut fields = body.split('|');
    let state = MachineState::parse(fields.next()?);
    let mut st = Status {
        state,
        ..Status::default()
    };
    for f in fields {
        let Some((key, val)) = f.split_once(':') else {
            continue;
        };
        match key {
            // Grbl may report 3 or more axes; we keep X, Y, Z.
            "MPos" => st.mpos = parse_list(val),
            "WPos" => st.wpos = parse_list(val),
            "WCO" => st.wco = parse_list(val),
            "FS" => {
                if let Some([f, s]) = parse_list(val) {
                    st.feed = Some(f);
                    st.speed = Some(s);
                }
            }
            "F" => st.feed = val.parse().ok(),
            "Bf" => st.buffer = parse_list(val).map(|[b, r]| (b, r)),
            "Ln" => st.line = val.parse().ok(),
            "Ov" => st.overrides = parse_list(val),
            _ => {}
        }
    }
    Some(st)
}

/// One line Grbl sent.
#[derive(Clone, Debug, PartialEq)]
pub enum Reply {
    /// The oldest unanswered line was accepted (queued, not yet executed).
    Ok,
    /// The oldest unanswered line was rejected with this code.
    Error(u8),
    /// Pushed at any time: the machine stopped for this reason.
    Alarm(u8),
    /// The boot/reset banner, e.g. `Grbl 1.1h ['$' for help]`: the version text.
    Welcome(String),
    /// `[MSG:...]`: the text inside.
    Message(String),
    /// Other bracketed feedback (`[VER:..]`, `[OPT:..]`, `[GC:..]`, `[PRB:..]`...): the text inside.
    Feedback(String),
    Status(Status),
    /// `$N=...` setting dumps, `>...:ok` startup lines, anything else: verbatim.
    Other(String),
}

impl Reply {
    /// Parse one line (without its line ending).
    pub fn parse(line: &str) -> Reply {
        let l = line.trim();
        if l == "ok" {
            return Reply::Ok;
        }
        if let Some(n) = l.strip_prefix("error:") {
            if let Ok(n) = n.trim().parse() {
                return Reply::Error(n);
            }
        }
        if let Some(n) = l.strip_prefix("ALARM:") {
            if let Ok(n) = n.trim().parse() {
                return Reply::Alarm(n);
            }
        }
        if let Some(rest) = l.strip_prefix("Grbl ") {
            let version = rest.split_whitespace().next().unwrap_or("").to_string();
            return Reply::Welcome(version);
        }
        if let Some(body) = l.strip_prefix('<').and_then(|b| b.strip_suffix('>')) {
            if let Some(st) = parse_status(body) {
                return Reply::Status(st);
            }
        }
        if let Some(body) = l.strip_prefix('[').and_then(|b| b.strip_suffix(']')) {
            if let Some(msg) = body.strip_prefix("MSG:") {
                return Reply::Message(msg.to_string());
            }
            return Reply::Feedback(body.to_string());
        }
        Reply::Other(l.to_string())
    }
}

/// `[OPT:V,15,128]` → (planner blocks, receive buffer bytes). Grbl 1.1 only; 0.9 has no OPT line.
pub(crate) fn parse_opt(feedback: &str) -> Option<(usize, usize)> {
    let body = feedback.strip_prefix("OPT:")?;
    let mut it = body.split(',');
    let _codes = it.next()?;
    let blocks = it.next()?.trim().parse().ok()?;
    let rx = it.next()?.trim().parse().ok()?;
    Some((blocks, rx))
}

/// The unlock hint Grbl prints after boot or reset while the machine is locked in alarm.
pub(crate) fn is_unlock_hint(msg: &str) -> bool {
    msg.contains("'$H'|'$X' to unlock")
}

/// What an `error:N` means (Grbl 1.1, codes 1..38), in our words.
pub(crate) fn error_meaning(code: u8) -> &'static str {
    match code {
        1 => "a word without its letter: G-code words are a letter followed by a number",
        2 => "a number is missing or malformed",
        3 => "not a Grbl '$' command",
        4 => "a value that must be positive is negative",
        5 => "homing is not enabled in the settings ($22)",
        6 => "the step pulse time must be at least 3 microseconds",
        7 => "the settings memory (EEPROM) could not be read; defaults were restored",
        8 => "this '$' command only runs while the machine is idle",
        9 => "G-code is locked out during an alarm or a jog; unlock ($X) or home ($H) first",
        10 => "soft limits need homing enabled",
        11 => {
            "the line is longer than Grbl's line buffer (79 characters without spaces and comments)"
        }
        12 => "the setting would make the step rate exceed what the board can drive",
        13 => "the safety door is open",
        14 => "the build info or startup line is too long for the settings memory",
        15 => "the jog target is outside the machine's travel",
        16 => "a jog command without '=' or with a G-code jogging does not allow",
        17 => "laser mode needs the spindle PWM output",
        20 => "an unsupported or invalid G-code command",
        21 => "two commands from the same modal group on one line",
        22 => "a feed move (G1/G2/G3) before any feed rate F was set",
        23 => "this command needs an integer value",
        24 => "two commands on one line both want the axis words",
        25 => "the same word appears twice on one line",
        26 => "a command that needs axis words has none",
        27 => "the line number N is out of range",
        28 => "a required value word is missing",
        29 => "G59.x work coordinate systems are not supported",
        30 => "G53 only works with G0 or G1",
        31 => "axis words on a line where no command uses them",
        32 => "an arc (G2/G3) needs at least one axis word in the selected plane",
        33 => "the motion target is invalid (e.g. an arc that cannot be drawn)",
        34 => "the arc radius is invalid",
        35 => "an arc (G2/G3) needs at least one offset word in the selected plane",
        36 => "value words no command on the line uses",
        37 => "the tool length offset (G43.1) is not on the configured axis",
        38 => "the tool number is larger than supported",
        _ => "an error code this program does not know (newer firmware?)",
    }
}

/// What an `ALARM:N` means (Grbl 1.1, codes 1..9), in our words.
pub(crate) fn alarm_meaning(code: u8) -> &'static str {
    match code {
        1 => "hard limit: a limit switch was hit; position is lost, home the machine again",
        2 => "soft limit: a move would leave the machine's travel; position is kept",
        3 => "reset while moving: position may be lost, home or re-zero the machine",
        4 => "probe fail: the probe was not in its expected state before probing",
        5 => "probe fail: the probe did not make contact within the travel",
        6 => "homing fail: homing was reset",
        7 => "homing fail: the safety door opened during homing",
        8 => "homing fail: the pull-off move did not clear the limit switch",
        9 => "homing fail: no limit switch was found within the search distance",
        _ => "an alarm code this program does not know (newer firmware?)",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_replies() {
        assert_eq!(Reply::parse("ok"), Reply::Ok);
        assert_eq!(Reply::parse("error:22"), Reply::Error(22));
        assert_eq!(Reply::parse("ALARM:3"), Reply::Alarm(3));
        assert_eq!(
            Reply::parse("Grbl 1.1h ['$' for help]"),
            Reply::Welcome("1.1h".into())
        );
        assert_eq!(
            Reply::parse("[MSG:'$H'|'$X' to unlock]"),
            Reply::Message("'$H'|'$X' to unlock".into())
        );
        assert!(is_unlock_hint("'$H'|'$X' to unlock"));
        assert_eq!(
            Reply::parse("[OPT:V,15,128]"),
            Reply::Feedback("OPT:V,15,128".into())
        );
        assert_eq!(parse_opt("OPT:V,15,128"), Some((15, 128)));
        assert_eq!(parse_opt("OPT:VL,16,64"), Some((16, 64)));
        assert_eq!(
            Reply::parse("$110=500.000"),
            Reply::Other("$110=500.000".into())
        );
    }

    #[test]
    fn parses_status_reports() {
        let Reply::Status(s) = Reply::parse(
            "<Hold:1|MPos:1.500,-2.250,0.000|Bf:12,100|FS:600,250|Ln:42|WCO:0.000,0.000,0.000|Ov:100,50,120>",
        ) else {
            panic!("not a status");
        };
        assert_eq!(s.state, MachineState::Hold(1));
        assert_eq!(s.mpos, Some([1.5, -2.25, 0.0]));
        assert_eq!(s.buffer, Some((12, 100)));
        assert_eq!(s.feed, Some(600.0));
        assert_eq!(s.speed, Some(250.0));
        assert_eq!(s.line, Some(42));
        assert_eq!(s.wco, Some([0.0; 3]));
        assert_eq!(s.overrides, Some([100, 50, 120]));
        let Reply::Status(s) = Reply::parse("<Idle|WPos:3.000,4.000,5.000|F:0>") else {
            panic!("not a status");
        };
        assert_eq!(s.state, MachineState::Idle);
        assert_eq!(s.position(), Some([3.0, 4.0, 5.0]));
        assert_eq!(s.state.to_string(), "Idle");
    }

    #[test]
    fn every_documented_code_has_its_own_meaning() {
        let unknown = error_meaning(200);
        let errs: Vec<_> = (1..=38u8).filter(|c| !(18..=19).contains(c)).collect();
        for &c in &errs {
            assert_ne!(error_meaning(c), unknown, "error {c}");
        }
        let mut seen: Vec<_> = errs.iter().map(|&c| error_meaning(c)).collect();
        seen.sort();
        seen.dedup();
        assert_eq!(seen.len(), errs.len());
        for c in 1..=9 {
            assert_ne!(alarm_meaning(c), alarm_meaning(0), "alarm {c}");
        }
        assert!(error_meaning(22).contains("feed"));
    }

    #[test]
    fn realtime_bytes() {
        for b in [b'?', b'!', b'~', 0x18, 0x85, 0x9e] {
            assert!(is_realtime(b));
        }
        for b in b"G1X0.5F600$\n" {
            assert!(!is_realtime(*b));
        }
    }
}
