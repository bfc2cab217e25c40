//! Streaming a G-code program to Grbl over any byte port.
//!
//! The same code runs against a serial port and against the virtual Grbl on a pty, so the tests
//! exercise exactly what `stencil send` does. Flow control is Grbl's character counting (at most
//! rx buffer − 1 bytes in flight, each line counted with its `\n`), or send-response as a fallback.
//!
//! By concern: `link` (the byte port, read line by line), `session` (connect, setup commands,
//! status queries), `flight` (flow control, acknowledgements, the `$C` pass), `tracker` (which
//! acknowledged moves really ran), `control` (the operator's real-time commands and overrides),
//! `halt` (every stop path), `card` (a job uploaded to the controller's SD card and run there), `config` and `observe`
//! (what goes in and what comes out), `tcp`
//! (the network link), and
//! [`console`] (the same session held open for jogging and framing).

use std::sync::mpsc::Receiver;

mod card;
mod config;
mod console;
mod control;
mod flight;
mod halt;
mod link;
mod observe;
mod place;
mod prepare;
mod recover;
mod session;
mod settings;
mod tcp;
mod tracker;

pub use self::card::{send_to_card, watch_card, CardSummary};
pub use self::config::{
    Control, Expected, FlowControl, IfMoving, LaserMode, Override, PowerScale, Recovery,
    StreamConfig, MOVING_WAIT,
};
pub use self::console::{Console, Position};
pub use self::link::BytePort;
pub use self::observe::{ControllerInfo, Observer, Progress, Quiet, Summary};
pub use self::tcp::TcpPort;
use super::error::MachineError;
use super::program::Program;

use self::prepare::{allowed, name_differences, outgoing, rescale};
use self::session::Session;
use super::stall;

/// Stream `job` to the controller on `port` and wait until every line is acknowledged.
///
/// Connects (banner, `$I`, alarm check), optionally vets the job in check mode, restores the
/// modal state for `--from-line`, then streams with status polling. Any fault stops the machine
/// (soft reset, laser off) and returns an error carrying the resume line ([`MachineError::halt`]).
pub fn send(
    port: &mut dyn BytePort,
    job: &Program,
    cfg: &StreamConfig,
    controls: Option<&Receiver<Control>>,
    obs: &mut dyn Observer,
) -> Result<Summary, MachineError> {
    allowed(job, cfg)?;
    // Checked before anything is sent; built again below if a recovery moves the line.
    job.resume_preamble_with(cfg.from_line.max(1), &cfg.lift)?;
    let stall = stall::stall_bound(stall::slowest_step(job, cfg.rapid_mm_min));
    let mut s = Session::new(port, cfg, controls, obs, stall);
    s.connect()?;
    name_differences(&mut s, job);
    s.laser_mode()?;
    let from = match &cfg.recovery {
        Some(r) => s.recover(job, r, cfg.from_line.max(1))?,
        None => cfg.from_line.max(1),
    };
    // The job's zero where its placement says; a head the person put back at the job's corner
    // was placed by the recovery's own G92.
    let at_corner = cfg.recovery.as_ref().is_some_and(|r| r.at_corner.is_some());
    if let (Some(zero), false) = (cfg.place_zero, at_corner) {
        s.place(zero)?;
    }
    let preamble = job.resume_preamble_with(from, &cfg.lift)?;
    for d in &job.dropped {
        s.obs.message(&format!(
            "line {} `{}` only asks Grbl for information: left out of the stream",
            d.number, d.text
        ));
    }
    if cfg.flow == FlowControl::CharacterCounting {
        fits_buffer(job, s.rx_limit(), s.info.rx_buffer)?;
    }
    let (mut lines, resume_point) = outgoing(job, preamble, from);
    rescale(&s, job, &mut lines)?;
    if cfg.check_first {
        // With the preamble, so a resumed job is checked in the state it will run in.
        s.check(job, &lines)?;
    }
    let restore: Vec<&str> = lines
        .iter()
        .filter(|l| l.preamble)
        .map(|l| l.text.as_str())
        .collect();
    if !restore.is_empty() {
        s.obs.message(&format!(
            "resuming at line {from}: restoring the machine state with {}",
            restore.join(" ")
        ));
    }
    s.obs
        .phase(false, lines.iter().filter(|l| !l.preamble).count());
    let summary = s.stream(&lines, false, resume_point)?;
    if job.may_end_laser_on {
        s.obs
            .message("the program ends without switching the laser off: sending M5");
        s.command("M5")?;
    }
    if job.may_end_air_on {
        s.obs
            .message("the program ends without switching the air (coolant) off: sending M9");
        s.command("M9")?;
    }
    Ok(summary)
}

/// Character counting needs every line (with its newline) to fit the receive buffer at once.
fn fits_buffer(job: &Program, rx_limit: usize, rx: usize) -> Result<(), MachineError> {
    match job.lines.iter().find(|l| l.text.len() + 1 > rx_limit) {
        Some(l) => Err(MachineError::LineExceedsBuffer {
            file: job.name.clone(),
            line: l.number,
            len: l.text.len() + 1,
            rx,
        }),
        None => Ok(()),
    }
}
