//! Per-vertex curvature (Rusinkiewicz, "Estimating Curvatures and Their Derivatives on Triangle
//! Meshes", 3DPVT 2004): a second fundamental form per face, fitted by least squares to how the
//! vertex normals change along its edges, rotated into each vertex's tangent frame and averaged
//! with area weights. Sign convention: convex (seen from outside along the normal) is positive,
//! so a sphere of radius r has k1 = k2 = 1/r.
//!
//! From the tensor, [`view_dependent`] derives what suggestive contours need for one view: the
//! radial curvature κr and its directional derivative D_w κr (DeCarlo et al. 2003).

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::load::Mesh;

/// The second fundamental form per vertex in an orthonormal tangent frame (`u`, `v`).
#[derive(Clone, Debug)]
pub(crate) struct Curvature {
    pub(crate) u: Vec<Vec3>,
    pub(crate) v: Vec<Vec3>,
    /// Tensor entries [kuu, kuv, kvv] in the frame (u, v).
    pub(crate) tensor: Vec<[f32; 3]>,
}

/// Principal curvatures at one vertex and the direction of the larger (the tests check the
/// tensor by them).
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Principal {
    /// The larger curvature in magnitude.
    pub(crate) k1: f32,
    pub(crate) k2: f32,
    /// The direction of `k1`.
    pub(crate) dir1: Vec3,
}

impl Curvature {
    /// Normal curvature in tangent direction `t` (need not be unit; its normal part is ignored).
    #[inline]
    pub(crate) fn normal_curvature(&self, i: usize, t: Vec3) -> f32 {
        let (a, b) = (t.dot(self.u[i]), t.dot(self.v[i]));
        let len2 = a * a + b * b;
        if len2 <= 0.0 {
            return 0.5 * (self.tensor[i][0] + self.tensor[i][2]);
        }
        let [kuu, kuv, kvv] = self.tensor[i];
        (kuu * a * a + 2.0 * kuv * a * b + kvv * b * b) / len2
    }

    /// Principal curvatures at vertex `i` and the direction of the larger (eigen-decomposition of
    /// the 2×2 tensor).
    #[cfg(test)]
    pub(crate) fn principal(&self, i: usize) -> Principal {
        let [ku, kuv, kv] = self.tensor[i];
        let (mut c, mut s, mut tt) = (1.0f32, 0.0f32, 0.0f32);
        if kuv != 0.0 {
            // One Jacobi rotation diagonalises a symmetric 2×2 matrix.
            let h = 0.5 * (kv - ku) / kuv;
            tt = if h < 0.0 {
                1.0 / (h - (1.0 + h * h).sqrt())
            } else {
                1.0 / (h + (1.0 + h * h).sqrt())
            };
            c = 1.0 / (1.0 + tt * tt).sqrt();
            s = tt * c;
        }
        let (mut k1, mut k2) = (ku - tt * kuv, kv + tt * kuv);
        let (u, v) = (self.u[i], self.v[i]);
        let mut dir1 = u * c - v * s;
        if k1.abs() < k2.abs() {
            std::mem::swap(&mut k1, &mut k2);
            dir1 = u * s + v * c;
        }
        Principal { k1, k2, dir1 }
    }
}

/// Estimate the curvature tensor at every vertex from smooth vertex `normals`.
pub(crate) fn estimate(mesh: &Mesh, normals: &[Vec3]) -> Curvature {
    let p = &mesh.positions;
    let nv = p.len();
    // An initial tangent frame per vertex: any edge, made perpendicular to the normal.
    let mut u = vec![Vec3::ZERO; nv];
    for t in &mesh.triangles {
        for j in 0..3 {
            u[t[j] as usize] = p[t[(j + 1) % 3] as usize] - p[t[j] as usize];
        }
    }
    let (u, v): (Vec<Vec3>, Vec<Vec3>) = u
        .iter()
        .zip(normals)
        .map(|(&e, &n)| {
            let a = e
                .cross(n)
                .try_normalize()
                .unwrap_or_else(|| n.any_orthonormal_vector());
            (a, n.cross(a))
        })
        .unzip();
    // Per face: least-squares fit, then the face's tensor in each corner's frame, weighted by area.
    let per_face: Vec<([[f64; 3]; 3], f64)> = mesh
        .triangles
        .par_iter()
        .map(|t| face_tensor(t, p, normals, &u, &v))
        .collect();
    let mut acc = vec![[0f64; 3]; nv];
    let mut wsum = vec![0f64; nv];
    for (t, (corner, area)) in mesh.triangles.iter().zip(&per_face) {
        for j in 0..3 {
            let vi = t[j] as usize;
            for k in 0..3 {
                acc[vi][k] += area * corner[j][k];
            }
            wsum[vi] += area;
        }
    }
    let tensor = acc
        .iter()
        .zip(&wsum)
        .map(|(a, &w)| {
            if w > 0.0 {
                a.map(|x| (x / w) as f32)
            } else {
                [0.0; 3]
            }
        })
        .collect();
    Curvature { u, v, tensor }
}

/// The face's fitted tensor expressed in each of its three corners' frames, and the face's area.
fn face_tensor(
    t: &[u32; 3],
    p: &[Vec3],
    n: &[Vec3],
    u: &[Vec3],
    v: &[Vec3],
) -> ([[f64; 3]; 3], f64) {
    let pp = t.map(|i| p[i as usize].as_dvec3());
    let nn = t.map(|i| n[i as usize].as_dvec3());
    // Edge j runs from corner j+1 to corner j+2 (opposite corner j).
    let e = [pp[2] - pp[1], pp[0] - pp[2], pp[1] - pp[0]];
    let fnorm = e[0].cross(e[1]);
    let area = 0.5 * fnorm.length();
    let (Some(ft), Some(fnrm)) = (e[0].try_normalize(), fnorm.try_normalize()) else {
        return ([[0.0; 3]; 3], 0.0);
    };
    let fb = fnrm.cross(ft);
    // Normal equations of: dn·t = ku·(e·t) + kuv·(e·b),  dn·b = kuv·(e·t) + kv·(e·b).
    let mut m = [0f64; 3];
    let mut w = [[0f64; 3]; 3];
    for j in 0..3 {
        let (eu, ev) = (e[j].dot(ft), e[j].dot(fb));
        w[0][0] += eu * eu;
        w[0][1] += eu * ev;
        w[2][2] += ev * ev;
        let dn = nn[(j + 2) % 3] - nn[(j + 1) % 3];
        let (dnu, dnv) = (dn.dot(ft), dn.dot(fb));
        m[0] += dnu * eu;
        m[1] += dnu * ev + dnv * eu;
        m[2] += dnv * ev;
    }
    w[1][1] = w[0][0] + w[2][2];
    w[1][0] = w[0][1];
    w[1][2] = w[0][1];
    w[2][1] = w[0][1];
    let Some(x) = solve3(w, m) else {
        return ([[0.0; 3]; 3], 0.0);
    };
    let mut out = [[0f64; 3]; 3];
    for j in 0..3 {
        let vi = t[j] as usize;
        out[j] = project_tensor(ft, fb, x, u[vi].as_dvec3(), v[vi].as_dvec3());
    }
    (out, area)
}

/// Solve a 3×3 linear system by Cramer's rule (the matrix is small and well scaled).
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if d.abs() < 1e-300 || !d.is_finite() {
        return None;
    }
    let mut x = [0f64; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut m = a;
        for r in 0..3 {
            m[r][k] = b[r];
        }
        *xk = det(m) / d;
    }
    Some(x)
}

/// Rotate frame (`nu`, `nv`) into the plane of (`ou`, `ov`) about their common axis, so a tensor
/// can be re-expressed in it.
fn rotate_frame(ou: DVec3, ov: DVec3, nu: DVec3, nv: DVec3) -> (DVec3, DVec3) {
    let old_n = ou.cross(ov);
    let new_n = nu.cross(nv);
    let ndot = old_n.dot(new_n);
    if ndot <= -1.0 {
        return (-nu, -nv);
    }
    let perp = old_n - ndot * new_n;
    let dperp = (new_n + old_n) / (1.0 + ndot);
    (nu - dperp * nu.dot(perp), nv - dperp * nv.dot(perp))
}

/// Express tensor `k` = [kuu, kuv, kvv] given in frame (ou, ov) in the frame (nu, nv).
fn project_tensor(ou: DVec3, ov: DVec3, k: [f64; 3], nu: DVec3, nv: DVec3) -> [f64; 3] {
    let (ru, rv) = rotate_frame(ou, ov, nu, nv);
    let (u1, v1) = (ru.dot(ou), ru.dot(ov));
    let (u2, v2) = (rv.dot(ou), rv.dot(ov));
    [
        k[0] * u1 * u1 + k[1] * 2.0 * u1 * v1 + k[2] * v1 * v1,
        k[0] * u1 * u2 + k[1] * (u1 * v2 + u2 * v1) + k[2] * v1 * v2,
        k[0] * u2 * u2 + k[1] * 2.0 * u2 * v2 + k[2] * v2 * v2,
    ]
}

/// What one view needs per vertex for suggestive contours.
#[derive(Clone, Debug)]
pub(crate) struct ViewCurvature {
    /// Radial curvature κr: the normal curvature along w, the view vector projected onto the
    /// tangent plane.
    pub(crate) kr: Vec<f32>,
    /// D_w κr, with w the projection of the unit view vector (|w| = sin of the view angle),
    /// times radius² so it is scale-free.
    pub(crate) dwkr: Vec<f32>,
}

/// κr and D_w κr at every vertex for the camera at `view_dir(p)`; `radius` is the model's scale.
pub(crate) fn view_dependent(
    mesh: &Mesh,
    normals: &[Vec3],
    curv: &Curvature,
    view_dir: impl Fn(Vec3) -> Vec3 + Sync,
    radius: f32,
) -> ViewCurvature {
    let p = &mesh.positions;
    let w: Vec<Vec3> = p
        .par_iter()
        .zip(normals.par_iter())
        .map(|(&p, &n)| {
            let v = view_dir(p);
            v - n * n.dot(v)
        })
        .collect();
    let kr: Vec<f32> = (0..p.len())
        .into_par_iter()
        .map(|i| curv.normal_curvature(i, w[i]))
        .collect();
    // The gradient of κr, piecewise linear over faces, averaged to vertices by area.
    let grads: Vec<(Vec3, f32)> = mesh
        .triangles
        .par_iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| p[i as usize]);
            let f = t.map(|i| kr[i as usize]);
            let n = (b - a).cross(c - a);
            let area2 = n.length();
            if area2 <= 0.0 {
                return (Vec3::ZERO, 0.0);
            }
            let nh = n / area2;
            let g =
                (nh.cross(c - b) * f[0] + nh.cross(a - c) * f[1] + nh.cross(b - a) * f[2]) / area2;
            (g, 0.5 * area2)
        })
        .collect();
    let mut gsum = vec![Vec3::ZERO; p.len()];
    let mut asum = vec![0f32; p.len()];
    for (t, &(g, a)) in mesh.triangles.iter().zip(&grads) {
        for &i in t {
            gsum[i as usize] += g * a;
            asum[i as usize] += a;
        }
    }
    let r2 = radius * radius;
    let dwkr = (0..p.len())
        .into_par_iter()
        .map(|i| {
            if asum[i] > 0.0 {
                gsum[i].dot(w[i]) / asum[i] * r2
            } else {
                0.0
            }
        })
        .collect();
    ViewCurvature { kr, dwkr }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tone::mesh::shapes;

    #[test]
    fn sphere_has_equal_principal_curvatures() {
        let m = shapes::uv_sphere(2.0, 64, 32);
        let n = m.vertex_normals();
        let c = estimate(&m, &n);
        // Away from the poles, whose fans of slivers bias any area-weighted estimate.
        for i in (0..m.positions.len()).filter(|&i| m.positions[i].y.abs() < 1.9) {
            let pr = c.principal(i);
            assert!(
                (pr.k1 - 0.5).abs() < 0.02 && (pr.k2 - 0.5).abs() < 0.02,
                "{pr:?}"
            );
        }
    }

    #[test]
    fn torus_outer_equator_curvatures() {
        // Major radius 3, tube radius 1: on the outer equator k = 1 (tube) and 1/4 (around the axis).
        let m = shapes::torus(3.0, 1.0, 128, 64);
        let n = m.vertex_normals();
        let c = estimate(&m, &n);
        let (i, _) = m
            .positions
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.x.total_cmp(&b.1.x))
            .unwrap();
        let pr = c.principal(i);
        assert!((pr.k1 - 1.0).abs() < 0.03, "{pr:?}");
        assert!((pr.k2 - 0.25).abs() < 0.03, "{pr:?}");
        // The larger curvature runs around the tube (along y there), the smaller around the axis.
        assert!(pr.dir1.y.abs() > 0.95, "{pr:?}");
        // Inner equator: saddle, k = 1 and -1/2.
        let (j, _) = m
            .positions
            .iter()
            .enumerate()
            .filter(|(_, p)| p.z.abs() < 1e-3 && p.y.abs() < 1e-3 && p.x > 0.0)
            .min_by(|a, b| a.1.x.total_cmp(&b.1.x))
            .unwrap();
        let pr = c.principal(j);
        assert!(
            (pr.k1 - 1.0).abs() < 0.03 && (pr.k2 + 0.5).abs() < 0.03,
            "{pr:?}"
        );
    }

    #[test]
    fn radial_curvature_on_a_sphere_has_no_zero() {
        let m = shapes::uv_sphere(1.0, 48, 24);
        let n = m.vertex_normals();
        let c = estimate(&m, &n);
        let eye = Vec3::new(0.0, 0.0, 4.0);
        let vc = view_dependent(&m, &n, &c, |p| (eye - p).normalize(), 1.0);
        assert!(vc.kr.iter().all(|&k| k > 0.9 && k < 1.25));
        for (p, d) in m.positions.iter().zip(&vc.dwkr) {
            assert!(p.y.abs() > 0.9 || d.abs() < 0.3, "{p} {d}");
        }
    }
}
