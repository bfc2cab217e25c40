//! Job time estimate from the moves of a G-code program, the way Grbl 1.1 plans motion.
//!
//! CONTRACT (used by `stencil estimate`, `stencil simulate` and the virtual Grbl): keep these names.
//!
//! Each move is a block with a nominal speed (its feed, clamped to the machine's max feed, or the
//! rapid rate for G0) and an acceleration. As in Grbl's `planner.c`:
//! - the speed through the junction between two blocks is limited by the junction deviation δ:
//!   with θ the angle between the directions and `sin(θ/2) = sqrt((1 - cos θ)/2)` where
//!   `cos θ = -u_prev·u`, `v_j² = a_j · δ · sin(θ/2) / (1 - sin(θ/2))` (a reversal stops; a
//!   straight continuation is not limited), and by both blocks' nominal speeds;
//! - a reverse pass over the blocks Grbl holds (the last held ending at rest) and a forward pass
//!   from the running block's entry make every entry speed reachable by accelerating or braking
//!   at `a` over the block's length;
//! - each block then runs a trapezoid (accelerate, cruise, decelerate) or a triangle if short.
//!
//! Blocks are limited by their tightest axis (`$110`..`$112`, `$120`..`$122` where a controller's
//! `$$` gives them) and, with the steps per mm known, run between whole steps as Grbl rounds them.
//! Grbl holds 15 blocks (`[OPT:V,15,128]`), the running one included, and plans the last one it
//! holds to end at rest: each block's exit speed is planned over that window only, and never
//! across a point where Grbl empties its planner (a sync: M3/M4/M5, M8/M9, G4, M0, ...; see
//! [`Program::stops`]), where [`estimate_program`] also adds `$1`'s motor hold.
//!
//! Arcs come in as the chords Grbl cuts them into (`$12`), so their junctions are planned as
//! Grbl plans them. Checked against Grbl 1.1h itself (grbl-sim, in simulated time): within 0.5 %
//! on nine jobs, docs/estimate-vs-grbl-sim.md, which also lists what is not modelled (the serial
//! link, the AVR's own time, overrides).

use crate::interpret::{CutRule, Move, Program};
use crate::limits::PLANNER_BLOCKS;
use crate::machine::Motion;

/// What a job costs in time and distance.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Estimate {
    /// The whole program, s.
    pub total_s: f64,
    /// Moving with the tool cutting, s.
    pub cut_s: f64,
    /// Moving with the tool off, s.
    pub travel_s: f64,
    /// Length of moves with the tool on, mm.
    pub cut_mm: f64,
    /// Length of moves with the tool off, mm.
    pub travel_mm: f64,
}

/// One planned block.
pub(crate) struct Block {
    /// Length, mm.
    pub(crate) len: f64,
    /// Nominal speed, mm/s.
    pub(crate) v_nom: f64,
    /// Acceleration along the block, mm/s².
    pub(crate) accel: f64,
    /// Highest entry speed², from the junction and the nominal speeds.
    pub(crate) max_entry_sq: f64,
    /// Grbl emptied its planner before this block (a sync): it starts from a standstill, and the
    /// block before it ends in one.
    pub(crate) stop_before: bool,
    /// The tool cuts along it.
    pub(crate) cut: bool,
    /// The index of its move (moves without a step make no block).
    pub(crate) mv: usize,
}

/// `limit` per axis X, Y, Z, scaled to a direction as Grbl's `limit_value_by_axis_maximum`
/// does: the tightest axis wins.
fn limit_by_axis(limit: [f64; 3], unit: &[f64; 3]) -> f64 {
    unit.iter()
        .zip(limit)
        .filter(|(c, _)| c.abs() > 1e-12)
        .map(|(c, l)| l / c.abs())
        .fold(f64::INFINITY, f64::min)
}

/// Time to run `len` mm entering at `v0`, leaving at `v1`, cruising at most at `vn`, accelerating
/// at `a` (all speeds in mm/s).
pub(crate) fn block_time(len: f64, v0: f64, v1: f64, vn: f64, a: f64) -> f64 {
    if len <= 0.0 {
        return 0.0;
    }
    let d_acc = (vn * vn - v0 * v0).max(0.0) / (2.0 * a);
    let d_dec = (vn * vn - v1 * v1).max(0.0) / (2.0 * a);
    if d_acc + d_dec <= len {
        (vn - v0).max(0.0) / a + (vn - v1).max(0.0) / a + (len - d_acc - d_dec) / vn
    } else {
        // Triangle: the peak speed where the acceleration and braking ramps meet.
        let vp = ((2.0 * a * len + v0 * v0 + v1 * v1) / 2.0).sqrt();
        (vp - v0).max(0.0) / a + (vp - v1).max(0.0) / a
    }
}

/// Estimate a program's run time; which moves cut is [`CutRule::infer`]red from the program.
pub fn estimate(moves: &[Move], limits: &Motion) -> Estimate {
    estimate_with(moves, limits, CutRule::infer(moves))
}

/// Estimate with a given cut rule (a machine profile may refine the inferred one, see
/// [`CutRule::for_spindle_pen`]). The rule only splits time and length into cut and travel.
/// The moves are taken as one stream without stops between them; [`estimate_program`] also
/// knows where Grbl stops (its syncs) and its dwells.
pub fn estimate_with(moves: &[Move], limits: &Motion, rule: CutRule) -> Estimate {
    estimate_stops(moves, &[], limits, rule)
}

/// A whole program's time as Grbl runs it: the moves, planned with a stop wherever Grbl empties
/// its planner ([`Program::stops`]), plus `$1`'s motor hold at each of those stops and the G4
/// dwells. `total_s` is the whole; `cut_s + travel_s` is the time in motion.
pub fn estimate_program(program: &Program, limits: &Motion, rule: CutRule) -> Estimate {
    let mut e = estimate_stops(&program.moves, &program.stops, limits, rule);
    e.total_s += program.dwell_s + program.stops.len() as f64 * limits.stop_lock_s();
    e
}

/// What is left of a program once the moves before `first` have run (a sender's remaining
/// time): the moves from `first` on, planned from a standstill with the stops after it, plus the
/// motor holds and dwells still to come (a stop or dwell just before move `first` is to come: the
/// moves before it have run, it has not). From move 0 it is [`estimate_program`].
pub fn estimate_program_from(
    program: &Program,
    first: usize,
    limits: &Motion,
    rule: CutRule,
) -> Estimate {
    let first = first.min(program.moves.len());
    let stops: Vec<usize> = program
        .stops
        .iter()
        .filter(|&&s| s > first)
        .map(|&s| s - first)
        .collect();
    let holds = program.stops.iter().filter(|&&s| s >= first).count();
    let dwell_s: f64 = program
        .dwells
        .iter()
        .filter(|&&(m, _)| m >= first)
        .map(|&(_, s)| s)
        .sum();
    let mut e = estimate_stops(&program.moves[first..], &stops, limits, rule);
    e.total_s += dwell_s + holds as f64 * limits.stop_lock_s();
    e
}

fn estimate_stops(moves: &[Move], stops: &[usize], limits: &Motion, rule: CutRule) -> Estimate {
    let mut e = Estimate::default();
    let blocks = blocks(moves, stops, limits, rule, &mut e);
    if blocks.is_empty() {
        return e;
    }
    add_block_times(&blocks, plan_exit_speeds(&blocks), &mut e);
    e.total_s = e.cut_s + e.travel_s;
    e
}

/// Add to `e`'s cut and travel times each block's, run from rest with these exit speeds².
pub(crate) fn add_block_times(blocks: &[Block], exits: Vec<f64>, e: &mut Estimate) {
    let mut entry_sq: f64 = 0.0;
    for (b, exit_sq) in blocks.iter().zip(exits) {
        let t = block_time(b.len, entry_sq.sqrt(), exit_sq.sqrt(), b.v_nom, b.accel);
        entry_sq = exit_sq;
        if b.cut {
            e.cut_s += t;
        } else {
            e.travel_s += t;
        }
    }
}

/// The moves as Grbl's planner blocks, each with its nominal speed, acceleration and the highest
/// entry speed its junction allows; adds each move's length to `e`'s cut or travel.
///
/// With the machine's steps per mm known, each block runs between whole steps as Grbl's
/// `plan_buffer_line` makes it (`lround` of the target, length and direction from the step
/// counts), and a move shorter than half a step is no block at all.
pub(crate) fn blocks(
    moves: &[Move],
    stops: &[usize],
    limits: &Motion,
    rule: CutRule,
    e: &mut Estimate,
) -> Vec<Block> {
    let (rates, accels) = limits.axes();
    let feed_rates = rates.map(|r| r.min(limits.max_feed_mm_min));
    let mut blocks: Vec<Block> = Vec::with_capacity(moves.len());
    let mut prev: Option<(f64, [f64; 3])> = None;
    let mut steps_at: Option<[f64; 3]> = None;
    let mut stop_pending = false;
    let mut next_stop = stops.iter().peekable();
    for (k, m) in moves.iter().enumerate() {
        while next_stop.next_if(|&&s| s <= k).is_some() {
            stop_pending = true;
        }
        let exact_len = m.length();
        let cut = rule.cuts(m);
        if cut {
            e.cut_mm += exact_len;
        } else {
            e.travel_mm += exact_len;
        }
        let d = match limits.steps() {
            Some(spm) => {
                let at =
                    steps_at.unwrap_or_else(|| [0, 1, 2].map(|a| (m.from[a] * spm[a]).round()));
                let to = [0, 1, 2].map(|a| (m.to[a] * spm[a]).round());
                steps_at = Some(to);
                [0, 1, 2].map(|a| (to[a] - at[a]) / spm[a])
            }
            None => [0, 1, 2].map(|a| m.to[a] - m.from[a]),
        };
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if len < 1e-9 {
            continue; // Grbl drops blocks without a step.
        }
        let unit = [d[0] / len, d[1] / len, d[2] / len];
        let rate = if m.rapid {
            limit_by_axis(rates, &unit)
        } else {
            m.feed.min(limit_by_axis(feed_rates, &unit)).max(1.0) // Grbl's minimum feed rate, 1 mm/min.
        };
        let v_nom = rate / 60.0;
        let accel = limit_by_axis(accels, &unit);
        let max_entry_sq = match prev {
            None => 0.0,
            Some((pv, pu)) => junction_sq(pu, unit, accels, limits.junction_deviation_mm)
                .min(v_nom * v_nom)
                .min(pv * pv),
        };
        prev = Some((v_nom, unit));
        blocks.push(Block {
            len,
            v_nom,
            accel,
            max_entry_sq,
            stop_before: std::mem::take(&mut stop_pending),
            cut,
            mv: k,
        });
    }
    blocks
}

/// The highest speed² through the junction from direction `pu` to `unit` that the junction
/// deviation allows (a reversal stops; a straight continuation is not limited).
fn junction_sq(pu: [f64; 3], unit: [f64; 3], accels: [f64; 3], deviation_mm: f64) -> f64 {
    let cos_theta = -(pu[0] * unit[0] + pu[1] * unit[1] + pu[2] * unit[2]);
    if cos_theta > 0.999_999 {
        0.0 // reversal: stop
    } else if cos_theta < -0.999_999 {
        f64::INFINITY // straight on
    } else {
        let mut ju = [unit[0] - pu[0], unit[1] - pu[1], unit[2] - pu[2]];
        let jl = (ju[0] * ju[0] + ju[1] * ju[1] + ju[2] * ju[2]).sqrt();
        ju.iter_mut().for_each(|c| *c /= jl);
        let ja = limit_by_axis(accels, &ju);
        let sin_half = (0.5 * (1.0 - cos_theta)).sqrt();
        ja * deviation_mm * sin_half / (1.0 - sin_half)
    }
}

/// Every block's exit speed² (the next one's entry), as Grbl's planner leaves it when the block
/// runs: within the window of [`PLANNER_BLOCKS`] it holds (up to a sync; the module says why),
/// the reverse pass's entry speeds (within what braking over each block allows, and its
/// junction's limit), capped by what accelerating over the running block reaches from its own
/// entry (the forward pass).
pub(crate) fn plan_exit_speeds(blocks: &[Block]) -> Vec<f64> {
    plan_exit_speeds_in(blocks, PLANNER_BLOCKS)
}

/// For each block, the index one past the last block Grbl can hold with it: the next sync.
pub(crate) fn held_ends(blocks: &[Block]) -> Vec<usize> {
    let n = blocks.len();
    let mut held_end = vec![n; n];
    for i in (0..n.saturating_sub(1)).rev() {
        held_end[i] = if blocks[i + 1].stop_before {
            i + 1
        } else {
            held_end[i + 1]
        };
    }
    held_end
}

/// The highest entry speed² of the block after the held blocks `later` that still lets the
/// last of them end at rest (Grbl's reverse pass).
pub(crate) fn reverse_pass(later: &[Block]) -> f64 {
    let mut next_entry_sq = 0.0;
    for b in later.iter().rev() {
        next_entry_sq = b.max_entry_sq.min(next_entry_sq + 2.0 * b.accel * b.len);
    }
    next_entry_sq
}

/// [`plan_exit_speeds`] for a planner of `window` blocks.
pub(crate) fn plan_exit_speeds_in(blocks: &[Block], window: usize) -> Vec<f64> {
    let held_end = held_ends(blocks);
    let mut exits = Vec::with_capacity(blocks.len());
    let mut entry_sq = 0.0;
    for (i, b) in blocks.iter().enumerate() {
        let end = held_end[i].min(i + window);
        let next_entry_sq = reverse_pass(&blocks[i + 1..end]);
        let exit_sq = next_entry_sq.min(entry_sq + 2.0 * b.accel * b.len);
        exits.push(exit_sq);
        entry_sq = exit_sq;
    }
    exits
}

/// What length ÷ feed says (no acceleration): the number many senders show, for comparison.
pub fn length_over_feed_s(moves: &[Move], limits: &Motion) -> f64 {
    moves
        .iter()
        .map(|m| {
            let rate = if m.rapid {
                limits.rapid_mm_min
            } else {
                m.feed.min(limits.max_feed_mm_min).max(1.0)
            };
            m.length() / rate * 60.0
        })
        .sum()
}

/// `1 h 02 min 03 s` style, for people.
pub fn format_duration(s: f64) -> String {
    let t = s.max(0.0).round() as u64;
    let (h, m, sec) = (t / 3600, (t % 3600) / 60, t % 60);
    if h > 0 {
        format!("{h} h {m:02} min {sec:02} s")
    } else if m > 0 {
        format!("{m} min {sec:02} s")
    } else {
        format!("{sec} s")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interpret::{interpret, interpret_program};

    /// A generic GRBL 1.1 diode laser: 100 mm/s rapid and max feed, 1000 mm/s², Grbl's default
    /// junction deviation.
    fn diode() -> Motion {
        Motion {
            max_feed_mm_min: 6000.0,
            rapid_mm_min: 6000.0,
            accel_mm_s2: 1000.0,
            junction_deviation_mm: 0.01,
            homing: false,
            axis_rate_mm_min: None,
            axis_accel_mm_s2: None,
            steps_per_mm: None,
            profile_steps_per_mm: None,
            idle_lock_ms: None,
        }
    }

    #[test]
    fn block_time_trapezoid_and_triangle() {
        // 100 mm from rest to rest at 10 mm/s, a = 100: ramps 0.1 s and 0.5 mm each, cruise 99 mm.
        let t = block_time(100.0, 0.0, 0.0, 10.0, 100.0);
        assert!((t - (0.2 + 9.9)).abs() < 1e-9, "{t}");
        // 1 mm at up to 100 mm/s, a = 100: triangle with peak sqrt(100) = 10 mm/s, 0.2 s.
        let t = block_time(1.0, 0.0, 0.0, 100.0, 100.0);
        assert!((t - 0.2).abs() < 1e-9, "{t}");
    }

    #[test]
    fn straight_line_split_in_two_does_not_stop_in_the_middle() {
        let l = diode();
        let one = estimate(&interpret("G1 X100 F3000").unwrap(), &l);
        let two = estimate(&interpret("G1 X50 F3000\nG1 X100").unwrap(), &l);
        assert!((one.total_s - two.total_s).abs() < 1e-9);
        let back = estimate(&interpret("G1 X50 F3000\nG1 X0").unwrap(), &l);
        // A reversal stops: two full trapezoids.
        let t = 2.0 * block_time(50.0, 0.0, 0.0, 50.0, 1000.0);
        assert!((back.total_s - t).abs() < 1e-9);
    }

    #[test]
    fn look_ahead_limits_speed_on_tiny_segments() {
        // 2000 collinear 0.05 mm segments at a high rapid: without the window the head would
        // reach 100 mm/s; with 15 blocks (0.75 mm) it may only reach sqrt(2·1000·0.75) ≈ 38.7 mm/s.
        let mut p = String::from("G1 F6000\n");
        for i in 1..=2000 {
            p.push_str(&format!("X{:.2}\n", i as f64 * 0.05));
        }
        let e = estimate(&interpret(&p).unwrap(), &diode());
        let unlimited = block_time(100.0, 0.0, 0.0, 100.0, 1000.0);
        assert!(e.total_s > unlimited * 2.0, "{} vs {unlimited}", e.total_s);
        assert!((e.travel_mm + e.cut_mm - 100.0).abs() < 1e-6);
    }

    #[test]
    fn z_tool_programs_count_xy_feed_moves_as_cut() {
        let p = "G0 Z3\nG0 X10\nG1 Z-0.3 F300\nG1 X20 F1000\nG0 Z3\nG0 X0\n";
        let e = estimate(&interpret(p).unwrap(), &diode());
        assert!((e.cut_mm - 10.0).abs() < 1e-9, "{e:?}");
        assert!(
            (e.travel_mm - (3.0 + 10.0 + 3.3 + 3.3 + 20.0)).abs() < 1e-9,
            "{e:?}"
        );
        // A laser program: only powered moves cut, even if G1 moves without power exist.
        let p = "M4 S0 F1000\nG1 X10\nG1 X20 S500\nM5\nG0 X0\n";
        let e = estimate(&interpret(p).unwrap(), &diode());
        assert!((e.cut_mm - 10.0).abs() < 1e-9 && (e.travel_mm - 30.0).abs() < 1e-9);
    }

    #[test]
    fn acceleration_only_adds_time() {
        let p = "G1 X10 Y0 F3000\nG1 X10 Y10\nG0 X0 Y0\n";
        let m = interpret(p).unwrap();
        let l = diode();
        let naive = length_over_feed_s(&m, &l);
        // 20 mm at 50 mm/s plus 14.14 mm at 100 mm/s.
        assert!((naive - (0.4 + 200f64.sqrt() / 100.0)).abs() < 1e-9);
        assert!(estimate(&m, &l).total_s > naive);
    }

    #[test]
    fn grbl_stops_where_it_empties_its_planner() {
        // A straight 100 mm cut at 50 mm/s, with M5/M4 in the middle: Grbl syncs on each
        // spindle state change, so the head stops at X50 and holds the motors $1 = 25 ms.
        let l = diode();
        let through = interpret_program("M4 S100\nG1 X50 F3000\nG1 X100\n").unwrap();
        let stopped = interpret_program("M4 S100\nG1 X50 F3000\nM5\nM4\nG1 X100\n").unwrap();
        assert_eq!(stopped.stops, vec![1]);
        assert!(through.stops.is_empty());
        let rule = CutRule::Spindle;
        let a = estimate_program(&through, &l, rule).total_s;
        let b = estimate_program(&stopped, &l, rule).total_s;
        let want = 2.0 * block_time(50.0, 0.0, 0.0, 50.0, 1000.0) + 0.025;
        assert!((b - want).abs() < 1e-9, "{b} vs {want}");
        assert!((a - block_time(100.0, 0.0, 0.0, 50.0, 1000.0)).abs() < 1e-9);
        // Laser mode: an S change on a motion line is no stop; alone on its line it is one.
        let p = interpret_program("M4 S100\nG1 X50 F3000\nG1 X100 S200\nS300\nG1 X150\n").unwrap();
        assert_eq!(p.stops, vec![2]);
        // A dwell stops and waits; the estimate's total has both.
        let p = interpret_program("G1 X50 F3000\nG4 P1.5\nG1 X100\n").unwrap();
        assert_eq!(p.stops, vec![1]);
        let t = estimate_program(&p, &l, CutRule::Feed).total_s;
        assert!((t - (2.0 * block_time(50.0, 0.0, 0.0, 50.0, 1000.0) + 1.5 + 0.025)).abs() < 1e-9);
    }

    #[test]
    fn what_is_left_has_the_stops_and_dwells_still_to_come() {
        // Two passes, each with its spindle switched on and off, a dwell between them: what is
        // left from each move on is the estimate of the program's tail run on its own from a
        // standstill (the same lines, from that move's line, in the state the lines before
        // leave), stops, holds and dwells included; from move 0 it is the whole estimate.
        let l = diode();
        let lines = [
            "G21 G90 F3000",
            "G0 X10 Y10",
            "M4 S500",
            "G1 X60",
            "G1 Y40",
            "M5",
            "G4 P0.75",
            "G0 X20 Y50",
            "M4 S300",
            "G1 X80 Y90",
            "G1 X20",
            "M5",
            "G4 P0.5",
            "G0 X0 Y0",
        ];
        let text = lines.join("\n");
        let p = interpret_program(&text).unwrap();
        assert_eq!(p.dwells.len(), 2);
        assert!(p.stops.len() >= 3, "{:?}", p.stops);
        let rule = CutRule::Spindle;
        let whole = estimate_program(&p, &l, rule);
        assert_eq!(estimate_program_from(&p, 0, &l, rule), whole);
        let mut last = whole.total_s;
        for k in 1..=p.moves.len() {
            let got = estimate_program_from(&p, k, &l, rule).total_s;
            let tail = if k == p.moves.len() {
                0.0
            } else {
                // The tail's lines from the one after the move before (so the spindle changes
                // and dwells between them are the tail's), after the modal lines before them
                // (units, feed, spindle state) replayed without motion, and G92 saying the head
                // stands where the move before ended.
                let line = p.moves[k - 1].line + 1;
                let at = p.moves[k - 1].to;
                let mut t = format!("G21 G90 F3000\nG92 X{} Y{}\n", at[0], at[1]);
                let on = lines[..line - 1].iter().rev().find(|l| l.starts_with('M'));
                if let Some(m) = on.filter(|m| m.starts_with("M4")) {
                    t.push_str(m);
                    t.push('\n');
                }
                t.push_str(&lines[line - 1..].join("\n"));
                let tail = interpret_program(&t).unwrap();
                assert_eq!(tail.moves.len(), p.moves.len() - k, "move {k}");
                // A stop just before move k is still to come (the move before it is running):
                // its hold counts; the tail, starting from rest there, has none.
                let hold = if p.stops.contains(&k) {
                    l.stop_lock_s()
                } else {
                    0.0
                };
                estimate_program(&tail, &l, rule).total_s + hold
            };
            assert!((got - tail).abs() < 1e-9, "move {k}: {got} vs {tail}");
            assert!(got <= last + 1e-12, "move {k}: what is left grew");
            last = got;
        }
        // Without the stops and dwells (what `send` showed before) the job's time is short by
        // at least the dwells.
        let plain = estimate_with(&p.moves, &l, rule).total_s;
        assert!(
            whole.total_s - plain >= 1.25,
            "{} vs {plain}",
            whole.total_s
        );
    }

    #[test]
    fn a_block_leaves_only_as_fast_as_the_held_blocks_can_stop() {
        // 100 collinear 0.1 mm blocks at up to 100 mm/s: while a block runs Grbl holds the 14
        // after it (1.4 mm), so no block leaves faster than sqrt(2·1000·1.4) ≈ 53 mm/s, where
        // the whole 10 mm line seen at once would reach 100 mm/s in its middle.
        let mut p = String::from("G1 F6000\n");
        for i in 1..=100 {
            p.push_str(&format!("X{:.1}\n", f64::from(i) * 0.1));
        }
        let m = interpret(&p).unwrap();
        let e = estimate(&m, &diode()).total_s;
        // Seen at once, the line is one triangle: 2·sqrt(10 / 1000) = 0.2 s. Capped at 53 mm/s:
        // two 1.4 mm ramps and 7.2 mm of cruise, 0.242 s.
        let unlimited = 2.0 * (10.0f64 / 1000.0).sqrt();
        let v = (2.0 * 1000.0 * 1.4f64).sqrt();
        let capped = 2.0 * v / 1000.0 + (10.0 - 2.8) / v;
        assert!(
            (e - capped).abs() < 0.005 && e > unlimited * 1.15,
            "{e} vs {capped}"
        );
    }

    #[test]
    fn blocks_run_between_whole_steps_and_z_at_its_own_limits() {
        // Moves to X0.012 and X0.018 at 80 steps/mm: the first rounds to one step (0.0125 mm),
        // the second to none more, so Grbl runs one block of 0.0125 mm.
        let mut l = diode();
        l.steps_per_mm = Some([80.0; 3]);
        let m = interpret("G1 X0.012 F3000\nG1 X0.018\n").unwrap();
        let e = estimate(&m, &l).total_s;
        assert!(
            (e - block_time(0.0125, 0.0, 0.0, 50.0, 1000.0)).abs() < 1e-12,
            "{e}"
        );
        // A Z plunge of 5 mm at Z's 500 mm/min and 10 mm/s², not X's 6000 and 1000.
        l.axis_rate_mm_min = Some([6000.0, 6000.0, 500.0]);
        l.axis_accel_mm_s2 = Some([1000.0, 1000.0, 10.0]);
        let e = estimate(&interpret("G0 Z5\n").unwrap(), &l).total_s;
        let want = block_time(5.0, 0.0, 0.0, 500.0 / 60.0, 10.0);
        assert!((e - want).abs() < 1e-9, "{e} vs {want}");
    }

    #[test]
    fn durations_read_well() {
        assert_eq!(format_duration(3723.4), "1 h 02 min 03 s");
        assert_eq!(format_duration(65.0), "1 min 05 s");
        assert_eq!(format_duration(4.4), "4 s");
    }
}
