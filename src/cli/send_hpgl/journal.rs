//! The journal of a plotter job (`JOB.plt.journal`, beside the file, as a G-code run's): how far
//! the stream got, so a pulled cable, a crash or a power cut can be resumed with `--recover`.
//!
//! A plotter acknowledges nothing: flow control only says its buffer has room. So the journal
//! records bytes, not acknowledgements: how many reached the plotter, the size of the buffer
//! they may still wait in, and from that the first instruction not known to be cut (the
//! streamer's reckoning). It is written when the run starts, every few seconds while it streams
//! and at every stop, and removed when the job finishes. It names the job by size and hash (a
//! journal is never applied to a file that changed) and the plotter profile by name and content
//! (a resume runs only with the profile the run used, and never opens a file a journal names).

use std::path::Path;
use std::time::{SystemTime, UNIX_EPOCH};

use anyhow::bail;
use serde::{Deserialize, Serialize};

use stencil_grbl::{fingerprint, JournalError, RunState};
use stencil_hpgl::profile::Plotter;

/// The format tag: another than a G-code run's journal, which a plotter job never reads.
const FORMAT: &str = "stencil-plot-journal/1";

/// The journal file's content.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlotJournal {
    format: String,
    /// The job file as it was named.
    pub file: String,
    file_bytes: u64,
    file_fnv1a64: String,
    /// The plotter profile the run used, by name (a recovery loads it by name only).
    pub plotter: String,
    /// The profile's content as the run used it.
    pub plotter_fnv1a64: String,
    /// How the run stands.
    pub state: RunState,
    /// Why it stopped, for `Stopped`.
    pub stop_reason: Option<String>,
    started_unix_s: u64,
    updated_unix_s: u64,
    /// The run started at this line (a resumed run starts later than 1).
    pub from_line: usize,
    /// The line of the last instruction written to the port.
    pub last_sent_line: Option<usize>,
    /// Bytes of the run known to have reached the plotter (written, less what the host's own
    /// output queue still held).
    pub delivered_bytes: usize,
    /// The plotter's buffer (the profile's): how many of those bytes may not have been cut.
    pub buffer_bytes: usize,
    /// The first instruction not known to be cut: a recovery resumes here.
    pub resume_from: usize,
}

fn unix_now() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}

/// A plotter profile's content as the journal keeps it (its validated values, every field).
pub fn plotter_fingerprint(p: &Plotter) -> String {
    fingerprint(&format!("{p:?}"))
}

impl PlotJournal {
    /// A fresh journal for a run of `text` (the file at `file`) on `plotter` from `from_line`.
    pub fn new(file: &Path, text: &str, plotter: &Plotter, from_line: usize) -> Self {
        let now = unix_now();
        PlotJournal {
            format: FORMAT.into(),
            file: file.display().to_string(),
            file_bytes: text.len() as u64,
            file_fnv1a64: fingerprint(text),
            plotter: plotter.name.clone(),
            plotter_fnv1a64: plotter_fingerprint(plotter),
            state: RunState::Running,
            stop_reason: None,
            started_unix_s: now,
            updated_unix_s: now,
            from_line,
            last_sent_line: None,
            delivered_bytes: 0,
            buffer_bytes: plotter.serial.buffer_bytes,
            resume_from: from_line,
        }
    }

    /// Write it atomically to `path`.
    pub fn write(&mut self, path: &Path) -> Result<(), JournalError> {
        self.updated_unix_s = unix_now();
        let failed = |e: &dyn std::fmt::Display| JournalError::Write {
            path: path.to_path_buf(),
            detail: e.to_string(),
        };
        let text = serde_json::to_string_pretty(self).map_err(|e| failed(&e))?;
        stencil_io::write_atomic(path, text.as_bytes()).map_err(|e| failed(&e))
    }

    /// Read the journal at `path`.
    pub fn read(path: &Path) -> Result<Self, JournalError> {
        let text = match stencil_io::read_text(path, stencil_io::Kind::Journal) {
            Ok(t) => t,
            Err(stencil_io::ReadError::Open { source, .. })
                if source.kind() == std::io::ErrorKind::NotFound =>
            {
                return Err(JournalError::Missing {
                    path: path.to_path_buf(),
                })
            }
            Err(e) => {
                return Err(JournalError::Unreadable {
                    path: path.to_path_buf(),
                    detail: e.to_string(),
                })
            }
        };
        let not = |detail: String| JournalError::NotJournal {
            path: path.to_path_buf(),
            detail,
        };
        let j: PlotJournal = serde_json::from_str(&text).map_err(|e| {
            not(format!(
                "not a plotter job's journal: {}",
                stencil_io::excerpt(&e.to_string())
            ))
        })?;
        if j.format != FORMAT {
            return Err(not(format!(
                "format `{}`, expected `{FORMAT}`",
                stencil_io::excerpt(&j.format.escape_debug().to_string())
            )));
        }
        Ok(j)
    }

    /// Refuse a journal written for another text than `text` (the job file now).
    pub fn check_file(&self, path: &Path, text: &str) -> Result<(), JournalError> {
        let hash = fingerprint(text);
        if hash == self.file_fnv1a64 && text.len() as u64 == self.file_bytes {
            return Ok(());
        }
        Err(JournalError::Mismatch {
            path: path.to_path_buf(),
            file: self.file.clone(),
            journal_bytes: self.file_bytes,
            journal_hash: self.file_fnv1a64.clone(),
            file_bytes: text.len() as u64,
            file_hash: hash,
        })
    }

    /// How long ago it was last written, s.
    pub fn age_s(&self) -> f64 {
        unix_now().saturating_sub(self.updated_unix_s) as f64
    }
}

/// The plotter profile a recovery runs with: the one named with `--machine`, else the
/// journal's, looked up by name only (a journal is a file beside the job: a path it names is
/// never opened). Either way it must be the profile the run used, by name and content.
pub fn journal_plotter(
    given: Option<&str>,
    j: &PlotJournal,
    journal_path: &Path,
) -> anyhow::Result<Plotter> {
    let named = crate::cli::port::journal_named;
    let arg = crate::cli::port::recovery_profile(given, &j.plotter, "plotter", journal_path)?;
    let p = match stencil_hpgl::profile::load(&arg) {
        Ok(p) => p,
        Err(e) if given.is_none() => bail!(
            "{}: the journal's run used plotter profile `{}`, which cannot be loaded by name \
             here ({e}): name the profile the run used with --machine; nothing was sent",
            journal_path.display(),
            named(&j.plotter)
        ),
        Err(e) => return Err(e.into()),
    };
    let same_name = p.name == j.plotter;
    if !(same_name && plotter_fingerprint(&p) == j.plotter_fnv1a64) {
        bail!(
            "{}: the journal's run used plotter profile `{}` (as it was then), but {} is {}: a \
             resume must run with the profile the run used (its buffer, its units, its area); \
             nothing was sent. Recover with that profile (--machine), or resume from a line \
             after checking (--from-line)",
            journal_path.display(),
            named(&j.plotter),
            match given {
                Some(given) => format!("--machine {}", named(given)),
                None => format!("the profile `{}` now", named(&arg)),
            },
            if same_name {
                "that profile with other settings".to_string()
            } else {
                format!("profile `{}`", named(&p.name))
            }
        );
    }
    Ok(p)
}
