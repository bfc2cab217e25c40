//! Grbl 1.1 over a serial port: the protocol, streaming a G-code program with character-counting
//! flow control, framing and jogging sessions, the recovery journal, and a virtual Grbl for dry
//! runs and tests. Knows G-code text and byte ports, not stencils: it runs any third-party job.
//! Uses `stencil-gcode` for its interpreter (to vet a program and know its moves), Grbl's fixed
//! sizes (`limits`) and its number format (`write::num`, for the programs it writes itself).
//!
//! # Public API
//!
//! - [`stream`]: [`send`] streams a [`Program`] (a vetted G-code file: [`Program::parse`],
//!   [`ProgramLine`], [`ResumeLift`] and the resume preamble) by a [`StreamConfig`]
//!   ([`FlowControl`], [`stream::LaserMode`]) over a [`BytePort`], taking [`Control`]s
//!   ([`stream::Override`]) and telling a [`stream::Observer`] ([`stream::Quiet`],
//!   [`stream::Progress`], [`stream::ControllerInfo`]); it returns a [`stream::Summary`] or a
//!   [`MachineError`] (with its [`stream::Halt`] and [`stream::CheckRejection`]s).
//!   [`stream::console::Console`] holds the same session open for jog and frame
//!   ([`stream::console::Position`]).
//! - [`frame`]: [`frame::cut_extent`], [`frame::cut_extent_with`], [`frame::frame`] with
//!   [`frame::Extent`], [`frame::FrameTool`], [`frame::FramePlan`], [`frame::Framed`],
//!   [`frame::FrameError`].
//! - [`jog`]: [`jog::Jogger`], [`jog::run`], [`jog::JogKey`], [`jog::parse_key`],
//!   [`jog::parse_keys`], [`jog::Script`], [`jog::JogKeys`], [`jog::JogError`], [`jog::KEY_HELP`].
//! - [`journal`]: the recovery journal: [`journal::Journal`], [`journal::JournalWriter`],
//!   [`journal::RunState`], [`journal::ModalRecord`], [`journal::Proposal`],
//!   [`journal::JournalError`], [`journal::path_for`], [`journal::EVERY`].
//! - [`keys`]: operator keys while streaming: [`keys::Key`], [`keys::KeySource`], [`keys::pump`],
//!   [`keys::overrides_text`], [`keys::KEY_HELP`].
//! - [`stall`]: [`stall::Clock`], [`stall::ClockRef`] (time for the stall watch; a test's own
//!   clock), [`stall::slowest_step`].
//! - [`protocol`]: what Grbl says: [`protocol::Reply`], [`protocol::Status`],
//!   [`protocol::MachineState`].
//! - [`virtual_grbl`]: [`VirtualGrbl`] on a pty, built by a [`VirtualConfig`]
//!   ([`virtual_grbl::Pace`], [`virtual_grbl::Fault`], [`virtual_grbl::FaultKind`]), recording a
//!   [`virtual_grbl::Record`] ([`virtual_grbl::Received`], [`virtual_grbl::Event`],
//!   [`virtual_grbl::PlannedMove`]).

#![forbid(unsafe_code)]

mod error;
pub mod frame;
pub mod jog;
pub mod journal;
pub mod keys;
pub mod placement;
mod program;
pub mod protocol;
pub mod stall;
pub mod stream;
pub mod virtual_grbl;

pub use stream::{
    send, BytePort, Control, FlowControl, MachineError, Program, ProgramLine, ResumeLift,
    StreamConfig,
};
pub use virtual_grbl::{VirtualConfig, VirtualGrbl};
