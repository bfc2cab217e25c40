//! Arcs cut into straight segments the way Grbl 1.1's `mc_arc` (motion_control.c) cuts them, so
//! the estimate, the simulator, the bed check and the virtual Grbl all follow the same chords the
//! machine will: segment ends on the circle, as many as `$12` (arc tolerance, the largest gap
//! between chord and circle) asks for, the angle from one `atan2`, the last segment ending exactly
//! at the programmed target.

/// Grbl's `ARC_ANGULAR_TRAVEL_EPSILON` (config.h): an arc whose start and end coincide within
/// this angle is a full circle.
const ANGULAR_EPSILON: f64 = 5e-7;

/// Grbl's `N_ARC_CORRECTION` (config.h): every this many segments the rotated radius vector is
/// recomputed exactly with sin/cos, between them a small-angle rotation is used.
const N_ARC_CORRECTION: u32 = 12;

/// The most segments one arc may have: Grbl counts them in a `uint16_t`, so a larger arc would
/// wrap its count and cut a different path. Such an arc (a radius of kilometres at `$12=0.002`)
/// is refused instead.
pub const MAX_ARC_SEGMENTS: u64 = 65_535;

/// One arc as Grbl's parser hands it to `mc_arc`: all in mm, machine coordinates.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Arc {
    pub from: [f64; 3],
    pub to: [f64; 3],
    /// Centre minus start, in the plane's two axes (the other entry unused).
    pub offset: [f64; 3],
    pub radius: f64,
    /// The plane's first, second and linear (helix) axis: XY is (0, 1, 2), ZX (2, 0, 1),
    /// YZ (1, 2, 0).
    pub axes: (usize, usize, usize),
    pub clockwise: bool,
}

impl Arc {
    /// The angle swept, radians: negative clockwise, a full turn when start and end coincide.
    pub(crate) fn angular_travel(&self) -> f64 {
        let (a0, a1, _) = self.axes;
        let (r0, r1) = (-self.offset[a0], -self.offset[a1]);
        let c0 = self.from[a0] + self.offset[a0];
        let c1 = self.from[a1] + self.offset[a1];
        let (t0, t1) = (self.to[a0] - c0, self.to[a1] - c1);
        let mut travel = (r0 * t1 - r1 * t0).atan2(r0 * t0 + r1 * t1);
        if self.clockwise {
            if travel >= -ANGULAR_EPSILON {
                travel -= 2.0 * std::f64::consts::PI;
            }
        } else if travel <= ANGULAR_EPSILON {
            travel += 2.0 * std::f64::consts::PI;
        }
        travel
    }

    /// How many segments `mc_arc` cuts the arc into at arc tolerance `tol` (0 means one line).
    pub(crate) fn segments(&self, tol: f64) -> u64 {
        let chord = (tol * (2.0 * self.radius - tol)).sqrt();
        let n = ((0.5 * self.angular_travel() * self.radius).abs() / chord).floor();
        if n.is_finite() && n > 0.0 {
            n as u64
        } else {
            0
        }
    }

    /// The end points of the segments, the last one exactly `to`. Call only with a count no more
    /// than [`MAX_ARC_SEGMENTS`].
    pub(crate) fn points(&self, tol: f64) -> Vec<[f64; 3]> {
        let segments = self.segments(tol).min(MAX_ARC_SEGMENTS) as u32;
        let mut out = Vec::with_capacity(segments as usize + 1);
        if segments > 0 {
            let (a0, a1, lin) = self.axes;
            let c0 = self.from[a0] + self.offset[a0];
            let c1 = self.from[a1] + self.offset[a1];
            let (mut r0, mut r1) = (-self.offset[a0], -self.offset[a1]);
            let theta = self.angular_travel() / segments as f64;
            let linear = (self.to[lin] - self.from[lin]) / segments as f64;
            // Grbl's third-order small-angle rotation between exact corrections.
            let cos_t = (2.0 - theta * theta) * 0.5;
            let sin_t = theta * 0.166_666_67 * (2.0 - theta * theta + 4.0);
            let mut p = self.from;
            let mut count = 0;
            for i in 1..segments {
                if count < N_ARC_CORRECTION {
                    let ri = r0 * sin_t + r1 * cos_t;
                    r0 = r0 * cos_t - r1 * sin_t;
                    r1 = ri;
                    count += 1;
                } else {
                    let (s, c) = (i as f64 * theta).sin_cos();
                    r0 = -self.offset[a0] * c + self.offset[a1] * s;
                    r1 = -self.offset[a0] * s - self.offset[a1] * c;
                    count = 0;
                }
                p[a0] = c0 + r0;
                p[a1] = c1 + r1;
                p[lin] += linear;
                out.push(p);
            }
        }
        out.push(self.to);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quarter(tol: f64) -> Vec<[f64; 3]> {
        // From (10, 0) counter-clockwise about the origin to (0, 10).
        Arc {
            from: [10.0, 0.0, 0.0],
            to: [0.0, 10.0, 0.0],
            offset: [-10.0, 0.0, 0.0],
            radius: 10.0,
            axes: (0, 1, 2),
            clockwise: false,
        }
        .points(tol)
    }

    #[test]
    fn segments_follow_the_tolerance_as_grbl_counts_them() {
        // floor(|0.5 · π/2 · 10| / sqrt(0.002 · (20 − 0.002))) = floor(7.854 / 0.19999) = 39.
        assert_eq!(quarter(0.002).len(), 39);
        for p in quarter(0.002) {
            let r = p[0].hypot(p[1]);
            // Grbl's small-angle rotation drifts a little between its exact corrections.
            assert!((r - 10.0).abs() < 1e-4, "{p:?} is off the circle");
        }
        assert_eq!(quarter(0.002).last(), Some(&[0.0, 10.0, 0.0]));
        // A coarse tolerance: fewer, longer chords.
        assert!(quarter(0.1).len() < 10);
    }

    #[test]
    fn a_closed_arc_is_a_full_circle_and_clockwise_sweeps_negative() {
        let full = Arc {
            from: [10.0, 0.0, 0.0],
            to: [10.0, 0.0, 0.0],
            offset: [-10.0, 0.0, 0.0],
            radius: 10.0,
            axes: (0, 1, 2),
            clockwise: true,
        };
        assert!((full.angular_travel() + 2.0 * std::f64::consts::PI).abs() < 1e-12);
        let pts = full.points(0.002);
        let min_y = pts.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
        assert!(
            (min_y + 10.0).abs() < 0.01,
            "a full circle reaches Y-10: {min_y}"
        );
    }
}
