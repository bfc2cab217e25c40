//! `stencil estimate job.gcode`: how long any G-code file runs, the way Grbl plans its motion.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use stencil_gcode::estimate::{estimate_with, format_duration, length_over_feed_s};
use stencil_gcode::interpret::interpret_program;
use stencil_gcode::machine as machine_profile;

use super::gcode::check_bed;

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
}

pub fn run_estimate(a: EstimateArgs) -> anyhow::Result<ExitCode> {
    let machine = machine_profile::load(a.machine.as_deref())?;
    let text = super::send::read_program(&a.file)?;
    eprintln!("{}", super::send::origin_line(&a.file, &text));
    super::send::name_machine_changes_in(&a.file, &text);
    let program =
        interpret_program(&text).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    let moves = program.moves;
    check_bed(&a.file, &moves, &machine, a.no_bed_check)?;
    let mut e = estimate_with(&moves, &machine.motion, machine.cut_rule(&moves));
    // G4 dwells: the machine stands still (Grbl waits for the queue to empty first).
    e.total_s += program.dwell_s;
    println!(
        "{}: about {} on {} (cut {}, travel {}); {} moves, cut {:.0} mm, travel {:.0} mm; \
         length / feed alone would say {}",
        a.file.display(),
        format_duration(e.total_s),
        machine.name,
        format_duration(e.cut_s),
        format_duration(e.travel_s),
        moves.len(),
        e.cut_mm,
        e.travel_mm,
        format_duration(length_over_feed_s(&moves, &machine.motion)),
    );
    Ok(ExitCode::SUCCESS)
}
