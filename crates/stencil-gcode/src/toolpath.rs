//! From cut geometry (sheet millimetres, y down) to a job: closed loops in machine millimetres,
//! placed on the bed, checked against it, in cut order with a start vertex each.

use geo::{Area, LineString};

use crate::bounds::{MAX_BLADE_OFFSET_MM, MAX_PASSES};
use crate::cuts::{CutLoops, Pieces};
use crate::error::{Fit, PlanError, SettingsError};
use crate::job::{CutSettings, Job, Loop, PathStats};
use crate::machine::{Corner, Machine, Tool};

use crate::{order, travel};
use stencil_geom::curve::{self, Curves, Piece};
use stencil_geom::ring::dist;

/// Which point of the job sits at `--offset`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Anchor {
    /// That corner of the job.
    Corner(Corner),
    /// The job's centre.
    Center,
}

impl std::str::FromStr for Anchor {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "bottom-left" | "bl" => Anchor::Corner(Corner::BottomLeft),
            "bottom-right" | "br" => Anchor::Corner(Corner::BottomRight),
            "top-left" | "tl" => Anchor::Corner(Corner::TopLeft),
            "top-right" | "tr" => Anchor::Corner(Corner::TopRight),
            "center" | "centre" => Anchor::Center,
            _ => {
                return Err(format!(
                    "'{s}' is not a job origin: use bottom-left, bottom-right, top-left, top-right or center"
                ))
            }
        })
    }
}

/// Where the job goes on the bed and what is cut.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanConfig {
    /// The job point placed at `offset`; `None` = the corner at the machine's origin.
    pub anchor: Option<Anchor>,
    /// Machine coordinates (mm) of the anchor.
    pub offset: [f64; 2],
    /// Also cut the sheet's rectangle, after everything inside it.
    pub cut_outline: bool,
    /// Cut a drawing's open paths ([`CutLoops::lines`]) with a laser or knife, as open cuts.
    /// A pen draws them anyway.
    pub cut_open_paths: bool,
    /// How the material is cut.
    pub settings: CutSettings,
    /// Write each loop as lines and G2/G3 arcs fitted within this many mm of its polygon
    /// ([`stencil_geom::curve::fit_ring`]); 0 writes straight G1 segments only (`--no-arcs`, or a
    /// machine whose profile says `arcs = false`); see [`PlanConfig::arc_tolerance_on`].
    pub arc_tolerance_mm: f64,
    /// Keep the programmed feed where the serial line cannot bring the lines as fast as the
    /// feed uses them (the planner starves there: the head stutters). By default the feed is
    /// lowered there instead, and the summary says where.
    pub keep_feed: bool,
}

impl PlanConfig {
    /// The tolerance the job's arcs are fitted within on `machine`: 0 (straight segments only)
    /// when the machine's profile says `arcs = false` or its tool is a drag knife (its corner
    /// swivels are built from the polygon's corners), else [`PlanConfig::arc_tolerance_mm`].
    pub fn arc_tolerance_on(&self, machine: &Machine) -> f64 {
        let knife = matches!(machine.tool, Tool::Knife { .. });
        if machine.arcs && !knife && self.arc_tolerance_mm.is_finite() {
            self.arc_tolerance_mm.max(0.0)
        } else {
            0.0
        }
    }

    /// The defaults with these settings.
    pub fn new(settings: CutSettings) -> Self {
        PlanConfig {
            anchor: None,
            offset: [0.0, 0.0],
            cut_outline: false,
            cut_open_paths: false,
            settings,
            arc_tolerance_mm: 0.0,
            keep_feed: false,
        }
    }
}

/// Check cut settings against the machine (feed within its limit, laser S within its range).
pub(crate) fn check_settings(s: &CutSettings, machine: &Machine) -> Result<(), SettingsError> {
    let feeds = crate::bounds::FEED_MM_MIN;
    if !(s.speed_mm_min.is_finite() && s.speed_mm_min >= *feeds.start()) {
        return Err(SettingsError::SpeedTooLow {
            min: *feeds.start(),
            got: s.speed_mm_min,
        });
    }
    if s.speed_mm_min > machine.motion.max_feed_mm_min {
        return Err(SettingsError::AboveMaxFeed {
            speed: s.speed_mm_min,
            machine: machine.name.clone(),
            max: machine.motion.max_feed_mm_min,
        });
    }
    if !(s.blade_offset_mm.is_finite() && (0.0..=MAX_BLADE_OFFSET_MM).contains(&s.blade_offset_mm))
    {
        return Err(SettingsError::BladeOffset(s.blade_offset_mm));
    }
    if s.passes == 0 || s.passes > MAX_PASSES {
        return Err(SettingsError::Passes(s.passes));
    }
    if s.air_assist && !matches!(machine.tool, Tool::Laser { .. }) {
        return Err(SettingsError::AirAssistNotLaser {
            machine: machine.name.clone(),
            tool: machine.tool.kind(),
        });
    }
    if let Tool::Laser { s_max, s_min } = machine.tool {
        if !(s.power_pct.is_finite() && s.power_pct > 0.0 && s.power_pct <= 100.0) {
            return Err(SettingsError::LaserPower(s.power_pct));
        }
        let sv = laser_s(s.power_pct, s_max);
        if sv <= 0.0 {
            return Err(SettingsError::LaserDark {
                power: s.power_pct,
                machine: machine.name.clone(),
                s_max,
            });
        }
        if sv < s_min {
            return Err(SettingsError::BelowSMin {
                power: s.power_pct,
                s: sv,
                machine: machine.name.clone(),
                s_min,
            });
        }
    }
    Ok(())
}

/// The S word for a power percentage: `% × $30`, rounded to 0.1.
pub(crate) fn laser_s(power_pct: f64, s_max: f64) -> f64 {
    (power_pct / 100.0 * s_max * 10.0).round() / 10.0
}

/// The sheet's rectangle in sheet mm (y down): `[x0, y0, x1, y1]`.
pub(crate) fn sheet_rect(geom: &CutLoops) -> [f64; 4] {
    let o = geom.outline;
    [o.min().x, o.min().y, o.max().x, o.max().y]
}

/// What the job places at the anchor and the bed must hold: the sheet when its outline is cut,
/// else only what is cut (the bounding box of the cut loops and open paths). The margin around the picture is sheet
/// the head never visits unless the outline is cut, so it does not count against the bed: a
/// 395 mm picture with a 5 mm margin fits a 400 mm bed when only the picture is cut.
/// `reach`: how far past the cuts the tool's axis goes (a drag knife swivels around corners up
/// to its blade offset out), so the job's box holds that too.
fn job_rect(geom: &CutLoops, cut_outline: bool, reach: f64) -> [f64; 4] {
    let sheet = sheet_rect(geom);
    if cut_outline {
        return sheet;
    }
    let mut r = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    let loops = geom.cuts.0.iter().flat_map(|p| p.exterior().0.iter());
    // Open paths (a pen's lines, or cut open) are visited by the tool as much as the loops.
    for c in loops.chain(geom.lines.iter().flat_map(|l| l.0.iter())) {
        r = [r[0].min(c.x), r[1].min(c.y), r[2].max(c.x), r[3].max(c.y)];
    }
    if r[0] < r[2] && r[1] < r[3] {
        [r[0] - reach, r[1] - reach, r[2] + reach, r[3] + reach]
    } else {
        sheet
    }
}

/// Sheet mm (x right, y down) → machine mm, for the sheet `rect` placed per `cfg` on `machine`.
#[derive(Clone, Copy, Debug)]
struct Placement {
    /// The sheet's left and bottom (largest y-down) edges.
    x0: f64,
    y1: f64,
    w: f64,
    h: f64,
    flip_x: bool,
    flip_y: bool,
    shift: [f64; 2],
}

impl Placement {
    fn new(rect: [f64; 4], machine: &Machine, cfg: &PlanConfig) -> Self {
        let (w, h) = (rect[2] - rect[0], rect[3] - rect[1]);
        let origin = machine.bed.origin;
        let mut p = Placement {
            x0: rect[0],
            y1: rect[3],
            w,
            h,
            flip_x: origin.right(),
            flip_y: origin.top(),
            shift: [0.0, 0.0],
        };
        // The anchor in bed view (x right, y up, the sheet's lower-left at 0, 0).
        let (au, av) = match cfg.anchor.unwrap_or(Anchor::Corner(origin)) {
            Anchor::Center => (w / 2.0, h / 2.0),
            Anchor::Corner(c) => (
                if c.right() { w } else { 0.0 },
                if c.top() { h } else { 0.0 },
            ),
        };
        let a = p.orient(au, av);
        p.shift = [cfg.offset[0] - a[0], cfg.offset[1] - a[1]];
        p
    }

    /// Bed view (y up) → machine axes (which point away from the origin corner), unshifted.
    fn orient(&self, u: f64, v: f64) -> [f64; 2] {
        [
            if self.flip_x { self.w - u } else { u },
            if self.flip_y { self.h - v } else { v },
        ]
    }

    fn map(&self, x: f64, y_down: f64) -> [f64; 2] {
        let [mx, my] = self.orient(x - self.x0, self.y1 - y_down);
        [mx + self.shift[0], my + self.shift[1]]
    }
}

/// A ring as plain points: closing duplicate and repeated points removed.
fn ring_points(ls: &LineString<f64>, place: &Placement) -> Vec<[f64; 2]> {
    sheet_points(ls)
        .into_iter()
        .map(|p| place.map(p[0], p[1]))
        .collect()
}

/// A ring's points on the sheet (mm, y down): closing duplicate and repeated points removed.
fn sheet_points(ls: &LineString<f64>) -> Vec<[f64; 2]> {
    let mut pts: Vec<[f64; 2]> = Vec::with_capacity(ls.0.len());
    for c in &ls.0 {
        let p = [c.x, c.y];
        if pts.last().is_none_or(|&q| dist(p, q) > 1e-9) {
            pts.push(p);
        }
    }
    while pts.len() > 1 && dist(pts[0], pts[pts.len() - 1]) <= 1e-9 {
        pts.pop();
    }
    pts
}

/// How loops are fitted with arcs: within `tol` mm, no arc reaching outside `inside` (the job's
/// box on the sheet, [`curve::fit_ring_inside`]).
#[derive(Clone, Copy, Debug)]
struct ArcFit {
    tol: f64,
    inside: [f64; 4],
}

/// A ring placed on the bed, and its arcs when `fit` asks for them (empty when it has none).
/// A ring known as curves (`curves`: `make`'s fitted lines and arcs, or their kerf offset) is
/// written as those very pieces, its points rotated to start where the first piece does; any
/// other is fitted with arcs on the sheet. Either way each piece starts at one of the ring's own
/// points, so it maps to the very same machine numbers. The sheet's y runs down and the
/// machine's up, and a bed origin on the right or at the back mirrors once more: a bulge
/// (positive counter-clockwise) changes sign with each mirror.
fn placed_ring(
    ls: &LineString<f64>,
    place: &Placement,
    fit: Option<ArcFit>,
    curves: &Curves,
) -> (Vec<[f64; 2]>, Vec<Piece>) {
    let mut sheet = sheet_points(ls);
    let pieces = match fit {
        Some(f) if sheet.len() >= 3 => match curves.pieces_of(&sheet) {
            Some((start, pieces)) => {
                sheet.rotate_left(start);
                pieces
            }
            None => curve::fit_ring_inside(&sheet, f.tol, f.inside),
        },
        _ => Vec::new(),
    };
    let points = sheet.iter().map(|p| place.map(p[0], p[1])).collect();
    let mirrors = 1 + u8::from(place.flip_x) + u8::from(place.flip_y);
    let sign = if mirrors % 2 == 1 { -1.0 } else { 1.0 };
    let curve = if curve::arc_count(&pieces) == 0 {
        Vec::new()
    } else {
        pieces
            .iter()
            .map(|p| Piece {
                from: place.map(p.from[0], p.from[1]),
                bulge: if p.bulge == 0.0 { 0.0 } else { sign * p.bulge },
            })
            .collect()
    };
    (points, curve)
}

/// Rotate a loop to start at vertex `start`; a loop with arcs starts at the end of one of its
/// pieces nearest to that vertex instead (its path is fitted from one start; a piece is not cut
/// in two), and its pieces rotate with it.
fn start_at(l: &mut Loop, start: usize) {
    if l.curve.is_empty() {
        l.points.rotate_left(start);
        return;
    }
    // Each piece starts at one of the points, in order: its index there.
    let mut at = Vec::with_capacity(l.curve.len());
    let mut k = 0;
    for p in &l.curve {
        while k < l.points.len() && l.points[k] != p.from {
            k += 1;
        }
        at.push(k.min(l.points.len() - 1));
    }
    let want = l.points[start];
    let best = (0..at.len())
        .min_by(|&a, &b| dist(l.points[at[a]], want).total_cmp(&dist(l.points[at[b]], want)))
        .unwrap_or(0);
    l.points.rotate_left(at[best]);
    l.curve.rotate_left(best);
}

/// Without bridge data (a drawing from another program), gaps between cut loops up to this wide
/// (besides the kerf) are taken for bridges: about the widths makers draw bridges at. Pieces
/// narrower than this are not told apart from their surroundings (the hull rule still orders
/// what lies in a single broken ring).
pub(crate) const DRAWN_BRIDGE_MAX_MM: f64 = 3.0;

/// What the planner knows of the pieces the cuts free: the cut regions before bridging when
/// `make` passed them; nothing to find when `make` had no islands; otherwise (a drawing) a
/// geometric closing of bridge-wide gaps.
fn gaps(geom: &CutLoops, place: &Placement) -> order::Gaps {
    match &geom.pieces {
        Pieces::Regions(regions) => order::Gaps::Regions(
            regions
                .0
                .iter()
                .filter(|p| !p.interiors().is_empty())
                .map(|p| order::Region {
                    exterior: ring_points(p.exterior(), place),
                    holes: p
                        .interiors()
                        .iter()
                        .map(|h| ring_points(h, place))
                        .collect(),
                })
                .collect(),
        ),
        Pieces::NoIslands => order::Gaps::None,
        Pieces::Unknown => order::Gaps::Closing {
            r_mm: (DRAWN_BRIDGE_MAX_MM + geom.kerf_mm) / 2.0,
        },
    }
}

/// Plan a job: place, check the bed, order the loops, pick start points.
pub fn plan(geom: &CutLoops, machine: &Machine, cfg: &PlanConfig) -> Result<Job, PlanError> {
    check_settings(&cfg.settings, machine)?;
    // A knife swivels up to its blade offset out.
    let reach = match machine.tool {
        Tool::Knife { .. } => cfg.settings.blade_offset_mm,
        _ => 0.0,
    };
    let arc_tolerance_mm = cfg.arc_tolerance_on(machine);
    let rect = job_rect(geom, cfg.cut_outline, reach);
    let size = [rect[2] - rect[0], rect[3] - rect[1]];
    let place = Placement::new(rect, machine, cfg);
    // Kept inside the job's box: with or without arcs the job lands at the same place.
    let fit = (arc_tolerance_mm > 0.0).then_some(ArcFit {
        tol: arc_tolerance_mm,
        inside: rect,
    });

    let mut loops = cut_loops(geom, &place, fit);
    let lines = open_lines(geom, &place);
    if !lines.is_empty() && !matches!(machine.tool, Tool::Pen(_)) && !cfg.cut_open_paths {
        return Err(PlanError::OpenPaths {
            count: lines.len(),
            machine: machine.name.clone(),
            tool: machine.tool.kind(),
        });
    }
    let frame = [
        place.map(rect[0], rect[1]),
        place.map(rect[2], rect[1]),
        place.map(rect[2], rect[3]),
        place.map(rect[0], rect[3]),
    ];
    if cfg.cut_outline {
        // A round sheet (a gobo's rim) is cut on its ring; the frame stays its box on the bed.
        let ring = geom.outline_ring.as_ref().map(|r| {
            let area = geo::Polygon::new(r.clone(), vec![]).unsigned_area();
            (placed_ring(r, &place, fit, &geom.curves), area)
        });
        loops.push(match ring {
            Some(((points, curve), area_mm2)) if points.len() >= 3 => Loop {
                points,
                outline: true,
                area_mm2,
                curve,
            },
            _ => Loop {
                points: frame.to_vec(),
                outline: true,
                area_mm2: size[0] * size[1],
                curve: Vec::new(),
            },
        });
    }
    if loops.is_empty() && lines.is_empty() {
        return Err(PlanError::Empty);
    }

    let (min, max) = check_on_bed(&frame, &loops, &lines, machine, reach)?;

    let home = [0.0, 0.0];
    let naive_travel_mm = travel::naive_travel(&lines, &loops, home);
    let lines = travel::order_lines(lines, home);
    let sequence = shortest_sequence(&loops, &gaps(geom, &place), home);
    let mut ordered = Vec::with_capacity(loops.len());
    for (i, start) in sequence {
        let mut l = loops[i].clone();
        start_at(&mut l, start);
        ordered.push(l);
    }
    let travel_mm = travel::travel_of(&lines, &ordered, home, cfg.settings.passes);
    let passes = cfg.settings.passes;
    let line_mm: f64 = lines.iter().map(|l| line_len(l)).sum();
    let cut_mm = (ordered.iter().map(Loop::perimeter_mm).sum::<f64>() + line_mm) * passes as f64;
    Ok(Job {
        stats: PathStats {
            loops: ordered.len(),
            lines: lines.len(),
            cut_mm,
            travel_mm,
            naive_travel_mm,
        },
        lines,
        loops: ordered,
        home,
        settings: cfg.settings,
        sheet_mm: size,
        min,
        max,
        arc_tolerance_mm,
    })
}

/// The loops to cut, placed on the bed, in input order: each polygon's holes (islands, which must
/// not exist after bridging but are cut if they do), then its exterior. Degenerate rings are
/// left out.
fn cut_loops(geom: &CutLoops, place: &Placement, fit: Option<ArcFit>) -> Vec<Loop> {
    let mut loops: Vec<Loop> = Vec::new();
    for poly in &geom.cuts.0 {
        for ring in poly
            .interiors()
            .iter()
            .chain(std::iter::once(poly.exterior()))
        {
            let (pts, curve) = placed_ring(ring, place, fit, &geom.curves);
            let area = geo::Polygon::new(ring.clone(), vec![]).unsigned_area();
            if pts.len() >= 3 && area > 1e-9 {
                loops.push(Loop {
                    points: pts,
                    outline: false,
                    area_mm2: area,
                    curve,
                });
            }
        }
    }
    loops
}

/// A drawing's open paths placed on the bed, as given (repeated points removed; a path with no
/// length left out).
fn open_lines(geom: &CutLoops, place: &Placement) -> Vec<Vec<[f64; 2]>> {
    let placed = |ls: &LineString<f64>| {
        let mut pts: Vec<[f64; 2]> = Vec::with_capacity(ls.0.len());
        for c in &ls.0 {
            let p = place.map(c.x, c.y);
            if pts.last().is_none_or(|&q| dist(p, q) > 1e-9) {
                pts.push(p);
            }
        }
        pts
    };
    geom.lines
        .iter()
        .map(placed)
        .filter(|p| p.len() >= 2)
        .collect()
}

/// The length of an open path, mm.
pub(crate) fn line_len(l: &[[f64; 2]]) -> f64 {
    l.windows(2).map(|w| dist(w[0], w[1])).sum()
}

/// Where the head goes, `(min, max)` in machine mm, refused unless it lies on the bed: the sheet
/// (`frame`), every line and every loop (its arcs' extremes included), which a drag knife's axis
/// passes by up to the blade offset (`reach`).
fn check_on_bed(
    frame: &[[f64; 2]; 4],
    loops: &[Loop],
    lines: &[Vec<[f64; 2]>],
    machine: &Machine,
    reach: f64,
) -> Result<([f64; 2], [f64; 2]), PlanError> {
    let mut min = [f64::INFINITY; 2];
    let mut max = [f64::NEG_INFINITY; 2];
    let mut grow = |p: &[f64; 2], r: f64| {
        for a in 0..2 {
            min[a] = min[a].min(p[a] - r);
            max[a] = max[a].max(p[a] + r);
        }
    };
    frame.iter().for_each(|p| grow(p, 0.0));
    loops
        .iter()
        .flat_map(|l| l.points.iter())
        .chain(lines.iter().flatten())
        .for_each(|p| grow(p, reach));
    // Arcs reach past their ends: their exact extremes.
    for b in loops.iter().filter_map(|l| curve::bounds(&l.curve)) {
        grow(&[b[0], b[1]], 0.0);
        grow(&[b[2], b[3]], 0.0);
    }
    let (bw, bh) = (machine.bed.width_mm, machine.bed.height_mm);
    let eps = 1e-6;
    if machine.check_extent(min, max, None).is_err() {
        let too_big = max[0] - min[0] > bw + eps || max[1] - min[1] > bh + eps;
        return Err(PlanError::DoesNotFit {
            machine: machine.name.clone(),
            w: max[0] - min[0],
            h: max[1] - min[1],
            bw,
            bh,
            x0: min[0],
            x1: max[0],
            y0: min[1],
            y1: max[1],
            fix: if too_big { Fit::ScaleDown } else { Fit::Move },
        });
    }
    Ok((min, max))
}

/// The cut sequence `(loop, start vertex)` with the least travel among candidate orders that all
/// keep the cut-order constraints: the depth layers optimised one by one, nearest neighbour under
/// the constraints, and the input order itself where it keeps them.
fn shortest_sequence(loops: &[Loop], gaps: &order::Gaps, home: [f64; 2]) -> Vec<(usize, usize)> {
    let order::Order { groups, before } = order::order(loops, gaps);
    let mut candidates = vec![
        travel::optimise(loops, &groups, home),
        travel::greedy_constrained(loops, &before, home),
    ];
    let mut input: Vec<(usize, usize)> = (0..loops.len()).map(|i| (i, 0)).collect();
    if travel::respects(&input, &before) {
        travel::refine_starts(loops, &mut input, home);
        candidates.push(input);
    }
    // The layered order always keeps them (first in the list); the others are checked.
    let travel_of_seq = |c: &Vec<(usize, usize)>| travel::sequence_travel(loops, c, home);
    let mut sequence = candidates.swap_remove(0);
    let mut best = travel_of_seq(&sequence);
    for c in candidates {
        let t = travel_of_seq(&c);
        if t < best - 1e-9 && travel::respects(&c, &before) {
            (sequence, best) = (c, t);
        }
    }
    sequence
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine;
    use geo::{Coord, MultiPolygon, Polygon, Rect};

    pub(crate) fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Polygon<f64> {
        Polygon::new(
            LineString::from(vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)]),
            vec![],
        )
    }

    fn geom(w: f64, h: f64, cuts: Vec<Polygon<f64>>) -> CutLoops {
        let outline = Rect::new(Coord { x: 0.0, y: 0.0 }, Coord { x: w, y: h });
        CutLoops::drawn(outline, MultiPolygon(cuts))
    }

    fn settings() -> CutSettings {
        CutSettings {
            power_pct: 80.0,
            speed_mm_min: 600.0,
            passes: 1,
            blade_offset_mm: 0.0,
            air_assist: false,
        }
    }

    /// Settings with the sheet's outline cut, so the whole sheet is placed and checked.
    fn sheet_cfg() -> PlanConfig {
        let mut cfg = PlanConfig::new(settings());
        cfg.cut_outline = true;
        cfg
    }

    #[test]
    fn flips_y_and_places_at_offset() {
        let m = machine::load(None).unwrap();
        let g = geom(100.0, 50.0, vec![rect(10.0, 5.0, 20.0, 15.0)]);
        // The sheet is placed (its outline is cut): these tests are about the placement.
        let mut cfg = sheet_cfg();
        cfg.offset = [30.0, 40.0];
        let job = plan(&g, &m, &cfg).unwrap();
        let pts = &job.loops[0].points;
        // y down 5..15 on a 50 mm sheet → y up 35..45, shifted by 40.
        let ys: Vec<f64> = pts.iter().map(|p| p[1]).collect();
        let xs: Vec<f64> = pts.iter().map(|p| p[0]).collect();
        assert!(ys
            .iter()
            .all(|&y| (y - 75.0).abs() < 1e-9 || (y - 85.0).abs() < 1e-9));
        assert!(xs
            .iter()
            .all(|&x| (x - 40.0).abs() < 1e-9 || (x - 50.0).abs() < 1e-9));
        assert_eq!(job.min, [30.0, 40.0]);
        assert_eq!(job.max, [130.0, 90.0]);
    }

    #[test]
    fn top_left_origin_keeps_y_down_and_center_anchor() {
        let mut m = machine::load(None).unwrap();
        m.bed.origin = Corner::TopLeft;
        let g = geom(100.0, 50.0, vec![rect(10.0, 5.0, 20.0, 15.0)]);
        let job = plan(&g, &m, &sheet_cfg()).unwrap();
        let ys: Vec<f64> = job.loops[0].points.iter().map(|p| p[1]).collect();
        assert!(ys.iter().all(|&y| y == 5.0 || y == 15.0), "{ys:?}");
        let mut cfg = sheet_cfg();
        cfg.anchor = Some(Anchor::Center);
        cfg.offset = [200.0, 200.0];
        let job = plan(&g, &m, &cfg).unwrap();
        assert_eq!(job.min, [150.0, 175.0]);
        assert_eq!(job.max, [250.0, 225.0]);
    }

    #[test]
    fn too_big_is_refused_with_sizes() {
        let m = machine::load(None).unwrap();
        let g = geom(500.0, 120.0, vec![rect(10.0, 10.0, 20.0, 20.0)]);
        let e = plan(&g, &m, &sheet_cfg()).unwrap_err().to_string();
        assert!(
            e.contains("500.0 x 120.0") && e.contains("400.0 x 400.0"),
            "{e}"
        );
        assert!(e.contains("scale"), "{e}");
        let g = geom(100.0, 100.0, vec![rect(10.0, 10.0, 20.0, 20.0)]);
        let mut cfg = sheet_cfg();
        cfg.offset = [350.0, 0.0];
        let e = plan(&g, &m, &cfg).unwrap_err().to_string();
        assert!(
            e.contains("X 350.0..450.0") && e.contains("move it on the bed"),
            "{e}"
        );
    }

    #[test]
    fn settings_are_checked() {
        let m = machine::load(None).unwrap();
        let g = geom(100.0, 100.0, vec![rect(10.0, 10.0, 20.0, 20.0)]);
        let mut s = settings();
        s.speed_mm_min = 60000.0;
        let e = plan(&g, &m, &PlanConfig::new(s)).unwrap_err().to_string();
        assert!(e.contains("max feed"), "{e}");
        s = settings();
        s.passes = 0;
        assert!(plan(&g, &m, &PlanConfig::new(s)).is_err());
        s = settings();
        s.power_pct = 120.0;
        assert!(plan(&g, &m, &PlanConfig::new(s)).is_err());
    }
}
