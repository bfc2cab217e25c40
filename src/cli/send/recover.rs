//! `send --recover`: read the journal a run left beside its file, say what it knows, and choose
//! where and with which machine profile the job resumes.

use std::path::Path;

use anyhow::bail;

use stencil_gcode::format_duration;
use stencil_gcode::machine as machine_profile;
use stencil_grbl::{Journal, Program, RunState};

/// Tell the user what the journal knows and where the job will resume; `None` if there is
/// nothing left to do.
fn recovery_report(j: &Journal, job: &Program, path: &std::path::Path) -> Option<usize> {
    let age = j.age().as_secs_f64();
    let how = crate::cli::port::run_state_words(j.state, j.stop_reason.as_deref());
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
pub fn recover(
    given: Option<&String>,
    job: &Program,
    text: &str,
    journal_path: &Path,
) -> anyhow::Result<Option<(usize, Option<String>, Journal)>> {
    let journal_error = |e: stencil_grbl::JournalError| {
        anyhow::anyhow!("{e}{}", crate::cli::port::journal_hint(&e))
    };
    let j = Journal::read(journal_path).map_err(journal_error)?;
    j.check_file(journal_path, text.as_bytes())
        .map_err(journal_error)?;
    let machine = journal_machine(given, &j, journal_path)?;
    Ok(recovery_report(&j, job, journal_path).map(|line| (line, machine, j)))
}

/// A machine profile's content as the journal keeps it (its validated values, every field).
pub fn profile_fingerprint(m: &machine_profile::Machine) -> String {
    stencil_grbl::fingerprint(&format!("{m:?}"))
}

/// The machine profile a recovery runs with: the one named with `--machine`, else the
/// journal's, which is looked up by name only (a journal is a file beside the job: the path
/// of a file it names is never opened). Either way it must be the profile the run used, by
/// name and content; any other is refused before anything is sent.
fn journal_machine(
    given: Option<&String>,
    j: &Journal,
    journal_path: &Path,
) -> anyhow::Result<Option<String>> {
    let named = crate::cli::port::journal_named;
    let arg = crate::cli::port::recovery_profile(
        given.map(String::as_str),
        &j.machine,
        "machine",
        journal_path,
    )?;
    let m = match machine_profile::load(Some(&arg)) {
        Ok(m) => m,
        Err(e) if given.is_none() => bail!(
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
            match given {
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
