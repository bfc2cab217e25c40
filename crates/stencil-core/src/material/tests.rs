use super::*;
use std::path::{Path, PathBuf};
use stencil_gcode::machine::Machine;

#[test]
fn every_shipped_profile_is_valid_and_named_after_its_file() {
    for s in SHIPPED {
        let m = Material::parse(s.text, Path::new(s.name)).unwrap();
        assert_eq!(m.name, s.name);
        assert!(m.kerf_mm < m.min_feature_mm);
    }
    assert_eq!(Material::default().name, DEFAULT_MATERIAL);
    // The default for each shipped machine's tool is shipped and set up for that tool.
    for s in stencil_gcode::machine::SHIPPED {
        let machine = stencil_gcode::machine::load(Some(s.name)).unwrap();
        let (m, _) = Material::find(default_for(&machine.tool)).unwrap();
        assert_eq!(
            m.process.kind().to_string(),
            machine.tool.kind(),
            "{}",
            m.name
        );
    }
}

#[test]
fn photo_etch_profiles_follow_the_thickness_rule() {
    for s in SHIPPED {
        let m = Material::parse(s.text, Path::new(s.name)).unwrap();
        if m.etch().is_some() {
            assert!(m.min_feature_mm >= m.thickness_mm, "{}", m.name);
            assert!(m.min_bridge_mm >= m.thickness_mm, "{}", m.name);
        }
    }
}

#[test]
fn the_widest_bridge_defaults_to_four_times_the_narrowest_and_is_checked() {
    let card = Material::default();
    assert_eq!(card.max_bridge_mm, 4.0 * card.min_bridge_mm);
    let with = |line: &str| {
        let text = SHIPPED[1].text.replace(
            "min_feature_mm = 0.5",
            &format!("min_feature_mm = 0.5\n{line}"),
        );
        Material::parse(&text, Path::new("x.toml"))
    };
    assert_eq!(with("max_bridge_mm = 3.0").unwrap().max_bridge_mm, 3.0);
    let e = with("max_bridge_mm = 0.5").unwrap_err().to_string();
    assert!(e.contains("x.toml") && e.contains("max_bridge_mm"), "{e}");
}

#[test]
fn strength_fields_default_and_absurd_values_name_the_field() {
    // Every shipped profile gives its own numbers (with sources in its comments).
    for s in SHIPPED {
        for field in [
            "youngs_modulus_gpa",
            "density_kg_m3",
            "max_sag_mm",
            "two_bridges_above_mm",
        ] {
            assert!(
                s.text.contains(&format!("\n{field} = ")),
                "{} {field}",
                s.name
            );
        }
    }
    let without: String = SHIPPED[1]
        .text
        .lines()
        .filter(|l| {
            !["youngs", "density", "max_sag", "two_bridges"]
                .iter()
                .any(|k| l.starts_with(k))
        })
        .map(|l| format!("{l}\n"))
        .collect();
    let m = Material::parse(&without, Path::new("x.toml")).unwrap();
    assert!(!m.strength.judged(), "no strength data: not judged");
    let one = without.replace(
        "min_feature_mm = 0.5",
        "min_feature_mm = 0.5\nmax_sag_mm = 2",
    );
    let m = Material::parse(&one, Path::new("x.toml")).unwrap();
    assert_eq!(
        m.strength,
        Strength {
            max_sag_mm: 2.0,
            ..DEFAULT_STRENGTH
        }
    );
    for (field, bad) in [
        ("youngs_modulus_gpa", "0"),
        ("youngs_modulus_gpa", "1e9"),
        ("density_kg_m3", "-5"),
        ("max_sag_mm", "0"),
        ("two_bridges_above_mm", "1e300"),
    ] {
        let text = without.replace(
            "min_feature_mm = 0.5",
            &format!("min_feature_mm = 0.5\n{field} = {bad}"),
        );
        let e = Material::parse(&text, Path::new("x.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("x.toml") && e.contains(field),
            "{field} = {bad}: {e}"
        );
    }
}

#[test]
fn a_section_for_another_process_is_an_error() {
    let text = SHIPPED[1].text.to_string()
        + "\n[etch]\netch_factor = 2.0\nmirror = false\ntwo_sided = false\n";
    let e = Material::parse(&text, Path::new("x.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("x.toml") && e.contains("etch"), "{e}");
}

fn laser_machine(source: &str, watts: f64) -> Machine {
    let text = stencil_gcode::machine::SHIPPED[0]
        .text
        .replace("source = \"diode\"", &format!("source = \"{source}\""))
        .replace("watts = 5.5", &format!("watts = {watts}"));
    stencil_gcode::machine::parse(&text, Path::new("m.toml")).unwrap()
}

#[test]
fn a_laser_gets_the_entry_for_its_source_with_the_most_power_at_or_below_its_own() {
    let card = Material::default();
    let pick = |src: &str, w: f64| settings_for(&card, &laser_machine(src, w));
    // 5.5 W diode: the 5 W entry; 12 W: the 10 W one; 40 W CO2: the CO2 one.
    assert_eq!(pick("diode", 5.5).unwrap().speed_mm_min, 1650.0);
    assert_eq!(pick("diode", 12.0).unwrap().speed_mm_min, 3375.0);
    assert_eq!(pick("diode", 25.0).unwrap().power_pct, 31.0);
    let co2 = pick("co2", 60.0).unwrap();
    assert_eq!((co2.power_pct, co2.speed_mm_min), (20.0, 1500.0));
    // Weaker than every entry: none (a 2 W diode, a 30 W tube).
    for (src, w) in [("diode", 2.0), ("co2", 30.0)] {
        let e = pick(src, w).unwrap_err();
        assert!(matches!(e, SettingsError::NoSettings { .. }), "{e}");
    }
    // Clear acrylic has no diode entry at any power.
    let (acrylic, _) = Material::find("acrylic-3mm").unwrap();
    let e = settings_for(&acrylic, &laser_machine("diode", 40.0)).unwrap_err();
    assert!(e.to_string().contains("CO2 laser 40 W or more"), "{e}");
}

#[test]
fn kept_settings_win_for_their_material_and_machine_only() {
    let card = Material::default();
    let diode = laser_machine("diode", 5.5);
    let user = UserSettings {
        path: Some(PathBuf::from("/c/cut-settings.toml")),
        entries: vec![Kept {
            material: "cardstock".into(),
            machine: "diode-400".into(),
            power_pct: Some(70.0),
            speed_mm_min: 800.0,
            passes: 3,
        }],
    };
    let c = choose(&card, &diode, &user).unwrap();
    assert_eq!(
        (
            c.settings.power_pct,
            c.settings.speed_mm_min,
            c.settings.passes
        ),
        (70.0, 800.0, 3)
    );
    assert!(c.from.contains("/c/cut-settings.toml"), "{}", c.from);
    let (paper, _) = Material::find("copy-paper").unwrap();
    assert_eq!(
        choose(&paper, &diode, &user).unwrap().settings.power_pct,
        10.0
    );
    // Written and read back.
    let dir = std::env::temp_dir().join(format!("stencil-kept-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join(USER_SETTINGS_FILE), user.to_toml("# test")).unwrap();
    let back = UserSettings::load_from(&dir);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(back.unwrap().entries, user.entries);
}

#[test]
fn laser_entries_are_checked() {
    let base = SHIPPED[1].text; // cardstock
    let bad = |from: &str, to: &str| {
        assert!(base.contains(from), "{from}");
        Material::parse(&base.replacen(from, to, 1), Path::new("x.toml"))
            .unwrap_err()
            .to_string()
    };
    let e = bad("from = \"Certifitrax", "from = \"\"\n#\"");
    assert!(e.contains("laser.on[0].from"), "{e}");
    let e = bad("watts = 10\n", "watts = 5\n");
    assert!(e.contains("same laser and power"), "{e}");
    let e = bad("power_pct = 48", "power_pct = 480");
    assert!(e.contains("laser.on[1].power_pct"), "{e}");
    let e = bad(
        "[laser]\n",
        "[laser]\npower_pct = 5\nspeed_mm_min = 5\npasses = 1\n",
    );
    assert!(e.contains("cannot be mixed"), "{e}");
}
