//! A job from cut loops to HP-GL: the G-code crate's planner places it on the plotter, orders the
//! cuts (inner ones first) and routes the travel; this writes it in plotter units with the drag
//! knife's blade physics, then times what was written on the virtual cutter.

use geo::{Coord, LineString, MapCoords, MultiPolygon, Rect};
use stencil_gcode::blade::{axis_path, direction, knife_loop, Blade};
use stencil_gcode::{plan, CutLoops, CutSettings, Job, PathStats, Pieces, PlanConfig, PlanError};

use crate::command::{to_text, Command};
use crate::cutter::{self, Refusal};
use crate::profile::{Park, Plotter, ToolKind};
use crate::weed::{weed_box, weed_lines, WeedError, Weeding};

/// What `make --emit hpgl` and `stencil hpgl` need besides the geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct HpglConfig {
    /// The plotter.
    pub plotter: Plotter,
    /// Where and how to cut: the planner's settings (speed, passes, blade offset; arcs are not
    /// used: HP-GL is written as straight segments).
    pub plan: PlanConfig,
    /// The blade force, grams (a knife whose plotter takes `FS`); `None`: the plotter's own.
    pub force_g: Option<f64>,
    /// The pen (tool) selected with `SP`.
    pub pen: u32,
    /// Where the settings came from, for the report.
    pub settings_from: String,
    /// Weeding aids to cut.
    pub weeding: Weeding,
}

/// What an HP-GL job costs, as `make` and `hpgl` print it and report.json records it.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HpglSummary {
    /// The plotter's name.
    pub plotter: String,
    /// knife or pen.
    pub tool: String,
    /// The dialect.
    pub dialect: String,
    /// The cut settings used.
    pub settings: Option<CutSettings>,
    /// Where they came from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settings_from: Option<String>,
    /// `FS` as written (`None`: none written).
    pub force: Option<i64>,
    /// The job was turned a quarter turn so its long side runs with the media feed.
    pub rotated: bool,
    /// Loops, lengths and travel as planned.
    #[serde(flatten)]
    pub path: PathStats,
    /// Instructions written.
    pub commands: usize,
    /// The virtual cutter's run of the written file: time and lengths.
    pub estimate: cutter::Timing,
    /// Weeding lines cut (each from a point inside a cut-out area to a cut around it).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub weed_lines: usize,
    /// A weeding box was cut around the job.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub weed_box: bool,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// The largest number of points in one `PU`/`PD`: every instruction stays short (under 80
/// bytes), well inside any plotter's buffer and the sender's pieces.
pub const POINTS_PER_COMMAND: usize = 4;

/// Why a job could not be written.
#[derive(Debug, thiserror::Error)]
pub enum HpglError {
    /// The planner refused it.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// A weeding aid cannot be cut.
    #[error(transparent)]
    Weed(#[from] WeedError),
    /// Our own output failed our own virtual cutter: a bug, reported rather than written.
    #[error("internal error: the written HP-GL does not run on the virtual cutter ({0}); please report this")]
    Internal(Refusal),
}

/// Plan and write a job; the summary times the written text on the virtual cutter.
pub fn hpgl_for(geom: &CutLoops, cfg: &HpglConfig) -> Result<(String, HpglSummary), HpglError> {
    let p = &cfg.plotter;
    let machine = p.planner_machine();
    let mut plan_cfg = cfg.plan;
    plan_cfg.arc_tolerance_mm = 0.0;
    if p.tool == ToolKind::Pen {
        plan_cfg.settings.blade_offset_mm = 0.0;
    }
    let (job, rotated) = match plan(geom, &machine, &plan_cfg) {
        Err(PlanError::DoesNotFit { .. }) if p.roll => {
            // A roll cutter takes any length along the feed: turn the job so its long side runs
            // with it. Refused as the turned job's error if it still does not fit.
            (plan(&quarter_turn(geom), &machine, &plan_cfg)?, true)
        }
        r => (r?, false),
    };
    let mut job = job;
    if let Some(m) = cfg.weeding.box_margin_mm {
        let reach = box_reach(&job, p);
        make_room(&mut job, m + reach);
    }
    let Written {
        commands,
        force,
        weed_lines,
        weed_box,
    } = commands(&job, cfg)?;
    let text = to_text(&commands);
    let run = cutter::run_text(p, &text).map_err(HpglError::Internal)?;
    Ok((
        text,
        HpglSummary {
            plotter: p.name.clone(),
            tool: match p.tool {
                ToolKind::Knife => "knife".into(),
                ToolKind::Pen => "pen".into(),
            },
            dialect: p.dialect.name().into(),
            settings: Some(plan_cfg.settings),
            settings_from: (!cfg.settings_from.is_empty()).then(|| cfg.settings_from.clone()),
            force,
            rotated,
            path: job.stats,
            commands: commands.len(),
            estimate: run.timing,
            weed_lines,
            weed_box,
        },
    ))
}

/// How far outside a weeding box the head may go: a drag knife's axis swings the blade offset
/// beyond the tip's path at the corners; a little more for rounding to plotter units.
fn box_reach(job: &Job, p: &Plotter) -> f64 {
    let blade = match p.tool {
        ToolKind::Knife => job.settings.blade_offset_mm,
        ToolKind::Pen => 0.0,
    };
    blade + 0.05
}

/// A weeding box is part of the job, as in sign-making software: where the job was placed too
/// near the cutting area's origin edges for a box `margin` outside its cuts, it moves in just
/// as far as the box needs (the far edges are checked with the box).
fn make_room(job: &mut Job, margin: f64) {
    let mut lo = [f64::INFINITY; 2];
    for q in job
        .loops
        .iter()
        .filter(|l| !l.outline)
        .flat_map(|l| &l.points)
    {
        lo = [lo[0].min(q[0]), lo[1].min(q[1])];
    }
    let shift = [0, 1].map(|a| {
        if lo[a].is_finite() {
            (margin - lo[a]).max(0.0)
        } else {
            0.0
        }
    });
    if shift == [0.0, 0.0] {
        return;
    }
    let mv = |q: &mut [f64; 2]| {
        q[0] += shift[0];
        q[1] += shift[1];
    };
    for l in &mut job.loops {
        l.points.iter_mut().for_each(mv);
    }
    for l in &mut job.lines {
        l.iter_mut().for_each(mv);
    }
    mv(&mut job.min);
    mv(&mut job.max);
}

/// The job turned a quarter turn on the sheet (counter-clockwise as seen from above): the same
/// shape, its long side now along the plotter's X (the feed).
fn quarter_turn(g: &CutLoops) -> CutLoops {
    let (x0, y1) = (g.outline.min().x, g.outline.max().y);
    let turn = |c: Coord<f64>| Coord {
        x: y1 - c.y,
        y: c.x - x0,
    };
    let (a, b) = (turn(g.outline.min()), turn(g.outline.max()));
    let ring = |l: &LineString<f64>| l.map_coords(turn);
    CutLoops {
        outline: Rect::new(a, b),
        cuts: g.cuts.map_coords(turn),
        kerf_mm: g.kerf_mm,
        pieces: match &g.pieces {
            Pieces::Regions(r) => Pieces::Regions(MultiPolygon(
                r.0.iter().map(|p| p.map_coords(turn)).collect(),
            )),
            other => other.clone(),
        },
        lines: g.lines.iter().map(ring).collect(),
        outline_ring: g.outline_ring.as_ref().map(ring),
        curves: Default::default(),
    }
}

/// A job's instructions, the `FS` written and the weeding aids.
struct Written {
    commands: Vec<Command>,
    force: Option<i64>,
    weed_lines: usize,
    weed_box: bool,
}

/// The job's instructions, and the `FS` written.
fn commands(job: &Job, cfg: &HpglConfig) -> Result<Written, WeedError> {
    let p = &cfg.plotter;
    let s = &job.settings;
    let speed_mm_s = s.speed_mm_min / 60.0;
    let vs = p.velocity(speed_mm_s);
    let mut out = vec![Command::In, Command::Sp(cfg.pen.clamp(1, p.pens))];
    out.push(Command::Vs(vs));
    let force = match p.tool {
        ToolKind::Knife => cfg.force_g.and_then(|g| p.force(g)),
        ToolKind::Pen => None,
    };
    if let Some(f) = force {
        out.push(Command::Fs(f));
    }
    let units = |q: [f64; 2]| [p.units(q[0]), p.units(q[1])];
    let emit = |out: &mut Vec<Command>, path: &[[f64; 2]]| {
        out.push(Command::Pu(vec![units(path[0])]));
        let mut pts: Vec<[i64; 2]> = path[1..].iter().map(|&q| units(q)).collect();
        pts.dedup();
        for c in pts.chunks(POINTS_PER_COMMAND) {
            out.push(Command::Pd(c.to_vec()));
        }
    };
    // Open paths: drawn (or cut open) as they are, back and forth for further passes.
    for l in &job.lines {
        let mut path = l.clone();
        for pass in 1..s.passes {
            let back: Vec<[f64; 2]> = if pass % 2 == 1 {
                l.iter().rev().skip(1).copied().collect()
            } else {
                l.iter().skip(1).copied().collect()
            };
            path.extend(back);
        }
        emit(&mut out, &path);
    }
    // The blade after `IN` is taken to point along +X (the direction the last job ended in is
    // not known): the first cut's orientation move turns it from there.
    let mut blade_dir = [1.0, 0.0];
    let knife = match (p.tool, p.knife) {
        (ToolKind::Knife, Some(k)) => Some(k),
        _ => None,
    };
    // Weeding lines, while the sheet is whole: the tip from a point inside a cut-out area to
    // the cut around it, lowered there and swivelled to the line first (the axis runs on past
    // the cut by the blade offset, so the tip reaches it).
    let mut weed_count = 0;
    if let Some(spacing) = cfg.weeding.line_spacing_mm {
        for [from, to] in weed_lines(&job.loops, spacing) {
            let path = match knife {
                Some(k) => {
                    let path =
                        axis_path(&[from, to], s.blade_offset_mm, k.swivel_min_deg, blade_dir);
                    blade_dir = direction(from, to);
                    path
                }
                None => vec![from, to],
            };
            emit(&mut out, &path);
            weed_count += 1;
        }
    }
    let mut current_vs = vs;
    for l in &job.loops {
        let path = match (p.tool, p.knife) {
            (ToolKind::Knife, Some(k)) => {
                let small = is_small(&l.points, k.small_feature_mm);
                let want = if small {
                    p.velocity(speed_mm_s * k.small_feature_speed_pct / 100.0)
                } else {
                    vs
                };
                if want != current_vs {
                    out.push(Command::Vs(want));
                    current_vs = want;
                }
                let blade = Blade {
                    offset_mm: s.blade_offset_mm,
                    swivel_min_deg: k.swivel_min_deg,
                    overcut_mm: k.overcut_mm,
                };
                let (path, end) = knife_loop(&l.points, &blade, s.passes, blade_dir);
                blade_dir = end;
                path
            }
            _ => {
                let mut path = Vec::with_capacity(l.points.len() * s.passes as usize + 1);
                for _ in 0..s.passes {
                    path.extend_from_slice(&l.points);
                }
                path.push(l.points[0]);
                path
            }
        };
        emit(&mut out, &path);
    }
    // The weeding box, last, as the sheet's outline is: around everything, at the job's speed.
    let boxed = match cfg.weeding.box_margin_mm {
        Some(margin) => weed_box(
            &job.loops,
            margin,
            box_reach(job, p),
            [p.bed.width_mm, p.bed.height_mm],
        )?,
        None => None,
    };
    if let Some(b) = &boxed {
        if current_vs != vs {
            out.push(Command::Vs(vs));
        }
        let path = match knife {
            Some(k) => {
                let blade = Blade {
                    offset_mm: s.blade_offset_mm,
                    swivel_min_deg: k.swivel_min_deg,
                    overcut_mm: k.overcut_mm,
                };
                knife_loop(b, &blade, 1, blade_dir).0
            }
            None => {
                let mut path = b.clone();
                path.push(b[0]);
                path
            }
        };
        emit(&mut out, &path);
    }
    // Park: past the job along the feed so the media can be cut off, or home.
    let end_x = boxed
        .as_ref()
        .map_or(job.max[0], |b| job.max[0].max(b[1][0]));
    let park = match p.park {
        Park::PastJob => [(end_x + PARK_PAST_MM).min(p.bed.width_mm).max(0.0), 0.0],
        Park::Origin => [0.0, 0.0],
    };
    out.push(Command::Pu(vec![units(park)]));
    if p.tool == ToolKind::Pen {
        out.push(Command::Sp(0));
    }
    Ok(Written {
        commands: out,
        force,
        weed_lines: weed_count,
        weed_box: boxed.is_some(),
    })
}

/// How far past the job's end a roll cutter parks, mm: clear of the last cut, so the media can
/// be cut off across.
pub const PARK_PAST_MM: f64 = 10.0;

/// Whether a loop is a small feature: its bounding box's longer side below `limit_mm`.
fn is_small(points: &[[f64; 2]], limit_mm: f64) -> bool {
    let mut min = [f64::INFINITY; 2];
    let mut max = [f64::NEG_INFINITY; 2];
    for q in points {
        for a in 0..2 {
            min[a] = min[a].min(q[a]);
            max[a] = max[a].max(q[a]);
        }
    }
    (max[0] - min[0]).max(max[1] - min[1]) < limit_mm
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cutter::run_text_with;
    use crate::profile::load;
    use geo::{Polygon, Rect};
    use stencil_geom::ring::seg_dist;

    /// A 20 mm square hole and a sharp triangle on a 60 x 40 mm sheet, cut with a 0.25 mm blade
    /// offset on the generic cutter; `offset_mm` is the offset the writer compensates for.
    fn job(offset_mm: f64) -> (String, Plotter) {
        let square = LineString::from(vec![
            (10., 10.),
            (30., 10.),
            (30., 30.),
            (10., 30.),
            (10., 10.),
        ]);
        let tri = LineString::from(vec![(40., 30.), (55., 28.), (40., 26.), (40., 30.)]);
        let cuts = MultiPolygon(vec![
            Polygon::new(square, vec![]),
            Polygon::new(tri, vec![]),
        ]);
        let geom = CutLoops::drawn(Rect::new((0., 0.), (60., 40.)), cuts);
        let plotter = load("vinyl-hpgl").unwrap();
        let settings = CutSettings {
            power_pct: 100.0,
            speed_mm_min: 2400.0,
            passes: 1,
            blade_offset_mm: offset_mm,
            air_assist: false,
        };
        let cfg = HpglConfig {
            plotter: plotter.clone(),
            plan: PlanConfig::new(settings),
            force_g: Some(80.0),
            pen: 1,
            settings_from: String::new(),
            weeding: Weeding::default(),
        };
        (hpgl_for(&geom, &cfg).unwrap().0, plotter)
    }

    /// The outlines as placed: the job's box (the cuts' box, grown by the blade's reach) at 0,0,
    /// y up.
    fn outlines(reach: f64) -> Vec<Vec<[f64; 2]>> {
        let place = |x: f64, y: f64| [x - 10.0 + reach, 30.0 + reach - y];
        vec![
            vec![(10., 10.), (30., 10.), (30., 30.), (10., 30.)],
            vec![(40., 30.), (55., 28.), (40., 26.)],
        ]
        .into_iter()
        .map(|r| r.into_iter().map(|(x, y)| place(x, y)).collect())
        .collect()
    }

    /// How far the farthest tip point lies from the nearest outline, mm.
    fn worst(tip: &[Vec<[f64; 2]>], rings: &[Vec<[f64; 2]>]) -> f64 {
        tip.iter()
            .flatten()
            .map(|&p| {
                rings
                    .iter()
                    .flat_map(|r| {
                        (0..r.len()).map(move |i| seg_dist(p, r[i], r[(i + 1) % r.len()]))
                    })
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn the_blade_tip_follows_the_outline_when_compensated() {
        let r = 0.25;
        // Compensated: the virtual cutter drags the tip r behind the axis; it stays on the
        // outlines (the swivels hold it on each corner).
        let (text, p) = job(r);
        let c = run_text_with(&p, &text, r).unwrap();
        let on = worst(&c.tip, &outlines(r));
        // Within two plotter units (0.05 mm): the rounding of each point to 0.025 mm, and the
        // tractrix drawn in steps.
        assert!(on < 0.05, "compensated tip strays {on} mm");
        // Not compensated, the same blade rounds every corner off (the 30° corner most).
        let (text, p) = job(0.0);
        let c = run_text_with(&p, &text, r).unwrap();
        let off = worst(&c.tip, &outlines(0.0));
        assert!(off > 0.1, "uncompensated tip strays only {off} mm");
    }

    #[test]
    fn each_loop_is_cut_through_past_its_start() {
        let (text, p) = job(0.25);
        let c = run_text_with(&p, &text, 0.25).unwrap();
        let len = |s: &Vec<[f64; 2]>| {
            s.windows(2)
                .map(|w| ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt())
                .sum::<f64>()
        };
        // The tip cuts each loop round once and 1 mm further (the overcut).
        let tri = 2.0 * (15f64.hypot(2.0)) + 4.0;
        let mut got: Vec<f64> = c.tip.iter().map(len).collect();
        got.sort_by(f64::total_cmp);
        assert!((got[0] - (tri + 1.0)).abs() < 0.1, "{got:?}");
        assert!((got[1] - 81.0).abs() < 0.1, "{got:?}");
        // The file has the material's force and speed (neither loop is a small feature), and
        // parks 10 mm past the job's far end.
        assert!(
            text.contains("\nFS80;\n") && text.contains("\nVS4;\n"),
            "{text}"
        );
        assert!(text.trim_end().ends_with(&format!(
            "PU{},0;",
            p.units(55.0 - 10.0 + 0.25 + PARK_PAST_MM + 0.25)
        )));
    }
}
