//! The simulated controller's build, its pace, and the faults a test injects.

use stencil_gcode::limits::{PLANNER_BLOCKS, RX_BUFFER_BYTES};

use crate::protocol::Firmware;

/// How the simulated machine spends time on motion (its pace; not a move).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pace {
    /// Moves complete the moment they are planned: a dry run goes as fast as the link allows.
    Instant,
    /// Moves take their length ÷ feed, divided by `speedup` (1.0 = as the machine would).
    Timed {
        /// 1.0 = as fast as the machine; 10.0 = ten times faster.
        speedup: f64,
    },
}

/// What goes wrong, for tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultKind {
    /// Answer `error:N` instead of running the line.
    Error(u8),
    /// Stop everything with `ALARM:N` when the line arrives (like a limit switch): motion and laser
    /// stop, buffers are dropped, and the controller waits for a soft reset, then stays locked.
    Alarm(u8),
    /// From this line on, read and act on everything but never answer.
    Silence,
    /// Close the port when this line arrives (a cable pulled; the board loses power, laser off).
    ClosePort,
    /// The network link drops when this line arrives (WiFi lost): the board runs the line and
    /// what it holds, answering nobody, and takes the next connection. On a pty it is
    /// [`FaultKind::ClosePort`].
    DropLink,
    /// Freeze when this line arrives: the line is never answered, nothing more is taken from the
    /// receive buffer and nothing moves, yet status queries are still answered, in `Run` at a
    /// fixed position (a stalled planner or stepper driver: the firmware's serial interrupt
    /// lives on). A feed hold then reports a completed hold (nothing moves); a soft reset thaws
    /// it.
    Freeze,
    /// The `ok` for this line is lost on the wire (noise, a USB glitch): Grbl runs the line but
    /// the host never hears its answer.
    DropOk,
    /// The `ok` for this line arrives garbled (`okM`, as grbl-sim was once seen to send): Grbl
    /// runs the line, the host reads a line that is no answer.
    GarbleOk,
    /// The board loses power when this line arrives and comes back at once: planner, G92 and
    /// modal state gone, outputs off, the position read as machine zero (without homing
    /// switches nothing tells it where the head is), the banner sent again; a board with homing
    /// (`$22=1`) boots locked in alarm, as Grbl does.
    PowerLoss,
}

/// A fault that fires once, when the `at_job_line`-th G-code line arrives (counting lines that are
/// not empty, not `$` commands, and not sent in check mode; 1-based).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fault {
    /// The job line it fires at.
    pub at_job_line: usize,
    /// What happens.
    pub kind: FaultKind,
}

/// The simulated controller's build.
#[derive(Clone, Debug)]
pub struct VirtualConfig {
    /// Receive buffer size in bytes (128 in stock Grbl); reported in `$I` as `[OPT:V,blocks,rx]`.
    pub rx_buffer: usize,
    /// Planner blocks (15 on an AVR).
    pub planner_blocks: usize,
    /// How fast moves run.
    pub pace: Pace,
    /// Pace the link at this baud rate (10 bits per byte, both directions); `None` = as fast as the
    /// pty goes.
    pub baud: Option<u32>,
    /// G0 rate, mm/min.
    pub rapid_mm_min: f64,
    /// Faults to inject.
    pub faults: Vec<Fault>,
    /// Laser mode, `$32` (settable with `$32=0|1`): on, the beam never fires in G0 and M3/M4
    /// act as a laser; off, a switched-on spindle stays on through G0 moves too.
    pub laser_mode: bool,
    /// Report `Ln:` (the N number of the block being executed), as Grbl built with
    /// `USE_LINE_NUMBERS` does; stock Grbl does not.
    pub line_numbers: bool,
    /// Settings that differ from the simulated defaults (`$$` lists them), e.g. `(32, "0")`.
    pub settings: Vec<(u32, String)>,
    /// Homing enabled (`$22=1`): `$H` homes to machine zero and clears an alarm; disabled, `$H`
    /// answers `error:5` as Grbl does.
    pub homing: bool,
    /// Everything the board sends arrives this much later (a USB-serial adapter's latency
    /// timer, 1..16 ms on FTDI and CH340 chips): a status report read by the host describes the
    /// machine as it was, not as it is.
    pub latency: std::time::Duration,
    /// The work systems (G54..G59), G92, tool length offset, selected system and head position
    /// it starts with, as a person's saved `$#`, `$G` and `?` say (its `$$` goes in `settings`);
    /// `None`: at machine zero with no offsets.
    pub start: Option<crate::placement::ControllerState>,
    /// The board was left running a job when the host opened its port (its sender died
    /// mid-job, and opening the port does not reset this board): these lines are already on
    /// their way into its receive buffer and run at once, no banner greets the new host, and
    /// their answers went to the sender that is gone. Give it a timed pace to have it moving.
    pub mid_job: Option<String>,
    /// The board's thread loses the CPU now and then, as on a busy computer where the dry run's
    /// controller shares two cores with a dozen other processes; `None`: it runs when it can.
    pub stutter: Option<Stutter>,
    /// The firmware it plays: its banner, `$I`, status fields and codes. grblHAL and FluidNC
    /// boards do not reset when a port opens, so they greet a new host with no banner (build
    /// one with [`VirtualConfig::dialect`] for their buffer sizes too).
    pub firmware: Firmware,
}

/// Pauses between the board's turns: after each turn, with a chance of one in `one_in`, it
/// sleeps up to `longest` (drawn from `seed`, so a run can be repeated).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stutter {
    /// Seed of the pauses.
    pub seed: u64,
    /// One turn in this many pauses.
    pub one_in: u32,
    /// The longest pause.
    pub longest: std::time::Duration,
}

impl Stutter {
    /// The pause after the next turn (zero most of the time); advances `state` (a splitmix64
    /// generator seeded with `seed`).
    pub fn next_pause(&self, state: &mut u64) -> std::time::Duration {
        let mut draw = || {
            *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = *state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        };
        if self.one_in == 0 || draw() % u64::from(self.one_in) != 0 {
            return std::time::Duration::ZERO;
        }
        let nanos = self.longest.as_nanos().min(u128::from(u64::MAX)) as u64;
        std::time::Duration::from_nanos(draw() % nanos.max(1))
    }
}

impl VirtualConfig {
    /// A controller running `firmware` with its usual sizes: Grbl's 128-byte receive buffer and
    /// 15 blocks; grblHAL's 1024 bytes and 35 blocks (what its `$I` reports on most 32-bit
    /// boards); FluidNC's 256-byte channel buffer and 16 blocks (which only its status reports
    /// tell).
    pub fn dialect(firmware: Firmware) -> VirtualConfig {
        let (rx_buffer, planner_blocks) = match firmware {
            Firmware::Grbl => (RX_BUFFER_BYTES, PLANNER_BLOCKS),
            Firmware::GrblHal => (1024, 35),
            Firmware::FluidNc => (256, 16),
        };
        VirtualConfig {
            firmware,
            rx_buffer,
            planner_blocks,
            ..VirtualConfig::default()
        }
    }

    /// The settings a stock laser build lists in `$$` (with the configured homing, laser mode and
    /// rapid rate), then the configured ones over them.
    pub(super) fn initial_settings(&self) -> Vec<(u32, String)> {
        let rapid = format!("{:.3}", self.rapid_mm_min);
        let mut settings: Vec<(u32, String)> = [
            (10, "2"),
            (11, "0.010"),
            (20, "0"),
            (22, if self.homing { "1" } else { "0" }),
            (30, "1000"),
            (31, "0"),
            (32, if self.laser_mode { "1" } else { "0" }),
            (110, rapid.as_str()),
            (111, rapid.as_str()),
            (120, "1000.000"),
            (121, "1000.000"),
            (130, "400.000"),
            (131, "400.000"),
        ]
        .iter()
        .map(|&(k, v)| (k, v.to_string()))
        .collect();
        for (k, v) in self.settings.clone() {
            put_setting(&mut settings, k, v);
        }
        if self.firmware == Firmware::FluidNc {
            // FluidNC lists no minimum power: its laser's speed map in the configuration file
            // holds it.
            settings.retain(|(k, _)| *k != 31);
        }
        settings
    }
}

/// Setting `$k` set to `v`: changed in place where listed, else added at the end.
pub(super) fn put_setting(settings: &mut Vec<(u32, String)>, k: u32, v: String) {
    match settings.iter_mut().find(|(n, _)| *n == k) {
        Some(e) => e.1 = v,
        None => settings.push((k, v)),
    }
}

impl Default for VirtualConfig {
    fn default() -> Self {
        VirtualConfig {
            rx_buffer: RX_BUFFER_BYTES,
            planner_blocks: PLANNER_BLOCKS,
            pace: Pace::Instant,
            baud: None,
            rapid_mm_min: 6000.0,
            faults: Vec::new(),
            laser_mode: true,
            line_numbers: false,
            settings: Vec::new(),
            homing: true,
            latency: std::time::Duration::ZERO,
            start: None,
            stutter: None,
            mid_job: None,
            firmware: Firmware::Grbl,
        }
    }
}
