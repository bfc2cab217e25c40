//! The machine and cut options `stencil gcode` and `make --emit gcode` share: which machine,
//! where the job goes on its bed, and cut settings that override the material's.

use anyhow::bail;
use clap::Args;

use stencil_gcode::machine::{self as machine_profile, Machine, Tool};
use stencil_gcode::{self as plan, Anchor, CutSettings, PlanConfig};

/// Which machine, and where the job goes on its bed.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Machine (G-code)")]
pub struct MachineArgs {
    /// Machine profile: a name (diode-400, co2-600x400, pen-a3, pen-servo, drag-knife) or a path to a
    /// .toml file. Default: diode-400, a generic GRBL 1.1 diode laser with a 400 x 400 mm bed.
    #[arg(long, value_name = "NAME|FILE")]
    pub machine: Option<String>,
    /// The job point placed at --offset: bottom-left, bottom-right, top-left, top-right or center
    /// (as seen from above, rear at the top). Default: the corner at the machine's origin.
    #[arg(long, value_name = "CORNER", value_parser = |s: &str| s.parse::<Anchor>())]
    pub origin: Option<Anchor>,
    /// Where that point is, mm, in the job's coordinates: the machine's when `send`/`frame`
    /// start from machine coordinates; from the work zero or the head's position with
    /// `--start-from work-zero|current` (so 0,0 puts the job's corner right there).
    #[arg(long, value_name = "X,Y", default_value = "0,0", value_parser = super::bounds::parse_offset, allow_hyphen_values = true)]
    pub offset: [f64; 2],
    /// Also cut the sheet's outline (a rectangle), after everything inside it.
    #[arg(long)]
    pub cut_outline: bool,
    /// Cut a drawing's open paths (lines, shapes not closed with Z) with a laser or knife, as
    /// open cuts. A pen draws them anyway; without this a cutting tool refuses them.
    #[arg(long)]
    pub cut_open_paths: bool,
    /// Write straight G1 segments only, no G2/G3 arcs (for a controller or sender without arcs;
    /// a machine profile with `arcs = false` does the same). By default each loop is fitted with
    /// lines and arcs within the outline's tolerance (make: --tolerance-mm; gcode: 0.02 mm, twice
    /// the SVG reader's flattening). With make, the outlines are then made straight within the
    /// whole --tolerance-mm of the traced outline, and the SVG and DXF carry the same polygons,
    /// which are what the width check judged.
    #[arg(long)]
    pub no_arcs: bool,
    /// Keep the cutting feed where the machine's serial line cannot bring the lines as fast as
    /// the feed uses them (tiny segments at a high feed: the planner starves and the head
    /// stutters there). By default the feed is lowered there, and the summary says where.
    #[arg(long)]
    pub keep_feed: bool,
}

impl MachineArgs {
    pub fn machine(&self) -> anyhow::Result<Machine> {
        Ok(machine_profile::load(self.machine.as_deref())?)
    }

    /// Where and how to cut; loops are written as arcs fitted within `arc_tolerance_mm` unless
    /// `--no-arcs`.
    pub fn plan_config(&self, settings: CutSettings, arc_tolerance_mm: f64) -> PlanConfig {
        PlanConfig {
            anchor: self.origin,
            offset: self.offset,
            cut_outline: self.cut_outline,
            cut_open_paths: self.cut_open_paths,
            settings,
            arc_tolerance_mm: if self.no_arcs { 0.0 } else { arc_tolerance_mm },
            keep_feed: self.keep_feed,
        }
    }
}

/// Cut settings given on the command line; each overrides the material's.
#[derive(Args, Debug, Clone, Default)]
#[command(next_help_heading = "Cut settings (override the material)")]
pub struct CutArgs {
    /// Laser power, % of full ($30): 0.1 to 100.
    #[arg(long, value_name = "PCT", value_parser = |s: &str| super::bounds::number_in(s, 0.1..=100.0, " %"))]
    pub power: Option<f64>,
    /// Cutting feed, mm/min: 1 to 200000, and at most the machine's max feed.
    #[arg(long, value_name = "MM_MIN", value_parser = super::bounds::parse_feed)]
    pub speed: Option<f64>,
    /// Times each loop is cut: 1 to 100.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=plan::bounds::MAX_PASSES as i64))]
    pub passes: Option<u32>,
    /// Drag knife: how far the blade tip trails its axis, mm (0 = no corner compensation; at
    /// most 5).
    #[arg(long, value_name = "MM", value_parser = |s: &str| super::bounds::number_in(s, 0.0..=plan::bounds::MAX_BLADE_OFFSET_MM, " mm"))]
    pub blade_offset: Option<f64>,
    /// Laser: air assist (on Grbl's coolant output) on with the beam, M8 before the first cut and
    /// M9 at the end: on or off [default: the material's air_assist, else the machine's].
    #[arg(long, value_name = "on|off", value_parser = clap::builder::BoolishValueParser::new())]
    pub air_assist: Option<bool>,
}

impl CutArgs {
    /// Whether the flags alone give every setting the tool uses (then no material is needed).
    pub fn covers_all(&self, machine: &Machine) -> bool {
        let laser = matches!(machine.tool, Tool::Laser { .. });
        self.speed.is_some() && self.passes.is_some() && (!laser || self.power.is_some())
    }

    /// Apply the overrides to `base` (from the material), or build settings from the flags alone
    /// (power only matters to a laser).
    pub fn settings(
        &self,
        base: Option<CutSettings>,
        machine: &Machine,
    ) -> anyhow::Result<CutSettings> {
        let laser = matches!(machine.tool, Tool::Laser { .. });
        Ok(match base {
            Some(b) => CutSettings {
                power_pct: self.power.unwrap_or(b.power_pct),
                speed_mm_min: self.speed.unwrap_or(b.speed_mm_min),
                passes: self.passes.unwrap_or(b.passes),
                blade_offset_mm: self.blade_offset.unwrap_or(b.blade_offset_mm),
                air_assist: self.air_assist.unwrap_or(b.air_assist),
            },
            None => {
                let (power, Some(speed)) = (self.power.or((!laser).then_some(100.0)), self.speed)
                else {
                    bail!(
                        "no cut settings: name a material (--material) or give --speed MM_MIN{}",
                        if laser { " and --power PCT" } else { "" }
                    );
                };
                let Some(power) = power else {
                    bail!("no laser power: name a material (--material) or give --power PCT");
                };
                CutSettings {
                    power_pct: power,
                    speed_mm_min: speed,
                    passes: self.passes.unwrap_or(1),
                    blade_offset_mm: self.blade_offset.unwrap_or(0.0),
                    air_assist: self.air_assist.unwrap_or(laser && machine.air_assist),
                }
            }
        })
    }

    /// Whether any cut option was given.
    pub fn any(&self) -> bool {
        self.power.is_some()
            || self.speed.is_some()
            || self.passes.is_some()
            || self.blade_offset.is_some()
            || self.air_assist.is_some()
    }
}
