//! An output folder's set of files replaced as one transaction: whenever the process is killed,
//! the folder holds the complete earlier set or the complete new set of the names the writer owns
//! (once the half-finished swap is finished by the next run, or by any command that reads the
//! folder), never a mix; every other file in the folder is left alone. An owned name may sit in
//! a folder of its own (`layer-1/stencil.png`, a layered set's): the swap makes such folders as
//! the new set needs them and removes those it leaves empty, so a one-layer run into a layered
//! folder leaves no layer folder behind.
//!
//! How (a write-ahead plan, rolled forward):
//! 1. The folder is locked (an advisory lock on the folder itself, so no lock file is left
//!    behind); a swap an earlier, killed run left half-done is finished first ([`recover`]).
//! 2. Every new file is written in full (and synced) into the hidden `.stencil-swap/new/`.
//!    Killed here, the folder's own files are untouched; the next run deletes `.stencil-swap/`.
//! 3. The plan (every rename, in order) is written to `.stencil-swap/plan` by a rename: the
//!    commit point. From here on the swap is only ever finished, never undone: the new set is
//!    complete on disk, so finishing it is always possible.
//! 4. The plan's steps run one by one (old owned files into `.stencil-swap/old/`, new ones into
//!    place), each recorded in `.stencil-swap/done` after it is made. A step found already made
//!    (its source gone) on a re-run is skipped, so a kill between a rename and its record is
//!    harmless, and no later step ever re-creates an earlier step's source.
//! 5. The plan is deleted first (so a re-run never starts it over), then `.stencil-swap/` with
//!    the old files in it.
//!
//! A failed run uses the same machinery to move the earlier set into `previous/` ([`set_aside`]),
//! so that nothing in the folder can be taken for the failed run's result; the next successful
//! run deletes what `previous/` holds of the owned names (and the folder, when that empties it).

use std::ffi::{OsStr, OsString};
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use crate::atomic::{Replaced, WriteError};
use crate::disk::{not_a_file, plain_io, SWAP_DIR};

/// Where a failed run moves the earlier set ([`set_aside`]).
pub(crate) const PREVIOUS_DIR: &str = "previous";

const PLAN: &str = "plan";
const DONE: &str = "done";

/// One step of a plan; paths are relative to the output folder.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Step {
    /// Rename `.0` to `.1` (skipped when `.0` is gone: made before a kill).
    Rename(String, String),
    /// Create this folder (nothing when it is there).
    MkDir(String),
    /// Remove this folder if it is empty (a person's files in it keep it).
    RmDirIfEmpty(String),
}

impl Step {
    fn line(&self) -> String {
        match self {
            Step::Rename(a, b) => format!("R\t{a}\t{b}"),
            Step::MkDir(a) => format!("M\t{a}"),
            Step::RmDirIfEmpty(a) => format!("X\t{a}"),
        }
    }

    /// A plan line, if it is one this module writes for the `owned` names. A plan is a file in
    /// the folder, and the folder may have come from someone else: a plan that names anything
    /// else (a person's file, a path out of the folder) is not run. An owned name may sit in a
    /// folder of its own (`layer-1/stencil.png`): such folders ([`owned_folders`]) may be made
    /// and removed when empty, in the output folder, in `previous/` and in the swap's own.
    fn parse(line: &str, owned: &Owned) -> Option<Step> {
        let strip = |s: &'_ str, prefixes: &[&str]| -> String {
            prefixes
                .iter()
                .find_map(|p| s.strip_prefix(p))
                .unwrap_or(s)
                .to_string()
        };
        // Where an owned file may be; an owned folder, in all but the new set's.
        const FILE_IN: &[&str] = &[
            "previous/",
            ".stencil-swap/old/",
            ".stencil-swap/old-previous/",
            ".stencil-swap/new/",
        ];
        let file = |s: &str| owned.names.contains(strip(s, FILE_IN).as_str());
        let owned_folder = |s: &str| owned.folders.contains(strip(s, &FILE_IN[..3]).as_str());
        let folder = |s: &str| {
            matches!(
                s,
                PREVIOUS_DIR | ".stencil-swap/old" | ".stencil-swap/old-previous"
            ) || owned_folder(s)
        };
        let mut f = line.split('\t');
        let step = match (f.next()?, f.next()?, f.next()) {
            ("R", a, Some(b)) if file(a) && file(b) => Step::Rename(a.into(), b.into()),
            ("M", a, None) if folder(a) => Step::MkDir(a.into()),
            ("X", a, None) if a == PREVIOUS_DIR || (owned_folder(a) && !a.starts_with('.')) => {
                Step::RmDirIfEmpty(a.into())
            }
            _ => return None,
        };
        Some(step)
    }

    fn run(&self, dir: &Path) -> Result<(), WriteError> {
        // Every folder a step goes through (previous/, an owned name's folder, and the swap's
        // own old/ and new/) is followed only as a real folder, never a link: a received folder
        // whose `.stencil-swap/old` links elsewhere would otherwise have its files moved over
        // files of another folder, and a linked `new/` would move another folder's files in.
        let paths: &[&String] = match self {
            Step::Rename(a, b) => &[a, b],
            Step::MkDir(a) | Step::RmDirIfEmpty(a) => &[a],
        };
        for p in paths {
            for anc in ancestors(p) {
                let at = dir.join(anc);
                if (anc == PREVIOUS_DIR && matches!(self, Step::Rename(..))) || exists(&at) {
                    refuse_unless_real(&at, true)?;
                }
            }
        }
        let err = |p: &str, e| io_err(&dir.join(p), e);
        match self {
            Step::Rename(a, b) => match std::fs::rename(dir.join(a), dir.join(b)) {
                Err(e) if e.kind() == std::io::ErrorKind::NotFound && !exists(&dir.join(a)) => {
                    Ok(())
                }
                r => r.map_err(|e| err(a, e)),
            },
            Step::MkDir(a) => match std::fs::create_dir(dir.join(a)) {
                // There already: only as a real folder (a link is not followed).
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    refuse_unless_real(&dir.join(a), true)
                }
                r => r.map_err(|e| err(a, e)),
            },
            Step::RmDirIfEmpty(a) => {
                if real_dir(&dir.join(a)) {
                    let _ = std::fs::remove_dir(dir.join(a));
                }
                Ok(())
            }
        }
    }
}

/// Refuse a path a swap goes through that is not a real folder (`folder`: one it needs there), or
/// a file of the swap's own (its plan, its record of steps done) that is there as anything but a
/// regular file: a symbolic link is never followed, read or written through, wherever it points.
fn refuse_unless_real(p: &Path, folder: bool) -> Result<(), WriteError> {
    let is = match std::fs::symlink_metadata(p) {
        Ok(m) if (folder && m.is_dir()) || (!folder && m.is_file()) => return Ok(()),
        Ok(m) if m.file_type().is_symlink() => "a symbolic link",
        // (Only a folder's place can hold a regular file here.)
        Ok(m) => not_a_file(&m.file_type()).unwrap_or("a file"),
        Err(_) if folder => "missing",
        Err(_) => return Ok(()),
    };
    Err(WriteError::NotSwapFolder {
        path: p.to_path_buf(),
        is,
    })
}

fn exists(p: &Path) -> bool {
    std::fs::symlink_metadata(p).is_ok()
}

/// The folders a relative path sits in, outermost first (`a/b/c` → `a`, `a/b`).
fn ancestors(p: &str) -> Vec<&str> {
    p.match_indices('/').map(|(i, _)| &p[..i]).collect()
}

/// The folders the owned names sit in (`layer-1` for `layer-1/stencil.png`), outermost first,
/// each once.
fn owned_folders<'a>(owned: &[&'a str]) -> Vec<&'a str> {
    let mut seen = std::collections::HashSet::new();
    let mut out: Vec<&str> = Vec::new();
    for n in owned {
        // A name's own folder seen means its folders all are (they were added with it): one
        // look per name, not one per folder (a tiled set owns some twenty thousand names, and
        // this runs a few times per write).
        let Some((folder, _)) = n.rsplit_once('/') else {
            continue;
        };
        if seen.contains(folder) {
            continue;
        }
        for a in ancestors(n) {
            if seen.insert(a) {
                out.push(a);
            }
        }
    }
    out.sort_by_key(|f| f.matches('/').count());
    out
}

/// The owned names and their folders as sets, for the plan's lines to be checked against (a
/// tiled set owns some twenty thousand names: a list searched per line took seconds).
struct Owned<'a> {
    names: std::collections::HashSet<&'a str>,
    folders: std::collections::HashSet<&'a str>,
}

impl<'a> Owned<'a> {
    fn new(owned: &[&'a str]) -> Self {
        Owned::with_folders(owned, &owned_folders(owned))
    }

    /// [`Owned::new`] given the names' folders ([`owned_folders`] of `owned`), where a write
    /// has them already.
    fn with_folders(owned: &[&'a str], folders: &[&'a str]) -> Self {
        Owned {
            names: owned.iter().copied().collect(),
            folders: folders.iter().copied().collect(),
        }
    }
}

/// Which of `folders` (outermost first, as [`owned_folders`] gives them) are there in `dir` as
/// anything. A folder whose parent is not there as a real folder is not looked for, nor one its
/// parent's listing does not hold: most owned folders (a tile's, a tile's layer's: over a hundred
/// at the top alone) are absent, each look is a system call, and a parent is listed once (where
/// it cannot be listed, each folder is looked for).
fn folders_there<'a>(dir: &Path, folders: &[&'a str]) -> Vec<&'a str> {
    let mut real = std::collections::HashSet::new();
    let mut listed: std::collections::HashMap<&str, Option<std::collections::HashSet<OsString>>> =
        std::collections::HashMap::new();
    let mut there = Vec::new();
    for f in folders {
        let (parent, name) = match f.rsplit_once('/') {
            Some((parent, name)) => {
                if !real.contains(parent) {
                    continue;
                }
                (parent, name)
            }
            None => ("", *f),
        };
        let names = listed.entry(parent).or_insert_with(|| {
            let entries = std::fs::read_dir(dir.join(parent)).ok()?;
            entries
                .map(|e| e.map(|e| e.file_name()))
                .collect::<std::io::Result<_>>()
                .ok()
        });
        if names
            .as_ref()
            .is_some_and(|n| !n.contains(OsStr::new(name)))
        {
            continue;
        }
        if let Ok(m) = std::fs::symlink_metadata(dir.join(f)) {
            if m.is_dir() {
                real.insert(*f);
            }
            there.push(*f);
        }
    }
    there
}

/// Refuse an owned folder that is there but is not a real folder (a file, a link elsewhere).
fn refuse_odd_folders(dir: &Path, folders: &[&str]) -> Result<(), WriteError> {
    for f in folders_there(dir, folders) {
        let p = dir.join(f);
        if !real_dir(&p) {
            return Err(WriteError::NotAFile {
                path: p,
                is: "not a folder stencil made",
            });
        }
    }
    Ok(())
}

/// Whether `p` is a folder itself (not a link to one).
fn real_dir(p: &Path) -> bool {
    std::fs::symlink_metadata(p).is_ok_and(|m| m.is_dir())
}

/// Where a test may stop the swap, as a kill would: the hook gets a running count of the points
/// passed and returns `false` to stop there, with nothing undone or cleaned up.
pub(crate) type Hook<'a> = &'a mut dyn FnMut(usize) -> bool;

/// Why a swap stopped: an error, or (tests only) the hook.
#[derive(Debug)]
pub(crate) enum Stop {
    Error(WriteError),
    Hook,
}

impl From<WriteError> for Stop {
    fn from(e: WriteError) -> Self {
        Stop::Error(e)
    }
}

struct Points<'a> {
    hook: Hook<'a>,
    n: usize,
}

impl Points<'_> {
    fn pass(&mut self) -> Result<(), Stop> {
        self.n += 1;
        if (self.hook)(self.n) {
            Ok(())
        } else {
            Err(Stop::Hook)
        }
    }
}

/// The hook of a real run. In a debug build, `STENCIL_FAULT_SWAP_STEP=N` aborts the process at
/// the N-th point (as `kill -9` would stop it: no destructor, no clean-up), so that the tests can
/// kill `stencil make` at every step of its swap; a release build has no such variable.
fn process_hook() -> impl FnMut(usize) -> bool {
    #[cfg(debug_assertions)]
    let at: Option<usize> = std::env::var("STENCIL_FAULT_SWAP_STEP")
        .ok()
        .and_then(|s| s.parse().ok());
    #[cfg(not(debug_assertions))]
    let at: Option<usize> = None;
    move |n| {
        if Some(n) == at {
            std::process::abort();
        }
        true
    }
}

fn io_err(path: &Path, e: std::io::Error) -> WriteError {
    WriteError::Write {
        path: path.to_path_buf(),
        source: plain_io(e),
    }
}

/// A folder locked against other stencil runs for as long as the value lives: an advisory lock
/// on the folder itself, so that no lock file is left behind.
pub struct FolderLock(#[allow(dead_code)] File);

/// Lock `dir` against other stencil runs, waiting up to `wait` for one that holds it (polled:
/// each holder keeps it for one short read-modify-write); [`WriteError::Busy`] after that. A
/// file system without locks is not refused: the folder is used unlocked.
pub fn lock_folder(dir: &Path, wait: std::time::Duration) -> Result<FolderLock, WriteError> {
    let f = File::open(dir).map_err(|e| io_err(dir, e))?;
    let until = std::time::Instant::now() + wait;
    loop {
        match f.try_lock() {
            Ok(()) => return Ok(FolderLock(f)),
            Err(std::fs::TryLockError::WouldBlock) if std::time::Instant::now() < until => {
                std::thread::sleep(std::time::Duration::from_millis(10));
            }
            Err(std::fs::TryLockError::WouldBlock) => {
                return Err(WriteError::Busy {
                    path: dir.to_path_buf(),
                })
            }
            // A file system without locks: go on unlocked rather than refuse to write at all.
            Err(std::fs::TryLockError::Error(_)) => return Ok(FolderLock(f)),
        }
    }
}

/// Whether files and folders are synced to disk. Syncing is for power loss, which a kill is not;
/// the unit tests (which stop the swap thousands of times) skip it to run in seconds.
const SYNC: bool = !cfg!(test);

fn sync_file(f: &File) -> std::io::Result<()> {
    if SYNC {
        f.sync_all()
    } else {
        Ok(())
    }
}

fn sync_dir(dir: &Path) {
    // Durability against power loss; a kill does not need it, and some file systems refuse it.
    if !SYNC {
        return;
    }
    if let Ok(f) = File::open(dir) {
        let _ = f.sync_all();
    }
}

/// What [`recover`] found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Recovered {
    /// No half-finished swap.
    Nothing,
    /// A swap killed after its commit point was finished: the folder holds that run's set.
    Finished,
    /// A run killed before its commit point left new files that were deleted: the folder holds
    /// the earlier set.
    Discarded,
}

/// Finish or discard a swap an earlier, killed run left in `dir` for the `owned` names, and delete
/// the hidden temp files a killed single-file write left ([`crate::write_atomic`]). Commands that
/// read a folder call it first, so that they never read a mix of two runs. A folder another run is
/// writing now is refused ([`WriteError::Busy`]).
pub fn recover(dir: &Path, owned: &[&str]) -> Result<Recovered, WriteError> {
    if !exists(&dir.join(SWAP_DIR)) {
        crate::atomic::sweep_temps(dir);
        return Ok(Recovered::Nothing);
    }
    let _lock = lock_folder(dir, std::time::Duration::ZERO)?;
    let mut h = process_hook();
    let mut pts = Points { hook: &mut h, n: 0 };
    recover_locked(dir, owned, &mut pts).map_err(unstop)
}

/// [`recover`] for a command given `path`, a file or a folder inside an output folder: the folder
/// the file is in (or the folder itself), and every folder around it whose set `path` belongs to,
/// outermost first. A layer's file (`OUT/layer-1/stencil.gcode`) or folder (`OUT/layer-1`) is
/// part of the set of `OUT`, whose half-finished swap may still hold the new design's layer, so
/// `OUT` is settled before the layer is read, as when `OUT` itself is given. Which folders those
/// are is read from the path's names (a layer folder a killed run has not made yet counts too),
/// never by following a link. Each folder is listed with what [`recover`] found there.
pub fn recover_around(
    path: &Path,
    owned: &[&str],
) -> Result<Vec<(PathBuf, Recovered)>, WriteError> {
    (folders_around(path, owned).into_iter())
        .map(|dir| recover(&dir, owned).map(|r| (dir, r)))
        .collect()
}

/// The folders [`recover_around`] settles for `path`, outermost first, as the path names them
/// (made absolute only where it runs out of names: `stencil.gcode` given inside `layer-1`).
fn folders_around(path: &Path, owned: &[&str]) -> Vec<PathBuf> {
    let folders = owned_folders(owned);
    // The folder read: `path` itself when it is one, else the folder it is in.
    let base = if path.is_dir() {
        path.to_path_buf()
    } else {
        match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        }
    };
    let mut out = vec![base.clone()];
    // Up from there while the folders passed are one an owned name sits in (`layer-1`).
    let mut at = base;
    let mut rel: Vec<String> = Vec::new();
    while let Some((name, up)) = name_and_parent(&at) {
        rel.insert(0, name);
        if !folders.contains(&rel.join("/").as_str()) {
            break;
        }
        out.push(up.clone());
        at = up;
    }
    out.reverse();
    out
}

/// A folder's own name and the folder it is in, from the path's names, or from the absolute
/// path where those run out (`.`, a bare name, `..`).
fn name_and_parent(p: &Path) -> Option<(String, PathBuf)> {
    let split = |p: &Path| -> Option<(String, PathBuf)> {
        let name = p.file_name()?.to_string_lossy().into_owned();
        let up = p.parent().filter(|u| !u.as_os_str().is_empty())?;
        Some((name, up.to_path_buf()))
    };
    split(p)
        .or_else(|| std::path::absolute(p).ok().and_then(|a| split(&a)))
        .or_else(|| p.canonicalize().ok().and_then(|a| split(&a)))
}

#[cfg(test)]
pub(crate) fn recover_hooked(dir: &Path, owned: &[&str], hook: Hook) -> Result<Recovered, Stop> {
    let _lock = lock_folder(dir, std::time::Duration::ZERO)?;
    let mut pts = Points { hook, n: 0 };
    recover_locked(dir, owned, &mut pts)
}

fn unstop(s: Stop) -> WriteError {
    match s {
        Stop::Error(e) => e,
        Stop::Hook => WriteError::Write {
            path: PathBuf::from(SWAP_DIR),
            source: std::io::Error::other("stopped by the test hook"),
        },
    }
}

fn recover_locked(dir: &Path, owned: &[&str], pts: &mut Points) -> Result<Recovered, Stop> {
    crate::atomic::sweep_temps(dir);
    let swap = dir.join(SWAP_DIR);
    if !exists(&swap) {
        return Ok(Recovered::Nothing);
    }
    refuse_unless_real(&swap, true)?;
    let plan = swap.join(PLAN);
    if exists(&plan) {
        run_plan(dir, &Owned::new(owned), pts)?;
        finish(dir, pts)?;
        Ok(Recovered::Finished)
    } else {
        std::fs::remove_dir_all(&swap).map_err(|e| io_err(&swap, e))?;
        pts.pass()?;
        Ok(Recovered::Discarded)
    }
}

/// Run the committed plan from its first unrecorded step.
fn run_plan(dir: &Path, owned: &Owned, pts: &mut Points) -> Result<(), Stop> {
    let swap = dir.join(SWAP_DIR);
    let plan_path = swap.join(PLAN);
    let bad = || {
        Stop::Error(WriteError::BadPlan {
            path: plan_path.clone(),
        })
    };
    refuse_unless_real(&plan_path, false)?;
    let text = crate::read::read_text(&plan_path, crate::read::Kind::Journal).map_err(|_| bad())?;
    let steps: Vec<Step> = text
        .lines()
        .map(|l| Step::parse(l, owned).ok_or_else(bad))
        .collect::<Result<_, _>>()?;
    let done_path = swap.join(DONE);
    refuse_unless_real(&done_path, false)?;
    let done = std::fs::symlink_metadata(&done_path).map_or(0, |m| m.len() as usize);
    let mut record = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&done_path)
        .map_err(|e| io_err(&done_path, e))?;
    for step in steps.iter().skip(done) {
        step.run(dir)?;
        pts.pass()?;
        record.write_all(b".").map_err(|e| io_err(&done_path, e))?;
        pts.pass()?;
    }
    Ok(())
}

/// Delete the plan (so that nothing starts it over), then the swap folder with the old files.
fn finish(dir: &Path, pts: &mut Points) -> Result<(), Stop> {
    let swap = dir.join(SWAP_DIR);
    sync_dir(dir);
    std::fs::remove_file(swap.join(PLAN)).map_err(|e| io_err(&swap, e))?;
    pts.pass()?;
    std::fs::remove_dir_all(&swap).map_err(|e| io_err(&swap, e))?;
    pts.pass()?;
    sync_dir(dir);
    Ok(())
}

/// Write the plan and commit it (the rename of its temp name is the commit point).
fn commit(dir: &Path, steps: &[Step], pts: &mut Points) -> Result<(), Stop> {
    let swap = dir.join(SWAP_DIR);
    let tmp = swap.join("plan.tmp");
    let text: String = steps.iter().map(|s| s.line() + "\n").collect();
    let mut f = File::create(&tmp).map_err(|e| io_err(&tmp, e))?;
    f.write_all(text.as_bytes())
        .and_then(|()| sync_file(&f))
        .map_err(|e| io_err(&tmp, e))?;
    pts.pass()?;
    std::fs::rename(&tmp, swap.join(PLAN)).map_err(|e| io_err(&tmp, e))?;
    sync_dir(&swap);
    pts.pass()
}

/// A fresh, empty swap folder (after [`recover_locked`], none is left).
fn new_swap(dir: &Path) -> Result<PathBuf, WriteError> {
    let swap = dir.join(SWAP_DIR);
    std::fs::create_dir(&swap).map_err(|e| io_err(&swap, e))?;
    Ok(swap)
}

/// What `path` is, if there and not a regular file or a link (which are moved as they are).
fn refuse_odd(path: &Path) -> Result<bool, WriteError> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_file() || m.file_type().is_symlink() => Ok(true),
        Ok(m) => Err(WriteError::NotAFile {
            path: path.to_path_buf(),
            is: not_a_file(&m.file_type()).unwrap_or("not a regular file"),
        }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
        Err(e) => Err(io_err(path, e)),
    }
}

/// Steps that delete the owned files `previous/` holds (into the swap folder), and `previous/`
/// itself if that empties it. `folders` are the `owned` names' ([`owned_folders`]).
fn clear_previous(
    dir: &Path,
    (owned, folders): (&[&str], &[&str]),
    steps: &mut Vec<Step>,
) -> Result<(), WriteError> {
    let prev = dir.join(PREVIOUS_DIR);
    if !real_dir(&prev) {
        return Ok(());
    }
    refuse_odd_folders(&prev, folders)?;
    let there = present(&prev, owned, folders)?;
    let from = format!("{PREVIOUS_DIR}/");
    move_into(steps, &there, &from, &format!("{SWAP_DIR}/old-previous"));
    for f in owned_folders(&there).iter().rev() {
        steps.push(Step::RmDirIfEmpty(format!("{PREVIOUS_DIR}/{f}")));
    }
    steps.push(Step::RmDirIfEmpty(PREVIOUS_DIR.into()));
    Ok(())
}

/// The `owned` names there in `dir` (refusing one that is not a file or a link); `folders` are
/// their folders ([`owned_folders`]).
fn present<'a>(
    dir: &Path,
    owned: &[&'a str],
    folders: &[&str],
) -> Result<Vec<&'a str>, WriteError> {
    // Only names whose folder is there as a real folder can be there (an odd folder is refused
    // before this by refuse_odd_folders).
    let folders: std::collections::HashSet<&str> =
        folders_there(dir, folders).into_iter().collect();
    let mut there = Vec::new();
    for n in owned {
        if let Some((parent, _)) = n.rsplit_once('/') {
            if !folders.contains(parent) {
                continue;
            }
        }
        if refuse_odd(&dir.join(n))? {
            there.push(*n);
        }
    }
    Ok(there)
}

/// Steps that move the owned `names` from `from` (a folder and its `/`, or "" for the output
/// folder) into the folder `into`, made first with the folders the names sit in in it.
fn move_into(steps: &mut Vec<Step>, names: &[&str], from: &str, into: &str) {
    if names.is_empty() {
        return;
    }
    steps.push(Step::MkDir(into.to_string()));
    for f in owned_folders(names) {
        steps.push(Step::MkDir(format!("{into}/{f}")));
    }
    for n in names {
        steps.push(Step::Rename(format!("{from}{n}"), format!("{into}/{n}")));
    }
}

/// Write a set of files into `dir` as one transaction (see the module notes): afterwards the
/// folder's files of the `owned` names are exactly `files`; owned names this set does not write
/// are removed (listed in the result), and so is what `previous/` holds of them. If anything
/// fails before the commit point, the folder is as it was.
pub fn replace_all(
    dir: &Path,
    files: &[(String, Vec<u8>)],
    owned: &[&str],
) -> Result<Replaced, WriteError> {
    let mut h = process_hook();
    replace_all_hooked(dir, files, owned, &mut h).map_err(unstop)
}

pub(crate) fn replace_all_hooked(
    dir: &Path,
    files: &[(String, Vec<u8>)],
    owned: &[&str],
    hook: Hook,
) -> Result<Replaced, Stop> {
    let mut pts = Points { hook, n: 0 };
    let _lock = lock_folder(dir, std::time::Duration::ZERO)?;
    recover_locked(dir, owned, &mut pts)?;
    let mut owned: Vec<&str> = owned.to_vec();
    let mut seen: std::collections::HashSet<&str> = owned.iter().copied().collect();
    for (n, _) in files {
        if seen.insert(n.as_str()) {
            owned.push(n);
        }
    }
    // Refuse, before writing anything, to replace what is not a file.
    let folders = owned_folders(&owned);
    refuse_odd_folders(dir, &folders)?;
    let existing = present(dir, &owned, &folders)?;
    let mut steps = Vec::new();
    clear_previous(dir, (&owned, &folders), &mut steps)?;
    let swap = new_swap(dir)?;
    let staged = stage(&swap, files, &mut pts);
    if let Err(e) = staged {
        if matches!(e, Stop::Error(_)) {
            let _ = std::fs::remove_dir_all(&swap);
        }
        return Err(e);
    }
    move_into(&mut steps, &existing, "", &format!("{SWAP_DIR}/old"));
    let new_names: Vec<&str> = files.iter().map(|(n, _)| n.as_str()).collect();
    let new_folders = owned_folders(&new_names);
    for f in &new_folders {
        steps.push(Step::MkDir(f.to_string()));
    }
    for (n, _) in files {
        steps.push(Step::Rename(format!("{SWAP_DIR}/new/{n}"), n.clone()));
    }
    // Owned folders this set left empty go (a person's file in one keeps it): those there now
    // and those this set makes; the rest are not there to remove.
    let mut may_be_there: std::collections::HashSet<&str> =
        folders_there(dir, &folders).into_iter().collect();
    may_be_there.extend(new_folders.iter().copied());
    for f in folders.iter().rev().filter(|f| may_be_there.contains(*f)) {
        steps.push(Step::RmDirIfEmpty(f.to_string()));
    }
    commit(dir, &steps, &mut pts)?;
    run_plan(dir, &Owned::with_folders(&owned, &folders), &mut pts)?;
    finish(dir, &mut pts)?;
    Ok(Replaced {
        written: files.iter().map(|(n, _)| dir.join(n)).collect(),
        removed: existing
            .iter()
            .filter(|n| !files.iter().any(|(f, _)| f == *n))
            .map(|n| dir.join(n))
            .collect(),
    })
}

/// Every new file written in full and synced into `.stencil-swap/new/`.
fn stage(swap: &Path, files: &[(String, Vec<u8>)], pts: &mut Points) -> Result<(), Stop> {
    let new = swap.join("new");
    std::fs::create_dir(&new).map_err(|e| io_err(&new, e))?;
    for (name, bytes) in files {
        let p = new.join(name);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).map_err(|e| io_err(parent, e))?;
        }
        let mut f = File::create(&p).map_err(|e| io_err(&p, e))?;
        f.write_all(bytes)
            .and_then(|()| sync_file(&f))
            .map_err(|e| io_err(&p, e))?;
        pts.pass()?;
    }
    Ok(())
}

/// What [`set_aside`] moved.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SetAside {
    /// The names moved, in the order given.
    pub names: Vec<String>,
    /// Where they are now (`<dir>/previous`).
    pub into: PathBuf,
    /// When the earlier set was written (its newest file's modification time).
    pub made: Option<SystemTime>,
}

/// After a failed run: move the files of the `owned` names in `dir` into `dir/previous/` as one
/// transaction (what `previous/` held of those names is deleted first), so that nothing in the
/// folder can be taken for the failed run's result. `None` when there was nothing to move. A
/// person's own files, in the folder or in `previous/`, stay where they are.
pub fn set_aside(dir: &Path, owned: &[&str]) -> Result<Option<SetAside>, WriteError> {
    let mut h = process_hook();
    set_aside_hooked(dir, owned, &mut h).map_err(unstop)
}

pub(crate) fn set_aside_hooked(
    dir: &Path,
    owned: &[&str],
    hook: Hook,
) -> Result<Option<SetAside>, Stop> {
    let mut pts = Points { hook, n: 0 };
    if !real_dir(dir) {
        return Ok(None);
    }
    let _lock = lock_folder(dir, std::time::Duration::ZERO)?;
    recover_locked(dir, owned, &mut pts)?;
    let folders = owned_folders(owned);
    refuse_odd_folders(dir, &folders)?;
    let existing = present(dir, owned, &folders)?;
    let made = (existing.iter())
        .filter_map(|n| {
            std::fs::symlink_metadata(dir.join(n))
                .and_then(|m| m.modified())
                .ok()
        })
        .max();
    if existing.is_empty() {
        return Ok(None);
    }
    let prev = dir.join(PREVIOUS_DIR);
    match std::fs::symlink_metadata(&prev) {
        Ok(m) if !m.is_dir() => {
            return Err(Stop::Error(WriteError::NotAFile {
                path: prev,
                is: "not a folder",
            }))
        }
        _ => {}
    }
    let mut steps = Vec::new();
    clear_previous(dir, (owned, &folders), &mut steps)?;
    // clear_previous may remove an emptied previous/: made again here before it is filled.
    move_into(&mut steps, &existing, "", PREVIOUS_DIR);
    let there: std::collections::HashSet<&str> = folders_there(dir, &folders).into_iter().collect();
    for f in folders.iter().rev().filter(|f| there.contains(*f)) {
        steps.push(Step::RmDirIfEmpty(f.to_string()));
    }
    new_swap(dir)?;
    commit(dir, &steps, &mut pts)?;
    run_plan(dir, &Owned::with_folders(owned, &folders), &mut pts)?;
    finish(dir, &mut pts)?;
    Ok(Some(SetAside {
        names: existing.iter().map(|s| s.to_string()).collect(),
        into: prev,
        made,
    }))
}

#[cfg(test)]
mod tests;
