//! Where a job goes (`--start-from`, `--controller-state`, estimate's `--head-at`): shared by
//! `send`, `frame` and `estimate`, so the three place a job the same way and check the bed where
//! the machine will really cut.

use std::path::{Path, PathBuf};
use std::time::Duration;

use clap::Args;

use stencil_gcode::interpret::Move;
use stencil_gcode::machine::Machine;
use stencil_grbl::{
    BytePort, Console, ControllerState, IfMoving, Observer, Placement, StartFrom, StreamConfig,
    VirtualConfig,
};

/// What `--start-from` says, worded once for send and frame.
pub const START_FROM_HELP: &str = "\
Where the job's X0 Y0 goes: `machine` (the job's coordinates are machine coordinates, the origin \
homing finds; a work offset in X/Y is cancelled for the run with G92), `work-zero` (the \
controller's work zero: G54..G59 and G92 as its $# reports them), or `current` (where the head \
stands when the run starts: G92 X0 Y0 there). `stencil make` and `gcode` put the job's --origin \
corner at --offset in these coordinates, so with the default --offset 0,0 the job's corner lands \
on the chosen zero. The bed check uses the offset the controller really has. [default: machine \
on a machine that homes ($22=1), else work-zero; said before anything moves]";

/// `--start-from` and `--controller-state`, for the commands that talk to a controller.
#[derive(Args, Debug, Clone, Default)]
pub struct StartArgs {
    #[arg(long, value_name = "machine|work-zero|current", long_help = START_FROM_HELP,
          help = "Where the job's X0 Y0 goes: machine, work-zero or current (head position) \
                  [default: machine if the controller homes, else work-zero]")]
    pub start_from: Option<StartFrom>,
    /// With --dry-run: a controller's saved state, the lines Grbl prints for `$$` and `$#` (and
    /// optionally `$G` and `?`, for the selected work system and where the head is): the
    /// simulated Grbl starts with those settings, offsets and head position.
    #[arg(long, value_name = "FILE", requires = "dry_run")]
    pub controller_state: Option<PathBuf>,
}

/// Read a saved `$$`/`$#` dump (bounded: at most 1 MB, like a profile).
pub fn read_dump(path: &Path) -> anyhow::Result<ControllerState> {
    let text = stencil_io::read_text(path, stencil_io::Kind::Profile)?;
    Ok(ControllerState::parse_dump(path, &text)?)
}

/// The virtual Grbl of a dry run started from a saved dump: its `$$` over `vcfg`'s settings,
/// its offsets and head position; homing as its `$22` says.
pub fn virtual_from(mut vcfg: VirtualConfig, dump: Option<&ControllerState>) -> VirtualConfig {
    if let Some(st) = dump {
        for &(k, v) in &st.settings {
            vcfg.settings.retain(|(n, _)| *n != k);
            vcfg.settings.push((k, stencil_gcode::num(v)));
        }
        vcfg.homing = st.homes().unwrap_or(vcfg.homing);
        vcfg.rapid_mm_min = st.setting(110).unwrap_or(vcfg.rapid_mm_min);
        vcfg.start = Some(st.clone());
    }
    vcfg
}

/// Ask the controller on `port` what decides where a job lands (`$$`, `$#`, `$G`, `?`), on a
/// short session of its own before the job's (a machine locked in alarm answers these too).
pub fn read_controller(
    port: &mut dyn BytePort,
    timeout: Duration,
    if_moving: IfMoving,
) -> anyhow::Result<Reading> {
    let cfg = StreamConfig {
        timeout,
        if_moving,
        ..StreamConfig::default()
    };
    let mut notes = Notes;
    let mut console = Console::connect(port, &cfg, None, &mut notes)
        .map_err(|e| anyhow::anyhow!("{e}{}", super::port::machine_hint(&e)))?;
    Ok(Reading {
        state: console.controller_state()?,
        stopped_running: console.stopped_running(),
    })
}

/// What [`read_controller`] found.
pub struct Reading {
    pub state: ControllerState,
    /// The controller was running moves it had been given before, and was stopped as
    /// `--stop-running` asked: what it had queued did not all run.
    pub stopped_running: bool,
}

/// The streamer's own notes while the controller is read (a machine found running, waited
/// for or stopped), on stderr; the controller's messages are left to the connection that
/// follows, which shows them.
struct Notes;

impl Observer for Notes {
    fn message(&mut self, text: &str) {
        if !text.starts_with("Grbl: ") {
            eprintln!("{text}");
        }
    }
}

/// The start the person chose, or the default: the machine's origin where homing makes it
/// trustworthy (the controller's `$22`, else the profile's), else the work zero.
pub fn choose(given: Option<StartFrom>, st: &ControllerState, machine: &Machine) -> StartFrom {
    given.unwrap_or(if st.homes().unwrap_or(machine.motion.homing) {
        StartFrom::Machine
    } else {
        StartFrom::WorkZero
    })
}

/// The `G92` that puts the controller's work zero where `p` says, if it is elsewhere (judged
/// from the state read before anything moved; `None` when it is there already or the head's
/// position is unknown).
pub fn g92_needed(p: &Placement, st: &ControllerState) -> Option<String> {
    let w = st.wco();
    let there = (w[0] - p.zero[0]).abs() < 0.0015 && (w[1] - p.zero[1]).abs() < 0.0015;
    match (there, st.position) {
        (false, Some(pos)) => Some(stencil_grbl::g92_for(p.zero, pos)),
        _ => None,
    }
}

/// The bed check on placed moves: a refusal says where the job's zero was put and how to move
/// it.
pub fn check_bed(
    file: &Path,
    moves: &[Move],
    machine: &Machine,
    skip: bool,
    p: &Placement,
) -> anyhow::Result<()> {
    if skip {
        return Ok(());
    }
    machine.check_moves(moves).map_err(|e| {
        anyhow::anyhow!(
            "{}: {e}; {}; refused before anything moved. Move the work zero or the head \
             (`stencil jog`), choose another --start-from, or name the machine with --machine; \
             --no-bed-check skips this check",
            file.display(),
            p.describe()
        )
    })
}

/// `estimate --head-at X,Y`.
pub fn parse_head_at(s: &str) -> Result<[f64; 2], String> {
    let v = super::bounds::parse_offset(s)?;
    let lim = stencil_gcode::interpret::MAX_COORD_MM;
    if v.iter().all(|c| c.abs() <= lim) {
        Ok(v)
    } else {
        Err(format!(
            "'{s}' is beyond any machine: use X,Y within ±{lim} mm"
        ))
    }
}
