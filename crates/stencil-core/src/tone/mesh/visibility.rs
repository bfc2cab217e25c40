//! The rasteriser: a z-buffered visibility buffer (nearest triangle per pixel), built in parallel
//! over horizontal bands of rows. Shading happens afterwards, once per visible pixel, from the
//! triangle id and the pixel's exact ray (see `shade`), which makes every interpolation
//! perspective-correct without carrying attributes through the raster loop.

use glam::Vec2;
use rayon::prelude::*;

use super::camera::Camera;
use super::load::Mesh;

/// No triangle covers the pixel.
pub(crate) const NONE: u32 = u32::MAX;

/// Rows per band: each band is rasterised by one task from the triangles binned to it.
const BAND: usize = 16;

/// The nearest triangle per pixel.
#[derive(Clone, Debug)]
pub(crate) struct VisBuffer {
    pub width: u32,
    pub height: u32,
    /// Triangle index per pixel, or [`NONE`].
    pub(crate) tri: Vec<u32>,
}

/// Rasterise every triangle into a visibility buffer. `cull_back` skips triangles that face away
/// from the camera (valid for closed meshes, whose back faces are always hidden); otherwise both
/// sides are drawn and the shader lights whichever side is seen.
pub(crate) fn rasterize(mesh: &Mesh, cam: &Camera, cull_back: bool) -> VisBuffer {
    let (w, h) = (cam.width as usize, cam.height as usize);
    // Screen position and depth key per vertex.
    let screen: Vec<(Vec2, f32)> = mesh
        .positions
        .par_iter()
        .map(|&p| {
            let s = cam.project(p);
            let key = if cam.orthographic { -s.z } else { 1.0 / s.z };
            (Vec2::new(s.x, s.y), key)
        })
        .collect();
    // Bin triangles to bands by their row range.
    let nbands = h.div_ceil(BAND);
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); nbands];
    for (i, t) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = t.map(|v| screen[v as usize].0);
        let area2 = (b - a).perp_dot(c - a);
        // y is down: a counter-clockwise (front) face has a negative signed area on screen.
        if area2 == 0.0 || !area2.is_finite() || (cull_back && area2 > 0.0) {
            continue;
        }
        let (ylo, yhi) = (a.y.min(b.y).min(c.y), a.y.max(b.y).max(c.y));
        let (xlo, xhi) = (a.x.min(b.x).min(c.x), a.x.max(b.x).max(c.x));
        if yhi < 0.0 || xhi < 0.0 || ylo > h as f32 || xlo > w as f32 {
            continue;
        }
        let r0 = (ylo - 0.5).ceil().max(0.0) as usize;
        let r1 = ((yhi - 0.5).floor().max(-1.0) as isize).min(h as isize - 1);
        if r1 < r0 as isize {
            continue;
        }
        for band in bins.iter_mut().take(r1 as usize / BAND + 1).skip(r0 / BAND) {
            band.push(i as u32);
        }
    }
    let mut tri = vec![NONE; w * h];
    tri.par_chunks_mut(BAND * w)
        .zip(bins.par_iter())
        .enumerate()
        .for_each_init(Vec::new, |key, (band, (tri, list))| {
            let (y0, rows) = (band * BAND, tri.len() / w);
            // The band's depth keys, reused: larger is nearer (1/z perspective, -z orthographic).
            key.clear();
            key.resize(tri.len(), f32::NEG_INFINITY);
            for &t in list {
                let idx = mesh.triangles[t as usize];
                let [(a, ka), (mut b, mut kb), (mut c, mut kc)] = idx.map(|v| screen[v as usize]);
                if (b - a).perp_dot(c - a) < 0.0 {
                    std::mem::swap(&mut b, &mut c);
                    std::mem::swap(&mut kb, &mut kc);
                }
                raster_triangle(a, b, c, [ka, kb, kc], t, y0, rows, w, tri, key);
            }
        });
    VisBuffer {
        width: cam.width,
        height: cam.height,
        tri,
    }
}

/// Rasterise one triangle (positive signed area, y down) into the band of `rows` rows from `y0`.
#[allow(clippy::too_many_arguments)]
#[inline]
fn raster_triangle(
    a: Vec2,
    b: Vec2,
    c: Vec2,
    k: [f32; 3],
    id: u32,
    y0: usize,
    rows: usize,
    w: usize,
    tri: &mut [u32],
    key: &mut [f32],
) {
    let area2 = (b - a).perp_dot(c - a);
    let inv = 1.0 / area2;
    let xlo = (a.x.min(b.x).min(c.x) - 0.5).ceil().max(0.0) as usize;
    let xhi = ((a.x.max(b.x).max(c.x) - 0.5).floor()).min(w as f32 - 1.0);
    let ylo = ((a.y.min(b.y).min(c.y) - 0.5).ceil().max(y0 as f32)) as usize;
    let yhi = ((a.y.max(b.y).max(c.y) - 0.5).floor()).min((y0 + rows) as f32 - 1.0);
    if xhi < xlo as f32 || yhi < ylo as f32 {
        return;
    }
    let (xhi, yhi) = (xhi as usize, yhi as usize);
    // Edge functions e(p) = (q - p0) x (p1 - p0)-style, positive inside. A pixel centre exactly on
    // a shared edge is taken by both neighbours (the depth test decides), so a tiny tolerance
    // relative to the edge length closes cracks from rounding.
    let edges = [(b, c), (c, a), (a, b)];
    let mut coef = [(0f32, 0f32, 0f32); 3];
    for (i, (p, q)) in edges.iter().enumerate() {
        let d = *q - *p;
        let tol = 1e-4 * d.length();
        // e(x, y) = d.x * (y - p.y) - d.y * (x - p.x), positive inside for our orientation.
        coef[i] = (-d.y, d.x, d.y * p.x - d.x * p.y + tol);
    }
    for y in ylo..=yhi {
        let py = y as f32 + 0.5;
        let row = (y - y0) * w;
        // The row's span inside all three edges (each edge function is linear in x), a pixel wider
        // on each side for rounding; the test per pixel below decides. Without it a long thin
        // triangle (a fan of a many-sided polygon) cost its whole bounding box, quadratic in the
        // polygon's size.
        let (mut lo, mut hi) = (xlo as f32, xhi as f32);
        for &(ex, ey, e0) in &coef {
            let c = ey * py + e0;
            if ex > 0.0 {
                lo = lo.max((-c / ex - 0.5).floor() - 1.0);
            } else if ex < 0.0 {
                hi = hi.min((-c / ex - 0.5).ceil() + 1.0);
            } else if c < 0.0 {
                hi = lo - 1.0;
            }
        }
        if lo.is_nan() || hi.is_nan() || lo > hi {
            continue;
        }
        let (xa, xb) = (lo as usize, hi as usize);
        let px0 = xa as f32 + 0.5;
        let mut e = coef.map(|(ex, ey, e0)| ex * px0 + ey * py + e0);
        for x in xa..=xb {
            if e[0] >= 0.0 && e[1] >= 0.0 && e[2] >= 0.0 {
                // Barycentric weight of a is e[0] (edge bc), of b is e[1], of c is e[2].
                let z = (e[0] * k[0] + e[1] * k[1] + e[2] * k[2]) * inv;
                let i = row + x;
                if z > key[i] {
                    key[i] = z;
                    tri[i] = id;
                }
            }
            e[0] += coef[0].0;
            e[1] += coef[1].0;
            e[2] += coef[2].0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tone::mesh::camera::{Orbit, RenderSize};
    use glam::Vec3;

    fn quad_mesh() -> Mesh {
        // Two triangles forming a square in the z = 0 plane, counter-clockwise seen from +z.
        Mesh::new(
            vec![
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(-1.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    fn cam(az: f32) -> Camera {
        let m = quad_mesh();
        let (c, r) = m.bounding_sphere();
        let o = Orbit {
            azimuth_deg: az,
            elevation_deg: 0.0,
            up: crate::tone::mesh::camera::Up::Y,
            distance: 3.0,
            orthographic: true,
        };
        Camera::frame(
            c,
            r,
            &o,
            RenderSize::Exact {
                width: 100,
                height: 100,
            },
            &m.positions,
        )
    }

    #[test]
    fn square_covers_its_pixels_without_cracks() {
        let m = quad_mesh();
        let vb = rasterize(&m, &cam(0.0), true);
        // The square spans pixels 5..95 (5% margin) in both directions, with no holes on the diagonal.
        for y in 0..100u32 {
            for x in 0..100u32 {
                let inside = (5..95).contains(&x) && (5..95).contains(&y);
                let hit = vb.tri[(y * 100 + x) as usize] != NONE;
                assert_eq!(hit, inside, "pixel {x},{y}");
            }
        }
    }

    #[test]
    fn back_faces_are_culled_only_when_asked() {
        let m = quad_mesh();
        let c = cam(180.0);
        assert!(rasterize(&m, &c, true).tri.iter().all(|&t| t == NONE));
        assert!(
            rasterize(&m, &c, false)
                .tri
                .iter()
                .filter(|&&t| t != NONE)
                .count()
                > 8000
        );
    }

    #[test]
    fn nearer_triangle_wins() {
        // A big far square and a small near one in front of it.
        let mut p = quad_mesh().positions;
        p.extend(
            [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]].map(|[x, y]| Vec3::new(x, y, 0.5)),
        );
        let m = Mesh::new(p, vec![[4, 5, 6], [4, 6, 7], [0, 1, 2], [0, 2, 3]]);
        let (c, r) = m.bounding_sphere();
        let o = Orbit {
            azimuth_deg: 0.0,
            elevation_deg: 0.0,
            up: crate::tone::mesh::camera::Up::Y,
            distance: 4.0,
            orthographic: false,
        };
        let cam = Camera::frame(
            c,
            r,
            &o,
            RenderSize::Exact {
                width: 64,
                height: 64,
            },
            &m.positions,
        );
        let vb = rasterize(&m, &cam, true);
        let mid = vb.tri[32 * 64 + 32];
        assert!(
            mid == 0 || mid == 1,
            "the near square covers the centre, got {mid}"
        );
        assert!(vb.tri[(6 * 64 + 6) as usize] >= 2);
    }
}
