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
        (
            "stencil-core",
            BTreeSet::from(["stencil-io", "stencil-geom", "stencil-gcode"]),
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
        // A gobo: placed on the traced stencil, its polarity worded as the masks word it.
        ("gobo", &["vector", "export"][..]),
        (
            "request",
            &[
                "bridge", "export", "fit", "material", "raster", "tone", "units", "vector",
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
        // driver). Each may use the stages and those before it, never one after it.
        let facade = ["pipeline", "inputs", "resolve", "driver", "layers"];
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
