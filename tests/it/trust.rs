//! Issue 25, items 1 to 5: nothing lost, nothing stale, nothing read that was not asked for.
//! `make` killed at every step of its folder swap; a failed run's earlier set moved aside; outputs
//! refused over inputs and over what is not a file; FIFOs, devices and huge files refused at once;
//! received folders naming materials, never files. Every check reads the files a person would.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use crate::common::{files_in, ink_png, s, stderr, stencil, tmp};

const OWNED: &[&str] = stencil_core::pipeline::OUTPUT_NAMES;

/// Run `stencil` with a guard against a hang: a run still going after a minute is killed and the
/// test fails (the reads under test must return at once; this only keeps a regression from
/// hanging the suite).
fn stencil_guarded(args: &[&str]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_stencil"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    for _ in 0..600 {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    let _ = child.kill();
    panic!("stencil {args:?} still running after a minute: it blocked");
}

fn refused(o: &Output, needles: &[&str]) -> String {
    let err = stderr(o);
    assert!(!o.status.success(), "should fail: {err}");
    assert!(o.status.code().is_some(), "killed: {err}");
    assert!(!err.contains("panicked"), "panic: {err}");
    for n in needles {
        assert!(err.contains(n), "message should contain {n:?}: {err}");
    }
    err
}

/// A small picture: a ring (an island to bridge) of radius `r` px in a 60 × 60 square.
fn ring(path: &Path, r: f64) {
    ink_png(path, 60, 60, |x, y| {
        let d = ((x as f64 - 30.0).powi(2) + (y as f64 - 30.0).powi(2)).sqrt();
        (d - r).abs() < 4.0
    });
}

/// A ring picture in `d` and a `make` of it (PNG, SVG and G-code, 150 mm wide) into `d/name`.
fn made(d: &Path, name: &str) -> (PathBuf, PathBuf) {
    let pic = d.join("photo.png");
    ring(&pic, 18.0);
    let out = d.join(name);
    let ok = stencil(&[
        "make",
        s(&pic),
        "-o",
        s(&out),
        "--emit",
        "png,svg,gcode",
        "--width-mm",
        "150",
    ]);
    assert!(ok.status.success(), "{}", stderr(&ok));
    (pic, out)
}

/// The owned files of a folder and their bytes (report.json without its timings, which differ
/// from run to run).
fn owned_set(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut m = BTreeMap::new();
    for n in OWNED {
        let p = dir.join(n);
        if let Ok(b) = std::fs::read(&p) {
            let b = if *n == "report.json" {
                let mut v: serde_json::Value = serde_json::from_slice(&b).unwrap();
                v.as_object_mut().unwrap().remove("timings_ms");
                serde_json::to_vec(&v).unwrap()
            } else {
                b
            };
            m.insert(n.to_string(), b);
        }
    }
    m
}

fn hidden(dir: &Path) -> Vec<String> {
    files_in(dir)
        .into_iter()
        .filter(|n| n.starts_with(".stencil"))
        .collect()
}

/// Item 1: `make` aborted (as `kill -9` stops it: no clean-up) at every point of its swap, in a
/// debug build's fault hook. Right after the kill, the next reader (`check`) finishes or discards
/// the swap; the folder then holds the complete earlier set or the complete new set, the person's
/// file is untouched, and the next successful run leaves no hidden file.
#[test]
fn make_killed_at_every_step_of_the_swap_leaves_one_whole_set() {
    if !cfg!(debug_assertions) {
        // The fault hook exists only in debug builds (the binary is built like this test).
        return;
    }
    let dir = tmp();
    let (a, b) = (dir.path().join("a.png"), dir.path().join("b.png"));
    ring(&a, 14.0);
    ring(&b, 20.0);
    let make = |input: &Path, out: &Path, kill_at: Option<usize>| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_stencil"));
        c.args(["make", s(input), "-o", s(out), "--emit", "png,svg,gcode"]);
        c.args(["--width-mm", "60"]);
        if let Some(k) = kill_at {
            c.env("STENCIL_FAULT_SWAP_STEP", k.to_string());
        }
        c.output().unwrap()
    };
    // The sets each run writes, for comparison.
    let ref_old = dir.path().join("ref-old");
    let ref_new = dir.path().join("ref-new");
    assert!(make(&a, &ref_old, None).status.success());
    assert!(make(&b, &ref_new, None).status.success());
    let (old, new) = (owned_set(&ref_old), owned_set(&ref_new));
    assert_ne!(old, new);
    let (mut kills, mut olds, mut news) = (0, 0, 0);
    for k in 1.. {
        let out = dir.path().join(format!("out{k}"));
        std::fs::create_dir(&out).unwrap();
        for n in files_in(&ref_old) {
            std::fs::copy(ref_old.join(&n), out.join(&n)).unwrap();
        }
        std::fs::write(out.join("notes.txt"), "mine").unwrap();
        let o = make(&b, &out, Some(k));
        if o.status.success() {
            // k is past the last point: the run went through.
            assert_eq!(owned_set(&out), new);
            break;
        }
        assert!(o.status.code().is_none(), "aborted at {k}: {}", stderr(&o));
        kills += 1;
        // The next command that reads the folder settles it first.
        let c = stencil(&["check", s(&out)]);
        assert!(!stderr(&c).contains("panicked"), "{}", stderr(&c));
        let got = owned_set(&out);
        if got == old {
            olds += 1;
        } else if got == new {
            news += 1;
        } else {
            panic!(
                "killed at point {k}: a mix: {:?} (old {:?}, new {:?})",
                got.keys().collect::<Vec<_>>(),
                old.keys().collect::<Vec<_>>(),
                new.keys().collect::<Vec<_>>()
            );
        }
        assert_eq!(std::fs::read(out.join("notes.txt")).unwrap(), b"mine");
        assert_eq!(hidden(&out), Vec::<String>::new(), "killed at {k}");
        // A kill that the next `make` (not a reader) finds is settled the same way.
        let o = make(&b, &out, Some(k));
        assert!(o.status.code().is_none());
        assert!(make(&a, &out, None).status.success());
        assert_eq!(owned_set(&out), old, "after a kill at {k} and a full run");
        assert_eq!(hidden(&out), Vec::<String>::new());
        assert_eq!(std::fs::read(out.join("notes.txt")).unwrap(), b"mine");
    }
    println!("make killed at {kills} points: {olds} left the earlier set, {news} the new one");
    assert!(kills > 20 && olds > 0 && news > 0, "{kills} {olds} {news}");
}

/// Item 2: a run that fails leaves nothing that can be taken for its result. The earlier set is
/// moved to previous/ (the error says which files, made when, and where); `send` finds no job;
/// the next successful run deletes previous/'s stencil files but keeps a person's file there.
#[test]
fn a_failed_run_moves_the_earlier_job_aside() {
    let dir = tmp();
    let (pic, out) = made(dir.path(), "out");
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let earlier = std::fs::read(out.join("stencil.gcode")).unwrap();
    let o = stencil(&[
        "make",
        s(&pic),
        "-o",
        s(&out),
        "--emit",
        "png,svg,gcode",
        "--width-mm",
        "500",
    ]);
    let err = refused(
        &o,
        &[
            "does not fit",
            "nothing of this run was written",
            "previous",
            "stencil.gcode",
            "made 2",
        ],
    );
    assert!(err.contains(s(&out)), "{err}");
    assert!(!out.join("stencil.gcode").exists(), "{:?}", files_in(&out));
    assert_eq!(
        std::fs::read(out.join("previous/stencil.gcode")).unwrap(),
        earlier
    );
    assert_eq!(std::fs::read(out.join("notes.txt")).unwrap(), b"mine");
    let send = stencil(&["send", s(&out.join("stencil.gcode")), "--dry-run"]);
    assert!(!send.status.success(), "the old job was streamed");
    // A person's file in previous/ is kept when the next good run clears it.
    std::fs::write(out.join("previous/why.txt"), "kept").unwrap();
    let ok = stencil(&["make", s(&pic), "-o", s(&out), "--emit", "png,svg,gcode"]);
    assert!(ok.status.success(), "{}", stderr(&ok));
    assert_eq!(files_in(&out.join("previous")), vec!["why.txt".to_string()]);
    // With nothing of a person's in it, previous/ goes too.
    let o = stencil(&[
        "make",
        s(&pic),
        "-o",
        s(&out),
        "--width-mm",
        "500",
        "--emit",
        "png,gcode",
    ]);
    refused(&o, &["previous"]);
    std::fs::remove_file(out.join("previous/why.txt")).unwrap();
    let ok = stencil(&["make", s(&pic), "-o", s(&out)]);
    assert!(ok.status.success(), "{}", stderr(&ok));
    assert!(!out.join("previous").exists(), "{:?}", files_in(&out));
    assert_eq!(hidden(&out), Vec::<String>::new());
}

/// Item 2: `estimate`, `send` and `frame` say where a job comes from before they start (on
/// stderr, with the other notes, so that stdout keeps the result scripts read).
#[test]
fn jobs_say_where_they_come_from() {
    let dir = tmp();
    let (pic, out) = made(dir.path(), "out");
    let job = out.join("stencil.gcode");
    // The size placed on the bed, as the job's own header gives it (what is cut: the 150 mm
    // picture's ring, not its empty margin).
    let text = std::fs::read_to_string(&job).unwrap();
    let size = text
        .lines()
        .find_map(|l| l.strip_prefix("; job "))
        .and_then(|l| l.split(" at ").next())
        .expect("a `; job W x H mm at` header line")
        .to_string();
    assert!(size.ends_with(" mm") && size.contains(" x "), "{size}");
    for args in [
        vec!["estimate", s(&job)],
        vec!["send", s(&job), "--dry-run"],
        vec!["frame", s(&job), "--dry-run"],
    ] {
        let o = stencil(&args);
        // On stderr (stdout keeps the command's result), before anything else.
        let text = stderr(&o);
        let first = text.lines().next().unwrap_or("");
        for n in [
            &format!("from {}", pic.display()) as &str,
            "material cardstock",
            &size,
            "for diode-400",
            "file written 2",
        ] {
            assert!(
                first.contains(n),
                "{args:?}: {n:?} not in the first line {first:?}\n{}",
                stderr(&o)
            );
        }
    }
    let foreign = dir.path().join("other.gcode");
    std::fs::write(&foreign, "G21 G90\nG0 X1 Y1\nM2\n").unwrap();
    let o = stencil(&["estimate", s(&foreign)]);
    assert!(
        stderr(&o).contains("not written by stencil"),
        "{}",
        stderr(&o)
    );
}

/// A job's first line names its picture by its start and its end: a long name is cut in the
/// middle, so the extension stays (issue 42 item 4: it read "chelsea.pn… (41 characters)").
#[test]
fn a_long_picture_name_keeps_its_end_in_the_jobs_line() {
    let dir = tmp();
    let base = format!("chelsea_the_cat_{}_in_the_garden.png", "x".repeat(90));
    let pic = dir.path().join(&base);
    ring(&pic, 18.0);
    let out = dir.path().join("out");
    let ok = stencil(&["make", s(&pic), "-o", s(&out), "--emit", "gcode"]);
    assert!(ok.status.success(), "{}", stderr(&ok));
    let o = stencil(&["send", s(&out.join("stencil.gcode")), "--dry-run"]);
    let first = stderr(&o).lines().next().unwrap_or("").to_string();
    let from = pic.display().to_string();
    let n = from.chars().count();
    let head: String = from.chars().take(60).collect();
    let tail: String = from.chars().skip(n - 30).collect();
    assert!(
        first.contains(&format!("from {head}…{tail} ({n} characters),")),
        "{first}"
    );
    assert!(tail.ends_with("_in_the_garden.png"), "{tail}");
}

/// Item 3: no command's output replaces one of its inputs, or what is not a regular file; the
/// message names both paths, and the input is untouched.
#[test]
fn outputs_never_replace_inputs_or_what_is_not_a_file() {
    let dir = tmp();
    let d = dir.path();
    let (pic, out) = made(d, "out");
    let job = out.join("stencil.gcode");
    let svg = out.join("stencil.svg");
    let png = out.join("stencil.png");
    let bytes = |p: &Path| std::fs::read(p).unwrap();
    let (job0, svg0, png0) = (bytes(&job), bytes(&svg), bytes(&png));

    let o = stencil(&["simulate", s(&job), "-o", s(&job)]);
    refused(&o, &[s(&job), "is the input"]);
    assert_eq!(bytes(&job), job0);

    let o = stencil(&["gcode", s(&svg), "-o", s(&svg)]);
    refused(&o, &[s(&svg), "is the input"]);
    assert_eq!(bytes(&svg), svg0);

    // The folder's report.json is an input of `gcode DIR`.
    let rep = out.join("report.json");
    let o = stencil(&["gcode", s(&out), "-o", s(&rep)]);
    refused(&o, &[s(&rep), "is the input"]);

    let o = stencil(&["make", s(&png), "-o", s(&out)]);
    refused(&o, &["stencil.png would be replaced", s(&png), s(&out)]);
    assert_eq!(bytes(&png), png0);

    let o = stencil(&["tone", s(&png), "-o", s(&png)]);
    refused(&o, &["is the input", s(&png)]);
    assert_eq!(bytes(&png), png0);

    // A hard link is the same file under another name.
    let link = d.join("link.gcode");
    std::fs::hard_link(&job, &link).unwrap();
    let o = stencil(&["simulate", s(&job), "-o", s(&link)]);
    refused(&o, &["is the input"]);
    assert_eq!(bytes(&job), job0);

    // A folder where a file goes, and a file where the folder goes.
    let o = stencil(&["simulate", s(&job), "-o", s(d)]);
    refused(&o, &[s(d), "is a folder"]);
    let o = stencil(&["make", s(&pic), "-o", s(&job)]);
    refused(&o, &[s(&job), "not a folder"]);
    assert_eq!(bytes(&job), job0);

    #[cfg(unix)]
    {
        let fifo = d.join("pipe");
        assert!(Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success());
        let sock = d.join("sock");
        let _l = std::os::unix::net::UnixListener::bind(&sock).unwrap();
        use std::os::unix::fs::FileTypeExt;
        for (target, is) in [(&fifo, "a named pipe"), (&sock, "a socket")] {
            for args in [
                vec!["simulate", s(&job), "-o", s(target)],
                vec!["gcode", s(&out), "-o", s(target)],
                vec!["tone", s(&pic), "-o", s(target)],
                vec!["test-grid", "-o", s(target)],
            ] {
                let o = stencil_guarded(&args);
                refused(&o, &[s(target), is]);
            }
        }
        assert!(std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo());
        assert!(std::fs::symlink_metadata(&sock)
            .unwrap()
            .file_type()
            .is_socket());
        // One of make's own names taken by a FIFO: refused before the run, folder untouched.
        let gc = out.join("stencil.gcode");
        std::fs::remove_file(&gc).unwrap();
        assert!(Command::new("mkfifo").arg(&gc).status().unwrap().success());
        let o = stencil_guarded(&["make", s(&pic), "-o", s(&out)]);
        refused(&o, &[s(&gc), "a named pipe"]);
        assert_eq!(bytes(&svg), svg0);
    }
}

/// Item 4: every file is read through one bounded reader: FIFOs and devices are refused at once
/// (a FIFO with no writer used to block `make` forever), and each kind has a cap named in the
/// message (a sparse file stands in for a huge one).
#[test]
#[cfg(unix)]
fn fifos_devices_and_huge_files_are_refused_at_once() {
    let dir = tmp();
    let d = dir.path();
    let fifo = d.join("in.png");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let gfifo = d.join("job.gcode");
    assert!(Command::new("mkfifo")
        .arg(&gfifo)
        .status()
        .unwrap()
        .success());
    let out = d.join("out");
    let sim = d.join("sim.png");
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec!["make", s(&fifo), "-o", s(&out)],
            vec!["a named pipe", "picture"],
        ),
        (vec!["check", s(&fifo)], vec!["a named pipe"]),
        (
            vec!["estimate", s(&gfifo)],
            vec!["a named pipe", "G-code file"],
        ),
        (
            vec!["send", s(&gfifo), "--dry-run"],
            vec!["a named pipe", "G-code file"],
        ),
        (
            vec!["simulate", s(&gfifo), "-o", s(&sim)],
            vec!["a named pipe"],
        ),
        (
            vec!["estimate", "/dev/zero"],
            vec!["a device", "G-code file"],
        ),
        (vec!["make", "/dev/zero", "-o", s(&out)], vec!["a device"]),
        (
            vec!["make", s(&fifo), "-o", s(&out), "--material", s(&gfifo)],
            vec!["a named pipe", "profile"],
        ),
    ];
    for (args, needles) in cases {
        let o = stencil_guarded(&args);
        refused(&o, &needles);
    }
    let sparse = |name: &str, len: u64| {
        let p = d.join(name);
        std::fs::File::create(&p).unwrap().set_len(len).unwrap();
        p
    };
    let big_job = sparse("big.gcode", (512 << 20) + 1);
    let o = stencil_guarded(&["estimate", s(&big_job)]);
    refused(&o, &["larger than the 512 MB a G-code file can be"]);
    let big_pic = sparse("big.png", (1 << 30) + 1);
    let o = stencil_guarded(&["make", s(&big_pic), "-o", s(&out)]);
    refused(&o, &["larger than the 1024 MB a picture can be"]);
    let big_obj = sparse("big.obj", (1 << 30) + 1);
    let o = stencil_guarded(&["make", s(&big_obj), "-o", s(&out)]);
    refused(&o, &["larger than the 1024 MB a mesh (OBJ) can be"]);
    let big_svg = sparse("big.svg", (256 << 20) + 1);
    let o = stencil_guarded(&["gcode", s(&big_svg), "--power", "50", "--speed", "600"]);
    refused(&o, &["larger than the 256 MB a drawing (SVG) can be"]);
    assert!(files_in(&out).is_empty());
}

/// A stencil folder with a report.json edited by `edit`.
fn received_folder(d: &Path, edit: impl Fn(&mut serde_json::Value)) -> PathBuf {
    std::fs::create_dir_all(d).unwrap();
    let (_, out) = made(d, "received");
    let rp = out.join("report.json");
    let mut r: serde_json::Value = serde_json::from_slice(&std::fs::read(&rp).unwrap()).unwrap();
    edit(&mut r);
    std::fs::write(&rp, serde_json::to_vec(&r).unwrap()).unwrap();
    out
}

/// Item 5: a received folder's report.json names its material by value; a material given as a
/// path is refused without the file being opened, and nothing of that file is printed.
#[test]
fn received_folders_name_materials_not_files() {
    let dir = tmp();
    let d = dir.path();
    // A secret file the report points at.
    let secret = d.join("secret.toml");
    std::fs::write(&secret, "root:x:0:0:SECRET-LINE\n").unwrap();
    for (material, source) in [
        (s(&secret).to_string(), None),
        ("../../secret".to_string(), None),
        ("cardstock".to_string(), Some(s(&secret).to_string())),
    ] {
        let sub = tempfile::tempdir_in(d).unwrap();
        let out = received_folder(sub.path(), |r| {
            let o = r.as_object_mut().unwrap();
            o.remove("material_values");
            o.insert("material".into(), material.clone().into());
            if let Some(src) = &source {
                o.insert("material_source".into(), src.clone().into());
            }
        });
        for args in [
            vec!["gcode", s(&out), "--machine", "diode-400"],
            vec!["check", s(&out)],
        ] {
            let o = stencil(&args);
            let all = format!("{}{}", stderr(&o), String::from_utf8_lossy(&o.stdout));
            assert!(
                !all.contains("SECRET-LINE"),
                "{args:?} printed the file: {all}"
            );
            if source.is_none() {
                refused(&o, &["not a material name", "--material"]);
            } else {
                // An old report's name is used; the source path is a note, never opened.
                assert!(o.status.success(), "{args:?}: {all}");
            }
        }
    }
    // The values travel with the folder: a material no profile on this machine has.
    let out = received_folder(d, |r| {
        let v = r["material_values"]
            .as_object_mut()
            .expect("report.json carries the values");
        v.insert("name".into(), "their-card".into());
        v.insert("kerf_mm".into(), 0.21.into());
        r["material"] = "their-card".into();
    });
    let o = stencil(&["gcode", s(&out), "--machine", "diode-400"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let job = std::fs::read_to_string(out.join("stencil.gcode")).unwrap();
    assert!(job.contains("material their-card, kerf 0.21 mm"), "{job}");
    // Values that break the profile rules are refused as a profile file's would be.
    let out = received_folder(&d.join("x"), |r| {
        r["material_values"]["kerf_mm"] = 9.0.into();
    });
    let o = stencil(&["check", s(&out)]);
    refused(&o, &["material_values", "kerf_mm"]);
    // A file that is not G-code given to `send`: refused before a port opens, nothing quoted.
    let o = stencil(&["send", s(&secret), "--dry-run"]);
    let err = refused(&o, &["not a G-code program", "nothing was sent"]);
    assert!(
        !err.contains("SECRET-LINE") && !err.to_lowercase().contains("root:x"),
        "{err}"
    );
    // A file that is not TOML given as --material: its first line is not printed.
    let o = stencil(&[
        "check",
        s(&out.join("stencil.png")),
        "--material",
        s(&secret),
    ]);
    let err = refused(&o, &[s(&secret), "line 1"]);
    assert!(
        !err.contains("SECRET-LINE") && !err.contains("root:x"),
        "{err}"
    );
}

/// Two runs into one folder at once: the swap holds the folder's lock, so the second is told the
/// folder is busy and moves nothing aside; the folder ends with one whole set.
#[test]
fn a_run_that_finds_the_folder_busy_leaves_it_alone() {
    let dir = tmp();
    let (pic, out) = made(dir.path(), "out");
    let before = owned_set(&out);
    // Hold the lock as a running `make` would (an advisory lock on the folder itself).
    let held = std::fs::File::open(&out).unwrap();
    held.try_lock().unwrap();
    let o = stencil(&[
        "make",
        s(&pic),
        "-o",
        s(&out),
        "--emit",
        "png,svg,gcode",
        "--width-mm",
        "150",
    ]);
    let err = refused(&o, &["another stencil run is writing this folder now"]);
    assert!(!err.contains("previous"), "{err}");
    drop(held);
    assert_eq!(owned_set(&out), before);
    assert!(!out.join("previous").exists());
}

/// Item 2 under item 1: a failed `make` aborted at every point of moving the earlier set aside.
/// After the next reader settles the folder, the earlier set is whole either where it was or in
/// previous/, never split between them.
#[test]
fn a_failed_run_killed_while_moving_the_earlier_set_aside_leaves_it_whole() {
    if !cfg!(debug_assertions) {
        return;
    }
    let dir = tmp();
    let (pic, reference) = made(dir.path(), "ref");
    let old = owned_set(&reference);
    let (mut kills, mut stayed, mut moved) = (0, 0, 0);
    for k in 1.. {
        let out = dir.path().join(format!("out{k}"));
        std::fs::create_dir(&out).unwrap();
        for n in files_in(&reference) {
            std::fs::copy(reference.join(&n), out.join(&n)).unwrap();
        }
        let o = Command::new(env!("CARGO_BIN_EXE_stencil"))
            .args(["make", s(&pic), "-o", s(&out), "--emit", "png,svg,gcode"])
            .args(["--width-mm", "500"])
            .env("STENCIL_FAULT_SWAP_STEP", k.to_string())
            .output()
            .unwrap();
        if o.status.code().is_some() {
            // Past the last point: the failed run moved the set aside whole.
            refused(&o, &["previous"]);
            assert_eq!(owned_set(&out.join("previous")), old);
            break;
        }
        kills += 1;
        let c = stencil(&["estimate", s(&out.join("stencil.gcode"))]);
        assert!(!stderr(&c).contains("panicked"));
        let (here, aside) = (owned_set(&out), owned_set(&out.join("previous")));
        if here == old && aside.is_empty() {
            stayed += 1;
        } else if here.is_empty() && aside == old {
            moved += 1;
        } else {
            panic!(
                "killed at {k}: split: here {:?}, previous {:?}",
                here.keys().collect::<Vec<_>>(),
                aside.keys().collect::<Vec<_>>()
            );
        }
        assert_eq!(hidden(&out), Vec::<String>::new());
    }
    println!("failed make killed at {kills} points: {stayed} kept the set in place, {moved} in previous/");
    assert!(
        kills > 10 && stayed > 0 && moved > 0,
        "{kills} {stayed} {moved}"
    );
}

/// Issue 39, item 4: a received folder whose half-finished swap has a link in it
/// (`.stencil-swap/old` or `new/` pointing at another folder, or its record of steps done
/// pointing at another file): the reader that settles it refuses, naming the link, and no file
/// of the other folder is overwritten, moved away or written to.
#[cfg(unix)]
#[test]
fn a_link_inside_a_received_swap_is_never_followed() {
    use std::os::unix::fs::symlink;
    type Case<'a> = (&'a str, &'a str, &'a [&'a str]);
    let cases: [Case; 3] = [
        // `check` would move the folder's stencil.png over the other folder's.
        (
            "old",
            "M\t.stencil-swap/old\nR\tstencil.png\t.stencil-swap/old/stencil.png\n",
            &["check", "OUT"],
        ),
        // `send` would move the other folder's job in (and stream it).
        (
            "new",
            "M\t.stencil-swap/old\nR\tstencil.gcode\t.stencil-swap/old/stencil.gcode\n\
             R\t.stencil-swap/new/stencil.gcode\tstencil.gcode\n",
            &["send", "OUT/stencil.gcode", "--dry-run"],
        ),
        // The record of steps done, appended to as steps are made.
        (
            "done",
            "M\t.stencil-swap/old\nR\tstencil.svg\t.stencil-swap/old/stencil.svg\n",
            &["estimate", "OUT/stencil.gcode"],
        ),
    ];
    for (link, plan, args) in cases {
        let dir = tmp();
        let (_, out) = made(dir.path(), "received");
        let other = dir.path().join("other");
        std::fs::create_dir(&other).unwrap();
        for n in ["stencil.png", "stencil.gcode", "stencil.svg", "notes.txt"] {
            std::fs::write(other.join(n), format!("theirs: {n}")).unwrap();
        }
        let swap = out.join(".stencil-swap");
        std::fs::create_dir(&swap).unwrap();
        std::fs::write(swap.join("plan"), plan).unwrap();
        let target = if link == "done" {
            other.join("notes.txt")
        } else {
            other.clone()
        };
        symlink(&target, swap.join(link)).unwrap();
        let before = owned_set(&out);
        let args: Vec<String> = args.iter().map(|a| a.replace("OUT", s(&out))).collect();
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = stencil_guarded(&args);
        let err = refused(&o, &["symbolic link", "nothing was moved through it"]);
        assert!(
            err.contains(s(&swap.join(link))),
            "{link}: the message names the link: {err}"
        );
        for n in ["stencil.png", "stencil.gcode", "stencil.svg", "notes.txt"] {
            assert_eq!(
                std::fs::read_to_string(other.join(n)).unwrap(),
                format!("theirs: {n}"),
                "{link}: the other folder's {n} changed"
            );
        }
        if link != "new" {
            // Refused before the plan's first step (the `new` plan's first steps are sound, and
            // are made).
            assert!(
                owned_set(&out) == before,
                "{link}: the folder's files moved"
            );
        }
        assert!(
            !String::from_utf8_lossy(&o.stdout).contains("lines received"),
            "{link}: something was sent"
        );
    }
}
