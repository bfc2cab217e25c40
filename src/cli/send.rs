//! `stencil send` (stream G-code to Grbl, or to the virtual Grbl with --dry-run) and
//! `stencil simulate` (draw a program and estimate its time). OWNER: the machine issue.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Sender};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use stencil::export;
use stencil::machine::gcode::Move;
use stencil::machine::simulate;
use stencil::machine::stream::{
    self, Control, ControllerInfo, FlowControl, Job, Observer, Progress, StreamConfig,
};
use stencil::machine::virtual_grbl::{Motion, VirtualConfig};
use stencil::plan::estimate::{estimate, format_duration, MotionLimits};
use stencil::profile::machine as machine_profile;

/// Stream a G-code file to a Grbl 1.1 controller.
#[derive(Args, Debug)]
#[command(
    after_help = "While streaming: ! or h = feed hold, ~ or r = resume, a / q / Esc / Ctrl-C = \
abort (soft reset, laser off, prints the line to resume from)."
)]
pub struct SendArgs {
    /// The G-code file.
    pub file: PathBuf,
    /// Serial port of the controller (e.g. /dev/ttyUSB0, /dev/ttyACM0, COM3).
    #[arg(long)]
    pub port: Option<String>,
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,
    /// Send one line at a time, each after the previous `ok` (slower; for boards that overflow
    /// with character counting).
    #[arg(long)]
    pub send_response: bool,
    /// Resume at this line of the file (as printed after a stop): restores units, distance mode,
    /// position, feed and laser state first.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
    pub from_line: u64,
    /// Run the file through Grbl's check mode ($C) first; cut nothing if any line is rejected.
    #[arg(long)]
    pub check: bool,
    /// Unlock ($X) a machine that is locked in alarm before streaming.
    #[arg(long)]
    pub unlock: bool,
    /// Stream to a simulated Grbl on a pseudo-terminal instead of a machine.
    #[arg(long)]
    pub dry_run: bool,
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
    /// use (name or .toml path) [default: diode-400].
    #[arg(long, value_name = "NAME|FILE")]
    pub machine: Option<String>,
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
}

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
    /// Machine profile whose motion limits the time estimate uses (name or .toml path)
    /// [default: diode-400].
    #[arg(long, value_name = "NAME|FILE")]
    pub machine: Option<String>,
}

/// `--timeout-s`: from a tenth of a second (a reply takes milliseconds) to an hour (Grbl answers
/// a status query within a fraction of a second, even mid-move).
pub(super) fn parse_timeout(s: &str) -> Result<f64, String> {
    super::number_in(s, 0.1..=3600.0, " seconds")
}

pub(super) fn read_program(path: &PathBuf) -> anyhow::Result<String> {
    let bytes = std::fs::read(path)
        .with_context(|| format!("{}: cannot read the G-code file", path.display()))?;
    String::from_utf8(bytes).map_err(|e| {
        anyhow::anyhow!(
            "{}: not a text file (invalid UTF-8 at byte {}); G-code must be ASCII",
            path.display(),
            e.utf8_error().valid_up_to()
        )
    })
}

pub fn run_simulate(a: SimulateArgs) -> anyhow::Result<ExitCode> {
    let text = read_program(&a.file)?;
    let name = a.file.display().to_string();
    let moves = simulate::moves(&name, &text)?;
    let machine = machine_profile::load(a.machine.as_deref())?;
    let est = estimate(&moves, &machine.limits());
    let d = simulate::draw(&moves, a.size_px);
    export::write_atomic(
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
        "wrote {} ({}×{} px, {:.3} mm per px; red = laser on, blue = travel)",
        a.output.display(),
        d.width,
        d.height,
        d.mm_per_px
    );
    Ok(ExitCode::SUCCESS)
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
        if std::io::stdin().is_terminal() && crossterm::terminal::enable_raw_mode().is_ok() {
            let stop2 = stop.clone();
            let thread = std::thread::spawn(move || key_loop(&tx, &stop2));
            return Keys {
                stop,
                thread: Some(thread),
                raw: true,
            };
        }
        // No terminal to read keys from: Ctrl-C (SIGINT) still aborts safely. A second handler
        // cannot be installed in one process; then Ctrl-C keeps its default meaning.
        let _ = ctrlc::set_handler(move || {
            let _ = tx.send(Control::Abort);
        });
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

fn key_loop(tx: &Sender<Control>, stop: &AtomicBool) {
    use crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
    while !stop.load(Ordering::SeqCst) {
        match event::poll(Duration::from_millis(100)) {
            Ok(true) => {}
            Ok(false) => continue,
            Err(_) => return,
        }
        let Ok(Event::Key(k)) = event::read() else {
            continue;
        };
        if k.kind == KeyEventKind::Release {
            continue;
        }
        let ctrl_c = k.modifiers.contains(KeyModifiers::CONTROL) && k.code == KeyCode::Char('c');
        let c = match k.code {
            _ if ctrl_c => Control::Abort,
            KeyCode::Char('!') | KeyCode::Char('h') | KeyCode::Char(' ') => Control::FeedHold,
            KeyCode::Char('~') | KeyCode::Char('r') => Control::Resume,
            KeyCode::Char('a') | KeyCode::Char('q') | KeyCode::Esc => Control::Abort,
            _ => continue,
        };
        if tx.send(c).is_err() {
            return;
        }
    }
}

/// The progress bar: lines acknowledged, percent, machine state and position, elapsed and
/// remaining time (estimated over the moves that have not run yet).
struct Bar {
    bar: ProgressBar,
    moves: Vec<Move>,
    limits: MotionLimits,
    raw: bool,
    last_estimate: Option<Instant>,
    remaining: String,
    state: String,
}

impl Bar {
    fn new(moves: Vec<Move>, limits: MotionLimits, raw: bool) -> Bar {
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
            moves,
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
            let k = self.moves.partition_point(|m| m.line < p.unexecuted_from);
            let e = estimate(&self.moves[k..], &self.limits);
            self.remaining = format!("~{} left", format_duration(e.total_s));
        }
        if let Some(st) = &p.state {
            self.state = match p.position {
                Some(pos) => format!("{st} X{:.2} Y{:.2}", pos[0], pos[1]),
                None => st.to_string(),
            };
        }
        self.bar
            .set_message(format!("{} {}", self.state, self.remaining));
    }
}

pub fn run_send(a: SendArgs) -> anyhow::Result<ExitCode> {
    let text = read_program(&a.file)?;
    let name = a.file.display().to_string();
    let job = Job::parse(&name, &text)?;
    let machine = machine_profile::load(a.machine.as_deref())?;
    let limits = machine.limits();
    let frame = match a.frame {
        false => None,
        true if !a.yes && !super::frame::can_ask() => bail!(
            "--frame asks on the terminal before starting the job, but stdin is not a terminal: \
             pass --yes to start right after framing, or frame first with `stencil frame`"
        ),
        // The frame is of the whole file (a resumed job still lands where the file says).
        true => Some(super::frame::setup(&a.file, &job, &machine, a.frame_feed, false)?),
    };
    let mut cfg = StreamConfig {
        flow: if a.send_response {
            FlowControl::SendResponse
        } else {
            FlowControl::CharacterCounting
        },
        rx_buffer: a.rx_buffer,
        timeout: Duration::from_secs_f64(a.timeout_s),
        unlock: a.unlock,
        check_first: a.check,
        from_line: a.from_line as usize,
        ..StreamConfig::default()
    };

    let vcfg = VirtualConfig {
        motion: if a.realtime {
            Motion::Paced { speedup: 1.0 }
        } else {
            Motion::Instant
        },
        baud: a.realtime.then_some(a.baud),
        rapid_mm_min: limits.rapid_mm_min,
        ..VirtualConfig::default()
    };
    let super::port::Opened {
        mut port,
        label,
        virtual_grbl,
    } = super::port::open_machine(a.dry_run, a.port.as_deref(), a.baud, vcfg)?;

    let (tx, rx) = channel();
    if let Some(s) = &frame {
        let keys = Keys::start(tx.clone());
        let mut say = super::frame::Say { raw: keys.raw };
        let framed = super::frame::frame_on(port.as_mut(), &cfg, &rx, &mut say, s);
        drop(keys);
        eprintln!("{}", super::frame::framed_line(&framed?, &label));
        if !a.yes && !super::frame::ask_start(&mut std::io::stdin().lock())? {
            eprintln!("not started: nothing was cut");
            return Ok(ExitCode::SUCCESS);
        }
        // The controller is awake and idle: no need to wait for a boot banner.
        cfg.boot_wait = Duration::from_millis(300);
    }
    let keys = Keys::start(tx);
    let mut bar = Bar::new(job.moves.clone(), limits, keys.raw);
    if keys.raw {
        bar.say("keys: ! or h = feed hold, ~ or r = resume, a / q / Esc / Ctrl-C = abort");
    }
    let result = stream::send(port.as_mut(), &job, &cfg, Some(&rx), &mut bar);
    bar.bar.finish_and_clear();
    drop(keys);
    let sum = match result {
        Ok(s) => s,
        Err(e) => {
            let hint = match e.halt() {
                Some(h) => format!(
                    "\nto resume: stencil send {} --from-line {}{}{}",
                    a.file.display(),
                    h.resume_from,
                    match &a.port {
                        Some(p) => format!(" --port {p}"),
                        None => String::new(),
                    },
                    if h.locked { " --unlock" } else { "" }
                ),
                None => String::new(),
            };
            return Err(anyhow::anyhow!("{e}{hint}"));
        }
    };
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
        let r = vg.stop();
        println!(
            "virtual Grbl: {} lines received, at most {} bytes in its receive buffer, {} bytes overflowed, laser {}",
            r.received.len(),
            r.max_rx_used,
            r.overflow_bytes,
            if r.laser_on { "ON" } else { "off" }
        );
    }
    Ok(ExitCode::SUCCESS)
}
