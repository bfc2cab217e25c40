//! A swivel (drag) knife's blade physics: where its axis must go so that the blade tip, which
//! trails the axis by the blade offset, follows the outline. Shared by the G-code writer and the
//! HP-GL writer of plotter cutters, so both cut the same way.
//!
//! The tip of a drag knife lies `r` (the blade offset) behind the holder's axis, along the
//! direction of the last move. Driving the axis along the outline cuts every corner short; so the
//! axis overshoots each corner by `r` and swings on a circle of radius `r` around it, which turns
//! the blade to the new direction with its tip on the corner (the "swivel"). Corners that turn
//! less than a set angle are cut straight: the tip's error there is small
//! (`r·(1 − cos θ)`), and swivelling at every vertex of a finely traced curve would slow the cut
//! and wear the blade for nothing.

use stencil_geom::ring::dist;

/// Largest angle step of a swivel arc, degrees (arcs are written as chords).
pub const SWIVEL_STEP_DEG: f64 = 10.0;

/// How a drag knife is driven around a closed loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blade {
    /// How far the tip trails the axis, mm (0: no compensation, the axis follows the outline).
    pub offset_mm: f64,
    /// Corners turning at least this much (degrees) are swivelled around.
    pub swivel_min_deg: f64,
    /// How far past the loop's start the tip cuts again, mm, so the loop is cut through where it
    /// closes (the blade enters the material at the start with its angle still settling).
    pub overcut_mm: f64,
}

/// The unit vector from `a` to `b` (x axis for a zero-length step).
pub fn direction(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    let d = dist(a, b);
    if d <= 1e-12 {
        return [1.0, 0.0];
    }
    [(b[0] - a[0]) / d, (b[1] - a[1]) / d]
}

/// The point `len` mm along the closed loop `points` from its start, and the vertices passed on
/// the way (the start itself not included).
pub fn walk(points: &[[f64; 2]], len: f64) -> Vec<[f64; 2]> {
    let n = points.len();
    let mut out = Vec::new();
    let mut left = len;
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        let d = dist(a, b);
        if d >= left {
            let t = if d > 0.0 { left / d } else { 0.0 };
            out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
            return out;
        }
        left -= d;
        out.push(b);
    }
    out
}

/// The axis path that drags the tip along the open polyline `tip`, the blade pointing `from`
/// (a unit vector) when it is lowered at `tip[0]`. The first point is where the knife goes down
/// (the axis `r` ahead of the tip along `from`); if the first segment turns from `from` by at
/// least `min_deg`, the axis swivels around `tip[0]` first: the orientation move that lines the
/// blade up with the first segment before it cuts. Then each segment is shifted `r` along its
/// own direction, with a swivel around every vertex turning at least `min_deg`. Returns the path
/// and the blade's direction at its end.
pub fn axis_path(tip: &[[f64; 2]], r: f64, min_deg: f64, from: [f64; 2]) -> Vec<[f64; 2]> {
    let n = tip.len();
    if r <= 0.0 || n == 0 {
        return tip.to_vec();
    }
    let mut out = Vec::with_capacity(n * 3);
    let mut d_in = from;
    for i in 0..n {
        let p = tip[i];
        out.push([p[0] + r * d_in[0], p[1] + r * d_in[1]]);
        let Some(&next) = tip.get(i + 1) else { break };
        let d_out = direction(p, next);
        let a0 = d_in[1].atan2(d_in[0]);
        let mut turn = d_out[1].atan2(d_out[0]) - a0;
        // The shorter way round, in (-π, π].
        while turn > std::f64::consts::PI {
            turn -= std::f64::consts::TAU;
        }
        while turn <= -std::f64::consts::PI {
            turn += std::f64::consts::TAU;
        }
        if turn.abs().to_degrees() >= min_deg {
            let steps = (turn.abs().to_degrees() / SWIVEL_STEP_DEG).ceil() as usize;
            for k in 1..=steps {
                let a = a0 + turn * k as f64 / steps as f64;
                out.push([p[0] + r * a.cos(), p[1] + r * a.sin()]);
            }
        }
        d_in = d_out;
    }
    out
}

/// The tip's path for one pass around the closed loop `points` from `points[0]`, back to it,
/// then `overcut_mm` further along the loop.
pub fn tip_loop(points: &[[f64; 2]], overcut_mm: f64) -> Vec<[f64; 2]> {
    let mut tip = points.to_vec();
    if let Some(&p0) = points.first() {
        tip.push(p0);
    }
    if overcut_mm > 0.0 && points.len() >= 2 {
        tip.extend(walk(points, overcut_mm));
    }
    tip
}

/// The axis path of a drag knife cutting the closed loop `points` (`passes` times round, then
/// the overcut), the blade pointing `from` as it is lowered; and the blade's direction at the
/// end (for the orientation move of the next cut).
pub fn knife_loop(
    points: &[[f64; 2]],
    blade: &Blade,
    passes: u32,
    from: [f64; 2],
) -> (Vec<[f64; 2]>, [f64; 2]) {
    let mut tip: Vec<[f64; 2]> = Vec::with_capacity(points.len() * passes as usize + 8);
    for _ in 1..passes.max(1) {
        tip.extend_from_slice(points);
    }
    tip.extend(tip_loop(points, blade.overcut_mm));
    tip.dedup_by(|a, b| dist(*a, *b) <= 1e-9);
    let end_dir = match tip.len() {
        0 | 1 => from,
        k => direction(tip[k - 2], tip[k - 1]),
    };
    (
        axis_path(&tip, blade.offset_mm, blade.swivel_min_deg, from),
        end_dir,
    )
}

/// The axis path for one pass around a closed loop, starting (and implicitly ending) with the
/// tip at `points[0]` and the blade along the loop's last segment, every corner turning at least
/// `min_deg` swivelled: what the G-code writer repeats for each pass.
pub fn drag_knife_path(points: &[[f64; 2]], r: f64, min_deg: f64) -> Vec<[f64; 2]> {
    let n = points.len();
    if r <= 0.0 || n < 2 {
        return points.to_vec();
    }
    let mut tip = points.to_vec();
    tip.push(points[0]);
    let mut out = axis_path(&tip, r, min_deg, direction(points[n - 1], points[0]));
    // The last point is the first again (the closing move returns there).
    out.pop();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn walk_follows_the_loop() {
        let sq = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        assert_eq!(walk(&sq, 4.0), vec![[4.0, 0.0]]);
        assert_eq!(walk(&sq, 12.0), vec![[10.0, 0.0], [10.0, 2.0]]);
    }

    #[test]
    fn knife_loop_orients_then_overcuts() {
        let sq = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        let blade = Blade {
            offset_mm: 0.5,
            swivel_min_deg: 30.0,
            overcut_mm: 1.0,
        };
        // The blade arrives pointing down (-y): lowered with the axis 0.5 below the start, it
        // swivels a quarter turn around (0, 0) before the first cut.
        let (p, end) = knife_loop(&sq, &blade, 1, [0.0, -1.0]);
        assert_eq!(p[0], [0.0, -0.5]);
        let last_swivel = p[1..]
            .iter()
            .position(|q| (q[0] - 0.5).abs() < 1e-9 && q[1].abs() < 1e-9);
        assert!(last_swivel.is_some(), "{p:?}");
        // Ends 1 mm past the start along the first edge, the axis 0.5 ahead: (1.5, 0).
        let q = p[p.len() - 1];
        assert!((q[0] - 1.5).abs() < 1e-9 && q[1].abs() < 1e-9, "{q:?}");
        assert_eq!(end, [1.0, 0.0]);
    }
}
