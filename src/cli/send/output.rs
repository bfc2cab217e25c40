//! What `send` shows while and after a job streams: the progress bar (with the remaining time
//! over Grbl's stops and dwells) and the summary, with what the virtual Grbl saw on a dry run.

use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use stencil_gcode::interpret::CutRule;
use stencil_gcode::machine as machine_profile;
use stencil_gcode::{estimate_program_from, format_duration};

use crate::cli::port::controller_motion;
use stencil_grbl::{ControllerInfo, Observer, Program, Progress, Summary, VirtualGrbl};

/// The progress bar: lines acknowledged, percent, machine state and position, elapsed and
/// remaining time (estimated over the moves that have not run yet).
pub struct Bar {
    pub bar: ProgressBar,
    /// The job as Grbl runs it: its moves with the stops and dwells between them.
    job: stencil_gcode::interpret::Program,
    rule: CutRule,
    limits: machine_profile::Motion,
    raw: bool,
    last_estimate: Option<Instant>,
    remaining: String,
    state: String,
}

impl Bar {
    pub fn new(job: &Program, text: &str, limits: machine_profile::Motion, raw: bool) -> Bar {
        // Hidden until the job starts (shown by `phase`), so connecting draws no empty bar.
        let bar = ProgressBar::with_draw_target(Some(0), ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} {elapsed_precise} [{bar:20}] {pos}/{len} lines {percent}% {wide_msg}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        Bar {
            bar,
            job: timed_job(job, text),
            rule: CutRule::infer(&job.moves),
            limits,
            raw,
            last_estimate: None,
            remaining: String::new(),
            state: String::new(),
        }
    }

    pub fn say(&self, text: &str) {
        // Raw mode does not turn \n into \r\n.
        let end = if self.raw { "\r\n" } else { "\n" };
        self.bar.suspend(|| eprint!("{text}{end}"));
    }
}

impl Observer for Bar {
    fn connected(&mut self, info: &ControllerInfo) {
        // The remaining time is estimated with the controller's own rates and accelerations
        // (the settings check has said where they differ from the profile).
        self.limits = controller_motion(self.limits, info);
        self.say(&format!(
            "connected to {} ({} planner blocks, {}-byte receive buffer){}",
            info.name(),
            info.planner_blocks,
            info.rx_buffer,
            if info.unlocked { ", unlocked" } else { "" }
        ));
    }
    fn message(&mut self, text: &str) {
        self.say(text);
    }
    fn phase(&mut self, checking: bool, total: usize) {
        self.bar
            .set_draw_target(ProgressDrawTarget::stderr_with_hz(5));
        self.bar.set_length(total as u64);
        self.bar.set_position(0);
        self.bar
            .set_prefix(if checking { "check" } else { "cut" }.to_string());
        if !checking {
            self.bar.reset_elapsed();
        }
    }
    fn progress(&mut self, p: &Progress) {
        self.bar.set_position(p.acked as u64);
        if self
            .last_estimate
            .is_none_or(|t| t.elapsed() > Duration::from_millis(500))
        {
            self.last_estimate = Some(Instant::now());
            let k = self
                .job
                .moves
                .partition_point(|m| m.line < p.unexecuted_from);
            let e = estimate_program_from(&self.job, k, &self.limits, self.rule);
            self.remaining = format!("~{} left", format_duration(e.total_s));
        }
        if let Some(st) = &p.state {
            self.state = match p.position {
                Some(pos) => format!("{st} X{:.2} Y{:.2}", pos[0], pos[1]),
                None => st.to_string(),
            };
            if let Some(ov) = p.overrides {
                self.state = format!("{} {}", self.state, stencil_grbl::overrides_text(ov));
            }
        }
        self.bar
            .set_message(format!("{} {}", self.state, self.remaining));
    }
}

/// `job` as Grbl runs it, for the remaining time: its moves with the stops where Grbl empties its
/// planner and the dwells (what `stencil estimate` counts), read from `text` from the job's start
/// state. A program with lines stencil's interpreter cannot follow keeps the moves it could read,
/// without stops: the estimate is then short by what they would add.
fn timed_job(job: &Program, text: &str) -> stencil_gcode::interpret::Program {
    match stencil_gcode::interpret::interpret_from(text, job.start) {
        Ok(p) if p.moves == job.moves => p,
        _ => stencil_gcode::interpret::Program {
            moves: job.moves.clone(),
            ..Default::default()
        },
    }
}

/// What a finished stream did, and with `--dry-run` what the simulated machine saw.
pub fn print_summary(sum: &Summary, label: &str, virtual_grbl: Option<VirtualGrbl>) {
    let secs = sum.elapsed.as_secs_f64();
    println!(
        "sent {} lines ({} bytes) to {label}: streamed in {:.2} s ({:.0} bytes/s), job done after {}; {}, counting against {} bytes, at most {} in flight",
        sum.lines,
        sum.bytes,
        secs,
        if secs > 0.0 { sum.bytes as f64 / secs } else { 0.0 },
        format_duration(sum.total.as_secs_f64()),
        sum.info.name(),
        sum.rx_limit,
        sum.max_in_flight
    );
    if let Some(vg) = virtual_grbl {
        print_virtual(vg);
    }
}

/// What the simulated machine of a dry run saw, and how it was left (also after a stop).
pub fn print_virtual(vg: VirtualGrbl) {
    let r = vg.stop();
    let alarms: Vec<String> = r
        .events
        .iter()
        .filter_map(|e| match e {
            stencil_grbl::Event::Alarm(c) => Some(format!("ALARM:{c}")),
            _ => None,
        })
        .collect();
    println!(
        "virtual Grbl: {} lines received, at most {} bytes in its receive buffer, {} bytes overflowed, laser {}, air {}, $32={}, state {}, alarms: {}",
        r.received.len(),
        r.max_rx_used,
        r.overflow_bytes,
        if r.laser_on { "ON" } else { "off" },
        if r.air_on { "ON" } else { "off" },
        u8::from(r.laser_mode),
        r.state,
        if alarms.is_empty() { "none".to_string() } else { alarms.join(" ") }
    );
    // Where the simulated beam (or tool) really went, machine coordinates: the placement seen
    // from the machine's side.
    let cut: Vec<[f64; 2]> = (r.moves.iter())
        .filter(|m| m.beam && m.moves_xy())
        .flat_map(|m| [m.from, m.to].map(|p| [p[0], p[1]]))
        .collect();
    let [x0, y0, x1, y1] = stencil_geom::ring::bbox(&cut);
    if x0.is_finite() {
        println!("virtual Grbl: the beam cut within machine X {x0:.3}..{x1:.3} Y {y0:.3}..{y1:.3}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The remaining time `send` shows counts Grbl's stops and the dwells, as `stencil estimate`
    /// does: a job with a dwell and spindle changes between its passes has them in what is left
    /// at its start; a job stencil cannot wholly read keeps its moves.
    #[test]
    fn the_remaining_time_has_the_stops_and_dwells() {
        let text = "G21 G90 F3000\nM4 S500\nG1 X50\nM5\nG4 P2\nM4 S500\nG1 X100\nM5\n";
        let job = Program::parse("job.nc", text).unwrap();
        let timed = timed_job(&job, text);
        assert_eq!(timed.moves, job.moves);
        assert_eq!(timed.dwells.len(), 1);
        assert_eq!(timed.stops, vec![1]);
        let limits = machine_profile::load(Some("diode-400")).unwrap().motion;
        let rule = CutRule::infer(&job.moves);
        let left = estimate_program_from(&timed, 0, &limits, rule).total_s;
        let moving = stencil_gcode::estimate(&job.moves, &limits).total_s;
        assert!(left >= moving + 2.0, "{left} vs {moving}");
        // After the first pass, the dwell is still to come.
        let after = estimate_program_from(&timed, 1, &limits, rule).total_s;
        assert!(after >= 2.0 && after < left, "{after} vs {left}");
        // A line stencil's interpreter refuses (Grbl may take it): the moves it read, no stops.
        let odd = "G1 X10 F600\nG5.1 X1\nG1 X20\n";
        let job = Program::parse("odd.nc", odd).unwrap();
        let timed = timed_job(&job, odd);
        assert_eq!(timed.moves, job.moves);
        assert!(timed.stops.is_empty() && timed.dwells.is_empty());
    }
}
