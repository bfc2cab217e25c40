//! Grbl 1.1's fixed sizes in the stock firmware, in one place: the writer keeps its lines within
//! them, the estimate plans with them, and `stencil-grbl` streams and emulates with them.

/// Longest line Grbl accepts after stripping spaces and comments; longer is `error:11`. Its line
/// buffer is 80 bytes with the terminating zero, so 79 characters fit (protocol.c flags overflow
/// at `char_counter >= LINE_BUFFER_SIZE-1`).
pub const MAX_LINE_BYTES: usize = 79;

/// Planner blocks in the stock firmware (`[OPT:V,15,...]`): the look-ahead window.
pub const PLANNER_BLOCKS: usize = 15;

/// Grbl's serial receive buffer in the stock firmware (`[OPT:...,128]`).
pub const RX_BUFFER_BYTES: usize = 128;
