//! The studio's connections: HTTP/1 on 127.0.0.1, bounded so that clients which open
//! connections and never finish a request cannot lock the page out.
//!
//! Why not `axum::serve`: it has no header timeout and no bound on connections, so 1,100
//! connections that never finish their headers held 1,100 open files; under a desktop's limit of
//! 1,024 the server could accept nothing more, the page included. Here:
//! - a connection must send a request's headers within [`HEADER_TIMEOUT`] (also the longest a
//!   kept-alive connection waits idle for its next request), or it is closed;
//! - at most [`connection_cap`] connections are open at once (well under the open-file limit,
//!   leaving files for the worker and the export); when a new one comes at the cap, the
//!   connection idle the longest (no request in flight: still sending headers, or kept alive
//!   between requests) is closed to make room, as nginx drains its idle connections. A request
//!   in flight (a change being computed, the page's event stream) is never closed for this, so a
//!   real request is answered while idle connections are held open against it.

use std::collections::HashMap;
use std::convert::Infallible;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;

use axum::body::Body;
use axum::response::Response;
use axum::Router;
use hyper::body::{Frame, Incoming, SizeHint};
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::net::TcpListener;
use tokio::sync::{watch, Notify, Semaphore};

/// How long a client may take to send a request's headers (a browser sends them at once).
pub const HEADER_TIMEOUT: Duration = Duration::from_secs(10);
/// How long open connections may take to finish once the studio stops.
const CLOSING: Duration = Duration::from_secs(5);
/// Open files kept for everything but connections: the input, material and machine profiles,
/// the export's files and their temporaries, the runtime's own.
const OTHER_FILES: usize = 64;

/// How many connections are served at once: half the open files left after [`OTHER_FILES`],
/// at most 256 (a page needs a handful; a script a few more), at least 8.
fn connection_cap() -> usize {
    let limit = open_file_limit().unwrap_or(1024);
    (limit.saturating_sub(OTHER_FILES) / 2).clamp(8, 256)
}

/// The process's soft limit on open files, where the system says (Linux's `/proc`).
fn open_file_limit() -> Option<usize> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits.lines().find(|l| l.starts_with("Max open files"))?;
    // "Max open files   SOFT   HARD   files"; "unlimited" leaves the default.
    line.split_whitespace().nth(3)?.parse().ok()
}

/// One open connection, as the accept loop sees it.
struct Conn {
    /// Requests in flight (from the headers read until the response's body is sent or dropped).
    busy: AtomicUsize,
    /// When it last became idle, as a count of events (older is smaller).
    idle_since: AtomicU64,
    /// Chosen to make room; its task closes it.
    evicted: AtomicBool,
    close: Notify,
}

/// Every open connection, to find the one idle the longest.
#[derive(Default)]
struct Conns {
    open: Mutex<HashMap<u64, Arc<Conn>>>,
    clock: AtomicU64,
}

impl Conns {
    fn open(&self) -> std::sync::MutexGuard<'_, HashMap<u64, Arc<Conn>>> {
        self.open.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn tick(&self) -> u64 {
        self.clock.fetch_add(1, Ordering::SeqCst)
    }

    /// Close the connection idle the longest, if one is idle.
    fn evict_oldest_idle(&self) {
        let open = self.open();
        let oldest = open
            .values()
            .filter(|c| c.busy.load(Ordering::SeqCst) == 0 && !c.evicted.load(Ordering::SeqCst))
            .min_by_key(|c| c.idle_since.load(Ordering::SeqCst));
        if let Some(c) = oldest {
            c.evicted.store(true, Ordering::SeqCst);
            c.close.notify_one();
        }
    }
}

/// Marks its connection busy while it lives: from a request's headers to the end of its
/// response's body.
struct Busy {
    conn: Arc<Conn>,
    conns: Arc<Conns>,
}

impl Busy {
    fn new(conn: Arc<Conn>, conns: Arc<Conns>) -> Busy {
        conn.busy.fetch_add(1, Ordering::SeqCst);
        Busy { conn, conns }
    }
}

impl Drop for Busy {
    fn drop(&mut self) {
        self.conn
            .idle_since
            .store(self.conns.tick(), Ordering::SeqCst);
        self.conn.busy.fetch_sub(1, Ordering::SeqCst);
    }
}

/// A response body that keeps its connection busy until it is sent (or dropped).
struct Guarded {
    body: Body,
    _busy: Busy,
}

impl hyper::body::Body for Guarded {
    type Data = axum::body::Bytes;
    type Error = axum::Error;

    fn poll_frame(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<Frame<Self::Data>, Self::Error>>> {
        Pin::new(&mut self.body).poll_frame(cx)
    }

    fn is_end_stream(&self) -> bool {
        self.body.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        self.body.size_hint()
    }
}

/// The router, with each request marking its connection busy.
#[derive(Clone)]
struct Service {
    inner: TowerToHyperService<Router>,
    conn: Arc<Conn>,
    conns: Arc<Conns>,
}

impl hyper::service::Service<hyper::Request<Incoming>> for Service {
    type Response = hyper::Response<Guarded>;
    type Error = Infallible;
    type Future =
        Pin<Box<dyn std::future::Future<Output = Result<Self::Response, Infallible>> + Send>>;

    fn call(&self, req: hyper::Request<Incoming>) -> Self::Future {
        let busy = Busy::new(self.conn.clone(), self.conns.clone());
        let answer = self.inner.call(req);
        Box::pin(async move {
            let res: Response = answer.await?;
            Ok(res.map(|body| Guarded { body, _busy: busy }))
        })
    }
}

/// Serve `router` on `listener`, at most [`connection_cap`] connections at once, until `stop`
/// turns true; then let open connections finish (graceful shutdown: the event streams end on
/// `stop`) for up to [`CLOSING`].
pub async fn serve(listener: TcpListener, router: Router, stop: watch::Receiver<bool>) {
    let cap = connection_cap();
    let permits = Arc::new(Semaphore::new(cap));
    let conns = Arc::new(Conns::default());
    let mut ids = 0u64;
    let mut stopping = stop.clone();
    loop {
        let accepted = tokio::select! {
            r = listener.accept() => r,
            _ = stopping.wait_for(|s| *s) => break,
        };
        let stream = match accepted {
            Ok((stream, _)) => stream,
            Err(_) => {
                // Out of open files (or another transient failure): make room, then retry.
                conns.evict_oldest_idle();
                tokio::time::sleep(Duration::from_millis(50)).await;
                continue;
            }
        };
        let permit = match permits.clone().try_acquire_owned() {
            Ok(p) => p,
            Err(_) => {
                conns.evict_oldest_idle();
                tokio::select! {
                    p = permits.clone().acquire_owned() => match p {
                        Ok(p) => p,
                        Err(_) => break,
                    },
                    _ = stopping.wait_for(|s| *s) => break,
                }
            }
        };
        ids += 1;
        let id = ids;
        let conn = Arc::new(Conn {
            busy: AtomicUsize::new(0),
            idle_since: AtomicU64::new(conns.tick()),
            evicted: AtomicBool::new(false),
            close: Notify::new(),
        });
        conns.open().insert(id, conn.clone());
        let service = Service {
            inner: TowerToHyperService::new(router.clone()),
            conn: conn.clone(),
            conns: conns.clone(),
        };
        let conns = conns.clone();
        let mut stop = stop.clone();
        tokio::spawn(async move {
            let _permit = permit;
            let mut http = hyper::server::conn::http1::Builder::new();
            http.timer(TokioTimer::new())
                .header_read_timeout(HEADER_TIMEOUT);
            let served = http.serve_connection(TokioIo::new(stream), service);
            tokio::pin!(served);
            let stopping = tokio::select! {
                _ = served.as_mut() => false,
                // Dropped: the socket closes.
                _ = conn.close.notified() => false,
                _ = async { stop.wait_for(|s| *s).await.is_ok() } => true,
            };
            if stopping {
                served.as_mut().graceful_shutdown();
                let _ = tokio::time::timeout(CLOSING, served).await;
            }
            conns.open().remove(&id);
        });
    }
    // Every permit back: every connection closed (or the time is up).
    let _ = tokio::time::timeout(CLOSING * 2, permits.acquire_many(cap as u32)).await;
}
