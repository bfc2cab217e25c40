//! `stencil simulate`: draw what a G-code program would make the machine do, without a machine.
//! Cutting moves (laser firing, pen or blade down: one [`CutRule`] with the time estimate) in one
//! colour, travel in another, Y up (machine convention) flipped to image rows, scaled to the
//! job's extent.

use crate::interpret::{CutRule, Move};

/// Colour of cutting moves (laser firing, pen or blade down).
pub const CUT_RGB: [u8; 3] = [200, 20, 20];
/// Colour of travel (G0, or any move with the tool off or lifted).
pub const TRAVEL_RGB: [u8; 3] = [120, 170, 235];
const BACKGROUND: [u8; 3] = [255, 255, 255];

/// An RGB picture of a program's moves.
#[derive(Clone, Debug, PartialEq)]
pub struct Drawing {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Row by row from the top, three bytes a pixel.
    pub rgb: Vec<u8>,
    /// Millimetres per pixel of the drawing.
    pub mm_per_px: f64,
}

/// Draw the moves into a picture whose longer side is `max_px` pixels (plus a margin); `rule`
/// says which moves cut (the one the estimate uses, so the picture and the numbers agree).
pub fn draw(moves: &[Move], max_px: u32, rule: CutRule) -> Drawing {
    let margin = 8u32;
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for m in moves {
        for p in [m.from, m.to] {
            for a in 0..2 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
    }
    if moves.is_empty() {
        lo = [0.0; 2];
        hi = [1.0; 2];
    }
    let span = [(hi[0] - lo[0]).max(1e-6), (hi[1] - lo[1]).max(1e-6)];
    let max_px = max_px.max(16);
    let mm_per_px = span[0].max(span[1]) / (max_px - 1) as f64;
    let width = (span[0] / mm_per_px).round() as u32 + 1 + 2 * margin;
    let height = (span[1] / mm_per_px).round() as u32 + 1 + 2 * margin;
    let mut rgb = BACKGROUND.repeat((width * height) as usize);
    let to_px = |p: [f64; 3]| -> (f64, f64) {
        (
            (p[0] - lo[0]) / mm_per_px + margin as f64,
            // Machine Y grows upward; image rows grow downward.
            (hi[1] - p[1]) / mm_per_px + margin as f64,
        )
    };
    // Travel first, so cuts are drawn over it.
    for cut in [false, true] {
        let colour = if cut { CUT_RGB } else { TRAVEL_RGB };
        for m in moves.iter().filter(|m| rule.cuts(m) == cut) {
            let (a, b) = (to_px(m.from), to_px(m.to));
            line(&mut rgb, width, height, a, b, colour);
        }
    }
    Drawing {
        width,
        height,
        rgb,
        mm_per_px,
    }
}

fn line(rgb: &mut [u8], w: u32, h: u32, a: (f64, f64), b: (f64, f64), c: [u8; 3]) {
    let steps = (b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil().max(1.0) as usize;
    for i in 0..=steps {
        let t = i as f64 / steps as f64;
        let x = (a.0 + (b.0 - a.0) * t).round();
        let y = (a.1 + (b.1 - a.1) * t).round();
        if x < 0.0 || y < 0.0 || x >= w as f64 || y >= h as f64 {
            continue;
        }
        let i = (y as usize * w as usize + x as usize) * 3;
        rgb[i..i + 3].copy_from_slice(&c);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interpret::interpret;

    fn px(d: &Drawing, x: u32, y: u32) -> [u8; 3] {
        let i = ((y * d.width + x) * 3) as usize;
        [d.rgb[i], d.rgb[i + 1], d.rgb[i + 2]]
    }

    #[test]
    fn cut_and_travel_colours_y_up() {
        // Travel along y = 0 (bottom), cut along y = 10 (top).
        let m = interpret("G0 X0 Y0\nG0 X10\nM4 S500\nG0 Y10\nG1 X0 F600\nM5\n").unwrap();
        let d = draw(&m, 101, CutRule::infer(&m));
        assert_eq!((d.width, d.height), (117, 117));
        // Bottom edge of the job (y = 0) is near the bottom of the image: travel colour.
        assert_eq!(px(&d, 58, 108), TRAVEL_RGB);
        // Top edge (y = 10): the cut.
        assert_eq!(px(&d, 58, 8), CUT_RGB);
        // The middle is empty.
        assert_eq!(px(&d, 58, 58), BACKGROUND);
    }

    /// A pen on Z (no spindle at all): the lines drawn with the pen down are cut colour, the
    /// lifted travel is not. Before one rule served both, simulate drew such jobs as all travel.
    #[test]
    fn pen_on_z_is_drawn_as_cutting() {
        let m =
            interpret("G0 Z5\nG0 X0 Y0\nG0 X10\nG1 Z0 F500\nG1 Y10 F1000\nG0 Z5\nG0 X0\n").unwrap();
        let rule = CutRule::infer(&m);
        assert_eq!(
            rule,
            CutRule::ZDown {
                down_at_or_below: 0.0
            }
        );
        let d = draw(&m, 101, rule);
        // The pen-down line X = 10 is the image's right edge; the lifted return along Y = 10 the top.
        assert_eq!(px(&d, 108, 58), CUT_RGB);
        assert_eq!(px(&d, 58, 8), TRAVEL_RGB);
    }

    #[test]
    fn bad_program_names_the_line() {
        let e = interpret("G0 X1\nG1 X2\n").unwrap_err();
        let s = e.to_string();
        assert!(s.contains("line 2"), "{s}");
    }
}
