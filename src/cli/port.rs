//! Opening the machine for `send`, `frame` and `jog`: a serial port, or the virtual Grbl on a
//! pseudo-terminal for `--dry-run`.

use std::time::Duration;

use anyhow::{bail, Context};

use stencil_grbl::journal::JournalError;
use stencil_grbl::stream::{BytePort, MachineError};
use stencil_grbl::virtual_grbl::{VirtualConfig, VirtualGrbl};

/// Where the controller is: a serial port, or `--dry-run` for the simulated Grbl (shared by
/// `send`, `frame` and `jog`).
#[derive(clap::Args, Debug, Clone)]
pub struct PortArgs {
    /// Serial port of the controller (e.g. /dev/ttyUSB0, /dev/ttyACM0, COM3).
    #[arg(long)]
    pub port: Option<String>,
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,
    /// Talk to a simulated Grbl on a pseudo-terminal instead of a machine.
    #[arg(long)]
    pub dry_run: bool,
}

/// The option that does what a machine error asks for. The library says what is wrong and what
/// to do at the machine; the command line adds which option does it.
pub(super) fn machine_hint(e: &MachineError) -> &'static str {
    match e {
        MachineError::Locked { .. } => "; run again with --unlock to send $X",
        MachineError::LaserModeOff { .. } => {
            "; run again with --set-laser-mode to send $32=1, or name the machine's profile with \
             --machine"
        }
        MachineError::FromLine { .. } | MachineError::ResumeState { .. } => " (--from-line)",
        MachineError::Homing { .. } => "; then resume with --from-line",
        _ => "",
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
    /// Open the port, or with `--dry-run` start a virtual Grbl built as `vcfg` says.
    pub fn open(&self, vcfg: VirtualConfig) -> anyhow::Result<Opened> {
        open_machine(self.dry_run, self.port.as_deref(), self.baud, vcfg)
    }
}

/// An open link to a controller.
pub struct Opened {
    pub port: Box<dyn BytePort>,
    /// What it is, for messages: the port's path, or "the virtual Grbl (dry run)".
    pub label: String,
    /// The simulated controller behind a dry run (its record is printed at the end).
    pub virtual_grbl: Option<VirtualGrbl>,
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

/// Open `port` at `baud`, or with `dry_run` start a virtual Grbl built as `vcfg` says.
fn open_machine(
    dry_run: bool,
    port: Option<&str>,
    baud: u32,
    vcfg: VirtualConfig,
) -> anyhow::Result<Opened> {
    if dry_run {
        let (vg, host) = VirtualGrbl::spawn(vcfg)
            .context("cannot start the virtual Grbl (no pseudo-terminals available?)")?;
        return Ok(Opened {
            port: Box::new(host),
            label: "the virtual Grbl (dry run)".into(),
            virtual_grbl: Some(vg),
        });
    }
    let Some(p) = port else {
        bail!(
            "no machine given: pass --port PATH (ports found: {}) or --dry-run to use a simulated Grbl",
            list_ports()
        );
    };
    let sp = serialport::new(p, baud)
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
    })
}
