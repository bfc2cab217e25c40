//! Per-pixel shading: a point light close to the model, Lambert diffuse plus a Blinn-Phong
//! highlight. Each visible pixel's ray is intersected with its triangle, so the barycentric
//! weights (and everything interpolated with them: normal, κr, D_w κr) are perspective-correct.

use std::ops::Range;

use glam::Vec3;
use rayon::prelude::*;

use super::camera::Camera;
use super::curvature::ViewCurvature;
use super::load::Mesh;
use super::visibility::{VisBuffer, NONE};

/// The light and the material's highlight.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Light {
    /// World position of the point light (the key light).
    pub(crate) position: Vec3,
    /// Weight of the Blinn-Phong highlight (0 = matte).
    pub specular: f32,
    /// Blinn-Phong exponent: larger = smaller, sharper highlight.
    pub shininess: f32,
    /// Light that comes from everywhere, 0..1: a surface facing away from every light shows this
    /// much, and the key and fill share the rest (0 = none, the default: only direct light).
    pub ambient: f32,
    /// A second, diffuse-only light (no highlight) and its strength relative to the key: a
    /// photographer's fill, which lifts the side the key leaves dark.
    pub fill: Option<(Vec3, f32)>,
}

/// What the tests read of a pixel's fragment (see [`geometry`]).
#[cfg(test)]
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Fragment {
    /// Camera-space depth; `f32::INFINITY` where no model is seen.
    pub(crate) depth: f32,
    /// Cosine between the shading normal and the direction to the viewer.
    pub(crate) ndotv: f32,
}

#[cfg(test)]
impl Fragment {
    pub(crate) fn is_model(&self) -> bool {
        self.depth.is_finite()
    }
}

/// Shade every visible pixel: [`geometry`] then [`light`] (the intensities are kept apart from
/// the surfaces, so one raster serves many lights).
#[cfg(test)]
pub(crate) fn shade(
    mesh: &Mesh,
    normals: &[Vec3],
    vb: &VisBuffer,
    cam: &Camera,
    light: &Light,
    view: Option<&ViewCurvature>,
) -> (Vec<Fragment>, Vec<f32>) {
    let (frags, surf) = geometry(mesh, normals, vb, cam, view);
    let lit = self::light(&surf, cam, light);
    let background = Fragment {
        depth: f32::INFINITY,
        ..Default::default()
    };
    let w = vb.width as usize;
    let frags = (0..surf.model.len())
        .map(|i| match surf.model[i] {
            true => {
                let [depth, _, _, ndotv] = frags[surf.kept(i % w, i / w)];
                Fragment { depth, ndotv }
            }
            false => background,
        })
        .collect();
    (frags, lit)
}

/// Each visible pixel's surface: what the lines read (its camera-space depth, its interpolated
/// κr and D_w κr, signed as seen, and the cosine between normal and view, at [`Surfaces::kept`];
/// zeros where `Surfaces::model` says no model is seen), and where its ray meets its triangle and
/// the normal there (the [`Surfaces`] lighting reads). `normals` are the smooth vertex normals
/// (used unless the mesh has per-corner normals from its file); `view` adds κr and D_w κr when
/// suggestive contours are wanted. Independent of the light.
pub(crate) fn geometry(
    mesh: &Mesh,
    normals: &[Vec3],
    vb: &VisBuffer,
    cam: &Camera,
    view: Option<&ViewCurvature>,
) -> (Vec<[f32; 4]>, Surfaces) {
    let w = (vb.width as usize).max(1);
    let n = vb.tri.len();
    let shader = Shader {
        mesh,
        normals,
        cam,
        view,
        setup: (!cam.orthographic).then(|| ray_setup(mesh, cam)),
    };
    // Each row's surfaces from its first seen triangle to its last (see `Surfaces::rows`).
    let mut at = 0;
    let rows: Vec<[usize; 3]> = (vb.tri.chunks(w))
        .map(|tri| {
            let a = tri.iter().position(|&t| t != NONE).unwrap_or(w);
            let b = w - tri.iter().rev().position(|&t| t != NONE).unwrap_or(0);
            at += 6 * (b - a);
            [at - 6 * (b - a), a, b]
        })
        .collect();
    // One pass writes all three, rows in parallel; fragments and planes for each row's span only.
    let (mut frags, mut planes, mut model) =
        (vec![[0f32; 4]; at / 6], vec![0f32; at], vec![false; n]);
    let (mut rest, mut frags_rest) = (&mut planes[..], &mut frags[..]);
    let row_spans: Vec<(&mut [f32], &mut [[f32; 4]])> = (rows.iter())
        .map(|&[_, a, b]| {
            let (row, tail) = std::mem::take(&mut rest).split_at_mut(6 * (b - a));
            let (fr, frags_tail) = std::mem::take(&mut frags_rest).split_at_mut(b - a);
            (rest, frags_rest) = (tail, frags_tail);
            (row, fr)
        })
        .collect();
    let us = cam.column_xs();
    model
        .par_chunks_mut(w)
        .zip(row_spans)
        .zip(vb.tri.par_chunks(w))
        .enumerate()
        .for_each_init(Vec::new, |sign, (y, ((model, (planes, fr)), tri))| {
            let (a, n, v) = (rows[y][1], fr.len(), cam.row_y(y));
            sign.clear();
            sign.resize(n, 0.0);
            for (x, &t) in tri.iter().enumerate().skip(a).take(n) {
                if t != NONE {
                    let (f, p, nrm, s) = shader.surface(t, cam.ray_at(us[x], v));
                    for (c, v) in [p.x, p.y, p.z, nrm.x, nrm.y, nrm.z].into_iter().enumerate() {
                        planes[c * n + x - a] = v;
                    }
                    (fr[x - a], model[x], sign[x - a]) = (f, f[0].is_finite(), s);
                }
            }
            shader.face(planes, sign, fr);
        });
    (
        frags,
        Surfaces {
            rows,
            planes,
            model,
        },
    )
}

/// The intensity of every sample under `light` (1 where no model is seen), one by one: a pass
/// over the kept surfaces, no ray, no raster. (The renderer lights and averages in one pass,
/// `super::light`; this whole-image form is for the tests.)
#[cfg(test)]
pub(crate) fn light(surf: &Surfaces, cam: &Camera, light: &Light) -> Vec<f32> {
    let lighter = Lighter::new(cam, light);
    (0..surf.model.len())
        .map(|i| match surf.model[i] {
            true => {
                let (p, n) = surf.point_normal(i);
                lighter.intensity(p, n)
            }
            false => 1.0,
        })
        .collect()
}

/// A light and a camera, with what every pixel's intensity shares worked out once.
pub(crate) struct Lighter<'a> {
    light: &'a Light,
    /// The camera's eye, and the direction to the viewer when the lens is orthographic.
    eye: Vec3,
    ortho_view: Option<Vec3>,
    spec_cut: f32,
}

impl<'a> Lighter<'a> {
    pub(crate) fn new(cam: &Camera, light: &'a Light) -> Self {
        Lighter {
            light,
            eye: cam.eye,
            ortho_view: cam.orthographic.then_some(-cam.forward),
            spec_cut: specular_cutoff(light),
        }
    }

    /// Lambert from the key (and the fill), lifted by the ambient share, plus the key's Blinn-Phong
    /// highlight; at most 1. `p` is the surface point, `n` its unit normal on the side seen. The
    /// definition, one sample at a time; the renderer lights rows with [`Lighter::row`].
    #[cfg(test)]
    pub(crate) fn intensity(&self, p: Vec3, n: Vec3) -> f32 {
        let light = self.light;
        let v = match self.ortho_view {
            Some(v) => v,
            None => (self.eye - p).normalize_or_zero(),
        };
        let l = (light.position - p).normalize_or_zero();
        let ndl = n.dot(l);
        let mut i = ndl.max(0.0);
        if let Some((fp, strength)) = light.fill {
            i += strength * n.dot((fp - p).normalize_or_zero()).max(0.0);
        }
        if light.ambient > 0.0 {
            i = light.ambient + (1.0 - light.ambient) * i;
        }
        if ndl > 0.0 {
            let ndh = n.dot((l + v).normalize_or_zero());
            if ndh > self.spec_cut {
                i += light.specular * ndh.powf(light.shininess);
            }
        }
        i.min(1.0)
    }
}

/// What lighting reads of a view's working samples, kept apart from the fragments the lines
/// read: per working row, six planes of its samples from its first seen triangle to its last
/// (the surface point's x, y, z, then the normal's), and which samples show the model. A light
/// change reads only these, as straight runs of floats the compiler turns into vector code.
#[derive(Clone, Debug, Default)]
pub struct Surfaces {
    /// Row `y`'s `[start, a, b]`: its planes are `planes[start..][..6 * (b - a)]`, of samples
    /// `a..b` (none where no triangle is seen: a view's background is most of its samples).
    rows: Vec<[usize; 3]>,
    planes: Vec<f32>,
    /// The samples that show the model (a finite depth).
    pub model: Vec<bool>,
}

impl Surfaces {
    /// A `width`-wide image of samples (point, normal, shows the model), row by row.
    #[cfg(test)]
    pub(crate) fn of(samples: &[(Vec3, Vec3, bool)], width: usize) -> Surfaces {
        let mut planes = vec![0f32; 6 * samples.len()];
        for (i, (p, n, _)) in samples.iter().enumerate() {
            let (y, x) = (i / width, i % width);
            for (c, v) in [p.x, p.y, p.z, n.x, n.y, n.z].into_iter().enumerate() {
                planes[6 * width * y + c * width + x] = v;
            }
        }
        let model = samples.iter().map(|s| s.2).collect();
        let rows = (0..samples.len() / width)
            .map(|y| [6 * width * y, 0, width])
            .collect();
        Surfaces {
            rows,
            planes,
            model,
        }
    }

    /// Sample `i`'s point and normal.
    #[cfg(test)]
    pub(crate) fn point_normal(&self, i: usize) -> (Vec3, Vec3) {
        let width = self.model.len() / self.rows.len();
        let (y, x) = (i / width, i % width);
        let (xs, r) = self.row(y);
        if !xs.contains(&x) {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        let x = x - xs.start;
        (
            Vec3::new(r[0][x], r[1][x], r[2][x]),
            Vec3::new(r[3][x], r[4][x], r[5][x]),
        )
    }

    /// Where sample (`x`, `y`), which shows the model, is among the samples kept (each row's span).
    #[inline]
    pub(crate) fn kept(&self, x: usize, y: usize) -> usize {
        let [start, a, _] = self.rows[y];
        start / 6 + x - a
    }

    /// Working row `y`'s span: the samples kept.
    pub(crate) fn span(&self, y: usize) -> Range<usize> {
        self.rows[y][1]..self.rows[y][2]
    }

    /// Working row `y`'s samples kept, and their six planes (point x, y, z, normal x, y, z).
    fn row(&self, y: usize) -> (Range<usize>, [&[f32]; 6]) {
        let [start, a, b] = self.rows[y];
        let r = &self.planes[start..start + 6 * (b - a)];
        (
            a..b,
            std::array::from_fn(|c| &r[c * (b - a)..(c + 1) * (b - a)]),
        )
    }
}

/// `v` made unit length, or zero when it has none: glam's `normalize_or_zero` on its three
/// components, operation for operation (the same bits), without a branch.
#[inline(always)]
fn unit(x: f32, y: f32, z: f32) -> (f32, f32, f32) {
    let r = 1.0 / ((x * x) + (y * y) + (z * z)).sqrt();
    let ok = r.is_finite() && r > 0.0;
    (
        if ok { x * r } else { 0.0 },
        if ok { y * r } else { 0.0 },
        if ok { z * r } else { 0.0 },
    )
}

impl Lighter<'_> {
    /// The intensity of the samples `s` keeps of working row `y` into `out` (the others, and
    /// the background's, are left or meaningless), `ndh` a scratch row: Lambert from the key (and the fill),
    /// lifted by the ambient share, plus the key's Blinn-Phong highlight, at most 1. Two passes:
    /// every term but the highlight's power as straight-line float code over the row (vector
    /// code, no branch), then the power (a `powf`, which has no vector form) only where the
    /// highlight shows. The operations are those of the one-sample definition (`intensity`, kept
    /// for the tests), in its order: the same bits.
    pub(crate) fn row(&self, s: &Surfaces, y: usize, out: &mut [f32], ndh: &mut [f32]) {
        let (xs, row) = s.row(y);
        let (out, ndh) = (&mut out[xs.clone()], &mut ndh[xs]);
        let e = self.eye;
        let persp = |x: f32, y: f32, z: f32| unit(e.x - x, e.y - y, e.z - z);
        let key = |_: [f32; 6], i: f32| i;
        let (fp, strength) = self.light.fill.unwrap_or_default();
        let fill = |[x, y, z, a, b, c]: [f32; 6], i: f32| {
            let (fx, fy, fz) = unit(fp.x - x, fp.y - y, fp.z - z);
            i + strength * ((a * fx) + (b * fy) + (c * fz)).max(0.0)
        };
        // One loop for each lens and whether there is a fill, so none tests it per sample.
        match (self.ortho_view, self.light.fill.is_some()) {
            (Some(v), false) => self.terms(row, out, ndh, |_, _, _| (v.x, v.y, v.z), key),
            (Some(v), true) => self.terms(row, out, ndh, |_, _, _| (v.x, v.y, v.z), fill),
            (None, false) => self.terms(row, out, ndh, persp, key),
            (None, true) => self.terms(row, out, ndh, persp, fill),
        }
        let (spec, shine) = (self.light.specular, self.light.shininess);
        for (o, &h) in out.iter_mut().zip(ndh.iter()) {
            if h > 0.0 {
                *o += spec * h.powf(shine);
            }
            *o = o.min(1.0);
        }
    }

    /// The first pass of [`Lighter::row`]: each sample's diffuse terms (`fill` adds the fill's
    /// to the key's, given the sample's point and normal), the ambient lift, and the highlight's
    /// n·h where it shows (0 elsewhere; where it shows it is above the cut-off, which is > 0).
    #[inline(always)]
    fn terms(
        &self,
        [px, py, pz, nx, ny, nz]: [&[f32]; 6],
        out: &mut [f32],
        ndh: &mut [f32],
        view: impl Fn(f32, f32, f32) -> (f32, f32, f32),
        fill: impl Fn([f32; 6], f32) -> f32,
    ) {
        let n = px.len();
        let (out, ndh) = (&mut out[..n], &mut ndh[..n]);
        let (py, pz, nx, ny, nz) = (&py[..n], &pz[..n], &nx[..n], &ny[..n], &nz[..n]);
        let lp = self.light.position;
        let ambient = self.light.ambient;
        let cut = self.spec_cut;
        for j in 0..n {
            let (x, y, z) = (px[j], py[j], pz[j]);
            let (a, b, c) = (nx[j], ny[j], nz[j]);
            let (vx, vy, vz) = view(x, y, z);
            let (lx, ly, lz) = unit(lp.x - x, lp.y - y, lp.z - z);
            let ndl = (a * lx) + (b * ly) + (c * lz);
            let i = fill([x, y, z, a, b, c], ndl.max(0.0));
            let lifted = ambient + (1.0 - ambient) * i;
            out[j] = if ambient > 0.0 { lifted } else { i };
            let (hx, hy, hz) = unit(lx + vx, ly + vy, lz + vz);
            let h = (a * hx) + (b * hy) + (c * hz);
            ndh[j] = if ndl > 0.0 && h > cut { h } else { 0.0 };
        }
    }
}

/// Below this n·h the highlight is under 1/1024: the pow is skipped.
fn specular_cutoff(light: &Light) -> f32 {
    if light.specular > 0.0 {
        (1.0f32 / 1024.0 / light.specular).powf(1.0 / light.shininess.max(1e-3))
    } else {
        f32::INFINITY
    }
}

/// A perspective camera's rays share their origin, so most of Möller–Trumbore is per triangle.
fn ray_setup(mesh: &Mesh, cam: &Camera) -> Vec<TriSetup> {
    mesh.triangles
        .par_iter()
        .map(|t| {
            let [p0, p1, p2] = t.map(|i| mesh.positions[i as usize]);
            let (e1, e2) = (p1 - p0, p2 - p0);
            let tv = cam.eye - p0;
            let v = tv.cross(e1);
            TriSetup {
                u: e2.cross(tv),
                v,
                d: e2.cross(e1),
                c: e2.dot(v),
            }
        })
        .collect()
}

/// What [`shade`] reads for every pixel.
struct Shader<'a> {
    mesh: &'a Mesh,
    normals: &'a [Vec3],
    cam: &'a Camera,
    view: Option<&'a ViewCurvature>,
    /// Per-triangle ray constants (perspective cameras only).
    setup: Option<Vec<TriSetup>>,
}

impl Shader<'_> {
    /// Triangle `t` where the ray (`o`, `d`) meets it: the fragment (see [`geometry`]) but its n·v,
    /// the point, the normal interpolated (not unit) and the side seen (-1 back, 1 front).
    #[inline]
    fn surface(&self, t: u32, (o, d): (Vec3, Vec3)) -> ([f32; 4], Vec3, Vec3, f32) {
        let (mesh, cam) = (self.mesh, self.cam);
        let idx = mesh.triangles[t as usize];
        let [p0, p1, p2] = idx.map(|i| mesh.positions[i as usize]);
        let (b1, b2, depth, back) = match &self.setup {
            Some(setup) => {
                // Möller–Trumbore with the pixel-independent parts folded per triangle.
                let s = &setup[t as usize];
                let det = d.dot(s.d);
                if det.abs() > 1e-20 {
                    let inv = 1.0 / det;
                    (d.dot(s.u) * inv, d.dot(s.v) * inv, s.c * inv, det < 0.0)
                } else {
                    let c = (p0 + p1 + p2) / 3.0;
                    (1.0 / 3.0, 1.0 / 3.0, (c - cam.eye).dot(cam.forward), false)
                }
            }
            None => moller_trumbore(o, d, p0, p1, p2, cam),
        };
        // Pixel centres a hair outside the triangle (the raster's tolerance): clamp.
        let b1 = b1.clamp(0.0, 1.0);
        let b2 = b2.clamp(0.0, 1.0 - b1);
        let b0 = 1.0 - b1 - b2;
        let p = p0 * b0 + p1 * b1 + p2 * b2;
        let cn = match &mesh.corner_normals {
            Some(cn) => cn[t as usize],
            None => idx.map(|i| self.normals[i as usize]),
        };
        // The side we see: on open surfaces the back is visible and lit as a front.
        let sign = if back { -1.0 } else { 1.0 };
        let (kr, dwkr) = match self.view {
            Some(vc) => {
                let k = idx.map(|i| vc.kr[i as usize]);
                let dk = idx.map(|i| vc.dwkr[i as usize]);
                (
                    sign * (k[0] * b0 + k[1] * b1 + k[2] * b2),
                    sign * (dk[0] * b0 + dk[1] * b1 + dk[2] * b2),
                )
            }
            None => (0.0, 0.0),
        };
        let n = cn[0] * b0 + cn[1] * b1 + cn[2] * b2;
        ([depth.max(0.0), kr, dwkr, 0.0], p, n, sign)
    }

    /// A row's [`Shader::surface`]s finished in straight-line (vector) code: normals made unit and
    /// turned to the side seen (`sign`, 0: no triangle), n·v; glam's operations in their order.
    fn face(&self, planes: &mut [f32], sign: &mut [f32], fr: &mut [[f32; 4]]) {
        let cam = self.cam;
        let (e, f) = (cam.eye, -cam.forward);
        let ortho = |_: f32, _: f32, _: f32| (f.x, f.y, f.z);
        let persp = |x: f32, y: f32, z: f32| unit(e.x - x, e.y - y, e.z - z);
        match cam.orthographic {
            true => faces(planes, sign, ortho),
            false => faces(planes, sign, persp),
        }
        for (f, &d) in fr.iter_mut().zip(sign.iter()) {
            f[3] = d;
        }
    }
}

/// [`Shader::face`] for one lens (`view`: the unit direction to the viewer): n·v into `sign`.
#[inline(always)]
fn faces(planes: &mut [f32], sign: &mut [f32], view: impl Fn(f32, f32, f32) -> (f32, f32, f32)) {
    let (n, mut planes) = (sign.len(), planes.chunks_mut(sign.len().max(1)));
    let [px, py, pz, nx, ny, nz] = std::array::from_fn(|_| planes.next().unwrap_or_default());
    for i in 0..n {
        let s = sign[i];
        let (x, y, z) = unit(nx[i], ny[i], nz[i]);
        let (x, y, z) = (x * s, y * s, z * s);
        let (vx, vy, vz) = view(px[i], py[i], pz[i]);
        (nx[i], ny[i], nz[i]) = (x, y, z);
        sign[i] = if s != 0.0 {
            (x * vx) + (y * vy) + (z * vz)
        } else {
            0.0
        };
    }
}

#[cfg(test)]
impl Shader<'_> {
    /// The fragment of triangle `t` seen through the pixel centre (`sx`, `sy`) (see
    /// [`geometry`]), the surface point there and the normal of the side seen (world, unit).
    #[inline]
    fn fragment(&self, t: u32, sx: f32, sy: f32) -> ([f32; 4], Vec3, Vec3) {
        let (mesh, cam) = (self.mesh, self.cam);
        let idx = mesh.triangles[t as usize];
        let [p0, p1, p2] = idx.map(|i| mesh.positions[i as usize]);
        let (o, d) = cam.ray(sx, sy);
        let (b1, b2, depth, back) = match &self.setup {
            Some(setup) => {
                // Möller–Trumbore with the pixel-independent parts folded per triangle.
                let s = &setup[t as usize];
                let det = d.dot(s.d);
                if det.abs() > 1e-20 {
                    let inv = 1.0 / det;
                    (d.dot(s.u) * inv, d.dot(s.v) * inv, s.c * inv, det < 0.0)
                } else {
                    let c = (p0 + p1 + p2) / 3.0;
                    (1.0 / 3.0, 1.0 / 3.0, (c - cam.eye).dot(cam.forward), false)
                }
            }
            None => moller_trumbore(o, d, p0, p1, p2, cam),
        };
        // Pixel centres a hair outside the triangle (the raster's tolerance): clamp.
        let b1 = b1.clamp(0.0, 1.0);
        let b2 = b2.clamp(0.0, 1.0 - b1);
        let b0 = 1.0 - b1 - b2;
        let p = p0 * b0 + p1 * b1 + p2 * b2;
        let cn = match &mesh.corner_normals {
            Some(cn) => cn[t as usize],
            None => idx.map(|i| self.normals[i as usize]),
        };
        let mut n = (cn[0] * b0 + cn[1] * b1 + cn[2] * b2).normalize_or_zero();
        // The side we see: on open surfaces the back is visible and lit as a front.
        let sign = if back { -1.0 } else { 1.0 };
        n *= sign;
        let v = if cam.orthographic {
            -cam.forward
        } else {
            (cam.eye - p).normalize_or_zero()
        };
        let (kr, dwkr) = match self.view {
            Some(vc) => {
                let k = idx.map(|i| vc.kr[i as usize]);
                let dk = idx.map(|i| vc.dwkr[i as usize]);
                (
                    sign * (k[0] * b0 + k[1] * b1 + k[2] * b2),
                    sign * (dk[0] * b0 + dk[1] * b1 + dk[2] * b2),
                )
            }
            None => (0.0, 0.0),
        };
        ([depth.max(0.0), kr, dwkr, n.dot(v)], p, n)
    }
}

/// Per-triangle constants of Möller–Trumbore for rays from one origin: for a ray direction d,
/// det = d·D, u = d·U / det, v = d·V / det, t = c / det.
struct TriSetup {
    u: Vec3,
    v: Vec3,
    d: Vec3,
    c: f32,
}

/// Ray-triangle intersection: barycentric weights of p1 and p2, the ray parameter (the depth, as
/// `d · forward = 1`) and whether the triangle's back faces the ray.
#[inline]
fn moller_trumbore(
    o: Vec3,
    d: Vec3,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
    cam: &Camera,
) -> (f32, f32, f32, bool) {
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let pvec = d.cross(e2);
    let det = e1.dot(pvec);
    if det.abs() > 1e-20 {
        let inv = 1.0 / det;
        let tv = o - p0;
        let qv = tv.cross(e1);
        (
            tv.dot(pvec) * inv,
            d.dot(qv) * inv,
            e2.dot(qv) * inv,
            det < 0.0,
        )
    } else {
        // Seen exactly edge-on: take the centroid.
        let c = (p0 + p1 + p2) / 3.0;
        (1.0 / 3.0, 1.0 / 3.0, (c - cam.eye).dot(cam.forward), false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Lcg;
    use crate::tone::mesh::camera::{Orbit, RenderSize};
    use crate::tone::mesh::{shapes, visibility};

    fn setup(m: &Mesh, el: f32) -> Camera {
        let (c, r) = m.bounding_sphere();
        let o = Orbit {
            azimuth_deg: 20.0,
            elevation_deg: el,
            up: crate::tone::mesh::camera::Up::Y,
            distance: 2.0,
            orthographic: false,
        };
        Camera::frame(c, r, &o, RenderSize::LongSide(120), &m.positions)
    }

    #[test]
    fn interpolation_is_perspective_correct() {
        // A strongly foreshortened plane: each pixel's depth must put its point back on the
        // pixel centre and on the surface (y = 0.3 x).
        let m = shapes::height_field(4, |x, _| 0.3 * x);
        let cam = setup(&m, 35.0);
        let vb = visibility::rasterize(&m, &cam, false);
        let light = Light {
            position: cam.eye,
            specular: 0.0,
            shininess: 1.0,
            ambient: 0.0,
            fill: None,
        };
        let (frags, _) = shade(&m, &m.vertex_normals(), &vb, &cam, &light, None);
        let w = cam.width as usize;
        let mut checked = 0;
        for (i, f) in frags.iter().enumerate().filter(|(_, f)| f.is_model()) {
            let (sx, sy) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
            let (o, d) = cam.ray(sx, sy);
            let p = o + d * f.depth;
            let back = cam.project(p);
            assert!((back.x - sx).abs() < 1e-2 && (back.y - sy).abs() < 1e-2);
            if p.x.abs() < 0.98 && p.z.abs() < 0.98 {
                assert!((p.y - 0.3 * p.x).abs() < 1e-3, "{p}");
                checked += 1;
            }
        }
        assert!(checked > 1000);
    }

    #[test]
    fn open_surfaces_are_lit_on_the_side_seen() {
        // A flat sheet seen from below, lit from below: the visible side faces the light.
        let m = shapes::height_field(8, |_, _| 0.0);
        let cam = setup(&m, -40.0);
        let vb = visibility::rasterize(&m, &cam, false);
        let light = Light {
            position: Vec3::new(0.0, -2.0, 0.0),
            specular: 0.0,
            shininess: 1.0,
            ambient: 0.0,
            fill: None,
        };
        let (frags, shades) = shade(&m, &m.vertex_normals(), &vb, &cam, &light, None);
        let lit: Vec<f32> = frags
            .iter()
            .zip(&shades)
            .filter(|(f, _)| f.is_model())
            .map(|(_, &s)| s)
            .collect();
        assert!(lit.len() > 1000);
        assert!(
            lit.iter().all(|&s| s > 0.3),
            "min {:?}",
            lit.iter().cloned().fold(1.0, f32::min)
        );
        assert!(frags.iter().filter(|f| f.is_model()).all(|f| f.ndotv > 0.0));
    }

    /// The row-at-a-time geometry against the per-sample fragment on both lenses: an open sheet
    /// seen from below (its back faces, the file's corner normals) and a bumpy sphere with its
    /// curvature: the same bits.
    #[test]
    fn row_geometry_is_the_per_sample_fragment_to_the_bit() {
        let mut sheet = shapes::height_field(8, |x, z| 0.3 * x * z);
        let corners = (sheet.triangles.iter())
            .map(|t| {
                let [a, b, c] = t.map(|v| sheet.positions[v as usize]);
                [(b - a).cross(c - a).normalize(); 3]
            })
            .collect();
        sheet.corner_normals = Some(corners);
        let sphere = shapes::displaced_sphere(12);
        for (m, el, ortho) in [
            (&sheet, -40.0, false),
            (&sheet, -40.0, true),
            (&sphere, 20.0, false),
            (&sphere, 20.0, true),
        ] {
            let mut cam = setup(m, el);
            cam.orthographic = ortho;
            let normals = m.vertex_normals();
            let c = super::super::curvature::estimate(m, &normals);
            let radius = m.bounding_sphere().1;
            let view = super::super::curvature::view_dependent(
                m,
                &normals,
                &c,
                |p| cam.view_dir(p),
                radius,
            );
            let vb = visibility::rasterize(m, &cam, false);
            let (frags, surf) = geometry(m, &normals, &vb, &cam, Some(&view));
            let shader = Shader {
                mesh: m,
                normals: &normals,
                cam: &cam,
                view: Some(&view),
                setup: (!ortho).then(|| ray_setup(m, &cam)),
            };
            let (w, mut seen) = (cam.width as usize, 0);
            for (i, &t) in vb.tri.iter().enumerate().filter(|(_, &t)| t != NONE) {
                let (x, y) = (i % w, i / w);
                let (f, p, n) = shader.fragment(t, x as f32 + 0.5, y as f32 + 0.5);
                let bits = |v: &[f32]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(
                    bits(&f),
                    bits(&frags[surf.kept(x, y)]),
                    "{ortho} at {x},{y}"
                );
                let (sp, sn) = surf.point_normal(i);
                assert_eq!(
                    bits(&[p, n].map(|v| v.to_array()).concat()),
                    bits(&[sp, sn].map(|v| v.to_array()).concat())
                );
                assert_eq!(surf.model[i], f[0].is_finite());
                seen += 1;
            }
            assert!(seen > 1000, "{seen}");
        }
    }

    /// The row lighter against the per-sample one on random surfaces, lights and lenses,
    /// with the awkward cases among them (a point on the light, a point at the eye, a zero
    /// normal, background samples): the same bits.
    #[test]
    fn row_lighting_is_the_per_sample_lighting_to_the_bit() {
        let mut rng = Lcg(12345);
        let mut next = || (rng.next_u64() >> 40) as f32 / (1 << 24) as f32 * 2.0 - 1.0;
        let m = shapes::height_field(4, |_, _| 0.0);
        for trial in 0..24 {
            let mut cam = setup(&m, 20.0);
            cam.orthographic = trial % 3 == 0;
            let key = Vec3::new(next(), next(), next()) * 3.0;
            let light = Light {
                position: key,
                specular: [0.0, 0.3, 2.0, 9.5][trial % 4],
                shininess: [1.0, 32.0, 7.5][trial % 3],
                ambient: if trial % 2 == 0 {
                    0.0
                } else {
                    next().abs() * 0.9
                },
                fill: (trial % 5 < 2).then(|| (Vec3::new(next(), next(), next()) * 3.0, 0.6)),
            };
            let w = 37;
            let frags: Vec<(Vec3, Vec3, bool)> = (0..w * 3)
                .map(|i| {
                    let point = match i {
                        0 => key,
                        1 => cam.eye,
                        _ => Vec3::new(next(), next(), next()),
                    };
                    let normal = match i {
                        2 => Vec3::ZERO,
                        _ => Vec3::new(next(), next(), next()).normalize_or_zero(),
                    };
                    (point, normal, i % 7 != 3)
                })
                .collect();
            let s = Surfaces::of(&frags, w);
            let lighter = Lighter::new(&cam, &light);
            let (mut out, mut ndh) = (vec![0f32; w], vec![0f32; w]);
            for y in 0..3 {
                lighter.row(&s, y, &mut out, &mut ndh);
                for x in 0..w {
                    let (point, normal, model) = frags[y * w + x];
                    assert_eq!(s.model[y * w + x], model);
                    let want = lighter.intensity(point, normal);
                    assert_eq!(out[x].to_bits(), want.to_bits(), "trial {trial} at {x},{y}");
                }
            }
        }
    }
}
