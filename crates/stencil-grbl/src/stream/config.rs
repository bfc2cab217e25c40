//! How a stream is run: flow control, laser mode, timeouts, where to start and how to resume.

use std::time::Duration;

use crate::program::ResumeLift;
use crate::protocol;
use crate::stall::ClockRef;

/// How lines are paced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlowControl {
    /// Keep the receive buffer as full as Grbl allows (fast; the normal mode).
    CharacterCounting,
    /// One line at a time, each waiting for its `ok` (slow; for boards that overflow).
    SendResponse,
}

/// What to do about Grbl's laser mode (`$32`) before a job.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LaserMode {
    /// Not a laser job: leave `$32` alone.
    #[default]
    Ignore,
    /// A laser job: read `$$` and refuse if `$32=0`.
    Require,
    /// A laser job: read `$$` and set `$32=1` if it is off (`--set-laser-mode`).
    Set,
}

/// What connecting does about a controller found still running moves it was given before
/// (another program's job, or the rest of one whose sender died): a soft reset then would lose
/// its position (ALARM:3), so it is never reset while it moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IfMoving {
    /// Wait until it stands idle, at most this long, then connect as usual; a machine held in a
    /// feed hold or at its safety door, which will not finish by itself, is refused at once.
    Wait(Duration),
    /// Stop it as the abort key does: feed hold, wait until it stands, then the soft reset
    /// (from a completed hold Grbl keeps its position).
    Stop,
}

/// How long connecting waits for a machine found running to finish: what a sender that died
/// leaves queued (15 planner blocks and a 128-byte buffer of lines) takes minutes at most.
pub const MOVING_WAIT: Duration = Duration::from_secs(300);

/// The longest a homing cycle may take before the sender gives up on it.
pub(crate) const HOMING_LIMIT: Duration = Duration::from_secs(300);

/// Streaming settings.
#[derive(Clone, Debug)]
pub struct StreamConfig {
    /// How lines are paced.
    pub flow: FlowControl,
    /// Receive buffer size to count against; `None` = ask Grbl (`$I`), else 128.
    pub rx_buffer: Option<usize>,
    /// A controller that says nothing for this long (while being polled) is reported as silent.
    pub timeout: Duration,
    /// How long to wait for the banner of a board that resets when the port opens, before sending
    /// a soft reset to wake it.
    pub boot_wait: Duration,
    /// Status poll period (Grbl asks for 5 Hz or less).
    pub poll_interval: Duration,
    /// Send `$X` if the machine is locked in alarm.
    pub unlock: bool,
    /// Run the whole program through `$C` check mode first; refuse to cut if any line errors.
    pub check_first: bool,
    /// Start at this 1-based line of the file, after restoring the modal state it needs.
    pub from_line: usize,
    /// How the tool is lifted for the travel to a resume point (from the machine profile).
    pub lift: ResumeLift,
    /// The machine's G0 rate, mm/min (from its profile), for the stall bound; `None` = time G0
    /// at the job's slowest feed (a looser bound).
    pub rapid_mm_min: Option<f64>,
    /// Time for stall detection (a test's clock, or the system's).
    pub clock: ClockRef,
    /// Check (or set) laser mode before anything is sent.
    pub laser_mode: LaserMode,
    /// Home (`$H`) after connecting, before anything else moves: a recovery after a crash or a
    /// power loss cannot trust the machine's position. Also clears the alarm a homing machine
    /// boots in.
    pub home_first: bool,
    /// What the job and the machine profile expect of Grbl's settings; compared with `$$`
    /// before anything moves.
    pub expect: Expected,
    /// A power scale (`$30`/`$31`) that differs from the job's is not refused: every S is
    /// rescaled to the controller's scale, and the stream says so.
    pub rescale_power: bool,
    /// A resume after a stop, crash or power loss: checked against the controller's own
    /// position before anything moves.
    pub recovery: Option<Recovery>,
    /// Let the job's own lines change the machine (`$` settings, homing, unlock, check mode,
    /// jogs, stored offsets); otherwise they are refused before anything is sent.
    pub allow_machine_commands: bool,
    /// Machine coordinates (X, Y) the job's X0 Y0 must be at ([`crate::placement::Placement`]):
    /// after connecting (and any homing or recovery check), a work zero found elsewhere is moved
    /// there with `G92`. `None` leaves the controller's offsets as they are.
    pub place_zero: Option<[f64; 2]>,
    /// A controller found running moves when connecting: waited for, or stopped safely.
    pub if_moving: IfMoving,
}

/// What a job and its machine profile expect of the controller's settings (`$$`). Every field
/// left `None` is not compared.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Expected {
    /// The machine profile's name, for messages.
    pub profile: String,
    /// The power scale the job's S words were written for.
    pub power: Option<PowerScale>,
    /// Rapid rate, mm/min (`$110`, `$111`).
    pub rapid_mm_min: Option<f64>,
    /// Acceleration, mm/s² (`$120`, `$121`).
    pub accel_mm_s2: Option<f64>,
    /// Junction deviation, mm (`$11`).
    pub junction_mm: Option<f64>,
    /// The bed, mm: max travel (`$130`, `$131`) must reach it.
    pub bed_mm: Option<[f64; 2]>,
}

/// The S scale a job was written for.
#[derive(Clone, Debug, PartialEq)]
pub struct PowerScale {
    /// S at full power (`$30`).
    pub s_max: f64,
    /// S at the lowest power (`$31`).
    pub s_min: f64,
    /// Where the scale was read, as messages put it after the scale in brackets: "read from its
    /// header", or "taken from machine profile diode-400, as its header does not say".
    pub source: String,
}

impl Default for StreamConfig {
    fn default() -> Self {
        StreamConfig {
            flow: FlowControl::CharacterCounting,
            rx_buffer: None,
            timeout: Duration::from_secs(10),
            boot_wait: Duration::from_millis(2500),
            poll_interval: Duration::from_millis(250),
            unlock: false,
            check_first: false,
            from_line: 1,
            lift: ResumeLift::default(),
            rapid_mm_min: None,
            clock: ClockRef::default(),
            laser_mode: LaserMode::Ignore,
            home_first: false,
            expect: Expected::default(),
            rescale_power: false,
            allow_machine_commands: false,
            recovery: None,
            place_zero: None,
            if_moving: IfMoving::Wait(MOVING_WAIT),
        }
    }
}

/// What a recovery knows from the journal, and what the person has said since.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recovery {
    /// Machine position of the last status report the journal kept.
    pub last_position: Option<[f64; 3]>,
    /// The journal's last acknowledged line: Grbl ran at least the lines before the resume
    /// point, and after a sender crash it ran on through everything it had received.
    pub last_acked: Option<usize>,
    /// The person says the controller's coordinates are right again (homed, or re-zeroed by
    /// hand): the position is not compared.
    pub confirmed: bool,
    /// The person brought the head back to this point of the job (work coordinates, its start
    /// corner): the controller is told so (`G92`) before the resume.
    pub at_corner: Option<[f64; 2]>,
    /// A controller standing idle exactly where a later line ends ran on after the journal's
    /// last record (the sender crashed, Grbl did not): resume after that line.
    pub follow: bool,
    /// The journal's last line sent: Grbl can have received nothing past it.
    pub last_sent: Option<usize>,
    /// The run's stop reset Grbl (its queue was dropped): nothing ran after the journal's last
    /// record, and the journal's resume point stands.
    pub grbl_stopped: bool,
    /// Connecting found the machine still running what it had received and stopped it (as
    /// asked): it did not run everything it received.
    pub cut_short: bool,
}

/// Commands from the operator while a job runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    /// Feed hold (`!`).
    FeedHold,
    /// Cycle start (`~`).
    Resume,
    /// Stop now: soft reset, laser off, report the resume line.
    Abort,
    /// Change a feed or power override (Grbl's real-time bytes; the job keeps running).
    Override(Override),
}

/// The overrides an operator changes while cutting: feed and spindle (laser power) in 10 %
/// steps within Grbl's 10..200 %, or back to 100 %.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Override {
    /// Feed +10 %.
    FeedPlus10,
    /// Feed −10 %.
    FeedMinus10,
    /// Feed back to 100 %.
    FeedReset,
    /// Power +10 %.
    PowerPlus10,
    /// Power −10 %.
    PowerMinus10,
    /// Power back to 100 %.
    PowerReset,
}

impl Override {
    /// Grbl's real-time byte for it.
    pub fn byte(self) -> u8 {
        match self {
            Override::FeedPlus10 => protocol::RT_FEED_OV_PLUS_10,
            Override::FeedMinus10 => protocol::RT_FEED_OV_MINUS_10,
            Override::FeedReset => protocol::RT_FEED_OV_RESET,
            Override::PowerPlus10 => protocol::RT_SPINDLE_OV_PLUS_10,
            Override::PowerMinus10 => protocol::RT_SPINDLE_OV_MINUS_10,
            Override::PowerReset => protocol::RT_SPINDLE_OV_RESET,
        }
    }
}
