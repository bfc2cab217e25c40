//! Grbl 1.1 over a serial port: the protocol, streaming a G-code program with character-counting
//! flow control, framing and jogging sessions, the recovery journal, and a virtual Grbl for dry
//! runs and tests. Knows G-code text and byte ports, not stencils: it runs any third-party job.
//! Uses `stencil-gcode` for its interpreter (to vet a program and know its moves), Grbl's fixed
//! sizes (`limits`) and its number format (`write::num`, for the programs it writes itself).
//!
//! [`send`] streams a [`Program`] by a [`StreamConfig`] over a [`BytePort`]; a [`Console`] holds
//! the same session open for [`frame`] and [`jog_session`]; a [`JournalWriter`] keeps what a
//! stopped job needs to resume; a [`VirtualGrbl`] answers on a pty as a board would.
//!
//! A dry run, as `stencil send --dry-run` streams it:
//!
//! ```
//! use stencil_grbl::{send, Program, Quiet, StreamConfig, VirtualConfig, VirtualGrbl};
//!
//! let job = Program::parse("job.gcode", "G21 G90\nM4 S300\nG1 X10 Y5 F1200\nM5\n")?;
//! let (grbl, mut port) = VirtualGrbl::spawn(VirtualConfig::default())?;
//! let summary = send(&mut port, &job, &StreamConfig::default(), None, &mut Quiet)?;
//! let record = grbl.stop();
//! assert_eq!(summary.lines, 4); // every job line acknowledged,
//! let received = ["$I", "$$", "G21G90", "M4S300", "G1X10Y5F1200", "M5"];
//! assert_eq!(record.run_lines(), received); // received once, after the sender's own queries,
//! assert!(!record.laser_on && record.state == "Idle"); // and the machine idle, laser off.
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod codes;
mod dialects;
mod error;
mod frame;
mod jog;
mod journal;
mod keys;
mod placement;
mod program;
mod protocol;
mod stall;
mod stream;
mod virtual_grbl;
mod xmodem;

pub use error::{CheckRejection, Halt, MachineChange, MachineError, Unanswered};
pub use frame::{frame, FrameError, FramePlan, FrameTool, Framed};
pub use jog::JOG_KEY_HELP;
pub use jog::{jog_session, parse_key, parse_keys, JogError, JogKey, JogKeys, Jogger, Script};
pub use journal::{fingerprint, journal_path, Journal, JournalError, JournalWriter, JOURNAL_EVERY};
pub use journal::{ModalRecord, PlacementRecord, Proposal, RunState};
pub use keys::{controls_for, overrides_text, pump, Key, KeySource, SEND_KEY_HELP};
pub use placement::{g92_for, ControllerState, DumpError, Placement, StartFrom};
pub use program::{cut_extent, cut_extent_with, machine_change, Extent, Program, ProgramLine};
pub use program::{ResumeLift, StateBefore};
pub use protocol::{Firmware, MachineState, Status};
pub use stall::{slowest_step, Clock, ClockRef};
pub use stream::{
    send, send_to_card, watch_card, BytePort, CardSummary, Console, Control, ControllerInfo,
    Expected, FlowControl,
};
pub use stream::{IfMoving, LaserMode, Observer, Override, Position, PowerScale, Progress, Quiet};
pub use stream::{Recovery, StreamConfig, Summary, TcpPort, MOVING_WAIT};
pub use virtual_grbl::{Event, Fault, FaultKind, Pace, PlannedMove, Received, Record, Stutter};
pub use virtual_grbl::{VirtualConfig, VirtualGrbl};
