//! Material profiles: every bad-profile case gives a clear error naming the file and the field.

use std::path::Path;
use std::process::Command;

use stencil_core::material::{DEFAULT_MATERIAL, SHIPPED};
use {stencil_core::material::Material, stencil_io::profile::ProfileError};

const GOOD: &str = r#"
name = "test-card"
thickness_mm = 0.3
min_bridge_mm = 1.0
min_feature_mm = 0.5
kerf_mm = 0.1
process = "laser"

[laser]
power_pct = 20
speed_mm_min = 1500
passes = 1
"#;

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn load_err(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "bad.toml", text);
    let e = Material::load(&p).unwrap_err().to_string();
    assert!(e.contains("bad.toml"), "error must name the file: {e}");
    assert!(!e.contains('\n'), "one line: {e}");
    e
}

#[test]
fn a_good_profile_loads_from_a_path() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "mine.toml", GOOD);
    let (m, src) = Material::find(p.to_str().unwrap()).unwrap();
    assert_eq!(m.name, "test-card");
    assert_eq!(src, p);
    assert_eq!(m.laser().unwrap().on[0].speed_mm_min, 1500.0);
    assert_eq!(
        m.laser().unwrap().on[0].laser,
        None,
        "flat [laser] settings: any laser"
    );
}

#[test]
fn unknown_field_is_named() {
    let e = load_err(&GOOD.replace("kerf_mm = 0.1", "kerf_mm = 0.1\nbridge_mm = 2"));
    assert!(
        e.contains("bridge_mm") && e.contains("unknown field"),
        "{e}"
    );
}

#[test]
fn unknown_field_in_a_process_section_is_named() {
    let e = load_err(&GOOD.replace("passes = 1", "passes = 1\nwatts = 40"));
    assert!(e.contains("watts"), "{e}");
}

#[test]
fn missing_field_is_named() {
    let e = load_err(&GOOD.replace("min_bridge_mm = 1.0\n", ""));
    assert!(e.contains("min_bridge_mm") && e.contains("missing"), "{e}");
}

#[test]
fn missing_process_section_is_named() {
    let text = GOOD.split("[laser]").next().unwrap().to_string();
    let e = load_err(&text);
    assert!(e.contains("[laser]"), "{e}");
}

#[test]
fn negative_value_is_named() {
    let e = load_err(&GOOD.replace("kerf_mm = 0.1", "kerf_mm = -0.1"));
    assert!(e.contains("kerf_mm") && e.contains("negative"), "{e}");
}

#[test]
fn absurd_value_is_named() {
    let e = load_err(&GOOD.replace("thickness_mm = 0.3", "thickness_mm = 300"));
    assert!(
        e.contains("thickness_mm") && e.contains("out of range"),
        "{e}"
    );
    let e = load_err(&GOOD.replace("power_pct = 20", "power_pct = 2000"));
    assert!(e.contains("laser.power_pct"), "{e}");
}

#[test]
fn kerf_wider_than_the_smallest_feature_is_refused() {
    let e = load_err(&GOOD.replace("kerf_mm = 0.1", "kerf_mm = 0.6"));
    assert!(e.contains("kerf_mm") && e.contains("min_feature_mm"), "{e}");
}

#[test]
fn unknown_name_lists_the_known_names() {
    let e = Material::find("cardboard-9000").unwrap_err();
    assert!(matches!(e, ProfileError::Unknown { .. }));
    let msg = e.to_string();
    assert!(msg.contains("cardboard-9000"), "{msg}");
    for s in SHIPPED {
        assert!(msg.contains(s.name), "{msg} lacks {}", s.name);
    }
}

#[test]
fn every_shipped_profile_is_found_by_name() {
    for s in SHIPPED {
        let (m, _) = Material::find(s.name).unwrap();
        assert_eq!(m.name, s.name);
    }
    assert_eq!(Material::default().name, DEFAULT_MATERIAL);
}

#[test]
fn cli_rejects_an_unknown_material_before_doing_anything() {
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("in.png");
    let bits = stencil_core::raster::BitGrid::new(20, 20, true);
    std::fs::write(&img, stencil_core::export::png::encode_bits(&bits)).unwrap();
    let out = dir.path().join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_stencil"))
        .args([
            "make",
            img.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--material",
            "tinfoil",
        ])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("tinfoil") && err.contains("cardstock") && err.contains("mylar-0.19"),
        "{err}"
    );
    assert!(!out.exists(), "nothing written");
}

#[test]
fn cli_lists_the_shipped_profiles() {
    let o = Command::new(env!("CARGO_BIN_EXE_stencil"))
        .arg("profiles")
        .output()
        .unwrap();
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    for s in SHIPPED {
        let m = Material::find(s.name).unwrap().0;
        let line = text
            .lines()
            .find(|l| l.starts_with(s.name))
            .unwrap_or_else(|| panic!("{} missing:\n{text}", s.name));
        assert!(line.contains(&format!("{} mm", m.min_bridge_mm)), "{line}");
    }
}

/// A run that names no material or machine uses the shipped defaults wherever it starts: an
/// edited copy in `./profiles/` changes a run only when the run names it. (Before, the command
/// looked in the current folder first and the library did not, so `make`'s output depended on
/// the folder it was started in.)
#[test]
fn the_default_profiles_do_not_depend_on_the_working_directory() {
    let tmp = tempfile::tempdir().unwrap();
    let picture = std::fs::canonicalize("samples/rings.png").unwrap();
    let plain = tmp.path().join("plain");
    let edited = tmp.path().join("edited");
    std::fs::create_dir_all(&plain).unwrap();
    std::fs::create_dir_all(edited.join("profiles/materials")).unwrap();
    std::fs::create_dir_all(edited.join("profiles/machines")).unwrap();
    // Copies that would change every output: wider bridges, another acceleration.
    let card = std::fs::read_to_string("profiles/materials/cardstock.toml")
        .unwrap()
        .replace("min_bridge_mm = 1.0", "min_bridge_mm = 2.0");
    assert!(card.contains("min_bridge_mm = 2.0"));
    std::fs::write(edited.join("profiles/materials/cardstock.toml"), card).unwrap();
    let diode = std::fs::read_to_string("profiles/machines/diode-400.toml").unwrap();
    let slow = diode.replace("accel_mm_s2 = ", "accel_mm_s2 = 1");
    assert_ne!(slow, diode);
    std::fs::write(edited.join("profiles/machines/diode-400.toml"), slow).unwrap();

    let make = |cwd: &Path, extra: &[&str]| {
        let mut args = vec![
            "make",
            picture.to_str().unwrap(),
            "-o",
            "out",
            "--emit",
            "png,gcode",
        ];
        args.extend_from_slice(extra);
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_stencil"))
            .args(&args)
            .current_dir(cwd)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(cwd.join("out/report.json")).unwrap()).unwrap();
        let png = std::fs::read(cwd.join("out/stencil.png")).unwrap();
        let gcode = std::fs::read(cwd.join("out/stencil.gcode")).unwrap();
        (report, png, gcode)
    };
    let (r1, png1, g1) = make(&plain, &[]);
    let (r2, png2, g2) = make(&edited, &[]);
    assert_eq!(png1, png2, "stencil.png differs with ./profiles/ present");
    assert_eq!(g1, g2, "the G-code differs with ./profiles/ present");
    for r in [&r1, &r2] {
        assert_eq!(
            r["material_source"], "<embedded>/materials/cardstock.toml",
            "{r}"
        );
    }
    assert_eq!(r1["gcode"]["estimate"], r2["gcode"]["estimate"]);
    // Named, the edited copies are used: wider bridges, another time estimate.
    let (r3, _, _) = make(
        &edited,
        &["--material", "cardstock", "--machine", "diode-400"],
    );
    assert_eq!(r3["material_source"], "profiles/materials/cardstock.toml");
    assert!(
        r3["min_bridge_px"].as_f64().unwrap() > r1["min_bridge_px"].as_f64().unwrap(),
        "{} vs {}",
        r3["min_bridge_px"],
        r1["min_bridge_px"]
    );
    assert_ne!(r3["gcode"]["estimate"], r1["gcode"]["estimate"]);
}

/// Issue 39, item 4: ten `profiles set` for ten different material and machine pairs, all at
/// once (a script keeping a test grid's results): every one succeeds and every pair is kept.
/// Before, each read the file, changed it and wrote it back unguarded, so most writes replaced
/// others' (1 to 7 of 10 kept), and one could fail when another swept its temp file.
#[test]
fn concurrent_profiles_set_keep_every_pair() {
    let materials = [
        "acrylic-3mm",
        "cardstock",
        "copy-paper",
        "mylar-0.19",
        "plywood-3mm",
    ];
    let machines = ["diode-400", "co2-600x400"];
    for round in 0..3 {
        let tmp = tempfile::tempdir().unwrap();
        let config = tmp.path().join("config");
        let mut children = Vec::new();
        for (i, m) in materials.iter().enumerate() {
            for (k, machine) in machines.iter().enumerate() {
                let power = (10 + 10 * i + k).to_string();
                let child = Command::new(env!("CARGO_BIN_EXE_stencil"))
                    .args(["profiles", "set", m, "--machine", machine])
                    .args(["--power", &power, "--speed", "600", "--passes", "2"])
                    .env("STENCIL_CONFIG_DIR", &config)
                    .stdout(std::process::Stdio::piped())
                    .stderr(std::process::Stdio::piped())
                    .spawn()
                    .unwrap();
                children.push((m, machine, power, child));
            }
        }
        let mut ran = Vec::new();
        for (m, machine, power, child) in children {
            let o = child.wait_with_output().unwrap();
            assert!(
                o.status.success(),
                "round {round}: {m} on {machine}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            ran.push((m, machine, power));
        }
        let kept = stencil_core::material::UserSettings::load_from(&config).unwrap();
        for (m, machine, power) in ran {
            let k = kept
                .find(m, machine)
                .unwrap_or_else(|| panic!("round {round}: {m} on {machine} was not kept"));
            assert_eq!(
                k.power_pct,
                Some(power.parse().unwrap()),
                "{m} on {machine}"
            );
        }
        let hidden: Vec<String> = std::fs::read_dir(&config)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with('.'))
            .collect();
        assert!(hidden.is_empty(), "temp files left: {hidden:?}");
    }
}
