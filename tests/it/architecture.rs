//! The workspace's shape, checked from its sources: which crate may depend on which, and which
//! module may use which. A new edge that runs backwards (the G-code side reaching into stencils,
//! the Grbl side into anything but the interpreter, a stage into a later stage) fails here, with
//! the file and the edge named, instead of slowly turning the layers into a knot.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The `stencil-*` crates a manifest's `[dependencies]` names (not dev-dependencies: tests may
/// use anything).
fn stencil_deps(manifest: &Path) -> BTreeSet<String> {
    let text = std::fs::read_to_string(manifest).unwrap();
    let mut out = BTreeSet::new();
    let mut in_deps = false;
    for line in text.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            in_deps = t == "[dependencies]";
            continue;
        }
        if in_deps {
            if let Some(name) = t.split(['.', ' ', '=']).next() {
                if name.starts_with("stencil-") {
                    out.insert(name.to_string());
                }
            }
        }
    }
    out
}

/// Every `.rs` file under `dir`.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The source of a file without its `#[cfg(test)]` module (tests may reach anywhere); nothing of
/// a `tests.rs`, a module's tests kept in a file of their own (`#[cfg(test)] mod tests;`).
fn non_test_source(path: &Path) -> String {
    if path.file_name().is_some_and(|n| n == "tests.rs") {
        return String::new();
    }
    let text = std::fs::read_to_string(path).unwrap();
    match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => text[..i].to_string(),
        None => text,
    }
}

/// The crates each library crate may depend on. The G-code side knows cut loops, not stencils;
/// the Grbl side knows G-code text and ports; the leaves know neither.
fn allowed() -> BTreeMap<&'static str, BTreeSet<&'static str>> {
    BTreeMap::from([
        ("stencil-io", BTreeSet::new()),
        ("stencil-geom", BTreeSet::new()),
        (
            "stencil-gcode",
            BTreeSet::from(["stencil-io", "stencil-geom"]),
        ),
        (
            "stencil-grbl",
            BTreeSet::from(["stencil-io", "stencil-gcode"]),
        ),
        // HP-GL for plotters: cut loops planned by the G-code side's planner, written as HP-GL.
        (
            "stencil-hpgl",
            BTreeSet::from(["stencil-io", "stencil-geom", "stencil-gcode"]),
        ),
        (
            "stencil-core",
            BTreeSet::from([
                "stencil-io",
                "stencil-geom",
                "stencil-gcode",
                "stencil-hpgl",
            ]),
        ),
        // The studio runs core's stages and writes through core's exporter.
        (
            "stencil-studio",
            BTreeSet::from(["stencil-core", "stencil-io"]),
        ),
    ])
}

#[test]
fn crates_depend_only_forwards() {
    let allowed = allowed();
    let mut seen = BTreeSet::new();
    for e in std::fs::read_dir(root().join("crates")).unwrap() {
        let dir = e.unwrap().path();
        let name = dir.file_name().unwrap().to_str().unwrap().to_string();
        let Some(ok) = allowed.get(name.as_str()) else {
            panic!("crates/{name}: a crate this test does not know; add its allowed edges");
        };
        for dep in stencil_deps(&dir.join("Cargo.toml")) {
            assert!(
                ok.contains(dep.as_str()),
                "crates/{name}/Cargo.toml depends on {dep}: not an allowed edge ({ok:?})"
            );
        }
        // The sources use no workspace crate the manifest does not allow either (a path
        // dependency slipped in through a dev-dependency would not show in [dependencies]).
        for f in rust_files(&dir.join("src")) {
            let src = non_test_source(&f);
            for other in allowed.keys() {
                let ident = format!("{}::", other.replace('-', "_"));
                if *other != name && src.contains(&ident) {
                    assert!(
                        ok.contains(other),
                        "{}: uses {ident} but {name} may not depend on {other}",
                        f.display()
                    );
                }
            }
        }
        seen.insert(name);
    }
    assert_eq!(seen.len(), allowed.len(), "crates found: {seen:?}");
    // The binary uses them all; nothing depends on the binary (it has no library).
    let bin = stencil_deps(&root().join("Cargo.toml"));
    assert_eq!(bin.len(), allowed.len(), "{bin:?}");
}

#[test]
fn libraries_forbid_unsafe_code_and_the_binary_keeps_it_in_one_file() {
    for e in std::fs::read_dir(root().join("crates")).unwrap() {
        let lib = e.unwrap().path().join("src/lib.rs");
        let text = std::fs::read_to_string(&lib).unwrap();
        assert!(
            text.contains("#![forbid(unsafe_code)]"),
            "{}: no #![forbid(unsafe_code)]",
            lib.display()
        );
    }
    // Process-wide settings (SIGPIPE, the allocator) are the binary's: main.rs and alloc.rs only.
    for f in rust_files(&root().join("src")) {
        let name = f.file_name().unwrap().to_str().unwrap();
        let src = std::fs::read_to_string(&f).unwrap();
        if src.contains("unsafe {") {
            assert!(
                name == "main.rs" || name == "alloc.rs",
                "{}: unsafe outside main.rs and alloc.rs",
                f.display()
            );
        }
    }
}

/// The Grbl side uses the G-code crate for its interpreter, Grbl's fixed sizes and the G-code
/// number format (for the commands it writes: resume preambles, frames, jogs) only: it runs
/// any program, not just ours, so it must not plan or write toolpaths.
#[test]
fn grbl_uses_only_the_interpreter_of_the_gcode_crate() {
    let ok = ["interpret", "limits", "num"];
    for f in rust_files(&root().join("crates/stencil-grbl/src")) {
        let src = non_test_source(&f);
        for (i, _) in src.match_indices("stencil_gcode::") {
            let rest = &src[i + "stencil_gcode::".len()..];
            let module: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            assert!(
                ok.contains(&module.as_str()),
                "{}: uses stencil_gcode::{module}; the Grbl side may use only {ok:?}",
                f.display()
            );
        }
    }
}

/// Inside `stencil-core`, data flows one way, stage to stage: each module uses only the layers
/// below it (`raster` under everything; a stage never reaches into a later one). Comments and test
/// modules do not count.
#[test]
fn core_stages_use_only_earlier_layers() {
    let allowed: BTreeMap<&str, &[&str]> = BTreeMap::from([
        ("units", &[][..]),
        ("timing", &[][..]),
        // The unit tests' seeded generator: compiled for tests only, it uses nothing.
        ("test_rng", &[][..]),
        ("material", &[][..]),
        ("raster", &["units"][..]),
        ("limits", &["units"][..]),
        // Deciding the size before the work: from the picture's size and the stock alone.
        ("fit", &["units"][..]),
        ("islands", &["raster"][..]),
        ("tone", &["raster", "limits", "units", "timing"][..]),
        (
            "bridge",
            &["raster", "islands", "material", "units", "timing"][..],
        ),
        ("vector", &["raster", "units"][..]),
        (
            "check",
            &["raster", "islands", "material", "units", "vector"][..],
        ),
        // material: an etch material's undercut compensates the masks.
        (
            "export",
            &["raster", "vector", "limits", "units", "material"][..],
        ),
        // A gobo: placed on the traced stencil, its polarity worded as the masks word it, its
        // sheet drawn on the bit grids for the PNGs.
        ("gobo", &["vector", "export", "raster"][..]),
        (
            "request",
            &[
                "bridge", "export", "fit", "gobo", "material", "raster", "tone", "units", "vector",
                "timing",
            ][..],
        ),
        (
            "plan",
            &["bridge", "material", "tone", "units", "vector"][..],
        ),
        // Every error the pipeline returns: the stages' own, gathered.
        (
            "error",
            &[
                "tone", "bridge", "export", "vector", "check", "limits", "report", "fit",
            ][..],
        ),
        (
            "report",
            // export: the masks' description (what was written) is reported as encoded.
            &[
                "raster", "tone", "bridge", "vector", "check", "units", "material", "export",
                "gobo",
            ][..],
        ),
    ]);
    let src = root().join("crates/stencil-core/src");
    for f in rust_files(&src) {
        let rel = f.strip_prefix(&src).unwrap();
        let first = rel.iter().next().unwrap().to_str().unwrap();
        let module = first.trim_end_matches(".rs");
        // The facade, in its own order: `pipeline` (the stage functions, resolve, the writer),
        // `driver` (the stages listed once), `layers` (a set of stencils, each run by the
        // driver), `tiles` (a stencil or a set in tiles, each run by the driver). Each may use
        // the stages and those before it, never one after it.
        let facade = ["pipeline", "inputs", "resolve", "driver", "layers", "tiles"];
        if let Some(k) = facade.iter().position(|m| *m == module) {
            let code = non_test_source(&f);
            for later in &facade[k + 1..] {
                assert!(
                    !code.contains(&format!("crate::{later}")),
                    "{}: uses crate::{later}; {module} comes before it (no cycle between them)",
                    rel.display()
                );
            }
            continue;
        }
        if module == "lib" {
            continue;
        }
        let Some(ok) = allowed.get(module) else {
            panic!(
                "{}: a module this test does not know; add its layer",
                rel.display()
            );
        };
        let code: String = non_test_source(&f)
            .lines()
            .filter(|l| !l.trim_start().starts_with("//"))
            .collect::<Vec<_>>()
            .join("\n");
        for (i, _) in code.match_indices("crate::") {
            let used: String = code[i + "crate::".len()..]
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            assert!(
                used == module || ok.contains(&used.as_str()),
                "{}: uses crate::{used}; {module} may use only {ok:?}",
                rel.display()
            );
        }
    }
}

/// Library messages say what is wrong with the values; the `stencil` binary names the option that
/// changes them (`src/cli/errors.rs`). A string literal in library code (comments and tests
/// aside) that names a command-line option (`--` and a letter) fails, with its file and line.
#[test]
fn libraries_name_no_command_line_options() {
    // The strength notes are report.json text, not errors; they name the option the user sets.
    let allowed = ["lower --bridges-per-island or"];
    for f in rust_files(&root().join("crates")) {
        if f.components().any(|c| c.as_os_str() == "tests") {
            continue;
        }
        for (line, lit) in string_literals(&non_test_source(&f)) {
            let named = lit
                .match_indices("--")
                .any(|(k, _)| lit[k + 2..].starts_with(|c: char| c.is_ascii_lowercase()));
            assert!(
                !named || allowed.iter().any(|a| lit.contains(a)),
                "{}:{line}: a library string names an option: {lit:?}",
                f.display()
            );
        }
    }
}

/// The string literals of Rust source with the line each starts on (comments and character
/// literals skipped; escapes kept as written).
fn string_literals(code: &str) -> Vec<(usize, String)> {
    let b = code.as_bytes();
    let (mut out, mut i, mut line) = (Vec::new(), 0, 1);
    while i < b.len() {
        match b[i] {
            b'\n' => line += 1,
            b'/' if b.get(i + 1) == Some(&b'/') => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
                continue;
            }
            b'\'' if b.get(i + 2) == Some(&b'\'') || b.get(i + 1) == Some(&b'\\') => {
                // 'x' or '\x': skip to the closing quote.
                i += 1;
                while i < b.len() && b[i] != b'\'' {
                    i += if b[i] == b'\\' { 2 } else { 1 };
                }
            }
            b'"' => {
                let (start, mut lit) = (line, Vec::new());
                i += 1;
                while i < b.len() && b[i] != b'"' {
                    if b[i] == b'\\' {
                        lit.push(b[i]);
                        i += 1;
                    }
                    if let Some(&c) = b.get(i) {
                        line += usize::from(c == b'\n');
                        lit.push(c);
                    }
                    i += 1;
                }
                out.push((start, String::from_utf8_lossy(&lit).into_owned()));
            }
            _ => {}
        }
        i += 1;
    }
    out
}

// ---- No import cycle between files (issue 40 item 5) ----

/// A token of Rust source as far as paths need it: an identifier (keywords and numbers too) or
/// one punctuation character (`::` is one token), with its line. Comments, strings and character
/// literals are dropped, so a path written in a message or a doc comment is no edge.
#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Id(String),
    P(&'static str),
}

fn tokens(src: &str) -> Vec<(Tok, usize)> {
    let c: Vec<char> = src.chars().collect();
    let (mut out, mut i, mut line) = (Vec::new(), 0, 1usize);
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    // Skips a string body from the opening quote at `i` (`hashes` for raw strings).
    let string = |i: &mut usize, line: &mut usize, raw: Option<usize>| {
        *i += 1;
        while *i < c.len() {
            match (c[*i], raw) {
                ('\\', None) => *i += 1,
                ('"', None) => break,
                ('"', Some(h)) if (1..=h).all(|k| c.get(*i + k) == Some(&'#')) => {
                    *i += h;
                    break;
                }
                _ => {}
            }
            if c.get(*i) == Some(&'\n') {
                *line += 1;
            }
            *i += 1;
        }
        *i += 1;
    };
    while i < c.len() {
        let ch = c[i];
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && c.get(i + 1) == Some(&'/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && c.get(i + 1) == Some(&'*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 1;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 1;
                    if depth == 0 {
                        i += 1;
                        break;
                    }
                } else if c[i] == '\n' {
                    line += 1;
                }
                i += 1;
            }
        } else if ch == '"' {
            string(&mut i, &mut line, None);
        } else if ch == '\'' {
            // A character literal ('x', '\n', '\u{..}') or a lifetime ('a).
            if c.get(i + 1) == Some(&'\\') {
                i += 2;
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
            } else if c.get(i + 2) == Some(&'\'') {
                i += 3;
            } else {
                i += 1;
                while i < c.len() && ident(c[i]) {
                    i += 1;
                }
            }
        } else if ident(ch) {
            let start = i;
            while i < c.len() && ident(c[i]) {
                i += 1;
            }
            let word: String = c[start..i].iter().collect();
            let prefix = matches!(word.as_str(), "r" | "b" | "br" | "c" | "cr");
            if prefix && c.get(i) == Some(&'"') {
                let raw = word.contains('r').then_some(0);
                string(&mut i, &mut line, raw);
            } else if prefix && word.contains('r') && c.get(i) == Some(&'#') {
                let h = c[i..].iter().take_while(|x| **x == '#').count();
                if c.get(i + h) == Some(&'"') {
                    i += h;
                    string(&mut i, &mut line, Some(h));
                } else {
                    // A raw identifier: r#type.
                    let s = i + 1;
                    i = s;
                    while i < c.len() && ident(c[i]) {
                        i += 1;
                    }
                    out.push((Tok::Id(c[s..i].iter().collect()), line));
                }
            } else {
                out.push((Tok::Id(word), line));
            }
        } else if ch == ':' && c.get(i + 1) == Some(&':') {
            out.push((Tok::P("::"), line));
            i += 2;
        } else {
            const PUNCT: &[&str] = &[
                "#", "[", "]", "(", ")", "{", "}", ";", ",", "*", "<", ">", "=", "$",
            ];
            if let Some(p) = PUNCT.iter().find(|p| p.starts_with(ch)) {
                out.push((Tok::P(p), line));
            } else {
                out.push((Tok::P("."), line));
            }
            i += 1;
        }
    }
    out
}

/// One file of a crate: its path under the crate's source folder and its text.
struct SourceFile {
    rel: String,
    text: String,
}

/// The module a file is the node of: `lib.rs`/`main.rs` the crate root, `a/mod.rs` and `a.rs`
/// module `a`, `a/b.rs` module `a::b`.
fn module_of(rel: &str) -> Vec<String> {
    let mut parts: Vec<String> = rel.split('/').map(str::to_string).collect();
    let last = parts.pop().unwrap();
    if last != "mod.rs" && !(parts.is_empty() && (last == "lib.rs" || last == "main.rs")) {
        parts.push(last.trim_end_matches(".rs").to_string());
    }
    parts
}

/// What one file uses of its crate: every path that starts with `crate::`, `super::`, `self::`,
/// a child module's name or a name a `use` bound to a module of the crate, in `use` lines and in
/// code alike, resolved to module paths, with the line. Items under `#[cfg(test)]` are skipped;
/// the child modules declared under it are returned (test-only files).
#[allow(clippy::type_complexity)]
fn paths_used(
    file: &SourceFile,
    modules: &BTreeSet<Vec<String>>,
) -> (Vec<(Vec<String>, usize)>, Vec<Vec<String>>) {
    let toks = tokens(&file.text);
    let base = module_of(&file.rel);
    let (mut used, mut test_only) = (Vec::new(), Vec::new());
    // Inline modules open here: (name, brace depth inside it).
    let mut inline: Vec<(String, i32)> = Vec::new();
    let mut bound: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let (mut depth, mut i) = (0i32, 0usize);
    let id = |k: usize| match toks.get(k) {
        Some((Tok::Id(s), _)) => Some(s.as_str()),
        _ => None,
    };
    let p = |k: usize| match toks.get(k) {
        Some((Tok::P(s), _)) => Some(*s),
        _ => None,
    };
    while i < toks.len() {
        let here: Vec<String> = base
            .iter()
            .cloned()
            .chain(inline.iter().map(|(n, _)| n.clone()))
            .collect();
        let resolve = |path: &[String]| -> Option<Vec<String>> {
            let first = path[0].as_str();
            let (start, rest): (Vec<String>, &[String]) = match first {
                "crate" => (vec![], &path[1..]),
                "self" => (here.clone(), &path[1..]),
                "super" => {
                    let n = path.iter().take_while(|s| *s == "super").count();
                    (here[..here.len().saturating_sub(n)].to_vec(), &path[n..])
                }
                _ => {
                    if let Some(b) = bound.get(first) {
                        (b.clone(), &path[1..])
                    } else {
                        let child: Vec<String> =
                            here.iter().cloned().chain([first.to_string()]).collect();
                        if !modules.contains(&child) {
                            return None;
                        }
                        (here.clone(), path)
                    }
                }
            };
            Some(start.into_iter().chain(rest.iter().cloned()).collect())
        };
        match (&toks[i].0, p(i + 1), id(i + 1)) {
            (Tok::P("#"), Some("["), _)
                if id(i + 2) == Some("cfg")
                    && id(i + 4) == Some("test")
                    && p(i + 5) == Some(")") =>
            {
                // Skip the attribute, any further attributes, then the item.
                i += 7;
                while p(i) == Some("#") {
                    let mut d = 0;
                    loop {
                        match p(i) {
                            Some("[") => d += 1,
                            Some("]") => d -= 1,
                            _ => {}
                        }
                        i += 1;
                        if d == 0 && p(i - 1) == Some("]") {
                            break;
                        }
                    }
                }
                if id(i) == Some("mod") || (id(i) == Some("pub") && id(i + 1) == Some("mod")) {
                    let k = if id(i) == Some("mod") { i + 1 } else { i + 2 };
                    if p(k + 1) == Some(";") {
                        test_only.push(
                            here.iter()
                                .cloned()
                                .chain([id(k).unwrap().into()])
                                .collect(),
                        );
                    }
                }
                let (mut d, mut block) = (0i32, false);
                while i < toks.len() {
                    match &toks[i].0 {
                        Tok::P("{") | Tok::P("(") | Tok::P("[") => {
                            block |= p(i) == Some("{") && d == 0;
                            d += 1;
                        }
                        Tok::P("}") | Tok::P(")") | Tok::P("]") => {
                            d -= 1;
                            if d < 0 {
                                break; // the enclosing block closes: not ours
                            }
                        }
                        Tok::P(";") if d == 0 => {
                            i += 1;
                            break;
                        }
                        Tok::P(",") if d == 0 && !block => {
                            i += 1;
                            break;
                        }
                        _ => {}
                    }
                    i += 1;
                    if block && d == 0 {
                        break;
                    }
                }
                continue;
            }
            (Tok::Id(m), _, Some(name)) if m == "mod" => {
                if p(i + 2) == Some("{") {
                    inline.push((name.to_string(), depth + 1));
                    depth += 1;
                    i += 3;
                } else {
                    i += 2;
                }
                continue;
            }
            (Tok::Id(u), _, _) if u == "use" => {
                // A use tree up to its `;`: every leaf path, and the names it binds.
                let mut k = i + 1;
                let mut stack: Vec<Vec<String>> = vec![vec![]];
                let mut cur: Vec<String> = vec![];
                let line = toks[i].1;
                let mut leaves: Vec<(Vec<String>, String)> = vec![];
                while k < toks.len() && p(k) != Some(";") {
                    let prefix = stack.last().unwrap().clone();
                    match &toks[k].0 {
                        Tok::Id(s) if s == "as" => {
                            let full: Vec<String> = prefix.iter().chain(&cur).cloned().collect();
                            leaves.push((full, id(k + 1).unwrap_or("_").into()));
                            cur.clear();
                            k += 1;
                        }
                        Tok::Id(s) => cur.push(s.clone()),
                        Tok::P("{") => {
                            stack.push(prefix.iter().chain(&cur).cloned().collect());
                            cur.clear();
                        }
                        Tok::P(",") | Tok::P("}") => {
                            if !cur.is_empty() {
                                let full: Vec<String> =
                                    prefix.iter().chain(&cur).cloned().collect();
                                let name = cur.last().unwrap().clone();
                                leaves.push((full, name));
                                cur.clear();
                            }
                            if p(k) == Some("}") {
                                stack.pop();
                            }
                        }
                        Tok::P("*") => {
                            leaves.push((prefix.iter().chain(&cur).cloned().collect(), "*".into()));
                            cur.clear();
                        }
                        _ => {}
                    }
                    k += 1;
                }
                if !cur.is_empty() {
                    let name = cur.last().unwrap().clone();
                    leaves.push((cur.clone(), name));
                }
                let mut binds = vec![];
                for (mut path, name) in leaves {
                    if path.last().is_some_and(|s| s == "self") {
                        path.pop();
                    }
                    if path.is_empty() {
                        continue;
                    }
                    if let Some(abs) = resolve(&path) {
                        if modules.contains(&abs) && name != "*" {
                            binds.push((
                                if name == "self" {
                                    abs.last().cloned().unwrap_or_default()
                                } else {
                                    name
                                },
                                abs.clone(),
                            ));
                        }
                        used.push((abs, line));
                    }
                }
                bound.extend(binds);
                i = k + 1;
                continue;
            }
            (Tok::Id(first), Some("::"), _)
                if !matches!(p(i.wrapping_sub(1)), Some("::"))
                    && id(i.wrapping_sub(1)) != Some("in") =>
            {
                let mut path = vec![first.clone()];
                let mut k = i + 1;
                while p(k) == Some("::") {
                    match id(k + 1) {
                        Some(s) => path.push(s.to_string()),
                        None => break,
                    }
                    k += 2;
                }
                if let Some(abs) = resolve(&path) {
                    used.push((abs, toks[i].1));
                }
                i = k;
                continue;
            }
            (Tok::P("{"), _, _) => depth += 1,
            (Tok::P("}"), _, _) => {
                if inline.last().is_some_and(|(_, d)| *d == depth) {
                    inline.pop();
                }
                depth -= 1;
            }
            _ => {}
        }
        i += 1;
    }
    (used, test_only)
}

/// The import cycles between the files of one crate: for every file on a cycle, the shortest
/// cycle through it (each cycle once), as `a.rs:LINE -> b.rs:LINE -> a.rs`, the line where each
/// file uses the next.
fn file_cycles(files: &[SourceFile]) -> Vec<String> {
    let files: Vec<&SourceFile> = files
        .iter()
        .filter(|f| !f.rel.ends_with("tests.rs"))
        .collect();
    let mut modules: BTreeSet<Vec<String>> = files.iter().map(|f| module_of(&f.rel)).collect();
    let node_of: BTreeMap<Vec<String>, &str> = files
        .iter()
        .map(|f| (module_of(&f.rel), f.rel.as_str()))
        .collect();
    let mut edges: BTreeMap<&str, BTreeMap<&str, usize>> = BTreeMap::new();
    let mut test_only = BTreeSet::new();
    let mut used_all = Vec::new();
    for f in &files {
        let (used, tests) = paths_used(f, &modules);
        test_only.extend(tests);
        used_all.push((f.rel.as_str(), used));
    }
    modules.retain(|m| !test_only.contains(m));
    for (from, used) in used_all {
        if test_only.contains(&module_of(from)) {
            continue;
        }
        for (abs, line) in used {
            // The file of the longest module prefix: `crate::a::Item` is a.rs, `crate::Item` lib.rs.
            let to = (0..=abs.len())
                .rev()
                .find_map(|n| {
                    node_of
                        .get(&abs[..n])
                        .filter(|_| modules.contains(&abs[..n]))
                })
                .copied();
            if let Some(to) = to.filter(|t| *t != from) {
                edges.entry(from).or_default().entry(to).or_insert(line);
            }
        }
    }
    let mut cycles: Vec<Vec<&str>> = Vec::new();
    for &start in edges.keys() {
        // Breadth-first from start's successors back to start: the shortest cycle through it.
        let mut prev: BTreeMap<&str, &str> = BTreeMap::new();
        let mut queue = std::collections::VecDeque::from([start]);
        let mut found = None;
        while let Some(n) = queue.pop_front() {
            for &m in edges
                .get(n)
                .map(|e| e.keys().collect::<Vec<_>>())
                .unwrap_or_default()
            {
                if m == start {
                    found = Some(n);
                    break;
                }
                if let std::collections::btree_map::Entry::Vacant(e) = prev.entry(m) {
                    e.insert(n);
                    queue.push_back(m);
                }
            }
            if found.is_some() {
                break;
            }
        }
        if let Some(mut n) = found {
            let mut cycle = vec![n];
            while n != start {
                n = prev[n];
                cycle.push(n);
            }
            cycle.reverse();
            // One rotation for each cycle: start from its least file.
            let k = (0..cycle.len()).min_by_key(|&k| cycle[k]).unwrap();
            cycle.rotate_left(k);
            if !cycles.contains(&cycle) {
                cycles.push(cycle);
            }
        }
    }
    cycles
        .iter()
        .map(|c| {
            let mut s = String::new();
            for (k, a) in c.iter().enumerate() {
                let b = c[(k + 1) % c.len()];
                s += &format!("{a}:{} -> ", edges[a][b]);
            }
            s + c[0]
        })
        .collect()
}

/// The non-test `.rs` files of one crate's source folder.
fn crate_sources(src: &Path) -> Vec<SourceFile> {
    rust_files(src)
        .into_iter()
        .map(|f| SourceFile {
            rel: f
                .strip_prefix(src)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/"),
            text: std::fs::read_to_string(&f).unwrap(),
        })
        .collect()
}

/// Files, not modules, are the nodes: a cycle between two files means neither can be read,
/// tested or moved without the other. One test per crate so that each crate's result shows.
macro_rules! no_file_cycles {
    ($($test:ident: $dir:literal),* $(,)?) => {$(
        #[test]
        fn $test() {
            let cycles = file_cycles(&crate_sources(&root().join($dir)));
            assert!(
                cycles.is_empty(),
                "{}: {} import cycle(s) between files (the line where each file uses the next); \
                 move what both use into a file that uses neither:\n{}",
                $dir,
                cycles.len(),
                cycles.join("\n")
            );
        }
    )*};
}

no_file_cycles!(
    no_file_cycles_in_stencil_io: "crates/stencil-io/src",
    no_file_cycles_in_stencil_geom: "crates/stencil-geom/src",
    no_file_cycles_in_stencil_gcode: "crates/stencil-gcode/src",
    no_file_cycles_in_stencil_grbl: "crates/stencil-grbl/src",
    no_file_cycles_in_stencil_hpgl: "crates/stencil-hpgl/src",
    no_file_cycles_in_stencil_core: "crates/stencil-core/src",
    no_file_cycles_in_stencil_studio: "crates/stencil-studio/src",
    no_file_cycles_in_the_binary: "src",
);

/// Every crate's source folder has a test above: a new crate gets one.
#[test]
fn every_crate_is_checked_for_file_cycles() {
    let this = std::fs::read_to_string(root().join("tests/it/architecture.rs")).unwrap();
    for e in std::fs::read_dir(root().join("crates")).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(
            this.contains(&format!("\"crates/{name}/src\"")),
            "crates/{name}: no no_file_cycles test; add one"
        );
    }
}

/// The reader of edges itself, on a made-up crate: each kind of path makes its edge, and what
/// must not (a `mod` line, comments, strings, test code) makes none.
#[test]
fn file_cycles_finds_each_kind_of_edge() {
    let crate_of = |files: &[(&str, &str)]| {
        file_cycles(
            &files
                .iter()
                .map(|(rel, text)| SourceFile {
                    rel: rel.to_string(),
                    text: text.to_string(),
                })
                .collect::<Vec<_>>(),
        )
    };
    // Declaring children is no edge; neither are comments, strings or test code.
    let quiet = [
        ("lib.rs", "mod a;\nmod b;\n// crate::a::X\n"),
        (
            "a.rs",
            "fn f() { let s = \"crate::b::Y super::Z\"; }\n#[cfg(test)]\nmod tests { use crate::b::*; }\n",
        ),
        ("b.rs", "/* super::a::X */ pub fn g() -> u8 { crate::a::f(); 0 }\n"),
    ];
    assert_eq!(crate_of(&quiet), Vec::<String>::new());
    // A child using an item of lib.rs, lib.rs using the child's: a cycle.
    let up = [
        ("lib.rs", "mod a;\npub struct T;\nfn h() { a::f(); }\n"),
        ("a.rs", "pub fn f() -> super::T { super::T }\n"),
    ];
    assert_eq!(crate_of(&up), ["a.rs:1 -> lib.rs:3 -> a.rs"]);
    // Through a `use` group, `self::`, a bound module name, and in a nested folder.
    let nested = [
        ("lib.rs", "mod s;\n"),
        (
            "s/mod.rs",
            "mod x;\nmod y;\nuse self::{x::A, y};\nfn k() { y::f(); }\n",
        ),
        ("s/x.rs", "pub struct A;\n"),
        ("s/y.rs", "\n\nfn f() { let _ = super::x::A; }\n"),
        ("s/z.rs", ""),
    ];
    assert_eq!(crate_of(&nested), Vec::<String>::new());
    let mut back = nested;
    back[2] = ("s/x.rs", "pub struct A;\nfn g() { crate::s::y::f() }\n");
    back[3] = ("s/y.rs", "use super::x;\n");
    assert_eq!(
        crate_of(&back),
        ["s/x.rs:2 -> s/y.rs:1 -> s/x.rs"],
        "x uses y inline and y binds x"
    );
}
