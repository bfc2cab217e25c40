//! `stencil send`: stream G-code to Grbl, or to the virtual Grbl with --dry-run.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Sender};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::bail;
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use stencil_gcode::interpret::{CutRule, Move};
use stencil_gcode::machine as machine_profile;
use stencil_gcode::{estimate_program_from, format_duration};
use stencil_grbl::journal::{self, Journal, JournalWriter, RunState};
use stencil_grbl::keys::{self, Key, KeySource};
use stencil_grbl::placement::{ControllerState, Placement, StartFrom};
use stencil_grbl::stall::ClockRef;
use stencil_grbl::stream::{
    self, Control, ControllerInfo, FlowControl, LaserMode, Observer, Program, Progress, ResumeLift,
    StreamConfig, Summary,
};
use stencil_grbl::virtual_grbl::{Fault, FaultKind, Pace, VirtualConfig, VirtualGrbl};

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
    #[arg(long, default_value_t = 10.0, value_parser = parse_timeout)]
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
    /// restarts at machine zero), `error:C@N`, `alarm:C@N`. To rehearse a stop and its recovery.
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
    #[arg(long, value_name = "MM_MIN", requires = "frame", value_parser = super::frame::parse_feed)]
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
}

/// Say which lines of a job would change the machine itself (a `$` setting, homing, a stored
/// offset...): `send` refuses them unless `--allow-machine-commands` is given.
pub(super) fn name_machine_changes(job: &Program) {
    for c in &job.machine_changes {
        machine_change_note(&job.name, c.line, &c.text, &c.what);
    }
}

/// [`name_machine_changes`] for a file read as text (the commands that do not stream it).
pub(super) fn name_machine_changes_in(path: &Path, text: &str) {
    for (i, raw) in text.lines().enumerate() {
        let clean = stencil_gcode::interpret::clean_line(raw);
        if let Some(what) = stream::machine_change(&clean) {
            machine_change_note(&path.display().to_string(), i + 1, &clean, &what);
        }
    }
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

fn machine_change_note(file: &str, line: usize, text: &str, what: &str) {
    eprintln!(
        "note: {file}: line {line} `{text}` {what}: `stencil send` refuses it unless \
         --allow-machine-commands is given"
    );
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
                 power-loss, error:C, alarm:C and N the G-code line (1 or more), e.g. close@60";
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
        Some(("error", c)) => FaultKind::Error(code(c, 1..=38)?),
        Some(("alarm", c)) => FaultKind::Alarm(code(c, 1..=9)?),
        _ => return Err(format!("`{s}`: {usage}")),
    };
    Ok(Fault {
        at_job_line: at,
        kind,
    })
}

/// `--timeout-s`: from a tenth of a second (a reply takes milliseconds) to an hour (Grbl answers
/// a status query within a fraction of a second, even mid-move).
pub(super) fn parse_timeout(s: &str) -> Result<f64, String> {
    super::number_in(s, 0.1..=3600.0, " seconds")
}

/// A G-code file, read through the bounded reader (at most 512 MB; a FIFO or a device is refused
/// at once). A `stencil make` folder it lies in (or, for a layer's job, the set's folder around
/// it) that a killed run left half-swapped is finished first ([`settle`]), so the program is
/// never one run's beside another run's files, nor the previous design's layer.
pub(super) fn read_program(path: &Path) -> anyhow::Result<String> {
    settle(path)?;
    Ok(stencil_io::read_text(path, stencil_io::Kind::Gcode)?)
}

/// Before `path` (a file or a folder) is read: finish or discard a half-finished swap of `make`
/// in the folder it is, and in the set folder around it when it is a layer's
/// ([`stencil_io::recover_around`]), saying so.
pub(super) fn settle(path: &Path) -> anyhow::Result<()> {
    for (dir, r) in stencil_io::recover_around(path, stencil_core::layers::owned_names())? {
        match r {
            stencil_io::Recovered::Nothing => {}
            stencil_io::Recovered::Finished => eprintln!(
                "note: {}: finished writing the files of a `stencil make` that was stopped while \
                 it put them in place",
                dir.display()
            ),
            stencil_io::Recovered::Discarded => eprintln!(
                "note: {}: deleted the unfinished files of a `stencil make` that was stopped \
                 before it put them in place; the folder holds the run before it",
                dir.display()
            ),
        }
    }
    Ok(())
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

/// The job's origin, from its header and the file's time, printed before anything moves: which
/// picture, material, size and machine the file was made for, and when it was written, so that
/// an old job is not taken for a new one. (When it was made is the file's time, not a header
/// line: the same input and options still give the same bytes.)
pub(super) fn origin_line(path: &Path, text: &str) -> String {
    let header: Vec<&str> = text
        .lines()
        .map(str::trim)
        .take_while(|l| l.starts_with(';') || l.is_empty())
        .filter_map(|l| l.strip_prefix(';').map(str::trim))
        .collect();
    let when = std::fs::metadata(path)
        .and_then(|m| m.modified())
        .map_or(String::new(), |t| {
            format!("; file written {}", super::errors::utc(t))
        });
    let Some(first) = header.first().filter(|l| l.starts_with("stencil ")) else {
        return format!(
            "job {}: not written by stencil (no header saying what it was made from){when}",
            path.display()
        );
    };
    let machine = first
        .split_once(" for ")
        .map(|(_, m)| m.split(':').next().unwrap_or(m).trim());
    let mut parts: Vec<String> = Vec::new();
    for l in &header[1..] {
        if let Some(from) = l.strip_prefix("from ") {
            parts.push(format!("from {}", stencil_io::excerpt(from)));
        } else if let Some(m) = l.strip_prefix("material ") {
            parts.push(format!("material {}", stencil_io::excerpt(m)));
        } else if let Some(job) = l.strip_prefix("job ") {
            let size = job.split(" at ").next().unwrap_or(job);
            parts.push(stencil_io::excerpt(size));
        }
    }
    if let Some(m) = machine {
        parts.push(format!("for {}", stencil_io::excerpt(m)));
    }
    format!("job {}: {}{when}", path.display(), parts.join(", "))
}

/// What asked for an abort, the first that did: a stop signal or a key, said in the stop's message
/// and the journal (the stream knows only that an abort was asked for).
static ABORT_CAUSE: std::sync::OnceLock<&'static str> = std::sync::OnceLock::new();

/// The stop's first words for an abort: what asked for it.
pub(super) fn abort_cause() -> &'static str {
    ABORT_CAUSE
        .get()
        .copied()
        .unwrap_or("aborted by the operator")
}

/// SIGINT, SIGTERM and SIGHUP take the abort's path, once per process, each named as it arrives.
#[cfg(unix)]
fn on_stop_signals(tx: Sender<Control>) {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
            return;
        };
        std::thread::spawn(move || {
            for sig in signals.forever() {
                let _ = ABORT_CAUSE.set(match sig {
                    SIGINT => "stopped by SIGINT (Ctrl-C)",
                    SIGTERM => {
                        "stopped by SIGTERM (a request to end stencil: `kill`, a service manager \
                         or a shutdown)"
                    }
                    _ => "stopped by SIGHUP (the terminal closed)",
                });
                let _ = tx.send(Control::Abort);
            }
        });
    });
}

/// Ctrl-C (and closing the console) take the abort's path, once per process.
#[cfg(not(unix))]
fn on_stop_signals(tx: Sender<Control>) {
    let _ = ctrlc::set_handler(move || {
        let _ = ABORT_CAUSE.set("stopped by Ctrl-C");
        let _ = tx.send(Control::Abort);
    });
}

/// Keys from the terminal in raw mode (no Enter needed; Ctrl-C arrives as a key). Restores the
/// terminal when dropped, also on error paths.
pub(super) struct Keys {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    pub(super) raw: bool,
}

impl Keys {
    pub(super) fn start(tx: Sender<Control>) -> Keys {
        let stop = Arc::new(AtomicBool::new(false));
        // SIGINT, SIGTERM and SIGHUP (the terminal closed, a service manager stopping us) take
        // the abort's path: hold, wait until the machine stands, reset, laser and air off. One
        // handler per process: `send --frame` starts keys twice on the same channel, so the
        // first handler serves both.
        on_stop_signals(tx.clone());
        if std::io::stdin().is_terminal() && crossterm::terminal::enable_raw_mode().is_ok() {
            let stop2 = stop.clone();
            let thread = std::thread::spawn(move || keys::pump(&mut Terminal, &tx, &stop2));
            return Keys {
                stop,
                thread: Some(thread),
                raw: true,
            };
        }
        Keys {
            stop,
            thread: None,
            raw: false,
        }
    }
}

impl Drop for Keys {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        if self.raw {
            let _ = crossterm::terminal::disable_raw_mode();
        }
    }
}

/// The terminal in raw mode as a key source (crossterm: already how raw mode is entered here, and
/// it reads keys the same way on Unix and Windows).
struct Terminal;

impl KeySource for Terminal {
    fn next_key(&mut self, wait: Duration) -> std::io::Result<Option<Key>> {
        use crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
        if !event::poll(wait)? {
            return Ok(None);
        }
        let Event::Key(k) = event::read()? else {
            return Ok(None);
        };
        if k.kind == KeyEventKind::Release {
            return Ok(None);
        }
        let key = match k.code {
            KeyCode::Char('c') if k.modifiers.contains(KeyModifiers::CONTROL) => Key::CtrlC,
            KeyCode::Char(c) => Key::Char(c),
            KeyCode::Esc => Key::Esc,
            _ => return Ok(None),
        };
        if keys::controls_for(key) == [Control::Abort] {
            let _ = ABORT_CAUSE.set(match key {
                Key::CtrlC => "aborted with Ctrl-C",
                Key::Esc => "aborted with the abort key (Esc)",
                Key::Char('q') => "aborted with the abort key (q)",
                _ => "aborted with the abort key (a)",
            });
        }
        Ok(Some(key))
    }
}

/// The progress bar: lines acknowledged, percent, machine state and position, elapsed and
/// remaining time (estimated over the moves that have not run yet).
struct Bar {
    bar: ProgressBar,
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
    fn new(job: &Program, text: &str, limits: machine_profile::Motion, raw: bool) -> Bar {
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

    fn say(&self, text: &str) {
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
            "connected to Grbl {} ({} planner blocks, {}-byte receive buffer){}",
            info.version,
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
                self.state = format!("{} {}", self.state, keys::overrides_text(ov));
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

/// `limits` with the rapid rate, acceleration and junction deviation the controller reported in
/// `$$` (the slower axis of X and Y), where it did.
pub(super) fn controller_motion(
    mut limits: machine_profile::Motion,
    info: &ControllerInfo,
) -> machine_profile::Motion {
    let lower = |a: u32, b: u32| match (info.setting(a), info.setting(b)) {
        (Some(x), Some(y)) => Some(x.min(y)),
        (x, y) => x.or(y),
    };
    if let Some(r) = lower(110, 111).filter(|r| *r > 0.0) {
        limits.rapid_mm_min = r;
        limits.max_feed_mm_min = limits.max_feed_mm_min.min(r);
    }
    if let Some(a) = lower(120, 121).filter(|a| *a > 0.0) {
        limits.accel_mm_s2 = a;
    }
    if let Some(j) = info.setting(11).filter(|j| *j > 0.0) {
        limits.junction_deviation_mm = j;
    }
    // Per axis, as Grbl limits each block by its tightest axis (a slow Z), and the steps per mm
    // its blocks are rounded to: only when the controller gives all three.
    let axes = |first: u32| -> Option<[f64; 3]> {
        let v = [first, first + 1, first + 2].map(|k| info.setting(k).filter(|x| *x > 0.0));
        Some([v[0]?, v[1]?, v[2]?])
    };
    if let Some(r) = axes(110) {
        limits.axis_rate_mm_min = Some(r);
    }
    if let Some(a) = axes(120) {
        limits.axis_accel_mm_s2 = Some(a);
    }
    if let Some(s) = axes(100) {
        limits.steps_per_mm = Some(s);
    }
    if let Some(ms) = info.setting(1).filter(|ms| *ms >= 0.0) {
        limits.idle_lock_ms = Some(ms);
    }
    limits
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

/// Tell the user what the journal knows and where the job will resume; `None` if there is
/// nothing left to do.
fn recovery_report(j: &Journal, job: &Program, path: &std::path::Path) -> Option<usize> {
    let age = j.age().as_secs_f64();
    let how = match j.state {
        RunState::Running => {
            "did not end (the sender was killed, crashed, or the power went)".to_string()
        }
        // The journal is a file that may have come from elsewhere: its text is printed with its
        // control characters written out.
        RunState::Stopped => format!(
            "stopped: {}",
            stencil_io::printable(j.stop_reason.as_deref().unwrap_or("(no reason recorded)"))
        ),
        RunState::Complete => "finished".to_string(),
    };
    println!(
        "journal {}: the run of {} from line {} on {}, last written {} ago, {how}",
        path.display(),
        stencil_io::printable(&j.file),
        j.from_line,
        stencil_io::printable(&j.machine),
        format_duration(age)
    );
    let end = job.source_lines();
    let p = j.proposal(job);
    if j.state == RunState::Complete || p.line > end {
        println!("every line of the job ran: nothing to recover");
        return None;
    }
    match j.last_acked_line {
        Some(l) => println!("last acknowledged line: {l}"),
        None => println!("no line was acknowledged"),
    }
    let m = &j.modal;
    println!(
        "{}; resuming from line {} with the program's state there: {} {}, {}, {}{}, air {}, at X{:.3} Y{:.3} Z{:.3}",
        p.why,
        p.line,
        stencil_io::printable(&m.units),
        stencil_io::printable(&m.distance),
        match m.feed_mm_min {
            Some(f) => format!("F{f}"),
            None => "no feed yet".into(),
        },
        stencil_io::printable(&m.spindle),
        if m.spindle != "M5" { format!(" S{}", m.s) } else { String::new() },
        if m.air { "on" } else { "off" },
        m.position_mm[0],
        m.position_mm[1],
        m.position_mm[2]
    );
    Some(p.line)
}

/// `--recover`: read the journal beside the file, check it was written for this file, say what
/// it knows, and propose where to resume: the line and the machine to use (the journal's unless
/// one was named); `None` when nothing is left to do.
fn recover(
    a: &SendArgs,
    job: &Program,
    text: &str,
    journal_path: &Path,
) -> anyhow::Result<Option<(usize, Option<String>, Journal)>> {
    let journal_error =
        |e: journal::JournalError| anyhow::anyhow!("{e}{}", super::port::journal_hint(&e));
    let j = Journal::read(journal_path).map_err(journal_error)?;
    j.check_file(journal_path, text.as_bytes())
        .map_err(journal_error)?;
    let machine = journal_machine(a, &j, journal_path)?;
    Ok(recovery_report(&j, job, journal_path).map(|line| (line, machine, j)))
}

/// A machine profile's content as the journal keeps it (its validated values, every field).
fn profile_fingerprint(m: &machine_profile::Machine) -> String {
    journal::fingerprint(&format!("{m:?}"))
}

/// The machine profile a recovery runs with: the one named with `--machine`, else the
/// journal's, which is looked up by name only (a journal is a file beside the job: the path
/// of a file it names is never opened). Either way it must be the profile the run used, by
/// name and content; any other is refused before anything is sent.
fn journal_machine(
    a: &SendArgs,
    j: &Journal,
    journal_path: &Path,
) -> anyhow::Result<Option<String>> {
    // Quoted with control characters escaped: a journal is not trusted to hold a name.
    let named = |m: &str| stencil_io::excerpt(&m.escape_debug().to_string());
    let arg = match &a.machine {
        Some(m) => m.clone(),
        None => {
            let plain = !j.machine.is_empty()
                && !j.machine.contains(['/', '\\'])
                && !j.machine.ends_with(".toml")
                && j.machine.chars().all(|c| c.is_ascii_graphic());
            if !plain {
                bail!(
                    "{}: the journal names its machine profile as `{}`, which is not a profile \
                     name; a recovery never opens a file a journal names: name the profile the \
                     run used with --machine; nothing was sent",
                    journal_path.display(),
                    named(&j.machine)
                );
            }
            j.machine.clone()
        }
    };
    let m = match machine_profile::load(Some(&arg)) {
        Ok(m) => m,
        Err(e) if a.machine.is_none() => bail!(
            "{}: the journal's run used machine profile `{}`, which cannot be loaded by name \
             here ({e}): name the profile the run used with --machine; nothing was sent",
            journal_path.display(),
            named(&j.machine)
        ),
        Err(e) => return Err(e.into()),
    };
    let same_name = m.name == j.machine;
    let same_content = j
        .machine_fnv1a64
        .as_ref()
        .is_none_or(|h| *h == profile_fingerprint(&m));
    if !(same_name && same_content) {
        bail!(
            "{}: the journal's run used machine profile `{}`{}, but {} is {}: a resume must run \
             with the profile the run used (its bed, its limits, its power scale); nothing was \
             sent. Recover with that profile (--machine), or resume from a line after checking \
             (--from-line)",
            journal_path.display(),
            named(&j.machine),
            if j.machine_fnv1a64.is_some() {
                " (as it was then)"
            } else {
                ""
            },
            match &a.machine {
                Some(given) => format!("--machine {}", named(given)),
                None => format!("the profile `{}` now", named(&arg)),
            },
            if same_name {
                "that profile with other settings".to_string()
            } else {
                format!("profile `{}`", named(&m.name))
            }
        );
    }
    Ok(Some(arg))
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
fn stopped(a: &SendArgs, journal_path: &Path, e: stream::MachineError) -> anyhow::Error {
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
        stream::MachineError::Aborted { halt } => {
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

/// What a finished stream did, and with `--dry-run` what the simulated machine saw.
fn print_summary(sum: &Summary, label: &str, virtual_grbl: Option<VirtualGrbl>) {
    let secs = sum.elapsed.as_secs_f64();
    println!(
        "sent {} lines ({} bytes) to {label}: streamed in {:.2} s ({:.0} bytes/s), job done after {}; Grbl {}, counting against {} bytes, at most {} in flight",
        sum.lines,
        sum.bytes,
        secs,
        if secs > 0.0 { sum.bytes as f64 / secs } else { 0.0 },
        format_duration(sum.total.as_secs_f64()),
        sum.info.version,
        sum.rx_limit,
        sum.max_in_flight
    );
    if let Some(vg) = virtual_grbl {
        print_virtual(vg);
    }
}

/// What the simulated machine of a dry run saw, and how it was left (also after a stop).
fn print_virtual(vg: VirtualGrbl) {
    let r = vg.stop();
    let alarms: Vec<String> = r
        .events
        .iter()
        .filter_map(|e| match e {
            stencil_grbl::virtual_grbl::Event::Alarm(c) => Some(format!("ALARM:{c}")),
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
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for m in r.moves.iter().filter(|m| m.beam && m.moves_xy()) {
        for p in [m.from, m.to] {
            for a in 0..2 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
    }
    if lo[0].is_finite() {
        println!(
            "virtual Grbl: the beam cut within machine X {:.3}..{:.3} Y {:.3}..{:.3}",
            lo[0], hi[0], lo[1], hi[1]
        );
    }
}

pub fn run_send(a: SendArgs) -> anyhow::Result<ExitCode> {
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
    let journal_path = journal::path_for(&a.file);
    let (from_line, machine_arg, journal) = if a.recover {
        match recover(&a, &job, &text, &journal_path)? {
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
    frame_can_ask(&a)?;
    let dump = match &a.start.controller_state {
        Some(p) => Some(super::place::read_dump(p)?),
        None => None,
    };
    let super::port::Opened {
        mut port,
        label,
        virtual_grbl,
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
    let state = reading.state;
    let placement = placement_for(&a, &state, &machine, journal.as_ref(), from_line)?;
    println!("{}", placement.describe());
    let job = super::place::placed(&name, &text, &placement)?;
    // The moves that will run (from --from-line or the recovered line on) must stay on the bed,
    // where the controller's offsets put them: checked before anything moves.
    let to_run: Vec<Move> = job
        .moves
        .iter()
        .filter(|m| m.line >= from_line)
        .copied()
        .collect();
    super::place::check_bed(&a.file, &to_run, &machine, a.no_bed_check, &placement)?;
    let limits = machine.motion;
    let home_first = a.recover && machine.motion.homing;
    if home_first {
        println!(
            "machine {} homes ($22=1 in its profile): homing ($H) before anything moves",
            machine.name
        );
    }
    let frame = frame_setup(&a, &job, &machine)?;
    let mut cfg = stream_config(&a, &machine, &job, from_line, home_first);
    cfg.expect = super::port::expected(&machine, &text, &job);
    cfg.place_zero = Some(placement.zero);
    if a.recover || from_line > 1 {
        cfg.recovery = Some(stream::Recovery {
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
            super::place::g92_needed(&placement, &state)
        };
        let framed = super::frame::frame_on(port.as_mut(), &cfg, &rx, &mut say, s, g92.as_deref());
        drop(keys);
        if !framed_and_started(framed, &label, a.yes)? {
            return Ok(ExitCode::SUCCESS);
        }
        // The controller is awake and idle: no need to wait for a boot banner.
        cfg.boot_wait = Duration::from_millis(300);
    }
    let keys = Keys::start(tx);
    let mut bar = Bar::new(&job, &text, limits, keys.raw);
    if keys.raw {
        bar.say(&format!("keys: {}", keys::KEY_HELP));
    }
    // The profile by its name and content, never the path it was read from: a recovery
    // loads profiles by name only.
    let mut started = Journal::new(&a.file, text.as_bytes(), &job, &machine.name, from_line);
    started.machine_fnv1a64 = Some(profile_fingerprint(&machine));
    started.placement = Some(journal::PlacementRecord {
        start_from: placement.start_from.name().into(),
        zero_mm: placement.zero,
    });
    let mut journal = JournalWriter::new(
        &mut bar,
        started,
        journal_path.clone(),
        &job,
        ClockRef::default(),
        journal::EVERY,
    );
    let result = stream::send(port.as_mut(), &job, &cfg, Some(&rx), &mut journal);
    journal.finish(&result);
    bar.bar.finish_and_clear();
    drop(keys);
    let sum = match result {
        Ok(s) => s,
        Err(e) => {
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
    framed: anyhow::Result<stencil_grbl::frame::Framed>,
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

/// `--frame` without `--yes` asks on the terminal: refused before the controller is asked
/// anything when there is none.
fn frame_can_ask(a: &SendArgs) -> anyhow::Result<()> {
    if a.frame && !a.yes && !super::frame::can_ask() {
        bail!(
            "--frame asks on the terminal before starting the job, but stdin is not a terminal: \
             pass --yes to start right after framing, or frame first with `stencil frame`"
        );
    }
    Ok(())
}

/// With --frame, what to trace before the job: the whole file's extent (a resumed job still
/// lands where the file says). Refused when the question before starting cannot be asked.
fn frame_setup(
    a: &SendArgs,
    job: &Program,
    machine: &machine_profile::Machine,
) -> anyhow::Result<Option<super::frame::Setup>> {
    match a.frame {
        false => Ok(None),
        true => Ok(Some(super::frame::setup(
            &a.file,
            job,
            machine,
            a.frame_feed,
            a.no_bed_check,
        )?)),
    }
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
