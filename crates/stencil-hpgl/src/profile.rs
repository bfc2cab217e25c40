//! Plotter profiles: a plotter cutter or pen plotter that takes HP-GL over a serial line, read
//! from TOML (`profiles/machines/*.toml` with an `[hpgl]` table) and validated once at load.
//!
//! A profile says what the planner needs (the cutting area, where 0,0 is, how fast it moves),
//! what the writer needs (the dialect, plotter units per mm, the range of `VS` and `FS`, where
//! the head parks, the blade's corner rules) and what the sender and the virtual cutter need (the
//! baud rate, the flow control, the input buffer). The shipped ones are compiled in, as the
//! G-code machines are.

use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use stencil_gcode::machine::{Bed, Link, Machine, Motion, PenLift, Tool, ZLift};
use stencil_io::profile::{check_range, embedded, parse_toml, ProfileError, Shipped};
use stencil_io::shipped;

/// The shipped plotter profiles, embedded so an installed binary has them.
pub const SHIPPED: &[Shipped] = &[
    shipped!("machines", "vinyl-hpgl"),
    shipped!("machines", "roland-camm"),
    shipped!("machines", "graphtec-hpgl"),
    shipped!("machines", "hp7475a"),
];

/// The HP-GL flavour a plotter speaks: which instructions it takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Dialect {
    /// HP-GL as the many generic vinyl cutters take it (the HP 7475A's set plus `FS`).
    Hpgl,
    /// Roland's CAMM-GL III in its HP-GL compatible mode ("mode 2"), with `FS`.
    CammGl,
    /// Graphtec's HP-GL emulation (the cutter's command mode set to HP-GL), with `FS`.
    Graphtec,
    /// The HP 7475A's HP-GL: a pen plotter, no `FS`.
    Hp7475a,
}

impl Dialect {
    /// The name used in profiles.
    pub fn name(self) -> &'static str {
        match self {
            Dialect::Hpgl => "hpgl",
            Dialect::CammGl => "camm-gl",
            Dialect::Graphtec => "graphtec",
            Dialect::Hp7475a => "hp7475a",
        }
    }

    /// Whether the plotter takes the two-letter instruction `mnemonic` (upper case).
    pub fn accepts(self, mnemonic: &str) -> bool {
        if mnemonic == "FS" {
            return self != Dialect::Hp7475a;
        }
        HPGL_7475A.contains(&mnemonic)
    }
}

/// The HP 7475A's HP-GL instructions (its Interfacing and Programming Manual, appendix "HP-GL
/// instruction summary"); the cutters' dialects take these too, plus `FS`.
const HPGL_7475A: &[&str] = &[
    "AA", "AR", "CA", "CI", "CP", "CS", "DC", "DF", "DI", "DP", "DR", "DT", "EA", "ER", "EW", "FT",
    "IM", "IN", "IP", "IW", "LB", "LT", "OA", "OC", "OD", "OE", "OF", "OH", "OI", "OO", "OP", "OS",
    "OW", "PA", "PD", "PR", "PS", "PT", "PU", "RA", "RO", "RR", "SA", "SC", "SI", "SL", "SM", "SP",
    "SR", "SS", "TL", "UC", "VS", "WG", "XT", "YT",
];

/// The tool a plotter carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ToolKind {
    /// A swivel (drag) knife.
    Knife,
    /// A pen.
    Pen,
}

/// How the plotter tells the computer to stop sending.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Flow {
    /// Software: the plotter sends XOFF (DC3) when its buffer is nearly full and XON (DC1) when
    /// it has room again.
    XonXoff,
    /// Hardware: the plotter drops a handshake line (seen as CTS by the computer) while its
    /// buffer is nearly full.
    RtsCts,
}

impl Flow {
    /// The name used in profiles.
    pub fn name(self) -> &'static str {
        match self {
            Flow::XonXoff => "xon-xoff",
            Flow::RtsCts => "rts-cts",
        }
    }
}

/// Where the head goes at the end of a job.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Park {
    /// Past the job's far end along the media feed, across at 0: the media can be cut off and
    /// taken (roll cutters).
    PastJob,
    /// Back to 0,0 (pen plotters: the pen out of the way in its corner).
    Origin,
}

/// A drag knife's corner rules and how small features are slowed (from the profile's `[knife]`).
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KnifeRules {
    /// How far past each closed loop's start the blade cuts again, mm.
    pub overcut_mm: f64,
    /// Corners turning at least this many degrees are swivelled around (blade compensation).
    pub swivel_min_deg: f64,
    /// A loop whose longer side is below this, mm, is a small feature: cut slower.
    pub small_feature_mm: f64,
    /// Speed of small features, % of the cut speed.
    pub small_feature_speed_pct: f64,
}

/// The serial line and the plotter's input buffer.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Serial {
    /// Baud rate.
    pub baud: u32,
    /// Flow control.
    pub flow: Flow,
    /// The plotter's input buffer, bytes.
    pub buffer_bytes: usize,
    /// XON/XOFF: the plotter sends XOFF when fewer than this many bytes are free, and XON when
    /// this many are free again. RTS/CTS: it drops the line while fewer are free. The sender
    /// never has more than this in flight after a stop, so nothing overflows.
    pub headroom_bytes: usize,
}

/// A validated plotter profile.
#[derive(Clone, Debug, PartialEq)]
pub struct Plotter {
    /// The profile's name.
    pub name: String,
    /// One line about the plotter.
    pub description: String,
    /// The cutting (plotting) area, mm, from the origin corner: X along the media feed for a
    /// roll cutter.
    pub bed: Bed,
    /// Knife or pen.
    pub tool: ToolKind,
    /// Its HP-GL flavour.
    pub dialect: Dialect,
    /// Plotter units per mm (40 for HP-GL's 0.025 mm unit).
    pub units_per_mm: f64,
    /// `VS` range, cm/s (what the plotter takes).
    pub velocity_cm_s: [f64; 2],
    /// Speed of pen-up moves, mm/s (for the time estimate).
    pub travel_mm_s: f64,
    /// Acceleration, mm/s² (for the time estimate).
    pub accel_mm_s2: f64,
    /// Grams of blade force per unit of `FS` (1 when `FS` takes grams); `None`: no `FS`.
    pub force_g_per_unit: Option<f64>,
    /// `FS` range, in its units.
    pub force_range: [f64; 2],
    /// Number of pens or tools the plotter selects with `SP`.
    pub pens: u32,
    /// The media moves along X (a roll cutter): a job too long across is turned a quarter turn so
    /// its long side runs with the feed.
    pub roll: bool,
    /// Where the head parks at the end.
    pub park: Park,
    /// Knife rules (`None` for a pen).
    pub knife: Option<KnifeRules>,
    /// The serial line.
    pub serial: Serial,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlotter {
    name: String,
    #[serde(default)]
    description: String,
    bed: Bed,
    hpgl: RawHpgl,
    knife: Option<KnifeRules>,
    serial: Serial,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHpgl {
    dialect: Dialect,
    tool: ToolKind,
    units_per_mm: f64,
    velocity_cm_s: [f64; 2],
    travel_mm_s: f64,
    accel_mm_s2: f64,
    force_g_per_unit: Option<f64>,
    force_range: Option<[f64; 2]>,
    #[serde(default = "one")]
    pens: u32,
    #[serde(default)]
    roll: bool,
    park: Park,
}

fn one() -> u32 {
    1
}

/// Whether `arg` (a `--machine` name or path) names an HP-GL plotter: a shipped plotter profile,
/// or a profile file with an `[hpgl]` table. Nothing is read but that file.
pub fn is_plotter(arg: &str) -> bool {
    if SHIPPED.iter().any(|s| s.name == arg) {
        return true;
    }
    let path = if arg.contains('/') || arg.contains('\\') || arg.ends_with(".toml") {
        PathBuf::from(arg)
    } else {
        Path::new("profiles")
            .join("machines")
            .join(format!("{arg}.toml"))
    };
    stencil_io::read_text(&path, stencil_io::Kind::Profile)
        .is_ok_and(|t| t.lines().any(|l| l.trim() == "[hpgl]"))
}

/// Load a plotter profile by name (shipped, or `./profiles/machines/NAME.toml`) or path.
pub fn load(arg: &str) -> Result<Plotter, ProfileError> {
    let (raw, origin): (RawPlotter, PathBuf) =
        stencil_io::profile::resolve(arg, "machines", SHIPPED)?;
    validate(raw, &origin)
}

/// Every shipped plotter, as embedded.
pub fn shipped() -> Vec<Result<Plotter, ProfileError>> {
    SHIPPED
        .iter()
        .map(|s| {
            let (raw, origin): (RawPlotter, PathBuf) = embedded(s.name, "machines", SHIPPED)?;
            validate(raw, &origin)
        })
        .collect()
}

/// Parse and validate a profile's text; `origin` names it in errors.
pub fn parse(text: &str, origin: &Path) -> Result<Plotter, ProfileError> {
    validate(parse_toml(text, origin)?, origin)
}

fn validate(raw: RawPlotter, origin: &Path) -> Result<Plotter, ProfileError> {
    let within = |field: &str, v: f64, r: RangeInclusive<f64>, unit: &str| {
        check_range(origin, field, v, *r.start(), *r.end(), unit)
    };
    let bad = |field: &str, value: String, why: &str| ProfileError::Invalid {
        path: origin.to_path_buf(),
        field: field.into(),
        value,
        why: why.into(),
    };
    if raw.name.trim().is_empty() || raw.name.chars().any(char::is_control) {
        return Err(bad(
            "name",
            format!("{:?}", raw.name),
            "must be one line, not empty",
        ));
    }
    within("bed.width_mm", raw.bed.width_mm, 1.0..=50_000.0, "mm")?;
    within("bed.height_mm", raw.bed.height_mm, 1.0..=10_000.0, "mm")?;
    let h = &raw.hpgl;
    within(
        "hpgl.units_per_mm",
        h.units_per_mm,
        1.0..=1000.0,
        "units/mm",
    )?;
    // HP-GL numbers: coordinates up to 2^23 units on cutters, ±32767 on old pen plotters.
    let max_units = raw.bed.width_mm.max(raw.bed.height_mm) * h.units_per_mm;
    within(
        "bed (in plotter units)",
        max_units,
        1.0..=8_388_607.0,
        "units",
    )?;
    for (i, v) in h.velocity_cm_s.iter().enumerate() {
        within(
            &format!("hpgl.velocity_cm_s[{i}]"),
            *v,
            0.01..=500.0,
            "cm/s",
        )?;
    }
    if h.velocity_cm_s[0] > h.velocity_cm_s[1] {
        return Err(bad(
            "hpgl.velocity_cm_s",
            format!("{:?}", h.velocity_cm_s),
            "the lowest speed must come first",
        ));
    }
    within("hpgl.travel_mm_s", h.travel_mm_s, 1.0..=5000.0, "mm/s")?;
    within("hpgl.accel_mm_s2", h.accel_mm_s2, 1.0..=100_000.0, "mm/s²")?;
    within("hpgl.pens", h.pens as f64, 1.0..=64.0, "pens")?;
    let force_range = match (h.force_g_per_unit, h.force_range) {
        (Some(g), Some(r)) => {
            within("hpgl.force_g_per_unit", g, 0.01..=1000.0, "g")?;
            within("hpgl.force_range[0]", r[0], 0.0..=10_000.0, "")?;
            within("hpgl.force_range[1]", r[1], r[0]..=10_000.0, "")?;
            r
        }
        (None, None) => [0.0, 0.0],
        _ => {
            return Err(bad(
                "hpgl.force_range",
                "one of force_g_per_unit and force_range".into(),
                "give both (the plotter takes FS) or neither",
            ))
        }
    };
    if h.force_g_per_unit.is_some() && h.dialect == Dialect::Hp7475a {
        return Err(bad(
            "hpgl.force_g_per_unit",
            "given".into(),
            "the HP 7475A dialect has no FS instruction",
        ));
    }
    match (h.tool, &raw.knife) {
        (ToolKind::Knife, Some(k)) => {
            within("knife.overcut_mm", k.overcut_mm, 0.0..=50.0, "mm")?;
            within("knife.swivel_min_deg", k.swivel_min_deg, 0.0..=180.0, "°")?;
            within(
                "knife.small_feature_mm",
                k.small_feature_mm,
                0.0..=1000.0,
                "mm",
            )?;
            within(
                "knife.small_feature_speed_pct",
                k.small_feature_speed_pct,
                1.0..=100.0,
                "%",
            )?;
        }
        (ToolKind::Knife, None) => {
            return Err(bad("knife", "missing".into(), "is required for a knife"))
        }
        (ToolKind::Pen, Some(_)) => {
            return Err(bad("knife", "given".into(), "is for a knife, not a pen"))
        }
        (ToolKind::Pen, None) => {}
    }
    let s = &raw.serial;
    within("serial.baud", s.baud as f64, 50.0..=4_000_000.0, "baud")?;
    within(
        "serial.buffer_bytes",
        s.buffer_bytes as f64,
        16.0..=16_777_216.0,
        "bytes",
    )?;
    within(
        "serial.headroom_bytes",
        s.headroom_bytes as f64,
        8.0..=(s.buffer_bytes as f64 / 2.0),
        "bytes (at most half the buffer)",
    )?;
    Ok(Plotter {
        name: raw.name,
        description: raw.description,
        bed: raw.bed,
        tool: h.tool,
        dialect: h.dialect,
        units_per_mm: h.units_per_mm,
        velocity_cm_s: h.velocity_cm_s,
        travel_mm_s: h.travel_mm_s,
        accel_mm_s2: h.accel_mm_s2,
        force_g_per_unit: h.force_g_per_unit,
        force_range,
        pens: h.pens,
        roll: h.roll,
        park: h.park,
        knife: raw.knife,
        serial: raw.serial,
    })
}

impl Plotter {
    /// The plotter as the G-code planner sees a machine: its area, its speeds, its tool (a knife
    /// with its overcut, or a pen), no arcs (HP-GL is written as straight `PD` segments). The
    /// planner places, checks, orders and routes the job exactly as it does for a GRBL machine.
    pub fn planner_machine(&self) -> Machine {
        let max_feed = self.velocity_cm_s[1] * 10.0 * 60.0;
        let z = ZLift {
            up_mm: 1.0,
            down_mm: 0.0,
            plunge_mm_min: max_feed,
        };
        Machine {
            name: self.name.clone(),
            description: self.description.clone(),
            bed: self.bed,
            motion: Motion {
                max_feed_mm_min: max_feed,
                rapid_mm_min: self.travel_mm_s * 60.0,
                accel_mm_s2: self.accel_mm_s2,
                junction_deviation_mm: 0.01,
                homing: false,
                axis_rate_mm_min: None,
                axis_accel_mm_s2: None,
                steps_per_mm: None,
                profile_steps_per_mm: None,
                idle_lock_ms: None,
            },
            tool: match (self.tool, self.knife) {
                (ToolKind::Knife, Some(k)) => Tool::Knife {
                    z,
                    overcut_mm: k.overcut_mm,
                    swivel_min_deg: k.swivel_min_deg,
                    small_feature_mm: k.small_feature_mm,
                    small_feature_speed_pct: k.small_feature_speed_pct,
                },
                _ => Tool::Pen(PenLift::Z(z)),
            },
            air_assist: false,
            frame_power_pct: 0.0,
            laser: None,
            // Grbl's serial model (the planner-starvation check) is the G-code writer's; this
            // crate writes the HP-GL and streams it with the plotter's own buffer and handshake.
            link: Link::default(),
            arcs: false,
        }
    }

    /// A length in mm as plotter units, rounded.
    pub fn units(&self, mm: f64) -> i64 {
        (mm * self.units_per_mm).round() as i64
    }

    /// The `VS` value for a speed in mm/s, within the plotter's range (cm/s, 0.1 steps).
    pub fn velocity(&self, mm_s: f64) -> f64 {
        let v = (mm_s / 10.0).clamp(self.velocity_cm_s[0], self.velocity_cm_s[1]);
        (v * 10.0).round() / 10.0
    }

    /// The `FS` value for a blade force in grams, within the plotter's range; `None` when it
    /// takes no `FS`.
    pub fn force(&self, grams: f64) -> Option<i64> {
        let g = self.force_g_per_unit?;
        let v = (grams / g).round();
        Some(v.clamp(self.force_range[0], self.force_range[1]) as i64)
    }

    /// The largest coordinate on each axis, plotter units.
    pub fn max_units(&self) -> [i64; 2] {
        [
            self.units(self.bed.width_mm),
            self.units(self.bed.height_mm),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_profiles_load() {
        for p in shipped() {
            let p = p.unwrap();
            assert!(p.units_per_mm > 0.0, "{}", p.name);
            assert!(p.serial.headroom_bytes * 2 <= p.serial.buffer_bytes);
        }
    }

    #[test]
    fn a_force_without_its_range_is_refused() {
        let text = SHIPPED[0].text.replace("force_range", "# force_range");
        let e = parse(&text, Path::new("x.toml")).unwrap_err().to_string();
        assert!(e.contains("x.toml") && e.contains("force_range"), "{e}");
    }
}
