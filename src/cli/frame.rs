//! `stencil frame JOB.gcode`: trace the outline of what a G-code file cuts, tool off or a laser at
//! a glimmer, and come back; and the framing step of `send --frame`. Machine side: reads any
//! G-code file, knows nothing of stencils.

use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::mpsc::{channel, Receiver};
use std::time::Duration;

use anyhow::bail;
use clap::Args;

use stencil_gcode::machine::{self as machine_profile, Machine, PenLift, Tool};
use stencil_grbl::{
    cut_extent_with, BytePort, Console, Control, ControllerInfo, Extent, FrameError, FrameTool,
    Framed, Observer, Program, StreamConfig,
};

/// The framing feed when none is given, mm/min (capped at the machine's max feed): slow enough
/// to follow the head with the eye, fast enough not to bore.
pub const DEFAULT_FRAME_FEED: f64 = 3000.0;

/// Trace the outline of a G-code job on the machine.
#[derive(Args, Debug)]
#[command(after_help = "\
Traces the rectangle around the job's cutting moves with the laser off (or at the machine \
profile's frame_power_pct, in M4 so the beam is dim and lit only while moving; a pen or knife \
stays up), then returns to where the head was. While framing: a / q / Esc / Ctrl-C = abort \
(soft reset, laser off).
Example: stencil frame job.gcode --dry-run --machine diode-400")]
pub struct FrameArgs {
    /// The G-code file (any GRBL program: ours or another program's).
    pub file: PathBuf,
    #[command(flatten)]
    pub link: super::port::PortArgs,
    /// Machine profile: its bed, its max feed, its tool and frame_power_pct (name or .toml path)
    /// [default: diode-400].
    #[arg(long, value_name = "NAME|FILE")]
    pub machine: Option<String>,
    /// Framing feed, mm/min [default: 3000, at most the machine's max feed].
    #[arg(long, value_name = "MM_MIN", value_parser = super::bounds::parse_feed)]
    pub feed: Option<f64>,
    /// Unlock ($X) a machine that is locked in alarm first.
    #[arg(long)]
    pub unlock: bool,
    /// Do not refuse a job that leaves the machine's bed (for a work zero set away from the
    /// machine's origin).
    #[arg(long)]
    pub no_bed_check: bool,
    /// Report the controller as silent after this many seconds without an answer (0.1 to 3600).
    #[arg(long, default_value_t = 10.0, value_parser = super::bounds::parse_timeout)]
    pub timeout_s: f64,
    #[command(flatten)]
    pub start: super::place::StartArgs,
}

/// What to trace and how, from the file and the machine profile.
#[derive(Clone, Copy, Debug)]
pub struct Setup {
    /// What is traced, in the work coordinates the frame runs in (the job placed).
    pub extent: Extent,
    /// The same in machine coordinates (what the bed check saw).
    pub machine: Extent,
    pub tool: FrameTool,
    pub feed: f64,
}

impl Setup {
    /// One line for the user.
    pub fn describe(&self) -> String {
        let e = &self.extent;
        let m = &self.machine;
        let at_machine = if m.min != e.min {
            format!(
                " (machine X {:.2}..{:.2} Y {:.2}..{:.2})",
                m.min[0], m.max[0], m.min[1], m.max[1]
            )
        } else {
            String::new()
        };
        format!(
            "X {:.2}..{:.2} Y {:.2}..{:.2}{at_machine} ({:.1} x {:.1} mm) at {:.0} mm/min, {}",
            e.min[0],
            e.max[0],
            e.min[1],
            e.max[1],
            e.width(),
            e.height(),
            self.feed,
            match self.tool {
                FrameTool::Laser { s, z } => format!(
                    "{}{}",
                    if s > 0.0 {
                        format!("laser dim at S{s:.0} (M4)")
                    } else {
                        "laser off".into()
                    },
                    z.map_or(String::new(), |z| format!(" at the job's Z{z:.3}"))
                ),
                FrameTool::ZUp { up_mm } => format!("tool up at Z{up_mm}"),
                FrameTool::SpindlePen => "pen up (M5)".into(),
            }
        )
    }
}

/// The frame of `job` on `machine`: the extent of its cutting moves (on the bed unless
/// `no_bed_check`), how the tool stays dark, and the feed.
pub fn setup(
    file: &Path,
    job: &Program,
    machine: &Machine,
    feed: Option<f64>,
    no_bed_check: bool,
) -> anyhow::Result<Setup> {
    let Some(on_machine) = cut_extent_with(&job.moves, machine.cut_rule(&job.moves)) else {
        bail!(
            "{}: nothing to frame: no move in the file cuts (no powered G1 for a laser, no G1 in \
             X/Y for a pen or knife)",
            file.display()
        );
    };
    // The bed check `send`, `estimate` and `simulate` make: every move of the placed job, its
    // travels too, not only the rectangle traced.
    if !no_bed_check {
        if let Err(e) = machine.check_moves(&job.moves) {
            let w = job.start.wco();
            bail!(
                "{}: {e}, with the job's X0 Y0 at machine X{} Y{}; nothing was moved. Place the \
                 job on the bed (its X0 Y0 goes where --start-from says), or pass --no-bed-check",
                file.display(),
                stencil_gcode::num(w[0]),
                stencil_gcode::num(w[1])
            );
        }
    }
    // The frame runs in work coordinates: the placed job's zero taken off again.
    let w = job.start.wco();
    let extent = Extent {
        min: [on_machine.min[0] - w[0], on_machine.min[1] - w[1]],
        max: [on_machine.max[0] - w[0], on_machine.max[1] - w[1]],
        ..on_machine
    };
    let max = machine.motion.max_feed_mm_min;
    let feed = match feed {
        Some(f) if f > max => bail!(
            "--feed {f} is above the max feed of {} ({max} mm/min)",
            machine.name
        ),
        Some(f) => f,
        None => DEFAULT_FRAME_FEED.min(max),
    };
    let tool = match machine.tool {
        Tool::Laser { s_max, .. } => FrameTool::Laser {
            s: machine.frame_power_pct / 100.0 * s_max,
            z: cut_z(job, machine).map(|z| z - w[2]),
        },
        Tool::Pen(PenLift::Z(z)) | Tool::Knife { z, .. } => FrameTool::ZUp { up_mm: z.up_mm },
        Tool::Pen(PenLift::Spindle { .. }) => FrameTool::SpindlePen,
    };
    Ok(Setup {
        extent,
        machine: on_machine,
        tool,
        feed,
    })
}

/// The machine Z a job that sets its own Z cuts at (its first cutting move's), so a frame
/// traces at the job's height; `None` for a job that never moves Z.
fn cut_z(job: &Program, machine: &Machine) -> Option<f64> {
    let moves_z = job.moves.iter().any(|m| (m.to[2] - m.from[2]).abs() > 1e-9);
    if !moves_z {
        return None;
    }
    let rule = machine.cut_rule(&job.moves);
    job.moves.iter().find(|m| rule.cuts(m)).map(|m| m.from[2])
}

/// Prints what the controller and the framing say, on stderr (`\r\n` in raw mode).
pub struct Say {
    pub raw: bool,
}

impl Say {
    pub fn line(&self, text: &str) {
        let end = if self.raw { "\r\n" } else { "\n" };
        eprint!("{text}{end}");
    }
}

impl Observer for Say {
    fn connected(&mut self, info: &ControllerInfo) {
        self.line(&format!(
            "connected to {}{}",
            info.name(),
            if info.unlocked { ", unlocked" } else { "" }
        ));
    }
    fn message(&mut self, text: &str) {
        self.line(text);
    }
}

/// Connect on `port` and frame; the operator's aborts come on `controls`.
pub fn frame_on(
    port: &mut dyn BytePort,
    cfg: &StreamConfig,
    controls: &Receiver<Control>,
    obs: &mut dyn Observer,
    s: &Setup,
    before: Option<&str>,
) -> anyhow::Result<Framed> {
    let mut console = Console::connect(port, cfg, Some(controls), obs)?;
    // A resume with the head brought back to the job's corner sets the work position first,
    // so the frame traces where the resume will cut.
    if let Some(cmd) = before {
        console.command(cmd)?;
        console.say(&format!(
            "work position set where the job goes ({cmd}, until the next reset)"
        ));
    }
    console.say(&format!("framing {}", s.describe()));
    stencil_grbl::frame(&mut console, s.extent, s.tool, s.feed).map_err(|e| {
        let hint = match &e {
            FrameError::Machine(m) => super::port::machine_hint(m),
            // Locked before, or by the stop.
            _ if console.locked() => "; run again with --unlock to send $X",
            _ => "",
        };
        match &e {
            // Said with what asked for the abort (a signal, which one, or a key).
            FrameError::Aborted { laser } => {
                anyhow::anyhow!("framing {}; {laser}{hint}", super::operator::abort_cause())
            }
            e => anyhow::anyhow!("{e}{hint}"),
        }
    })
}

/// What framing did, for the user.
pub fn framed_line(f: &Framed, label: &str) -> String {
    format!(
        "framed on {label}: the job cuts within X {:.2}..{:.2} Y {:.2}..{:.2} mm; the head is \
         back at X {:.2} Y {:.2}",
        f.plan.extent.min[0],
        f.plan.extent.max[0],
        f.plan.extent.min[1],
        f.plan.extent.max[1],
        f.end[0],
        f.end[1]
    )
}

/// `send --frame` asks before cutting; answered from `input` (the terminal). Yes only for `y`
/// or `yes`; anything else, or no answer, is no.
pub fn ask_start(input: &mut dyn BufRead) -> anyhow::Result<bool> {
    eprint!("Start the job? [y/N] ");
    let _ = std::io::stderr().flush();
    let mut line = String::new();
    input.read_line(&mut line)?;
    let a = line.trim().to_ascii_lowercase();
    Ok(a == "y" || a == "yes")
}

pub fn run_frame(a: FrameArgs) -> anyhow::Result<ExitCode> {
    let text = super::program::read_program(&a.file)?;
    eprintln!("{}", super::program::origin_line(&a.file, &text));
    let name = a.file.display().to_string();
    let job = Program::parse(&name, &text)?;
    let machine = machine_profile::load(a.machine.as_deref())?;
    super::program::name_machine_changes(&job);
    let dump = (a.start.controller_state.as_deref())
        .map(super::place::read_dump)
        .transpose()?;
    let mut opened = a.link.open(super::place::virtual_from(
        super::port::virtual_for(&machine, &[]),
        dump.as_ref(),
    ))?;
    // Where the job goes, from the controller's offsets and head (as `send` places it).
    let state = super::place::read_controller(
        opened.port.as_mut(),
        Duration::from_secs_f64(a.timeout_s),
        a.link.if_moving(),
    )?
    .state;
    let start = super::place::choose(a.start.start_from, &state, &machine);
    let placement = stencil_grbl::Placement::new(start, &state);
    println!("{}", placement.describe());
    let job = Program::parse_from(&name, &text, placement.modal)?;
    let s = setup(&a.file, &job, &machine, a.feed, a.no_bed_check)?;
    let g92 = super::place::g92_needed(&placement, &state);
    // The frame may trace with the beam dimly on: the power scale is checked first too.
    let cfg = StreamConfig {
        timeout: Duration::from_secs_f64(a.timeout_s),
        unlock: a.unlock,
        if_moving: a.link.if_moving(),
        expect: super::port::expected(&machine, &text, &job),
        ..StreamConfig::default()
    };
    let (tx, rx) = channel();
    let keys = super::operator::Keys::start(tx);
    let mut say = Say { raw: keys.raw };
    if keys.raw {
        say.line("keys: a / q / Esc / Ctrl-C = abort");
    }
    let result = frame_on(
        opened.port.as_mut(),
        &cfg,
        &rx,
        &mut say,
        &s,
        g92.as_deref(),
    );
    drop(keys);
    let framed = result?;
    println!("{}", framed_line(&framed, &opened.label));
    if let Some(vg) = opened.virtual_grbl.take() {
        let r = vg.stop();
        let beam = r.moves.iter().filter(|m| m.beam).count();
        println!(
            "virtual Grbl: {} moves, {} with the beam on; laser {} at the end, machine at X {:.3} Y {:.3}",
            r.moves.len(),
            beam,
            if r.laser_on { "ON" } else { "off" },
            r.position[0],
            r.position[1]
        );
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_yes_starts_the_job() {
        for (answer, start) in [
            ("y\n", true),
            ("YES\n", true),
            ("n\n", false),
            ("\n", false),
            ("", false),
            ("maybe\n", false),
        ] {
            assert_eq!(
                ask_start(&mut answer.as_bytes()).unwrap(),
                start,
                "{answer:?}"
            );
        }
    }
}
