//! The material profiles: what a sheet is, read from TOML and checked once.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use stencil_io::profile::{check_range, embedded, load_toml, resolve, ProfileError, Shipped};
use stencil_io::shipped;

use stencil_gcode::machine::Tool;

/// The profile used when none is named: 0.3 mm cardstock, the most common hobby stencil sheet.
pub const DEFAULT_MATERIAL: &str = "cardstock";

/// The profile used when none is named and the machine draws with a pen: drawing paper.
pub(crate) const DEFAULT_PEN_MATERIAL: &str = "plotter-paper";

/// The profile used when none is named and the machine cuts with a drag knife: cardstock, as for
/// a laser, with knife settings.
pub(crate) const DEFAULT_KNIFE_MATERIAL: &str = "cardstock-knife";

/// The material used when none is named, for a machine with this tool: a laser material for a
/// laser, and so on, so `--machine pen-a3` alone works.
pub fn default_for(tool: &Tool) -> &'static str {
    match tool {
        Tool::Pen(_) => DEFAULT_PEN_MATERIAL,
        Tool::Knife { .. } => DEFAULT_KNIFE_MATERIAL,
        Tool::Laser { .. } => DEFAULT_MATERIAL,
    }
}

/// `max_bridge_mm` when a profile does not give it, as a multiple of `min_bridge_mm`: 4. A bridge
/// many times the minimum adds strength handling never calls on while it hides the picture; four
/// still lets the width follow the island and stays in the range stencil guides draw (1–5 mm in
/// card and film, up to 15 mm in 3 mm plywood).
pub(crate) const DEFAULT_MAX_BRIDGE_RATIO: f64 = 4.0;

/// The strength numbers a profile without them gets: card-like, the weakest sheet stencils are
/// commonly cut from, so an unknown material is judged as if it were floppy rather than stiff
/// (bending modulus 3 GPa and density 900 kg/m³, as `cardstock.toml`; sag limit 1 mm; two bridges
/// for islands longer than 40 mm). See [`Strength::youngs_modulus_gpa`].
pub(crate) const DEFAULT_STRENGTH: Strength = Strength {
    youngs_modulus_gpa: 3.0,
    density_kg_m3: 900.0,
    max_sag_mm: 1.0,
    two_bridges_above_mm: 40.0,
};

/// What the bridge stage needs to judge whether an island's bridges hold it (see
/// `bridge::strength`). All four are optional in a profile file: one that gives some of them gets
/// `DEFAULT_STRENGTH`'s value for the others; one that gives none is not judged at all (its sag
/// limit and two-bridge size are infinite, and `make` says so): strength numbers are not invented
/// for a material nothing is known of (the corpus's "pixel" material, with no physical limits).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Strength {
    /// Bending (Young's) modulus of the sheet, GPa (paper 2–6, PET 4, plywood 8, steel 193).
    pub youngs_modulus_gpa: f64,
    /// Density, kg/m³ (paper 700–900, PMMA 1190, aluminium 2700, steel 8000).
    pub density_kg_m3: f64,
    /// The most an island may sag under its own weight on its bridges, mm.
    pub max_sag_mm: f64,
    /// Islands longer than this (along their main axis) get at least two bridges, mm: one bridge
    /// is a hinge.
    pub two_bridges_above_mm: f64,
}

impl Strength {
    /// Whether the profile gave strength data to judge islands by (see [`Strength`]).
    pub(crate) fn judged(&self) -> bool {
        self.max_sag_mm.is_finite() || self.two_bridges_above_mm.is_finite()
    }
}

/// The material profiles shipped with the crate, embedded so an installed binary has them.
pub const SHIPPED: &[Shipped] = &[
    shipped!("materials", "copy-paper"),
    shipped!("materials", "cardstock"),
    shipped!("materials", "mylar-0.19"),
    shipped!("materials", "poster-board"),
    shipped!("materials", "cardstock-knife"),
    shipped!("materials", "vinyl-0.08"),
    shipped!("materials", "plotter-paper"),
    shipped!("materials", "plywood-3mm"),
    shipped!("materials", "acrylic-3mm"),
    shipped!("materials", "stainless-0.5-etch"),
    shipped!("materials", "brass-0.3-etch"),
    shipped!("materials", "aluminium-gobo"),
];

/// How the sheet is cut, with that process's settings.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum Process {
    /// A laser cutter.
    Laser(LaserSettings),
    /// A drag-knife cutting plotter.
    Knife(KnifeSettings),
    /// A pen plotter (outlines to cut by hand).
    Pen(PenSettings),
    /// Photo-etching (masks, no G-code).
    Etch(EtchSettings),
}

impl Process {
    /// Which process, without its settings.
    pub fn kind(&self) -> ProcessKind {
        match self {
            Process::Laser(_) => ProcessKind::Laser,
            Process::Knife(_) => ProcessKind::Knife,
            Process::Pen(_) => ProcessKind::Pen,
            Process::Etch(_) => ProcessKind::Etch,
        }
    }
}

/// The `process = "..."` key.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ProcessKind {
    /// `laser`.
    Laser,
    /// `knife`.
    Knife,
    /// `pen`.
    Pen,
    /// `etch`.
    Etch,
}

impl std::fmt::Display for ProcessKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ProcessKind::Laser => "laser",
            ProcessKind::Knife => "knife",
            ProcessKind::Pen => "pen",
            ProcessKind::Etch => "etch",
        })
    }
}

/// `[laser]`: the cut settings of a laser job (`S` from power, `F` from speed, passes), one entry
/// per kind of laser they were published for ([`LaserCut`]: the same card wants 20 % at 1500
/// mm/min on a 40 W CO2 and full power at a fifth of that on a 5 W diode), and air assist.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LaserSettings {
    /// The settings, each for a kind of laser, with its source.
    pub on: Vec<LaserCut>,
    /// Air assist for this material: `true` / `false` overrides the machine's `air_assist`;
    /// absent, the machine decides. (Air keeps flames and smoke off the cut; on thin film or
    /// paper it can lift the sheet.)
    pub(crate) air_assist: Option<bool>,
}

/// Cut settings published for one kind of laser.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaserCut {
    /// The laser they are for: `"diode"` or `"co2"`; `None` (a flat `[laser]` section of a
    /// user's own profile, written before settings were per kind) for any laser.
    pub laser: Option<stencil_gcode::machine::LaserSource>,
    /// The power they were published for, W (a diode's optical output, a CO2 tube's rating);
    /// they are used on machines with this much power or more.
    #[serde(default)]
    pub(crate) watts: f64,
    /// Laser power in percent of the machine's maximum (0 < p ≤ 100).
    pub power_pct: f64,
    /// Cutting feed in mm/min.
    pub speed_mm_min: f64,
    /// Passes over each outline.
    pub passes: u32,
    /// Where the numbers come from (a maker's table, a published settings library), so a
    /// person can check them; printed by `stencil profiles` and recorded in report.json.
    #[serde(default)]
    pub from: String,
}

/// The `[laser]` section as written: a list of `[[laser.on]]` entries, or (a user's own profile
/// from before) flat settings for any laser.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LaserFile {
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    on: Vec<LaserCut>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    power_pct: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    speed_mm_min: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    passes: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    air_assist: Option<bool>,
}

/// `[knife]`: a drag-knife cutting plotter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KnifeSettings {
    /// Blade force in grams.
    pub force_g: f64,
    /// Cutting speed in mm/s.
    pub speed_mm_s: f64,
    /// Passes over each outline.
    pub passes: u32,
    /// Drag-knife blade offset in mm (tip behind the axis).
    pub(crate) blade_offset_mm: f64,
}

/// `[pen]`: a pen plotter drawing the outlines to cut by hand.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PenSettings {
    /// Drawing speed, mm/min.
    pub speed_mm_min: f64,
    /// Width of the pen's line, mm.
    pub pen_width_mm: f64,
}

/// `[etch]`: photo-etching (the mask goes to the etching shop or onto the resist).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EtchSettings {
    /// Etch factor: depth etched per unit of sideways undercut.
    pub etch_factor: f64,
    /// Mirror the mask by default (film emulsion side down on the metal).
    pub mirror: bool,
    /// Etched from both sides (front and back art mirror each other).
    pub two_sided: bool,
}

/// The file layout: flat numbers plus one section per process. Only this type touches serde.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    name: String,
    #[serde(default)]
    description: String,
    thickness_mm: f64,
    min_bridge_mm: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    max_bridge_mm: Option<f64>,
    min_feature_mm: f64,
    kerf_mm: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    youngs_modulus_gpa: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    density_kg_m3: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    max_sag_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    two_bridges_above_mm: Option<f64>,
    process: ProcessKind,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    laser: Option<LaserFile>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    knife: Option<KnifeSettings>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pen: Option<PenSettings>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    etch: Option<EtchSettings>,
}

/// A material's values in the layout of its profile file: what `report.json` carries, so that a
/// folder received from someone else names its material by value. Reading them back goes through
/// the same checks as a profile file ([`Material::from_values`]); no file is opened.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(transparent)]
pub struct MaterialValues(MaterialFile);

/// A validated material profile. Public for every stage that needs the sheet's numbers (the
/// pipeline converts the widths to pixels, `check` measures against them, the G-code planner reads
/// [`Process::Laser`] for power, speed and passes).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Material {
    /// The profile's name (shipped profiles: the file stem, e.g. `cardstock`).
    pub name: String,
    pub(crate) description: String,
    /// Sheet thickness.
    pub thickness_mm: f64,
    /// Narrowest bridge the sheet holds (bridges are checked against this).
    pub min_bridge_mm: f64,
    /// Widest bridge the bridge stage draws, measured at right angles to it: an island's bridge
    /// is `k·√A` wide for its area `A` in mm² (a quarter of its side), clamped to
    /// `min_bridge_mm..=max_bridge_mm`. Optional in a profile; default
    /// `DEFAULT_MAX_BRIDGE_RATIO` × `min_bridge_mm`. A bridge wider than this hides more of the
    /// picture than it adds strength.
    pub max_bridge_mm: f64,
    /// Narrowest web (material) or hole (cut) that survives cutting.
    pub min_feature_mm: f64,
    /// Width of material the tool removes; cut loops are offset by half of it into the hole.
    pub kerf_mm: f64,
    /// Stiffness, weight and the limits the bridge stage holds islands to (optional fields of the
    /// file; see [`Strength`]).
    pub strength: Strength,
    /// How it is cut, with that process's settings.
    pub process: Process,
}

impl Default for Material {
    /// The shipped [`DEFAULT_MATERIAL`] (its validity is unit-tested).
    fn default() -> Self {
        Material::find_default(DEFAULT_MATERIAL)
            .expect("the shipped default material is valid (unit-tested)")
            .0
    }
}

impl Material {
    /// Find a material by shipped name, a name in `./profiles/materials/`, or a path.
    pub fn find(arg: &str) -> Result<(Material, PathBuf), ProfileError> {
        let (file, origin): (MaterialFile, PathBuf) = resolve(arg, "materials", SHIPPED)?;
        Ok((Material::validate(file, &origin)?, origin))
    }

    /// The material a run uses when the user names none: `name` (e.g. [`default_for`] a tool)
    /// as shipped in the binary, whatever `./profiles/materials/` holds, so that such a run gives
    /// the same output in every folder (the library's [`Material::default`] is the same).
    pub fn find_default(name: &str) -> Result<(Material, PathBuf), ProfileError> {
        let (file, origin): (MaterialFile, PathBuf) = embedded(name, "materials", SHIPPED)?;
        Ok((Material::validate(file, &origin)?, origin))
    }

    /// Load a material profile from a TOML file.
    pub fn load(path: &Path) -> Result<Material, ProfileError> {
        Material::validate(load_toml(path)?, path)
    }

    /// Parse a material profile from TOML text; `origin` names it in errors.
    #[cfg(test)]
    pub(crate) fn parse(text: &str, origin: &Path) -> Result<Material, ProfileError> {
        Material::validate(stencil_io::profile::parse_toml(text, origin)?, origin)
    }

    /// This material's values, as its profile file would hold them.
    pub(crate) fn values(&self) -> MaterialValues {
        let st = self.strength;
        let judged = st.judged();
        let given = |v: f64| judged.then_some(v);
        let (mut laser, mut knife, mut pen, mut etch) = (None, None, None, None);
        match &self.process {
            Process::Laser(l) => {
                laser = Some(LaserFile {
                    on: l.on.clone(),
                    power_pct: None,
                    speed_mm_min: None,
                    passes: None,
                    air_assist: l.air_assist,
                })
            }
            Process::Knife(k) => knife = Some(*k),
            Process::Pen(p) => pen = Some(*p),
            Process::Etch(e) => etch = Some(*e),
        }
        MaterialValues(MaterialFile {
            name: self.name.clone(),
            description: self.description.clone(),
            thickness_mm: self.thickness_mm,
            min_bridge_mm: self.min_bridge_mm,
            max_bridge_mm: Some(self.max_bridge_mm),
            min_feature_mm: self.min_feature_mm,
            kerf_mm: self.kerf_mm,
            // A profile with no strength data keeps the default stiffness and no limits: giving
            // none of the four reproduces it (and JSON has no infinity to write).
            youngs_modulus_gpa: given(st.youngs_modulus_gpa),
            density_kg_m3: given(st.density_kg_m3),
            max_sag_mm: given(st.max_sag_mm),
            two_bridges_above_mm: given(st.two_bridges_above_mm),
            process: self.process.kind(),
            laser,
            knife,
            pen,
            etch,
        })
    }

    /// A material from values a report carried, checked like a profile file (`origin` names
    /// where they came from in errors).
    pub fn from_values(v: MaterialValues, origin: &Path) -> Result<Material, ProfileError> {
        Material::validate(v.0, origin)
    }

    /// Laser settings (per kind of laser), when the process is laser cutting.
    pub fn laser(&self) -> Option<&LaserSettings> {
        match &self.process {
            Process::Laser(l) => Some(l),
            _ => None,
        }
    }

    /// Etch settings, when the process is photo-etching.
    pub fn etch(&self) -> Option<&EtchSettings> {
        match &self.process {
            Process::Etch(e) => Some(e),
            _ => None,
        }
    }

    /// A material file checked field by field (a typo, a unit mix-up or a missing section is
    /// refused with the field named), with the defaults filled in.
    fn validate(mut f: MaterialFile, origin: &Path) -> Result<Material, ProfileError> {
        let max_bridge_mm = check_dimensions(&f, origin)?;
        let strength = strength_of(&f, origin)?;
        let process = process_of(&mut f, origin)?;
        Ok(Material {
            name: f.name,
            description: f.description,
            thickness_mm: f.thickness_mm,
            min_bridge_mm: f.min_bridge_mm,
            max_bridge_mm,
            min_feature_mm: f.min_feature_mm,
            kerf_mm: f.kerf_mm,
            strength,
            process,
        })
    }
}

fn invalid(origin: &Path, field: &str, value: String, why: &str) -> ProfileError {
    ProfileError::Invalid {
        path: origin.to_path_buf(),
        field: field.into(),
        value,
        why: why.into(),
    }
}

/// The name and the sizes in mm, each in its range (anything outside is a typo: a unit mix-up, a
/// missing decimal point), and a kerf that leaves the smallest feature standing. Returns the
/// widest bridge (given, or [`DEFAULT_MAX_BRIDGE_RATIO`] × the narrowest).
fn check_dimensions(f: &MaterialFile, origin: &Path) -> Result<f64, ProfileError> {
    let range = |field: &str, v, lo, hi, unit| check_range(origin, field, v, lo, hi, unit);
    if f.name.trim().is_empty() {
        return Err(invalid(origin, "name", "\"\"".into(), "must not be empty"));
    }
    range("thickness_mm", f.thickness_mm, 0.005, 50.0, "mm")?;
    range("min_bridge_mm", f.min_bridge_mm, 0.01, 50.0, "mm")?;
    range("min_feature_mm", f.min_feature_mm, 0.01, 50.0, "mm")?;
    let max_bridge_mm = f
        .max_bridge_mm
        .unwrap_or(DEFAULT_MAX_BRIDGE_RATIO * f.min_bridge_mm);
    range(
        "max_bridge_mm",
        max_bridge_mm,
        f.min_bridge_mm,
        200.0,
        "mm (at least min_bridge_mm)",
    )?;
    range("kerf_mm", f.kerf_mm, 0.0, 2.0, "mm")?;
    if f.kerf_mm >= f.min_feature_mm {
        return Err(invalid(
            origin,
            "kerf_mm",
            f.kerf_mm.to_string(),
            "must be smaller than min_feature_mm: the tool would remove whole features",
        ));
    }
    Ok(max_bridge_mm)
}

/// The stiffness and weight the strength rules read. A file that gives none of the four keeps
/// the defaults' stiffness and weight but no sag or span limit (of the strength rules only the
/// bridges-per-island count applies); one that gives any gets the defaults for the rest, limits
/// included.
fn strength_of(f: &MaterialFile, origin: &Path) -> Result<Strength, ProfileError> {
    let range = |field: &str, v, lo, hi, unit| check_range(origin, field, v, lo, hi, unit);
    let d = DEFAULT_STRENGTH;
    let given = f.youngs_modulus_gpa.is_some()
        || f.density_kg_m3.is_some()
        || f.max_sag_mm.is_some()
        || f.two_bridges_above_mm.is_some();
    let d = if given {
        d
    } else {
        Strength {
            max_sag_mm: f64::INFINITY,
            two_bridges_above_mm: f64::INFINITY,
            ..d
        }
    };
    let strength = Strength {
        youngs_modulus_gpa: f.youngs_modulus_gpa.unwrap_or(d.youngs_modulus_gpa),
        density_kg_m3: f.density_kg_m3.unwrap_or(d.density_kg_m3),
        max_sag_mm: f.max_sag_mm.unwrap_or(d.max_sag_mm),
        two_bridges_above_mm: f.two_bridges_above_mm.unwrap_or(d.two_bridges_above_mm),
    };
    // Tissue paper is about 0.5 GPa, diamond 1000; the lightest foam board 30 kg/m³, osmium
    // 22,600.
    range(
        "youngs_modulus_gpa",
        strength.youngs_modulus_gpa,
        0.01,
        1200.0,
        "GPa",
    )?;
    range(
        "density_kg_m3",
        strength.density_kg_m3,
        10.0,
        25_000.0,
        "kg/m³",
    )?;
    if given {
        range("max_sag_mm", strength.max_sag_mm, 0.001, 1000.0, "mm")?;
        range(
            "two_bridges_above_mm",
            strength.two_bridges_above_mm,
            0.1,
            100_000.0,
            "mm",
        )?;
    }
    Ok(strength)
}

/// The process's settings: its own section, present and in range, and no other process's.
fn process_of(f: &mut MaterialFile, origin: &Path) -> Result<Process, ProfileError> {
    let range = |field: &str, v, lo, hi, unit| check_range(origin, field, v, lo, hi, unit);
    let sections = [
        ("laser", f.laser.is_some(), ProcessKind::Laser),
        ("knife", f.knife.is_some(), ProcessKind::Knife),
        ("pen", f.pen.is_some(), ProcessKind::Pen),
        ("etch", f.etch.is_some(), ProcessKind::Etch),
    ];
    for (sec, present, kind) in sections {
        if present && kind != f.process {
            return Err(invalid(
                origin,
                sec,
                format!("[{sec}]"),
                &format!(
                    "section given but process = \"{}\"; remove it or change process",
                    f.process
                ),
            ));
        }
    }
    let missing = |sec: &str| {
        invalid(
            origin,
            sec,
            "(missing)".into(),
            &format!("process = \"{sec}\" needs a [{sec}] section with its settings"),
        )
    };
    Ok(match f.process {
        ProcessKind::Laser => {
            let l = f.laser.take().ok_or_else(|| missing("laser"))?;
            Process::Laser(laser_of(l, origin)?)
        }
        ProcessKind::Knife => {
            let k = f.knife.take().ok_or_else(|| missing("knife"))?;
            check_knife(&k, origin)?;
            Process::Knife(k)
        }
        ProcessKind::Pen => {
            let p = f.pen.take().ok_or_else(|| missing("pen"))?;
            range("pen.speed_mm_min", p.speed_mm_min, 1.0, 100_000.0, "mm/min")?;
            range("pen.pen_width_mm", p.pen_width_mm, 0.01, 5.0, "mm")?;
            Process::Pen(p)
        }
        ProcessKind::Etch => {
            let e = f.etch.take().ok_or_else(|| missing("etch"))?;
            range("etch.etch_factor", e.etch_factor, 0.5, 10.0, "")?;
            Process::Etch(e)
        }
    })
}

/// The `[laser]` section checked: flat settings (all three, for any laser) or `[[laser.on]]`
/// entries, not both; each entry in range, with its source named and no two for the same kind.
fn laser_of(l: LaserFile, origin: &Path) -> Result<LaserSettings, ProfileError> {
    let range = |field: &str, v, lo, hi, unit| check_range(origin, field, v, lo, hi, unit);
    let flat = [
        ("laser.power_pct", l.power_pct.is_some()),
        ("laser.speed_mm_min", l.speed_mm_min.is_some()),
        ("laser.passes", l.passes.is_some()),
    ];
    let mut on = l.on;
    if flat.iter().any(|f| f.1) {
        if !on.is_empty() {
            return Err(invalid(
                origin,
                "laser.power_pct",
                "set".into(),
                "flat settings (for any laser) and [[laser.on]] entries (per kind of laser) \
                 cannot be mixed; move them into a [[laser.on]] entry",
            ));
        }
        if let Some((field, _)) = flat.iter().find(|f| !f.1) {
            return Err(invalid(
                origin,
                field,
                "(missing)".into(),
                "flat [laser] settings need power_pct, speed_mm_min and passes",
            ));
        }
        on.push(LaserCut {
            laser: None,
            watts: 0.0,
            power_pct: l.power_pct.unwrap_or_default(),
            speed_mm_min: l.speed_mm_min.unwrap_or_default(),
            passes: l.passes.unwrap_or_default(),
            from: format!("{} (for any laser)", origin.display()),
        });
    }
    if on.is_empty() {
        return Err(invalid(
            origin,
            "laser.on",
            "(missing)".into(),
            "give at least one [[laser.on]] entry (laser, watts, power_pct, speed_mm_min, \
             passes, from)",
        ));
    }
    let flat = flat.iter().any(|f| f.1);
    for (k, c) in on.iter().enumerate() {
        // A flat section's fields are named as written (`laser.power_pct`).
        let field = |f: &str| {
            if flat {
                format!("laser.{f}")
            } else {
                format!("laser.on[{k}].{f}")
            }
        };
        range(&field("power_pct"), c.power_pct, 0.1, 100.0, "%")?;
        range(
            &field("speed_mm_min"),
            c.speed_mm_min,
            1.0,
            100_000.0,
            "mm/min",
        )?;
        range(&field("passes"), c.passes as f64, 1.0, 50.0, "passes")?;
        if c.laser.is_some() {
            let w = stencil_gcode::bounds::WATTS;
            range(&field("watts"), c.watts, *w.start(), *w.end(), "W")?;
            if c.from.trim().is_empty() {
                return Err(invalid(
                    origin,
                    &field("from"),
                    "(missing)".into(),
                    "say where the numbers come from (a maker's table, a settings library, \
                     your own test grid)",
                ));
            }
        }
        if on[..k]
            .iter()
            .any(|o| o.laser == c.laser && o.watts == c.watts)
        {
            return Err(invalid(
                origin,
                &field("watts"),
                c.watts.to_string(),
                "a second entry for the same laser and power",
            ));
        }
    }
    Ok(LaserSettings {
        on,
        air_assist: l.air_assist,
    })
}

fn check_knife(k: &KnifeSettings, origin: &Path) -> Result<(), ProfileError> {
    let range = |field: &str, v, lo, hi, unit| check_range(origin, field, v, lo, hi, unit);
    range("knife.force_g", k.force_g, 1.0, 2000.0, "g")?;
    range("knife.speed_mm_s", k.speed_mm_s, 1.0, 2000.0, "mm/s")?;
    range("knife.passes", k.passes as f64, 1.0, 20.0, "passes")?;
    range("knife.blade_offset_mm", k.blade_offset_mm, 0.0, 2.0, "mm")
}
