//! `stencil send`: stream G-code to Grbl, or to the virtual Grbl with --dry-run.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::mpsc::channel;
use std::time::Duration;

use anyhow::bail;
use clap::Args;

use stencil_gcode::interpret::Move;
use stencil_gcode::machine as machine_profile;

mod card;
mod output;
mod recover;

use super::operator::{abort_cause, Keys};
use super::program::{name_machine_changes, origin_line, read_program};
use output::{print_summary, print_virtual, Bar};
use recover::{profile_fingerprint, recover};
use stencil_grbl::{
    ClockRef, ControllerState, Fault, FaultKind, FlowControl, Journal, JournalWriter, LaserMode,
    Pace, Placement, Program, ResumeLift, RunState, StartFrom, StreamConfig, VirtualConfig,
};

/// Stream a G-code file to a Grbl 1.1 controller.
#[derive(Args, Debug)]
#[command(
    after_help = "While streaming: ! or h = feed hold, ~ or r = resume, + / - = feed override \
±10 %, ] / [ = power (spindle) override ±10 %, 0 = both back to 100 %, a / q / Esc / Ctrl-C = \
abort (feed hold, soft reset, laser and air off, prints the line to resume from)."
)]
pub struct SendArgs {
    /// The G-code file.
    pub file: PathBuf,
    #[command(flatten)]
    pub link: super::port::PortArgs,
    /// Send one line at a time, each after the previous `ok` (slower; for boards that overflow
    /// with character counting).
    #[arg(long)]
    pub send_response: bool,
    /// Resume at this line of the file (as printed after a stop): restores units, distance mode,
    /// position, feed, air and laser state first; a pen or knife on Z is lifted (to the machine
    /// profile's up height) before the travel and lowered at its plunge feed after it.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
    pub from_line: u64,
    /// Resume after a crash, a pulled cable or a power loss from the journal the last run left
    /// beside the file (FILE.journal): says what it knows, proposes the last line surely executed,
    /// homes first if the machine profile says it homes, then resumes as --from-line does.
    #[arg(long, conflicts_with = "from_line")]
    pub recover: bool,
    /// Run the file through Grbl's check mode ($C) first; cut nothing if any line is rejected.
    #[arg(long)]
    pub check: bool,
    /// Unlock ($X) a machine that is locked in alarm before streaming.
    #[arg(long)]
    pub unlock: bool,
    /// With --dry-run: pace the simulated machine and link as the real ones would run.
    #[arg(long, requires = "dry_run")]
    pub realtime: bool,
    /// Report the controller as silent after this many seconds without an answer (0.1 to 3600).
    #[arg(long, default_value_t = 10.0, value_parser = super::bounds::parse_timeout)]
    pub timeout_s: f64,
    /// Count against a receive buffer of this many bytes instead of the one Grbl reports.
    #[arg(long)]
    pub rx_buffer: Option<usize>,
    /// Machine profile whose motion limits the remaining-time estimate (and a --realtime dry run)
    /// use, and whose bed the job must stay on (name or .toml path) [default: diode-400].
    #[arg(long, value_name = "NAME|FILE")]
    pub machine: Option<String>,
    /// A laser job needs Grbl's laser mode ($32=1): if it is off, set it (instead of refusing).
    #[arg(long)]
    pub set_laser_mode: bool,
    /// With --dry-run: start the simulated Grbl with this setting, e.g. `$32=0` (laser mode off),
    /// to rehearse what happens on such a machine. Repeatable.
    #[arg(long, value_name = "$N=V", requires = "dry_run", value_parser = parse_setting)]
    pub dry_run_setting: Vec<(u32, String)>,
    /// With --dry-run: make the simulated Grbl fail when the N-th G-code line of the run arrives:
    /// `close@N` (port dies), `silence@N`, `freeze@N` (stuck in Run, still answering status),
    /// `drop-ok@N` / `garble-ok@N` (its answer lost or garbled), `power-loss@N` (the board
    /// restarts at machine zero), `drop-link@N` (with --dry-run-tcp: the network link drops, the
    /// board runs on), `error:C@N`, `alarm:C@N`. To rehearse a stop and its recovery. An HP-GL
    /// job's virtual cutter takes `close@N` (it cuts on through its buffer) and `power-loss@N`
    /// (its buffer is lost, the instruction it was cutting unfinished), N its N-th instruction.
    #[arg(long, value_name = "KIND@N", requires = "dry_run", value_parser = parse_fault)]
    pub dry_run_fault: Vec<Fault>,
    /// Do not refuse a job that leaves the machine's bed (for a file whose work zero is set away
    /// from the machine's origin).
    #[arg(long)]
    pub no_bed_check: bool,
    /// Frame the job first (as `stencil frame` does: its outline traced with the tool off, or
    /// at the profile's frame_power_pct), then ask on the terminal whether to start.
    #[arg(long)]
    pub frame: bool,
    /// With --frame: start after framing without asking (needed when stdin is not a terminal).
    #[arg(long, requires = "frame")]
    pub yes: bool,
    /// With --frame: framing feed, mm/min [default: 3000, at most the machine's max feed].
    #[arg(long, value_name = "MM_MIN", requires = "frame", value_parser = super::bounds::parse_feed)]
    pub frame_feed: Option<f64>,
    /// When the controller's power scale ($30/$31) differs from the job's, rescale every S to
    /// the controller's scale for this run (instead of refusing).
    #[arg(long)]
    pub rescale_power: bool,
    /// Let the job's own lines change the machine: Grbl settings ($N=V), startup lines, $H, $X,
    /// $C, $J=, $RST=, $SLP, and stored offsets (G10 L2/L20, G28.1, G30.1). Refused otherwise.
    #[arg(long)]
    pub allow_machine_commands: bool,
    /// With --recover or --from-line: the controller's coordinates are right again (you homed
    /// or re-zeroed the machine by hand), so its position is not compared with the journal's.
    #[arg(long)]
    pub position_confirmed: bool,
    /// With --recover or --from-line: you jogged the head back to the job's start corner (its
    /// lowest X and Y, where a frame starts, e.g. `stencil jog`): the controller's work position
    /// is set there (G92) before the resume. Add --frame to trace the job first.
    #[arg(long, conflicts_with = "position_confirmed")]
    pub head_at_corner: bool,
    #[command(flatten)]
    pub start: super::place::StartArgs,
    /// With --dry-run of an HP-GL job: abort as the abort key would once N instructions are
    /// sent, to rehearse a stop (the plotter's buffer cleared, the tool lifted).
    #[arg(long, value_name = "N", requires = "dry_run")]
    pub dry_run_abort_at: Option<usize>,
    /// With --dry-run of an HP-GL job: write what the virtual cutter ran (its instructions, byte
    /// for byte, as it cut them) to FILE.
    #[arg(long, value_name = "FILE", requires = "dry_run")]
    pub dry_run_record: Option<PathBuf>,
    /// Upload the job to the controller's own storage (SD card or flash: grblHAL by YModem,
    /// FluidNC by XModem), check it arrived whole (listed size, read back), run it there and
    /// follow it: a USB or WiFi drop cannot kill the cut. Grbl 1.1h has no card (refused).
    #[arg(long, conflicts_with_all = ["from_line", "recover", "send_response"])]
    pub to_card: bool,
}

/// Before an allowed job streams: a `$32=0` in it turns Grbl's laser mode off for the rest of the
/// job (and after it: Grbl keeps its settings), which the laser-mode check before the job cannot
/// see coming. Said with what it means at the machine.
fn warn_laser_mode_off(job: &Program) {
    for c in &job.machine_changes {
        let off = c
            .text
            .strip_prefix("$32=")
            .and_then(|v| v.trim().parse::<f64>().ok())
            .is_some_and(|v| v == 0.0);
        if off {
            eprintln!(
                "warning: {}: line {} `{}` turns Grbl's laser mode off: from there on Grbl runs \
                 the beam as a spindle, keeping it on through G0 travel and wherever motion \
                 stops (laser mode turns it off there), and pausing at every power change; \
                 Grbl keeps $32=0 after the job. Take the line out if this machine is a laser",
                job.name, c.line, c.text
            );
        }
    }
}

/// `--dry-run-setting $32=0`.
fn parse_setting(s: &str) -> Result<(u32, String), String> {
    let t = s.trim().trim_start_matches('$');
    let (k, v) = t
        .split_once('=')
        .ok_or_else(|| format!("`{s}`: expected $N=VALUE, e.g. $32=0"))?;
    let k: u32 = k
        .parse()
        .map_err(|_| format!("`{s}`: the setting number must be a whole number, e.g. $32=0"))?;
    let x: f64 = v
        .parse()
        .map_err(|_| format!("`{s}`: the value must be a number, e.g. $32=0"))?;
    if !x.is_finite() {
        return Err(format!("`{s}`: the value must be a finite number"));
    }
    Ok((k, v.to_string()))
}

/// `--dry-run-fault close@60`.
fn parse_fault(s: &str) -> Result<Fault, String> {
    let usage = "expected KIND@N with KIND one of close, silence, freeze, drop-ok, garble-ok, \
                 power-loss, drop-link, error:C, alarm:C and N the G-code line (1 or more), e.g. close@60";
    let (kind, at) = s.split_once('@').ok_or_else(|| format!("`{s}`: {usage}"))?;
    let at: usize = at
        .parse()
        .ok()
        .filter(|&n| n >= 1)
        .ok_or_else(|| format!("`{s}`: {usage}"))?;
    let code = |c: &str, range: std::ops::RangeInclusive<u8>| {
        c.parse::<u8>()
            .ok()
            .filter(|n| range.contains(n))
            .ok_or_else(|| format!("`{s}`: the code must be in {range:?}"))
    };
    let kind = match kind.split_once(':') {
        None if kind == "close" => FaultKind::ClosePort,
        None if kind == "silence" => FaultKind::Silence,
        None if kind == "freeze" => FaultKind::Freeze,
        None if kind == "drop-ok" => FaultKind::DropOk,
        None if kind == "garble-ok" => FaultKind::GarbleOk,
        None if kind == "power-loss" => FaultKind::PowerLoss,
        None if kind == "drop-link" => FaultKind::DropLink,
        Some(("error", c)) => FaultKind::Error(code(c, 1..=38)?),
        Some(("alarm", c)) => FaultKind::Alarm(code(c, 1..=9)?),
        _ => return Err(format!("`{s}`: {usage}")),
    };
    Ok(Fault {
        at_job_line: at,
        kind,
    })
}

/// `--dry-run-fault` for a plotter job: what its virtual line can rehearse.
fn plotter_faults(faults: &[Fault]) -> anyhow::Result<Vec<stencil_hpgl::stream::LineFault>> {
    use stencil_hpgl::stream::{LineFault, LineFaultKind};
    faults
        .iter()
        .map(|f| {
            let kind = match f.kind {
                FaultKind::ClosePort => LineFaultKind::PortLost,
                FaultKind::PowerLoss => LineFaultKind::PowerLoss,
                _ => bail!(
                    "--dry-run-fault: the virtual plotter cutter rehearses close@N (the port goes \
                     away) and power-loss@N (the plotter loses power), N its N-th instruction"
                ),
            };
            Ok(LineFault {
                at_instruction: f.at_job_line,
                kind,
            })
        })
        .collect()
}

/// Refuse, before a port is opened, a file with no move at all whose first line stencil does not
/// read as G-code: some other file given by mistake (`/etc/passwd`), which would otherwise be
/// streamed for the controller to reject (and its first line quoted back in that error). A real
/// program with commands stencil does not know still goes to Grbl to judge.
fn refuse_non_gcode(path: &Path, job: &Program, text: &str) -> anyhow::Result<()> {
    if !job.moves.is_empty() {
        return Ok(());
    }
    if let Err(e) = stencil_gcode::interpret::interpret(text) {
        bail!(
            "{}: not a G-code program (line {} is not G-code, and no line moves the machine); \
             nothing was sent",
            path.display(),
            e.line
        );
    }
    Ok(())
}

/// What the machine profile says about lifting the tool for a resume's travel (a pen or knife on
/// Z); lasers and servo pens need none beyond the `M5` the restore starts with.
fn resume_lift(machine: &machine_profile::Machine) -> ResumeLift {
    use machine_profile::{PenLift, Tool};
    match machine.tool {
        Tool::Pen(PenLift::Z(z)) | Tool::Knife { z, .. } => ResumeLift {
            z_up_mm: Some(z.up_mm),
            plunge_mm_min: Some(z.plunge_mm_min),
        },
        Tool::Laser { .. } | Tool::Pen(PenLift::Spindle { .. }) => ResumeLift::default(),
    }
}

/// A laser machine running a job that switches the beam on needs laser mode; anything else
/// leaves `$32` alone (a pen servo or a spindle must not be put in laser mode).
fn laser_mode(machine: &machine_profile::Machine, job: &Program, set: bool) -> LaserMode {
    let fires = job.moves.iter().any(|m| m.power > 0.0);
    match machine.tool {
        machine_profile::Tool::Laser { .. } if fires && set => LaserMode::Set,
        machine_profile::Tool::Laser { .. } if fires => LaserMode::Require,
        _ => LaserMode::Ignore,
    }
}

/// The simulated Grbl of `--dry-run`: instant, or paced as the machine and link would run
/// (`--realtime`), with the `--dry-run-setting`s and `--dry-run-fault`s asked for.
fn virtual_config(a: &SendArgs, machine: &machine_profile::Machine) -> VirtualConfig {
    VirtualConfig {
        pace: if a.realtime {
            Pace::Timed { speedup: 1.0 }
        } else {
            Pace::Instant
        },
        baud: a.realtime.then_some(a.link.baud),
        faults: a.dry_run_fault.clone(),
        ..super::port::virtual_for(machine, &a.dry_run_setting)
    }
}

/// The options that reach the same machine again (`--port P` or `--dry-run`).
fn link_options(a: &SendArgs) -> String {
    match &a.link.port {
        Some(p) => format!(" --port {p}"),
        None if a.link.dry_run => " --dry-run".into(),
        None => String::new(),
    }
}

/// A stream that stopped, worded with the options that resume it: the command for the line to
/// resume from (unlocking a machine the stop left locked), and `--recover` with the journal.
fn stopped(a: &SendArgs, journal_path: &Path, e: stencil_grbl::MachineError) -> anyhow::Error {
    let hint = match e.halt() {
        Some(h) => format!(
            "\nto resume: stencil send {} --from-line {}{}{}{}\n(the journal {} keeps this; \
             after a crash or power loss: stencil send {} --recover{})",
            a.file.display(),
            h.resume_from,
            link_options(a),
            if h.locked { " --unlock" } else { "" },
            match &a.machine {
                Some(m) => format!(" --machine {m}"),
                None => String::new(),
            },
            journal_path.display(),
            a.file.display(),
            link_options(a),
        ),
        None => String::new(),
    };
    // An abort says what asked for it (a signal, which one, or a key), here and in the journal,
    // where the stream wrote only that the operator aborted.
    let text = match &e {
        stencil_grbl::MachineError::Aborted { halt } => {
            let text = format!("{}; {halt}", abort_cause());
            if let Ok(mut j) = Journal::read(journal_path) {
                if j.state == RunState::Stopped {
                    j.stop_reason = Some(text.clone());
                    let _ = j.write(journal_path);
                }
            }
            text
        }
        e => e.to_string(),
    };
    anyhow::anyhow!("{text}{}{hint}", super::port::machine_hint(&e))
}

pub fn run_send(a: SendArgs) -> anyhow::Result<ExitCode> {
    if super::send_hpgl::is_hpgl_file(&a.file) {
        if a.to_card {
            anyhow::bail!(
                "{}: --to-card runs a G-code job from a grblHAL or FluidNC board's card; a \
                 plotter has no card: send the HP-GL job without --to-card",
                a.file.display()
            );
        }
        return super::send_hpgl::run_send_hpgl(super::send_hpgl::SendHpgl {
            file: &a.file,
            machine: a.machine.as_deref(),
            port: a.link.port.as_deref(),
            dry_run: a.link.dry_run,
            from_line: a.from_line as usize,
            recover: a.recover,
            abort_at: a.dry_run_abort_at,
            faults: plotter_faults(&a.dry_run_fault)?,
            record: a.dry_run_record.as_deref(),
        });
    }
    if a.dry_run_record.is_some() {
        bail!(
            "{}: --dry-run-record writes what a virtual plotter cutter ran, for an HP-GL job \
             (.plt); a G-code dry run prints what the virtual Grbl did",
            a.file.display()
        );
    }
    let text = read_program(&a.file)?;
    eprintln!("{}", origin_line(&a.file, &text));
    let name = a.file.display().to_string();
    let job = Program::parse(&name, &text)?;
    refuse_non_gcode(&a.file, &job, &text)?;
    if a.allow_machine_commands {
        warn_laser_mode_off(&job);
    } else {
        name_machine_changes(&job);
    }
    if job.dropped_percent > 0 {
        println!(
            "{name}: {} `%` line(s) left out: they mark a program's start and end for other \
             controllers, and Grbl 1.1 answers them error:1",
            job.dropped_percent
        );
    }
    if let Some(&line) = job.pauses.first() {
        // M0: Grbl holds until cycle start, which only someone at the terminal gives (`r`).
        if !std::io::stdin().is_terminal() {
            anyhow::bail!(
                "{name}: line {line} has M0 (program pause): Grbl holds there until cycle start, \
                 which send takes from the terminal (r); run it at a terminal, or take the M0 out"
            );
        }
        println!(
            "{name}: M0 at line(s) {:?}: the machine holds there; press r to go on",
            job.pauses
        );
    }
    let journal_path = stencil_grbl::journal_path(&a.file);
    let (from_line, machine_arg, journal) = if a.recover {
        match recover(a.machine.as_ref(), &job, &text, &journal_path)? {
            Some((line, m, j)) => (line, m, Some(j)),
            None => return Ok(ExitCode::SUCCESS),
        }
    } else {
        // A resume from a line checks the controller's position against the journal too, when
        // one for this very file is there.
        let j = (a.from_line > 1)
            .then(|| Journal::read(&journal_path).ok())
            .flatten()
            .filter(|j| j.check_file(&journal_path, text.as_bytes()).is_ok());
        (a.from_line as usize, a.machine.clone(), j)
    };
    let machine = machine_profile::load(machine_arg.as_deref())?;
    // `--frame` without `--yes` asks on the terminal: refused before the controller is asked
    // anything when there is none.
    if a.frame && !a.yes && !std::io::stdin().is_terminal() {
        bail!(
            "--frame asks on the terminal before starting the job, but stdin is not a terminal: \
             pass --yes to start right after framing, or frame first with `stencil frame`"
        );
    }
    let dump = (a.start.controller_state.as_deref())
        .map(super::place::read_dump)
        .transpose()?;
    let super::port::Opened {
        mut port,
        label,
        virtual_grbl,
        tcp,
    } = a.link.open(super::place::virtual_from(
        virtual_config(&a, &machine),
        dump.as_ref(),
    ))?;
    // Where the job goes, from what the controller holds: a recovery puts it where the
    // journal's run had it; a fresh run where --start-from says.
    let reading = super::place::read_controller(
        port.as_mut(),
        Duration::from_secs_f64(a.timeout_s),
        a.link.if_moving(),
    )?;
    let state = &reading.state;
    let placement = placement_for(&a, state, &machine, journal.as_ref(), from_line)?;
    println!("{}", placement.describe());
    let job = Program::parse_from(&name, &text, placement.modal)?;
    // The moves that will run (from --from-line or the recovered line on) must stay on the bed,
    // where the controller's offsets put them: checked before anything moves.
    let to_run: Vec<Move> = job
        .moves
        .iter()
        .filter(|m| m.line >= from_line)
        .copied()
        .collect();
    super::place::check_bed(&a.file, &to_run, &machine, a.no_bed_check, &placement)?;
    let home_first = a.recover && machine.motion.homing;
    if home_first {
        println!(
            "machine {} homes ($22=1 in its profile): homing ($H) before anything moves",
            machine.name
        );
    }
    // With --frame, the whole file's extent is traced (a resumed job still lands where the file
    // says).
    let frame = (a.frame)
        .then(|| super::frame::setup(&a.file, &job, &machine, a.frame_feed, a.no_bed_check))
        .transpose()?;
    let mut cfg = stream_config(&a, &machine, &job, from_line, home_first);
    cfg.expect = super::port::expected(&machine, &text, &job);
    cfg.place_zero = Some(placement.zero);
    if a.recover || from_line > 1 {
        cfg.recovery = Some(stencil_grbl::Recovery {
            last_position: journal.as_ref().and_then(|j| j.last_position),
            last_acked: journal.as_ref().and_then(|j| j.last_acked_line),
            confirmed: a.position_confirmed,
            at_corner: a.head_at_corner.then(|| job.start_corner()),
            follow: a.recover,
            last_sent: journal.as_ref().and_then(|j| j.last_sent_line),
            grbl_stopped: journal.as_ref().is_some_and(|j| j.grbl_stopped),
            cut_short: reading.stopped_running,
        });
    }

    let (tx, rx) = channel();
    if let Some(s) = &frame {
        let keys = Keys::start(tx.clone());
        let mut say = super::frame::Say { raw: keys.raw };
        let corner = job.start_corner();
        // The frame traces where the job will cut: the head put back at its corner, or the
        // job's zero put where its placement says, before it starts.
        let g92 = if a.head_at_corner {
            Some(format!(
                "G92X{}Y{}",
                stencil_gcode::num(corner[0]),
                stencil_gcode::num(corner[1])
            ))
        } else {
            super::place::g92_needed(&placement, state)
        };
        let framed = super::frame::frame_on(port.as_mut(), &cfg, &rx, &mut say, s, g92.as_deref());
        drop(keys);
        if !framed_and_started(framed, &label, a.yes)? {
            return Ok(ExitCode::SUCCESS);
        }
        // The controller is awake and idle: no need to wait for a boot banner.
        cfg.boot_wait = Duration::from_millis(300);
    }
    if a.to_card {
        let run = card::Run {
            port,
            label,
            virtual_grbl,
            tcp,
        };
        return card::run(run, &job, &cfg, tx, &rx);
    }
    let keys = Keys::start(tx);
    let mut bar = Bar::new(&job, &text, machine.motion, keys.raw);
    if keys.raw {
        bar.say(&format!("keys: {}", stencil_grbl::SEND_KEY_HELP));
    }
    // The profile by its name and content, never the path it was read from: a recovery
    // loads profiles by name only.
    let mut started = Journal::new(&a.file, text.as_bytes(), &job, &machine.name, from_line);
    started.machine_fnv1a64 = Some(profile_fingerprint(&machine));
    started.placement = Some(stencil_grbl::PlacementRecord {
        start_from: placement.start_from.name().into(),
        zero_mm: placement.zero,
    });
    let mut journal = JournalWriter::new(
        &mut bar,
        started,
        journal_path.clone(),
        &job,
        ClockRef::default(),
        stencil_grbl::JOURNAL_EVERY,
    );
    let result = stencil_grbl::send(port.as_mut(), &job, &cfg, Some(&rx), &mut journal);
    journal.finish(&result);
    bar.bar.finish_and_clear();
    drop(keys);
    let sum = match result {
        Ok(s) => s,
        Err(e) => {
            if let (Some(tcp), stencil_grbl::MachineError::PortLost { .. }) = (&tcp, &e) {
                drop(port);
                super::port::after_drop(tcp, &cfg);
            }
            if let Some(vg) = virtual_grbl {
                print_virtual(vg);
            }
            return Err(stopped(&a, &journal_path, e));
        }
    };
    print_summary(&sum, &label, virtual_grbl);
    Ok(ExitCode::SUCCESS)
}

/// Where this run puts the job: a resume with a journal that kept its run's placement puts it
/// there again (a stop's reset cleared G92); otherwise `--start-from` or the default. `current`
/// is refused for a resume without one: the head stands somewhere in the job, not at its zero.
fn placement_for(
    a: &SendArgs,
    state: &ControllerState,
    machine: &machine_profile::Machine,
    journal: Option<&Journal>,
    from_line: usize,
) -> anyhow::Result<Placement> {
    let kept = journal.and_then(|j| j.placement.as_ref());
    if let Some(k) = kept {
        let start: StartFrom = k
            .start_from
            .parse()
            .map_err(|e: String| anyhow::anyhow!(e))?;
        if a.start.start_from.is_some_and(|s| s != start) {
            println!(
                "the journal's run started from {}: resuming there (--start-from is for a new run)",
                start.name()
            );
        }
        return Ok(Placement::at(start, k.zero_mm, state));
    }
    let start = super::place::choose(a.start.start_from, state, machine);
    if start == StartFrom::Current && from_line > 1 {
        bail!(
            "--start-from current puts the job's X0 Y0 where the head stands, but a resume from              line {from_line} finds the head inside the job: resume with --recover (the journal              keeps where the run started), or with --start-from work-zero once the work zero is              where the run's was"
        );
    }
    Ok(Placement::new(start, state))
}

/// After framing: say where the frame went, then (unless --yes) ask whether to start. False when
/// the user says no: nothing was cut.
fn framed_and_started(
    framed: anyhow::Result<stencil_grbl::Framed>,
    label: &str,
    yes: bool,
) -> anyhow::Result<bool> {
    eprintln!("{}", super::frame::framed_line(&framed?, label));
    if !yes && !super::frame::ask_start(&mut std::io::stdin().lock())? {
        eprintln!("not started: nothing was cut");
        return Ok(false);
    }
    Ok(true)
}

/// How the job is streamed: the flow control, Grbl's buffer, the timeout, what happens before
/// the first line (unlock, check mode, homing, a resume's lift), the rapid feed and laser mode.
fn stream_config(
    a: &SendArgs,
    machine: &machine_profile::Machine,
    job: &Program,
    from_line: usize,
    home_first: bool,
) -> StreamConfig {
    StreamConfig {
        flow: if a.send_response {
            FlowControl::SendResponse
        } else {
            FlowControl::CharacterCounting
        },
        rx_buffer: a.rx_buffer,
        timeout: Duration::from_secs_f64(a.timeout_s),
        unlock: a.unlock,
        check_first: a.check,
        from_line,
        home_first,
        lift: resume_lift(machine),
        rapid_mm_min: Some(machine.motion.rapid_mm_min),
        laser_mode: laser_mode(machine, job, a.set_laser_mode),
        rescale_power: a.rescale_power,
        allow_machine_commands: a.allow_machine_commands,
        if_moving: a.link.if_moving(),
        ..StreamConfig::default()
    }
}
