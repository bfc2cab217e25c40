//! Everything that stops a stream, with the file, line or port it concerns and what to do at the
//! machine; the ones that stop a running job carry a [`Halt`]: how the laser was switched off and
//! where to resume. The messages name no command-line options: the binary adds those (which
//! option resumes, unlocks or sets laser mode) from the fields.

use super::protocol;
use stencil_gcode::interpret as gcode;
use stencil_gcode::limits::MAX_LINE_BYTES;

/// How a stream that stopped early left the machine, and where to pick it up.
#[derive(Clone, Debug, PartialEq)]
pub struct Halt {
    /// File line of the last line Grbl acknowledged (queued).
    pub last_acked: Option<usize>,
    /// First file line that may not have run: resume here.
    pub resume_from: usize,
    /// What was done to make sure the laser is off.
    pub laser: String,
    /// Grbl is locked in alarm after the stop: unlock (`$X`) or home before resuming.
    pub locked: bool,
    /// Why the machine may have moved on while (or after) it was stopped, so that its position
    /// can no longer be trusted; `None` when it was seen standing before the reset.
    pub position_unsure: Option<Box<str>>,
}

impl std::fmt::Display for Halt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.last_acked {
            Some(l) => write!(f, "last acknowledged line {l}; ")?,
            None => write!(f, "no line was acknowledged; ")?,
        }
        write!(f, "{}; resume from line {}", self.laser, self.resume_from)?;
        if let Some(why) = &self.position_unsure {
            write!(
                f,
                "\nthe position may be lost: {why}. Before resuming, home the machine ($H), or \
                 bring the head back onto the work and set its zero again"
            )?;
        }
        Ok(())
    }
}

/// Lines whose answers never came although Grbl has read and handled them (see
/// [`MachineError::RepliesLost`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Unanswered {
    /// File line of the first unanswered line.
    pub first: usize,
    /// File line of the last.
    pub last: usize,
    /// How many.
    pub count: usize,
    /// Every line of the job had been sent.
    pub all_sent: bool,
    /// The first line not sent, if any.
    pub next_unsent: Option<usize>,
}

impl std::fmt::Display for Unanswered {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} line(s) sent ({}..={}) were never answered: their `ok` was lost or garbled on \
             the way, so Grbl has run or refused them and said so unheard; ",
            self.count, self.first, self.last
        )?;
        match (self.all_sent, self.next_unsent) {
            (true, _) => write!(
                f,
                "every line of the job was sent, so the job has most likely run to its end: look \
                 at the work before resuming"
            ),
            (false, Some(n)) => write!(f, "nothing from line {n} on was sent"),
            (false, None) => write!(f, "nothing after them was sent"),
        }
    }
}

/// One line `$C` check mode rejected.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckRejection {
    /// 1-based line in the file.
    pub line: usize,
    /// The line as sent.
    pub text: String,
    /// Grbl's error code.
    pub code: u8,
}

/// A line of a job that changes the machine itself: a Grbl setting, homing, unlocking, check
/// mode, a jog, sleep, or a stored offset or position.
#[derive(Clone, Debug, PartialEq)]
pub struct MachineChange {
    /// 1-based line in the file.
    pub line: usize,
    /// The line as Grbl would see it.
    pub text: String,
    /// What it does, e.g. "writes Grbl setting $32".
    pub what: String,
}

/// The first ten items, `; `-separated, and how many more there are.
fn list_ten<T>(items: &[T], each: impl Fn(&T) -> String) -> String {
    let mut s: Vec<String> = items.iter().take(10).map(each).collect();
    if items.len() > 10 {
        s.push(format!("and {} more", items.len() - 10));
    }
    s.join("; ")
}

/// Why a stream, a connection or a program was refused or stopped.
#[allow(missing_docs)] // Each variant's message says when it happens and what its fields are.
#[derive(Debug, thiserror::Error)]
pub enum MachineError {
    #[error("{file}: line {line} is {len} bytes without spaces and comments; Grbl takes at most {max}: split it", max = MAX_LINE_BYTES)]
    LineTooLong {
        file: String,
        line: usize,
        len: usize,
    },
    #[error("{file}: line {line} holds {ch:?}, which Grbl cannot take in a line (non-ASCII or a real-time command character): remove it")]
    BadChar { file: String, line: usize, ch: char },
    #[error("{file}: line {line} is {len} bytes with its newline, more than the controller's {rx}-byte receive buffer holds: split it")]
    LineExceedsBuffer {
        file: String,
        line: usize,
        len: usize,
        rx: usize,
    },
    #[error("{file}: line {line} to resume from is outside the file (1..={total})")]
    FromLine {
        file: String,
        line: usize,
        total: usize,
    },
    #[error("{file}: cannot work out the machine state to resume from line {from_line}: {cause}")]
    ResumeState {
        file: String,
        from_line: usize,
        cause: gcode::GcodeError,
    },
    #[error("{file}: {cause}")]
    Gcode {
        file: String,
        cause: gcode::GcodeError,
    },
    #[error("{port}: {detail}")]
    Io { port: String, detail: String },
    #[error("{port}: no Grbl banner within {secs:.1} s, even after a soft reset: check the port and the baud rate (Grbl 1.1 uses 115200)")]
    NoWelcome { port: String, secs: f64 },
    #[error("{port}: the machine is locked in alarm{}; check it, then home it ($H) or unlock it ($X)", alarm.map(|a| format!(" (ALARM:{a}: {})", protocol::alarm_meaning(a))).unwrap_or_default())]
    Locked { port: String, alarm: Option<u8> },
    #[error("{port}: homing ($H) failed: {detail}; nothing was sent. Check the limit switches and Grbl's homing settings ($22..$27), and home the machine by hand before resuming")]
    Homing { port: String, detail: String },
    #[error("{port}: {}; nothing was sent, and it was not reset: a soft reset while it moves loses its position (ALARM:3). {}", match waited_s { Some(s) => format!("the machine was still running moves it was given before this connection ({state}) after {s:.0} s of waiting"), None => format!("the machine holds moves it was given before this connection ({state}): it waits for a cycle start or a stop, and will not finish by itself") }, if waited_s.is_some() { "Let it finish, then connect again; or stop it safely (feed hold, wait until it stands, soft reset)" } else { "Resume it at the machine (cycle start) and let it finish; or stop it safely (feed hold, wait until it stands, soft reset)" })]
    Running {
        port: String,
        state: String,
        waited_s: Option<f64>,
    },
    #[error("{port}: the machine is busy ({state}); wait until it is Idle")]
    Busy { port: String, state: String },
    #[error("{port}: Grbl refused `{cmd}` during setup: error:{code} ({})", protocol::error_meaning(*code))]
    Setup { port: String, cmd: String, code: u8 },
    #[error("{port}: Grbl is not in laser mode ($32={value}) and this is a laser job: without it Grbl stops at every power change and keeps the beam on through G0 moves that should be dark; nothing was sent. Set $32=1 (Grbl keeps it in its settings), or, if this machine is not a laser, use its own machine profile")]
    LaserModeOff { port: String, value: String },
    /// FluidNC reports laser mode off: its `$32` only mirrors the configuration file, where the
    /// spindle is not a laser.
    #[error("{port}: FluidNC's laser mode is off ($32=0): its spindle in the configuration file (config.yaml) is not a laser, so the beam would stay on through G0 moves; nothing was sent. $32 cannot be set on FluidNC: give the configuration a `Laser:` spindle (with its speed_map), upload it and restart the board")]
    FluidLaserOff { port: String },
    #[error("{port}: the controller's power scale is ${setting}={} but the job was written for ${setting}={} ({written_for}): {example}; nothing was sent. Set ${setting}={} on the controller (Grbl keeps it), or have every S rescaled to the controller's scale", stencil_gcode::num(*controller), stencil_gcode::num(*job), stencil_gcode::num(*job))]
    PowerScale {
        port: String,
        setting: u32,
        controller: f64,
        job: f64,
        written_for: String,
        example: String,
    },
    #[error("{port}: the controller's ${setting}={} ({axis} max travel) is less than machine profile {profile}'s {bed} mm bed, and {why}: Grbl would stop the job with an alarm where the bed goes on; nothing was sent. Set ${setting}={bed} if the machine reaches it, or make the profile's bed match the machine", stencil_gcode::num(*travel))]
    TravelShort {
        port: String,
        axis: char,
        setting: u32,
        travel: f64,
        bed: f64,
        profile: String,
        why: String,
    },
    #[error("{file}: the job would change the machine itself, not only cut: {}; nothing was sent. Remove these lines, or allow them if you meant the job to do this", list_ten(changes, |c| format!("line {} `{}` {}", c.line, c.text, c.what)))]
    MachineCommands {
        file: String,
        changes: Vec<MachineChange>,
    },
    #[error("{port}: Grbl answered `$32=1` with ok but still reports $32={value}: laser mode cannot be set on this controller (built without variable spindle?)")]
    LaserModeNotSet { port: String, value: String },
    #[error("{file}: check mode ($C) rejected {} line(s), nothing was cut: {}", rejected.len(), list_ten(rejected, |e| format!("line {} `{}`: error:{} ({})", e.line, e.text, e.code, protocol::error_meaning(e.code))))]
    CheckFailed {
        file: String,
        rejected: Vec<CheckRejection>,
    },
    #[error("Grbl rejected line {line} `{text}` with error:{code} ({}); stopped: {halt} (after fixing the line)", protocol::error_meaning(*code))]
    Rejected {
        line: usize,
        text: String,
        code: u8,
        halt: Halt,
    },
    #[error("ALARM:{code} ({}); stopped: {halt}", protocol::alarm_meaning(*code))]
    Alarm { code: u8, halt: Halt },
    #[error("{port}: Grbl has not answered for {secs:.1} s; stopped: {halt}")]
    Silent { port: String, secs: f64, halt: Halt },
    #[error("{port}: the port went away ({detail}); {halt}")]
    PortLost {
        port: String,
        detail: String,
        halt: Halt,
    },
    #[error("{port}: the machine stood still at X{:.3} Y{:.3} Z{:.3} in Run with work queued for {still_s:.1} s, longer than this job's slowest step allows ({bound_s:.1} s): a stall (frozen controller or driver); stopped: {halt}", position[0], position[1], position[2])]
    Stalled {
        port: String,
        still_s: f64,
        bound_s: f64,
        position: Box<[f64; 3]>,
        halt: Halt,
    },
    #[error("{port}: Grbl stands idle with its buffers empty, yet {lost}; stopped: {halt}")]
    RepliesLost {
        port: String,
        lost: Box<Unanswered>,
        halt: Halt,
    },
    #[error("{port}: the controller puts the head at X{:.3} Y{:.3} (machine coordinates), but when the job stopped it was at X{:.3} Y{:.3}: the controller restarted without homing (a power loss?) and no longer knows where the head is; nothing was moved. Home the machine, or jog the head back to the job's start corner (X{:.3} Y{:.3} in the job's coordinates) and resume from there, or confirm that the coordinates are right again", now[0], now[1], then[0], then[1], corner[0], corner[1])]
    PositionLost {
        port: String,
        now: Box<[f64; 3]>,
        then: Box<[f64; 3]>,
        corner: [f64; 2],
    },
    #[error("{port}: the controller puts the head at X{:.3} Y{:.3} Z{:.3} (the job's coordinates), {} several lines that may have run last{}: which of them did cannot be told from the controller (a job that cuts the same path more than once), so nothing was moved. Look at the work, then resume from the right one of lines {} after checking", position[0], position[1], position[2], if *inside { "inside" } else { "at the end of" }, if *inside { "" } else { " (resuming after each)" }, resume.iter().map(|l| l.to_string()).collect::<Vec<_>>().join(", "))]
    ResumeAmbiguous {
        port: String,
        position: Box<[f64; 3]>,
        /// The lines the job could resume from, one for each place the head could be.
        resume: Vec<usize>,
        /// The head stands partway through those lines (not at their ends).
        inside: bool,
    },
    #[error("Grbl restarted in the middle of the job (power or reset); stopped: {halt}")]
    Restarted { halt: Halt },
    #[error("aborted by the operator; {halt}")]
    Aborted { halt: Halt },
    #[error("{port}: {firmware} has no card to run a job from (only grblHAL and FluidNC boards keep job files, on an SD card or flash): stream the job instead")]
    NoCard { port: String, firmware: String },
    #[error("{port}: {firmware} has no card to put the job on ({detail}): insert its SD card, or stream the job instead")]
    CardMissing {
        port: String,
        firmware: String,
        detail: String,
    },
    #[error("{port}: a job on the card runs whole, from its first line: resuming from a line is done by streaming")]
    CardWholeJob { port: String },
    #[error("{port}: the upload of {file} to the card failed ({detail}); nothing was started")]
    CardUpload {
        port: String,
        file: String,
        detail: String,
    },
    #[error("{port}: {file} did not arrive whole on the card ({detail}); nothing was started")]
    CardMismatch {
        port: String,
        file: String,
        detail: String,
    },
    #[error("{port}: the controller stopped the card job {file}: `{text}` ({}); the laser is off with the job", protocol::error_meaning(*code))]
    CardJobError {
        port: String,
        file: String,
        text: String,
        code: u8,
    },
    #[error("{port}: the controller stopped the card job {file} with ALARM:{code} ({}); an alarm switches the laser off", protocol::alarm_meaning(*code))]
    CardAlarm {
        port: String,
        file: String,
        code: u8,
    },
    #[error("{port}: the link to the controller dropped ({detail}) while it runs {file} from its card: the cut goes on there, unharmed")]
    CardLinkLost {
        port: String,
        file: String,
        detail: String,
    },
}

impl MachineError {
    /// Where a stopped job can be resumed, for errors that stopped one.
    pub fn halt(&self) -> Option<&Halt> {
        match self {
            MachineError::Rejected { halt, .. }
            | MachineError::Alarm { halt, .. }
            | MachineError::Silent { halt, .. }
            | MachineError::Stalled { halt, .. }
            | MachineError::PortLost { halt, .. }
            | MachineError::RepliesLost { halt, .. }
            | MachineError::Restarted { halt }
            | MachineError::Aborted { halt } => Some(halt),
            _ => None,
        }
    }
}
