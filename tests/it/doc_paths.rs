//! Every repository path a Markdown file names exists (issue 25 item 8): the README and the
//! pages under docs/ named paths that moved in the workspace split, and nothing caught it.
//!
//! A path counts when it starts with one of the repository's top folders (`crates/`, `src/`,
//! `tests/`, `benches/`, `profiles/`, `samples/`, `docs/`) right after a character that cannot
//! be part of a path (a space, a backquote, a bracket), so `./profiles/...` (the user's folder) and
//! `~/.config/...` are not taken for repository paths. Markdown under target/ and hidden
//! folders is not the repository's own.

use std::path::{Path, PathBuf};

const TOP: [&str; 7] = [
    "crates/",
    "src/",
    "tests/",
    "benches/",
    "profiles/",
    "samples/",
    "docs/",
];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The repository's Markdown files, outside target/, out/ and hidden folders.
fn markdown(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if p.is_dir() {
            if !(name.starts_with('.') || name == "target" || name == "out") {
                markdown(&p, out);
            }
        } else if name.ends_with(".md") {
            out.push(p);
        }
    }
}

fn path_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || "_./-".contains(c)
}

/// The repository paths a text names, with their line numbers (trailing sentence punctuation
/// left off).
fn named_paths(text: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    for (n, line) in text.lines().enumerate() {
        for (i, _) in line.char_indices() {
            let rest = &line[i..];
            let after_boundary = line[..i]
                .chars()
                .next_back()
                .is_none_or(|c| !(path_char(c) || c == '~'));
            if after_boundary && TOP.iter().any(|t| rest.starts_with(t)) {
                let end = rest.find(|c: char| !path_char(c)).unwrap_or(rest.len());
                let p = rest[..end].trim_end_matches(['.', ',', ':', ';']);
                found.push((n + 1, p.to_string()));
            }
        }
    }
    found
}

#[test]
fn the_scanner_finds_repository_paths_and_only_those() {
    let text = "see `src/main.rs`, [x](docs/a.md) and crates/stencil-io/src/read.rs.\n\
                put it in ./profiles/materials/NAME.toml or ~/.config/stencil; out/rings/x";
    let got: Vec<String> = named_paths(text).into_iter().map(|(_, p)| p).collect();
    assert_eq!(
        got,
        ["src/main.rs", "docs/a.md", "crates/stencil-io/src/read.rs"]
    );
}

#[test]
fn every_path_a_markdown_file_names_exists() {
    let root = root();
    let mut files = Vec::new();
    markdown(&root, &mut files);
    files.sort();
    assert!(
        files.iter().any(|f| f.ends_with("README.md")),
        "no README.md found under {}",
        root.display()
    );
    let (mut checked, mut missing) = (0, Vec::new());
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        for (line, p) in named_paths(&text) {
            checked += 1;
            if !root.join(&p).exists() {
                let rel = f.strip_prefix(&root).unwrap_or(f);
                missing.push(format!("{}:{line}: {p}", rel.display()));
            }
        }
    }
    assert!(
        checked >= 20,
        "only {checked} paths found in {files:?}: is the scanner still finding them?"
    );
    assert!(
        missing.is_empty(),
        "paths named in Markdown that do not exist:\n{}",
        missing.join("\n")
    );
}
