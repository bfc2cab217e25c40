//! The HTTP side: one page, a JSON API, server-sent events, and the worker thread that runs the
//! engine.
//!
//! Safety of a local server: it listens on 127.0.0.1 only; every request must carry the random
//! token the printed URL holds (query `token=` or `Authorization: Bearer`); a request whose
//! `Host` or `Origin` is not this server's own is refused (a web page elsewhere cannot reach it
//! through DNS rebinding); bodies are bounded; the only files it writes are `make`'s outputs and
//! the painted keep-out picture, in the output folder.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Instant;

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
/// The painted keep-out picture's name in the output folder (not one of `make`'s outputs).
pub const KEEP_OUT_NAME: &str = "keep-out-painted.png";
/// How many changes undo remembers.
const HISTORY: usize = 500;

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
            Some((k, what)) => (k.parse::<usize>().ok()?, what),
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

/// One finished run, as the page sees it.
struct Done {
    version: u64,
    outcome: Result<Shown, String>,
    /// Why `make` would write nothing for it, in `make`'s words.
    refused: Option<String>,
    /// The preview only: the trace and the check of this version are still running.
    checking: bool,
    ms: f64,
    /// Encoded images of this run, by name, made on first request.
    images: Mutex<HashMap<String, Bytes>>,
}

struct History {
    states: Vec<Params>,
    at: usize,
    version: u64,
    /// The newest change to compute: its version, configuration and set (if one).
    job: Option<(u64, stencil_core::MakeConfig, Option<LayersConfig>)>,
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

    /// Take `p` as the new state (after `make`'s own checks), remembered for undo unless
    /// `push` is false; returns its version.
    fn apply(&self, p: Params, push: bool) -> Result<u64, (StatusCode, Json<Value>)> {
        let args = self.args(&p);
        let cfg = self
            .maker
            .config(&args)
            .map_err(|m| bad(StatusCode::BAD_REQUEST, m))?;
        let set = self
            .maker
            .set(&args)
            .map_err(|m| bad(StatusCode::BAD_REQUEST, m))?;
        let mut h = self.history.lock().unwrap_or_else(|e| e.into_inner());
        if push {
            let at = h.at;
            h.states.truncate(at + 1);
            h.states.push(p);
            if h.states.len() > HISTORY {
                h.states.remove(0);
            }
            h.at = h.states.len() - 1;
        }
        h.version += 1;
        let v = h.version;
        h.job = Some((v, cfg, set));
        self.wanted.store(v, Ordering::SeqCst);
        self.wake.notify_all();
        drop(h);
        self.asked.send_replace(v);
        Ok(v)
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
        loop {
            let (v, cfg, set) = {
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
            let t0 = Instant::now();
            let superseded = || self.wanted.load(Ordering::SeqCst) != v;
            let publish = |outcome, refused, checking| {
                self.done.send_replace(Arc::new(Done {
                    version: v,
                    outcome,
                    refused,
                    checking,
                    ms: t0.elapsed().as_secs_f64() * 1e3,
                    images: Mutex::new(HashMap::new()),
                }));
            };
            // A set (layers, fill-in) is made whole by `make`'s own layer code.
            if let Some(lc) = set {
                let outcome = match stencil_core::layers::run(&cfg, &lc) {
                    Ok(set) => Ok(Shown::Set(Arc::new(SetRun { cfg, lc, set }))),
                    Err(e) => Err(self.maker.describe(&cfg, e)),
                };
                publish(outcome, None, false);
                continue;
            }
            // One stencil: the preview first (up to the bridges), then the trace and the
            // check, shown as they arrive: the page says "checking" in between.
            let preview = match engine.preview(&cfg, &superseded) {
                Err(RunError::Cancelled) => continue,
                Err(RunError::Core(e)) => {
                    publish(Err(self.maker.describe(&cfg, e)), None, false);
                    continue;
                }
                Ok(c) => Arc::new(c),
            };
            publish(Ok(Shown::One(preview.clone())), None, true);
            match engine.check(&preview, &superseded) {
                Err(RunError::Cancelled) => continue,
                Err(RunError::Core(e)) => publish(Err(self.maker.describe(&cfg, e)), None, false),
                Ok(mut c) => {
                    let refused = c.refused.take().map(|e| self.maker.describe(&cfg, e));
                    publish(Ok(Shown::One(Arc::new(c))), refused, false);
                }
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

/// Apply a change and answer with the state once it (or a newer change) is computed.
async fn change(s: &Shared, p: Params) -> ApiResult {
    let v = s.apply(p, true)?;
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
    let (cur, ..) = s.current();
    let p = cur
        .with(&s.specs, &changes)
        .map_err(|e| bad(StatusCode::BAD_REQUEST, e.to_string()))?;
    change(&s, p).await
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
    let (cur, ..) = s.current();
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
    let mut list = cur.get(name).to_vec();
    list.push(value);
    let p = cur
        .with(&s.specs, &json!({ name: list }))
        .map_err(|e| bad(StatusCode::BAD_REQUEST, e.to_string()))?;
    change(&s, p).await
}

async fn post_undo(State(s): State<Shared>) -> ApiResult {
    step_history(&s, -1).await
}

async fn post_redo(State(s): State<Shared>) -> ApiResult {
    step_history(&s, 1).await
}

async fn step_history(s: &Shared, d: isize) -> ApiResult {
    let p = {
        let mut h = s.history.lock().unwrap_or_else(|e| e.into_inner());
        let to = h.at as isize + d;
        if to < 0 || to as usize >= h.states.len() {
            return Err(bad(StatusCode::CONFLICT, "nothing to undo or redo"));
        }
        h.at = to as usize;
        h.states[h.at].clone()
    };
    let v = s.apply(p, false)?;
    let done = s.wait_for(v).await;
    Ok(Json(s.state(&done)).into_response())
}

/// `POST /api/keepout`: a PNG (dark = no bridge), saved in the output folder and used as the
/// `keep-out` picture; an empty body clears it.
async fn post_keepout(State(s): State<Shared>, body: Bytes) -> ApiResult {
    let (cur, ..) = s.current();
    let value = if body.is_empty() {
        String::new()
    } else {
        if !body.starts_with(b"\x89PNG\r\n\x1a\n") {
            return Err(bad(
                StatusCode::BAD_REQUEST,
                "the keep-out picture must be a PNG",
            ));
        }
        let path = s.out_dir.join(KEEP_OUT_NAME);
        std::fs::create_dir_all(&s.out_dir).map_err(|e| {
            bad(
                StatusCode::INTERNAL_SERVER_ERROR,
                format!("{}: {e}", s.out_dir.display()),
            )
        })?;
        stencil_io::write_atomic(&path, &body).map_err(|e| {
            bad(
                StatusCode::INTERNAL_SERVER_ERROR,
                format!("{}: {e}", path.display()),
            )
        })?;
        path.display().to_string()
    };
    let p = cur
        .with(&s.specs, &json!({ "keep-out": value }))
        .map_err(|e| bad(StatusCode::BAD_REQUEST, e.to_string()))?;
    change(&s, p).await
}

/// `POST /api/export`: what `make` writes, into the output folder, by `make`'s writer.
async fn post_export(State(s): State<Shared>) -> ApiResult {
    let v = s.wanted.load(Ordering::SeqCst);
    let done = s.wait_for(v).await;
    let shown = match &done.outcome {
        Ok(c) => c.clone(),
        Err(e) => return Err(bad(StatusCode::CONFLICT, e.clone())),
    };
    let (params, ..) = s.current();
    let command = s.command(&params);
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
    let cached = done
        .images
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .get(name)
        .cloned();
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
                             set: sK-NAME for stencil K, and composite)"
                    ),
                )
            })?;
            if let Shown::One(c) = shown {
                s.keep_png(c, name, &p);
            }
            p
        }
    };
    done.images
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .entry(name.to_string())
        .or_insert_with(|| png.clone());
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
            wake: Condvar::new(),
            wanted: AtomicU64::new(0),
            done: watch::Sender::new(Arc::new(Done {
                version: 0,
                outcome: Err("starting".into()),
                refused: None,
                checking: false,
                ms: 0.0,
                images: Mutex::new(HashMap::new()),
            })),
            asked: watch::Sender::new(0),
            shutdown: watch::Sender::new(false),
        });
        // The first run: its options are checked now, so a bad one stops the studio at once.
        studio
            .apply(initial, false)
            .map_err(|(_, Json(e))| e["error"].as_str().unwrap_or("bad option").to_string())?;
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
        let stop = studio.clone();
        let served = axum::serve(listener, api)
            .with_graceful_shutdown(async move {
                let _ = tokio::signal::ctrl_c().await;
                stop.shutdown.send_replace(true);
            })
            .await;
        {
            let mut h = studio.history.lock().unwrap_or_else(|e| e.into_inner());
            h.stop = true;
            studio.wanted.store(u64::MAX, Ordering::SeqCst);
            studio.wake.notify_all();
        }
        let _ = worker.join();
        served.map_err(|e| e.to_string())
    })
}
