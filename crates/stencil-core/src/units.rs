//! Physical units. One [`Scale`] (millimetres per working pixel) says how pixels and millimetres
//! relate; its methods convert single lengths, and the vector stage and the report multiply by
//! [`Scale::mm_per_px`] directly where they convert whole outlines.

use serde::{Deserialize, Serialize};

/// A length in millimetres.
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd, Default, Serialize, Deserialize)]
pub(crate) struct Mm(pub f64);

/// A length in working pixels.
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd, Default, Serialize, Deserialize)]
pub(crate) struct Px(pub f64);

/// How big the picture is on the sheet. Sizes are of the input picture: supersampling (`--scale`,
/// automatic or given) makes the working pixels finer, never the picture larger.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Size {
    /// 0.1 mm per input pixel ([`Scale::default`]).
    #[default]
    Default,
    /// The picture's width in mm (the height follows).
    WidthMm(f64),
    /// Input pixels per inch.
    Dpi(f64),
}

/// Millimetres per working pixel.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scale {
    /// Millimetres per working pixel (> 0).
    pub mm_per_px: f64,
}

impl Default for Scale {
    /// 0.1 mm per pixel (254 dpi): the documented default when neither `--width-mm` nor `--dpi`
    /// is given (per pixel of the picture; supersampling divides it).
    fn default() -> Self {
        Scale { mm_per_px: 0.1 }
    }
}

impl Scale {
    pub(crate) fn from_dpi(dpi: f64) -> Self {
        Scale {
            mm_per_px: 25.4 / dpi,
        }
    }

    /// The scale that makes an image `width_px` wide come out `width_mm` wide.
    pub(crate) fn from_width(width_px: u32, width_mm: f64) -> Self {
        Scale {
            mm_per_px: width_mm / width_px.max(1) as f64,
        }
    }

    pub(crate) fn to_px(self, mm: Mm) -> Px {
        Px(mm.0 / self.mm_per_px)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dpi_round_trip() {
        let s = Scale::from_dpi(254.0);
        assert!((s.mm_per_px - 0.1).abs() < 1e-12);
        assert!((s.to_px(Mm(2.0)).0 - 20.0).abs() < 1e-9);
    }
}
