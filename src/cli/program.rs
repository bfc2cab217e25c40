//! The G-code file a command reads (`send`, `frame`, `estimate`, `simulate`): read bounded after
//! settling the `make` folder it lies in, where it came from, and its lines that change the
//! machine itself.

use std::path::Path;
use stencil_grbl::Program;

/// The job's origin, from its header and the file's time, printed before anything moves: which
/// picture, material, size and machine the file was made for, and when it was written, so that
/// an old job is not taken for a new one. (When it was made is the file's time, not a header
/// line: the same input and options still give the same bytes.)
pub fn origin_line(path: &Path, text: &str) -> String {
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
    for (i, l) in header.iter().enumerate().skip(1) {
        if *l == "from" || l.starts_with("from ") {
            // A long path wraps over lines, up to the material's.
            let n = header[i..]
                .iter()
                .position(|l| l.starts_with("material "))
                .unwrap_or(1);
            let from = stencil_gcode::unwrap_comment(&header[i..i + n]);
            let from = from.strip_prefix("from ").unwrap_or(&from);
            parts.push(format!("from {}", stencil_io::excerpt_name(from)));
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

/// A G-code file, read through the bounded reader (at most 512 MB; a FIFO or a device is refused
/// at once). A `stencil make` folder it lies in (or, for a layer's job, the set's folder around
/// it) that a killed run left half-swapped is finished first ([`settle`]), so the program is
/// never one run's beside another run's files, nor the previous design's layer.
pub fn read_program(path: &Path) -> anyhow::Result<String> {
    settle(path)?;
    Ok(stencil_io::read_text(path, stencil_io::Kind::Gcode)?)
}

/// Before `path` (a file or a folder) is read: finish or discard a half-finished swap of `make`
/// in the folder it is, and in the set folder around it when it is a layer's
/// ([`stencil_io::recover_around`]), saying so.
pub fn settle(path: &Path) -> anyhow::Result<()> {
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

fn machine_change_note(file: &str, line: usize, text: &str, what: &str) {
    eprintln!(
        "note: {file}: line {line} `{text}` {what}: `stencil send` refuses it unless \
         --allow-machine-commands is given"
    );
}

/// Say which lines of a job would change the machine itself (a `$` setting, homing, a stored
/// offset...): `send` refuses them unless `--allow-machine-commands` is given.
pub fn name_machine_changes(job: &Program) {
    for c in &job.machine_changes {
        machine_change_note(&job.name, c.line, &c.text, &c.what);
    }
}

/// [`name_machine_changes`] for a file read as text (the commands that do not stream it).
pub fn name_machine_changes_in(path: &Path, text: &str) {
    for (i, raw) in text.lines().enumerate() {
        let clean = stencil_gcode::interpret::clean_line(raw);
        if let Some(what) = stencil_grbl::machine_change(&clean) {
            machine_change_note(&path.display().to_string(), i + 1, &clean, &what);
        }
    }
}
