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
        for x in surf.span(y) {
            row[x] = seed(mesh, cam, vb, (frags, surf), p, (x, y), (us[x], v));
        }
    });
    if p.mode == LineMode::Suggestive && p.min_run_px > 1 {
        drop_short_runs(&mut seeds, w, h, p.min_run_px);
    }
    thicken(&seeds, w, h, p.width_px)
}

/// Classify one pixel, (`u`, `v`) its centre on the image plane (see `Camera::ray_at`).
#[inline]
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
    let rows: Vec<Vec<usize>> = seeds
        .par_chunks(w)
        .map(|row| {
            row.iter()
                .enumerate()
                .filter(|(_, &s)| s != 0)
                .map(|(x, _)| x)
                .collect()
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
            for &x in &rows[sy as usize] {
                let lo = (x as isize - hw).max(0) as usize;
                let hi = ((x as isize + hw) as usize).min(w - 1);
                line[lo..=hi].fill(true);
            }
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

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
