//! What a stream tells a front end while it runs, and what it reports when done.

use std::time::Duration;

use crate::protocol::{Firmware, MachineState};

/// What the controller told us on connect.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ControllerInfo {
    /// Which firmware, from the banner and `$I`.
    pub firmware: Firmware,
    /// The firmware version from the banner or `$I`.
    pub version: String,
    /// Receive buffer, bytes.
    pub rx_buffer: usize,
    /// Planner blocks.
    pub planner_blocks: usize,
    /// The machine was in alarm and `$X` unlocked it.
    pub unlocked: bool,
    /// Grbl's settings as `$$` listed them on connect (number, value); empty if it did not.
    pub settings: Vec<(u32, f64)>,
}

impl ControllerInfo {
    /// "Grbl 1.1h", "grblHAL 1.1f", "FluidNC 3.7.8": what the controller is, for messages.
    pub fn name(&self) -> String {
        format!("{} {}", self.firmware, self.version)
    }

    /// Setting `$n` as the controller reported it.
    pub fn setting(&self, n: u32) -> Option<f64> {
        self.settings.iter().find(|(k, _)| *k == n).map(|&(_, v)| v)
    }
}

/// Where a running job stands.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Progress {
    /// Program lines acknowledged (the resume preamble not counted).
    pub acked: usize,
    /// Program lines in all.
    pub total: usize,
    /// File line of the last acknowledged line.
    pub last_acked_line: Option<usize>,
    /// First file line that may not have run yet (acknowledged lines can still wait in the
    /// planner): the remaining-time estimate starts here.
    pub unexecuted_from: usize,
    /// The last status report's state.
    pub state: Option<MachineState>,
    /// The last status report's position, mm.
    pub position: Option<[f64; 3]>,
    /// Feed, rapid and spindle overrides in percent, as the last `Ov:` field said (Grbl sends it
    /// every few reports and right after a change).
    pub overrides: Option<[u32; 3]>,
    /// The N number Grbl last reported executing (`Ln:`, firmware built with line numbers).
    pub status_line: Option<u32>,
    /// Time since the session began (connecting included).
    pub elapsed: Duration,
}

/// Things a front end may show. Every method has a do-nothing default.
pub trait Observer {
    /// Connected: what the controller said.
    fn connected(&mut self, _info: &ControllerInfo) {}
    /// A `[MSG:..]` or other text from the controller, or a note from the streamer.
    fn message(&mut self, _text: &str) {}
    /// The check-mode pass (true) or the real run (false) begins.
    fn phase(&mut self, _checking: bool, _total: usize) {}
    /// After each acknowledgement or status report.
    fn progress(&mut self, _p: &Progress) {}
    /// Program line `line` is about to be written to the port (called before it goes out).
    fn sending(&mut self, _line: usize) {}
}

/// An observer that shows nothing.
pub struct Quiet;
impl Observer for Quiet {}

/// What a finished stream did.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// Program lines acknowledged.
    pub lines: usize,
    /// Program bytes written (lines with their newlines, without the preamble).
    pub bytes: u64,
    /// From the first program byte to the last acknowledgement.
    pub elapsed: Duration,
    /// The most bytes kept in flight (receive buffer − 1).
    pub rx_limit: usize,
    /// Most bytes ever in flight.
    pub max_in_flight: usize,
    /// From the start of streaming until the machine was idle with every line done.
    pub total: Duration,
    /// What the controller said on connect.
    pub info: ControllerInfo,
}
