use super::*;

const GOOD: &str = r#"
name = "t"
[bed]
width_mm = 300
height_mm = 200
origin = "top-left"
[motion]
max_feed_mm_min = 5000
rapid_mm_min = 8000
accel_mm_s2 = 800
[tool]
kind = "laser"
s_max = 255
"#;

#[test]
fn every_builtin_profile_loads() {
    for name in builtin_names() {
        let m = load(Some(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(m.name, name, "the profile's name matches its file");
    }
    let d = load(None).unwrap();
    assert_eq!((d.bed.width_mm, d.bed.height_mm), (400.0, 400.0));
    assert!(matches!(d.tool, Tool::Laser { .. }));
}

#[test]
fn good_profile_fields() {
    let m = parse(GOOD, Path::new("t.toml")).unwrap();
    assert_eq!(m.bed.origin, Corner::TopLeft);
    assert_eq!(m.motion.junction_deviation_mm, 0.01);
    assert_eq!(
        m.tool,
        Tool::Laser {
            s_max: 255.0,
            s_min: 0.0
        }
    );
}

fn err(text: &str) -> String {
    parse(text, Path::new("my.toml")).unwrap_err().to_string()
}

#[test]
fn unknown_field_is_named() {
    let e = err(&GOOD.replace("accel_mm_s2", "acceleration"));
    assert!(e.starts_with("my.toml:"), "{e}");
    assert!(e.contains("acceleration"), "{e}");
    assert!(!e.contains('\n'), "one line: {e}");
}

#[test]
fn negative_bed_is_named() {
    let e = err(&GOOD.replace("width_mm = 300", "width_mm = -3"));
    assert!(e.contains("bed.width_mm") && e.contains("-3"), "{e}");
}

#[test]
fn s_min_above_s_max_is_refused() {
    let e = err(&GOOD.replace("s_max = 255", "s_max = 255\ns_min = 300"));
    assert!(e.contains("tool.s_min"), "{e}");
}

#[test]
fn field_of_another_tool_is_refused() {
    let e = err(&GOOD.replace("s_max = 255", "overcut_mm = 1"));
    assert!(e.contains("tool.overcut_mm") && e.contains("laser"), "{e}");
    let pen = GOOD.replace(
        "kind = \"laser\"\ns_max = 255",
        "kind = \"pen\"\nlift = \"spindle\"\npen_down_s = 30\nair_assist = true",
    );
    let e = err(&pen);
    assert!(e.contains("tool.air_assist") && e.contains("pen"), "{e}");
    let air = parse(
        &GOOD.replace("s_max = 255", "s_max = 255\nair_assist = true"),
        Path::new("a"),
    );
    assert!(air.unwrap().air_assist);
}

#[test]
fn a_laser_source_comes_with_its_power() {
    let m = parse(
        &GOOD.replace("s_max = 255", "s_max = 255\nsource = \"diode\"\nwatts = 10"),
        Path::new("a"),
    )
    .unwrap();
    assert_eq!(
        m.kind(),
        MachineKind::Laser(Some(LaserPower {
            source: LaserSource::Diode,
            watts: 10.0
        }))
    );
    assert_eq!(m.kind().to_string(), "diode laser 10 W");
    assert_eq!(parse(GOOD, Path::new("a")).unwrap().laser, None);
    let e = err(&GOOD.replace("s_max = 255", "s_max = 255\nsource = \"co2\""));
    assert!(e.contains("tool.watts"), "{e}");
    let e = err(&GOOD.replace("s_max = 255", "s_max = 255\nwatts = 10"));
    assert!(e.contains("tool.source"), "{e}");
    let e = err(&GOOD.replace("s_max = 255", "s_max = 255\nsource = \"co2\"\nwatts = 9000"));
    assert!(e.contains("tool.watts"), "{e}");
    let pen = GOOD.replace(
        "kind = \"laser\"\ns_max = 255",
        "kind = \"pen\"\nlift = \"spindle\"\npen_down_s = 30\nwatts = 5",
    );
    assert!(err(&pen).contains("tool.watts"));
    for name in ["diode-400", "co2-600x400"] {
        assert!(load(Some(name)).unwrap().laser.is_some(), "{name}");
    }
}

#[test]
fn frame_power_is_a_low_laser_setting() {
    let m = parse(
        &GOOD.replace("s_max = 255", "s_max = 255\nframe_power_pct = 1.5"),
        Path::new("t.toml"),
    )
    .unwrap();
    assert_eq!(m.frame_power_pct, 1.5);
    assert_eq!(
        parse(GOOD, Path::new("t.toml")).unwrap().frame_power_pct,
        0.0
    );
    let e = err(&GOOD.replace("s_max = 255", "s_max = 255\nframe_power_pct = 40"));
    assert!(
        e.contains("tool.frame_power_pct") && e.contains("10"),
        "{e}"
    );
    let pen = GOOD.replace(
        "kind = \"laser\"\ns_max = 255",
        "kind = \"pen\"\nlift = \"spindle\"\npen_down_s = 30\nframe_power_pct = 1",
    );
    assert!(err(&pen).contains("tool.frame_power_pct"), "{}", err(&pen));
}

#[test]
fn knife_needs_z_heights() {
    let text = GOOD.replace(
        "kind = \"laser\"\ns_max = 255",
        "kind = \"knife\"\nz_up_mm = 3",
    );
    let e = err(&text);
    assert!(
        e.contains("tool.z_down_mm") && e.contains("required"),
        "{e}"
    );
    let text = GOOD.replace(
        "kind = \"laser\"\ns_max = 255",
        "kind = \"knife\"\nz_up_mm = -1\nz_down_mm = 0\nplunge_mm_min = 300",
    );
    assert!(err(&text).contains("above"));
}

#[test]
fn bad_origin_and_unknown_kind() {
    let e = err(&GOOD.replace("top-left", "middle"));
    assert!(e.contains("middle") || e.contains("origin"), "{e}");
    let e = err(&GOOD.replace("\"laser\"", "\"plasma\""));
    assert!(e.contains("plasma"), "{e}");
}

#[test]
fn unknown_name_lists_builtins() {
    let e = load(Some("nope")).unwrap_err().to_string();
    assert!(e.contains("nope") && e.contains("diode-400"), "{e}");
    let e = load(Some("/no/such/m.toml")).unwrap_err().to_string();
    assert!(e.contains("/no/such/m.toml"), "{e}");
}

#[test]
fn every_number_is_bounded_by_what_a_machine_can_be() {
    let knife = GOOD.replace(
        "kind = \"laser\"\ns_max = 255",
        "kind = \"knife\"\nz_up_mm = 3\nz_down_mm = -0.3\nplunge_mm_min = 300\novercut_mm = 1",
    );
    let pen = GOOD.replace(
        "kind = \"laser\"\ns_max = 255",
        "kind = \"pen\"\nlift = \"spindle\"\npen_down_s = 30",
    );
    assert!(parse(&knife, Path::new("k.toml")).is_ok());
    assert!(parse(&pen, Path::new("p.toml")).is_ok());
    for (base, from, to, field) in [
        (GOOD, "width_mm = 300", "width_mm = 1e308", "bed.width_mm"),
        (
            GOOD,
            "height_mm = 200",
            "height_mm = 0.001",
            "bed.height_mm",
        ),
        (
            GOOD,
            "max_feed_mm_min = 5000",
            "max_feed_mm_min = 1e308",
            "motion.max_feed_mm_min",
        ),
        (
            GOOD,
            "max_feed_mm_min = 5000",
            "max_feed_mm_min = 1e-300",
            "motion.max_feed_mm_min",
        ),
        (
            GOOD,
            "rapid_mm_min = 8000",
            "rapid_mm_min = 1e9",
            "motion.rapid_mm_min",
        ),
        (
            GOOD,
            "accel_mm_s2 = 800",
            "accel_mm_s2 = 1e12",
            "motion.accel_mm_s2",
        ),
        (
            GOOD,
            "accel_mm_s2 = 800",
            "accel_mm_s2 = 800\njunction_deviation_mm = 1e-300",
            "motion.junction_deviation_mm",
        ),
        (GOOD, "s_max = 255", "s_max = 1e308", "tool.s_max"),
        (&knife, "z_up_mm = 3", "z_up_mm = 1e9", "tool.z_up_mm"),
        (
            &knife,
            "z_down_mm = -0.3",
            "z_down_mm = -1e9",
            "tool.z_down_mm",
        ),
        (
            &knife,
            "plunge_mm_min = 300",
            "plunge_mm_min = 1e300",
            "tool.plunge_mm_min",
        ),
        (
            &knife,
            "overcut_mm = 1",
            "overcut_mm = 1e6",
            "tool.overcut_mm",
        ),
        (
            &pen,
            "pen_down_s = 30",
            "pen_down_s = 1e300",
            "tool.pen_down_s",
        ),
        (
            GOOD,
            "name = \"t\"",
            &format!("name = \"{}\"", "n".repeat(500)),
            "name",
        ),
    ] {
        let text = base.replace(from, to);
        assert_ne!(text, base, "{from}");
        let e = err(&text);
        assert!(
            e.starts_with("my.toml: field `") && e.contains(field),
            "{to}: {e}"
        );
        assert!(e.len() < 300 && !e.contains("00000000000"), "{e}");
    }
}

#[test]
fn the_serial_link_defaults_to_an_avr_grbl_and_is_checked() {
    // Without [link]: Grbl 1.1h on an AVR, as its `$I` says ([OPT:V,15,128]) at 115200 baud.
    let m = parse(GOOD, Path::new("t.toml")).unwrap();
    assert_eq!(
        (m.link.baud, m.link.rx_buffer_bytes, m.link.planner_blocks),
        (115_200, 128, 15)
    );
    let with = |link: &str| GOOD.replace("[tool]", &format!("[link]\n{link}\n[tool]"));
    let m = parse(
        &with("baud = 250000\nplanner_blocks = 35"),
        Path::new("t.toml"),
    )
    .unwrap();
    assert_eq!(
        (m.link.baud, m.link.rx_buffer_bytes, m.link.planner_blocks),
        (250_000, 128, 35)
    );
    let e = err(&with("baud = 300"));
    assert!(e.contains("link.baud") && e.contains("300"), "{e}");
    let e = err(&with("rx_buffer_bytes = 4"));
    assert!(e.contains("link.rx_buffer_bytes"), "{e}");
    let e = err(&with("planner_blocks = 1"));
    assert!(e.contains("link.planner_blocks"), "{e}");
    let e = err(&with("bauds = 9600"));
    assert!(e.contains("bauds"), "{e}");
}
