//! The HTTP side: one page, a JSON API, server-sent events, and the worker thread that runs the
//! engine.
//!
//! Safety of a local server: it listens on 127.0.0.1 only; every request must carry the random
//! token the printed URL holds (query `token=` or `Authorization: Bearer`); a request whose
//! `Host` or `Origin` is not this server's own is refused (a web page elsewhere cannot reach it
//! through DNS rebinding); bodies are bounded; connections are bounded and must send their
//! headers in time ([`crate::conn`]); the only files it writes are `make`'s outputs and the
//! painted keep-out pictures, in the output folder.
//!
//! One version, one picture: every result is kept with the options it was computed from and the
//! input file's identity on disk ([`Stamp`]), so the state, the command line and the files an
//! export writes are of that one version, and a picture replaced on disk is read again whole
//! (its options checked against the new picture, its pixels taken from it) rather than mixed.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use axum::body::Bytes;
use axum::extract::{DefaultBodyLimit, Path as UrlPath, Query, Request, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::middleware::{self, Next};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde_json::{json, Value};
use tokio::sync::watch;

use stencil_core::export::png;
use stencil_core::inputs::{stamp, Stamp};
use stencil_core::layers::{Layered, LayersConfig};
use stencil_core::pipeline::Made;

use stencil_core::pipeline::Cleaned;
use stencil_core::raster::Gray;

use crate::engine::{fast_png, Computed, Engine, Pixels, RunError};
use crate::params::{shell_quote, OptionSpec, Params};
use crate::Maker;

/// The JSON bodies' bound: a change of options is a few hundred bytes.
const JSON_LIMIT: usize = 64 * 1024;
/// The painted keep-out picture's bound (a PNG of the working image).
const PNG_LIMIT: usize = 32 * 1024 * 1024;
/// How the painted keep-out pictures are named in the output folder (not one of `make`'s
/// outputs): `keep-out-painted-HASH.png`, HASH of the content, so each painting has its own file
/// (undo gives back the earlier painting exactly) and the same painting is one file.
pub const KEEP_OUT_PREFIX: &str = "keep-out-painted";
/// How many changes undo remembers.
const HISTORY: usize = 500;
/// How many encoded images one result keeps (a set of six layers and its fill-in has 36
/// names; the page shows one or two at a time).
const IMAGE_CACHE: usize = 12;
/// How often the input file is looked at for a change on disk.
const INPUT_POLL: Duration = Duration::from_secs(1);
/// How many times a run reads the input again when it changes while being read.
const RELOADS: usize = 3;

/// What `stencil studio` was started with.
pub struct StudioConfig {
    pub input: PathBuf,
    pub out_dir: PathBuf,
    /// Option values given on the command line, as `/api/params` takes them.
    pub initial: Value,
    /// 0: any free port.
    pub port: u16,
}

/// What a run computed: one stencil, through the incremental engine, or a set.
#[derive(Clone)]
enum Shown {
    One(Arc<Computed>),
    Set(Arc<SetRun>),
}

/// A set (`--layers`, `--fill-in`, registration marks for a mask) as `make` computes it, by
/// `stencil_core::layers::run`. Not incremental: each layer's bridges depend on the darker
/// layers' stencils, so a change runs the whole set again, and a newer change waits for it.
struct SetRun {
    cfg: stencil_core::MakeConfig,
    lc: LayersConfig,
    set: Layered,
}

impl SetRun {
    /// The stencils in painting order: the layers, then the fill-in.
    fn stencils(&self) -> Vec<&Made> {
        self.set.layers.iter().chain(&self.set.fill_in).collect()
    }

    /// One of the page's images: `composite` (the painted set, the picture's size), or
    /// `NAME` / `sK-NAME` for stencil K (1-based, in painting order, the fill-in last) with a
    /// NAME as [`Computed::image`] has.
    fn image(&self, name: &str) -> Option<Vec<u8>> {
        if name == "composite" {
            let (w, h) = (self.set.tones.luma.width, self.set.tones.luma.height);
            return Some(fast_png(w, h, &self.set.composite, Pixels::Rgb));
        }
        let (k, what) = match name.strip_prefix('s').and_then(|r| r.split_once('-')) {
            // Canonical numbers only (`s1`, not `s01` or `s+1`): one name per image.
            Some((k, what)) => (
                k.parse::<usize>().ok().filter(|n| n.to_string() == k)?,
                what,
            ),
            None => (1, name),
        };
        let m = *self.stencils().get(k.checked_sub(1)?)?;
        let (w, h) = (m.bridged.bits.width, m.bridged.bits.height);
        let gray = &m.twotone.gray;
        Some(match what {
            "gray" => fast_png(w, h, &gray.to_u8(), Pixels::Gray),
            "twotone" => fast_png(w, h, &m.twotone.bits.to_u8(), Pixels::Gray),
            "stencil" => fast_png(w, h, &m.bridged.bits.to_u8(), Pixels::Gray),
            "picture" => fast_png(w, h, &m.picture.to_u8(), Pixels::Gray),
            "preview" => {
                let rgb = png::preview_rgb(
                    gray,
                    &m.picture,
                    &m.twotone.bits,
                    &m.bridged.bits,
                    &m.dropped_px,
                    1,
                );
                fast_png(w, h, &rgb, Pixels::Rgb)
            }
            _ => return None,
        })
    }
}

/// A state's options as `make` reads them, with the input's stamp when they were read (the
/// picture's size is read for `--crop` and the size in mm).
#[derive(Clone)]
struct Derived {
    stamp: Option<Stamp>,
    cfg: stencil_core::MakeConfig,
    set: Option<LayersConfig>,
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

/// One finished run, as the page sees it.
struct Done {
    version: u64,
    /// The options it was computed from (the command line an export of it shows).
    params: Params,
    /// The input file it was computed from.
    stamp: Option<Stamp>,
    /// Set when this run read the input again because it changed on disk.
    notice: Option<String>,
    outcome: Result<Shown, String>,
    /// Why `make` would write nothing for it, in `make`'s words.
    refused: Option<String>,
    /// The preview only: the trace and the check of this version are still running.
    checking: bool,
    ms: f64,
    /// Encoded images of this run, by canonical name, made on first request; at most
    /// [`IMAGE_CACHE`], the oldest dropped first.
    images: Mutex<Vec<(String, Bytes)>>,
}

impl Done {
    fn cached(&self, name: &str) -> Option<Bytes> {
        let images = self.images.lock().unwrap_or_else(|e| e.into_inner());
        images
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, b)| b.clone())
    }

    fn cache(&self, name: &str, png: &Bytes) {
        let mut images = self.images.lock().unwrap_or_else(|e| e.into_inner());
        if images.iter().any(|(n, _)| n == name) {
            return;
        }
        if images.len() >= IMAGE_CACHE {
            images.remove(0);
        }
        images.push((name.to_string(), png.clone()));
    }
}

struct History {
    states: Vec<Params>,
    at: usize,
    version: u64,
    /// The newest version to compute.
    job: Option<Job>,
    stop: bool,
}

/// The engine's working gray.
type WorkingGray = Arc<Gray>;

/// What the page is sent that depends on one stage's output alone, kept with that output (the
/// `Arc` the engine hands out again for as long as the stage is not re-run): after a change
/// that did not touch the working gray or the clean-up (a bridge weight), the state and the
/// before/after picture are sent without counting or encoding them again.
#[derive(Default)]
struct Reuse {
    histogram: Option<(WorkingGray, Arc<Vec<u64>>)>,
    gray_png: Option<(WorkingGray, Bytes)>,
    picture_png: Option<(Arc<Cleaned>, Bytes)>,
}

/// The running studio, shared by the handlers and the worker.
pub struct Studio {
    reuse: Mutex<Reuse>,
    maker: Arc<dyn Maker>,
    specs: Vec<OptionSpec>,
    input: PathBuf,
    out_dir: PathBuf,
    token: String,
    hosts: Vec<String>,
    history: Mutex<History>,
    /// Held by a change from reading the state to taking the new one, so changes made at once
    /// each build on the one before (none is lost) and the history moves only when a change is
    /// taken.
    edit: Mutex<()>,
    /// One export at a time (two would write the same folder at once).
    exporting: tokio::sync::Mutex<()>,
    wake: Condvar,
    wanted: AtomicU64,
    done: watch::Sender<Arc<Done>>,
    /// Bumped for every new version asked for (the page says "updating").
    asked: watch::Sender<u64>,
    shutdown: watch::Sender<bool>,
}

type Shared = Arc<Studio>;
type ApiResult = Result<Response, (StatusCode, Json<Value>)>;

fn bad(status: StatusCode, msg: impl Into<String>) -> (StatusCode, Json<Value>) {
    (status, Json(json!({ "error": msg.into() })))
}

impl Studio {
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
    fn command(&self, p: &Params) -> String {
        let mut words = vec!["stencil".to_string(), "make".to_string()];
        words.extend(self.args(p).iter().map(|w| shell_quote(w)));
        words.join(" ")
    }

    /// `p` as `make` reads it (or the message `make` fails with), with the input's stamp from
    /// before it was read.
    fn derive(&self, p: &Params) -> Result<Derived, String> {
        let stamp = stamp(&self.input);
        let args = self.args(p);
        let cfg = self.maker.config(&args)?;
        let set = self.maker.set(&args)?;
        Ok(Derived { stamp, cfg, set })
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

    /// Take `change(current state)` as the new state, after `make`'s own checks, remembered for
    /// undo; returns its version. A refused change leaves everything as it was.
    fn push(
        &self,
        change: impl FnOnce(&Params) -> Result<Params, (StatusCode, Json<Value>)>,
    ) -> Result<u64, (StatusCode, Json<Value>)> {
        let _edit = self.edit.lock().unwrap_or_else(|e| e.into_inner());
        let (cur, ..) = self.current();
        let p = change(&cur)?;
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
    fn step(&self, d: isize) -> Result<u64, (StatusCode, Json<Value>)> {
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
    fn rerun(&self) {
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
    async fn watch_input(self: Arc<Self>) {
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
    async fn wait_for(&self, v: u64) -> Arc<Done> {
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

    /// `GET /api/state`'s body.
    fn state(&self, done: &Done) -> Value {
        let (params, wanted, can_undo, can_redo) = self.current();
        let mut s = json!({
            "version": wanted,
            "shown": done.version,
            "updating": done.version < wanted,
            // The preview is this version's; the trace and the check are still running.
            "checking": done.checking,
            "params": params.to_json(&self.specs),
            "command": self.command(&params),
            "can_undo": can_undo,
            "can_redo": can_redo,
            "ms": done.ms,
            // The input changed on disk and was read again for this result.
            "notice": done.notice,
        });
        match &done.outcome {
            Err(e) => s["error"] = json!(e),
            Ok(Shown::Set(set)) => {
                // The page shows one stencil of the set at a time (`layer_reports[k]`; `report`
                // is the first) or the composite.
                let stencils = set.stencils();
                let reports: Vec<Value> = stencils
                    .iter()
                    .map(|m| serde_json::to_value(&m.report).unwrap_or(Value::Null))
                    .collect();
                let first = stencils[0];
                let luma = &set.set.tones.luma;
                s["set"] = serde_json::to_value(&set.set.report).unwrap_or(Value::Null);
                s["report"] = reports[0].clone();
                s["layer_reports"] = json!(reports);
                s["histogram"] = json!(histogram(luma));
                s["mm_per_px"] = json!(first.scale.mm_per_px);
                s["width_px"] = json!(first.report.width_px);
                s["height_px"] = json!(first.report.height_px);
                s["composite_px"] = json!([luma.width, luma.height]);
            }
            Ok(Shown::One(c)) => {
                let r = &c.report;
                s["report"] = serde_json::to_value(r).unwrap_or(Value::Null);
                s["refused"] = json!(done.refused);
                s["ran"] = json!(c.ran);
                s["otsu"] = json!(c.otsu);
                s["histogram"] = json!(*self.histogram_of(&c.gray));
                s["mm_per_px"] = json!(c.params.working.scale.mm_per_px);
                s["width_px"] = json!(r.width_px);
                s["height_px"] = json!(r.height_px);
            }
        }
        s
    }
}

impl Studio {
    /// The working gray's histogram, counted once per gray.
    fn histogram_of(&self, gray: &WorkingGray) -> Arc<Vec<u64>> {
        let mut r = self.reuse.lock().unwrap_or_else(|e| e.into_inner());
        match &r.histogram {
            Some((g, h)) if Arc::ptr_eq(g, gray) => h.clone(),
            _ => {
                let h = Arc::new(histogram(gray));
                r.histogram = Some((gray.clone(), h.clone()));
                h
            }
        }
    }

    /// The `gray` or `picture` PNG of `c` when it was made for the same stage output before.
    fn kept_png(&self, c: &Computed, name: &str) -> Option<Bytes> {
        let r = self.reuse.lock().unwrap_or_else(|e| e.into_inner());
        match name {
            "gray" => r
                .gray_png
                .as_ref()
                .filter(|(g, _)| Arc::ptr_eq(g, &c.gray))
                .map(|(_, b)| b.clone()),
            "picture" => r
                .picture_png
                .as_ref()
                .filter(|(k, _)| Arc::ptr_eq(k, &c.cleaned))
                .map(|(_, b)| b.clone()),
            _ => None,
        }
    }

    /// Keep `png` when it is the `gray` or `picture` of `c` (see [`Studio::kept_png`]).
    fn keep_png(&self, c: &Computed, name: &str, png: &Bytes) {
        let mut r = self.reuse.lock().unwrap_or_else(|e| e.into_inner());
        match name {
            "gray" => r.gray_png = Some((c.gray.clone(), png.clone())),
            "picture" => r.picture_png = Some((c.cleaned.clone(), png.clone())),
            _ => {}
        }
    }
}

/// Pixels per gray level (0..255) of the working gray.
fn histogram(g: &stencil_core::raster::Gray) -> Vec<u64> {
    let mut h = vec![0u64; 256];
    for &v in &g.data {
        h[(v.clamp(0.0, 1.0) * 255.0).round() as usize] += 1;
    }
    h
}

// ---- guards -----------------------------------------------------------------------------------

async fn guard(State(s): State<Shared>, req: Request, next: Next) -> Response {
    let headers = req.headers();
    let host = headers
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .unwrap_or("");
    if !s.hosts.iter().any(|h| h == host) {
        return (
            StatusCode::FORBIDDEN,
            "wrong Host: this server answers only to its own address",
        )
            .into_response();
    }
    if let Some(origin) = headers.get(header::ORIGIN) {
        let ok = origin
            .to_str()
            .ok()
            .and_then(|o| o.strip_prefix("http://"))
            .is_some_and(|o| s.hosts.iter().any(|h| h == o));
        if !ok {
            return (
                StatusCode::FORBIDDEN,
                "wrong Origin: this server answers only to its own page",
            )
                .into_response();
        }
    }
    let bearer = headers
        .get(header::AUTHORIZATION)
        .and_then(|h| h.to_str().ok())
        .and_then(|h| h.strip_prefix("Bearer "));
    let query = req.uri().query().unwrap_or("");
    let in_query = query
        .split('&')
        .filter_map(|kv| kv.strip_prefix("token="))
        .next();
    let given = bearer.or(in_query).unwrap_or("");
    if !same(given.as_bytes(), s.token.as_bytes()) {
        return (
            StatusCode::UNAUTHORIZED,
            "missing or wrong token: open the URL the studio printed",
        )
            .into_response();
    }
    next.run(req).await
}

/// Equal, in a time that does not depend on where they first differ.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

// ---- handlers ---------------------------------------------------------------------------------

const PAGE: &str = include_str!("assets/index.html");
const SCRIPT: &str = include_str!("assets/app.js");
const STYLE: &str = include_str!("assets/app.css");

async fn page() -> Response {
    let html = PAGE
        .replace("/*STYLE*/", STYLE)
        .replace("/*SCRIPT*/", SCRIPT);
    (
        [(
            header::CONTENT_SECURITY_POLICY,
            "default-src 'self'; img-src 'self' blob: data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'; connect-src 'self'",
        )],
        Html(html),
    )
        .into_response()
}

#[derive(serde::Deserialize)]
struct WaitQuery {
    wait: Option<u8>,
}

async fn get_state(State(s): State<Shared>, Query(q): Query<WaitQuery>) -> ApiResult {
    let done = if q.wait.unwrap_or(0) != 0 {
        let v = s.wanted.load(Ordering::SeqCst);
        s.wait_for(v).await
    } else {
        s.done.borrow().clone()
    };
    Ok(Json(s.state(&done)).into_response())
}

async fn get_options(State(s): State<Shared>) -> ApiResult {
    Ok(Json(json!({ "options": s.specs, "input": s.input.display().to_string(), "out": s.out_dir.display().to_string() })).into_response())
}

/// Answer with the state once version `v` (or a newer one) is computed.
async fn answer(s: &Shared, v: u64) -> ApiResult {
    let done = s.wait_for(v).await;
    Ok(Json(s.state(&done)).into_response())
}

async fn post_params(State(s): State<Shared>, body: Bytes) -> ApiResult {
    let changes: Value = serde_json::from_slice(&body).map_err(|e| {
        bad(
            StatusCode::BAD_REQUEST,
            format!("the body is not JSON: {e}"),
        )
    })?;
    let v = s.push(|cur| {
        cur.with(&s.specs, &changes)
            .map_err(|e| bad(StatusCode::BAD_REQUEST, e.to_string()))
    })?;
    answer(&s, v).await
}

/// `POST /api/bridges`: `{"delete": N}` (the bridge at index N of the report's `bridges`, kept
/// away by a `no-bridge-near` disc covering it) or `{"pin": [X, Y]}` (a `bridge-at` place, mm).
async fn post_bridges(State(s): State<Shared>, body: Bytes) -> ApiResult {
    let req: Value = serde_json::from_slice(&body).map_err(|e| {
        bad(
            StatusCode::BAD_REQUEST,
            format!("the body is not JSON: {e}"),
        )
    })?;
    let (name, value) = if let Some(n) = req.get("delete").and_then(Value::as_u64) {
        let done = s.done.borrow().clone();
        let c = match &done.outcome {
            Ok(Shown::One(c)) => c,
            Ok(Shown::Set(_)) => {
                return Err(bad(
                    StatusCode::CONFLICT,
                    "a set's bridges are chosen per layer; keep them away with no-bridge-near \
                     discs (Bridges), which every layer obeys",
                ))
            }
            Err(_) => {
                return Err(bad(
                    StatusCode::CONFLICT,
                    "no stencil to delete a bridge from",
                ))
            }
        };
        let bridges = &c.joined.bridged.bridges;
        let b = bridges.get(n as usize).ok_or_else(|| {
            bad(
                StatusCode::BAD_REQUEST,
                format!("there is no bridge {n} (there are {})", bridges.len()),
            )
        })?;
        let mm = c.params.working.scale.mm_per_px;
        let pts = &b.polygon;
        let k = pts.len().max(1) as f64;
        let (cx, cy) = (
            pts.iter().map(|p| p[0]).sum::<f64>() / k,
            pts.iter().map(|p| p[1]).sum::<f64>() / k,
        );
        // Pixel centres are at +0.5; the disc covers the bridge's outline and half a pixel more.
        let r = pts
            .iter()
            .map(|p| (p[0] - cx).hypot(p[1] - cy))
            .fold(0.0, f64::max)
            + 1.0;
        (
            "no-bridge-near",
            format!(
                "{:.3},{:.3},{:.3}",
                (cx + 0.5) * mm,
                (cy + 0.5) * mm,
                r * mm
            ),
        )
    } else if let Some([x, y]) = req
        .get("pin")
        .and_then(|v| serde_json::from_value::<[f64; 2]>(v.clone()).ok())
    {
        ("bridge-at", format!("{x:.3},{y:.3}"))
    } else {
        return Err(bad(
            StatusCode::BAD_REQUEST,
            "the body must be {\"delete\": N} or {\"pin\": [X, Y]} (mm)",
        ));
    };
    let v = s.push(|cur| {
        let mut list = cur.get(name).to_vec();
        list.push(value);
        cur.with(&s.specs, &json!({ name: list }))
            .map_err(|e| bad(StatusCode::BAD_REQUEST, e.to_string()))
    })?;
    answer(&s, v).await
}

async fn post_undo(State(s): State<Shared>) -> ApiResult {
    step_history(&s, -1).await
}

async fn post_redo(State(s): State<Shared>) -> ApiResult {
    step_history(&s, 1).await
}

async fn step_history(s: &Shared, d: isize) -> ApiResult {
    let v = s.step(d)?;
    answer(s, v).await
}

/// `POST /api/keepout`: a PNG (dark = no bridge), saved in the output folder under a name of
/// its own (see [`KEEP_OUT_PREFIX`]) and used as the `keep-out` picture; an empty body clears
/// it.
async fn post_keepout(State(s): State<Shared>, body: Bytes) -> ApiResult {
    let value = if body.is_empty() {
        String::new()
    } else {
        if !body.starts_with(b"\x89PNG\r\n\x1a\n") {
            return Err(bad(
                StatusCode::BAD_REQUEST,
                "the keep-out picture must be a PNG",
            ));
        }
        let s2 = s.clone();
        tokio::task::spawn_blocking(move || save_painting(&s2.out_dir, &body))
            .await
            .map_err(|e| bad(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))?
            .map_err(|e| bad(StatusCode::INTERNAL_SERVER_ERROR, e))?
            .display()
            .to_string()
    };
    let v = s.push(|cur| {
        cur.with(&s.specs, &json!({ "keep-out": value }))
            .map_err(|e| bad(StatusCode::BAD_REQUEST, e.to_string()))
    })?;
    answer(&s, v).await
}

/// Save a painted keep-out picture in `dir` as `keep-out-painted-HASH.png` (FNV-1a of its
/// bytes): the same painting is the same file; a file of that name with other bytes (another
/// program's, or a hash collision) is never overwritten, the next free `-2`, `-3`... is used.
fn save_painting(dir: &Path, png: &[u8]) -> Result<PathBuf, String> {
    let hash = png.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for k in 1..=100 {
        let name = match k {
            1 => format!("{KEEP_OUT_PREFIX}-{hash:016x}.png"),
            _ => format!("{KEEP_OUT_PREFIX}-{hash:016x}-{k}.png"),
        };
        let path = dir.join(name);
        match std::fs::read(&path) {
            Ok(old) if old == png => return Ok(path),
            Ok(_) => continue,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                stencil_io::write_atomic(&path, png)
                    .map_err(|e| format!("{}: {e}", path.display()))?;
                return Ok(path);
            }
            Err(e) => return Err(format!("{}: {e}", path.display())),
        }
    }
    Err(format!(
        "{}: 100 files named {KEEP_OUT_PREFIX}-{hash:016x}*.png hold other pictures; move them away",
        dir.display()
    ))
}

/// `POST /api/export`: what `make` writes, into the output folder, by `make`'s writer.
///
/// One version: the newest computed result is taken once, and the files written and the
/// command line answered are both of it (a change made meanwhile is the next export's).
async fn post_export(State(s): State<Shared>) -> ApiResult {
    let _one = s.exporting.lock().await;
    let v = s.wanted.load(Ordering::SeqCst);
    let done = s.wait_for(v).await;
    let shown = match &done.outcome {
        Ok(c) => c.clone(),
        Err(e) => return Err(bad(StatusCode::CONFLICT, e.clone())),
    };
    let input_changed = || {
        bad(
            StatusCode::CONFLICT,
            format!(
                "{} changed on disk since the result shown was computed: the studio is \
                 computing it again from the new file; look at it, then export again",
                s.input.display()
            ),
        )
    };
    if stamp(&s.input) != done.stamp {
        s.rerun();
        return Err(input_changed());
    }
    let command = s.command(&done.params);
    let rereads = matches!(shown, Shown::Set(_));
    let s2 = s.clone();
    let written = tokio::task::spawn_blocking(move || match shown {
        Shown::One(c) => {
            let made = c.made().map_err(|e| s2.maker.describe(&c.cfg, e))?;
            stencil_core::pipeline::write(&c.cfg, made)
                .map(|(_, r)| r)
                .map_err(|e| s2.maker.describe(&c.cfg, e))
        }
        // `make`'s own set writer: it runs the set again (a set is not kept stage by stage).
        Shown::Set(set) => stencil_core::layers::make(&set.cfg, &set.lc)
            .map(|(_, r)| r)
            .map_err(|e| s2.maker.describe(&set.cfg, e)),
    })
    .await
    .map_err(|e| bad(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))?
    .map_err(|e| bad(StatusCode::CONFLICT, e))?;
    // A set's writer read the input again: it must have read the same file.
    if rereads && stamp(&s.input) != done.stamp {
        s.rerun();
        return Err(input_changed());
    }
    // Names in the output folder (a set's files are in its layer folders).
    let names = |v: &[PathBuf]| -> Vec<String> {
        v.iter()
            .map(|p| {
                p.strip_prefix(&s.out_dir)
                    .unwrap_or(p)
                    .display()
                    .to_string()
            })
            .collect()
    };
    Ok(Json(json!({
        "dir": s.out_dir.display().to_string(),
        "files": names(&written.written),
        "removed": names(&written.removed),
        "command": command,
        "version": done.version,
    }))
    .into_response())
}

async fn get_image(State(s): State<Shared>, UrlPath(file): UrlPath<String>) -> ApiResult {
    let name = file
        .strip_suffix(".png")
        .ok_or_else(|| bad(StatusCode::NOT_FOUND, "images are NAME.png"))?;
    let done = s.done.borrow().clone();
    let Ok(shown) = &done.outcome else {
        return Err(bad(StatusCode::CONFLICT, "no stencil yet"));
    };
    let cached = done.cached(name);
    let kept = match (&cached, shown) {
        (None, Shown::One(c)) => s.kept_png(c, name),
        _ => None,
    };
    let png = match cached.or(kept) {
        Some(p) => p,
        None => {
            let run = shown.clone();
            let n = name.to_string();
            let p = tokio::task::spawn_blocking(move || {
                match run {
                    Shown::One(c) => c.image(&n),
                    Shown::Set(set) => set.image(&n),
                }
                .map(Bytes::from)
            })
            .await
            .ok()
            .flatten()
            .ok_or_else(|| {
                bad(
                    StatusCode::NOT_FOUND,
                    format!(
                        "no image {name}: gray, twotone, stencil, preview, picture (of a \
                             set: sK-NAME for stencil K, K as 1, 2, ..., and composite)"
                    ),
                )
            })?;
            if let Shown::One(c) = shown {
                s.keep_png(c, name, &p);
            }
            p
        }
    };
    done.cache(name, &png);
    let mut headers = HeaderMap::new();
    headers.insert(
        header::CONTENT_TYPE,
        "image/png"
            .parse()
            .unwrap_or(header::HeaderValue::from_static("image/png")),
    );
    headers.insert(
        header::CACHE_CONTROL,
        header::HeaderValue::from_static("no-store"),
    );
    if let Ok(v) = done.version.to_string().parse() {
        headers.insert("x-stencil-version", v);
    }
    Ok((headers, png).into_response())
}

/// `GET /api/events`: `asked` (a change is being computed: show "updating") and `done`
/// (version N is ready: fetch the state and images), as server-sent events.
async fn events(State(s): State<Shared>) -> impl IntoResponse {
    let asked = s.asked.subscribe();
    let done = s.done.subscribe();
    let stop = s.shutdown.subscribe();
    let stream = futures_util::stream::unfold(
        (asked, done, stop, true),
        |(mut asked, mut done, mut stop, first)| async move {
            if first {
                let v = done.borrow_and_update().version;
                let ev = Event::default().event("done").data(v.to_string());
                return Some((
                    Ok::<_, std::convert::Infallible>(ev),
                    (asked, done, stop, false),
                ));
            }
            let ev = tokio::select! {
                r = asked.changed() => { r.ok()?; Event::default().event("asked").data(asked.borrow_and_update().to_string()) }
                r = done.changed() => { r.ok()?; Event::default().event("done").data(done.borrow_and_update().version.to_string()) }
                _ = stop.wait_for(|s| *s) => return None,
            };
            Some((Ok(ev), (asked, done, stop, false)))
        },
    );
    Sse::new(stream).keep_alive(KeepAlive::default())
}

/// A random token (128 bits, hex) from the system's generator.
fn token() -> std::io::Result<String> {
    let mut b = [0u8; 16];
    getrandom::fill(&mut b).map_err(|e| std::io::Error::other(e.to_string()))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

/// Serve the studio until Ctrl-C. `ready` gets the URL (with the token) once the server listens;
/// the initial options are checked as `make` checks them first (an error returns before
/// anything listens).
pub fn serve(
    maker: Arc<dyn Maker>,
    cfg: StudioConfig,
    ready: impl FnOnce(&str),
) -> Result<(), String> {
    let specs = maker.options();
    let initial = Params::defaults(&specs)
        .with(&specs, &cfg.initial)
        .map_err(|e| e.to_string())?;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| e.to_string())?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(SocketAddr::from(([127, 0, 0, 1], cfg.port)))
            .await
            .map_err(|e| format!("cannot listen on 127.0.0.1:{}: {e}", cfg.port))?;
        let port = listener.local_addr().map_err(|e| e.to_string())?.port();
        let studio = Arc::new(Studio {
            reuse: Mutex::new(Reuse::default()),
            maker,
            specs,
            input: cfg.input,
            out_dir: cfg.out_dir,
            token: token().map_err(|e| format!("no random token: {e}"))?,
            hosts: vec![format!("127.0.0.1:{port}"), format!("localhost:{port}")],
            history: Mutex::new(History {
                states: vec![initial.clone()],
                at: 0,
                version: 0,
                job: None,
                stop: false,
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
        // The first run: its options are checked now, so a bad one stops the studio at once.
        let derived = studio.derive(&initial)?;
        {
            let mut h = studio.history.lock().unwrap_or_else(|e| e.into_inner());
            studio.queue(&mut h, initial, Some(derived));
        }
        let worker = {
            let s = studio.clone();
            std::thread::spawn(move || s.work())
        };
        let api = Router::new()
            .route("/", get(page))
            .route("/api/options", get(get_options))
            .route("/api/state", get(get_state))
            .route("/api/params", post(post_params))
            .route("/api/bridges", post(post_bridges))
            .route("/api/undo", post(post_undo))
            .route("/api/redo", post(post_redo))
            .route("/api/export", post(post_export))
            .route("/api/image/{file}", get(get_image))
            .route("/api/events", get(events))
            .layer(DefaultBodyLimit::max(JSON_LIMIT))
            .route(
                "/api/keepout",
                post(post_keepout).layer(DefaultBodyLimit::max(PNG_LIMIT)),
            )
            .layer(middleware::from_fn_with_state(studio.clone(), guard))
            .with_state(studio.clone());
        ready(&format!("http://127.0.0.1:{port}/?token={}", studio.token));
        tokio::spawn(studio.clone().watch_input());
        let stop = studio.clone();
        tokio::spawn(async move {
            let _ = tokio::signal::ctrl_c().await;
            stop.shutdown.send_replace(true);
        });
        crate::conn::serve(
            listener,
            api,
            crate::conn::connection_cap(),
            studio.shutdown.subscribe(),
        )
        .await;
        {
            let mut h = studio.history.lock().unwrap_or_else(|e| e.into_inner());
            h.stop = true;
            studio.wanted.store(u64::MAX, Ordering::SeqCst);
            studio.wake.notify_all();
        }
        let _ = worker.join();
        Ok(())
    })
}
