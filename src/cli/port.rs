//! Opening the machine for `send`, `frame` and `jog`: a serial port, or the virtual Grbl on a
//! pseudo-terminal for `--dry-run`.

use std::time::Duration;

use anyhow::{bail, Context};

use stencil_gcode::machine::{Machine, Tool};
use stencil_grbl::{
    BytePort, Expected, Firmware, IfMoving, JournalError, MachineError, PowerScale, Program,
    TcpPort, VirtualConfig, VirtualGrbl, MOVING_WAIT,
};

/// Where the controller is: a serial port, or `--dry-run` for the simulated Grbl (shared by
/// `send`, `frame` and `jog`).
#[derive(clap::Args, Debug, Clone)]
pub struct PortArgs {
    /// Serial port of the controller (e.g. /dev/ttyUSB0, /dev/ttyACM0, COM3), or
    /// tcp://HOST:PORT for a FluidNC or grblHAL board's network stream (e.g. tcp://fluidnc.local:23).
    #[arg(long)]
    pub port: Option<String>,
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,
    /// Talk to a simulated Grbl on a pseudo-terminal instead of a machine.
    #[arg(long)]
    pub dry_run: bool,
    /// A controller found still running moves it was given before (another program's job, or
    /// the rest of one whose sender died): stop it safely (feed hold, wait until it stands,
    /// soft reset; its position is kept) instead of waiting up to 5 minutes for it to finish.
    /// It is never reset while it moves.
    #[arg(long)]
    pub stop_running: bool,
    /// With --dry-run: the firmware the simulated controller plays (its banner, $I, status
    /// fields, buffer sizes and settings; grblHAL and FluidNC do not reset when the port opens).
    #[arg(long, value_enum, default_value_t = DryFirmware::Grbl, requires = "dry_run")]
    pub dry_run_firmware: DryFirmware,
    /// With --dry-run: reach the simulated controller over TCP on 127.0.0.1 (as a WiFi board's
    /// tcp:// port) instead of a pseudo-terminal.
    #[arg(long, requires = "dry_run")]
    pub dry_run_tcp: bool,
}

/// How long a dropped network link is tried again before giving up.
const RECONNECT_FOR: Duration = Duration::from_secs(30);

/// `tcp://HOST:PORT` → `HOST:PORT`; `None` for a serial port's path.
fn tcp_address(port: &str) -> anyhow::Result<Option<&str>> {
    let Some(rest) = port.strip_prefix("tcp://") else {
        return Ok(None);
    };
    let ok = rest
        .rsplit_once(':')
        .is_some_and(|(h, p)| !h.is_empty() && p.parse::<u16>().is_ok_and(|p| p > 0));
    if !ok {
        bail!(
            "--port {port}: a network port is tcp://HOST:PORT, e.g. tcp://192.168.1.50:23 \
             (FluidNC's and grblHAL's telnet stream listen on port 23)"
        );
    }
    Ok(Some(rest))
}

/// The firmware a dry run's controller plays.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum DryFirmware {
    /// Grbl 1.1h (128-byte receive buffer, 15 planner blocks).
    Grbl,
    /// grblHAL (1024-byte receive buffer, 35 planner blocks, `$I` with NEWOPT).
    Grblhal,
    /// FluidNC (settings from its configuration file, sizes only in its status reports).
    Fluidnc,
}

/// The option that does what a machine error asks for. The library says what is wrong and what
/// to do at the machine; the command line adds which option does it.
pub(super) fn machine_hint(e: &MachineError) -> &'static str {
    match e {
        MachineError::Locked { .. } => "; run again with --unlock to send $X",
        MachineError::NoCard { .. } | MachineError::CardWholeJob { .. } => " (without --to-card)",
        MachineError::CardMissing { .. } => " (or without --to-card)",
        MachineError::LaserModeOff { .. } => {
            "; run again with --set-laser-mode to send $32=1, or name the machine's profile with \
             --machine"
        }
        MachineError::FromLine { .. } | MachineError::ResumeState { .. } => " (--from-line)",
        MachineError::Homing { .. } => "; then resume with --from-line",
        MachineError::PowerScale { .. } => {
            " (--rescale-power rescales every S to the controller's scale for this run)"
        }
        MachineError::TravelShort { .. } => " (the profile is the --machine file)",
        MachineError::PositionLost { .. } => {
            ": `stencil jog` moves the head; then resume with --head-at-corner (add --frame to \
             trace the job first), or with --position-confirmed once the machine is homed or \
             re-zeroed"
        }
        MachineError::Running { .. } => "; --stop-running stops it that way",
        MachineError::ResumeAmbiguous { .. } => {
            ": resume with --from-line N --position-confirmed, N the line to resume from"
        }
        MachineError::MachineCommands { .. } => {
            " (--allow-machine-commands lets the job change the machine)"
        }
        _ => "",
    }
}

/// A name as a journal keeps it, for a message: quoted with control characters escaped (a
/// journal is a file that may have come from elsewhere, not trusted to hold a name).
pub(super) fn journal_named(m: &str) -> String {
    stencil_io::excerpt(&m.escape_debug().to_string())
}

/// The profile a recovery loads: the one named with `--machine`, else the name the journal
/// keeps for its run's `kind` (machine or plotter) profile, when it is a plain profile name: a
/// recovery never opens a file a journal names.
pub(super) fn recovery_profile(
    given: Option<&str>,
    in_journal: &str,
    kind: &str,
    journal_path: &std::path::Path,
) -> anyhow::Result<String> {
    if let Some(m) = given {
        return Ok(m.to_string());
    }
    let plain = !in_journal.is_empty()
        && !in_journal.contains(['/', '\\'])
        && !in_journal.ends_with(".toml")
        && in_journal.chars().all(|c| c.is_ascii_graphic());
    if !plain {
        bail!(
            "{}: the journal names its {kind} profile as `{}`, which is not a profile name; a \
             recovery never opens a file a journal names: name the profile the run used with \
             --machine; nothing was sent",
            journal_path.display(),
            journal_named(in_journal)
        );
    }
    Ok(in_journal.to_string())
}

/// How a journal's run stands, as a recovery says it (the stop's reason printed with its
/// control characters written out).
pub(super) fn run_state_words(state: stencil_grbl::RunState, reason: Option<&str>) -> String {
    match state {
        stencil_grbl::RunState::Running => {
            "did not end (the sender was killed, crashed, or the power went)".to_string()
        }
        stencil_grbl::RunState::Stopped => format!(
            "stopped: {}",
            stencil_io::printable(reason.unwrap_or("(no reason recorded)"))
        ),
        stencil_grbl::RunState::Complete => "finished".to_string(),
    }
}

/// The options that resume without a usable journal.
pub(super) fn journal_hint(e: &JournalError) -> &'static str {
    match e {
        JournalError::Missing { .. } | JournalError::NotJournal { .. } => " with --from-line N",
        JournalError::Mismatch { .. } => " (--recover with that file, or --from-line N)",
        _ => "",
    }
}

impl PortArgs {
    /// What connecting does about a controller found running (`--stop-running`).
    pub fn if_moving(&self) -> IfMoving {
        if self.stop_running {
            IfMoving::Stop
        } else {
            IfMoving::Wait(MOVING_WAIT)
        }
    }

    /// Open the port, or with `--dry-run` start a virtual Grbl built as `vcfg` says.
    pub fn open(&self, vcfg: VirtualConfig) -> anyhow::Result<Opened> {
        if self.dry_run {
            let firmware = match self.dry_run_firmware {
                DryFirmware::Grbl => Firmware::Grbl,
                DryFirmware::Grblhal => Firmware::GrblHal,
                DryFirmware::Fluidnc => Firmware::FluidNc,
            };
            let sizes = VirtualConfig::dialect(firmware);
            let vcfg = VirtualConfig {
                firmware,
                rx_buffer: sizes.rx_buffer,
                planner_blocks: sizes.planner_blocks,
                ..vcfg
            };
            if self.dry_run_tcp {
                let (vg, addr) =
                    VirtualGrbl::spawn_tcp(vcfg).context("cannot start the virtual Grbl on TCP")?;
                let tcp = addr.to_string();
                let port = TcpPort::connect(&tcp, Duration::from_secs(5))
                    .with_context(|| format!("cannot reach the virtual Grbl at tcp://{tcp}"))?;
                return Ok(Opened {
                    port: Box::new(port),
                    label: format!("the virtual Grbl at tcp://{tcp} (dry run)"),
                    virtual_grbl: Some(vg),
                    tcp: Some(tcp),
                });
            }
            let (vg, host) = VirtualGrbl::spawn(vcfg)
                .context("cannot start the virtual Grbl (no pseudo-terminals available?)")?;
            return Ok(Opened {
                port: Box::new(host),
                label: "the virtual Grbl (dry run)".into(),
                virtual_grbl: Some(vg),
                tcp: None,
            });
        }
        let Some(p) = &self.port else {
            bail!(
                "no machine given: pass --port PATH (ports found: {}) or --dry-run to use a simulated Grbl",
                list_ports()
            );
        };
        if let Some(tcp) = tcp_address(p)? {
            let port = TcpPort::connect(tcp, Duration::from_secs(10)).map_err(|e| {
                anyhow::anyhow!(
                    "{p}: cannot connect: {e}; check the board is on this network (its WiFi \
                     or Ethernet address) and its telnet stream is enabled"
                )
            })?;
            return Ok(Opened {
                port: Box::new(port),
                label: p.to_string(),
                virtual_grbl: None,
                tcp: Some(tcp.to_string()),
            });
        }
        let sp = serialport::new(p, self.baud)
            .timeout(Duration::from_millis(100))
            .open()
            .map_err(|e| {
                anyhow::anyhow!(
                    "{p}: cannot open the serial port: {e}; ports found: {}",
                    list_ports()
                )
            })?;
        Ok(Opened {
            port: Box::new(sp),
            label: p.to_string(),
            virtual_grbl: None,
            tcp: None,
        })
    }
}

/// An open link to a controller.
pub struct Opened {
    pub port: Box<dyn BytePort>,
    /// What it is, for messages: the port's path, or "the virtual Grbl (dry run)".
    pub label: String,
    /// The simulated controller behind a dry run (its record is printed at the end).
    pub virtual_grbl: Option<VirtualGrbl>,
    /// A network link's HOST:PORT, to reach the controller again after the link drops.
    pub tcp: Option<String>,
}

/// Connect (waiting while the board runs what it holds, never resetting it), switch the beam
/// and the air off, and say where it stands: the firmware's name and the head's position.
fn make_safe(
    port: &mut TcpPort,
    cfg: &stencil_grbl::StreamConfig,
    print: &mut Print,
) -> anyhow::Result<(String, stencil_grbl::Position)> {
    let mut c = stencil_grbl::Console::connect(port, cfg, None, print)?;
    c.command("M5")?;
    c.command("M9")?;
    let at = c.position()?;
    Ok((c.info().name(), at))
}

/// Prints what a session after a dropped link hears.
struct Print;
impl stencil_grbl::Observer for Print {
    fn message(&mut self, text: &str) {
        eprintln!("{text}");
    }
}

/// The network link dropped mid-job: the board runs on with what it holds. Reach it again (for
/// at most 30 s), never resetting it: while it still runs what it holds, it is watched until it
/// stands (as connecting always does), then the beam and the air are switched off (M5, M9),
/// which a board left in M3 would otherwise keep on. Says what it found; false when it could
/// not be reached.
pub fn after_drop(tcp: &str, cfg: &stencil_grbl::StreamConfig) -> bool {
    eprintln!(
        "the network link to tcp://{tcp} dropped mid-job: reaching the controller again (for at \
         most {} s) to watch it finish what it holds and switch the beam off; it is not reset",
        RECONNECT_FOR.as_secs()
    );
    let Some(mut port) = reach(tcp) else {
        return false;
    };
    let cfg = stencil_grbl::StreamConfig {
        boot_wait: Duration::from_millis(300),
        if_moving: IfMoving::Wait(MOVING_WAIT),
        home_first: false,
        unlock: false,
        ..cfg.clone()
    };
    let mut print = Print;
    let reached = make_safe(&mut port, &cfg, &mut print);
    match reached {
        Ok((name, at)) => {
            let p = at.work;
            eprintln!(
                "reached {name} again: it ran what it held and stands {} at X{:.3} Y{:.3} \
                 (work); laser and air switched off (M5, M9), not reset",
                at.status.state, p[0], p[1]
            );
            true
        }
        Err(e) => {
            eprintln!(
                "tcp://{tcp} answered but could not be made safe ({e}): at the machine, make \
                 sure the laser and the air are off"
            );
            false
        }
    }
}

/// Reach a network controller again after its link dropped, trying for at most
/// [`RECONNECT_FOR`]; `None` (said) when it cannot be reached.
pub fn reach(tcp: &str) -> Option<TcpPort> {
    let end = std::time::Instant::now() + RECONNECT_FOR;
    loop {
        match TcpPort::connect(tcp, Duration::from_secs(3)) {
            Ok(p) => return Some(p),
            Err(e) if std::time::Instant::now() >= end => {
                eprintln!(
                    "tcp://{tcp} cannot be reached ({e}): at the machine, make sure the laser \
                     and the air are off"
                );
                return None;
            }
            Err(_) => std::thread::sleep(Duration::from_secs(1)),
        }
    }
}

/// The serial ports the system lists, for error messages.
pub fn list_ports() -> String {
    match serialport::available_ports() {
        Ok(ports) if !ports.is_empty() => ports
            .iter()
            .map(|p| p.port_name.clone())
            .collect::<Vec<_>>()
            .join(", "),
        Ok(_) => "none found".into(),
        Err(e) => format!("cannot list them: {e}"),
    }
}

/// What the machine profile and the job say Grbl's settings should be (see [`Expected`]): the
/// power scale the job's S words were written for (its header's `$30=`/`$31=`, as `stencil`
/// writes it, else the profile's), the profile's rates, acceleration, junction deviation and bed.
pub fn expected(machine: &Machine, text: &str, job: &Program) -> Expected {
    let fires = job.moves.iter().any(|m| m.power > 0.0);
    let power = match machine.tool {
        Tool::Laser { s_max, s_min } if fires => {
            let ((s_max, s_min), source) = match header_scale(text) {
                Some(scale) => (scale, "read from its header".into()),
                None => (
                    (s_max, s_min),
                    format!(
                        "taken from machine profile {}, as its header does not say",
                        machine.name
                    ),
                ),
            };
            Some(PowerScale {
                s_max,
                s_min,
                source,
            })
        }
        _ => None,
    };
    Expected {
        profile: machine.name.clone(),
        power,
        rapid_mm_min: Some(machine.motion.rapid_mm_min),
        accel_mm_s2: Some(machine.motion.accel_mm_s2),
        junction_mm: Some(machine.motion.junction_deviation_mm),
        bed_mm: Some([machine.bed.width_mm, machine.bed.height_mm]),
    }
}

/// `$30=` and `$31=` in a comment line of the job (the header `stencil` writes says
/// `; $30=1000 $31=0; power ...`).
fn header_scale(text: &str) -> Option<(f64, f64)> {
    let value = |line: &str, key: &str| -> Option<f64> {
        let rest = &line[line.find(key)? + key.len()..];
        let end = rest
            .find(|c: char| !(c.is_ascii_digit() || c == '.'))
            .unwrap_or(rest.len());
        rest[..end].parse().ok()
    };
    text.lines()
        .map(str::trim_start)
        .filter(|l| l.starts_with(';') || l.starts_with('('))
        .find_map(|l| Some((value(l, "$30=")?, value(l, "$31=").unwrap_or(0.0))))
}

/// The settings a virtual Grbl starts from for `machine`, as its controller would be set up
/// for the profile (`$$`), so that a dry run by default passes the settings check.
pub fn profile_settings(machine: &Machine) -> Vec<(u32, String)> {
    let n = stencil_gcode::num;
    let m = &machine.motion;
    let mut v = vec![
        (11, n(m.junction_deviation_mm)),
        (22, u32::from(m.homing).to_string()),
        (110, n(m.rapid_mm_min)),
        (111, n(m.rapid_mm_min)),
        (120, n(m.accel_mm_s2)),
        (121, n(m.accel_mm_s2)),
        (130, n(machine.bed.width_mm)),
        (131, n(machine.bed.height_mm)),
    ];
    if let Tool::Laser { s_max, s_min } = machine.tool {
        v.extend([(30, n(s_max)), (31, n(s_min))]);
    }
    v
}

/// The virtual Grbl for a dry run on `machine`: the profile's settings and homing, then
/// `overrides` (`--dry-run-setting`) over them.
pub fn virtual_for(machine: &Machine, overrides: &[(u32, String)]) -> VirtualConfig {
    let mut settings = profile_settings(machine);
    settings.extend(overrides.iter().cloned());
    VirtualConfig {
        rapid_mm_min: machine.motion.rapid_mm_min,
        homing: machine.motion.homing,
        settings,
        ..VirtualConfig::default()
    }
}

/// `limits` with the rapid rate, acceleration and junction deviation the controller reported in
/// `$$` (the slower axis of X and Y), where it did.
pub fn controller_motion(
    mut limits: stencil_gcode::machine::Motion,
    info: &stencil_grbl::ControllerInfo,
) -> stencil_gcode::machine::Motion {
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
    limits.axis_rate_mm_min = axes(110).or(limits.axis_rate_mm_min);
    limits.axis_accel_mm_s2 = axes(120).or(limits.axis_accel_mm_s2);
    limits.steps_per_mm = axes(100).or(limits.steps_per_mm);
    limits.idle_lock_ms = (info.setting(1).filter(|ms| *ms >= 0.0)).or(limits.idle_lock_ms);
    limits
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_header_says_the_power_scale() {
        let t = "; stencil 0.1.0 for diode-400\n; $30=1000 $31=0; power 20 % = S200\nG0X1\n";
        assert_eq!(super::header_scale(t), Some((1000.0, 0.0)));
        assert_eq!(super::header_scale("(x $30=255)\nG0\n"), Some((255.0, 0.0)));
        assert_eq!(super::header_scale("G0X1\n$30=1000\n"), None);
    }
}
