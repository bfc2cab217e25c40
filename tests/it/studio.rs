//! `stencil studio` through its JSON API, as a script would drive it: the guards (token, Host,
//! Origin, bounded bodies), `make`'s own messages for bad values, the incremental engine, and
//! export compared byte for byte with `stencil make` run with the command line the studio shows,
//! after random sequences of changes; and the hostile inputs of issue 39 (a refused undo, two
//! keep-out paintings, exports racing changes, the input replaced on disk, image name spellings,
//! connections that never finish their headers, a value that looks like an option).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use serde_json::{json, Value};

use crate::common::{make_as_shown, same_outputs};

/// A running `stencil studio`, stopped when dropped.
pub(crate) struct Studio {
    child: Child,
    port: u16,
    token: String,
}

impl Drop for Studio {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_stencil")
}

impl Studio {
    pub(crate) fn start(input: &str, out: &Path, extra: &[&str]) -> Studio {
        let mut cmd = Command::new(bin());
        cmd.args(["studio", input, "-o"]).arg(out).args(extra);
        Studio::spawn(cmd)
    }

    /// Start a command that runs `stencil studio` (the binary, or a shell that execs it).
    fn spawn(mut cmd: Command) -> Studio {
        let mut child = cmd
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start stencil studio");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let url = line.trim();
        let rest = url
            .strip_prefix("http://127.0.0.1:")
            .unwrap_or_else(|| panic!("first line is not the URL: {url:?}"));
        let (port, token) = rest.split_once("/?token=").unwrap();
        Studio {
            child,
            port: port.parse().unwrap(),
            token: token.to_string(),
        }
    }

    /// One request with the token in the header; returns the status and the body.
    pub(crate) fn call(&self, method: &str, path: &str, body: &[u8]) -> (u16, Vec<u8>) {
        let auth = format!("Bearer {}", self.token);
        let host = format!("127.0.0.1:{}", self.port);
        request(
            self.port,
            method,
            path,
            &[("Host", &host), ("Authorization", &auth)],
            body,
        )
    }

    pub(crate) fn json(&self, method: &str, path: &str, body: Value) -> (u16, Value) {
        let (s, b) = self.call(method, path, body.to_string().as_bytes());
        let v = serde_json::from_slice(&b)
            .unwrap_or_else(|_| panic!("{path}: not JSON: {}", String::from_utf8_lossy(&b)));
        (s, v)
    }

    pub(crate) fn ok(&self, method: &str, path: &str, body: Value) -> Value {
        let (s, v) = self.json(method, path, body);
        assert_eq!(s, 200, "{method} {path}: {v}");
        v
    }
}

/// A bare HTTP/1.1 request (the test trusts no client library of ours).
fn request(
    port: u16,
    method: &str,
    path: &str,
    headers: &[(&str, &str)],
    body: &[u8],
) -> (u16, Vec<u8>) {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    let mut req = format!("{method} {path} HTTP/1.1\r\nConnection: close\r\n");
    for (k, v) in headers {
        req += &format!("{k}: {v}\r\n");
    }
    req += &format!(
        "Content-Type: application/json\r\nContent-Length: {}\r\n\r\n",
        body.len()
    );
    s.write_all(req.as_bytes()).unwrap();
    s.write_all(body).unwrap();
    let mut raw = Vec::new();
    let _ = s.read_to_end(&mut raw);
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("an HTTP response");
    let head = String::from_utf8_lossy(&raw[..split]).to_lowercase();
    let status: u16 = head.split(' ').nth(1).unwrap().parse().unwrap();
    let mut body = raw[split + 4..].to_vec();
    if head.contains("transfer-encoding: chunked") {
        body = unchunk(&body);
    }
    (status, body)
}

fn unchunk(mut b: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let Some(eol) = b.windows(2).position(|w| w == b"\r\n") else {
            return out;
        };
        let n = usize::from_str_radix(String::from_utf8_lossy(&b[..eol]).trim(), 16).unwrap();
        if n == 0 {
            return out;
        }
        out.extend_from_slice(&b[eol + 2..eol + 2 + n]);
        b = &b[eol + 2 + n + 2..];
    }
}

pub(crate) fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("stencil-studio-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn guards_refuse_strangers_and_bad_values_get_makes_message() {
    let out = tmp("guards");
    let st = Studio::start("samples/rings.png", &out, &[]);
    let host = format!("127.0.0.1:{}", st.port);
    // No token, a wrong one, a foreign Host (DNS rebinding), a foreign Origin.
    let (s, _) = request(st.port, "GET", "/api/state", &[("Host", &host)], b"");
    assert_eq!(s, 401);
    let (s, _) = request(
        st.port,
        "GET",
        "/api/state?token=0123",
        &[("Host", &host)],
        b"",
    );
    assert_eq!(s, 401);
    let q = format!("/api/state?token={}", st.token);
    let (s, _) = request(st.port, "GET", &q, &[("Host", "evil.example:80")], b"");
    assert_eq!(s, 403);
    let (s, _) = request(
        st.port,
        "GET",
        &q,
        &[("Host", &host), ("Origin", "http://evil.example")],
        b"",
    );
    assert_eq!(s, 403);
    let (s, _) = request(st.port, "GET", &q, &[("Host", &host)], b"");
    assert_eq!(s, 200);
    // The page itself needs the token too, and carries no outside reference.
    let (s, page) = request(
        st.port,
        "GET",
        &format!("/?token={}", st.token),
        &[("Host", &host)],
        b"",
    );
    assert_eq!(s, 200);
    let page = String::from_utf8(page).unwrap();
    assert!(page.contains("<html"));
    // Nothing from the network: the only URL is the SVG namespace, which is a name, not a fetch.
    let urls = page.matches("http").count();
    let namespace = page.matches("http://www.w3.org/2000/svg").count();
    assert_eq!(urls, namespace, "the page refers to the network");
    // A body over the bound.
    let (s, _) = st.call("POST", "/api/params", &vec![b' '; 200_000]);
    assert_eq!(s, 413);
    // A bad value: 400 with make's own message, and nothing changes.
    let before = st.ok("GET", "/api/state?wait=1", json!(null));
    let (s, v) = st.json("POST", "/api/params", json!({"threshold": "abc"}));
    assert_eq!(s, 400);
    let make = Command::new(bin())
        .args(["make", "samples/rings.png", "--threshold", "abc", "-o"])
        .arg(out.join("never"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&make.stderr);
    let msg = v["error"].as_str().unwrap();
    assert!(
        stderr.contains(msg),
        "studio said {msg:?}, make said {stderr:?}"
    );
    let (s, v) = st.json("POST", "/api/params", json!({"width-mm": "-3"}));
    assert_eq!(s, 400, "{v}");
    let (s, v) = st.json("POST", "/api/params", json!({"no-such-option": "1"}));
    assert_eq!(s, 400, "{v}");
    let after = st.ok("GET", "/api/state?wait=1", json!(null));
    assert_eq!(before["params"], after["params"]);
    assert_eq!(before["version"], after["version"]);
    // Images: the four names, PNGs of the working size.
    for name in ["gray", "twotone", "stencil", "preview"] {
        let (s, b) = st.call("GET", &format!("/api/image/{name}.png"), b"");
        assert_eq!(s, 200, "{name}");
        assert!(b.starts_with(b"\x89PNG"), "{name}");
    }
    let (s, _) = st.call("GET", "/api/image/secret.png", b"");
    assert_eq!(s, 404);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_change_re_runs_only_the_stages_after_it() {
    let out = tmp("stages");
    let st = Studio::start("samples/rings.png", &out, &[]);
    let s0 = st.ok("GET", "/api/state?wait=1", json!(null));
    assert_eq!(s0["ran"][0], "load");
    let s = st.ok("POST", "/api/params", json!({"threshold": "100"}));
    assert_eq!(
        s["ran"],
        json!(["threshold", "clean", "walk", "join", "trace"])
    );
    assert_eq!(s["report"]["threshold_level"], 100);
    let s = st.ok("POST", "/api/params", json!({"w-length": "2.5"}));
    assert_eq!(s["ran"], json!(["join", "trace"]));
    // A material with the same smallest feature but another stiffness and narrowest bridge:
    // from the bridges on (the narrowest bridge moves the walks' twins and the drop's widths).
    let s = st.ok("POST", "/api/params", json!({"material": "mylar-0.19"}));
    assert_eq!(s["ran"], json!(["walk", "join", "trace"]));
    // A finer smallest feature needs a finer working pixel: the automatic supersampling
    // changes, so from the working gray on.
    let s = st.ok("POST", "/api/params", json!({"material": "brass-0.3-etch"}));
    assert_eq!(s["ran"][0], "gray", "{}", s["ran"]);
    assert!(s["report"]["scale_factor"].as_u64().unwrap() > 1);
    // Undo goes back to the kept outputs' parameters; redo forward.
    let u = st.ok("POST", "/api/undo", json!(null));
    assert_eq!(u["params"]["material"], "mylar-0.19");
    let r = st.ok("POST", "/api/redo", json!(null));
    assert_eq!(r["params"]["material"], "brass-0.3-etch");
    let _ = std::fs::remove_dir_all(&out);
}

/// A mesh: a light change re-lights the kept view (no raster), a view change draws again, and
/// what the studio then exports is what `make` writes with the command line it shows.
#[test]
fn a_mesh_light_change_re_lights_the_kept_view() {
    let out = tmp("mesh");
    let st = Studio::start(
        "samples/torus.obj",
        &out,
        &["--size", "300", "--supersample", "1", "--emit", "png,svg"],
    );
    let s0 = st.ok("GET", "/api/state?wait=1", json!(null));
    assert_eq!(s0["ran"][0], "load");
    let from_light = json!([
        "light",
        "gray",
        "threshold",
        "look",
        "clean",
        "walk",
        "join",
        "trace"
    ]);
    let s = st.ok("POST", "/api/params", json!({"light": "-45,30"}));
    assert_eq!(s["ran"], from_light);
    let s = st.ok(
        "POST",
        "/api/params",
        json!({"ambient": "0.3", "fill": "0.4"}),
    );
    assert_eq!(s["ran"], from_light);
    let s = st.ok("POST", "/api/params", json!({"view": "side"}));
    assert_eq!(s["ran"][0], "draw", "{}", s["ran"]);
    let s = st.ok("POST", "/api/params", json!({"light": "60,10"}));
    assert_eq!(s["ran"], from_light);
    let state = st.ok("GET", "/api/state?wait=1", json!(null));
    let command = state["command"].as_str().unwrap().to_string();
    let (code, e) = st.json("POST", "/api/export", json!(null));
    assert_eq!(code, 200, "{e}");
    let made = tmp("mesh-make");
    make_as_shown(&command, &made);
    same_outputs(&out, &made, &command);
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(&made);
}

/// A small deterministic generator (xorshift), so a failing sequence can be replayed by seed.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn pick<'a>(&mut self, xs: &[&'a str]) -> &'a str {
        xs[(self.next() % xs.len() as u64) as usize]
    }
}

#[test]
fn export_after_random_changes_is_what_make_writes() {
    let mut exported = 0;
    let runs = [
        (7u64, "samples/rings.png"),
        (42, "samples/blobs.png"),
        (1234, "samples/letters.png"),
        (99, "samples/rings.png"),
        (2026, "samples/target.png"),
        (5, "samples/blobs.png"),
        (27, "samples/grace_hopper.jpg"),
        (2702, "samples/shaded.png"),
    ];
    for (seed, input) in runs {
        let out = tmp(&format!("random-{seed}"));
        let st = Studio::start(input, &out, &["--emit", "png,svg,dxf"]);
        let mut rng = Rng(seed);
        let mut log = Vec::new();
        for _ in 0..10 {
            let choice = rng.next() % 16;
            let (path, body) = match choice {
                0 => (
                    "/api/params",
                    json!({"threshold": rng.pick(&["90", "128", "160", "otsu"])}),
                ),
                1 => (
                    "/api/params",
                    json!({"invert": rng.pick(&["true", "false"])}),
                ),
                2 => (
                    "/api/params",
                    json!({"w-length": rng.pick(&["0.5", "1", "3"]), "w-intensity": rng.pick(&["1", "2", "4"])}),
                ),
                3 => (
                    "/api/params",
                    json!({"bridges-per-island": rng.pick(&["1", "2", "3"])}),
                ),
                4 => (
                    "/api/params",
                    json!({"material": rng.pick(&["", "mylar-0.19", "brass-0.3-etch", "poster-board"])}),
                ),
                5 => (
                    "/api/params",
                    json!({"width-mm": rng.pick(&["", "60", "120"]), "allow-thin": "true"}),
                ),
                6 => {
                    let s = st.ok("GET", "/api/state?wait=1", json!(null));
                    let n = s["report"]["bridges"].as_array().map_or(0, |b| b.len());
                    if n == 0 {
                        continue;
                    }
                    ("/api/bridges", json!({"delete": rng.next() % n as u64}))
                }
                7 => {
                    let s = st.ok("GET", "/api/state?wait=1", json!(null));
                    let (w, h) = (
                        s["report"]["width_mm"].as_f64().unwrap_or(10.0),
                        s["report"]["height_mm"].as_f64().unwrap_or(10.0),
                    );
                    let (x, y) = (
                        (rng.next() % 100) as f64 / 100.0 * w * 0.8,
                        (rng.next() % 100) as f64 / 100.0 * h * 0.8,
                    );
                    ("/api/bridges", json!({"pin": [x, y]}))
                }
                8 => (rng.pick(&["/api/undo", "/api/redo"]), json!(null)),
                // The picture's adjustments (issue 27), as the page's sliders send them.
                9 => (
                    "/api/params",
                    json!({"brightness": rng.pick(&["0", "-30", "25"]), "contrast": rng.pick(&["0", "40", "-20"])}),
                ),
                10 => (
                    "/api/params",
                    json!({"gamma": rng.pick(&["1", "0.6", "1.8"]), "smooth": rng.pick(&["0", "0.3"])}),
                ),
                11 => (
                    "/api/params",
                    json!({"abstract": rng.pick(&["0", "0.4", "0.8"])}),
                ),
                12 => (
                    "/api/params",
                    json!({"local-threshold": rng.pick(&["0", "2", "6"])}),
                ),
                13 => (
                    "/api/params",
                    json!({"crop": rng.pick(&["", "1,1,12,10", "3,2,9,9"]), "rotate": rng.pick(&["0", "90", "180", "270"])}),
                ),
                14 => (
                    "/api/params",
                    json!({"keep-all-islands": rng.pick(&["true", "false"])}),
                ),
                _ => (
                    "/api/params",
                    json!({"threshold": rng.pick(&["auto", "otsu", "110"])}),
                ),
            };
            let (s, v) = st.json("POST", path, body.clone());
            log.push(format!("{path} {body} -> {s}"));
            assert!(s == 200 || s == 409, "{log:?}: {v}");
        }
        let state = st.ok("GET", "/api/state?wait=1", json!(null));
        let command = state["command"].as_str().unwrap().to_string();
        let (s, e) = st.json("POST", "/api/export", json!(null));
        let made = tmp(&format!("random-{seed}-make"));
        if s != 200 {
            // make refuses the same options in the same words.
            let o = Command::new(bin())
                .args(command.split(' ').skip(1))
                .output()
                .unwrap();
            assert!(
                !o.status.success(),
                "{log:?}: studio refused ({e}) but make did not"
            );
            let msg = e["error"].as_str().unwrap();
            let stderr = String::from_utf8_lossy(&o.stderr);
            assert!(
                stderr.contains(msg),
                "{log:?}: studio {msg:?}, make {stderr:?}"
            );
            continue;
        }
        assert_eq!(e["command"], command.as_str());
        make_as_shown(&command, &made);
        same_outputs(&out, &made, &format!("seed {seed}: {command}; {log:?}"));
        exported += 1;
        eprintln!("seed {seed}: {command}: same files as make");
        let _ = std::fs::remove_dir_all(&out);
        let _ = std::fs::remove_dir_all(&made);
    }
    assert!(
        exported >= runs.len() / 2,
        "only {exported} of {} sequences exported",
        runs.len()
    );
}

/// A set (issue 27): `layers` and `fill-in` on the page show each stencil and the composite, and
/// export writes what `make` writes for the command line shown, layer folders and all; back to
/// one stencil, export leaves no layer folder behind (as `make` does). Dropped islands are
/// counted in the report and yellow in the page's preview.
#[test]
fn a_set_is_shown_stencil_by_stencil_and_exported_as_make_writes_it() {
    let out = tmp("set");
    let st = Studio::start("samples/grace_hopper.jpg", &out, &[]);
    let s0 = st.ok("GET", "/api/state?wait=1", json!(null));
    let dropped = s0["report"]["dropped_islands"]
        .as_array()
        .map_or(0, Vec::len);
    assert!(dropped > 0, "grace_hopper.jpg drops islands by default");
    let (_, preview) = st.call("GET", "/api/image/preview.png", b"");
    assert!(
        has_rgb(&preview, [255, 220, 0]),
        "the dropped islands are yellow in the page's preview"
    );
    let s = st.ok("POST", "/api/params", json!({"keep-all-islands": "true"}));
    assert!(s["report"]["dropped_islands"].is_null(), "{}", s["report"]);

    let export_and_compare = |what: &str| {
        let state = st.ok("GET", "/api/state?wait=1", json!(null));
        let command = state["command"].as_str().unwrap().to_string();
        let e = st.ok("POST", "/api/export", json!(null));
        let made = tmp(&format!("set-make-{what}"));
        make_as_shown(&command, &made);
        same_outputs(&out, &made, &format!("{what}: {command}"));
        let _ = std::fs::remove_dir_all(&made);
        e
    };

    let s = st.ok(
        "POST",
        "/api/params",
        json!({"layers": "2", "abstract": "0.4"}),
    );
    assert_eq!(s["set"]["layers"].as_array().map(Vec::len), Some(2), "{s}");
    assert_eq!(s["layer_reports"].as_array().map(Vec::len), Some(2));
    assert!(s["command"].as_str().unwrap().contains("--layers 2"));
    for name in [
        "composite",
        "preview",
        "s1-preview",
        "s2-preview",
        "s2-stencil",
    ] {
        let (code, b) = st.call("GET", &format!("/api/image/{name}.png"), b"");
        assert_eq!(code, 200, "{name}");
        assert!(b.starts_with(b"\x89PNG"), "{name}");
    }
    let (code, _) = st.call("GET", "/api/image/s3-preview.png", b"");
    assert_eq!(code, 404, "a two-layer set has no third stencil");
    // A bridge of a set is not deleted by index (each layer has its own).
    let (code, _) = st.json("POST", "/api/bridges", json!({"delete": 0}));
    assert_eq!(code, 409);
    let e = export_and_compare("layers");
    let files: Vec<&str> = e["files"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(Value::as_str)
        .collect();
    assert!(
        files.contains(&"layer-2/stencil.png") && files.contains(&"composite.png"),
        "{files:?}"
    );

    // The paper's fill-in layer: one stencil and the fill-in.
    let s = st.ok(
        "POST",
        "/api/params",
        json!({"layers": "", "fill-in": "true"}),
    );
    assert!(s["set"]["fill_in"].is_object(), "{}", s["set"]);
    assert_eq!(s["layer_reports"].as_array().map(Vec::len), Some(2));
    export_and_compare("fill-in");
    assert!(!out.join("layer-2").exists());

    // Back to one stencil: make's files, no set left behind.
    let s = st.ok(
        "POST",
        "/api/params",
        json!({"fill-in": "false", "brightness": "10"}),
    );
    assert!(s["set"].is_null());
    export_and_compare("one");
    assert!(!out.join("fill-in").exists() && !out.join("composite.png").exists());
    let _ = std::fs::remove_dir_all(&out);
}

/// Whether a PNG (RGB, 8 bits) has a pixel of this colour.
fn has_rgb(png: &[u8], c: [u8; 3]) -> bool {
    let img = image::load_from_memory(png).unwrap().to_rgb8();
    img.pixels().any(|p| p.0 == c)
}

// ---- issue 39: the fourth hostile-input campaign against the studio's server ------------------

/// A request like [`request`] that gives up after `secs` (a server that never answers fails the
/// test instead of hanging it): `None` when no answer came.
fn request_within(
    port: u16,
    path: &str,
    headers: &[(&str, &str)],
    secs: u64,
) -> Option<(u16, Vec<u8>)> {
    use std::time::Duration;
    let mut s = TcpStream::connect(("127.0.0.1", port)).ok()?;
    s.set_read_timeout(Some(Duration::from_secs(secs))).ok()?;
    let mut req = format!("GET {path} HTTP/1.1\r\nConnection: close\r\n");
    for (k, v) in headers {
        req += &format!("{k}: {v}\r\n");
    }
    req += "\r\n";
    s.write_all(req.as_bytes()).ok()?;
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).ok()?;
    let split = raw.windows(4).position(|w| w == b"\r\n\r\n")?;
    let head = String::from_utf8_lossy(&raw[..split]).to_lowercase();
    let status: u16 = head.split(' ').nth(1)?.parse().ok()?;
    Some((status, raw[split + 4..].to_vec()))
}

/// The threshold level `make` wrote in a folder's report.json.
fn written_level(out: &Path) -> Value {
    let r: Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    r["threshold_level"].clone()
}

/// An undo the server refuses (the material file it names now has a typo: `make`'s message,
/// naming the file) leaves the history and the state where they were: the state, its command
/// line and the files exported are the one version shown; mended, the undo goes through.
#[test]
fn a_refused_undo_leaves_the_history_and_the_state_as_they_were() {
    let dir = tmp("refused-undo");
    std::fs::create_dir_all(&dir).unwrap();
    let mat = dir.join("mine.toml");
    std::fs::copy("profiles/materials/cardstock.toml", &mat).unwrap();
    let out = dir.join("out");
    let st = Studio::start(
        "samples/rings.png",
        &out,
        &["--material", mat.to_str().unwrap()],
    );
    st.ok("POST", "/api/params", json!({"threshold": "100"}));
    let s = st.ok("POST", "/api/params", json!({"threshold": "150"}));
    assert_eq!(s["report"]["threshold_level"], 150);
    std::fs::write(&mat, "process = [laser\n").unwrap();
    let (code, v) = st.json("POST", "/api/undo", json!(null));
    assert_eq!(code, 400, "{v}");
    assert!(
        v["error"].as_str().unwrap().contains("mine.toml"),
        "the message names the file: {v}"
    );
    let s = st.ok("GET", "/api/state?wait=1", json!(null));
    assert_eq!(s["params"]["threshold"], "150", "{}", s["params"]);
    assert_eq!(s["report"]["threshold_level"], 150);
    assert!(
        s["command"].as_str().unwrap().contains("--threshold 150"),
        "{}",
        s["command"]
    );
    assert_eq!(
        s["can_redo"], false,
        "the refused undo did not move the history"
    );
    let (code, _) = st.json("POST", "/api/redo", json!(null));
    assert_eq!(code, 409, "nothing to redo: the undo was refused");
    let e = st.ok("POST", "/api/export", json!(null));
    assert!(e["command"].as_str().unwrap().contains("--threshold 150"));
    assert_eq!(written_level(&out), 150);
    // Mended, the same undo goes back one step.
    std::fs::copy("profiles/materials/cardstock.toml", &mat).unwrap();
    let u = st.ok("POST", "/api/undo", json!(null));
    assert_eq!(u["params"]["threshold"], "100");
    assert_eq!(u["report"]["threshold_level"], 100);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A PNG of `w` x `h` gray pixels, black where `dark(x, y)`.
fn mask_png(w: u32, h: u32, dark: impl Fn(u32, u32) -> bool) -> Vec<u8> {
    let img =
        image::GrayImage::from_fn(w, h, |x, y| image::Luma([if dark(x, y) { 0 } else { 255 }]));
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// Each keep-out painting is kept in its own file: a second painting does not overwrite the
/// first, so undo gives back the first mask exactly, and the export is what `make` writes with
/// the command line shown (which names that first file).
#[test]
fn each_keep_out_painting_is_kept_so_undo_restores_the_first() {
    let out = tmp("keepout-undo");
    let st = Studio::start("samples/rings.png", &out, &[]);
    st.ok("GET", "/api/state?wait=1", json!(null));
    let first = mask_png(64, 64, |x, _| x < 32);
    let second = mask_png(64, 64, |x, _| x >= 32);
    let (code, b) = st.call("POST", "/api/keepout", &first);
    assert_eq!(code, 200, "{}", String::from_utf8_lossy(&b));
    let (code, b) = st.call("POST", "/api/keepout", &second);
    assert_eq!(code, 200, "{}", String::from_utf8_lossy(&b));
    let s: Value = serde_json::from_slice(&b).unwrap();
    let second_path = s["params"]["keep-out"].as_str().unwrap().to_string();
    assert_eq!(std::fs::read(&second_path).unwrap(), second);
    let u = st.ok("POST", "/api/undo", json!(null));
    let first_path = u["params"]["keep-out"].as_str().unwrap().to_string();
    assert!(
        std::fs::read(&first_path).unwrap() == first,
        "undo's keep-out file {first_path} is not the first painting"
    );
    // The same painting again is the same file (named by its content).
    let (code, b) = st.call("POST", "/api/keepout", &first);
    assert_eq!(code, 200);
    let again: Value = serde_json::from_slice(&b).unwrap();
    assert_eq!(again["params"]["keep-out"], first_path.as_str());
    let state = st.ok("GET", "/api/state?wait=1", json!(null));
    let command = state["command"].as_str().unwrap().to_string();
    let e = st.ok("POST", "/api/export", json!(null));
    assert_eq!(e["command"], command.as_str());
    let made = tmp("keepout-undo-make");
    make_as_shown(&command, &made);
    same_outputs(&out, &made, &command);
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(&made);
}

/// An export while three other clients keep changing the threshold writes the files of one
/// version and answers with that version's command line (report.json's level is the one the
/// command names), every time.
#[test]
fn an_export_while_the_threshold_changes_is_of_one_version() {
    use std::sync::atomic::{AtomicBool, Ordering};
    let out = tmp("export-race");
    let st = Studio::start("samples/rings.png", &out, &[]);
    st.ok("GET", "/api/state?wait=1", json!(null));
    let stop = AtomicBool::new(false);
    std::thread::scope(|sc| {
        for levels in [["90", "160"], ["100", "170"], ["110", "150"]] {
            let (st, stop) = (&st, &stop);
            sc.spawn(move || {
                let mut i = 0;
                while !stop.load(Ordering::SeqCst) {
                    let t = levels[i % 2];
                    let (code, v) = st.json("POST", "/api/params", json!({ "threshold": t }));
                    assert_eq!(code, 200, "{v}");
                    i += 1;
                }
            });
        }
        let mut mixed = Vec::new();
        for k in 0..40 {
            let e = st.ok("POST", "/api/export", json!(null));
            let command = e["command"].as_str().unwrap();
            let named: u64 = command
                .split_once("--threshold ")
                .map_or(128, |(_, t)| t.split(' ').next().unwrap().parse().unwrap());
            let level = written_level(&out);
            if level != named {
                mixed.push(format!("export {k}: {command} wrote level {level}"));
            }
        }
        stop.store(true, Ordering::SeqCst);
        assert!(mixed.is_empty(), "{} of 40: {mixed:#?}", mixed.len());
    });
    let _ = std::fs::remove_dir_all(&out);
}

/// The input picture replaced on disk while the studio runs (a 48 x 16 mm picture by a 32 x 32
/// mm one): the studio notices, reads it again and says so; a crop that fits only the new
/// picture is then checked against it and cut from its pixels, so the export is what `make`
/// writes for the command line shown.
#[test]
fn a_picture_replaced_on_disk_is_read_again_whole() {
    let dir = tmp("replaced");
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("in.png");
    std::fs::copy("samples/letters.png", &input).unwrap();
    let out = dir.join("out");
    let st = Studio::start(input.to_str().unwrap(), &out, &[]);
    let s = st.ok("GET", "/api/state?wait=1", json!(null));
    assert_eq!(s["width_px"], 480);
    // Replaced as an editor saves: a new file renamed over the old.
    let new = dir.join("new.png");
    std::fs::copy("samples/rings.png", &new).unwrap();
    std::fs::rename(&new, &input).unwrap();
    // The studio reads it again by itself (it looks about once a second) and says so.
    let end = std::time::Instant::now() + std::time::Duration::from_secs(120);
    let s = loop {
        let s = st.ok("GET", "/api/state?wait=1", json!(null));
        if s["width_px"] == 320 {
            break s;
        }
        assert!(
            std::time::Instant::now() < end,
            "the studio still shows the old picture: {}",
            s["width_px"]
        );
        std::thread::sleep(std::time::Duration::from_millis(200));
    };
    assert!(
        s["notice"].as_str().is_some_and(|n| n.contains("changed")),
        "the page is told the picture changed: {}",
        s["notice"]
    );
    let s = st.ok("POST", "/api/params", json!({"crop": "20,20,10,10"}));
    assert_eq!(
        (s["width_px"].clone(), s["height_px"].clone()),
        (json!(100), json!(100))
    );
    let command = s["command"].as_str().unwrap().to_string();
    let e = st.ok("POST", "/api/export", json!(null));
    assert_eq!(e["command"], command.as_str());
    let made = dir.join("made");
    make_as_shown(&command, &made);
    same_outputs(&out, &made, &command);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Image names are canonical (`s1-preview`, not `s01-preview` or `s+1-preview`): the other
/// spellings are 404, so a client cannot grow the server's image cache by spelling one image
/// many ways.
#[test]
fn image_names_are_canonical() {
    let out = tmp("image-names");
    let st = Studio::start("samples/rings.png", &out, &["--layers", "2"]);
    let s = st.ok("GET", "/api/state?wait=1", json!(null));
    assert_eq!(s["layer_reports"].as_array().map(Vec::len), Some(2), "{s}");
    for name in ["s1-preview", "s2-stencil", "preview", "composite"] {
        let (code, b) = st.call("GET", &format!("/api/image/{name}.png"), b"");
        assert_eq!(code, 200, "{name}");
        assert!(b.starts_with(b"\x89PNG"), "{name}");
    }
    for name in [
        "s01-preview",
        "s001-preview",
        "s+1-preview",
        "s02-stencil",
        "s0-preview",
        "s1-",
        "s-preview",
    ] {
        let (code, _) = st.call("GET", &format!("/api/image/{name}.png"), b"");
        assert_eq!(code, 404, "{name}");
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// A connection that never finishes its headers is closed by the server (a browser sends its
/// headers at once; a client that does not holds a connection for nothing).
#[test]
fn a_connection_that_never_finishes_its_headers_is_closed() {
    use std::time::Duration;
    let out = tmp("slow-headers");
    let st = Studio::start("samples/rings.png", &out, &[]);
    let mut slow = TcpStream::connect(("127.0.0.1", st.port)).unwrap();
    slow.write_all(b"GET /api/state HTTP/1.1\r\nHost: 127.0.0.1\r\n")
        .unwrap();
    slow.set_read_timeout(Some(Duration::from_secs(180)))
        .unwrap();
    let mut buf = [0u8; 256];
    match slow.read(&mut buf) {
        // Closed: no bytes (or a 408 before closing), then the end.
        Ok(_) => {}
        Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset => {}
        Err(e) => panic!("the connection is still open after 180 s: {e}"),
    }
    let mut rest = Vec::new();
    let r = slow.read_to_end(&mut rest);
    assert!(
        r.is_ok()
            || r.as_ref()
                .is_err_and(|e| e.kind() == std::io::ErrorKind::ConnectionReset),
        "{r:?}"
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// 300 connections that never finish their headers, under an open-file limit of 200 (a
/// desktop's 1,024 against 1,100 such connections, scaled down): the page still answers a real
/// request while they are held open.
#[test]
fn idle_connections_do_not_lock_the_page_out() {
    let out = tmp("idle-conns");
    let mut cmd = Command::new("sh");
    cmd.args(["-c", "ulimit -n 200 && exec \"$0\" \"$@\"", bin()])
        .args(["studio", "samples/rings.png", "-o"])
        .arg(&out);
    let st = Studio::spawn(cmd);
    let host = format!("127.0.0.1:{}", st.port);
    let auth = format!("Bearer {}", st.token);
    let first = request_within(
        st.port,
        "/api/state?wait=1",
        &[("Host", &host), ("Authorization", &auth)],
        120,
    );
    assert_eq!(first.map(|r| r.0), Some(200));
    let mut idle = Vec::new();
    for _ in 0..300 {
        let mut s = TcpStream::connect(("127.0.0.1", st.port)).unwrap();
        let _ = s.write_all(b"GET /api/state HTTP/1.1\r\n");
        idle.push(s);
    }
    let answer = request_within(
        st.port,
        "/api/state",
        &[("Host", &host), ("Authorization", &auth)],
        120,
    );
    let (code, body) = answer.expect("the page answers while 300 idle connections are held");
    assert_eq!(code, 200);
    let v: Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(v["report"]["width_px"], 320, "{v}");
    drop(idle);
    let _ = std::fs::remove_dir_all(&out);
}

/// A negative threshold is refused with a message that names the option and the values it
/// takes (not "unexpected argument '-1'"); negative values of options that take them still work.
#[test]
fn a_negative_threshold_names_the_option() {
    let out = tmp("negative");
    let st = Studio::start("samples/rings.png", &out, &[]);
    let (code, v) = st.json("POST", "/api/params", json!({"threshold": "-1"}));
    assert_eq!(code, 400, "{v}");
    let msg = v["error"].as_str().unwrap();
    assert!(
        msg.contains("--threshold") && msg.contains("0..255") && msg.contains("otsu"),
        "{msg}"
    );
    let (code, v) = st.json("POST", "/api/params", json!({"width-mm": "--invert"}));
    assert_eq!(code, 400, "{v}");
    assert!(v["error"].as_str().unwrap().contains("--width-mm"), "{v}");
    let s = st.ok("POST", "/api/params", json!({"brightness": "-30"}));
    let command = s["command"].as_str().unwrap().to_string();
    assert!(command.contains("-30"), "{command}");
    let e = st.ok("POST", "/api/export", json!(null));
    let made = tmp("negative-make");
    make_as_shown(&command, &made);
    same_outputs(&out, &made, &command);
    assert_eq!(e["command"], command.as_str());
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(&made);
}

/// The studio exports an HP-GL job for a plotter cutter as `make` writes it (issue 45).
#[test]
fn the_studio_exports_the_hpgl_job_make_writes() {
    let dir = tmp("hpgl-export");
    let out = dir.join("studio");
    let args = [
        "--width-mm",
        "60",
        "--material",
        "vinyl-0.08",
        "--machine",
        "vinyl-hpgl",
        "--emit",
        "png,svg,hpgl",
    ];
    let st = Studio::start("samples/rings.png", &out, &args);
    let e = st.ok("POST", "/api/export", json!(null));
    assert!(
        e["files"]
            .as_array()
            .unwrap()
            .iter()
            .any(|f| f == "stencil.plt"),
        "{e}"
    );
    let made = dir.join("make");
    let o = Command::new(bin())
        .args(["make", "samples/rings.png", "-o"])
        .arg(&made)
        .args(args)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let plt = |d: &Path| std::fs::read(d.join("stencil.plt")).unwrap();
    assert!(plt(&out).starts_with(b"IN;\nSP1;\nVS4;\nFS80;\n"));
    assert_eq!(plt(&out), plt(&made), "the studio's stencil.plt is make's");
    let _ = std::fs::remove_dir_all(&dir);
}
