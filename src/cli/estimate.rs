//! `stencil estimate job.gcode`: how long any G-code file runs, the way Grbl plans its motion.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Args;

use stencil_gcode::interpret::{interpret_from, Program};
use stencil_gcode::machine as machine_profile;
use stencil_gcode::{estimate_streamed, format_duration, length_over_feed_s};
use stencil_grbl::{ControllerInfo, ControllerState, Placement, StartFrom};

/// `stencil estimate job.gcode`: time and distances of any G-code file.
#[derive(Args, Debug)]
pub struct EstimateArgs {
    /// The G-code file.
    pub file: PathBuf,
    /// Machine profile whose motion limits to use, and whose bed the job must stay on (name or
    /// .toml path) [default: diode-400].
    #[arg(long, value_name = "NAME|FILE")]
    pub machine: Option<String>,
    /// Do not refuse a job that leaves the machine's bed (for a file whose work zero is set away
    /// from the machine's origin).
    #[arg(long)]
    pub no_bed_check: bool,
    #[command(flatten)]
    pub place: PlaceArgs,
}

/// Where a job goes and how the machine times it: the options `estimate` and `simulate` share,
/// so that both read a job the way `send` and `frame` place it.
#[derive(Args, Debug, Clone, Default)]
pub struct PlaceArgs {
    /// Where the job's X0 Y0 goes, as `send --start-from`: machine, work-zero (the offsets of
    /// --controller-state, else none) or current (--head-at) [default: machine if the machine
    /// homes, else work-zero].
    #[arg(long, value_name = "machine|work-zero|current")]
    pub start_from: Option<StartFrom>,
    /// With --start-from current: where the head stands, machine coordinates, mm (there is no
    /// controller to ask).
    #[arg(long, value_name = "X,Y", value_parser = super::place::parse_head_at, allow_hyphen_values = true)]
    pub head_at: Option<[f64; 2]>,
    /// A controller's saved state (what Grbl prints for `$$` and `$#`, and optionally `$G` and
    /// `?`): its offsets place the job; its steps per mm, rates, accelerations, junction
    /// deviation, arc tolerance and motor hold ($100-$102, $110-$112, $120-$122, $11, $12, $1)
    /// time it.
    #[arg(long, value_name = "FILE")]
    pub controller_state: Option<PathBuf>,
}

/// A job read as the machine will run it: every move placed in machine coordinates, and the
/// motion limits to time it with.
pub struct PlacedJob {
    pub program: Program,
    pub motion: machine_profile::Motion,
}

/// Read `text` (from `file`) placed by `a` on `machine`, bed-checked unless `no_bed_check`;
/// says where the job goes when a placement was asked for.
pub fn read_placed(
    file: &Path,
    text: &str,
    machine: &machine_profile::Machine,
    a: &PlaceArgs,
    no_bed_check: bool,
) -> anyhow::Result<PlacedJob> {
    let mut state = match &a.controller_state {
        Some(p) => super::place::read_dump(p)?,
        None => ControllerState::default(),
    };
    if let Some(p) = &a.controller_state {
        check_timing_settings(p, &state.settings)?;
    }
    if let Some([x, y]) = a.head_at {
        let z = state.position.map_or(0.0, |p| p[2]);
        state.position = Some([x, y, z]);
    }
    let start = super::place::choose(a.start_from, &state, machine);
    if start == StartFrom::Current && state.position.is_none() {
        anyhow::bail!(
            "--start-from current needs where the head stands: give --head-at X,Y (machine \
             coordinates), or a status line (<Idle|MPos:...>) in --controller-state"
        );
    }
    let placement = Placement::new(start, &state);
    if a.start_from.is_some() || a.controller_state.is_some() {
        println!("{}", placement.describe());
    }
    let program = interpret_from(text, placement.modal)
        .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
    super::place::check_bed(file, &program.moves, machine, no_bed_check, &placement)?;
    let info = ControllerInfo {
        settings: state.settings.clone(),
        ..ControllerInfo::default()
    };
    let motion = super::port::controller_motion(machine.motion, &info);
    Ok(PlacedJob { program, motion })
}

/// The settings the estimate times a job with, and the values a Grbl can hold for them (a
/// `$100=1e308` in a saved state would time every move as 0 s, or NaN).
const TIMING_SETTINGS: &[(u32, &str, f64, f64)] = &[
    (1, "step idle delay, ms", 0.0, 255.0),
    (11, "junction deviation, mm", 0.0, 100.0),
    (12, "arc tolerance, mm", 0.0, 100.0),
    (100, "X steps per mm", 1e-3, 1e6),
    (101, "Y steps per mm", 1e-3, 1e6),
    (102, "Z steps per mm", 1e-3, 1e6),
    (110, "X max rate, mm/min", 1e-3, 1e7),
    (111, "Y max rate, mm/min", 1e-3, 1e7),
    (112, "Z max rate, mm/min", 1e-3, 1e7),
    (120, "X acceleration, mm/s^2", 1e-3, 1e7),
    (121, "Y acceleration, mm/s^2", 1e-3, 1e7),
    (122, "Z acceleration, mm/s^2", 1e-3, 1e7),
];

/// Refuse a saved controller state whose timing settings no Grbl can have, naming the setting.
fn check_timing_settings(file: &Path, settings: &[(u32, f64)]) -> anyhow::Result<()> {
    for &(k, v) in settings {
        let Some(&(_, what, lo, hi)) = TIMING_SETTINGS.iter().find(|t| t.0 == k) else {
            continue;
        };
        if !(v.is_finite() && (lo..=hi).contains(&v)) {
            anyhow::bail!(
                "{}: ${k}={} ({what}) is not a value a Grbl controller can hold (allowed \
                 {lo}..={hi}): the estimate would be meaningless; fix the saved state (what Grbl \
                 prints for $$)",
                file.display(),
                if v.is_finite() && v.abs() < 1e9 {
                    stencil_gcode::num(v)
                } else {
                    format!("{v:e}")
                }
            );
        }
    }
    Ok(())
}

pub fn run_estimate(a: EstimateArgs) -> anyhow::Result<ExitCode> {
    if super::send_hpgl::is_hpgl_file(&a.file) {
        return super::send_hpgl::run_estimate_hpgl(&a.file, a.machine.as_deref());
    }
    let machine = machine_profile::load(a.machine.as_deref())?;
    let text = super::program::read_program(&a.file)?;
    eprintln!("{}", super::program::origin_line(&a.file, &text));
    super::program::name_machine_changes_in(&a.file, &text);
    let job = read_placed(&a.file, &text, &machine, &a.place, a.no_bed_check)?;
    let (moves, motion) = (&job.program.moves, job.motion);
    // Grbl's stops (its planner syncs), their motor holds ($1) and the G4 dwells included, and
    // the time lost where the serial line cannot keep the planner fed.
    let streamed = estimate_streamed(
        &job.program,
        &text,
        &motion,
        &machine.link,
        machine.cut_rule(moves),
    );
    let e = streamed.estimate;
    println!(
        "{}: about {} ({:.2} s) on {} (cut {}, travel {}); {} moves, cut {:.0} mm, travel \
         {:.0} mm; length / feed alone would say {}",
        a.file.display(),
        format_duration(e.total_s),
        e.total_s,
        machine.name,
        format_duration(e.cut_s),
        format_duration(e.travel_s),
        moves.len(),
        e.cut_mm,
        e.travel_mm,
        format_duration(length_over_feed_s(moves, &motion)),
    );
    if !streamed.starved.is_empty() {
        println!(
            "warning: the planner starves in {} at {} baud ({:.2} s lost, included above): the \
             serial line brings the lines slower than the feed uses them, and the head stutters \
             there; lower the feed there or use longer segments:",
            super::gcode::places(streamed.starved.len()),
            machine.link.baud,
            streamed.lost_s(),
        );
        super::gcode::print_places(&streamed.starved, super::gcode::starve_line);
    }
    Ok(ExitCode::SUCCESS)
}
