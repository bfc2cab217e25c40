//! The test grid: small squares cut over a range of power × speed (a laser), depth × speed (a
//! drag knife) or speed alone (a pen), each labelled in the G-code and in an SVG preview, so a
//! user finds the setting that cuts their sheet cleanly and writes it into the material profile.
//!
//! The squares are a [`Job`] written by the one G-code writer (`write_each`):
//! same header, laser mode and end as every job, each square at its own settings.

use crate::machine::{Machine, Tool};
use stencil_geom::ring::bbox;

use crate::error::{Fit, PlanError, RowKind, SettingsError};
use crate::job::{CutSettings, Job, Loop, PathStats};
use crate::num::num;
use crate::toolpath::{check_settings, laser_s};
use crate::write::{write_each, LoopSettings};

/// A range of values: `from..to` in `steps` evenly spaced values (`A..B:N`), or one value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Steps {
    /// The first value.
    pub from: f64,
    /// The last value.
    pub to: f64,
    /// How many values.
    pub steps: usize,
}

/// The most values along one side of the grid.
pub(crate) const MAX_STEPS: usize = 20;

impl Steps {
    /// `A..B:N` (N values from A to B, both included), `A..B` (5 values) or `A` (one value).
    pub fn parse(s: &str) -> Result<Steps, String> {
        let bad =
            || format!("'{s}' is not a range: use FROM..TO:STEPS (e.g. 20..100:5) or one number");
        let num = |t: &str| -> Result<f64, String> {
            t.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(bad)
        };
        let (range, steps) = match s.split_once(':') {
            Some((r, n)) => (r, Some(n.trim().parse::<usize>().map_err(|_| bad())?)),
            None => (s, None),
        };
        let (from, to, steps) = match range.split_once("..") {
            Some((a, b)) => (num(a)?, num(b)?, steps.unwrap_or(5)),
            None if steps.is_none() => {
                let v = num(range)?;
                (v, v, 1)
            }
            None => return Err(bad()),
        };
        if !(1..=MAX_STEPS).contains(&steps) {
            return Err(format!(
                "'{s}': the number of steps must be 1 to {MAX_STEPS}"
            ));
        }
        if steps == 1 && from != to {
            return Err(format!(
                "'{s}': one step cannot cover {from}..{to}; use 2 or more"
            ));
        }
        Ok(Steps { from, to, steps })
    }

    /// The values, from `from` to `to`.
    pub fn values(&self) -> Vec<f64> {
        if self.steps == 1 {
            return vec![self.from];
        }
        (0..self.steps)
            .map(|i| self.from + (self.to - self.from) * i as f64 / (self.steps - 1) as f64)
            .map(|v| (v * 1000.0).round() / 1000.0)
            .collect()
    }
}

/// A test grid to cut.
#[derive(Clone, Debug, PartialEq)]
pub struct GridSpec {
    /// What the rows vary.
    pub row_kind: RowKind,
    /// Power % or depth per row (one `NaN`-free value per row; one row for [`RowKind::None`]).
    pub rows: Vec<f64>,
    /// Speed per column, mm/min.
    pub speeds: Vec<f64>,
    /// Side of each square, mm.
    pub size_mm: f64,
    /// Space between squares, mm.
    pub gap_mm: f64,
    /// Machine coordinates of the grid's lower-left corner, mm.
    pub offset: [f64; 2],
    /// Passes and blade offset (and the header's power and speed: the material's own).
    pub base: CutSettings,
}

/// One square.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Row, from 0.
    pub row: usize,
    /// Column, from 0.
    pub col: usize,
    /// The square's settings.
    pub settings: CutSettings,
    /// The S word (laser) or the depth (knife), as written.
    pub s: Option<f64>,
    /// The Z the knife or pen goes down to.
    pub depth: Option<f64>,
    /// Lower-left corner, machine mm.
    pub min: [f64; 2],
}

impl Cell {
    /// The square's label: `40% F900`, `Z-0.3 F900` or `F900`.
    pub fn label(&self) -> String {
        let f = format!("F{}", num(self.settings.speed_mm_min));
        match (self.s, self.depth) {
            (Some(_), _) => format!("{}% {f}", num(self.settings.power_pct)),
            (_, Some(d)) => format!("Z{} {f}", num(d)),
            _ => f,
        }
    }
}

/// A planned grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// What was asked for.
    pub spec: GridSpec,
    /// The squares, row by row.
    pub cells: Vec<Cell>,
    /// The squares as a job for the writer.
    pub job: Job,
    /// Width and height of the squares together, mm.
    pub size: [f64; 2],
}

/// The square at row `r`, column `c` (from 0) cut at `speed`, its lower-left corner at `min`:
/// its row's power or depth applied to the base settings, and checked against the machine.
fn cell(
    spec: &GridSpec,
    machine: &Machine,
    (r, c): (usize, usize),
    speed: f64,
    min: [f64; 2],
) -> Result<Cell, PlanError> {
    let row = spec.rows.get(r).copied();
    let mut settings = CutSettings {
        speed_mm_min: speed,
        ..spec.base
    };
    let (mut s, mut depth) = (None, None);
    match (spec.row_kind, machine.tool, row) {
        (RowKind::Power, Tool::Laser { s_max, .. }, Some(p)) => {
            settings.power_pct = p;
            s = Some(laser_s(p, s_max));
        }
        (RowKind::Depth, Tool::Knife { z, .. }, Some(d)) => {
            if d >= z.up_mm {
                return Err(SettingsError::DepthAboveBlade {
                    depth: d,
                    up: z.up_mm,
                    machine: machine.name.clone(),
                }
                .into());
            }
            depth = Some(d);
        }
        (RowKind::None, _, _) => {}
        (kind, tool, _) => {
            return Err(SettingsError::GridKind {
                kind,
                tool: tool.kind(),
                machine: machine.name.clone(),
            }
            .into())
        }
    }
    let cell = Cell {
        row: r,
        col: c,
        settings,
        s,
        depth,
        min,
    };
    check_settings(&settings, machine).map_err(|cause| PlanError::GridSquare {
        row: r + 1,
        col: c + 1,
        label: cell.label(),
        cause: Box::new(cause),
    })?;
    Ok(cell)
}

/// Lay the squares out (rows along +Y, columns along +X from `offset`), check every square's
/// settings against the machine and the whole grid against its bed.
pub fn plan_grid(spec: &GridSpec, machine: &Machine) -> Result<Grid, PlanError> {
    if !(spec.size_mm.is_finite()
        && spec.size_mm > 0.0
        && spec.gap_mm.is_finite()
        && spec.gap_mm >= 0.0)
    {
        return Err(SettingsError::GridSquares.into());
    }
    let (nr, nc) = (spec.rows.len().max(1), spec.speeds.len());
    if nc == 0 {
        return Err(SettingsError::GridNoSpeed.into());
    }
    let pitch = spec.size_mm + spec.gap_mm;
    let size = [
        nc as f64 * spec.size_mm + (nc - 1) as f64 * spec.gap_mm,
        nr as f64 * spec.size_mm + (nr - 1) as f64 * spec.gap_mm,
    ];
    check_on_bed(spec, machine, size)?;
    let mut cells = Vec::with_capacity(nr * nc);
    for r in 0..nr {
        for (c, &speed) in spec.speeds.iter().enumerate() {
            let min = [
                spec.offset[0] + c as f64 * pitch,
                spec.offset[1] + r as f64 * pitch,
            ];
            cells.push(cell(spec, machine, (r, c), speed, min)?);
        }
    }
    let job = squares_job(spec, &cells, size);
    Ok(Grid {
        spec: spec.clone(),
        cells,
        job,
        size,
    })
}

/// Refuse a grid of `size` (mm) at `spec.offset` that leaves the bed, counting the swing of a
/// drag knife's axis (the blade offset) at every corner.
fn check_on_bed(spec: &GridSpec, machine: &Machine, size: [f64; 2]) -> Result<(), PlanError> {
    let reach = spec.base.blade_offset_mm.max(0.0);
    let (x0, y0) = (spec.offset[0] - reach, spec.offset[1] - reach);
    let (x1, y1) = (
        spec.offset[0] + size[0] + reach,
        spec.offset[1] + size[1] + reach,
    );
    let (bw, bh) = (machine.bed.width_mm, machine.bed.height_mm);
    let eps = 1e-6;
    if x0 < -eps || y0 < -eps || x1 > bw + eps || y1 > bh + eps {
        return Err(PlanError::DoesNotFit {
            machine: machine.name.clone(),
            w: size[0],
            h: size[1],
            bw,
            bh,
            x0,
            x1,
            y0,
            y1,
            fix: Fit::ShrinkGrid,
        });
    }
    Ok(())
}

/// The squares as a job the G-code writer takes: one loop per square in the cells' order (row by
/// row, no travel optimisation, so the squares run in the order their comments number them),
/// starting from and returning to the origin (0, 0), with the base settings.
fn squares_job(spec: &GridSpec, cells: &[Cell], size: [f64; 2]) -> Job {
    let a = spec.size_mm;
    let loops: Vec<Loop> = cells
        .iter()
        .map(|c| {
            let [x, y] = c.min;
            Loop {
                points: vec![[x, y], [x + a, y], [x + a, y + a], [x, y + a]],
                outline: false,
                area_mm2: a * a,
                curve: Vec::new(),
            }
        })
        .collect();
    let home = [0.0, 0.0];
    let travel = crate::travel::naive_travel(&[], &loops, home);
    let cut_mm = loops
        .iter()
        .map(|l| l.perimeter_mm() * spec.base.passes as f64)
        .sum();
    Job {
        lines: Vec::new(),
        loops,
        home,
        settings: spec.base,
        // Squares: nothing to fit.
        arc_tolerance_mm: 0.0,
        sheet_mm: size,
        min: spec.offset,
        max: [spec.offset[0] + size[0], spec.offset[1] + size[1]],
        stats: PathStats {
            lines: 0,
            loops: cells.len(),
            cut_mm,
            travel_mm: travel,
            naive_travel_mm: travel,
        },
    }
}

/// The square's comment line in the G-code: `square 3 of 25, row 1 column 3: power 40 % S400,
/// speed 900 mm/min` (a knife: `depth Z-0.3`).
pub(crate) fn cell_comment(c: &Cell, total: usize, ncols: usize) -> String {
    let what = match (c.s, c.depth) {
        (Some(s), _) => format!("power {} % S{}, ", num(c.settings.power_pct), num(s)),
        (_, Some(d)) => format!("depth Z{}, ", num(d)),
        _ => String::new(),
    };
    format!(
        "square {} of {total}, row {} column {}: {what}speed {} mm/min",
        c.row * ncols + c.col + 1,
        c.row + 1,
        c.col + 1,
        num(c.settings.speed_mm_min)
    )
}

/// The grid's G-code: the job's header with `notes`, then each square after its comment.
pub fn grid_gcode(g: &Grid, machine: &Machine, notes: &[String]) -> String {
    let n = g.cells.len();
    let each: Vec<LoopSettings> = g
        .cells
        .iter()
        .map(|c| LoopSettings {
            settings: c.settings,
            z_down_mm: c.depth,
            comment: cell_comment(c, n, g.spec.speeds.len()),
        })
        .collect();
    write_each(&g.job, machine, notes, &each)
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// An SVG preview in millimetres, as seen from above (rear at the top, mirrored as the machine's
/// origin corner says): each square with its label (`40% F900`), the rows' values on the left,
/// the columns' speeds below, and a title.
pub fn grid_svg(g: &Grid, machine: &Machine, title: &str) -> String {
    let page = Page::new(g, machine);
    let w = page.left + g.size[0] + page.right;
    let h = page.top + g.size[1] + page.bottom;
    let mut out = String::new();
    out.push_str(&format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}mm\" height=\"{}mm\" viewBox=\"0 0 {} {}\" font-family=\"sans-serif\">\n",
        num(w), num(h), num(w), num(h)
    ));
    out.push_str(&format!(
        "<text class=\"title\" x=\"{}\" y=\"6\" font-size=\"3.5\">{}</text>\n",
        num(page.left),
        escape(title)
    ));
    squares_svg(&mut out, g, &page);
    row_labels_svg(&mut out, g, &page);
    column_labels_svg(&mut out, g, &page);
    out.push_str("</svg>\n");
    out
}

/// Where the preview draws: each square's rectangle in the bed view (x to the right, y to the
/// rear, mirrored as the machine's origin says), and the margins around the grid for the labels.
struct Page {
    rects: Vec<[f64; 4]>,
    /// The grid's left and rear edges in the bed view.
    vx0: f64,
    vy1: f64,
    left: f64,
    top: f64,
    bottom: f64,
    right: f64,
}

impl Page {
    fn new(g: &Grid, machine: &Machine) -> Page {
        let o = machine.bed.origin;
        let (bw, bh) = (machine.bed.width_mm, machine.bed.height_mm);
        // Bed view: x to the right, y to the rear.
        let view = |p: [f64; 2]| {
            [
                if o.right() { bw - p[0] } else { p[0] },
                if o.top() { bh - p[1] } else { p[1] },
            ]
        };
        let a = g.spec.size_mm;
        let rects: Vec<[f64; 4]> = g
            .cells
            .iter()
            .map(|c| {
                let p = view(c.min);
                let q = view([c.min[0] + a, c.min[1] + a]);
                bbox(&[p, q])
            })
            .collect();
        let vx0 = rects.iter().map(|r| r[0]).fold(f64::INFINITY, f64::min);
        let vy1 = rects.iter().map(|r| r[3]).fold(f64::NEG_INFINITY, f64::max);
        Page {
            rects,
            vx0,
            vy1,
            left: 30.0,
            top: 12.0,
            bottom: 14.0,
            right: 6.0,
        }
    }

    /// SVG x of a bed-view x.
    fn sx(&self, vx: f64) -> f64 {
        self.left + vx - self.vx0
    }

    /// SVG y of a bed-view y (SVG's y runs down, the bed's to the rear).
    fn sy(&self, vy: f64) -> f64 {
        self.top + self.vy1 - vy
    }
}

/// The squares, each outlined with its settings written inside (squeezed to the square's width).
fn squares_svg(out: &mut String, g: &Grid, page: &Page) {
    let a = g.spec.size_mm;
    let font = (a / 5.0).clamp(1.0, 2.5);
    for (c, r) in g.cells.iter().zip(&page.rects) {
        out.push_str(&format!(
            "<rect class=\"square\" x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"red\" stroke-width=\"0.2\"/>\n",
            num(page.sx(r[0])), num(page.sy(r[3])), num(a), num(a)
        ));
        out.push_str(&format!(
            "<text class=\"cell\" data-row=\"{}\" data-col=\"{}\" x=\"{}\" y=\"{}\" font-size=\"{}\" text-anchor=\"middle\" textLength=\"{}\" lengthAdjust=\"spacingAndGlyphs\">{}</text>\n",
            c.row + 1,
            c.col + 1,
            num(page.sx((r[0] + r[2]) / 2.0)),
            num(page.sy((r[1] + r[3]) / 2.0) + font / 3.0),
            num(font),
            num(a * 0.9),
            escape(&c.label())
        ));
    }
}

/// Row labels: the row's value (power with its S, or depth), left of its leftmost square; none
/// when the rows vary nothing.
fn row_labels_svg(out: &mut String, g: &Grid, page: &Page) {
    let ncols = g.spec.speeds.len();
    for (ri, v) in g.spec.rows.iter().enumerate() {
        let r = &page.rects[ri * ncols];
        let text = match g.spec.row_kind {
            RowKind::Power => {
                let s = g.cells[ri * ncols].s.unwrap_or(0.0);
                format!("power {} % (S{})", num(*v), num(s))
            }
            RowKind::Depth => format!("depth Z{}", num(*v)),
            RowKind::None => continue,
        };
        out.push_str(&format!(
            "<text class=\"row\" x=\"{}\" y=\"{}\" font-size=\"2.5\" text-anchor=\"end\">{}</text>\n",
            num(page.left - 2.0),
            num(page.sy((r[1] + r[3]) / 2.0) + 0.8),
            text
        ));
    }
}

/// Column labels: each column's speed under the grid, and the axis name below them.
fn column_labels_svg(out: &mut String, g: &Grid, page: &Page) {
    for (ci, v) in g.spec.speeds.iter().enumerate() {
        let r = &page.rects[ci];
        out.push_str(&format!(
            "<text class=\"col\" x=\"{}\" y=\"{}\" font-size=\"2.5\" text-anchor=\"middle\">F{}</text>\n",
            num(page.sx((r[0] + r[2]) / 2.0)),
            num(page.top + g.size[1] + 5.0),
            num(*v)
        ));
    }
    out.push_str(&format!(
        "<text x=\"{}\" y=\"{}\" font-size=\"2.5\" text-anchor=\"middle\">speed, mm/min</text>\n",
        num(page.left + g.size[0] / 2.0),
        num(page.top + g.size[1] + 10.0)
    ));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_parse_and_step() {
        assert_eq!(
            Steps::parse("20..100:5").unwrap().values(),
            [20.0, 40.0, 60.0, 80.0, 100.0]
        );
        assert_eq!(Steps::parse("300..1500").unwrap().values().len(), 5);
        assert_eq!(Steps::parse("7").unwrap().values(), [7.0]);
        assert_eq!(
            Steps::parse("-0.1..-0.5:3").unwrap().values(),
            [-0.1, -0.3, -0.5]
        );
        for bad in [
            "", "a..b", "1..2:0", "1..2:99", "1..2:x", "1..5:1", "inf..2",
        ] {
            assert!(Steps::parse(bad).is_err(), "{bad}");
        }
    }
}
