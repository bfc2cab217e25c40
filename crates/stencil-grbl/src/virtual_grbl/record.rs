//! What the simulated machine saw and did, for a test (or a dry run) to check.

use std::sync::{Mutex, MutexGuard};

/// One line the controller took out of its receive buffer.
#[derive(Clone, Debug, PartialEq)]
pub struct Received {
    /// The bytes of the line as received, without its terminator.
    pub text: String,
    /// Received while in `$C` check mode (parsed, never run).
    pub check_mode: bool,
}

/// Things that happened, in order.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// A line, as an index into [`Record::received`].
    Line(usize),
    /// A real-time byte.
    Realtime(u8),
    /// A soft reset (0x18).
    SoftReset,
    /// An alarm, by code.
    Alarm(u8),
    /// The port closed (an injected fault).
    Closed,
    /// The board lost power and came back (an injected fault).
    PowerLoss,
    /// The network link dropped; the board ran on (an injected fault).
    LinkDropped,
    /// A file was written to the card (its name), received over the stream.
    CardFile(String),
}

/// Everything the simulated machine saw and did.
#[derive(Clone, Debug, Default)]
pub struct Record {
    /// Every line taken from the receive buffer, in order.
    pub received: Vec<Received>,
    /// What happened, in order.
    pub events: Vec<Event>,
    /// Indices into `received` of lines the machine finished (motion completed or command run).
    pub executed: Vec<usize>,
    /// Most bytes ever waiting in the receive buffer.
    pub max_rx_used: usize,
    /// Bytes dropped because the receive buffer was full.
    pub overflow_bytes: usize,
    /// Bytes lost because they arrived while Grbl wrote a `$x=` setting to its EEPROM.
    pub eeprom_lost_bytes: usize,
    /// Laser armed: M3/M4 active with S > 0.
    pub laser_on: bool,
    /// Machine position, mm.
    pub position: [f64; 3],
    /// State as a status report names it (`Idle`, `Run`, `Alarm`...).
    pub state: String,
    /// The port was closed (an injected fault).
    pub closed: bool,
    /// Status reports sent (for checking the poll rate).
    pub status_reports: usize,
    /// Coolant output (M8; air assist on a laser) on.
    pub air_on: bool,
    /// Every move the planner accepted outside check mode (jogs too), in order, with the tool's
    /// state during it, in machine coordinates: what the head really went through (a test checks
    /// Z and the spindle during every XY move of a resume).
    pub moves: Vec<PlannedMove>,
    /// `$32` as it stands now.
    pub laser_mode: bool,
    /// Feed, rapid and spindle overrides in percent, as the last real-time bytes left them.
    pub overrides: [u32; 3],
    /// Frozen by [`FaultKind::Freeze`](super::FaultKind::Freeze) (until a soft reset).
    pub frozen: bool,
    /// Work coordinate offset (G54, set with `G10 L20 P1` or `G10 L2 P1`): work = machine - WCO.
    pub wco: [f64; 3],
}

/// One move as the simulated planner took it (machine coordinates).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlannedMove {
    /// Start, mm.
    pub from: [f64; 3],
    /// End, mm.
    pub to: [f64; 3],
    /// A G0 move.
    pub rapid: bool,
    /// M3/M4 on (a servo pen on the spindle output is down).
    pub spindle_on: bool,
    /// The beam fires during this move: spindle on with S > 0, and not a G0 or a jog in laser
    /// mode.
    pub beam: bool,
    /// Coolant (air assist) on during this move.
    pub air: bool,
    /// Index into [`Record::received`] of the line that made it.
    pub idx: usize,
}

impl PlannedMove {
    /// The move changes X or Y.
    pub fn moves_xy(&self) -> bool {
        self.from[0] != self.to[0] || self.from[1] != self.to[1]
    }
}

impl Record {
    /// The lines received outside check mode (what the machine was asked to run), in order.
    pub fn run_lines(&self) -> Vec<&str> {
        self.received
            .iter()
            .filter(|r| !r.check_mode)
            .map(|r| r.text.as_str())
            .collect()
    }
}

/// The record, even after a panic in the simulator thread (so a test still sees it).
pub(super) fn lock(m: &Mutex<Record>) -> MutexGuard<'_, Record> {
    // A panic in the simulator thread must not hide its record from the test.
    m.lock().unwrap_or_else(|p| p.into_inner())
}
