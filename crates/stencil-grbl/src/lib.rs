//! Grbl 1.1 over a serial port: the protocol, streaming a G-code program with character-counting
//! flow control, framing and jogging sessions, the recovery journal, and a virtual Grbl for dry
//! runs and tests. Knows G-code text and byte ports, not stencils: it runs any third-party job.
//! Uses `stencil-gcode` only for its interpreter (to vet a program and know its moves).

#![forbid(unsafe_code)]

pub mod error;
pub mod frame;
pub mod program;
pub mod jog;
pub mod journal;
pub mod keys;
pub mod protocol;
pub mod stall;
pub mod stream;
pub mod virtual_grbl;

pub use stream::{send, BytePort, Control, FlowControl, Program, MachineError, StreamConfig};
pub use virtual_grbl::{VirtualConfig, VirtualGrbl};
