//! The running studio ([`Studio`]): the history of states (undo, redo), `make`'s reading of each
//! (through the [`Maker`]), and the worker thread that computes the newest version through the
//! engine (or a set or tiles through `make`'s own code) and publishes it as [`Done`].
//!
//! One version, one picture: every result is kept with the options it was computed from and the
//! input file's identity on disk ([`Stamp`]), so the state, the command line and the files an
//! export writes are of that one version, and a picture replaced on disk is read again whole
//! (its options checked against the new picture, its pixels taken from it) rather than mixed.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use axum::http::StatusCode;
use serde_json::Value;
use tokio::sync::watch;

use stencil_core::layers::LayersConfig;
use stencil_core::tiles::TilesConfig;

use crate::engine::{Engine, RunError};
use crate::maker::Maker;
use crate::outcome::{Done, Reuse, SetRun, Shown, TilesRun};
use crate::params::{shell_quote, OptionSpec, Params};
use crate::state::{bad, Refusal, Shows, State};
use stencil_core::{stamp, Stamp};

/// How many changes undo remembers.
const HISTORY: usize = 500;
/// How often the input file is looked at for a change on disk.
const INPUT_POLL: Duration = Duration::from_secs(1);
/// How many times a run reads the input again when it changes while being read.
const RELOADS: usize = 3;

/// What `stencil studio` was started with.
pub struct StudioConfig {
    /// The picture or mesh, as `make` takes it.
    pub input: PathBuf,
    /// Where an export writes `make`'s files (and the painted keep-out pictures go).
    pub out_dir: PathBuf,
    /// Option values given on the command line, as `/api/params` takes them.
    pub initial: Value,
    /// The port on 127.0.0.1; 0: any free port.
    pub port: u16,
}

/// A state's options as `make` reads them, with the input's stamp when they were read (the
/// picture's size is read for `--crop` and the size in mm).
struct Derived {
    stamp: Option<Stamp>,
    cfg: stencil_core::MakeConfig,
    set: Option<LayersConfig>,
    tiles: Option<TilesConfig>,
}

/// A version to compute.
struct Job {
    version: u64,
    params: Params,
    /// Derived when it was asked for; the worker derives it again if the input changed since.
    derived: Option<Derived>,
}

/// A run's identity, as its results are published.
struct Run {
    version: u64,
    params: Params,
    stamp: Option<Stamp>,
    notice: Option<String>,
    t0: Instant,
}

/// The states taken (for undo and redo), the one shown, and the newest job for the worker.
#[derive(Default)]
struct History {
    states: Vec<Params>,
    at: usize,
    version: u64,
    /// The newest version to compute.
    job: Option<Job>,
    stop: bool,
}

/// The running studio, shared by the handlers and the worker.
pub(crate) struct Studio {
    pub(crate) reuse: Reuse,
    pub(crate) maker: Arc<dyn Maker>,
    pub(crate) specs: Vec<OptionSpec>,
    pub(crate) input: PathBuf,
    pub(crate) out_dir: PathBuf,
    pub(crate) token: String,
    pub(crate) hosts: Vec<String>,
    history: Mutex<History>,
    /// Held by a change from reading the state to taking the new one, so changes made at once
    /// each build on the one before (none is lost) and the history moves only when a change is
    /// taken.
    edit: Mutex<()>,
    /// One export at a time (two would write the same folder at once).
    pub(crate) exporting: tokio::sync::Mutex<()>,
    wake: Condvar,
    pub(crate) wanted: AtomicU64,
    pub(crate) done: watch::Sender<Arc<Done>>,
    /// Bumped for every new version asked for (the page says "updating").
    pub(crate) asked: watch::Sender<u64>,
    pub(crate) shutdown: watch::Sender<bool>,
}

impl Studio {
    /// A studio for `cfg` serving on `port` with the options `initial`, its first run (whose
    /// options are checked now, so a bad one stops the studio at once) queued, and its worker.
    pub(crate) fn start(
        maker: Arc<dyn Maker>,
        specs: Vec<OptionSpec>,
        initial: Params,
        cfg: StudioConfig,
        port: u16,
    ) -> Result<(Arc<Studio>, std::thread::JoinHandle<()>), String> {
        let studio = Arc::new(Studio {
            reuse: Reuse::default(),
            maker,
            specs,
            input: cfg.input,
            out_dir: cfg.out_dir,
            token: token().map_err(|e| format!("no random token: {e}"))?,
            hosts: vec![format!("127.0.0.1:{port}"), format!("localhost:{port}")],
            history: Mutex::new(History {
                states: vec![initial.clone()],
                ..History::default()
            }),
            edit: Mutex::new(()),
            exporting: tokio::sync::Mutex::new(()),
            wake: Condvar::new(),
            wanted: AtomicU64::new(0),
            done: watch::Sender::new(Arc::new(Done {
                version: 0,
                params: initial.clone(),
                stamp: None,
                notice: None,
                outcome: Err("starting".into()),
                refused: None,
                checking: false,
                ms: 0.0,
                images: Mutex::new(Vec::new()),
            })),
            asked: watch::Sender::new(0),
            shutdown: watch::Sender::new(false),
        });
        let derived = studio.derive(&initial)?;
        let mut h = studio.history.lock().unwrap_or_else(|e| e.into_inner());
        studio.queue(&mut h, initial, Some(derived));
        drop(h);
        let s = studio.clone();
        let worker = std::thread::spawn(move || s.work());
        Ok((studio, worker))
    }

    /// Stop the worker (it ends after the run under way).
    pub(crate) fn stop(&self) {
        let mut h = self.history.lock().unwrap_or_else(|e| e.into_inner());
        h.stop = true;
        self.wanted.store(u64::MAX, Ordering::SeqCst);
        self.wake.notify_all();
    }

    /// The arguments after `make`: the input, the output folder, then the options.
    fn args(&self, p: &Params) -> Vec<String> {
        let mut a = vec![
            self.input.display().to_string(),
            "-o".to_string(),
            self.out_dir.display().to_string(),
        ];
        a.extend(p.args(&self.specs));
        a
    }

    /// The command line that reproduces `p`.
    pub(crate) fn command(&self, p: &Params) -> String {
        let mut words = vec!["stencil".to_string(), "make".to_string()];
        words.extend(self.args(p).iter().map(|w| shell_quote(w)));
        words.join(" ")
    }

    /// `p` as `make` reads it (or the message `make` fails with), with the input's stamp from
    /// before it was read.
    fn derive(&self, p: &Params) -> Result<Derived, String> {
        let stamp = stamp(&self.input);
        let args = self.args(p);
        let c = self.maker.config(&args)?;
        Ok(Derived {
            stamp,
            cfg: c.cfg,
            set: c.set,
            tiles: c.tiles,
        })
    }

    /// Ask the worker for a new version of `params`; returns it.
    fn queue(&self, h: &mut History, params: Params, derived: Option<Derived>) -> u64 {
        h.version += 1;
        let v = h.version;
        h.job = Some(Job {
            version: v,
            params,
            derived,
        });
        self.wanted.store(v, Ordering::SeqCst);
        self.wake.notify_all();
        self.asked.send_replace(v);
        v
    }

    /// Take the current state with `changes(current state)` (option names and values, as
    /// `/api/params` takes them) as the new state, after `make`'s own checks, remembered for
    /// undo; returns its version. A refused change leaves everything as it was.
    pub(crate) fn push(&self, changes: impl FnOnce(&Params) -> Value) -> Result<u64, Refusal> {
        let _edit = self.edit.lock().unwrap_or_else(|e| e.into_inner());
        let (cur, ..) = self.current();
        let p = cur
            .with(&self.specs, &changes(&cur))
            .map_err(|e| bad(StatusCode::BAD_REQUEST, e.to_string()))?;
        let d = self
            .derive(&p)
            .map_err(|m| bad(StatusCode::BAD_REQUEST, m))?;
        let mut h = self.history.lock().unwrap_or_else(|e| e.into_inner());
        let at = h.at;
        h.states.truncate(at + 1);
        h.states.push(p.clone());
        if h.states.len() > HISTORY {
            h.states.remove(0);
        }
        h.at = h.states.len() - 1;
        Ok(self.queue(&mut h, p, Some(d)))
    }

    /// Undo (`d` = -1) or redo (+1): the remembered state is checked as `make` checks it
    /// first, and only a state it takes moves the history (a refused one leaves the history,
    /// the state and the result shown as they were).
    pub(crate) fn step(&self, d: isize) -> Result<u64, Refusal> {
        let _edit = self.edit.lock().unwrap_or_else(|e| e.into_inner());
        let (to, p) = {
            let h = self.history.lock().unwrap_or_else(|e| e.into_inner());
            let to = h.at as isize + d;
            if to < 0 || to as usize >= h.states.len() {
                return Err(bad(StatusCode::CONFLICT, "nothing to undo or redo"));
            }
            (to as usize, h.states[to as usize].clone())
        };
        let derived = self
            .derive(&p)
            .map_err(|m| bad(StatusCode::BAD_REQUEST, m))?;
        let mut h = self.history.lock().unwrap_or_else(|e| e.into_inner());
        h.at = to;
        Ok(self.queue(&mut h, p, Some(derived)))
    }

    /// Compute the current state again (the input changed on disk): the worker reads the
    /// options and the picture anew.
    pub(crate) fn rerun(&self) {
        let _edit = self.edit.lock().unwrap_or_else(|e| e.into_inner());
        let mut h = self.history.lock().unwrap_or_else(|e| e.into_inner());
        let p = h.states[h.at].clone();
        self.queue(&mut h, p, None);
    }

    fn current(&self) -> (Params, u64, bool, bool) {
        let h = self.history.lock().unwrap_or_else(|e| e.into_inner());
        (
            h.states[h.at].clone(),
            h.version,
            h.at > 0,
            h.at + 1 < h.states.len(),
        )
    }

    /// The worker: runs the newest job; a newer one cancels it between stages.
    fn work(self: Arc<Self>) {
        let mut engine = Engine::new();
        // The input's stamp of the last run (`None` before the first).
        let mut last = None;
        loop {
            let job = {
                let mut h = self.history.lock().unwrap_or_else(|e| e.into_inner());
                loop {
                    if h.stop {
                        return;
                    }
                    if let Some(job) = h.job.take() {
                        break job;
                    }
                    h = self.wake.wait(h).unwrap_or_else(|e| e.into_inner());
                }
            };
            self.run(&mut engine, &mut last, job);
        }
    }

    /// Compute one version and publish it (unless a newer one superseded it). The options are
    /// checked against the picture the pixels come from: when the input changed on disk since
    /// they were read (or changes while it is read), both are read again.
    fn run(&self, engine: &mut Engine, last: &mut Option<Option<Stamp>>, job: Job) {
        let superseded = || self.wanted.load(Ordering::SeqCst) != job.version;
        let mut run = Run {
            version: job.version,
            params: job.params.clone(),
            stamp: None,
            notice: None,
            t0: Instant::now(),
        };
        let mut derived = job.derived;
        for _ in 0..RELOADS {
            if superseded() {
                return;
            }
            let now = stamp(&self.input);
            if last.as_ref().is_some_and(|l| *l != now) {
                run.notice = Some(format!(
                    "{} changed on disk: the studio read it again, so this result is of the \
                     new file",
                    self.input.display()
                ));
            }
            let d = match derived.take().filter(|d| d.stamp == now) {
                Some(d) => d,
                None => match self.derive(&job.params) {
                    Ok(d) => d,
                    Err(m) => {
                        run.stamp = now;
                        self.publish(&run, Err(m), None, false);
                        return;
                    }
                },
            };
            if last.as_ref() != Some(&d.stamp) {
                engine.forget_input();
            }
            *last = Some(d.stamp.clone());
            run.stamp = d.stamp.clone();
            // The file read is the one the options were checked against.
            let unchanged = || stamp(&self.input) == d.stamp;
            // Tiles are made whole by `make`'s own tiles code (the seams depend on the whole
            // picture, and each tile's stencil on them).
            if let Some(tc) = d.tiles {
                let made = stencil_core::tiles::run(&d.cfg, &tc);
                if !unchanged() {
                    continue;
                }
                let outcome = match made {
                    Ok(tiled) => Ok(Shown::Tiles(Arc::new(TilesRun {
                        cfg: d.cfg,
                        tc,
                        tiled,
                    }))),
                    Err(e) => Err(self.maker.describe(&d.cfg, e)),
                };
                self.publish(&run, outcome, None, false);
                return;
            }
            // A set (layers, fill-in) is made whole by `make`'s own layer code.
            if let Some(lc) = d.set {
                let made = stencil_core::layers::run(&d.cfg, &lc);
                if !unchanged() {
                    continue;
                }
                let outcome = match made {
                    Ok(set) => Ok(Shown::Set(Arc::new(SetRun {
                        cfg: d.cfg,
                        lc,
                        set,
                    }))),
                    Err(e) => Err(self.maker.describe(&d.cfg, e)),
                };
                self.publish(&run, outcome, None, false);
                return;
            }
            // One stencil: the preview first (up to the bridges), then the trace and the
            // check, shown as they arrive: the page says "checking" in between.
            let cfg = &d.cfg;
            let preview = engine.preview(cfg, &superseded);
            if !unchanged() {
                continue;
            }
            let preview = match preview {
                Err(RunError::Cancelled) => return,
                Err(RunError::Core(e)) => {
                    self.publish(&run, Err(self.maker.describe(cfg, e)), None, false);
                    return;
                }
                Ok(c) => Arc::new(c),
            };
            self.publish(&run, Ok(Shown::One(preview.clone())), None, true);
            match engine.check(&preview, &superseded) {
                Err(RunError::Cancelled) => {}
                Err(RunError::Core(e)) => {
                    self.publish(&run, Err(self.maker.describe(cfg, e)), None, false)
                }
                Ok(mut c) => {
                    let refused = c.refused.take().map(|e| self.maker.describe(cfg, e));
                    self.publish(&run, Ok(Shown::One(Arc::new(c))), refused, false);
                }
            }
            return;
        }
        // No stamp: the watch sees the file differ from it and computes it again.
        run.stamp = None;
        let msg = format!(
            "{} kept changing while it was read; the studio reads it again once it stays the same",
            self.input.display()
        );
        self.publish(&run, Err(msg), None, false);
    }

    /// Show a run's result (or error) as the newest done.
    fn publish(
        &self,
        run: &Run,
        outcome: Result<Shown, String>,
        refused: Option<String>,
        checking: bool,
    ) {
        self.done.send_replace(Arc::new(Done {
            version: run.version,
            params: run.params.clone(),
            stamp: run.stamp.clone(),
            notice: run.notice.clone(),
            outcome,
            refused,
            checking,
            ms: run.t0.elapsed().as_secs_f64() * 1e3,
            images: Mutex::new(Vec::new()),
        }));
    }

    /// Look at the input file about once a second; when it changed since the result shown was
    /// computed (and nothing newer is being computed), compute the state again from it.
    pub(crate) async fn watch_input(self: Arc<Self>) {
        let mut stop = self.shutdown.subscribe();
        let mut tick = tokio::time::interval(INPUT_POLL);
        loop {
            tokio::select! {
                _ = tick.tick() => {}
                _ = stop.wait_for(|s| *s) => return,
            }
            let done = self.done.borrow().clone();
            let idle = done.version == self.wanted.load(Ordering::SeqCst) && !done.checking;
            if done.version > 0 && idle && done.stamp != stamp(&self.input) {
                self.rerun();
            }
        }
    }

    /// Wait until version `v` (or a newer one) is done.
    pub(crate) async fn wait_for(&self, v: u64) -> Arc<Done> {
        let mut rx = self.done.subscribe();
        // A version's preview comes before its check: wait for the checked one.
        let d = rx
            .wait_for(|d| d.version > v || (d.version == v && !d.checking))
            .await
            .map(|d| d.clone());
        match d {
            Ok(d) => d,
            Err(_) => self.done.borrow().clone(),
        }
    }

    /// `GET /api/state`'s body, with `done` as the result shown.
    pub(crate) fn state<'a>(&self, done: &'a Done) -> State<'a> {
        let (params, wanted, can_undo, can_redo) = self.current();
        State {
            version: wanted,
            shown: done.version,
            updating: done.version < wanted,
            checking: done.checking,
            params: params.to_json(&self.specs),
            command: self.command(&params),
            can_undo,
            can_redo,
            ms: done.ms,
            notice: done.notice.as_deref(),
            shows: Shows::of(done, &self.reuse),
        }
    }
}

/// A random token (128 bits, hex) from the system's generator.
fn token() -> std::io::Result<String> {
    let mut b = [0u8; 16];
    getrandom::fill(&mut b).map_err(|e| std::io::Error::other(e.to_string()))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}
