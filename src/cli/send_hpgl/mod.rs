//! `stencil send job.plt`: an HP-GL job streamed to a plotter cutter or pen plotter with its flow
//! control, or to the virtual plotter cutter with `--dry-run`.

use std::path::Path;
use std::process::ExitCode;
use std::sync::mpsc::channel;

use anyhow::{bail, Context};

use stencil_gcode::format_duration;
use stencil_grbl::{RunState, JOURNAL_EVERY};
use stencil_hpgl::cutter::{self, Cutter};
use stencil_hpgl::stream::{self, Control, Line, LineFault, Outcome, SerialLine, VirtualLine};

use super::operator::{abort_cause, Keys};

mod journal;
use journal::{journal_plotter, PlotJournal};

/// What `send` was asked for an HP-GL job.
pub struct SendHpgl<'a> {
    /// The file.
    pub file: &'a Path,
    /// `--machine`.
    pub machine: Option<&'a str>,
    /// `--port`.
    pub port: Option<&'a str>,
    /// `--dry-run`.
    pub dry_run: bool,
    /// `--from-line`.
    pub from_line: usize,
    /// `--recover`.
    pub recover: bool,
    /// `--dry-run-abort-at`.
    pub abort_at: Option<usize>,
    /// `--dry-run-fault`, as the virtual line rehearses them.
    pub faults: Vec<LineFault>,
    /// `--dry-run-record`.
    pub record: Option<&'a Path>,
}

/// Whether `path` is an HP-GL job: a `.plt`, `.hpgl`, `.hpg` or `.hgl` file.
pub fn is_hpgl_file(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| ["plt", "hpgl", "hpg", "hgl"].contains(&e.to_ascii_lowercase().as_str()))
}

/// Read an HP-GL file as text (HP-GL is ASCII).
pub fn read_hpgl(path: &Path) -> anyhow::Result<String> {
    stencil_io::read_text(path, stencil_io::Kind::Gcode)
        .with_context(|| format!("{}: cannot read the HP-GL file", path.display()))
}

/// The plotter `--machine` names for an HP-GL file.
fn plotter_for(machine: Option<&str>) -> anyhow::Result<stencil_hpgl::profile::Plotter> {
    let Some(name) = machine else {
        bail!(
            "an HP-GL job needs its plotter: name it with --machine (vinyl-hpgl, roland-camm, \
             graphtec-hpgl, hp7475a, or a .toml file), for its flow control, buffer and baud rate"
        );
    };
    Ok(stencil_hpgl::profile::load(name)?)
}

/// The whole file run on a fresh virtual cutter: refused as the real plotter would refuse it,
/// before anything is sent; its time is the job's.
pub fn check_file(
    path: &Path,
    text: &str,
    plotter: &stencil_hpgl::profile::Plotter,
) -> anyhow::Result<Cutter> {
    cutter::run_text(plotter, text).map_err(|e| {
        anyhow::anyhow!(
            "{}: the {} would refuse it: {e}; nothing was sent",
            path.display(),
            plotter.name
        )
    })
}

/// `--recover`: read the journal beside the file, check it was written for this file and this
/// plotter profile, say what it knows, and choose where to resume; `None` when nothing is left.
fn recover(
    a: &SendHpgl,
    text: &str,
    journal_path: &Path,
) -> anyhow::Result<Option<(stencil_hpgl::profile::Plotter, usize)>> {
    let journal_error =
        |e: stencil_grbl::JournalError| anyhow::anyhow!("{e}{}", super::port::journal_hint(&e));
    let j = PlotJournal::read(journal_path).map_err(journal_error)?;
    j.check_file(journal_path, text).map_err(journal_error)?;
    let plotter = journal_plotter(a.machine, &j, journal_path)?;
    let how = super::port::run_state_words(j.state, j.stop_reason.as_deref());
    println!(
        "journal {}: the run of {} from line {} on {}, last written {} ago, {how}",
        journal_path.display(),
        stencil_io::printable(&j.file),
        j.from_line,
        stencil_io::printable(&j.plotter),
        format_duration(j.age_s())
    );
    let last = stencil_hpgl::command::parse(text)?
        .last()
        .map_or(0, |p| p.line);
    if j.state == RunState::Complete || j.resume_from > last {
        println!("every instruction was cut: nothing to recover");
        return Ok(None);
    }
    println!(
        "{} bytes had reached the plotter, whose buffer holds up to {} bytes not yet cut: the          instructions before line {} are known cut; line {} may have been running when it          stopped, and the plotter may have cut further (cut again, a cut runs in its own groove)",
        j.delivered_bytes, j.buffer_bytes, j.resume_from, j.resume_from
    );
    println!(
        "resuming from line {}: initialised, the run's pen, speed and force set again, tool up,          travel to where that line starts, tool down. The media must not have moved, and the          plotter's origin must be where the run's was (a cutter switched off and on takes its          origin where the media lies: set it back first)",
        j.resume_from
    );
    Ok(Some((plotter, j.resume_from)))
}

pub fn run_send_hpgl(a: SendHpgl) -> anyhow::Result<ExitCode> {
    let text = read_hpgl(a.file)?;
    let journal_path = stencil_grbl::journal_path(a.file);
    if let Some(r) = a.record {
        stencil_io::check_output(r, &[a.file])?;
    }
    let (plotter, from_line) = if a.recover {
        match recover(&a, &text, &journal_path)? {
            Some(r) => r,
            None => return Ok(ExitCode::SUCCESS),
        }
    } else {
        (plotter_for(a.machine)?, a.from_line)
    };
    let whole = check_file(a.file, &text, &plotter)?;
    let (tx, rx) = channel();
    let keys = Keys::start(tx);
    // Instructions sent so far, for --dry-run-abort-at.
    let sent = std::cell::Cell::new(0usize);
    let mut aborts_at = a.abort_at;
    let mut control = || {
        if aborts_at.is_some_and(|n| sent.get() >= n) {
            aborts_at = None;
            return Some(Control::Abort);
        }
        match rx.try_recv().ok()? {
            stencil_grbl::Control::FeedHold => Some(Control::Pause),
            stencil_grbl::Control::Resume => Some(Control::Resume),
            stencil_grbl::Control::Abort => Some(Control::Abort),
            stencil_grbl::Control::Override(_) => None,
        }
    };
    let total_s = whole.timing.total_s;
    let bar = indicatif::ProgressBar::new(1);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} instructions, {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    println!(
        "{}: {} instructions for {} ({}, {} baud, {} flow control, {}-byte buffer); about {} \
         on the virtual cutter; ! or h = pause, ~ or r = resume, a / q / Esc / Ctrl-C = abort (clears the \
         plotter's buffer and lifts the tool)",
        a.file.display(),
        whole.executed,
        plotter.name,
        plotter.dialect.name(),
        plotter.serial.baud,
        plotter.serial.flow.name(),
        plotter.serial.buffer_bytes,
        format_duration(total_s)
    );
    let (mut vline, mut sline) = (None, None);
    let line: &mut dyn Line = match (a.port, a.dry_run) {
        (_, true) => {
            let mut v = VirtualLine::new(&plotter, 0.0);
            // The plotter cuts while it receives: one instruction for every 16 bytes arriving.
            v.run_every_bytes = 16;
            v.fault = a.faults.first().copied();
            if a.record.is_some() {
                v.cutter.log = Some(Vec::new());
            }
            vline.insert(v)
        }
        (Some(p), false) => sline.insert(
            SerialLine::open(p, &plotter)
                .with_context(|| format!("cannot open {p} for {}", plotter.name))?,
        ),
        (None, false) => {
            bail!("name the plotter's serial port with --port, or rehearse with --dry-run")
        }
    };
    // The journal exists from the run's start: a sender killed mid-job leaves it `running`.
    let mut journal = PlotJournal::new(a.file, &text, &plotter, from_line);
    let mut journal_warned = false;
    let mut save = |j: &mut PlotJournal| {
        if let Err(e) = j.write(&journal_path) {
            // The job goes on: a journal is a help, not a condition of cutting.
            if !journal_warned {
                journal_warned = true;
                eprintln!("{e}; the job goes on without it");
            }
        }
    };
    save(&mut journal);
    let out = {
        let mut last_write = std::time::Instant::now();
        let mut progress = |p: &stream::Progress| {
            bar.set_length(p.total as u64);
            bar.set_position(p.sent as u64);
            sent.set(p.sent);
            let left = total_s * (1.0 - p.sent as f64 / p.total.max(1) as f64);
            bar.set_message(format!("about {} left", format_duration(left)));
            journal.last_sent_line = Some(p.line);
            journal.delivered_bytes = p.delivered_bytes;
            journal.resume_from = p.resume_line;
            if last_write.elapsed() >= JOURNAL_EVERY {
                save(&mut journal);
                last_write = std::time::Instant::now();
            }
        };
        stream::stream(
            &text,
            from_line,
            &plotter.serial,
            line,
            &mut control,
            &mut progress,
        )
    };
    bar.finish_and_clear();
    drop(keys);
    if let (Some(v), Some(r)) = (&vline, a.record) {
        let log = v.cutter.log.as_deref().unwrap_or_default();
        stencil_io::write_atomic(r, log)
            .with_context(|| format!("{}: cannot write the record", r.display()))?;
    }
    if let Some(v) = &vline {
        print_virtual(&v.cutter, total_s);
    }
    let same_machine = format!(
        " --machine {}{}",
        plotter.name,
        if a.dry_run {
            " --dry-run".to_string()
        } else {
            a.port.map(|p| format!(" --port {p}")).unwrap_or_default()
        }
    );
    let resume_hint = |line: usize| {
        format!(
            "\nto resume: stencil send {} --from-line {line}{same_machine}\n(the journal {} \
             keeps this; after a crash or power loss: stencil send {} --recover{same_machine})",
            a.file.display(),
            journal_path.display(),
            a.file.display(),
        )
    };
    match out {
        Ok(Outcome::Done { sent, waits }) => {
            if let Err(e) = std::fs::remove_file(&journal_path) {
                if e.kind() != std::io::ErrorKind::NotFound {
                    eprintln!(
                        "{}: cannot remove the finished job's journal: {e}",
                        journal_path.display()
                    );
                }
            }
            println!(
                "{}: sent {sent} instructions to {}; the plotter said stop {waits} time(s)",
                a.file.display(),
                plotter.name
            );
            Ok(ExitCode::SUCCESS)
        }
        Ok(Outcome::Aborted { resume_line }) => {
            let text = format!(
                "{}; the plotter's buffer was cleared (ESC.K) and the tool lifted (PU)",
                abort_cause()
            );
            journal.state = RunState::Stopped;
            journal.stop_reason = Some(text.clone());
            journal.resume_from = resume_line;
            save(&mut journal);
            bail!("{text}{}", resume_hint(resume_line))
        }
        Err(e) => {
            let text = format!("{}: {e}; the stream stopped", a.file.display());
            journal.state = RunState::Stopped;
            journal.stop_reason = Some(text.clone());
            save(&mut journal);
            bail!("{text}{}", resume_hint(journal.resume_from))
        }
    }
}

/// What the virtual cutter did.
fn print_virtual(c: &Cutter, total_s: f64) {
    println!(
        "virtual cutter: {} instructions run ({} bytes), buffer peak {} bytes, {} flow stop(s), \
         {} buffer clear(s); tool {} at the end, at {},{}; cut {:.0} mm in {} strokes, travel \
         {:.0} mm; job time {} (the file's estimate {})",
        c.executed,
        c.executed_bytes,
        c.peak,
        c.stops,
        c.clears,
        if c.down { "DOWN" } else { "up" },
        c.pos[0],
        c.pos[1],
        c.timing.cut_mm,
        c.strokes.len(),
        c.timing.travel_mm,
        format_duration(c.timing.total_s),
        format_duration(total_s),
    );
    if !c.not_drawn.is_empty() {
        println!(
            "virtual cutter: taken but not drawn: {}",
            c.not_drawn
                .iter()
                .map(|(m, n)| format!("{m} x{n}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
}

/// `stencil estimate job.plt --machine PLOTTER`: the job's time on the virtual cutter.
pub fn run_estimate_hpgl(file: &Path, machine: Option<&str>) -> anyhow::Result<ExitCode> {
    let text = read_hpgl(file)?;
    let plotter = plotter_for(machine)?;
    let c = check_file(file, &text, &plotter)?;
    let t = &c.timing;
    println!(
        "estimated time {} on {} (cutting {}, travel {}); cut {:.0} mm, travel {:.0} mm, {} \
         instructions (HP-GL on the virtual cutter: each move accelerated and braked at the \
         profile's {} mm/s², pen-up at {} mm/s)",
        format_duration(t.total_s),
        plotter.name,
        format_duration(t.cut_s),
        format_duration(t.travel_s),
        t.cut_mm,
        t.travel_mm,
        c.executed,
        plotter.accel_mm_s2,
        plotter.travel_mm_s
    );
    Ok(ExitCode::SUCCESS)
}

/// `stencil simulate job.plt --machine PLOTTER`: what the virtual cutter cut, drawn (red: tool
/// down, blue: travel), and its time.
pub fn run_simulate_hpgl(
    file: &Path,
    machine: Option<&str>,
    output: &Path,
    size_px: u32,
) -> anyhow::Result<ExitCode> {
    let mut inputs = vec![file];
    inputs.extend(machine.map(Path::new));
    stencil_io::check_output(output, &inputs)?;
    let text = read_hpgl(file)?;
    let plotter = plotter_for(machine)?;
    let c = check_file(file, &text, &plotter)?;
    // The strokes as the G-code drawing's moves: tool down at Z0, travel at Z1.
    let mut moves = Vec::new();
    let mv = |from: [f64; 2], to: [f64; 2], z: f64| stencil_gcode::interpret::Move {
        from: [from[0], from[1], z],
        to: [to[0], to[1], z],
        rapid: z > 0.0,
        feed: 1.0,
        power: 0.0,
        spindle_s: 0.0,
        line: 0,
    };
    let mut at = [0.0, 0.0];
    for s in &c.strokes {
        moves.push(mv(at, s[0], 1.0));
        for w in s.windows(2) {
            moves.push(mv(w[0], w[1], 0.0));
        }
        at = *s.last().unwrap_or(&at);
    }
    let rule = stencil_gcode::interpret::CutRule::ZDown {
        down_at_or_below: 0.0,
    };
    let d = stencil_gcode::simulate::draw(&moves, size_px, rule);
    stencil_io::write_atomic(
        output,
        &stencil_core::export::png::encode_rgb(d.width, d.height, &d.rgb),
    )?;
    println!(
        "estimated time {} on {}; cut {:.0} mm in {} strokes, travel {:.0} mm",
        format_duration(c.timing.total_s),
        plotter.name,
        c.timing.cut_mm,
        c.strokes.len(),
        c.timing.travel_mm
    );
    println!(
        "wrote {} ({}×{} px, {:.3} mm per px; red = tool down, blue = travel)",
        output.display(),
        d.width,
        d.height,
        d.mm_per_px
    );
    Ok(ExitCode::SUCCESS)
}
