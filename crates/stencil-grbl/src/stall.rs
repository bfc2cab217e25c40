//! Noticing a machine that has stopped moving while it still answers.
//!
//! A frozen controller (a stalled planner, a stepper driver fault, a firmware bug) may keep
//! answering `?` from its serial interrupt: the silence timer never fires, and a sender waits for
//! ever (203 s on real Grbl before a human noticed). Grbl in `Run` always moves, dwells or waits on
//! a spindle: a position that stands still in `Run`, with work still queued, for longer than the
//! slowest single step of the job itself could take is a stall.
//!
//! Time comes from a [`Clock`], so tests run a stall in a handful of status reports instead of
//! waiting seconds.

use std::fmt;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::program::Program;
use super::protocol::{MachineState, Status};
use stencil_gcode::interpret as gcode;

/// Where time comes from: the system's monotonic clock, or a test's.
pub trait Clock: Send + Sync {
    /// Time since some fixed start.
    fn now(&self) -> Duration;
}

/// The monotonic system clock.
pub(crate) struct SystemClock(Instant);

impl Default for SystemClock {
    fn default() -> Self {
        SystemClock(Instant::now())
    }
}

impl Clock for SystemClock {
    fn now(&self) -> Duration {
        self.0.elapsed()
    }
}

/// A shared clock in a config (cloneable, printable).
#[derive(Clone)]
pub struct ClockRef(pub Arc<dyn Clock>);

impl Default for ClockRef {
    fn default() -> Self {
        ClockRef(Arc::new(SystemClock::default()))
    }
}

impl fmt::Debug for ClockRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("ClockRef")
    }
}

/// Slack over the slowest step: status reports come every quarter second or so, a spindle or
/// servo may take a moment, and a host under load reads late.
pub(crate) const STALL_MARGIN: Duration = Duration::from_secs(5);

/// How long the job's slowest single step takes at 100 % feed: the longest move at its programmed
/// feed (G0 at `rapid_mm_min`, or when that is unknown at the slowest feed the job uses, which
/// overestimates), or the longest dwell (`G4 P<seconds>`).
pub fn slowest_step(job: &Program, rapid_mm_min: Option<f64>) -> Duration {
    let slowest_feed = job
        .moves
        .iter()
        .filter(|m| !m.rapid && m.feed > 0.0)
        .map(|m| m.feed)
        .fold(f64::INFINITY, f64::min);
    let rapid = rapid_mm_min
        .filter(|r| *r > 0.0)
        .unwrap_or(if slowest_feed.is_finite() {
            slowest_feed
        } else {
            // No feed at all in the job: a slow machine's G0.
            500.0
        });
    let mut longest = 0.0f64;
    for m in &job.moves {
        let rate = if m.rapid { rapid } else { m.feed };
        if rate > 0.0 {
            longest = longest.max(m.length() / rate * 60.0);
        }
    }
    for l in &job.lines {
        let Ok(words) = gcode::words(&l.text, l.number) else {
            continue;
        };
        if words.iter().any(|&(c, v)| c == 'G' && v == 4.0) {
            if let Some(&(_, p)) = words.iter().find(|(c, _)| *c == 'P') {
                longest = longest.max(p);
            }
        }
    }
    Duration::from_secs_f64(longest.clamp(0.0, 1e6))
}

/// The stall bound: 1.5 × the slowest step plus [`STALL_MARGIN`].
pub(crate) fn stall_bound(slowest: Duration) -> Duration {
    slowest.mul_f64(1.5) + STALL_MARGIN
}

/// Watches status reports for a stall.
#[derive(Clone, Debug)]
pub(crate) struct StallWatch {
    /// The bound at 100 % feed; a lower feed override stretches it.
    pub bound: Duration,
    /// Since when (clock time) the machine has stood at this position in `Run`.
    since: Option<(Duration, [f64; 3])>,
    feed_override: u32,
}

/// A stall: how long the machine stood still, where, and the bound it exceeded.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Stall {
    pub still_for: Duration,
    pub bound: Duration,
    pub position: [f64; 3],
}

impl StallWatch {
    pub(crate) fn new(bound: Duration) -> StallWatch {
        StallWatch {
            bound,
            since: None,
            feed_override: 100,
        }
    }

    /// The bound under the feed override last reported (at 50 % a step takes twice as long).
    pub(crate) fn effective_bound(&self) -> Duration {
        let k = 100.0 / self.feed_override.clamp(1, 200) as f64;
        self.bound.mul_f64(k.max(1.0))
    }

    /// Take a status report seen at `now`; `busy` = lines still in flight or planner blocks in
    /// use. Returns the stall once the machine has stood still in `Run` past the bound.
    pub(crate) fn observe(&mut self, now: Duration, st: &Status, busy: bool) -> Option<Stall> {
        if let Some([f, _, _]) = st.overrides {
            self.feed_override = f;
        }
        let pos = st.position()?;
        if st.state != MachineState::Run || !busy {
            self.since = None;
            return None;
        }
        match self.since {
            Some((t0, p0)) if p0 == pos => {
                let still = now.saturating_sub(t0);
                let bound = self.effective_bound();
                (still > bound).then_some(Stall {
                    still_for: still,
                    bound,
                    position: pos,
                })
            }
            _ => {
                self.since = Some((now, pos));
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::Reply;

    fn status(s: &str) -> Status {
        match Reply::parse(s) {
            Reply::Status(st) => st,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_still_machine_in_run_is_a_stall_after_the_bound_only() {
        let mut w = StallWatch::new(Duration::from_secs(10));
        let run = status("<Run|MPos:1.000,2.000,0.000|Bf:10,100|FS:600,0>");
        let s = |t: u64| Duration::from_secs(t);
        assert_eq!(w.observe(s(0), &run, true), None);
        assert_eq!(w.observe(s(10), &run, true), None);
        let st = w.observe(s(11), &run, true).unwrap();
        assert_eq!((st.still_for, st.bound), (s(11), s(10)));
        // Moving resets the watch.
        let moved = status("<Run|MPos:1.001,2.000,0.000|Bf:10,100|FS:600,0>");
        assert_eq!(w.observe(s(12), &moved, true), None);
        assert_eq!(w.observe(s(21), &moved, true), None);
        // A hold, idle, or nothing left to do is never a stall.
        let mut w = StallWatch::new(s(10));
        let hold = status("<Hold:0|MPos:1.000,2.000,0.000|Bf:10,100|FS:0,0>");
        for t in [0, 100, 1000] {
            assert_eq!(w.observe(s(t), &hold, true), None);
            assert_eq!(w.observe(s(t), &run, false), None);
        }
        // A feed override of 50 % doubles the bound.
        let mut w = StallWatch::new(s(10));
        let slow = status("<Run|MPos:1.000,2.000,0.000|Bf:10,100|FS:300,0|Ov:50,100,100>");
        assert_eq!(w.observe(s(0), &slow, true), None);
        assert_eq!(w.observe(s(19), &run, true), None);
        assert!(w.observe(s(21), &run, true).is_some());
    }

    #[test]
    fn the_bound_comes_from_the_jobs_own_speeds() {
        // 100 mm at 600 mm/min = 10 s; a 30 mm G0 at 3000 mm/min = 0.6 s.
        let job = Program::parse("j", "G0 X30\nG1 X130 F600\nG1 X131\n").unwrap();
        assert_eq!(slowest_step(&job, Some(3000.0)), Duration::from_secs(10));
        assert_eq!(
            stall_bound(Duration::from_secs(10)),
            Duration::from_secs(20)
        );
        // Rapid rate unknown: G0 timed at the slowest feed (30 mm at 60 mm/min = 30 s).
        let job = Program::parse("j", "G0 X30\nG1 X31 F60\n").unwrap();
        assert_eq!(slowest_step(&job, None), Duration::from_secs(30));
        // A dwell longer than any move counts.
        let job = Program::parse("j", "G1 X1 F600\nG4 P12.5\n").unwrap();
        assert_eq!(slowest_step(&job, None), Duration::from_secs_f64(12.5));
    }
}
