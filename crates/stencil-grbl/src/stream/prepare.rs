//! The lines a job sends, prepared the same way whether they are streamed or go to the card:
//! machine changes refused unless allowed, the resume preamble put first, power rescaled, every
//! line within Grbl's length.

use super::config::StreamConfig;
use super::flight::Outgoing;
use super::session::Session;
use crate::dialects::grblhal_differs;
use crate::error::MachineError;
use crate::program::Program;
use crate::protocol::Firmware;

/// A job that changes the machine's settings goes out only when that was allowed.
pub(super) fn allowed(job: &Program, cfg: &StreamConfig) -> Result<(), MachineError> {
    if !job.machine_changes.is_empty() && !cfg.allow_machine_commands {
        return Err(MachineError::MachineCommands {
            file: job.name.clone(),
            changes: job.machine_changes.clone(),
        });
    }
    Ok(())
}

/// The lines as they go out: power rescaled as asked, each within Grbl's line length.
pub(super) fn rescale(
    s: &Session,
    job: &Program,
    lines: &mut [Outgoing],
) -> Result<(), MachineError> {
    for l in lines {
        l.text = s.rescaled(&l.text);
        if l.text.len() > stencil_gcode::limits::MAX_LINE_BYTES {
            return Err(MachineError::LineTooLong {
                file: job.name.clone(),
                line: l.number,
                len: l.text.len(),
            });
        }
    }
    Ok(())
}

/// What goes out: the resume preamble (numbered with the resume point), then the program's lines
/// from line `from` on; and the resume point (the first program line sent).
pub(super) fn outgoing(
    job: &Program,
    preamble: Vec<String>,
    from: usize,
) -> (Vec<Outgoing>, usize) {
    let body: Vec<Outgoing> = job
        .lines
        .iter()
        .filter(|l| l.number >= from)
        .map(Outgoing::program)
        .collect();
    let resume_point = body.first().map(|l| l.number).unwrap_or(from);
    let mut lines: Vec<Outgoing> = preamble
        .into_iter()
        .map(|text| Outgoing {
            number: resume_point,
            text,
            motion: false,
            preamble: true,
        })
        .collect();
    lines.extend(body);
    (lines, resume_point)
}

/// The job check plays Grbl 1.1h; on a grblHAL board, the lines it answers differently are
/// named (the first ten), before any is sent.
pub(super) fn name_differences(s: &mut Session, job: &Program) {
    if s.info.firmware != Firmware::GrblHal {
        return;
    }
    let differ: Vec<String> = job
        .lines
        .iter()
        .filter_map(|l| {
            let why = grblhal_differs(&l.text)?;
            Some(format!("line {} `{}`: {why}", l.number, l.text))
        })
        .collect();
    for d in differ.iter().take(10) {
        s.obs.message(&format!("{}: {d}", job.name));
    }
    if differ.len() > 10 {
        s.obs.message(&format!(
            "{}: {} more lines grblHAL answers differently from Grbl 1.1h",
            job.name,
            differ.len() - 10
        ));
    }
}
