//! Lines drawn as cuts: silhouettes (occluding contours) and suggestive contours (DeCarlo,
//! Finkelstein, Rusinkiewicz & Santella, "Suggestive Contours for Conveying Shape", SIGGRAPH 2003).
//!
//! Both are found in image space on the shaded fragments, so visibility comes from the z-buffer:
//! - silhouette: a model pixel next to the background, or the near side of a depth discontinuity
//!   (the neighbour is farther than the plane of its own triangle, extended to this pixel's ray,
//!   could explain: the surface folds away behind an occluding contour);
//! - suggestive contour: a zero crossing of the radial curvature κr between two neighbouring
//!   pixels of the same surface, kept only where D_w κr exceeds a threshold and the surface does
//!   not face the viewer head-on (DeCarlo's t_d and θ_c trims), and only as runs of some length.
//!
//! One-pixel seeds are then thickened to the line width with a disc.

use glam::Vec3;
use rayon::prelude::*;

use super::camera::Camera;
use super::load::Mesh;
use super::shade::Surfaces;
use super::visibility::{VisBuffer, NONE};

/// Which lines to draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LineMode {
    /// No lines.
    None,
    /// Silhouettes (occluding contours) only.
    Silhouette,
    /// Silhouettes and suggestive contours (DeCarlo et al. 2003).
    #[default]
    Suggestive,
}

/// Line settings at the working (supersampled) resolution.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LineParams {
    pub(crate) mode: LineMode,
    /// Line width in working pixels.
    pub width_px: f32,
    /// DeCarlo's t_d on the scale-free D_w κr·radius².
    pub contour_threshold: f32,
    /// Cosine of DeCarlo's θ_c: no suggestive contour where n·v is above it (facing the viewer).
    pub(crate) max_ndotv: f32,
    /// Suggestive contour runs shorter than this many working pixels are dropped.
    pub(crate) min_run_px: usize,
    /// Depth gap that counts as a discontinuity, in world units.
    pub(crate) depth_tolerance: f32,
}

const SILHOUETTE: u8 = 1;
const SUGGESTIVE: u8 = 2;

/// The line mask (true = line) at the working resolution, from `shade::geometry`'s fragments
/// and its surfaces' model mask: seeds (silhouettes, suggestive contours) thickened.
pub(crate) fn find(
    mesh: &Mesh,
    cam: &Camera,
    vb: &VisBuffer,
    (frags, surf): (&[[f32; 4]], &Surfaces),
    p: &LineParams,
) -> Vec<bool> {
    let (w, h) = (vb.width as usize, vb.height as usize);
    if p.mode == LineMode::None {
        return vec![false; w * h];
    }
    let mut seeds = vec![0u8; w * h];
    let us = cam.column_xs();
    seeds.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let v = cam.row_y(y);
        let at = |y: usize| Row::of((frags, surf), w, y);
        let rows = [
            y.checked_sub(1).map(at),
            Some(at(y)),
            (y + 1 < h).then(|| at(y + 1)),
        ];
        for x in surf.span(y) {
            row[x] = seed_in(mesh, cam, vb, &rows, p, (x, y), (us[x], v));
        }
    });
    if p.mode == LineMode::Suggestive && p.min_run_px > 1 {
        drop_short_runs(&mut seeds, w, h, p.min_run_px);
    }
    thicken(&seeds, w, h, p.width_px)
}

/// One working row as [`seed_in`] reads it: which samples show the model, and the fragments of
/// its span (from sample `a` on).
#[derive(Clone, Copy)]
struct Row<'a> {
    model: &'a [bool],
    frags: &'a [[f32; 4]],
    a: usize,
}

impl<'a> Row<'a> {
    fn of((frags, surf): (&'a [[f32; 4]], &'a Surfaces), w: usize, y: usize) -> Self {
        let span = surf.span(y);
        let start = if span.is_empty() {
            0
        } else {
            surf.kept(span.start, y)
        };
        Row {
            model: &surf.model[y * w..(y + 1) * w],
            frags: &frags[start..start + span.len()],
            a: span.start,
        }
    }

    /// The fragment of sample `x`, which shows the model (so lies in the span).
    #[inline(always)]
    fn frag(&self, x: usize) -> [f32; 4] {
        self.frags[x - self.a]
    }
}

/// The class `seed` gives pixel (`x`, `y`), given the rows above it, its own and below it (`None` past the
/// picture's edge), found once per row rather than per pixel and neighbour: the same tests in
/// the same order, so the same class.
#[inline]
fn seed_in(
    mesh: &Mesh,
    cam: &Camera,
    vb: &VisBuffer,
    [up, here, down]: &[Option<Row>; 3],
    p: &LineParams,
    (x, y): (usize, usize),
    (u, v): (f32, f32),
) -> u8 {
    let w = vb.width as usize;
    let Some(here) = here else { return 0 };
    if !here.model[x] {
        return 0;
    }
    let [depth, kr, dwkr, ndotv] = here.frag(x);
    let neighbours = [
        (Some(here), x.wrapping_sub(1), y),
        (Some(here), x + 1, y),
        (up.as_ref(), x, y.wrapping_sub(1)),
        (down.as_ref(), x, y + 1),
    ];
    let mut ray = None;
    let mut contour = false;
    for (row, nx, ny) in neighbours {
        let Some(row) = row else {
            return SILHOUETTE;
        };
        if nx >= w || !row.model[nx] {
            return SILHOUETTE;
        }
        let [g_depth, g_kr, ..] = row.frag(nx);
        let gap = g_depth - depth;
        if gap > p.depth_tolerance {
            let (o, d) = *ray.get_or_insert_with(|| cam.ray_at(u, v));
            if behind_plane(mesh, vb.tri[ny * w + nx], o, d, depth, p.depth_tolerance) {
                return SILHOUETTE;
            }
        }
        if p.mode == LineMode::Suggestive
            && !contour
            && (kr <= 0.0) != (g_kr <= 0.0)
            && kr.abs() <= g_kr.abs()
            && gap.abs() <= p.depth_tolerance.max(continuity_gap(cam, depth))
        {
            contour = dwkr > p.contour_threshold && ndotv < p.max_ndotv && ndotv > 0.0;
        }
    }
    if contour {
        SUGGESTIVE
    } else {
        0
    }
}

/// Classify one pixel, (`u`, `v`) its centre on the image plane (see `Camera::ray_at`). The
/// definition, a pixel at a time; [`find`] classifies rows with [`seed_in`].
#[cfg(test)]
fn seed(
    mesh: &Mesh,
    cam: &Camera,
    vb: &VisBuffer,
    (frags, surf): (&[[f32; 4]], &Surfaces),
    p: &LineParams,
    (x, y): (usize, usize),
    (u, v): (f32, f32),
) -> u8 {
    let (w, h) = (vb.width as usize, vb.height as usize);
    if !surf.model[y * w + x] {
        return 0;
    }
    let [depth, kr, dwkr, ndotv] = frags[surf.kept(x, y)];
    let neighbours = [
        (x.wrapping_sub(1), y),
        (x + 1, y),
        (x, y.wrapping_sub(1)),
        (x, y + 1),
    ];
    let mut ray = None;
    let mut contour = false;
    for &(nx, ny) in &neighbours {
        if nx >= w || ny >= h {
            return SILHOUETTE;
        }
        let j = ny * w + nx;
        if !surf.model[j] {
            return SILHOUETTE;
        }
        let [g_depth, g_kr, ..] = frags[surf.kept(nx, ny)];
        let gap = g_depth - depth;
        if gap > p.depth_tolerance {
            let (o, d) = *ray.get_or_insert_with(|| cam.ray_at(u, v));
            if behind_plane(mesh, vb.tri[j], o, d, depth, p.depth_tolerance) {
                return SILHOUETTE;
            }
        }
        if p.mode == LineMode::Suggestive
            && !contour
            && (kr <= 0.0) != (g_kr <= 0.0)
            && kr.abs() <= g_kr.abs()
            && gap.abs() <= p.depth_tolerance.max(continuity_gap(cam, depth))
        {
            contour = dwkr > p.contour_threshold && ndotv < p.max_ndotv && ndotv > 0.0;
        }
    }
    if contour {
        SUGGESTIVE
    } else {
        0
    }
}

/// How far apart in depth two neighbouring pixels of one smooth surface may plausibly be: a few
/// pixel footprints at that depth (the surface may be steep there).
#[inline]
fn continuity_gap(cam: &Camera, depth: f32) -> f32 {
    let footprint = if cam.orthographic {
        1.0 / cam.focal_px
    } else {
        depth / cam.focal_px
    };
    8.0 * footprint
}

/// Whether the plane of triangle `t`, extended to the ray (o, d), lies more than `tol` behind
/// `depth`: then the surface there cannot continue to this pixel and the step is an occluding
/// contour. Planes seen nearly edge-on cannot tell and say no.
#[inline]
fn behind_plane(mesh: &Mesh, t: u32, o: Vec3, d: Vec3, depth: f32, tol: f32) -> bool {
    if t == NONE {
        return true;
    }
    let [a, b, c] = mesh.triangles[t as usize].map(|i| mesh.positions[i as usize]);
    let n = (b - a).cross(c - a);
    let nd = n.dot(d);
    if nd.abs() < 0.2 * n.length() * d.length() {
        return false;
    }
    let z = n.dot(a - o) / nd;
    z > depth + tol
}

/// Remove suggestive-contour runs (8-connected) shorter than `min` pixels: a stencil wants a few
/// meaningful strokes, not dust.
fn drop_short_runs(seeds: &mut [u8], w: usize, h: usize, min: usize) {
    // A run's pixels are marked as found; the kept get their kind back at the end.
    const SEEN: u8 = 4;
    let mut stack = Vec::new();
    let mut comp = Vec::new();
    for start in 0..seeds.len() {
        if seeds[start] != SUGGESTIVE {
            continue;
        }
        comp.clear();
        stack.push(start);
        seeds[start] = SEEN;
        while let Some(i) = stack.pop() {
            comp.push(i);
            let (x, y) = ((i % w) as isize, (i / w) as isize);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as isize || ny >= h as isize {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    if seeds[j] == SUGGESTIVE {
                        seeds[j] = SEEN;
                        stack.push(j);
                    }
                }
            }
        }
        if comp.len() < min {
            for &i in &comp {
                seeds[i] = 0;
            }
        }
    }
    for s in seeds.iter_mut().filter(|s| **s == SEEN) {
        *s = SUGGESTIVE;
    }
}

/// Dilate the seeds by a disc of diameter `width` pixels (parallel over output rows).
fn thicken(seeds: &[u8], w: usize, h: usize, width: f32) -> Vec<bool> {
    let r = (width * 0.5).max(0.5);
    let ri = r.floor() as isize;
    // Half-width of the disc on each row offset.
    let half: Vec<isize> = (-ri..=ri)
        .map(|dy| ((r * r - (dy * dy) as f32).max(0.0)).sqrt().floor() as isize)
        .collect();
    // Each row's runs of seeds, first and last: the discs of a run's pixels cover on each row
    // one span from the first's left end to the last's right end (neighbours' spans touch), so
    // a silhouette along a row is filled once per row of the disc, not once per pixel.
    let rows: Vec<Vec<(usize, usize)>> = seeds
        .par_chunks(w)
        .map(|row| {
            let mut runs: Vec<(usize, usize)> = Vec::new();
            for (x, _) in row.iter().enumerate().filter(|(_, &s)| s != 0) {
                match runs.last_mut() {
                    Some((_, last)) if *last + 1 == x => *last = x,
                    _ => runs.push((x, x)),
                }
            }
            runs
        })
        .collect();
    let mut out = vec![false; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, line)| {
        for (k, dy) in (-ri..=ri).enumerate() {
            let sy = y as isize + dy;
            if sy < 0 || sy >= h as isize {
                continue;
            }
            let hw = half[k];
            for &(a, b) in &rows[sy as usize] {
                let lo = (a as isize - hw).max(0) as usize;
                let hi = ((b as isize + hw) as usize).min(w - 1);
                line[lo..=hi].fill(true);
            }
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Row by row, every pixel gets the class the per-pixel definition gives it: a trefoil knot
    /// (passing in front of itself), a bumpy sphere (suggestive contours) and an open sheet seen
    /// from below, both lenses, both line modes.
    #[test]
    fn row_seeds_are_the_per_pixel_seeds() {
        use super::super::camera::{Orbit, RenderSize, Up};
        use super::super::{curvature, shade, shapes, visibility};
        let sphere = shapes::displaced_sphere(12);
        let sheet = shapes::height_field(8, |x, z| 0.3 * x * z);
        let knot = shapes::trefoil();
        let mut seen = [0usize; 3];
        for (m, el, ortho) in [
            (&knot, 20.0, false),
            (&sphere, 20.0, false),
            (&sphere, 20.0, true),
            (&sheet, -40.0, false),
            (&sheet, 35.0, true),
        ] {
            let (c, r) = m.bounding_sphere();
            let orbit = Orbit {
                azimuth_deg: 20.0,
                elevation_deg: el,
                up: Up::Y,
                distance: 2.0,
                orthographic: ortho,
            };
            let cam = Camera::frame(c, r, &orbit, RenderSize::LongSide(120), &m.positions);
            let normals = m.vertex_normals();
            let curv = curvature::estimate(m, &normals);
            let view = curvature::view_dependent(m, &normals, &curv, |p| cam.view_dir(p), r);
            let vb = visibility::rasterize(m, &cam, m.is_closed());
            let (frags, surf) = shade::geometry(m, &normals, &vb, &cam, Some(&view));
            let (w, h) = (vb.width as usize, vb.height as usize);
            let us = cam.column_xs();
            for mode in [LineMode::Silhouette, LineMode::Suggestive] {
                let p = LineParams {
                    mode,
                    width_px: 3.0,
                    contour_threshold: 0.0,
                    max_ndotv: 20f32.to_radians().cos(),
                    min_run_px: 1,
                    depth_tolerance: 0.02 * r,
                };
                for y in 0..h {
                    let at = |y: usize| Row::of((&frags, &surf), w, y);
                    let rows = [
                        y.checked_sub(1).map(at),
                        Some(at(y)),
                        (y + 1 < h).then(|| at(y + 1)),
                    ];
                    let v = cam.row_y(y);
                    for x in surf.span(y) {
                        let want = seed(m, &cam, &vb, (&frags, &surf), &p, (x, y), (us[x], v));
                        let got = seed_in(m, &cam, &vb, &rows, &p, (x, y), (us[x], v));
                        assert_eq!(got, want, "{ortho} {mode:?} at {x},{y}");
                        seen[want as usize] += 1;
                    }
                }
            }
        }
        assert!(seen.iter().all(|&n| n > 50), "every class met: {seen:?}");
    }

    #[test]
    fn short_runs_go_long_runs_stay() {
        let (w, h) = (20, 5);
        let mut s = vec![0u8; w * h];
        s[w + 2] = SUGGESTIVE; // a lone dot
        for x in 5..15 {
            s[3 * w + x] = SUGGESTIVE; // a run of 10
        }
        s[0] = SILHOUETTE; // silhouettes are never trimmed
        drop_short_runs(&mut s, w, h, 5);
        assert_eq!(s[w + 2], 0);
        assert_eq!(s.iter().filter(|&&v| v == SUGGESTIVE).count(), 10);
        assert_eq!(s[0], SILHOUETTE);
    }

    /// Filled run by run, the thickened mask is the union of every seed's disc, filled seed by
    /// seed: random seeds, runs along rows and at both edges, several widths.
    #[test]
    fn thickening_by_runs_is_thickening_each_seed() {
        let mut rng = crate::test_rng::Lcg(29);
        let (w, h) = (53, 31);
        let mut s = vec![0u8; w * h];
        for (i, v) in s.iter_mut().enumerate() {
            let (x, y) = (i % w, i / w);
            let run = y % 7 == 3 && !(20..=40).contains(&x);
            *v = if run || rng.below(9) == 0 {
                SILHOUETTE
            } else {
                0
            };
        }
        for width in [0.5f32, 1.0, 2.5, 4.0, 7.3] {
            let r = (width * 0.5).max(0.5);
            let ri = r.floor() as isize;
            let mut want = vec![false; w * h];
            for (i, _) in s.iter().enumerate().filter(|(_, &v)| v != 0) {
                let (x, y) = ((i % w) as isize, (i / w) as isize);
                for dy in -ri..=ri {
                    let hw = ((r * r - (dy * dy) as f32).max(0.0)).sqrt().floor() as isize;
                    for dx in -hw..=hw {
                        let (nx, ny) = (x + dx, y + dy);
                        if nx >= 0 && ny >= 0 && nx < w as isize && ny < h as isize {
                            want[ny as usize * w + nx as usize] = true;
                        }
                    }
                }
            }
            assert_eq!(thicken(&s, w, h, width), want, "width {width}");
        }
    }

    #[test]
    fn thickening_makes_a_line_of_the_requested_width() {
        let (w, h) = (30, 30);
        let mut s = vec![0u8; w * h];
        for x in 0..w {
            s[15 * w + x] = SILHOUETTE;
        }
        for width in [1.0f32, 3.0, 5.0] {
            let m = thicken(&s, w, h, width);
            let col: usize = (0..h).filter(|&y| m[y * w + 10]).count();
            assert_eq!(col, width as usize, "width {width}");
        }
    }
}
