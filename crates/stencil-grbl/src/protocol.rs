//! The Grbl 1.1 serial protocol: what the controller says, what its numbers mean, and the real-time
//! bytes a host may send at any moment. Shared by the streamer and the virtual Grbl so both speak
//! exactly the same dialect.

use std::fmt;

pub(crate) use crate::codes::{alarm_meaning, error_meaning};

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
    /// Input pins active (`Pn:`, e.g. `XP` for the X limit and the probe).
    pub pins: Option<String>,
    /// grblHAL's `H:1` (homed) or `H:0`; the mask after a comma is not kept.
    pub homed: Option<bool>,
    /// grblHAL's `FW:` (the firmware's name, in the first report after connecting).
    pub firmware: Option<String>,
    /// grblHAL's `MPG:1`: a pendant has taken the controller, the host may only watch.
    pub mpg: Option<bool>,
    /// A job running from the controller's own card: percent done and the file (`SD:`).
    pub card: Option<(f64, String)>,
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
            "Pn" => st.pins = Some(val.to_string()),
            "H" => st.homed = val.split(',').next().map(|h| h == "1"),
            "FW" => st.firmware = Some(val.to_string()),
            "MPG" => st.mpg = Some(val == "1"),
            "SD" => {
                st.card = val.split_once(',').and_then(|(pct, file)| {
                    Some((pct.trim().parse().ok()?, file.trim().to_string()))
                })
            }
            // Whatever else a firmware adds (grblHAL's `Sc`, `T`, `AR`; FluidNC's `ISRs`,
            // `Heap`) describes nothing the sender acts on: ignored, never an error.
            _ => {}
        }
    }
    Some(st)
}

/// One line Grbl sent.
// A status report is the big variant and the common one: replies are read one at a time and
// never stored in bulk, so boxing it would only add an allocation per report.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Reply {
    /// The oldest unanswered line was accepted (queued, not yet executed).
    Ok,
    /// The oldest unanswered line was rejected with this code.
    Error(u8),
    /// Pushed at any time: the machine stopped for this reason.
    Alarm(u8),
    /// The boot/reset banner, e.g. `Grbl 1.1h ['$' for help]`, `GrblHAL 1.1f ['$' or '$HELP'
    /// for help]`, `Grbl 3.7 [FluidNC v3.7.8 (wifi) '$' for help]`: which firmware, and its
    /// version text.
    Welcome(Firmware, String),
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
        if let Some(rest) = l.strip_prefix("GrblHAL ") {
            let version = rest.split_whitespace().next().unwrap_or("").to_string();
            return Reply::Welcome(Firmware::GrblHal, version);
        }
        if let Some(rest) = l.strip_prefix("Grbl ") {
            // FluidNC's banner names itself and its own version in the brackets.
            if let Some(v) = rest.split_once("[FluidNC ").map(|(_, v)| v) {
                let version = v.split_whitespace().next().unwrap_or("");
                return Reply::Welcome(Firmware::FluidNc, version.trim_start_matches('v').into());
            }
            let version = rest.split_whitespace().next().unwrap_or("").to_string();
            return Reply::Welcome(Firmware::Grbl, version);
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

/// The firmware a controller runs: the three speak Grbl 1.1's protocol, each with its own
/// additions (status fields, codes, buffer sizes, how settings are kept).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Firmware {
    /// Grbl 1.1 (an AVR board: 128-byte receive buffer, 15 planner blocks).
    #[default]
    Grbl,
    /// grblHAL (32-bit boards: larger buffers, `$I` with `NEWOPT` and `FIRMWARE` lines).
    GrblHal,
    /// FluidNC (ESP32 boards; settings in a YAML configuration file; often over WiFi).
    FluidNc,
}

impl fmt::Display for Firmware {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Firmware::Grbl => "Grbl",
            Firmware::GrblHal => "grblHAL",
            Firmware::FluidNc => "FluidNC",
        })
    }
}

/// What `$I` (or grblHAL's `$I+`) said: the firmware, its version and the sizes it reports.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct BuildInfo {
    /// Which firmware, if the answer said (`[FIRMWARE:grblHAL]`, `NEWOPT`, `FluidNC` in `VER`).
    pub(crate) firmware: Option<Firmware>,
    /// The version (`1.1h`, grblHAL's `1.1f`, FluidNC's own `3.7.8`) and the build date.
    pub(crate) version: Option<String>,
    pub(crate) build: Option<u32>,
    /// Planner blocks and receive buffer bytes (`OPT`; FluidNC does not say).
    pub(crate) sizes: Option<(usize, usize)>,
    /// grblHAL's `NEWOPT` line was seen (an extended answer).
    pub(crate) newopt: bool,
}

/// Read a `$I` answer's bracketed lines.
pub(crate) fn build_info<'a>(feedback: impl IntoIterator<Item = &'a str>) -> BuildInfo {
    let mut b = BuildInfo::default();
    for f in feedback {
        if let Some(ver) = f.strip_prefix("VER:") {
            let head = ver.split(':').next().unwrap_or("").trim();
            if let Some(v) = head.split_once("FluidNC ").map(|(_, v)| v) {
                b.firmware = Some(Firmware::FluidNc);
                let v = v.split_whitespace().next().unwrap_or("");
                b.version = Some(v.trim_start_matches('v').to_string());
            } else {
                // `1.1h.20190830`: the version, a dot, the build date.
                let (v, build) = head.rsplit_once('.').unwrap_or((head, ""));
                b.version = Some(v.to_string());
                b.build = build.parse().ok();
            }
        } else if f.starts_with("OPT:") {
            b.sizes = b.sizes.or(parse_opt(f));
        } else if f.starts_with("NEWOPT:") {
            b.newopt = true;
            b.firmware = Some(Firmware::GrblHal);
        } else if f == "FIRMWARE:grblHAL" {
            b.firmware = Some(Firmware::GrblHal);
        }
    }
    b
}

/// Grbl 1.1h's build date: a `VER` line of a later build comes from grblHAL (whose `$I`
/// may leave its `NEWOPT` and `FIRMWARE` lines to `$I+`) or another fork.
pub(crate) const GRBL_LAST_BUILD: u32 = 20190830;

/// A FluidNC configuration (`$Config/Dump`, YAML, one section level deep): its `Laser:` spindle's `speed_map` as
/// (the S of full power, the highest S still at 0 %); `None` when it has no laser spindle.
pub(crate) fn laser_speed_map<'a>(config: impl IntoIterator<Item = &'a str>) -> Option<(f64, f64)> {
    // The lines come trimmed (as replies are read): a section is a key with no value.
    let mut in_laser = false;
    for line in config {
        let t = line.trim();
        if t.ends_with(':') {
            in_laser = t.eq_ignore_ascii_case("laser:");
            continue;
        }
        let Some(map) = t.strip_prefix("speed_map:").filter(|_| in_laser) else {
            continue;
        };
        let points: Vec<(f64, f64)> = map
            .split_whitespace()
            .filter_map(|p| {
                let (s, pct) = p.split_once('=')?;
                Some((s.parse().ok()?, pct.trim_end_matches('%').parse().ok()?))
            })
            .collect();
        let max = points.iter().map(|p| p.0).reduce(f64::max)?;
        let min = points
            .iter()
            .filter(|p| p.1 <= 0.0)
            .map(|p| p.0)
            .fold(0.0, f64::max);
        return Some((max, min));
    }
    None
}

/// The unlock hint Grbl prints after boot or reset while the machine is locked in alarm.
pub(crate) fn is_unlock_hint(msg: &str) -> bool {
    msg.contains("'$H'|'$X' to unlock")
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
            Reply::Welcome(Firmware::Grbl, "1.1h".into())
        );
        assert_eq!(
            Reply::parse("GrblHAL 1.1f ['$' or '$HELP' for help]"),
            Reply::Welcome(Firmware::GrblHal, "1.1f".into())
        );
        assert_eq!(
            Reply::parse("Grbl 3.7 [FluidNC v3.7.8 (esp32-wifi) '$' for help]"),
            Reply::Welcome(Firmware::FluidNc, "3.7.8".into())
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
    fn reads_each_firmwares_build_info_and_extended_status() {
        let hal = build_info([
            "VER:1.1f.20250731:",
            "OPT:VNMSL,35,1024,3,0",
            "AXS:3:XYZ",
            "NEWOPT:ENUMS,RT+,HOME,SED",
            "FIRMWARE:grblHAL",
        ]);
        assert_eq!(hal.firmware, Some(Firmware::GrblHal));
        assert_eq!(hal.version.as_deref(), Some("1.1f"));
        assert_eq!(hal.build, Some(20250731));
        assert_eq!(hal.sizes, Some((35, 1024)));
        let fluid = build_info(["VER:3.7 FluidNC v3.7.8 (esp32-wifi) :", "OPT:MPHS"]);
        assert_eq!(fluid.firmware, Some(Firmware::FluidNc));
        assert_eq!(fluid.version.as_deref(), Some("3.7.8"));
        assert_eq!(fluid.sizes, None);
        let grbl = build_info(["VER:1.1h.20190830:", "OPT:V,15,128"]);
        assert_eq!((grbl.firmware, grbl.build), (None, Some(GRBL_LAST_BUILD)));
        let Reply::Status(s) = Reply::parse(
            "<Run|MPos:1.000,2.000,0.000|Bf:34,1023|FS:600,300|Pn:XP|WCO:0.000,0.000,0.000|\
             A:S|Sc:|MPG:0|H:1,7|SD:45.25,/sd/job.nc|T:0|FW:grblHAL|Heap:1000|new:x|odd>",
        ) else {
            panic!("not a status");
        };
        assert_eq!(s.state, MachineState::Run);
        assert_eq!(s.buffer, Some((34, 1023)));
        assert_eq!(s.pins.as_deref(), Some("XP"));
        assert_eq!((s.homed, s.mpg), (Some(true), Some(false)));
        assert_eq!(s.firmware.as_deref(), Some("grblHAL"));
        assert_eq!(s.card, Some((45.25, "/sd/job.nc".to_string())));
        // A state word a firmware adds is kept, not an error.
        let Reply::Status(s) = Reply::parse("<Tool|MPos:0,0,0|Bf:35,1023>") else {
            panic!("not a status");
        };
        assert_eq!(s.state, MachineState::Other("Tool".into()));
    }

    #[test]
    fn reads_a_fluidnc_laser_speed_map() {
        let yaml = [
            "name: virtual",
            "spindle:",
            "Laser:",
            "  pwm_hz: 5000",
            "  speed_map: 0=0.000% 10=0.000% 1000=100.000%",
            "  off_on_alarm: true",
            "coolant:",
            "  speed_map: 0=0% 9=100%",
        ];
        assert_eq!(laser_speed_map(yaml), Some((1000.0, 10.0)));
        assert_eq!(
            laser_speed_map(["PWM:", "  speed_map: 0=0% 255=100%"]),
            None
        );
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
        // Beyond Grbl's codes, each firmware's meaning, named.
        assert!(error_meaning(46).starts_with("grblHAL: the machine must be homed"));
        assert!(
            error_meaning(162).starts_with("FluidNC:") && error_meaning(162).contains("read-only")
        );
        assert!(alarm_meaning(11).contains("grblHAL: homing is required"));
        assert!(alarm_meaning(11).contains("FluidNC:"));
        assert_eq!(alarm_meaning(40), alarm_meaning(0));
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
