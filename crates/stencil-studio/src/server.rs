//! The HTTP side ([`serve`]): one page, the JSON API's handlers, server-sent events, and the
//! guards every request passes.
//!
//! Safety of a local server: it listens on 127.0.0.1 only; every request must carry the random
//! token the printed URL holds (query `token=` or `Authorization: Bearer`); a request whose
//! `Host` or `Origin` is not this server's own is refused (a web page elsewhere cannot reach it
//! through DNS rebinding); bodies are bounded; connections are bounded and must send their
//! headers in time (conn.rs); the only files it writes are `make`'s outputs and the
//! painted keep-out pictures, in the output folder.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::{DefaultBodyLimit, Path as UrlPath, Query, Request, State};
use axum::http::{header, StatusCode};
use axum::middleware::{self, Next};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde_json::{json, Value};

use crate::maker::Maker;
use crate::outcome::Shown;
use crate::params::Params;
use crate::state::{bad, Exported, Options, Refusal};
use crate::studio::{Studio, StudioConfig};
use stencil_core::stamp;

/// The JSON bodies' bound: a change of options is a few hundred bytes.
const JSON_LIMIT: usize = 64 * 1024;
/// The painted keep-out picture's bound (a PNG of the working image).
const PNG_LIMIT: usize = 32 * 1024 * 1024;
/// How the painted keep-out pictures are named in the output folder (not one of `make`'s
/// outputs): `keep-out-painted-HASH.png`, HASH of the content, so each painting has its own file
/// (undo gives back the earlier painting exactly) and the same painting is one file.
pub const KEEP_OUT_PREFIX: &str = "keep-out-painted";
/// Why a set's bridges cannot be deleted one by one.
const SET_BRIDGES: &str = "a set's or tiles' bridges are chosen per stencil; keep them away \
                           with no-bridge-near discs (Bridges), which every stencil obeys";
type Shared = Arc<Studio>;
type ApiResult = Result<Response, Refusal>;

// ---- guards -----------------------------------------------------------------------------------

async fn guard(State(s): State<Shared>, req: Request, next: Next) -> Response {
    let headers = req.headers();
    let text = |name| headers.get(name).and_then(|h| h.to_str().ok());
    let ours = |host: &str| s.hosts.iter().any(|h| h == host);
    // An Origin that is there but not text is not this page's.
    let origin_ok = (headers.get(header::ORIGIN)).is_none_or(|o| {
        (o.to_str().ok())
            .and_then(|o| o.strip_prefix("http://"))
            .is_some_and(ours)
    });
    let bearer = text(header::AUTHORIZATION).and_then(|h| h.strip_prefix("Bearer "));
    let query = req.uri().query().unwrap_or("");
    let in_query = query
        .split('&')
        .filter_map(|kv| kv.strip_prefix("token="))
        .next();
    let given = bearer.or(in_query).unwrap_or("");
    let refused = if !ours(text(header::HOST).unwrap_or("")) {
        (
            StatusCode::FORBIDDEN,
            "wrong Host: this server answers only to its own address",
        )
    } else if !origin_ok {
        (
            StatusCode::FORBIDDEN,
            "wrong Origin: this server answers only to its own page",
        )
    } else if !same(given.as_bytes(), s.token.as_bytes()) {
        (
            StatusCode::UNAUTHORIZED,
            "missing or wrong token: open the URL the studio printed",
        )
    } else {
        return next.run(req).await;
    };
    refused.into_response()
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
    if q.wait.unwrap_or(0) != 0 {
        return answer(&s, s.wanted.load(Ordering::SeqCst)).await;
    }
    Ok(Json(s.state(&s.done.borrow().clone())).into_response())
}

async fn get_options(State(s): State<Shared>) -> ApiResult {
    let options = Options {
        options: &s.specs,
        input: s.input.display().to_string(),
        out: s.out_dir.display().to_string(),
    };
    Ok(Json(options).into_response())
}

/// Answer with the state once version `v` (or a newer one) is computed.
async fn answer(s: &Shared, v: u64) -> ApiResult {
    let done = s.wait_for(v).await;
    Ok(Json(s.state(&done)).into_response())
}

fn json_body(body: &[u8]) -> Result<Value, Refusal> {
    serde_json::from_slice(body).map_err(|e| {
        bad(
            StatusCode::BAD_REQUEST,
            format!("the body is not JSON: {e}"),
        )
    })
}

async fn post_params(State(s): State<Shared>, body: Bytes) -> ApiResult {
    let changes = json_body(&body)?;
    let v = s.push(|_| changes)?;
    answer(&s, v).await
}

/// `POST /api/bridges`: `{"delete": N}` (the bridge at index N of the report's `bridges`, kept
/// away by a `no-bridge-near` disc covering it) or `{"pin": [X, Y]}` (a `bridge-at` place, mm).
async fn post_bridges(State(s): State<Shared>, body: Bytes) -> ApiResult {
    let req = json_body(&body)?;
    let (name, value) = if let Some(n) = req.get("delete").and_then(Value::as_u64) {
        let done = s.done.borrow().clone();
        let c = match &done.outcome {
            Ok(Shown::One(c)) => c,
            Ok(Shown::Set(_) | Shown::Tiles(_)) => {
                return Err(bad(StatusCode::CONFLICT, SET_BRIDGES))
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
        json!({ name: list })
    })?;
    answer(&s, v).await
}

/// `POST /api/undo` (`d` = -1) and `/api/redo` (+1).
async fn step_history(State(s): State<Shared>, d: isize) -> ApiResult {
    let v = s.step(d)?;
    answer(&s, v).await
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
    let v = s.push(|_| json!({ "keep-out": value }))?;
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
    let rereads = matches!(shown, Shown::Set(_) | Shown::Tiles(_));
    let s2 = s.clone();
    let written = tokio::task::spawn_blocking(move || match shown {
        Shown::One(c) => {
            let made = c.made().map_err(|e| s2.maker.describe(&c.cfg, e))?;
            stencil_core::driver::write(&c.cfg, made)
                .map(|(_, r)| r)
                .map_err(|e| s2.maker.describe(&c.cfg, e))
        }
        // `make`'s own set writer: it runs the set again (a set is not kept stage by stage).
        Shown::Set(set) => stencil_core::layers::make(&set.cfg, &set.lc)
            .map(|(_, r)| r)
            .map_err(|e| s2.maker.describe(&set.cfg, e)),
        // `make`'s own tiles writer: it runs the tiling again, as a set's.
        Shown::Tiles(t) => stencil_core::tiles::make(&t.cfg, &t.tc)
            .map(|(_, r)| r)
            .map_err(|e| s2.maker.describe(&t.cfg, e)),
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
    Ok(Json(Exported {
        dir: s.out_dir.display().to_string(),
        files: names(&written.written),
        removed: names(&written.removed),
        command,
        version: done.version,
    })
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
        (None, Shown::One(c)) => s.reuse.kept_png(c, name),
        _ => None,
    };
    let png = match cached.or(kept) {
        Some(p) => p,
        None => {
            let run = shown.clone();
            let n = name.to_string();
            let p = tokio::task::spawn_blocking(move || run.image(&n).map(Bytes::from))
                .await
                .ok()
                .flatten()
                .ok_or_else(|| {
                    bad(
                        StatusCode::NOT_FOUND,
                        format!(
                            "no image {name}: gray, twotone, stencil, preview, picture (of a \
                             set: sK-NAME for stencil K, K as 1, 2, ..., and composite; of \
                             tiles: tK-NAME and tiles)"
                        ),
                    )
                })?;
            if let Shown::One(c) = shown {
                s.reuse.keep_png(c, name, &p);
            }
            p
        }
    };
    done.cache(name, &png);
    let headers = [
        (header::CONTENT_TYPE.as_str(), "image/png".to_string()),
        (header::CACHE_CONTROL.as_str(), "no-store".to_string()),
        ("x-stencil-version", done.version.to_string()),
    ];
    Ok((headers, png).into_response())
}

/// `GET /api/events`: `asked` (a change is being computed: show "updating") and `done`
/// (version N is ready: fetch the state and images), as server-sent events.
async fn events(State(s): State<Shared>) -> impl IntoResponse {
    let asked = s.asked.subscribe();
    let mut done = s.done.subscribe();
    // The first event says which version is ready now.
    done.mark_changed();
    let stop = s.shutdown.subscribe();
    let stream = futures_util::stream::unfold(
        (asked, done, stop),
        |(mut asked, mut done, mut stop)| async move {
            let ev = tokio::select! {
                r = asked.changed() => { r.ok()?; Event::default().event("asked").data(asked.borrow_and_update().to_string()) }
                r = done.changed() => { r.ok()?; Event::default().event("done").data(done.borrow_and_update().version.to_string()) }
                _ = stop.wait_for(|s| *s) => return None,
            };
            Some((Ok::<_, std::convert::Infallible>(ev), (asked, done, stop)))
        },
    );
    Sse::new(stream).keep_alive(KeepAlive::default())
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
        let (studio, worker) = Studio::start(maker, specs, initial, cfg, port)?;
        let api = Router::new()
            .route("/", get(page))
            .route("/api/options", get(get_options))
            .route("/api/state", get(get_state))
            .route("/api/params", post(post_params))
            .route("/api/bridges", post(post_bridges))
            .route("/api/undo", post(|s| step_history(s, -1)))
            .route("/api/redo", post(|s| step_history(s, 1)))
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
        crate::conn::serve(listener, api, studio.shutdown.subscribe()).await;
        studio.stop();
        let _ = worker.join();
        Ok(())
    })
}
