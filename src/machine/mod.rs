//! The machine: Grbl protocol, streaming over a serial port, the virtual Grbl, the simulator.
//! Knows G-code text and byte ports, not stencils: it must run any third-party job.
//! OWNER: the machine issue (the G-code interpreter in `gcode.rs` is shared with `plan`'s estimator).

pub mod error;
pub mod frame;
pub mod gcode;
pub mod job;
pub mod jog;
pub mod journal;
pub mod keys;
pub mod protocol;
pub mod simulate;
pub mod stall;
pub mod stream;
pub mod virtual_grbl;

pub use stream::{send, BytePort, Control, FlowControl, Job, MachineError, StreamConfig};
pub use virtual_grbl::{VirtualConfig, VirtualGrbl};
