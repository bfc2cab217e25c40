//! The planner: moves queued in machine coordinates and run at their feeds (or at once, by the
//! pace), and the head's position along them.

use std::time::Instant;

use stencil_gcode::interpret::Move;

use super::config::Pace;
use super::record::{lock, PlannedMove};
use super::sim::{Block, Sim, State};
use crate::program::n_word;

impl Sim {
    pub(super) fn advance(&mut self, now: Instant) {
        let dt = now.saturating_duration_since(self.last_tick).as_secs_f64();
        self.last_tick = now;
        let Pace::Timed { speedup } = self.cfg.pace else {
            return;
        };
        if self.frozen || self.state != State::Idle {
            return;
        }
        let dt = dt * speedup.max(1e-9);
        if self.hold {
            // Slowing down to rest: the speed falls linearly to zero over the deceleration
            // time, so the head covers the ramp's share of its programmed motion.
            let Some((left, total)) = self.hold_decel else {
                return;
            };
            let step = dt.min(left);
            self.run_planner((left * step - step * step / 2.0) / total);
            self.hold_decel = (left - step > 1e-9).then_some((left - step, total));
            return;
        }
        self.run_planner(dt);
    }

    /// Run `budget` seconds of the queued motion at its programmed (overridden) rate.
    fn run_planner(&mut self, mut budget: f64) {
        let [feed_ov, rapid_ov, _] = self.ov;
        while budget > 0.0 {
            let Some(b) = self.planner.front_mut() else {
                break;
            };
            // Overrides scale the rate: a block at 110 % takes 1/1.1 of its programmed time.
            let k = if b.mv.rapid { rapid_ov } else { feed_ov } as f64 / 100.0;
            if b.remaining_s > budget * k {
                b.remaining_s -= budget * k;
                break;
            }
            budget -= b.remaining_s / k;
            let done = self.planner.pop_front();
            if let Some(done) = done.filter(|d| d.last) {
                lock(&self.shared).executed.push(done.idx);
            }
        }
    }

    /// The simulated tool position: the end of the last finished move, or part way along the
    /// current one.
    pub(super) fn position(&self) -> [f64; 3] {
        match self.planner.front() {
            Some(b) => {
                let f = if b.duration_s > 0.0 {
                    1.0 - b.remaining_s / b.duration_s
                } else {
                    1.0
                };
                [0, 1, 2].map(|a| b.mv.from[a] + (b.mv.to[a] - b.mv.from[a]) * f)
            }
            None => self.modal.pos,
        }
    }

    pub(super) fn plan(&mut self, mv: Move, idx: usize) -> bool {
        if self.planner.len() >= self.cfg.planner_blocks {
            return false;
        }
        // The parser's moves are in machine coordinates already, offsets applied; the spindle
        // runs at S clamped to $30/$31, as Grbl's PWM (and its `FS:` report) does.
        let mv = Move {
            power: self.spindle_clamp(mv.power),
            spindle_s: self.spindle_clamp(mv.spindle_s),
            ..mv
        };
        let last = self.pending_rest.is_empty();
        let laser_mode = self.laser_mode();
        let jog = {
            let mut r = lock(&self.shared);
            let jog = r
                .received
                .get(idx)
                .is_some_and(|l| l.text.starts_with("$J"));
            let m = &self.modal;
            r.moves.push(PlannedMove {
                from: mv.from,
                to: mv.to,
                rapid: mv.rapid,
                spindle_on: m.spindle_on,
                beam: m.spindle_on && m.s > 0.0 && !((mv.rapid || jog) && laser_mode),
                air: m.coolant,
                idx,
            });
            jog
        };
        match self.cfg.pace {
            Pace::Instant if last => lock(&self.shared).executed.push(idx),
            Pace::Instant => {}
            Pace::Timed { .. } => {
                let rate = if mv.rapid {
                    self.cfg.rapid_mm_min
                } else {
                    mv.feed
                };
                let t = if rate > 0.0 {
                    mv.length() / rate * 60.0
                } else {
                    0.0
                };
                let n = lock(&self.shared)
                    .received
                    .get(idx)
                    .and_then(|r| n_word(&r.text));
                self.planner.push_back(Block {
                    mv,
                    n,
                    idx,
                    remaining_s: t,
                    duration_s: t,
                    jog,
                    last,
                });
            }
        }
        true
    }

    /// S as Grbl's spindle runs it (spindle_control.c): 0 stays off, at or above `$30` runs at
    /// `$30`, at or below `$31` at `$31`.
    fn spindle_clamp(&self, s: f64) -> f64 {
        let max = self.setting(30).unwrap_or(1000.0);
        let min = self.setting(31).unwrap_or(0.0);
        if s <= 0.0 {
            0.0
        } else if s >= max {
            max
        } else if s <= min {
            min
        } else {
            s
        }
    }
}
