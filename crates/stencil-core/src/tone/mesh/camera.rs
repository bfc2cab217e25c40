//! The camera: an orbit around the model's bounding sphere, framed so the model fills the image
//! with a margin.
//!
//! World space is the OBJ's (Y up). Camera space: x right, y up, z forward (depth). Pixel space:
//! x right, y down, pixel (i, j) covers [i, i+1) × [j, j+1), its centre is (i + 0.5, j + 0.5).

use glam::Vec3;

/// Fraction of the long side left empty around the model on each side.
pub(crate) const MARGIN: f32 = 0.05;

/// A pinhole (or orthographic) camera with its image plane already fitted to the model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Where the camera is, model units.
    pub eye: Vec3,
    pub(crate) right: Vec3,
    pub(crate) up: Vec3,
    pub(crate) forward: Vec3,
    /// Parallel projection instead of perspective.
    pub orthographic: bool,
    /// Pixels per unit of x/z (perspective) or per world unit (orthographic).
    pub focal_px: f32,
    /// The principal point (where the view axis meets the image), in pixels. The framing shifts it
    /// off the image centre so the model, not its bounding sphere, is centred.
    pub(crate) cx: f32,
    pub(crate) cy: f32,
    pub(crate) width: u32,
    pub(crate) height: u32,
    /// The bounding sphere the camera orbits.
    pub(crate) center: Vec3,
    pub(crate) radius: f32,
}

/// The model's up axis: which of its axes points up in the world it was modelled in (Y for most
/// OBJ exports, Z for CAD and some 3D-scanning tools). The orbit's azimuth turns around it and
/// its elevation rises towards it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Up {
    /// +X is up.
    X,
    /// +Y is up.
    #[default]
    Y,
    /// +Z is up.
    Z,
    /// −X is up.
    NegX,
    /// −Y is up.
    NegY,
    /// −Z is up.
    NegZ,
}

impl Up {
    /// A direction of the Y-up frame the orbit is computed in, as a direction of the model's own
    /// frame: a rotation by quarter turns (a signed permutation, exact in floating point; the
    /// identity for Y).
    #[inline]
    pub(crate) fn to_model(self, v: Vec3) -> Vec3 {
        match self {
            Up::Y => v,
            // Y-up (x, y, z) -> Z-up: up (0,1,0) -> (0,0,1), front +Z -> -Y.
            Up::Z => Vec3::new(v.x, -v.z, v.y),
            Up::X => Vec3::new(v.y, -v.x, v.z),
            Up::NegY => Vec3::new(v.x, -v.y, -v.z),
            Up::NegZ => Vec3::new(v.x, v.z, -v.y),
            Up::NegX => Vec3::new(-v.y, v.x, v.z),
        }
    }
}

/// Where the camera stands and how it sees, before framing.
#[derive(Clone, Copy, Debug)]
pub struct Orbit {
    pub(crate) azimuth_deg: f32,
    pub(crate) elevation_deg: f32,
    /// The model's up axis: the azimuth turns around it.
    pub up: Up,
    /// Eye distance from the centre, in bounding radii (> 1).
    pub distance: f32,
    pub(crate) orthographic: bool,
}

/// The rendered image's size in pixels, to fit the model into (named apart from
/// [`crate::units::Size`], the sheet's size in millimetres).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenderSize {
    /// This many pixels on the long side; the other side follows the model's outline.
    LongSide(u32),
    /// Exactly this size (the model fitted inside).
    Exact {
        /// Width, px.
        width: u32,
        /// Height, px.
        height: u32,
    },
}

impl Camera {
    /// Place the camera on its orbit and fit the image plane to the projected `positions`.
    pub(crate) fn frame(
        center: Vec3,
        radius: f32,
        orbit: &Orbit,
        size: RenderSize,
        positions: &[Vec3],
    ) -> Camera {
        let (az, el) = (
            orbit.azimuth_deg.to_radians(),
            orbit.elevation_deg.to_radians(),
        );
        // The orbit in a Y-up frame, turned into the model's (exact: see `Up::to_model`).
        let dir = Vec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos());
        let forward = -dir;
        // Looking straight down or up: keep "up" on the image pointing away from the viewer's side.
        let right = forward
            .cross(Vec3::Y)
            .try_normalize()
            .unwrap_or_else(|| Vec3::new(az.cos(), 0.0, -az.sin()));
        let up = right.cross(forward);
        let m = |v| orbit.up.to_model(v);
        let (dir, forward, right, up) = (m(dir), m(forward), m(right), m(up));
        let eye = center + dir * orbit.distance * radius;
        let mut cam = Camera {
            eye,
            right,
            up,
            forward,
            orthographic: orbit.orthographic,
            focal_px: 1.0,
            cx: 0.0,
            cy: 0.0,
            width: 1,
            height: 1,
            center,
            radius,
        };
        // Bounding box of the outline on the unit image plane.
        let (mut lo, mut hi) = (
            glam::Vec2::splat(f32::INFINITY),
            glam::Vec2::splat(f32::NEG_INFINITY),
        );
        for &p in positions {
            let q = cam.plane(p).0;
            lo = lo.min(q);
            hi = hi.max(q);
        }
        // A flat model seen edge-on still gets a sensible extent.
        let sphere = if orbit.orthographic {
            radius
        } else {
            (1.0 / (orbit.distance * orbit.distance - 1.0).max(1e-6)).sqrt()
        };
        let ext = (hi - lo).max(glam::Vec2::splat(sphere * 1e-3));
        let mid = (lo + hi) * 0.5;
        let (w, h, f) = match size {
            RenderSize::LongSide(n) => {
                let n = n as f32;
                let m = (MARGIN * n).round();
                let f = (n - 2.0 * m) / ext.x.max(ext.y);
                let (w, h) = if ext.x >= ext.y {
                    (n, (ext.y * f + 2.0 * m).round())
                } else {
                    ((ext.x * f + 2.0 * m).round(), n)
                };
                (w.max(1.0), h.max(1.0), f)
            }
            RenderSize::Exact { width, height } => {
                let (w, h) = (width as f32, height as f32);
                let m = (MARGIN * w.max(h)).round();
                let f = ((w - 2.0 * m) / ext.x).min((h - 2.0 * m) / ext.y).max(1e-6);
                (w, h, f)
            }
        };
        cam.width = w as u32;
        cam.height = h as u32;
        cam.focal_px = f;
        cam.cx = w * 0.5 - f * mid.x;
        cam.cy = h * 0.5 + f * mid.y;
        cam
    }

    /// Camera-space coordinates (x right, y up, z depth).
    #[inline]
    pub(crate) fn to_camera(self, p: Vec3) -> Vec3 {
        let d = p - self.eye;
        Vec3::new(d.dot(self.right), d.dot(self.up), d.dot(self.forward))
    }

    /// Position on the unit image plane (before the pixel scale and offset), and the depth.
    #[inline]
    fn plane(&self, p: Vec3) -> (glam::Vec2, f32) {
        let c = self.to_camera(p);
        let d = if self.orthographic { 1.0 } else { c.z };
        (glam::Vec2::new(c.x / d, c.y / d), c.z)
    }

    /// Pixel coordinates (x right, y down) and depth of a world point.
    #[inline]
    pub fn project(&self, p: Vec3) -> Vec3 {
        let (q, z) = self.plane(p);
        Vec3::new(
            self.cx + self.focal_px * q.x,
            self.cy - self.focal_px * q.y,
            z,
        )
    }

    /// The ray through pixel position (sx, sy): `ray_at` its image-plane position.
    #[cfg(test)]
    pub(crate) fn ray(&self, sx: f32, sy: f32) -> (Vec3, Vec3) {
        self.ray_at(
            (sx - self.cx) / self.focal_px,
            (self.cy - sy) / self.focal_px,
        )
    }

    /// The image-plane x of each pixel column's centre (for [`Camera::ray_at`]).
    pub(crate) fn column_xs(&self) -> Vec<f32> {
        (0..self.width)
            .map(|x| (x as f32 + 0.5 - self.cx) / self.focal_px)
            .collect()
    }

    /// The image-plane y of pixel row `y`'s centre.
    pub(crate) fn row_y(&self, y: usize) -> f32 {
        (self.cy - (y as f32 + 0.5)) / self.focal_px
    }

    /// The ray through image-plane position (`u`, `v`): origin, direction (`dir · forward = 1`).
    #[inline]
    pub(crate) fn ray_at(&self, u: f32, v: f32) -> (Vec3, Vec3) {
        let off = self.right * u + self.up * v;
        if self.orthographic {
            (self.eye + off, self.forward)
        } else {
            (self.eye, self.forward + off)
        }
    }

    /// Unit vector from a world point towards the viewer.
    #[inline]
    pub(crate) fn view_dir(&self, p: Vec3) -> Vec3 {
        if self.orthographic {
            -self.forward
        } else {
            (self.eye - p).normalize_or_zero()
        }
    }

    /// A point given in the camera's frame (x right, y up, z towards the viewer) relative to the
    /// bounding sphere's centre, in bounding radii, as a world point.
    pub(crate) fn world_from_view(&self, v: Vec3) -> Vec3 {
        self.center + (self.right * v.x + self.up * v.y - self.forward * v.z) * self.radius
    }

    /// The same view at `k` times the resolution (supersampling).
    pub(crate) fn scaled(&self, k: u32) -> Camera {
        let kf = k as f32;
        Camera {
            focal_px: self.focal_px * kf,
            cx: self.cx * kf,
            cy: self.cy * kf,
            width: self.width * k,
            height: self.height * k,
            ..*self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> Vec<Vec3> {
        let mut v = Vec::new();
        for i in 0..8 {
            v.push(Vec3::new(
                (i & 1) as f32 * 2.0 - 1.0,
                ((i >> 1) & 1) as f32 * 2.0 - 1.0,
                ((i >> 2) & 1) as f32 * 2.0 - 1.0,
            ));
        }
        v
    }

    #[test]
    fn orbit_zero_looks_down_minus_z() {
        let o = Orbit {
            azimuth_deg: 0.0,
            elevation_deg: 0.0,
            up: Up::Y,
            distance: 4.0,
            orthographic: false,
        };
        let c = Camera::frame(
            Vec3::ZERO,
            3f32.sqrt(),
            &o,
            RenderSize::LongSide(200),
            &cube(),
        );
        assert!((c.eye - Vec3::new(0.0, 0.0, 4.0 * 3f32.sqrt())).length() < 1e-4);
        assert!((c.right - Vec3::X).length() < 1e-6 && (c.up - Vec3::Y).length() < 1e-6);
        // The model fills the long side minus the margins.
        let xs: Vec<f32> = cube().iter().map(|&p| c.project(p).x).collect();
        let (lo, hi) = xs
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(
            (lo - 10.0).abs() < 1e-3 && (hi - 190.0).abs() < 1e-3,
            "{lo} {hi}"
        );
        assert_eq!((c.width, c.height), (200, 200));
    }

    #[test]
    fn rays_go_through_projected_points() {
        let o = Orbit {
            azimuth_deg: 30.0,
            elevation_deg: 20.0,
            up: Up::Y,
            distance: 3.0,
            orthographic: false,
        };
        let c = Camera::frame(
            Vec3::ZERO,
            1.8,
            &o,
            RenderSize::Exact {
                width: 300,
                height: 200,
            },
            &cube(),
        );
        for p in cube() {
            let s = c.project(p);
            let (o, d) = c.ray(s.x, s.y);
            assert!((o + d * s.z - p).length() < 1e-4);
        }
        assert!(c.world_from_view(Vec3::new(0.0, 0.0, 3.0)).distance(c.eye) < 1e-4);
    }

    #[test]
    fn elevation_ninety_is_not_degenerate() {
        let o = Orbit {
            azimuth_deg: 0.0,
            elevation_deg: 90.0,
            up: Up::Y,
            distance: 3.0,
            orthographic: true,
        };
        let c = Camera::frame(Vec3::ZERO, 1.8, &o, RenderSize::LongSide(100), &cube());
        assert!(c.right.is_finite() && c.up.is_finite());
        assert!(c.right.dot(c.forward).abs() < 1e-5 && c.up.dot(c.forward).abs() < 1e-5);
    }
}
