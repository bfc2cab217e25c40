//! The lines a job sends, prepared the same way whether they are streamed or go to the card:
//! machine changes refused unless allowed, the resume preamble put first, power rescaled, every
//! line within Grbl's length.

use super::config::StreamConfig;
use super::flight::Outgoing;
use super::session::Session;
use crate::error::MachineError;
use crate::program::Program;

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
