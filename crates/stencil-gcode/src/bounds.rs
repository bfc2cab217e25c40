//! What a GRBL machine and a cut can be, number by number: every number in a profile must lie in its range
//! (a `z_up_mm = 1e9` was written as `Z1000000000`, a feed of 1e308 broke the writer).

use std::ops::RangeInclusive;

/// Bed width and height, mm: up to 10 m.
pub const BED_MM: RangeInclusive<f64> = 1.0..=10_000.0;
/// Feeds and rates (max feed, rapid, plunge; also a cut's speed), mm/min: 1 mm/min to
/// 200 m/min.
pub const FEED_MM_MIN: RangeInclusive<f64> = 1.0..=200_000.0;
/// Acceleration, mm/s²: up to about 10 g.
pub const ACCEL_MM_S2: RangeInclusive<f64> = 1.0..=100_000.0;
/// Steps per mm: from a coarse lead screw to a fine belt with heavy microstepping.
pub const STEPS_PER_MM: RangeInclusive<f64> = 1.0..=10_000.0;
/// Junction deviation (`$11`), mm.
pub const JUNCTION_DEVIATION_MM: RangeInclusive<f64> = 0.0001..=10.0;
/// Spindle S values (`$30`, a pen's down S): up to 100,000 (spindle RPM).
pub const S: RangeInclusive<f64> = 0.1..=100_000.0;
/// Z heights, mm: within a metre of zero.
pub const Z_MM: RangeInclusive<f64> = -1000.0..=1000.0;
/// A drag knife's overcut, mm.
pub const OVERCUT_MM: RangeInclusive<f64> = 0.0..=50.0;
/// Framing power, % of full: a glimmer to see the outline by, never enough to mark.
pub const FRAME_POWER_PCT: RangeInclusive<f64> = 0.0..=10.0;
/// A laser's power, W: a 0.5 W diode to a 500 W CO2 tube.
pub const WATTS: RangeInclusive<f64> = 0.5..=500.0;
/// A controller's serial speed, baud: from 9600 to a native-USB board's 4 Mbaud.
pub const BAUD: RangeInclusive<f64> = 9600.0..=4_000_000.0;
/// A controller's serial receive buffer, bytes: an AVR Grbl's 128 up to a 32-bit port's 64 KiB.
pub const RX_BUFFER_BYTES: RangeInclusive<f64> = 32.0..=65_536.0;
/// A controller's planner blocks (usable): 2 up to the thousands some 32-bit ports keep.
pub const PLANNER_BLOCKS: RangeInclusive<f64> = 2.0..=4096.0;
/// The longest profile name, characters (it is printed in G-code comments and messages).
pub const NAME_CHARS: usize = 100;

/// The most passes a job may make.
pub const MAX_PASSES: u32 = 100;

/// The largest drag-knife blade offset, mm.
pub const MAX_BLADE_OFFSET_MM: f64 = 5.0;
