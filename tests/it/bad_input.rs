//! Bad input gives one clear line naming the file and the problem, a non-zero exit, and no output.

use std::path::Path;

use crate::common::*;

/// Run make on `input` into a fresh folder; assert failure, a one-line message containing every
/// `needle`, and that nothing was written.
fn fails_cleanly(input: &Path, needles: &[&str]) {
    let dir = tmp();
    let out = dir.path().join("out");
    let o = stencil(&["make", s(input), "-o", s(&out)]);
    let err = stderr(&o);
    assert!(!o.status.success(), "should fail: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err:?}");
    assert!(err.starts_with("error: "), "{err}");
    for n in needles {
        assert!(err.contains(n), "message should contain {n:?}: {err}");
    }
    assert!(
        files_in(&out).is_empty(),
        "partial output left: {:?}",
        files_in(&out)
    );
    assert!(!err.contains("panicked"));
}

#[test]
fn missing_file() {
    let dir = tmp();
    let p = dir.path().join("nope.png");
    fails_cleanly(&p, &["nope.png", "cannot open"]);
}

#[test]
fn not_an_image() {
    let dir = tmp();
    let p = dir.path().join("notes.png");
    std::fs::write(&p, "this is a text file, not a picture\n").unwrap();
    fails_cleanly(&p, &["notes.png", "not an image"]);
}

#[test]
fn truncated_png() {
    let dir = tmp();
    let bytes = std::fs::read(samples().join("rings.png")).unwrap();
    let p = dir.path().join("cut.png");
    std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    fails_cleanly(&p, &["cut.png", "damaged or truncated"]);
}

#[test]
fn header_claiming_ten_gigapixels_is_refused_before_decoding() {
    let dir = tmp();
    let p = dir.path().join("huge.png");
    std::fs::write(&p, png_header_only(100_000, 100_000, 8, 0)).unwrap();
    fails_cleanly(&p, &["huge.png", "100000x100000", "--max-pixels"]);
}

#[test]
fn max_pixels_is_a_setting() {
    let dir = tmp();
    let out = dir.path().join("out");
    let o = stencil(&[
        "make",
        s(&samples().join("rings.png")),
        "-o",
        s(&out),
        "--max-pixels",
        "1000",
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("320x320"), "{}", stderr(&o));
    assert!(files_in(&out).is_empty());
}

#[test]
fn unwritable_output_dir() {
    let dir = tmp();
    // A folder cannot be made below a regular file (root ignores permission bits, this does not).
    let file = dir.path().join("plain-file");
    std::fs::write(&file, "x").unwrap();
    let out = file.join("out");
    let o = stencil(&["make", s(&samples().join("rings.png")), "-o", s(&out)]);
    let err = stderr(&o);
    assert!(!o.status.success());
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains("plain-file/out") && err.contains("output folder"),
        "{err}"
    );
    assert!(!file.join("out").exists());
}

#[test]
fn bad_settings_name_the_flag() {
    for (args, flag) in [
        (vec!["--alpha", "2.5"], "alpha"),
        (vec!["--threshold", "300"], "threshold"),
        (vec!["--threshold", "1.5"], "threshold"),
        (vec!["--w-length=-1"], "w-length"),
        (vec!["--scale", "20"], "scale"),
    ] {
        let dir = tmp();
        let out = dir.path().join("out");
        let mut a = vec!["make", "samples/rings.png", "-o", s(&out)];
        a.extend(args.iter().copied());
        let o = stencil(&a);
        assert!(!o.status.success(), "{a:?} should fail");
        assert!(stderr(&o).contains(flag), "{a:?}: {}", stderr(&o));
        assert!(files_in(&out).is_empty());
    }
}

/// An error about the input names it once, at the front; an error about another file, or about
/// no file, gets the input in front of its own words (the CLI decides by what the error is about,
/// not by searching its text: an input named `o` is in most messages' words).
#[test]
fn the_input_is_named_once_and_first() {
    let dir = tmp();
    let first_line = |args: &[&str]| {
        let o = stencil(args);
        assert!(!o.status.success());
        stderr(&o).lines().next().unwrap_or_default().to_string()
    };
    let input = dir.path().join("o");
    let out = dir.path().join("out");
    let err = first_line(&["make", s(&input), "-o", s(&out)]);
    let opens = format!("error: {}: cannot open this picture: ", s(&input));
    assert!(err.starts_with(&opens), "{err}");
    assert_eq!(err.matches(s(&input)).count(), 1, "{err}");

    // The keep-out picture's path starts with the input's: its error was once taken for one
    // about the input, and the input went unnamed.
    let rings = dir.path().join("r");
    std::fs::copy(samples().join("rings.png"), &rings).unwrap();
    let keep = dir.path().join("r-keep.png");
    let err = first_line(&["make", s(&rings), "-o", s(&out), "--keep-out", s(&keep)]);
    let opens = format!(
        "error: {}: {}: cannot open this picture: ",
        s(&rings),
        s(&keep)
    );
    assert!(err.starts_with(&opens), "{err}");

    let torus = samples().join("torus.obj");
    let err = first_line(&["make", s(&torus), "-o", s(&out), "--layers", "3"]);
    let mesh = format!(
        "error: {}: layers are cut from a picture, not a mesh",
        s(&torus)
    );
    assert_eq!(err, mesh);
}
