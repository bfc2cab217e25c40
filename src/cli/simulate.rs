//! `stencil simulate`: draw what a G-code file makes the machine do (PNG) and estimate its time.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use stencil_core::export;
use stencil_gcode::machine as machine_profile;
use stencil_gcode::simulate;
use stencil_gcode::{estimate_streamed, format_duration};

use super::program::read_program;

/// Draw what a G-code file makes the machine do, and estimate its time.
#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// The G-code file.
    pub file: PathBuf,
    /// Output picture (PNG).
    #[arg(short = 'o', long, default_value = "sim.png")]
    pub output: PathBuf,
    /// Longer side of the picture, in pixels.
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u32).range(16..=20000))]
    pub size_px: u32,
    /// Machine profile whose motion limits the time estimate uses, and whose bed the job must
    /// stay on (name or .toml path) [default: diode-400].
    #[arg(long, value_name = "NAME|FILE")]
    pub machine: Option<String>,
    /// Do not refuse a job that leaves the machine's bed (for a file whose work zero is set away
    /// from the machine's origin).
    #[arg(long)]
    pub no_bed_check: bool,
    #[command(flatten)]
    pub place: super::estimate::PlaceArgs,
}

pub fn run_simulate(a: SimulateArgs) -> anyhow::Result<ExitCode> {
    if super::send_hpgl::is_hpgl_file(&a.file) {
        return super::send_hpgl::run_simulate_hpgl(
            &a.file,
            a.machine.as_deref(),
            &a.output,
            a.size_px,
        );
    }
    let mut inputs = vec![a.file.as_path()];
    inputs.extend(a.machine.as_deref().map(std::path::Path::new));
    stencil_io::check_output(&a.output, &inputs)?;
    let text = read_program(&a.file)?;
    super::program::name_machine_changes_in(&a.file, &text);
    let machine = machine_profile::load(a.machine.as_deref())?;
    // Read as `estimate` (and `send`, `frame`) read it: placed by --start-from, timed with the
    // controller's settings when given.
    let job = super::estimate::read_placed(&a.file, &text, &machine, &a.place, a.no_bed_check)?;
    let moves = &job.program.moves;
    let rule = machine.cut_rule(moves);
    // The same time `estimate` gives: over the machine's serial line, starvation included.
    let est = estimate_streamed(&job.program, &text, &job.motion, &machine.link, rule).estimate;
    let d = simulate::draw(moves, a.size_px, rule);
    stencil_io::write_atomic(
        &a.output,
        &export::png::encode_rgb(d.width, d.height, &d.rgb),
    )?;
    println!(
        "estimated time {} on {} (cutting {}, travel {}); cut {:.0} mm, travel {:.0} mm, {} moves",
        format_duration(est.total_s),
        machine.name,
        format_duration(est.cut_s),
        format_duration(est.travel_s),
        est.cut_mm,
        est.travel_mm,
        moves.len()
    );
    println!(
        "wrote {} ({}×{} px, {:.3} mm per px; red = cutting (laser on, pen or blade down), blue = travel)",
        a.output.display(),
        d.width,
        d.height,
        d.mm_per_px
    );
    Ok(ExitCode::SUCCESS)
}
