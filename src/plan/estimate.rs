//! Job time estimate from the moves of a G-code program. OWNER: the G-code issue.
//!
//! CONTRACT (used by `stencil estimate`, `stencil simulate` and the virtual Grbl): keep these names.
//! PLACEHOLDER: length ÷ feed only, to be replaced by trapezoidal profiles with Grbl-style junction
//! speeds.

use crate::machine::gcode::Move;

/// The motion limits the estimate needs (from a machine profile).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionLimits {
    /// Rate of G0 moves, mm/min.
    pub rapid_mm_min: f64,
    /// Highest feed the machine runs, mm/min (programmed feeds above it are clamped).
    pub max_feed_mm_min: f64,
    /// Acceleration, mm/s².
    pub accel_mm_s2: f64,
    /// Grbl's junction deviation ($11), mm.
    pub junction_deviation_mm: f64,
}

impl Default for MotionLimits {
    /// A generic GRBL 1.1 diode laser.
    fn default() -> Self {
        MotionLimits {
            rapid_mm_min: 6000.0,
            max_feed_mm_min: 6000.0,
            accel_mm_s2: 1000.0,
            junction_deviation_mm: 0.01,
        }
    }
}

/// What a job costs in time and distance.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Estimate {
    pub total_s: f64,
    pub cut_s: f64,
    pub travel_s: f64,
    /// Length of moves with the tool on, mm.
    pub cut_mm: f64,
    /// Length of moves with the tool off, mm.
    pub travel_mm: f64,
}

/// Estimate a program's run time.
pub fn estimate(moves: &[Move], limits: &MotionLimits) -> Estimate {
    let mut e = Estimate::default();
    for m in moves {
        let d = ((m.to[0] - m.from[0]).powi(2)
            + (m.to[1] - m.from[1]).powi(2)
            + (m.to[2] - m.from[2]).powi(2))
        .sqrt();
        let rate = if m.rapid {
            limits.rapid_mm_min
        } else {
            m.feed.min(limits.max_feed_mm_min)
        };
        let t = if rate > 0.0 { d / rate * 60.0 } else { 0.0 };
        if m.power > 0.0 {
            e.cut_mm += d;
            e.cut_s += t;
        } else {
            e.travel_mm += d;
            e.travel_s += t;
        }
    }
    e.total_s = e.cut_s + e.travel_s;
    e
}
