//! `stencil estimate job.gcode`: how long any G-code file runs, the way Grbl plans its motion.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use stencil_gcode::estimate::{estimate_with, format_duration, length_over_feed_s};
use stencil_gcode::interpret::interpret_from;
use stencil_gcode::machine as machine_profile;
use stencil_grbl::placement::{ControllerState, Placement, StartFrom};
use stencil_grbl::stream::ControllerInfo;

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
    /// Where the job's X0 Y0 goes, as `send --start-from`: machine, work-zero (the offsets of
    /// --controller-state, else none) or current (--head-at) [default: machine if the machine
    /// homes, else work-zero].
    #[arg(long, value_name = "machine|work-zero|current")]
    pub start_from: Option<StartFrom>,
    /// With --start-from current: where the head stands, machine coordinates, mm (the estimate
    /// has no controller to ask).
    #[arg(long, value_name = "X,Y", value_parser = super::place::parse_head_at, allow_hyphen_values = true)]
    pub head_at: Option<[f64; 2]>,
    /// A controller's saved state (what Grbl prints for `$$` and `$#`, and optionally `$G` and
    /// `?`): its offsets place the job, its rates, acceleration, junction deviation and arc
    /// tolerance ($110/$111, $120/$121, $11, $12) time it.
    #[arg(long, value_name = "FILE")]
    pub controller_state: Option<PathBuf>,
}

pub fn run_estimate(a: EstimateArgs) -> anyhow::Result<ExitCode> {
    let machine = machine_profile::load(a.machine.as_deref())?;
    let text = super::send::read_program(&a.file)?;
    eprintln!("{}", super::send::origin_line(&a.file, &text));
    super::send::name_machine_changes_in(&a.file, &text);
    let mut state = match &a.controller_state {
        Some(p) => super::place::read_dump(p)?,
        None => ControllerState::default(),
    };
    if let Some([x, y]) = a.head_at {
        let z = state.position.map_or(0.0, |p| p[2]);
        state.position = Some([x, y, z]);
    }
    let start = super::place::choose(a.start_from, &state, &machine);
    if start == StartFrom::Current && state.position.is_none() {
        anyhow::bail!(
            "--start-from current needs where the head stands: give --head-at X,Y (machine              coordinates), or a status line (<Idle|MPos:...>) in --controller-state"
        );
    }
    let placement = Placement::new(start, &state);
    if a.start_from.is_some() || a.controller_state.is_some() {
        println!("{}", placement.describe());
    }
    let program = interpret_from(&text, placement.modal)
        .map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    let moves = program.moves;
    super::place::check_bed(&a.file, &moves, &machine, a.no_bed_check, &placement)?;
    let info = ControllerInfo {
        settings: state.settings.clone(),
        ..ControllerInfo::default()
    };
    let motion = super::send::controller_motion(machine.motion, &info);
    let mut e = estimate_with(&moves, &motion, machine.cut_rule(&moves));
    // G4 dwells: the machine stands still (Grbl waits for the queue to empty first).
    e.total_s += program.dwell_s;
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
        format_duration(length_over_feed_s(&moves, &motion)),
    );
    Ok(ExitCode::SUCCESS)
}
