//! Machine profiles: the bed, the motion limits and the tool of a GRBL 1.1 machine, read from TOML
//! (`profiles/machines/*.toml`) and validated once at load.
//!
//! A profile names where machine (0, 0) is on the bed (`origin`), so the planner can place a job
//! right-reading on any machine; the S range mirrors Grbl's `$30`/`$31`; the motion limits feed the
//! time estimate. The shipped profiles are compiled into the binary, so `--machine diode-400` works
//! from any folder; a path to a `.toml` file loads a user's own (see [`load`]).

use std::ops::RangeInclusive;
use std::path::Path;

use serde::Deserialize;

use stencil_io::profile::{check_range, embedded, parse_toml, resolve, ProfileError, Shipped};
use stencil_io::shipped;

use crate::bounds;
use crate::interpret::{CutRule, Move};
use crate::num::num;

/// The machine used when none is named: a generic GRBL 1.1 diode laser, 400 × 400 mm bed.
pub const DEFAULT_MACHINE: &str = "diode-400";

/// The shipped profiles, embedded so an installed binary has them.
pub const SHIPPED: &[Shipped] = &[
    shipped!("machines", "diode-400"),
    shipped!("machines", "co2-600x400"),
    shipped!("machines", "pen-a3"),
    shipped!("machines", "pen-servo"),
    shipped!("machines", "drag-knife"),
];

/// Corners turning less than this (degrees) are cut without swivelling a drag knife, unless its
/// profile says otherwise (`tool.swivel_min_deg`).
pub const DEFAULT_SWIVEL_MIN_DEG: f64 = 10.0;

/// A corner of the bed, as seen from above with the rear (far side, +Y on most machines) at the top.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Corner {
    #[default]
    /// Front left.
    BottomLeft,
    /// Front right.
    BottomRight,
    /// Back left.
    TopLeft,
    /// Back right.
    TopRight,
}

impl Corner {
    /// The name used in profiles and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Corner::BottomLeft => "bottom-left",
            Corner::BottomRight => "bottom-right",
            Corner::TopLeft => "top-left",
            Corner::TopRight => "top-right",
        }
    }
    /// Whether this corner is on the right (high bed-view X) side.
    pub fn right(self) -> bool {
        matches!(self, Corner::BottomRight | Corner::TopRight)
    }
    /// Whether this corner is on the top (rear, high bed-view Y) side.
    pub fn top(self) -> bool {
        matches!(self, Corner::TopLeft | Corner::TopRight)
    }
}

/// The bed: the area the head can reach, in machine millimetres from the origin corner.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bed {
    /// X travel, mm.
    pub width_mm: f64,
    /// Y travel, mm.
    pub height_mm: f64,
    /// Where machine (0, 0) is; axes point away from it (into the bed).
    #[serde(default)]
    pub origin: Corner,
}

/// Motion limits, as set in Grbl (`$110`/`$111` max rates, `$120`/`$121` accelerations, `$11`):
/// what the time estimate plans with.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Motion {
    /// Highest feed the machine cuts at, mm/min; programmed feeds above it are refused.
    pub max_feed_mm_min: f64,
    /// Rate of G0 travel, mm/min (Grbl's max rate, `$110`).
    pub rapid_mm_min: f64,
    /// Acceleration, mm/s² (`$120`).
    pub accel_mm_s2: f64,
    /// Junction deviation, mm (`$11`, Grbl's default 0.010).
    #[serde(default = "default_jd")]
    pub junction_deviation_mm: f64,
    /// The machine has homing switches and homes with `$H` (Grbl `$22=1`): `send --recover`
    /// homes it first, since a crash or power loss loses the position.
    #[serde(default)]
    pub homing: bool,
    /// Per-axis max rates X, Y, Z, mm/min (`$110`..`$112`; this and the three below come from a
    /// controller's `$$`, never from a profile); `None`: `rapid_mm_min` on every axis. Grbl
    /// limits a block by its tightest axis, so a plunge on a slow Z runs at Z's rate.
    #[serde(skip)]
    pub axis_rate_mm_min: Option<[f64; 3]>,
    /// Per-axis accelerations X, Y, Z, mm/s² (`$120`..`$122`); `None`: `accel_mm_s2` on every
    /// axis.
    #[serde(skip)]
    pub axis_accel_mm_s2: Option<[f64; 3]>,
    /// Steps per mm X, Y, Z (`$100`..`$102`). Grbl plans every block between whole steps, so a
    /// segment a few steps long runs in the direction its rounded steps give, and its junctions
    /// are planned for that direction; `None`: exact coordinates.
    #[serde(skip)]
    pub steps_per_mm: Option<[f64; 3]>,
    /// The profile's steps per mm (`steps_per_mm` in `[motion]`, Grbl's `$100`/`$101`), taken for
    /// every axis where a controller's `$$` does not give [`Motion::steps_per_mm`]; optional.
    #[serde(default, rename = "steps_per_mm")]
    pub profile_steps_per_mm: Option<f64>,
    /// `$1`, ms: each time the motion runs out before more (a spindle or coolant change, a dwell,
    /// `M0`) Grbl's stepper interrupt holds the motors this long before the next motion can
    /// start; 255 keeps them on and costs nothing. `None`: Grbl's default, 25.
    #[serde(skip)]
    pub idle_lock_ms: Option<f64>,
}

impl Motion {
    /// The max rate (mm/min) and acceleration (mm/s²) of each axis X, Y, Z.
    pub fn axes(&self) -> ([f64; 3], [f64; 3]) {
        (
            self.axis_rate_mm_min.unwrap_or([self.rapid_mm_min; 3]),
            self.axis_accel_mm_s2.unwrap_or([self.accel_mm_s2; 3]),
        )
    }

    /// Steps per mm of each axis X, Y, Z: the controller's, else the profile's, else unknown.
    pub fn steps(&self) -> Option<[f64; 3]> {
        self.steps_per_mm
            .or(self.profile_steps_per_mm.map(|s| [s; 3]))
    }

    /// Seconds Grbl's stepper interrupt holds the motors at each full stop (`$1`; 255: none).
    pub fn stop_lock_s(&self) -> f64 {
        match self.idle_lock_ms.unwrap_or(25.0) {
            ms if ms >= 255.0 || ms <= 0.0 => 0.0,
            ms => ms / 1000.0,
        }
    }
}

fn default_jd() -> f64 {
    0.01
}

/// How jobs reach the controller: its serial speed and buffers (a profile's `[link]`; every
/// field optional). The defaults are Grbl 1.1h on an AVR (Arduino Uno/Nano): `BAUD_RATE 115200`
/// in its `config.h`, a 128-byte receive buffer (`serial.h`) and 16 planner slots of which 15
/// hold blocks (`planner.h`); its `$I` answers `[OPT:V,15,128]`. The starvation estimate
/// times the lines over it.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Link {
    /// Serial speed, baud; a character is 10 bits on the line (start, 8 data, stop).
    #[serde(default = "default_baud")]
    pub baud: u32,
    /// The controller's serial receive buffer, bytes (the second number of `$I`'s `[OPT:]`).
    #[serde(default = "default_rx")]
    pub rx_buffer_bytes: u32,
    /// Planner blocks it holds, the running one included (the first number of `[OPT:]`); the
    /// starvation estimate plans with at most 128 of them.
    #[serde(default = "default_planner")]
    pub planner_blocks: u32,
}

impl Default for Link {
    fn default() -> Self {
        Link {
            baud: default_baud(),
            rx_buffer_bytes: default_rx(),
            planner_blocks: default_planner(),
        }
    }
}

fn default_baud() -> u32 {
    115_200
}

fn default_rx() -> u32 {
    crate::limits::RX_BUFFER_BYTES as u32
}

fn default_planner() -> u32 {
    crate::limits::PLANNER_BLOCKS as u32
}

/// How a pen is raised and lowered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PenLift {
    /// A servo or solenoid on the spindle output: `M3 S<down_s>` lowers, `M5` raises.
    Spindle {
        /// The S that lowers it.
        down_s: f64,
    },
    /// A Z axis: `G0 Z<up>` raises, `G1 Z<down> F<plunge>` lowers.
    Z(ZLift),
}

/// Z heights of a tool on a Z axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZLift {
    /// Raised, Z mm.
    pub up_mm: f64,
    /// Lowered (cutting), Z mm.
    pub down_mm: f64,
    /// Feed for lowering the tool, mm/min.
    pub plunge_mm_min: f64,
}

/// The tool, and how it is switched on and off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tool {
    /// A laser in Grbl laser mode (`$32=1`): `M4` dynamic power, S from the material's power %
    /// scaled to `s_max` (`$30`); never below `s_min` (`$31`) while cutting.
    Laser {
        /// `$30`: the S of full power.
        s_max: f64,
        /// `$31`: the least S while cutting.
        s_min: f64,
    },
    /// A pen, and how it is lifted.
    Pen(PenLift),
    /// A drag knife on a Z axis; `overcut_mm` continues past the start of each loop so the cut
    /// closes cleanly.
    Knife {
        /// Its Z heights.
        z: ZLift,
        /// How far past the start each loop is cut, mm.
        overcut_mm: f64,
        /// Corners turning at least this many degrees are swivelled around (blade-offset
        /// compensation); `tool.swivel_min_deg`, default 10.
        swivel_min_deg: f64,
        /// Loops whose longer side is below this, mm, are cut at `small_feature_speed_pct` of
        /// the speed (`tool.small_feature_mm`, default 0: none).
        small_feature_mm: f64,
        /// The speed of small features, % (`tool.small_feature_speed_pct`, default 100).
        small_feature_speed_pct: f64,
    },
}

impl Tool {
    /// The tool in words: laser, pen or knife.
    pub fn kind(&self) -> &'static str {
        match self {
            Tool::Laser { .. } => "laser",
            Tool::Pen(_) => "pen",
            Tool::Knife { .. } => "knife",
        }
    }
}

/// What makes a laser's light: the two kinds hobby machines have, whose cut settings differ for
/// the same material (a blue diode's 450 nm passes through clear acrylic and PET that a CO2's
/// 10.6 µm is absorbed by, and its spot and power differ).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LaserSource {
    /// A diode laser.
    Diode,
    /// A CO2 tube.
    Co2,
}

impl LaserSource {
    /// The name used in profiles (`tool.source`, a material's `laser`).
    pub fn name(self) -> &'static str {
        match self {
            LaserSource::Diode => "diode",
            LaserSource::Co2 => "co2",
        }
    }
}

/// A laser's source and power: what a material's cut settings are looked up by. `watts` is a
/// diode's optical output (not its electrical input: a "40 W" module gives about 5.5 W of light)
/// and a CO2's tube rating.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaserPower {
    /// Diode or CO2.
    pub source: LaserSource,
    /// Optical (diode) or tube (CO2) power, W.
    pub watts: f64,
}

/// The kind of machine, as material profiles key their cut settings: a laser by its source and
/// power (unknown when the profile does not give them), a pen, a drag knife.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MachineKind {
    /// A laser, of this power when known.
    Laser(Option<LaserPower>),
    /// A pen.
    Pen,
    /// A drag knife.
    Knife,
}

impl std::fmt::Display for MachineKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MachineKind::Laser(Some(p)) => {
                let src = match p.source {
                    LaserSource::Diode => "diode",
                    LaserSource::Co2 => "CO2",
                };
                write!(f, "{src} laser {} W", num(p.watts))
            }
            MachineKind::Laser(None) => f.write_str("laser (source and power not given)"),
            MachineKind::Pen => f.write_str("pen"),
            MachineKind::Knife => f.write_str("drag knife"),
        }
    }
}

/// A validated machine profile.
#[derive(Clone, Debug, PartialEq)]
pub struct Machine {
    /// The profile's name.
    pub name: String,
    /// One line about the machine.
    pub description: String,
    /// The bed.
    pub bed: Bed,
    /// Grbl's motion settings.
    pub motion: Motion,
    /// The tool.
    pub tool: Tool,
    /// Laser only: the machine has air assist on Grbl's coolant output, switched with `M8`/`M9`
    /// (`tool.air_assist`). Jobs turn it on with the beam unless the material says otherwise.
    pub air_assist: bool,
    /// Laser only: the power, % of `s_max`, at which `stencil frame` traces a job's outline so
    /// the user sees it (`tool.frame_power_pct`, default 0: the frame is traced dark). Kept low
    /// ([`bounds::FRAME_POWER_PCT`]): it must show the beam, not mark the sheet.
    pub frame_power_pct: f64,
    /// Laser only: its source and power (`tool.source`, `tool.watts`), which a material's cut
    /// settings are chosen by; `None` when the profile does not say (a profile written before
    /// they existed).
    pub laser: Option<LaserPower>,
    /// The serial link and the controller's buffers (`[link]`), for the starvation estimate.
    pub link: Link,
    /// The firmware runs G2/G3 arcs (`arcs`, default true: every Grbl 1.1 does). A profile says
    /// `arcs = false` for a controller or sender that does not (some Grbl ports and plotter
    /// firmwares drop them): its jobs are written with straight G1 segments only.
    pub arcs: bool,
}

impl Machine {
    /// The machine's kind as material profiles key their cut settings.
    pub fn kind(&self) -> MachineKind {
        match self.tool {
            Tool::Laser { .. } => MachineKind::Laser(self.laser),
            Tool::Pen(_) => MachineKind::Pen,
            Tool::Knife { .. } => MachineKind::Knife,
        }
    }
}

/// A job that leaves the bed: the first side it crosses, how far it reaches, and the line of the
/// move that reaches there (for G-code files).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error(
    "job reaches {axis} {reached:.1} mm{}; the bed of {machine} is {size} mm {dim} ({axis} 0..{size})",
    line.map(|l| format!(" at line {l}")).unwrap_or_default()
)]
pub struct OffBed {
    /// The machine's name.
    pub machine: String,
    /// X or Y.
    pub axis: char,
    /// How far the job reaches, mm.
    pub reached: f64,
    /// The bed's width (X) or depth (Y), mm.
    pub size: f64,
    /// "wide" or "deep".
    pub dim: &'static str,
    /// The program line that reaches it.
    pub line: Option<usize>,
}

/// How far past the bed's edge still counts as on it (rounding of written coordinates), mm.
pub const BED_EPS_MM: f64 = 1e-3;

impl Machine {
    /// Check that everything from `min` to `max` (machine mm; the axes point into the bed from
    /// its origin corner, so the bed is X 0..width, Y 0..height) lies on the bed: the one check
    /// `make`, `gcode`, `send`, `estimate` and `simulate` share. `lines` names the program lines
    /// reaching `min` and `max` per axis, where known. The side exceeded most is reported.
    pub fn check_extent(
        &self,
        min: [f64; 2],
        max: [f64; 2],
        lines: Option<([usize; 2], [usize; 2])>,
    ) -> Result<(), OffBed> {
        let size = [self.bed.width_mm, self.bed.height_mm];
        let mut worst: Option<(f64, OffBed)> = None;
        for a in 0..2 {
            for (reached, over, line) in [
                (min[a], -min[a], lines.map(|l| l.0[a])),
                (max[a], max[a] - size[a], lines.map(|l| l.1[a])),
            ] {
                if over > BED_EPS_MM && worst.as_ref().is_none_or(|w| over > w.0) {
                    worst = Some((
                        over,
                        OffBed {
                            machine: self.name.clone(),
                            axis: ['X', 'Y'][a],
                            reached,
                            size: size[a],
                            dim: ["wide", "deep"][a],
                            line: line.filter(|&l| l > 0),
                        },
                    ));
                }
            }
        }
        worst.map_or(Ok(()), |(_, e)| Err(e))
    }

    /// [`Machine::check_extent`] for the moves of a G-code program.
    pub fn check_moves(&self, moves: &[Move]) -> Result<(), OffBed> {
        crate::interpret::extent(moves).map_or(Ok(()), |e| {
            self.check_extent(e.min, e.max, Some((e.min_line, e.max_line)))
        })
    }

    /// Which moves of `moves` cut on this machine: the rule the program itself shows
    /// ([`CutRule::infer`]), except that a pen servo on the spindle output draws in G0 too.
    pub fn cut_rule(&self, moves: &[Move]) -> CutRule {
        let rule = CutRule::infer(moves);
        match self.tool {
            Tool::Pen(PenLift::Spindle { .. }) => rule.for_spindle_pen(),
            // A laser cuts where its beam is on, whatever height its head is at: a job focused
            // at Z5 that travels at Z0 has two Z levels, which alone would read as a pen on Z.
            Tool::Laser { .. } if moves.iter().any(|m| m.power > 0.0) => CutRule::Spindle,
            _ => rule,
        }
    }
}

// ---- raw TOML shape -------------------------------------------------------------------------

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMachine {
    name: String,
    #[serde(default)]
    description: String,
    /// See [`Machine::arcs`].
    #[serde(default)]
    arcs: Option<bool>,
    bed: Bed,
    motion: Motion,
    #[serde(default)]
    link: Link,
    tool: RawTool,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum ToolKind {
    Laser,
    Pen,
    Knife,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum LiftKind {
    Spindle,
    Z,
}

/// All tool fields, checked against `kind` in [`validate`] (one flat table is what users edit).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTool {
    kind: ToolKind,
    /// Laser: `$30`. Pen on the spindle output: the S that lowers it.
    s_max: Option<f64>,
    /// Laser: `$31`.
    s_min: Option<f64>,
    /// Pen: "spindle" or "z".
    lift: Option<LiftKind>,
    pen_down_s: Option<f64>,
    z_up_mm: Option<f64>,
    z_down_mm: Option<f64>,
    plunge_mm_min: Option<f64>,
    overcut_mm: Option<f64>,
    /// Knife: the least corner angle swivelled around, degrees.
    swivel_min_deg: Option<f64>,
    /// Knife: loops smaller than this (mm) are cut slower.
    small_feature_mm: Option<f64>,
    /// Knife: their speed, % of the cut speed.
    small_feature_speed_pct: Option<f64>,
    /// Laser: air assist wired to the coolant output (M8 on, M9 off).
    air_assist: Option<bool>,
    /// Laser: power % for framing.
    frame_power_pct: Option<f64>,
    /// Laser: "diode" or "co2".
    source: Option<LaserSource>,
    /// Laser: optical output (diode) or tube rating (CO2), W.
    watts: Option<f64>,
}

/// Parse and validate a profile's text. `origin` (the file) is used in errors.
pub fn parse(text: &str, origin: &Path) -> Result<Machine, ProfileError> {
    validate(parse_toml(text, origin)?, origin)
}

fn validate(raw: RawMachine, origin: &Path) -> Result<Machine, ProfileError> {
    let c = Checker { origin };
    c.name(&raw.name)?;
    c.bed(&raw.bed)?;
    c.motion(&raw.motion)?;
    c.link(&raw.link)?;
    let t = &raw.tool;
    let tool = c.tool(t)?;
    let frame_power_pct = c.within(
        "tool.frame_power_pct",
        t.frame_power_pct.unwrap_or(0.0),
        bounds::FRAME_POWER_PCT,
        "%",
    )?;
    let laser = c.laser_power(t)?;
    Ok(Machine {
        laser,
        air_assist: t.air_assist.unwrap_or(false),
        name: raw.name,
        description: raw.description,
        bed: raw.bed,
        motion: raw.motion,
        tool,
        frame_power_pct,
        link: raw.link,
        arcs: raw.arcs.unwrap_or(true),
    })
}

/// The checks of one profile file, each naming the field it refuses.
struct Checker<'a> {
    origin: &'a Path,
}

impl Checker<'_> {
    fn bad(&self, field: &str, value: String, why: String) -> ProfileError {
        ProfileError::Invalid {
            path: self.origin.to_path_buf(),
            field: field.to_string(),
            value,
            why,
        }
    }

    fn within(
        &self,
        field: &str,
        v: f64,
        r: RangeInclusive<f64>,
        unit: &str,
    ) -> Result<f64, ProfileError> {
        check_range(self.origin, field, v, *r.start(), *r.end(), unit).map(|_| v)
    }

    /// A field the tool `kind` needs, within `r`.
    fn required(
        &self,
        kind: ToolKind,
        field: &'static str,
        v: Option<f64>,
        r: RangeInclusive<f64>,
        unit: &str,
    ) -> Result<f64, ProfileError> {
        let v = v.ok_or_else(|| {
            self.bad(
                field,
                "missing".into(),
                format!("is required for a {} tool", kind_name(kind)),
            )
        })?;
        self.within(field, v, r, unit)
    }

    /// One line, not empty, not too long to print in a G-code comment.
    fn name(&self, name: &str) -> Result<(), ProfileError> {
        if name.trim().is_empty() {
            return Err(self.bad("name", "\"\"".into(), "must not be empty".into()));
        }
        if name.chars().count() > bounds::NAME_CHARS || name.chars().any(char::is_control) {
            return Err(self.bad(
                "name",
                format!("\"{}\"", stencil_io::excerpt(name)),
                format!(
                    "must be one line of at most {} characters",
                    bounds::NAME_CHARS
                ),
            ));
        }
        Ok(())
    }

    fn bed(&self, bed: &Bed) -> Result<(), ProfileError> {
        self.within("bed.width_mm", bed.width_mm, bounds::BED_MM, "mm")?;
        self.within("bed.height_mm", bed.height_mm, bounds::BED_MM, "mm")?;
        Ok(())
    }

    fn motion(&self, m: &Motion) -> Result<(), ProfileError> {
        for (field, v, r, unit) in [
            (
                "motion.max_feed_mm_min",
                m.max_feed_mm_min,
                bounds::FEED_MM_MIN,
                "mm/min",
            ),
            (
                "motion.rapid_mm_min",
                m.rapid_mm_min,
                bounds::FEED_MM_MIN,
                "mm/min",
            ),
            (
                "motion.accel_mm_s2",
                m.accel_mm_s2,
                bounds::ACCEL_MM_S2,
                "mm/s²",
            ),
            (
                "motion.junction_deviation_mm",
                m.junction_deviation_mm,
                bounds::JUNCTION_DEVIATION_MM,
                "mm",
            ),
        ] {
            self.within(field, v, r, unit)?;
        }
        if let Some(steps) = m.profile_steps_per_mm {
            self.within(
                "motion.steps_per_mm",
                steps,
                bounds::STEPS_PER_MM,
                "steps/mm",
            )?;
        }
        Ok(())
    }

    fn link(&self, l: &Link) -> Result<(), ProfileError> {
        self.within("link.baud", f64::from(l.baud), bounds::BAUD, "baud")?;
        self.within(
            "link.rx_buffer_bytes",
            f64::from(l.rx_buffer_bytes),
            bounds::RX_BUFFER_BYTES,
            "bytes",
        )?;
        self.within(
            "link.planner_blocks",
            f64::from(l.planner_blocks),
            bounds::PLANNER_BLOCKS,
            "blocks",
        )?;
        Ok(())
    }

    /// The tool of its kind, refusing fields that belong to other kinds.
    fn tool(&self, t: &RawTool) -> Result<Tool, ProfileError> {
        self.foreign_fields(t)?;
        match t.kind {
            ToolKind::Laser => self.laser(t),
            ToolKind::Pen => self.pen(t),
            ToolKind::Knife => Ok(Tool::Knife {
                overcut_mm: self.within(
                    "tool.overcut_mm",
                    t.overcut_mm.unwrap_or(0.0),
                    bounds::OVERCUT_MM,
                    "mm",
                )?,
                z: self.z_lift(t)?,
                swivel_min_deg: self.within(
                    "tool.swivel_min_deg",
                    t.swivel_min_deg.unwrap_or(DEFAULT_SWIVEL_MIN_DEG),
                    0.0..=180.0,
                    "°",
                )?,
                small_feature_mm: self.within(
                    "tool.small_feature_mm",
                    t.small_feature_mm.unwrap_or(0.0),
                    0.0..=1000.0,
                    "mm",
                )?,
                small_feature_speed_pct: self.within(
                    "tool.small_feature_speed_pct",
                    t.small_feature_speed_pct.unwrap_or(100.0),
                    1.0..=100.0,
                    "%",
                )?,
            }),
        }
    }

    /// Fields that belong to other tool kinds are mistakes worth naming.
    fn foreign_fields(&self, t: &RawTool) -> Result<(), ProfileError> {
        use ToolKind::{Knife, Laser, Pen};
        let fields: [(&str, bool, &[ToolKind]); 15] = [
            ("tool.source", t.source.is_some(), &[Laser]),
            ("tool.watts", t.watts.is_some(), &[Laser]),
            ("tool.s_max", t.s_max.is_some(), &[Laser]),
            ("tool.s_min", t.s_min.is_some(), &[Laser]),
            ("tool.lift", t.lift.is_some(), &[Pen]),
            ("tool.pen_down_s", t.pen_down_s.is_some(), &[Pen]),
            ("tool.z_up_mm", t.z_up_mm.is_some(), &[Pen, Knife]),
            ("tool.z_down_mm", t.z_down_mm.is_some(), &[Pen, Knife]),
            (
                "tool.plunge_mm_min",
                t.plunge_mm_min.is_some(),
                &[Pen, Knife],
            ),
            ("tool.overcut_mm", t.overcut_mm.is_some(), &[Knife]),
            ("tool.swivel_min_deg", t.swivel_min_deg.is_some(), &[Knife]),
            (
                "tool.small_feature_mm",
                t.small_feature_mm.is_some(),
                &[Knife],
            ),
            (
                "tool.small_feature_speed_pct",
                t.small_feature_speed_pct.is_some(),
                &[Knife],
            ),
            ("tool.air_assist", t.air_assist.is_some(), &[Laser]),
            (
                "tool.frame_power_pct",
                t.frame_power_pct.is_some(),
                &[Laser],
            ),
        ];
        for (field, present, kinds) in fields {
            if present && !kinds.contains(&t.kind) {
                return Err(self.bad(
                    field,
                    "set".into(),
                    format!("does not apply to a {} tool; remove it", kind_name(t.kind)),
                ));
            }
        }
        Ok(())
    }

    /// A laser's source and power: both or neither (a profile without them still loads, and only
    /// settings given on the command line or kept with `stencil profiles set` apply to it).
    fn laser_power(&self, t: &RawTool) -> Result<Option<LaserPower>, ProfileError> {
        match (t.source, t.watts) {
            (Some(source), Some(w)) => Ok(Some(LaserPower {
                source,
                watts: self.within("tool.watts", w, bounds::WATTS, "W")?,
            })),
            (None, None) => Ok(None),
            (Some(_), None) => Err(self.bad(
                "tool.watts",
                "missing".into(),
                "is required with tool.source: the diode's optical output or the CO2 tube's \
                 rating, W"
                    .into(),
            )),
            (None, Some(_)) => Err(self.bad(
                "tool.source",
                "missing".into(),
                "is required with tool.watts: \"diode\" or \"co2\"".into(),
            )),
        }
    }

    fn laser(&self, t: &RawTool) -> Result<Tool, ProfileError> {
        let s_max = self.within("tool.s_max", t.s_max.unwrap_or(1000.0), bounds::S, "")?;
        let s_min = t.s_min.unwrap_or(0.0);
        if !(s_min.is_finite() && s_min >= 0.0 && s_min < s_max) {
            return Err(self.bad(
                "tool.s_min",
                s_min.to_string(),
                format!("must be >= 0 and below tool.s_max ({s_max})"),
            ));
        }
        Ok(Tool::Laser { s_max, s_min })
    }

    /// A pen lifted by the spindle output (a servo: Z fields do not apply) or by a Z axis (the
    /// spindle's down S does not apply).
    fn pen(&self, t: &RawTool) -> Result<Tool, ProfileError> {
        match t.lift {
            Some(LiftKind::Spindle) => {
                for (f, v) in [
                    ("tool.z_up_mm", t.z_up_mm),
                    ("tool.z_down_mm", t.z_down_mm),
                    ("tool.plunge_mm_min", t.plunge_mm_min),
                ] {
                    if v.is_some() {
                        return Err(self.bad(
                            f,
                            "set".into(),
                            "does not apply with lift = \"spindle\"".into(),
                        ));
                    }
                }
                Ok(Tool::Pen(PenLift::Spindle {
                    down_s: self.required(
                        t.kind,
                        "tool.pen_down_s",
                        t.pen_down_s,
                        bounds::S,
                        "",
                    )?,
                }))
            }
            Some(LiftKind::Z) => {
                if t.pen_down_s.is_some() {
                    return Err(self.bad(
                        "tool.pen_down_s",
                        "set".into(),
                        "does not apply with lift = \"z\"".into(),
                    ));
                }
                Ok(Tool::Pen(PenLift::Z(self.z_lift(t)?)))
            }
            None => Err(self.bad(
                "tool.lift",
                "missing".into(),
                "is required for a pen: \"spindle\" (M3/M5) or \"z\"".into(),
            )),
        }
    }

    /// Up and down heights (up above down) and the plunge feed of a tool on a Z axis.
    fn z_lift(&self, t: &RawTool) -> Result<ZLift, ProfileError> {
        let up = self.required(t.kind, "tool.z_up_mm", t.z_up_mm, bounds::Z_MM, "mm")?;
        let down = self.required(t.kind, "tool.z_down_mm", t.z_down_mm, bounds::Z_MM, "mm")?;
        let plunge = self.required(
            t.kind,
            "tool.plunge_mm_min",
            t.plunge_mm_min,
            bounds::FEED_MM_MIN,
            "mm/min",
        )?;
        if up <= down {
            return Err(self.bad(
                "tool.z_up_mm",
                up.to_string(),
                format!("must be above tool.z_down_mm ({down})"),
            ));
        }
        Ok(ZLift {
            up_mm: up,
            down_mm: down,
            plunge_mm_min: plunge,
        })
    }
}

fn kind_name(k: ToolKind) -> &'static str {
    match k {
        ToolKind::Laser => "laser",
        ToolKind::Pen => "pen",
        ToolKind::Knife => "knife",
    }
}

/// Names of the shipped profiles.
pub fn builtin_names() -> Vec<&'static str> {
    SHIPPED.iter().map(|s| s.name).collect()
}

/// Resolve `--machine` through the shared loader, `stencil_io::profile` (as materials are): a
/// path, a name in `./profiles/machines/`, or a shipped name. `None` gives the shipped
/// [`DEFAULT_MACHINE`] as embedded, whatever `./profiles/` holds.
pub fn load(name_or_path: Option<&str>) -> Result<Machine, ProfileError> {
    let (raw, origin): (RawMachine, _) = match name_or_path {
        Some(arg) => resolve(arg, "machines", SHIPPED)?,
        None => embedded(DEFAULT_MACHINE, "machines", SHIPPED)?,
    };
    validate(raw, &origin)
}

#[cfg(test)]
mod tests;
