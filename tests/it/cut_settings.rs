//! Cut settings per material and machine kind (issue 28, item 1): a diode gets the diode's
//! settings, a combination with none is refused before anything is written, and what a person
//! keeps with `stencil profiles set` wins and is recorded.

use std::path::Path;
use std::process::{Command, Output};

/// Run `stencil` with its config folder at `config`.
fn stencil(config: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_stencil"))
        .args(args)
        .env("STENCIL_CONFIG_DIR", config)
        .output()
        .expect("run stencil")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn rings() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("samples/rings.png")
        .display()
        .to_string()
}

/// The S and F of the first cut: the first cutting move (a G1 line, or a G2/G3 arc when the
/// loop starts with one) carries them.
fn first_cut_s_f(gcode: &str) -> (f64, f64) {
    let line = gcode
        .lines()
        .find(|l| {
            ["G1 ", "G2 ", "G3 "].iter().any(|g| l.starts_with(g))
                && l.contains(" S")
                && l.contains(" F")
        })
        .unwrap_or_else(|| panic!("no cutting G1/G2/G3 with S and F:\n{gcode}"));
    let word = |c: char| -> f64 {
        line.split_whitespace()
            .find_map(|w| w.strip_prefix(c))
            .unwrap()
            .parse()
            .unwrap()
    };
    (word('S'), word('F'))
}

#[test]
fn a_material_without_settings_for_the_machine_is_refused_before_anything_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let o = stencil(
        tmp.path(),
        &[
            "make",
            &rings(),
            "-o",
            out.to_str().unwrap(),
            "--material",
            "acrylic-3mm",
            "--emit",
            "png,gcode",
            "--machine",
            "diode-400",
        ],
    );
    assert!(!o.status.success());
    let err = text(&o.stderr);
    for needle in [
        "acrylic-3mm",
        "diode-400",
        "diode laser 5.5 W",
        "CO2 laser 40 W",
        "test-grid",
        "--power",
        "--speed",
        "profiles set",
    ] {
        assert!(err.contains(needle), "{needle} missing: {err}");
    }
    assert!(!out.exists(), "nothing written");

    // With --power and --speed the job is made, at those numbers, and says where they came from.
    let o = stencil(
        tmp.path(),
        &[
            "make",
            &rings(),
            "-o",
            out.to_str().unwrap(),
            "--material",
            "mylar-0.19",
            "--allow-thin",
            "--emit",
            "png,gcode",
            "--machine",
            "diode-400",
            "--power",
            "90",
            "--speed",
            "120",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let g = std::fs::read_to_string(out.join("stencil.gcode")).unwrap();
    assert_eq!(first_cut_s_f(&g), (900.0, 120.0));
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert!(
        r["gcode"]["settings_from"]
            .as_str()
            .unwrap()
            .contains("command line"),
        "{}",
        r["gcode"]
    );
}

#[test]
fn kept_settings_win_over_the_profile_and_are_recorded() {
    let tmp = tempfile::tempdir().unwrap();
    let config = tmp.path().join("config");
    let o = stencil(
        &config,
        &[
            "profiles",
            "set",
            "cardstock",
            "--machine",
            "diode-400",
            "--power",
            "85",
            "--speed",
            "700",
            "--passes",
            "3",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let file = config.join("cut-settings.toml");
    assert!(text(&o.stdout).contains(&file.display().to_string()));
    let kept = std::fs::read_to_string(&file).unwrap();
    assert!(
        kept.contains("cardstock") && kept.contains("diode-400"),
        "{kept}"
    );

    let out = tmp.path().join("out");
    let make = |extra: &[&str]| {
        let mut args = vec![
            "make",
            &rings(),
            "-o",
            out.to_str().unwrap(),
            "--emit",
            "png,gcode",
        ]
        .into_iter()
        .map(String::from)
        .collect::<Vec<_>>();
        args.extend(extra.iter().map(|s| s.to_string()));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        stencil(&config, &args)
    };
    // The default material and machine (cardstock on diode-400): the kept numbers.
    let o = make(&[]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let stdout = text(&o.stdout);
    assert!(
        stdout.contains("85 % power, 700 mm/min, 3 passes")
            && stdout.contains(&file.display().to_string()),
        "{stdout}"
    );
    let g = std::fs::read_to_string(out.join("stencil.gcode")).unwrap();
    assert_eq!(first_cut_s_f(&g), (850.0, 700.0));
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(r["gcode"]["settings"]["passes"], 3);
    assert!(r["gcode"]["settings_from"]
        .as_str()
        .unwrap()
        .contains("cut-settings.toml"));

    // Another machine keeps the profile's settings (the CO2 entry: S200 F1500).
    let o = make(&["--machine", "co2-600x400"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let g = std::fs::read_to_string(out.join("stencil.gcode")).unwrap();
    assert_eq!(first_cut_s_f(&g), (200.0, 1500.0));

    // Setting again replaces; `profiles` shows it as kept.
    let o = stencil(
        &config,
        &[
            "profiles",
            "set",
            "cardstock",
            "--machine",
            "diode-400",
            "--power",
            "60",
            "--speed",
            "800",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let kept = std::fs::read_to_string(&file).unwrap();
    assert_eq!(kept.matches("[[kept]]").count(), 1, "{kept}");
    let list = text(&stencil(&config, &["profiles"]).stdout);
    let row = list
        .lines()
        .find(|l| l.starts_with("cardstock ") && l.contains("kept"))
        .unwrap_or_else(|| panic!("no kept row:\n{list}"));
    assert!(row.contains("yes"), "the CO2 still from the profile: {row}");

    // A hand-edited file with a bad number is refused, naming the file and the field.
    std::fs::write(
        &file,
        kept.replace("speed_mm_min = 800.0", "speed_mm_min = -5"),
    )
    .unwrap();
    let o = make(&[]);
    assert!(!o.status.success());
    let err = text(&o.stderr);
    assert!(
        err.contains("cut-settings.toml") && err.contains("speed_mm_min"),
        "{err}"
    );
}

#[test]
fn profiles_set_refuses_what_the_machine_cannot_use() {
    let tmp = tempfile::tempdir().unwrap();
    for (args, needle) in [
        (
            vec!["cardstock", "--machine", "diode-400", "--speed", "700"],
            "--power",
        ),
        (
            vec![
                "cardstock-knife",
                "--machine",
                "drag-knife",
                "--power",
                "50",
                "--speed",
                "700",
            ],
            "--power",
        ),
        (
            vec!["cardstock", "--machine", "drag-knife", "--speed", "700"],
            "knife",
        ),
        (
            vec![
                "cardstock",
                "--machine",
                "diode-400",
                "--power",
                "50",
                "--speed",
                "90000",
            ],
            "max feed",
        ),
        (
            vec![
                "aluminium-gobo",
                "--machine",
                "diode-400",
                "--power",
                "50",
                "--speed",
                "700",
            ],
            "etch",
        ),
    ] {
        let mut all = vec!["profiles", "set"];
        all.extend(args.iter().copied());
        let o = stencil(tmp.path(), &all);
        assert!(!o.status.success(), "{args:?}");
        let err = text(&o.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    assert!(
        !tmp.path().join("cut-settings.toml").exists(),
        "nothing kept"
    );
}

#[test]
fn profiles_lists_machines_and_which_materials_cut_on_which() {
    let tmp = tempfile::tempdir().unwrap();
    let o = stencil(tmp.path(), &["profiles"]);
    assert!(o.status.success());
    let list = text(&o.stdout);
    let machine = |name: &str| {
        list.lines()
            .find(|l| l.starts_with(name))
            .unwrap_or_else(|| panic!("{name} missing:\n{list}"))
            .to_string()
    };
    assert!(machine("diode-400").contains("diode laser 5.5 W"));
    assert!(machine("co2-600x400").contains("CO2 laser 40 W"));
    // A machine row's second word is its bed, so scripts that pick materials by a process name
    // in the second column do not take a pen plotter for a material.
    for name in ["pen-a3", "drag-knife", "diode-400"] {
        let row = machine(name);
        let second = row.split_whitespace().nth(1).unwrap_or("");
        assert!(second.parse::<f64>().is_ok(), "{row}");
    }
    // The matrix: header of machine names, then a row per cutting material.
    let header = list
        .lines()
        .find(|l| l.starts_with("cut settings for"))
        .unwrap();
    let cols: Vec<&str> = header.split_whitespace().skip(3).collect();
    let row = |m: &str| -> Vec<String> {
        list.lines()
            .rfind(|l| l.split_whitespace().next() == Some(m))
            .unwrap()
            .split_whitespace()
            .skip(1)
            .map(String::from)
            .collect()
    };
    let cell = |m: &str, machine: &str| {
        let k = cols.iter().position(|c| *c == machine).unwrap();
        row(m)[k].clone()
    };
    assert_eq!(cell("acrylic-3mm", "diode-400"), "-", "{list}");
    assert_eq!(cell("acrylic-3mm", "co2-600x400"), "yes");
    assert_eq!(cell("cardstock", "diode-400"), "yes");
    assert_eq!(cell("cardstock", "drag-knife"), "-");
    assert_eq!(cell("vinyl-0.08", "drag-knife"), "yes");
    assert_eq!(cell("plotter-paper", "pen-a3"), "yes");
}
