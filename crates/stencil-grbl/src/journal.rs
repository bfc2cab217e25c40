//! The job journal: a small file beside a job being streamed (`JOB.gcode.journal`) that says how
//! far it got, so a crash, a pulled cable or a power cut can be resumed (`send --recover`).
//!
//! It is rewritten atomically (`stencil_io::write_atomic`) every few seconds while streaming
//! and on every stop, and removed when the job finishes. What it records is what the host knows:
//! Grbl acknowledges a line when it is queued, not when it has run, so besides the last
//! acknowledged line it keeps the first line that may not have run (from the status reports' free
//! planner blocks, or the whole planner depth when unknown) and Grbl's `Ln:` if it reports one.
//! The file is JSON and names the job by size and FNV-1a hash: a journal is never applied to a
//! file that changed.

use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};

use super::error::MachineError;
use super::program::{n_word, Program};
use super::stall::ClockRef;
use super::stream::{ControllerInfo, Observer, Progress, Summary};
use stencil_io::write_atomic;

/// The format tag the file starts with.
pub(crate) const FORMAT: &str = "stencil-send-journal/1";

/// How often the journal is rewritten while streaming.
pub const JOURNAL_EVERY: Duration = Duration::from_secs(2);

/// Where the journal of `job` lives: beside it, `NAME.journal`.
pub fn journal_path(job: &Path) -> PathBuf {
    let mut s = job.as_os_str().to_os_string();
    s.push(".journal");
    PathBuf::from(s)
}

/// Where the last line sent is kept between full writes of the journal at `journal`: a file
/// beside it holding one number, overwritten in place as each line goes out. Rewriting the
/// whole journal atomically for every line cost a 200,000-line dry run 34 s (23 s of it in the
/// kernel); one small write in place costs a system call. A killed sender's last write is in
/// the page cache, so it survives the process.
fn sent_path(journal: &Path) -> PathBuf {
    let mut s = journal.as_os_str().to_os_string();
    s.push(".sent");
    PathBuf::from(s)
}

/// The number [`sent_path`] holds, if it holds one (a short read: the file is one line).
fn read_sent(journal: &Path) -> Option<usize> {
    use std::io::Read;
    let mut f = std::fs::File::open(sent_path(journal)).ok()?;
    let mut buf = [0u8; SENT_RECORD];
    let n = f.read(&mut buf).ok()?;
    std::str::from_utf8(&buf[..n]).ok()?.trim().parse().ok()
}

/// The sent-line file's one record: a right-aligned number and a newline, always this long,
/// so each write replaces the whole of the last.
const SENT_RECORD: usize = 21;

/// The sent-line file of a run, made anew (an existing one, or a link in its place, is removed
/// first, and the new one is created exclusively: a link put there is never followed).
fn create_sent(journal: &Path) -> std::io::Result<std::fs::File> {
    let path = sent_path(journal);
    match std::fs::remove_file(&path) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(e),
    }
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
}

/// Overwrite the sent-line file's record with `line`.
fn write_sent(f: &mut std::fs::File, line: usize) -> std::io::Result<()> {
    use std::io::{Seek, SeekFrom, Write};
    let record = format!("{line:>width$}\n", width = SENT_RECORD - 1);
    f.seek(SeekFrom::Start(0))?;
    f.write_all(record.as_bytes())
}

/// FNV-1a, 64 bit: enough to tell a changed job file from the one journalled (not a security
/// hash; the size is compared too).
pub(crate) fn fnv1a64(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// A short text standing for `content` (a machine profile as the run used it): a journal keeps
/// it so that a recovery can tell the profile it is given from the one the run used.
pub fn fingerprint(content: &str) -> String {
    fnv1a64(content.as_bytes())
}

/// How the run stands.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RunState {
    /// Streaming (or the sender died without a word: crash, kill, power loss).
    #[default]
    Running,
    /// Stopped by an error, an alarm, a lost or silent port, a stall or the operator.
    Stopped,
    /// Every line ran; nothing to recover.
    Complete,
}

/// The modal state a resume must restore, as the program had built it before `resume_from`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ModalRecord {
    /// "G21" (mm) or "G20" (inches).
    pub units: String,
    /// "G90" (absolute) or "G91" (incremental).
    pub distance: String,
    /// The feed (F), mm/min, once one was set.
    pub feed_mm_min: Option<f64>,
    /// "M3", "M4" or "M5".
    pub spindle: String,
    /// The power (S).
    pub s: f64,
    /// Coolant (air assist) on.
    pub air: bool,
    /// Tool position, mm, where the program had it.
    pub position_mm: [f64; 3],
}

/// The journal file's content.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Journal {
    pub(crate) format: String,
    /// The job file as it was named.
    pub file: String,
    pub(crate) file_bytes: u64,
    pub(crate) file_fnv1a64: String,
    /// The machine profile the run used, by name (never a path: a recovery loads profiles by
    /// name only, and never opens a file a journal names).
    pub machine: String,
    /// The profile's content as the run used it ([`fingerprint`]): a recovery with a
    /// profile that differs is refused.
    #[serde(default)]
    pub machine_fnv1a64: Option<String>,
    /// How the run stands.
    pub state: RunState,
    /// Why it stopped (the sender's own message), for `Stopped`.
    pub stop_reason: Option<String>,
    pub(crate) started_unix_s: u64,
    pub(crate) updated_unix_s: u64,
    /// The run started at this line (a resumed run starts later than 1).
    pub from_line: usize,
    /// The last file line Grbl acknowledged (queued; maybe not run).
    pub last_acked_line: Option<usize>,
    /// The last file line handed to the port, recorded before it goes out: after a crash,
    /// Grbl can have received nothing past it.
    #[serde(default)]
    pub last_sent_line: Option<usize>,
    /// The stop reset Grbl, which dropped what it had queued: nothing ran after the journal's
    /// last record. False for a run that did not end (the sender crashed) and for a stop that
    /// could not reach Grbl (a lost or silent port): Grbl may have run on through every line
    /// it had received.
    #[serde(default)]
    pub grbl_stopped: bool,
    /// The last `Ln:` (N number being executed) a status report gave, if the firmware reports it.
    pub status_ln: Option<u32>,
    /// Grbl's planner depth: how many acknowledged moves may still wait.
    pub planner_blocks: usize,
    /// The first file line that may not have run (acknowledged lines still waiting in the
    /// planner count as not run).
    pub resume_from: usize,
    /// The modal state before `resume_from`.
    pub modal: ModalRecord,
    /// Where the last status report put the head (machine coordinates), so that a recovery
    /// can tell a controller that lost its position (a restart at MPos 0 without homing).
    #[serde(default)]
    pub last_position: Option<[f64; 3]>,
    /// Where the run put the job's X0 Y0 ([`Placement`](super::placement::Placement)): a stop's
    /// soft reset or a power loss clears G92, so a recovery puts it back from here.
    #[serde(default)]
    pub placement: Option<PlacementRecord>,
}

/// The placement a run used, as the journal keeps it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlacementRecord {
    /// `machine`, `work-zero` or `current`, as the option is spelled.
    pub start_from: String,
    /// Machine coordinates (X, Y) of the job's X0 Y0.
    pub zero_mm: [f64; 2],
}

/// Why a journal cannot be used.
#[allow(missing_docs)] // Each variant's message says when it happens and what its fields are.
#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    #[error("{}: no journal beside the job (nothing was streamed from this file, or it finished and the journal was removed); resume from a line instead", path.display())]
    Missing { path: PathBuf },
    #[error("{}: cannot read the journal: {detail}", path.display())]
    Unreadable { path: PathBuf, detail: String },
    #[error("{}: not a stencil send journal ({detail}); remove it, and resume from a line", path.display())]
    NotJournal { path: PathBuf, detail: String },
    #[error("{}: the journal was written for a different {file} ({journal_bytes} bytes, hash {journal_hash}) than the one there now ({file_bytes} bytes, hash {file_hash}): the file changed since the run, so its line numbers cannot be trusted; nothing was sent. Recover with the file the run used, or resume from a line after checking", path.display())]
    Mismatch {
        path: PathBuf,
        file: String,
        journal_bytes: u64,
        journal_hash: String,
        file_bytes: u64,
        file_hash: String,
    },
    #[error("{}: cannot write the journal: {detail}", path.display())]
    Write { path: PathBuf, detail: String },
}

fn unix_now() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}

impl Journal {
    /// A fresh journal for a run of `job` (its file's bytes) on `machine` from `from_line`.
    pub fn new(
        file: &Path,
        bytes: &[u8],
        job: &Program,
        machine: &str,
        from_line: usize,
    ) -> Journal {
        let now = unix_now();
        let mut j = Journal {
            format: FORMAT.into(),
            file: file.display().to_string(),
            file_bytes: bytes.len() as u64,
            file_fnv1a64: fnv1a64(bytes),
            machine: machine.to_string(),
            started_unix_s: now,
            updated_unix_s: now,
            from_line,
            planner_blocks: stencil_gcode::limits::PLANNER_BLOCKS,
            resume_from: from_line,
            modal: ModalRecord {
                units: "G21".into(),
                distance: "G90".into(),
                feed_mm_min: None,
                spindle: "M5".into(),
                s: 0.0,
                air: false,
                position_mm: [0.0; 3],
            },
            ..Journal::default()
        };
        j.set_resume(job, from_line);
        j
    }

    /// Move the resume point, and the modal state recorded with it.
    pub(crate) fn set_resume(&mut self, job: &Program, line: usize) {
        self.resume_from = line;
        // A line past the end (everything ran) has the state at the end of the file.
        let before = line.min(job.source_lines() + 1);
        let Ok(st) = job.state_before(before.max(1)) else {
            return;
        };
        let m = st.modal;
        self.modal = ModalRecord {
            units: if m.metric { "G21" } else { "G20" }.into(),
            distance: if m.absolute { "G90" } else { "G91" }.into(),
            feed_mm_min: m.feed,
            spindle: match (m.spindle_on, m.dynamic) {
                (false, _) => "M5",
                (true, true) => "M4",
                (true, false) => "M3",
            }
            .into(),
            s: m.s,
            air: m.coolant,
            position_mm: m.pos,
        };
    }

    /// Write it atomically to `path`.
    pub fn write(&mut self, path: &Path) -> Result<(), JournalError> {
        self.updated_unix_s = unix_now();
        let failed = |e: &dyn std::fmt::Display| JournalError::Write {
            path: path.to_path_buf(),
            detail: e.to_string(),
        };
        let text = serde_json::to_string_pretty(self).map_err(|e| failed(&e))?;
        write_atomic(path, text.as_bytes()).map_err(|e| failed(&e))
    }

    /// Read the journal at `path`.
    pub fn read(path: &Path) -> Result<Journal, JournalError> {
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
                let text = e.to_string();
                let prefix = format!("{}: ", path.display());
                return Err(JournalError::Unreadable {
                    path: path.to_path_buf(),
                    detail: text.strip_prefix(&prefix).unwrap_or(&text).to_string(),
                });
            }
        };
        let mut j: Journal = serde_json::from_str(&text).map_err(|e| JournalError::NotJournal {
            path: path.to_path_buf(),
            detail: e.to_string(),
        })?;
        if j.format != FORMAT {
            return Err(JournalError::NotJournal {
                path: path.to_path_buf(),
                detail: format!("format `{}`, expected `{FORMAT}`", j.format),
            });
        }
        // Lines sent since the journal was last written in full.
        if let Some(sent) = read_sent(path).filter(|&n| n > 0) {
            j.last_sent_line = Some(j.last_sent_line.map_or(sent, |s| s.max(sent)));
        }
        Ok(j)
    }

    /// Refuse a journal written for other bytes than `bytes` (the job file now).
    pub fn check_file(&self, path: &Path, bytes: &[u8]) -> Result<(), JournalError> {
        let hash = fnv1a64(bytes);
        if hash == self.file_fnv1a64 && bytes.len() as u64 == self.file_bytes {
            return Ok(());
        }
        Err(JournalError::Mismatch {
            path: path.to_path_buf(),
            file: self.file.clone(),
            journal_bytes: self.file_bytes,
            journal_hash: self.file_fnv1a64.clone(),
            file_bytes: bytes.len() as u64,
            file_hash: hash,
        })
    }

    /// The line to resume from, and why: the line carrying the last `Ln:` Grbl reported (it was
    /// running, so not surely done), else the first line that may not have run by the host's
    /// count (acknowledged minus what the planner may still have held).
    pub fn proposal(&self, job: &Program) -> Proposal {
        if let Some(ln) = self.status_ln {
            if let Some(l) = job.lines.iter().find(|l| n_word(&l.text) == Some(ln)) {
                return Proposal {
                    line: l.number,
                    why: format!(
                        "Grbl last reported executing N{ln} (line {}): lines before it surely ran",
                        l.number
                    ),
                };
            }
        }
        let why = match (self.state, self.last_acked_line) {
            (RunState::Complete, _) => "the job finished".to_string(),
            (_, None) => "no line was acknowledged".to_string(),
            (_, Some(a)) if self.resume_from > a => {
                format!("every acknowledged line (to {a}) had run when the machine stopped")
            }
            (_, Some(a)) => format!(
                "line {a} was the last acknowledged, but acknowledged means queued, not run: \
                 Grbl's planner holds up to {} moves, and by its last status report (free planner \
                 blocks; lines acknowledged after it count as not run) line {} is the last surely \
                 executed",
                self.planner_blocks,
                self.resume_from.saturating_sub(1)
            ),
        };
        Proposal {
            line: self.resume_from,
            why,
        }
    }

    /// How long ago it was last written.
    pub fn age(&self) -> Duration {
        Duration::from_secs(unix_now().saturating_sub(self.updated_unix_s))
    }
}

/// Where `--recover` proposes to resume.
#[derive(Clone, Debug, PartialEq)]
pub struct Proposal {
    /// The line to resume from.
    pub line: usize,
    /// Why that line.
    pub why: String,
}

/// An observer that keeps the journal while passing everything on to the front end's.
pub struct JournalWriter<'o, 'j> {
    inner: &'o mut dyn Observer,
    journal: Journal,
    path: PathBuf,
    job: &'j Program,
    clock: ClockRef,
    every: Duration,
    last_write: Option<Duration>,
    warned: bool,
    /// The real run has begun (not the check pass): lines sent now are recorded.
    live: bool,
    /// Where the run stands by the last progress report (first line that may not have run):
    /// taken into the journal, with its modal state, when it is next written in full.
    resume: usize,
    /// The sent-line file ([`sent_path`]), open while the real run lasts; `None` before,
    /// or when it could not be made (then each line sent rewrites the journal).
    sent: Option<std::fs::File>,
}

impl<'o, 'j> JournalWriter<'o, 'j> {
    /// Keep `journal` at `path` for `job`, passing every event on to `inner`; written in full at
    /// most every `every` by `clock`.
    pub fn new(
        inner: &'o mut dyn Observer,
        journal: Journal,
        path: PathBuf,
        job: &'j Program,
        clock: ClockRef,
        every: Duration,
    ) -> Self {
        JournalWriter {
            inner,
            resume: journal.resume_from,
            journal,
            path,
            job,
            clock,
            every,
            last_write: None,
            warned: false,
            live: false,
            sent: None,
        }
    }

    fn save(&mut self) {
        if let Err(e) = self.journal.write(&self.path) {
            // The job goes on: a journal is a help, not a condition of cutting.
            if !self.warned {
                self.warned = true;
                self.inner
                    .message(&format!("{e}; the job goes on without it"));
            }
        }
        self.last_write = Some(self.clock.0.now());
    }

    /// The run ended: a finished job's journal is removed (nothing is left to recover, and no
    /// stale file lingers beside the job); a stopped one records the resume line and the reason.
    /// Errors that stopped nothing (refused before streaming) leave the journal as it was.
    pub fn finish(&mut self, result: &Result<Summary, MachineError>) {
        match result {
            Ok(_) => {
                self.journal.state = RunState::Complete;
                self.sent = None;
                let _ = std::fs::remove_file(sent_path(&self.path));
                if let Err(e) = std::fs::remove_file(&self.path) {
                    if e.kind() != std::io::ErrorKind::NotFound {
                        self.inner.message(&format!(
                            "{}: cannot remove the finished job's journal: {e}",
                            self.path.display()
                        ));
                    }
                }
                return;
            }
            Err(e) => {
                let Some(h) = e.halt() else {
                    return;
                };
                self.journal.state = RunState::Stopped;
                self.journal.stop_reason = Some(e.to_string());
                // A lost or silent port may not have carried the stop: Grbl can have run on.
                self.journal.grbl_stopped = !matches!(
                    e,
                    MachineError::PortLost { .. } | MachineError::Silent { .. }
                );
                self.journal.last_acked_line = h.last_acked.or(self.journal.last_acked_line);
                self.journal.set_resume(self.job, h.resume_from);
            }
        }
        self.save();
    }
}

impl Observer for JournalWriter<'_, '_> {
    fn connected(&mut self, info: &ControllerInfo) {
        self.journal.planner_blocks = info.planner_blocks;
        self.inner.connected(info);
    }
    fn message(&mut self, text: &str) {
        self.inner.message(text);
    }
    fn phase(&mut self, checking: bool, total: usize) {
        if !checking {
            // The real run begins: the journal exists from its first line on.
            self.live = true;
            self.sent = create_sent(&self.path).ok();
            self.save();
        }
        self.inner.phase(checking, total);
    }
    fn progress(&mut self, p: &Progress) {
        self.journal.last_acked_line = p.last_acked_line.or(self.journal.last_acked_line);
        self.journal.status_ln = p.status_line.or(self.journal.status_ln);
        self.journal.last_position = p.position.or(self.journal.last_position);
        self.resume = p.unexecuted_from;
        let now = self.clock.0.now();
        if self
            .last_write
            .is_none_or(|t| now.saturating_sub(t) >= self.every)
        {
            self.journal.set_resume(self.job, self.resume);
            self.save();
        }
        self.inner.progress(p);
    }
    /// Written before the line goes out, so that after a crash the journal bounds what Grbl
    /// can have received (the resume point and its modal state stay as last written: still
    /// true, only older).
    fn sending(&mut self, line: usize) {
        if self.live && self.journal.last_sent_line.is_none_or(|s| line > s) {
            self.journal.last_sent_line = Some(line);
            let kept = match self.sent.as_mut() {
                Some(f) => write_sent(f, line).is_ok(),
                None => false,
            };
            if !kept {
                self.sent = None;
                self.save();
            }
        }
        self.inner.sending(line);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sent_line_file_carries_lines_sent_since_the_last_full_write_and_follows_no_link() {
        let dir = tempfile::tempdir().unwrap();
        let text = "G21 G90\nG1 X1 F600\nG1 X2\nG1 X3\n";
        let job = Program::parse("j.gcode", text).unwrap();
        let path = dir.path().join("j.gcode.journal");
        let mut j = Journal::new(Path::new("j.gcode"), text.as_bytes(), &job, "diode-400", 1);
        j.last_sent_line = Some(2);
        j.write(&path).unwrap();
        // A link where the file goes: removed, never written through.
        let outside = dir.path().join("outside.txt");
        std::fs::write(&outside, "keep me").unwrap();
        #[cfg(unix)]
        std::os::unix::fs::symlink(&outside, sent_path(&path)).unwrap();
        let mut f = create_sent(&path).unwrap();
        assert_eq!(std::fs::read_to_string(&outside).unwrap(), "keep me");
        write_sent(&mut f, 1234).unwrap();
        write_sent(&mut f, 4).unwrap();
        assert_eq!(
            std::fs::read_to_string(sent_path(&path)).unwrap().trim(),
            "4"
        );
        assert_eq!(Journal::read(&path).unwrap().last_sent_line, Some(4));
        // The journal's own value wins when it is later (written in full since).
        write_sent(&mut f, 1).unwrap();
        assert_eq!(Journal::read(&path).unwrap().last_sent_line, Some(2));
    }

    #[test]
    fn hash_and_path() {
        assert_eq!(fnv1a64(b""), "cbf29ce484222325");
        assert_eq!(fnv1a64(b"a"), "af63dc4c8601ec8c");
        assert_eq!(
            journal_path(Path::new("out/job.gcode")),
            PathBuf::from("out/job.gcode.journal")
        );
    }

    #[test]
    fn proposal_prefers_ln_then_the_planner_count() {
        let text = "G21 G90\nN10 M4 S100\nN20 G1 X1 F600\nN30 G1 X2\nN40 G1 X3\nN50 G1 X4\n";
        let job = Program::parse("n.gcode", text).unwrap();
        let mut j = Journal::new(Path::new("n.gcode"), text.as_bytes(), &job, "diode-400", 1);
        j.last_acked_line = Some(6);
        j.set_resume(&job, 4);
        let p = j.proposal(&job);
        assert_eq!(p.line, 4);
        assert!(
            p.why.contains("last acknowledged") && p.why.contains("line 3 is"),
            "{}",
            p.why
        );
        assert_eq!(j.modal.spindle, "M4");
        assert_eq!(j.modal.feed_mm_min, Some(600.0));
        assert_eq!(j.modal.position_mm, [1.0, 0.0, 0.0]);
        j.status_ln = Some(40);
        let p = j.proposal(&job);
        assert_eq!(p.line, 5);
        assert!(p.why.contains("N40"), "{}", p.why);
    }
}
