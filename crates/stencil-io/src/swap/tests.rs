//! The swap stopped at every point, as `kill -9` would stop it, then recovered (and recovery
//! itself stopped and recovered again): the folder must end up exactly as before or exactly as
//! the run meant, with a person's files untouched and no hidden file left.

use std::collections::BTreeMap;

use super::*;

const OWNED: &[&str] = &[
    "stencil.png",
    "stencil.svg",
    "stencil.gcode",
    "report.json",
    "mask.png",
    // Names in folders of their own, as a layered set has them.
    "layer-1/stencil.png",
    "layer-1/report.json",
    "layer-2/stencil.png",
];

/// The owned names' folders in a snapshot as the swap leaves them: there exactly when a file is
/// in them (an emptied one is removed), in the folder and in `previous/`.
fn fix_folders(map: &mut BTreeMap<String, Option<Vec<u8>>>) {
    for f in [
        "layer-1/",
        "layer-2/",
        "previous/layer-1/",
        "previous/layer-2/",
    ] {
        if map.keys().any(|k| k.starts_with(f) && k != f) {
            map.insert(f.to_string(), None);
        } else {
            map.remove(f);
        }
    }
}

/// Every file (with its bytes) and every folder under `dir`.
fn snapshot(dir: &Path) -> BTreeMap<String, Option<Vec<u8>>> {
    let mut out = BTreeMap::new();
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, Option<Vec<u8>>>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let e = e.unwrap();
            let rel = e.path().strip_prefix(root).unwrap().display().to_string();
            if e.file_type().unwrap().is_dir() {
                out.insert(rel + "/", None);
                walk(root, &e.path(), out);
            } else {
                out.insert(rel, Some(std::fs::read(e.path()).unwrap()));
            }
        }
    }
    walk(dir, dir, &mut out);
    out
}

fn write(dir: &Path, rel: &str, bytes: &[u8]) {
    let p = dir.join(rel);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(p, bytes).unwrap();
}

/// A small deterministic generator (xorshift64*): the fuzz loop is seeded and repeatable.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn subset<'a>(&mut self, of: &[&'a str]) -> Vec<&'a str> {
        of.iter().copied().filter(|_| self.below(2) == 0).collect()
    }
}

/// Whether the snapshot is the expected old or new state.
fn which(
    got: &BTreeMap<String, Option<Vec<u8>>>,
    old: &BTreeMap<String, Option<Vec<u8>>>,
    new: &BTreeMap<String, Option<Vec<u8>>>,
) -> Option<&'static str> {
    if got == old {
        Some("old")
    } else if got == new {
        Some("new")
    } else {
        None
    }
}

struct Case {
    dir: tempfile::TempDir,
    old: BTreeMap<String, Option<Vec<u8>>>,
    new: BTreeMap<String, Option<Vec<u8>>>,
    files: Vec<(String, Vec<u8>)>,
    aside: bool,
}

/// A folder with a person's files, an earlier set, maybe a `previous/`, orphan temps; and a run
/// (a replacement or a failed run's set-aside) with its expected end state.
fn case(rng: &mut Rng) -> Case {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let seed = rng.next();
    write(d, "notes.txt", format!("mine {seed}").as_bytes());
    if rng.below(2) == 0 {
        write(d, "send-journal.json", b"{}");
    }
    let earlier = rng.subset(OWNED);
    for n in &earlier {
        write(d, n, format!("old {n} {seed}").as_bytes());
    }
    let prev = if rng.below(3) == 0 {
        rng.subset(OWNED)
    } else {
        vec![]
    };
    for n in &prev {
        write(
            d,
            &format!("previous/{n}"),
            format!("older {n} {seed}").as_bytes(),
        );
    }
    let person_in_prev = !prev.is_empty() && rng.below(2) == 0;
    if person_in_prev {
        write(d, "previous/mine.txt", b"kept");
    }
    // An orphan temp of an older stencil (no lock held), as the issue found seven of.
    write(d, ".stencil-Ab12.tmp", b"orphan");
    let mut old = snapshot(d);
    old.remove(".stencil-Ab12.tmp");
    let aside = rng.below(4) == 0;
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    let mut new = old.clone();
    for n in OWNED {
        new.remove(*n);
        new.remove(&format!("previous/{n}"));
    }
    if aside {
        if earlier.is_empty() {
            new = old.clone();
        } else {
            new.insert("previous/".into(), None);
            for n in &earlier {
                new.insert(
                    format!("previous/{n}"),
                    Some(format!("old {n} {seed}").into_bytes()),
                );
            }
        }
    } else {
        let mut names = rng.subset(OWNED);
        if names.is_empty() {
            names.push("report.json");
        }
        for n in names {
            let bytes = format!("new {n} {seed}").into_bytes();
            new.insert(n.to_string(), Some(bytes.clone()));
            files.push((n.to_string(), bytes));
        }
        if !person_in_prev {
            new.remove("previous/");
        }
    }
    fix_folders(&mut new);
    if aside && earlier.is_empty() {
        // Nothing to move: the run leaves the folder as it was.
    } else if !new
        .keys()
        .any(|k| k.starts_with("previous/") && k != "previous/")
    {
        new.remove("previous/");
    }
    Case {
        dir,
        old,
        new,
        files,
        aside,
    }
}

fn run(c: &Case, hook: Hook) -> Result<(), Stop> {
    if c.aside {
        set_aside_hooked(c.dir.path(), OWNED, hook).map(|_| ())
    } else {
        replace_all_hooked(c.dir.path(), &c.files, OWNED, hook).map(|_| ())
    }
}

/// Points a whole run passes.
fn points(c: &Case) -> usize {
    let probe = case_like(c);
    let mut n = 0;
    run(&probe, &mut |k| {
        n = k;
        true
    })
    .unwrap_or_else(|_| panic!("an unhooked run succeeds"));
    n
}

/// A fresh copy of a case's folder (same start state).
fn case_like(c: &Case) -> Case {
    let dir = tempfile::tempdir().unwrap();
    for (k, v) in &c.old {
        match v {
            Some(bytes) => write(dir.path(), k, bytes),
            None => std::fs::create_dir_all(dir.path().join(k)).unwrap(),
        }
    }
    write(dir.path(), ".stencil-Ab12.tmp", b"orphan");
    Case {
        dir,
        old: c.old.clone(),
        new: c.new.clone(),
        files: c.files.clone(),
        aside: c.aside,
    }
}

#[test]
fn whole_runs_reach_the_new_state() {
    let mut rng = Rng(0x5eed);
    for _ in 0..50 {
        let c = case(&mut rng);
        run(&c, &mut |_| true).unwrap_or_else(|_| panic!("runs"));
        assert_eq!(snapshot(c.dir.path()), c.new, "aside {}", c.aside);
    }
}

/// The fuzz: seeded folders, each run stopped at every point it passes, then recovery stopped at
/// a random point and recovered again. Counts are printed (`--nocapture`).
#[test]
fn a_kill_at_any_point_leaves_the_old_or_the_new_set() {
    let mut rng = Rng(0x00c0_ffee);
    let (mut kills, mut nested, mut olds, mut news) = (0usize, 0usize, 0usize, 0usize);
    for _ in 0..40 {
        let c = case(&mut rng);
        let total = points(&c);
        for k in 1..=total {
            let t = case_like(&c);
            let r = run(&t, &mut |n| n < k);
            assert!(
                matches!(r, Err(Stop::Hook)),
                "stops at point {k} of {total}"
            );
            kills += 1;
            // The next run (or a reader) recovers; sometimes it is killed too.
            if rng.below(2) == 0 {
                let j = 1 + rng.below(8) as usize;
                let _ = recover_hooked(t.dir.path(), OWNED, &mut |n| n < j);
                nested += 1;
            }
            recover_hooked(t.dir.path(), OWNED, &mut |_| true)
                .unwrap_or_else(|_| panic!("recovers"));
            let got = snapshot(t.dir.path());
            match which(&got, &t.old, &t.new) {
                Some("old") => olds += 1,
                Some(_) => news += 1,
                None => panic!(
                    "stopped at {k} of {total} (aside {}): a mix\ngot {:?}\nold {:?}\nnew {:?}",
                    t.aside,
                    got.keys().collect::<Vec<_>>(),
                    t.old.keys().collect::<Vec<_>>(),
                    t.new.keys().collect::<Vec<_>>()
                ),
            }
            // And a run after it succeeds and leaves nothing hidden.
            run(&t, &mut |_| true).unwrap_or_else(|_| panic!("runs after recovery"));
            let after = snapshot(t.dir.path());
            assert!(
                !after.keys().any(|k| k.starts_with(".stencil")),
                "{after:?}"
            );
        }
    }
    println!("swap fuzz: {kills} kill points, {nested} recoveries killed too; {olds} ended old, {news} new");
    assert!(kills > 500 && olds > 0 && news > 0);
}

#[test]
fn what_is_not_a_file_is_refused_before_anything_moves() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("stencil.svg")).unwrap();
    write(dir.path(), "report.json", b"old");
    let files = vec![("report.json".to_string(), b"new".to_vec())];
    let e = replace_all(dir.path(), &files, OWNED)
        .unwrap_err()
        .to_string();
    assert!(e.contains("stencil.svg: is a folder"), "{e}");
    assert_eq!(
        std::fs::read(dir.path().join("report.json")).unwrap(),
        b"old"
    );
    assert!(!dir.path().join(SWAP_DIR).exists());
}

#[test]
fn a_second_writer_is_told_the_folder_is_busy() {
    let dir = tempfile::tempdir().unwrap();
    let held =
        lock_folder(dir.path(), std::time::Duration::ZERO).unwrap_or_else(|_| panic!("locks"));
    let files = vec![("report.json".to_string(), b"new".to_vec())];
    let e = replace_all(dir.path(), &files, OWNED)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("another stencil run is writing this folder now"),
        "{e}"
    );
    drop(held);
    replace_all(dir.path(), &files, OWNED).unwrap();
}

/// A plan is a file in the folder, and a received folder may carry a crafted one: a plan that
/// would move a person's file (or reach out of the folder) is not run, and nothing moves.
#[test]
fn a_plan_naming_other_files_is_not_run() {
    for line in [
        "R\tnotes.txt\t.stencil-swap/old/notes.txt",
        "R\t../outside/report.json\t.stencil-swap/old/report.json",
        "R\treport.json\t/tmp/report.json",
        "M\t/tmp/x",
    ] {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "notes.txt", b"mine");
        write(dir.path(), "report.json", b"theirs");
        write(
            dir.path(),
            ".stencil-swap/plan",
            format!("{line}\n").as_bytes(),
        );
        let before = snapshot(dir.path());
        let e = recover(dir.path(), OWNED).unwrap_err().to_string();
        assert!(e.contains("not a plan stencil wrote"), "{line}: {e}");
        assert_eq!(snapshot(dir.path()), before, "{line}");
    }
}

/// A layer's file or folder is settled with the set folder around it, outermost first; a folder
/// whose name is not an owned folder stops the walk.
#[test]
fn the_set_around_a_layers_path_is_settled_first() {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("set");
    write(&set, "layer-1/stencil.png", b"x");
    let around = |p: &Path| folders_around(p, OWNED);
    assert_eq!(
        around(&set.join("layer-1/stencil.png")),
        vec![set.clone(), set.join("layer-1")]
    );
    assert_eq!(
        around(&set.join("layer-1")),
        vec![set.clone(), set.join("layer-1")]
    );
    // A layer folder a killed run has not made yet counts too.
    assert_eq!(
        around(&set.join("layer-2/stencil.png")),
        vec![set.clone(), set.join("layer-2")]
    );
    assert_eq!(around(&set.join("stencil.png")), vec![set.clone()]);
    assert_eq!(around(&set.join("notes/a.txt")), vec![set.join("notes")]);
}

/// A link where the swap needs its own folder or file is refused, naming it, and nothing is
/// moved through it or written to where it points.
#[cfg(unix)]
#[test]
fn a_link_in_the_swap_folder_is_refused_and_never_followed() {
    for (link, plan) in [
        (
            "old",
            "M\t.stencil-swap/old\nR\treport.json\t.stencil-swap/old/report.json\n",
        ),
        ("new", "R\t.stencil-swap/new/report.json\treport.json\n"),
        ("done", "R\treport.json\t.stencil-swap/old/report.json\n"),
        ("plan", ""),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let (d, other) = (dir.path().join("d"), dir.path().join("other"));
        write(&d, "report.json", b"mine");
        write(&other, "report.json", b"theirs");
        write(&other, "plan", plan.as_bytes());
        if link != "plan" {
            write(&d, ".stencil-swap/plan", plan.as_bytes());
        }
        let target = match link {
            "done" => other.join("report.json"),
            "plan" => other.join("plan"),
            _ => other.clone(),
        };
        std::fs::create_dir_all(d.join(SWAP_DIR)).unwrap();
        std::os::unix::fs::symlink(&target, d.join(SWAP_DIR).join(link)).unwrap();
        let before = snapshot(&other);
        let e = recover(&d, OWNED).unwrap_err().to_string();
        assert!(
            e.contains(&format!(".stencil-swap/{link}: is a symbolic link")),
            "{link}: {e}"
        );
        assert_eq!(snapshot(&other), before, "{link}");
        assert_eq!(
            std::fs::read(d.join("report.json")).unwrap(),
            b"mine",
            "{link}"
        );
    }
}

/// The folders of the owned names, found with one look per name, are those of every name's
/// every folder in the order first met (outermost first): names in any order, nested and
/// repeated folders, a folder met first as a name's own and later inside a deeper one.
#[test]
fn owned_folders_are_every_names_folders_once_in_order() {
    let names = [
        "a/x.png",
        "top.png",
        "b/c/d/y.png",
        "a/q/z.png",
        "b/c/w.png",
        "a/x.png",
        "b/v.png",
        "e//f.png",
        "a/q/r/s.png",
        "b/c/d/y2.png",
    ];
    let mut want: Vec<&str> = Vec::new();
    for n in names {
        for a in ancestors(n) {
            if !want.contains(&a) {
                want.push(a);
            }
        }
    }
    want.sort_by_key(|f| f.matches('/').count());
    assert_eq!(owned_folders(&names), want);
    assert_eq!(
        owned_folders(&names)[..4],
        ["a", "b", "e", "b/c"],
        "outermost first, then in the order met"
    );
}
