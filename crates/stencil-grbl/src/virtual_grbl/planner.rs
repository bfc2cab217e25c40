//! The planner: moves queued in machine coordinates and run at their feeds (or at once, by the
//! pace), the head's position along them, and the work offset (`G10 L2/L20 P1`).

use std::time::Instant;

use stencil_gcode::interpret::{self as gcode, Move};

use super::sim::{Sim, State};
use super::{add, lock, Pace, PlannedMove};

/// A move in the planner queue.
pub(super) struct Block {
    pub(super) mv: Move,
    /// The line's N number, if it has one (reported as `Ln:`).
    pub(super) n: Option<u32>,
    /// Index into the record's `received`.
    pub(super) idx: usize,
    pub(super) remaining_s: f64,
    pub(super) duration_s: f64,
    /// A `$J=` jog: shown as `Jog`, dropped by a jog cancel (0x85).
    pub(super) jog: bool,
}

/// The N number a line starts with (`N120G1X5` → 120).
fn line_number(text: &str) -> Option<u32> {
    let rest = text.strip_prefix('N').or_else(|| text.strip_prefix('n'))?;
    let end = rest
        .find(|c: char| !c.is_ascii_digit())
        .unwrap_or(rest.len());
    rest[..end].parse().ok()
}

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
            if let Some(done) = done {
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
                let mut p = [0.0; 3];
                for (a, v) in p.iter_mut().enumerate() {
                    *v = b.mv.from[a] + (b.mv.to[a] - b.mv.from[a]) * f;
                }
                p
            }
            None => add(self.modal.pos, self.wco),
        }
    }

    pub(super) fn plan(&mut self, mv: Move, idx: usize) -> bool {
        if self.planner.len() >= self.cfg.planner_blocks {
            return false;
        }
        // Blocks run in machine coordinates: the work offset in force when the line was parsed.
        let mv = Move {
            from: add(mv.from, self.wco),
            to: add(mv.to, self.wco),
            ..mv
        };
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
            Pace::Instant => lock(&self.shared).executed.push(idx),
            Pace::Timed { .. } => {
                let d = ((mv.to[0] - mv.from[0]).powi(2)
                    + (mv.to[1] - mv.from[1]).powi(2)
                    + (mv.to[2] - mv.from[2]).powi(2))
                .sqrt();
                let rate = if mv.rapid {
                    self.cfg.rapid_mm_min
                } else {
                    mv.feed
                };
                let t = if rate > 0.0 { d / rate * 60.0 } else { 0.0 };
                let n = lock(&self.shared)
                    .received
                    .get(idx)
                    .and_then(|r| line_number(&r.text));
                self.planner.push_back(Block {
                    mv,
                    n,
                    idx,
                    remaining_s: t,
                    duration_s: t,
                    jog,
                });
            }
        }
        true
    }

    /// `G92 X.. Y..`: the current position becomes these work coordinates, until a reset or a
    /// power loss (Grbl 1.1 clears G92 in `gc_init`); only axis words are taken here.
    pub(super) fn set_g92(&mut self, clean: &str, idx: usize) {
        let words = match gcode::words(clean, idx + 1) {
            Ok(w) => w,
            Err(e) => return self.reply_error(e.code),
        };
        let mut axes = [None::<f64>; 3];
        for (w, v) in words {
            match w {
                'G' if v == 92.0 => {}
                'X' => axes[0] = Some(v),
                'Y' => axes[1] = Some(v),
                'Z' => axes[2] = Some(v),
                _ => return self.reply_error(20),
            }
        }
        if axes.iter().all(Option::is_none) {
            return self.reply_error(26);
        }
        if self.check_mode {
            return self.done(idx);
        }
        let unit = if self.modal.metric { 1.0 } else { 25.4 };
        for (a, v) in axes.into_iter().enumerate() {
            if let Some(v) = v {
                let machine = self.modal.pos[a] + self.wco[a];
                let wco = machine - v * unit;
                self.g92[a] += wco - self.wco[a];
                self.wco[a] = wco;
                self.modal.pos[a] = v * unit;
            }
        }
        self.wco_changed = true;
        self.done(idx);
    }

    /// A reset or power loss drops the G92 part of the work offset.
    pub(super) fn clear_g92(&mut self) {
        for a in 0..3 {
            let machine = self.modal.pos[a] + self.wco[a];
            self.wco[a] -= self.g92[a];
            self.modal.pos[a] = machine - self.wco[a];
        }
        if self.g92 != [0.0; 3] {
            self.wco_changed = true;
        }
        self.g92 = [0.0; 3];
    }

    /// `G10 L20 P1 X.. Y..` (the current position becomes these work coordinates) and
    /// `G10 L2 P1 X..` (G54's offset itself). P0 is the active system, here always G54; P2..P6
    /// are taken and kept nowhere (nothing here selects them). The offset counts from the end
    /// of the queued motion, as Grbl (which waits for the queue to empty first) would see it.
    pub(super) fn set_work_offset(&mut self, clean: &str, idx: usize) {
        let words = match gcode::words(clean, idx + 1) {
            Ok(w) => w,
            Err(e) => return self.reply_error(e.code),
        };
        let (mut l, mut p, mut axes) = (None, None, [None::<f64>; 3]);
        for (w, v) in words {
            match w {
                'G' if v == 10.0 => {}
                'L' => l = Some(v),
                'P' => p = Some(v),
                'X' => axes[0] = Some(v),
                'Y' => axes[1] = Some(v),
                'Z' => axes[2] = Some(v),
                _ => return self.reply_error(20),
            }
        }
        let Some(p) = p else {
            return self.reply_error(28);
        };
        let l20 = match l {
            Some(20.0) => true,
            Some(2.0) => false,
            _ => return self.reply_error(28),
        };
        if !(0.0..=6.0).contains(&p) || p.fract() != 0.0 {
            return self.reply_error(29);
        }
        if self.check_mode || p > 1.0 {
            return self.done(idx);
        }
        let unit = if self.modal.metric { 1.0 } else { 25.4 };
        for (a, v) in axes.into_iter().enumerate() {
            if let Some(v) = v {
                let machine = self.modal.pos[a] + self.wco[a];
                self.wco[a] = if l20 { machine - v * unit } else { v * unit };
                self.modal.pos[a] = machine - self.wco[a];
            }
        }
        self.wco_changed = true;
        self.done(idx);
    }
}
