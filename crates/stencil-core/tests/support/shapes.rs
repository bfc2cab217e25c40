//! Procedural meshes: the sample models (`cargo run --example make_meshes`), the benchmark's
//! displaced sphere and the test shapes. Every closed shape comes out right side out (see
//! `Mesh::new`), so generators need not care about winding.
//!
//! Test support, not library API: the crate's unit tests, the example, and the root package's
//! tests and benches include this file with `#[path]`; each includer has `Mesh` in scope (the
//! crate's `tone::mesh::Mesh`), which the file takes from its parent module.
#![allow(dead_code)]

use std::f32::consts::{PI, TAU};

use glam::Vec3;

use super::Mesh;

/// A grid of `nu × nv` quads over parameters (i, j), each split into two triangles. `wrap_u`
/// joins the last column to the first; rows run j = 0..=nv. Coincident points (poles, axis
/// points) weld into one vertex and their degenerate triangles disappear.
fn grid(
    nu: usize,
    nv: usize,
    wrap_u: bool,
    wrap_v: bool,
    f: impl Fn(usize, usize) -> Vec3,
) -> Mesh {
    let cols = if wrap_u { nu } else { nu + 1 };
    let rows = if wrap_v { nv } else { nv + 1 };
    let mut pos = Vec::with_capacity(cols * rows);
    for j in 0..rows {
        for i in 0..cols {
            pos.push(f(i, j));
        }
    }
    let id = |i: usize, j: usize| ((j % rows) * cols + (i % cols)) as u32;
    let mut tris = Vec::with_capacity(nu * nv * 2);
    for j in 0..nv {
        for i in 0..nu {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            tris.push([a, c, b]);
            tris.push([a, d, c]);
        }
    }
    Mesh::new(pos, tris)
}

/// A latitude-longitude sphere of radius `r` centred at the origin.
pub fn uv_sphere(r: f32, segments: usize, rings: usize) -> Mesh {
    grid(segments, rings, true, false, |i, j| {
        let phi = TAU * i as f32 / segments as f32;
        if j == 0 || j == rings {
            return Vec3::new(0.0, if j == 0 { r } else { -r }, 0.0);
        }
        let th = PI * j as f32 / rings as f32;
        Vec3::new(
            r * th.sin() * phi.cos(),
            r * th.cos(),
            r * th.sin() * phi.sin(),
        )
    })
}

/// A torus around the y axis: major radius `big`, tube radius `small`.
pub fn torus(big: f32, small: f32, nu: usize, nv: usize) -> Mesh {
    grid(nu, nv, true, true, |i, j| {
        let (u, v) = (TAU * i as f32 / nu as f32, TAU * j as f32 / nv as f32);
        let rr = big + small * v.cos();
        Vec3::new(rr * u.cos(), small * v.sin(), rr * u.sin())
    })
}

/// A surface of revolution around the y axis through `profile` points (radius, height), from
/// bottom to top. A radius of 0 closes the surface on the axis.
pub fn revolution(profile: &[(f32, f32)], segments: usize) -> Mesh {
    grid(segments, profile.len() - 1, true, false, |i, j| {
        let phi = TAU * i as f32 / segments as f32;
        let (r, y) = profile[j];
        if r == 0.0 {
            return Vec3::new(0.0, y, 0.0);
        }
        Vec3::new(r * phi.cos(), y, r * phi.sin())
    })
}

/// A tube of `radius` around the closed curve `c(t)`, t in [0, 1).
pub fn tube(c: impl Fn(f32) -> Vec3, radius: f32, along: usize, around: usize) -> Mesh {
    grid(around, along, true, true, |i, j| {
        let t = j as f32 / along as f32;
        let h = 1e-3;
        let tangent = (c(t + h) - c(t - h)).normalize();
        // A frame from a fixed axis: fine for curves whose tangent never points along it.
        let b = tangent.cross(Vec3::Z).normalize();
        let n = b.cross(tangent);
        let a = TAU * i as f32 / around as f32;
        c(t) + (n * a.cos() + b * a.sin()) * radius
    })
}

/// The six faces of the cube [-1, 1]³, each an `n × n` grid, with `f` applied to every point.
pub fn cube_grid(n: usize, f: impl Fn(Vec3) -> Vec3) -> Mesh {
    let lat = |i: usize| -1.0 + 2.0 * i as f32 / n as f32;
    let mut pos = Vec::new();
    let mut tris = Vec::new();
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let face = grid(n, n, false, false, |i, j| {
                let mut p = [0.0; 3];
                p[axis] = side;
                p[(axis + 1) % 3] = lat(i);
                p[(axis + 2) % 3] = lat(j);
                f(Vec3::from_array(p))
            });
            let base = pos.len() as u32;
            pos.extend(face.positions);
            // The grid winds towards -axis; the +side faces must point the other way.
            tris.extend(face.triangles.iter().map(|t| {
                let t = t.map(|v| v + base);
                if side > 0.0 {
                    [t[0], t[2], t[1]]
                } else {
                    t
                }
            }));
        }
    }
    Mesh::new(pos, tris)
}

/// An axis-aligned cube of half-size `h` centred at the origin (12 triangles).
pub fn cube(h: f32) -> Mesh {
    cube_grid(1, |p| p * h)
}

/// A sphere made from a subdivided cube (`n × n` per face, 12·n² triangles) whose radius is
/// `1 + bumps(direction)`: the benchmark's displaced sphere.
pub fn displaced_sphere(n: usize) -> Mesh {
    cube_grid(n, |p| {
        let d = p.normalize();
        let bump = 0.06 * (5.0 * d.x).sin() * (4.0 * d.y).sin() * (6.0 * d.z).sin()
            + 0.03 * (11.0 * d.x + 3.0 * d.y).sin();
        d * (1.0 + bump)
    })
}

/// A height field y = f(x, z) over [-1, 1]², `n × n` quads, facing up (+y): an open surface.
pub fn height_field(n: usize, f: impl Fn(f32, f32) -> f32) -> Mesh {
    let lat = |i: usize| -1.0 + 2.0 * i as f32 / n as f32;
    // With i along x and j along z the grid winds towards +y.
    grid(n, n, false, false, |i, j| {
        Vec3::new(lat(i), f(lat(i), lat(j)), lat(j))
    })
}

/// A chess pawn: a surface of revolution through a hand-drawn profile (base, collar, head).
pub fn pawn() -> Mesh {
    // (radius, height) key points, bottom to top; the head is a sphere sampled separately.
    let mut profile: Vec<(f32, f32)> = vec![
        (0.0, 0.0),
        (0.95, 0.0),
        (1.0, 0.05),
        (1.0, 0.18),
        (0.93, 0.24),
        (0.82, 0.28),
        (0.78, 0.34),
        (0.66, 0.40),
        (0.52, 0.48),
    ];
    // The body: a concave flank narrowing towards the collar.
    for k in 1..=12 {
        let t = k as f32 / 12.0;
        profile.push((0.52 - 0.22 * t + 0.06 * (PI * t).sin(), 0.48 + 0.95 * t));
    }
    // The collar.
    profile.extend([(0.52, 1.47), (0.56, 1.52), (0.52, 1.57), (0.30, 1.60)]);
    // The head: a sphere of radius 0.42 sitting on the collar.
    let (cy, r) = (1.95f32, 0.42f32);
    let start = ((1.60 - cy) / r).clamp(-1.0, 1.0).asin(); // angle below the equator
    let steps = 16;
    for k in 1..=steps {
        let a = start + (PI / 2.0 - start) * k as f32 / steps as f32;
        let rad = if k == steps { 0.0 } else { r * a.cos() };
        profile.push((rad, cy + r * a.sin()));
    }
    revolution(&profile, 48)
}

/// A trefoil knot, as a tube.
pub fn trefoil() -> Mesh {
    let curve = |t: f32| {
        let a = TAU * t;
        Vec3::new(
            a.sin() + 2.0 * (2.0 * a).sin(),
            a.cos() - 2.0 * (2.0 * a).cos(),
            -(3.0 * a).sin(),
        )
    };
    tube(curve, 0.45, 150, 16)
}
