//! The gray at the working resolution and its two-tone (the paper's Stage 1: a pixel above the
//! threshold is material), a cropped gobo's circle kept, and the picture's side of the likeness.

use std::sync::Arc;

use super::source::Source;
use crate::plan::ToneParams;
use crate::raster::{Gray, TwoTone};
use crate::tone::{self, mesh};

/// Stage 2: the gray at the working resolution (a picture upsampled by the factor; a mesh's
/// rendering as drawn). Shared: every two-tone made of it carries it (see [`TwoTone`]).
pub fn working_gray(source: Source, factor: u32) -> Arc<Gray> {
    match source {
        // Upsampling by 1 would only copy the picture.
        Source::Picture(g) if factor > 1 => Arc::new(tone::image::upsample(&g, factor)),
        Source::Picture(g) => g,
        Source::Mesh(r) => Arc::new(r.gray.clone()),
    }
}

/// Stage 3: the two-tone and the level used (Otsu's, when asked for). A mesh's lines are cut
/// and its background material whatever the level (see [`mesh::two_tone`]).
pub fn threshold(source: &Source, gray: Arc<Gray>, p: &ToneParams) -> (TwoTone, u8) {
    let (mut two, level) = match source {
        Source::Picture(_) => tone::threshold(gray, p.threshold, p.invert),
        Source::Mesh(r) => mesh::two_tone_with(r, gray, p.threshold, p.invert),
    };
    if let Some(c) = p.keep_circle_px {
        keep_circle(&mut two, c, p.invert);
    }
    (two, level)
}

/// Outside the circle (cx, cy, r) in pixels, metal: a cropped gobo's image area is all the
/// fixture projects, so the picture beyond it goes. The gray is set to the tone that thresholds
/// as material too, so the clean-up (which rereads it) keeps it so.
fn keep_circle(two: &mut TwoTone, [cx, cy, r]: [f64; 3], invert: bool) {
    let metal_gray = if invert { 0.0 } else { 1.0 };
    let w = two.bits.width;
    // A copy only when the gray is shared (the studio keeps it for other levels).
    let gray = Arc::make_mut(&mut two.gray);
    for y in 0..two.bits.height {
        for x in 0..w {
            if (x as f64 + 0.5 - cx).hypot(y as f64 + 0.5 - cy) > r {
                two.bits.set(x, y, true);
                gray.set(x, y, metal_gray);
            }
        }
    }
}

/// Stage 3b: the picture's side of the likeness measure ([`tone::Likeness`]), of the gray the
/// two-tone carries (`raw.gray`, see [`ToneParams::gray_key`]): the clean-up measures every
/// two-tone it makes of that gray against it, so it is made once per gray, not per level.
pub fn look(raw: &TwoTone) -> tone::Likeness {
    tone::Likeness::of(&raw.gray)
}
