//! Where a job's lines arrive slower than the machine runs them: the serial line and Grbl's
//! buffers added to the time estimate.
//!
//! Grbl plans only the blocks it holds. A sender keeps its receive buffer full (character
//! counting: the bytes of the lines not yet answered `ok` stay within the buffer), Grbl takes a
//! line out, parses it and puts its blocks in the planner (waiting while the planner is full) and
//! answers `ok`; the serial line brings `baud / 10` characters a second. While the lines come
//! faster than the blocks run, the planner stays full and the job runs as the plain estimate
//! says. When the blocks are shorter than the line can bring at the feed (a line of 20
//! characters a block of 0.1 mm: at 115200 baud 576 lines, 58 mm a second, where 6000 mm/min
//! needs 1000 lines a second), the planner runs down: it holds fewer blocks, must plan to stop
//! at the end of the last one it holds, and the head slows or stalls (a laser burns a darker dot
//! there).
//!
//! The model, block by block: each line's bytes go out as soon as the window allows (and the
//! `ok`s of the lines before it have come back), each block enters the planner when its line is
//! in and a slot is free (the block `planner_blocks` before it has run); when a block starts,
//! its exit speed is planned over the blocks held then, and again over those that arrive before
//! it must start braking (Grbl replans as blocks arrive). With the planner always full this is
//! exactly the plain estimate (tested); what it adds is the time lost where it is not, and
//! where. Not modelled: the AVR's own time to parse and plan a line (about 2 ms on a 16 MHz
//! AVR: at 115200 baud the serial line is the tighter limit for lines over 23 characters).

use crate::estimate::Estimate;
use crate::estimate::{add_block_times, block_time, blocks, held_ends, plan_exit_speeds_in};
use crate::estimate::{reverse_pass, Block};
use crate::interpret::{clean_line, CutRule, Program};
use crate::machine::{Link, Motion};

/// Bytes of Grbl's answer to each line (`ok\r\n`), which come back over the same line.
const OK_BYTES: f64 = 4.0;

/// A stretch counts as starving when it loses at least this long: less is the planner
/// catching up at the start of a job or after a stop, not a stall anyone sees.
pub const MIN_LOST_S: f64 = 0.02;

/// The most planner blocks the model plans with (a larger planner is planned as this one): the
/// time per block grows with it, and a 32-bit port's 256 blocks look ahead of any stall anyway.
pub const MAX_PLANNED_BLOCKS: u32 = 128;

/// The most times a block is replanned as blocks arrive before it brakes: each replan holds at
/// least one block more, and a job that starves receives a block or two per block it runs.
const MAX_REPLANS: usize = 8;

/// Stretches closer than this many blocks are one.
const JOIN_BLOCKS: usize = 8;

/// A stretch of a program where the planner starves: where, how much time it loses, and by how
/// much the serial line falls short.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Starve {
    /// First program line of the stretch (1-based).
    pub first_line: usize,
    /// Last program line of the stretch.
    pub last_line: usize,
    /// Where the head is when it begins, machine mm.
    pub from: [f64; 2],
    /// Where it ends, machine mm.
    pub to: [f64; 2],
    /// Seconds lost against a planner that is always full.
    pub lost_s: f64,
    /// Of which while cutting.
    pub lost_cut_s: f64,
    /// Length of the stretch, mm.
    pub length_mm: f64,
    /// The highest feed asked for in it, mm/min.
    pub feed_mm_min: f64,
    /// Lines a second the job uses up there with its planner full (the plain estimate).
    pub lines_per_s_needed: f64,
    /// Lines a second the serial line brings there.
    pub lines_per_s_link: f64,
    /// The feed the serial line keeps fed there (its characters a second over the stretch's
    /// characters per mm), mm/min.
    pub fed_mm_min: f64,
}

/// The job's time over the serial line: [`Estimate`] with the starvation's time added, and where
/// it starves (stretches losing at least [`MIN_LOST_S`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Streamed {
    /// The plain estimate plus the time lost where the planner starves.
    pub estimate: Estimate,
    /// Where the planner starves, in program order.
    pub starved: Vec<Starve>,
}

impl Streamed {
    /// Seconds lost to starvation in all.
    pub fn lost_s(&self) -> f64 {
        self.starved.iter().map(|s| s.lost_s).sum()
    }
}

/// The bytes a sender sends for each line of `text` (what Grbl keeps of it and the newline; 0
/// for a line with nothing to send), indexed by line number from 1.
fn line_bytes(text: &str) -> Vec<usize> {
    let mut out = vec![0];
    for line in text.lines() {
        let clean = clean_line(line);
        out.push(if clean.is_empty() || clean == "%" {
            0
        } else {
            clean.len() + 1
        });
    }
    out
}

/// The serial side: when each block enters Grbl's planner.
struct Serial<'a> {
    /// Characters a second.
    cps: f64,
    /// Bytes a sender may have unanswered.
    window: usize,
    /// Planner slots.
    slots: usize,
    /// Bytes of each sent line.
    bytes: Vec<usize>,
    /// Per sent line: its first block (the blocks of line k are `first[k]..first[k + 1]`).
    first: Vec<usize>,
    blocks: &'a [Block],
    /// Seconds of pause before each block (a dwell or the motor hold at a stop).
    pause: &'a [f64],
    /// When each sent line is in, and when Grbl has taken it (its blocks planned).
    rx_end: Vec<f64>,
    taken: Vec<f64>,
    /// The line being taken, and the window's first line and bytes.
    k: usize,
    win_start: usize,
    win_bytes: usize,
    /// When Grbl is done with what it has taken so far.
    t: f64,
    /// When each block entered the planner, in order.
    entry: Vec<f64>,
}

impl Serial<'_> {
    /// When block `j` enters the planner; `done[i]`, when block `i` ended, must be known for
    /// `i = j - slots` and, for a block after a stop, `j - 1`.
    fn entry(&mut self, j: usize, done: &[f64]) -> f64 {
        while self.entry.len() <= j {
            self.next(done);
        }
        self.entry[j]
    }

    /// Take the next block (and the lines without blocks before it).
    fn next(&mut self, done: &[f64]) {
        let j = self.entry.len();
        loop {
            let k = self.k;
            if self.rx_end.len() == k {
                self.receive(k);
            }
            if self.first[k + 1] > j {
                break;
            }
            // A line without blocks (or whose blocks are all in): taken once it is in.
            self.t = self.t.max(self.rx_end[k]);
            self.taken.push(self.t);
            self.k += 1;
        }
        let k = self.k;
        let mut t = self.t.max(self.rx_end[k]);
        if self.blocks[j].stop_before && j > 0 {
            t = t.max(done[j - 1] + self.pause[j]);
        }
        if j >= self.slots {
            t = t.max(done[j - self.slots]);
        }
        self.entry.push(t);
        self.t = t;
        if self.first[k + 1] == j + 1 {
            self.taken.push(t);
            self.k += 1;
        }
    }

    /// When line `k` is in: sent once the line before it is out and the lines not yet answered
    /// leave room for it.
    fn receive(&mut self, k: usize) {
        self.win_bytes += self.bytes[k];
        while self.win_bytes > self.window && self.win_start < k {
            self.win_bytes -= self.bytes[self.win_start];
            self.win_start += 1;
        }
        let free = match self.win_start {
            0 => 0.0,
            s => self.taken[s - 1] + OK_BYTES / self.cps,
        };
        let prev = if k == 0 { 0.0 } else { self.rx_end[k - 1] };
        self.rx_end
            .push(prev.max(free) + self.bytes[k] as f64 / self.cps);
    }
}

/// Time from entering at `v0` until braking to `v1` starts, on a block run as [`block_time`]
/// runs it.
fn until_braking(len: f64, v0: f64, v1: f64, vn: f64, a: f64) -> f64 {
    let t = block_time(len, v0, v1, vn, a);
    let d_acc = (vn * vn - v0 * v0).max(0.0) / (2.0 * a);
    let d_dec = (vn * vn - v1 * v1).max(0.0) / (2.0 * a);
    let peak = if d_acc + d_dec <= len {
        vn
    } else {
        ((2.0 * a * len + v0 * v0 + v1 * v1) / 2.0).sqrt()
    };
    (t - (peak - v1).max(0.0) / a).max(0.0)
}

/// A program's time sent over `link` from `text` (the program's own text: its lines' bytes),
/// and where the planner starves. From a standstill with the first line sent at 0; the time
/// counts from the first block's start, as the plain estimate does.
pub fn estimate_streamed(
    program: &Program,
    text: &str,
    limits: &Motion,
    link: &Link,
    rule: CutRule,
) -> Streamed {
    let mut base = Estimate::default();
    let blocks = blocks(&program.moves, &program.stops, limits, rule, &mut base);
    let slots = planner_slots(link);
    add_block_times(&blocks, plan_exit_speeds_in(&blocks, slots), &mut base);
    let (lost, base_t) = lost_per_block(program, text, &blocks, limits, link);
    let starved = stretches(program, text, &blocks, &lost, &base_t, link);
    let mut estimate = base;
    estimate.cut_s += starved.iter().map(|s| s.lost_cut_s).sum::<f64>();
    estimate.travel_s += starved.iter().map(|s| s.lost_s - s.lost_cut_s).sum::<f64>();
    estimate.total_s = estimate.cut_s
        + estimate.travel_s
        + program.dwell_s
        + program.stops.len() as f64 * limits.stop_lock_s();
    Streamed { estimate, starved }
}

/// The planner blocks the model plans with.
fn planner_slots(link: &Link) -> usize {
    link.planner_blocks.clamp(2, MAX_PLANNED_BLOCKS) as usize
}

/// For each block: how much longer it takes (waiting included) over the serial line than
/// with the planner always full, and how long it takes then.
fn lost_per_block(
    program: &Program,
    text: &str,
    blocks: &[Block],
    limits: &Motion,
    link: &Link,
) -> (Vec<f64>, Vec<f64>) {
    let n = blocks.len();
    if n == 0 {
        return (Vec::new(), Vec::new());
    }
    let slots = planner_slots(link);
    let by_line = line_bytes(text);
    // The sent lines, and each one's first block.
    let mut sent_of_line = vec![usize::MAX; by_line.len()];
    let mut bytes = Vec::new();
    for (no, &b) in by_line.iter().enumerate() {
        if b > 0 {
            sent_of_line[no] = bytes.len();
            bytes.push(b);
        }
    }
    let mut first = vec![n; bytes.len() + 1];
    for (j, b) in blocks.iter().enumerate().rev() {
        let line = program.moves[b.mv].line;
        if let Some(&k) = sent_of_line.get(line).filter(|&&k| k != usize::MAX) {
            first[k] = j;
        }
    }
    for k in (0..bytes.len()).rev() {
        first[k] = first[k].min(first[k + 1]);
    }
    // Pauses: the motor hold at each stop and the dwells, before the block they come before.
    let mut pause = vec![0.0; n];
    for (j, b) in blocks.iter().enumerate() {
        if b.stop_before {
            pause[j] += limits.stop_lock_s();
        }
    }
    for &(m, s) in &program.dwells {
        if let Some(j) = blocks.iter().position(|b| b.mv >= m) {
            pause[j] += s;
        }
    }
    let mut serial = Serial {
        cps: f64::from(link.baud) / 10.0,
        window: link.rx_buffer_bytes.saturating_sub(1) as usize,
        slots,
        bytes,
        first,
        blocks,
        pause: &pause,
        rx_end: Vec::new(),
        taken: Vec::new(),
        k: 0,
        win_start: 0,
        win_bytes: 0,
        t: 0.0,
        entry: Vec::with_capacity(n),
    };
    let base_exits = plan_exit_speeds_in(blocks, slots);
    let held_end = held_ends(blocks);
    let mut done: Vec<f64> = Vec::with_capacity(n);
    let mut lost = Vec::with_capacity(n);
    let mut base_times = Vec::with_capacity(n);
    let (mut entry_sq, mut base_entry_sq) = (0.0f64, 0.0f64);
    for (i, b) in blocks.iter().enumerate() {
        let ready = serial.entry(i, &done);
        let start = match i {
            0 => ready,
            _ => ready.max(done[i - 1] + if b.stop_before { pause[i] } else { 0.0 }),
        };
        let end = held_end[i].min(i + slots);
        let reach_sq = entry_sq + 2.0 * b.accel * b.len;
        // Plan over the blocks held now; again over those that come before braking starts.
        let mut held = i + 1;
        let mut horizon = start;
        let mut replans = 0;
        let exit_sq = loop {
            while held < end && serial.entry(held, &done) <= horizon {
                held += 1;
            }
            let exit_sq = reverse_pass(&blocks[i + 1..held]).min(reach_sq);
            replans += 1;
            if held == end || replans > MAX_REPLANS {
                break exit_sq;
            }
            let brake =
                start + until_braking(b.len, entry_sq.sqrt(), exit_sq.sqrt(), b.v_nom, b.accel);
            if serial.entry(held, &done) > brake {
                break exit_sq;
            }
            horizon = brake;
        };
        let t = block_time(b.len, entry_sq.sqrt(), exit_sq.sqrt(), b.v_nom, b.accel);
        let base_exit_sq = base_exits[i];
        let base_t = block_time(
            b.len,
            base_entry_sq.sqrt(),
            base_exit_sq.sqrt(),
            b.v_nom,
            b.accel,
        );
        let waited = match i {
            0 => 0.0,
            _ => start - done[i - 1] - if b.stop_before { pause[i] } else { 0.0 },
        };
        lost.push(waited + t - base_t);
        base_times.push(base_t);
        done.push(start + t);
        entry_sq = exit_sq;
        base_entry_sq = base_exit_sq;
    }
    (lost, base_times)
}

/// Group the blocks that lose time into stretches, keeping those that lose at least
/// [`MIN_LOST_S`].
fn stretches(
    program: &Program,
    text: &str,
    blocks: &[Block],
    lost: &[f64],
    base_t: &[f64],
    link: &Link,
) -> Vec<Starve> {
    let bytes = line_bytes(text);
    let cps = f64::from(link.baud) / 10.0;
    let mut out = Vec::new();
    let mut i = 0;
    while i < lost.len() {
        if lost[i] <= 1e-9 {
            i += 1;
            continue;
        }
        let start = i;
        let mut last = i;
        let mut j = i + 1;
        while j < lost.len() && j <= last + JOIN_BLOCKS {
            if lost[j] > 1e-9 {
                last = j;
            }
            j += 1;
        }
        i = last + 1;
        let span = &blocks[start..=last];
        let lost_s: f64 = lost[start..=last].iter().sum();
        if lost_s < MIN_LOST_S {
            continue;
        }
        let lost_cut_s: f64 = span
            .iter()
            .zip(&lost[start..=last])
            .filter(|(b, _)| b.cut)
            .map(|(_, l)| l)
            .sum();
        let (m0, m1) = (
            &program.moves[span[0].mv],
            &program.moves[span[span.len() - 1].mv],
        );
        let (first_line, last_line) = (m0.line, m1.line);
        let line_count = (first_line..=last_line)
            .filter(|&l| bytes.get(l).is_some_and(|&b| b > 0))
            .count()
            .max(1);
        let sent: usize = (first_line..=last_line).filter_map(|l| bytes.get(l)).sum();
        let mm: f64 = span.iter().map(|b| b.len).sum();
        let run_s: f64 = base_t[start..=last].iter().sum();
        let feed = span.iter().map(|b| b.v_nom).fold(0.0, f64::max) * 60.0;
        out.push(Starve {
            first_line,
            last_line,
            from: [m0.from[0], m0.from[1]],
            to: [m1.to[0], m1.to[1]],
            lost_s,
            lost_cut_s,
            length_mm: mm,
            feed_mm_min: feed,
            lines_per_s_needed: line_count as f64 / run_s.max(1e-9),
            lines_per_s_link: cps * line_count as f64 / sent.max(1) as f64,
            fed_mm_min: 60.0 * cps * mm / sent.max(1) as f64,
        });
    }
    out
}

#[cfg(test)]
mod tests;
