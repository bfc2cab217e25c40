//! A size that fits, decided from the picture's header before any work: a job for a machine is
//! scaled down to its bed when the picture at the default resolution would not fit, a job for a
//! sheet of stock (A4, A3, Letter or any W × H) is fitted to it, and a size asked for that cannot
//! fit is refused with the largest width that does, before seconds of work are spent on it.
//!
//! The margin counts only where something is cut or marked: the sheet's outline (cut on the
//! machine, or the edge of a sheet of stock the stencil is cut from), registration marks, a
//! gobo's rim. Without those, the margin is sheet the head never visits. The planner's bed check
//! (and `send`'s) still judges where the job really goes.

use crate::units::{Scale, Size};

/// What the picture must fit on.
#[derive(Clone, Debug, PartialEq)]
pub enum Stock {
    /// A machine's bed (it cannot be turned).
    Bed {
        /// The machine profile's name.
        machine: String,
        /// Bed width, mm.
        w_mm: f64,
        /// Bed height, mm.
        h_mm: f64,
    },
    /// A sheet of stock (card, vinyl) the stencil is cut from: its edge is the stencil's edge,
    /// so the margin always counts, and it may be turned a quarter turn.
    Sheet {
        /// The sheet as named (`A4`, `300x200`).
        name: String,
        /// Width, mm.
        w_mm: f64,
        /// Height, mm.
        h_mm: f64,
    },
}

impl Stock {
    fn dims(&self) -> (f64, f64) {
        match self {
            Stock::Bed { w_mm, h_mm, .. } | Stock::Sheet { w_mm, h_mm, .. } => (*w_mm, *h_mm),
        }
    }
}

impl std::fmt::Display for Stock {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Stock::Bed {
                machine,
                w_mm,
                h_mm,
            } => write!(f, "the {} x {} mm bed of {machine}", mm(*w_mm), mm(*h_mm)),
            Stock::Sheet { name, w_mm, h_mm } => {
                write!(f, "the {name} sheet ({} x {} mm)", mm(*w_mm), mm(*h_mm))
            }
        }
    }
}

/// A sheet size by name (`A4`, `A3`, `LETTER`, any case) or `WxH` in mm (`300x200`).
pub fn sheet(name: &str) -> Result<Stock, String> {
    let named = match name.to_ascii_uppercase().as_str() {
        // ISO 216 A sizes; ANSI Letter is 8.5 x 11 in.
        "A4" => Some(("A4", 210.0, 297.0)),
        "A3" => Some(("A3", 297.0, 420.0)),
        "LETTER" => Some(("Letter", 215.9, 279.4)),
        _ => None,
    };
    if let Some((n, w, h)) = named {
        return Ok(Stock::Sheet {
            name: n.into(),
            w_mm: w,
            h_mm: h,
        });
    }
    let bad = || format!("'{name}' is not a sheet: use A4, A3, LETTER or WxH in mm (e.g. 300x200)");
    let (w, h) = name
        .to_ascii_lowercase()
        .split_once('x')
        .map(|(w, h)| (w.trim().parse::<f64>(), h.trim().parse::<f64>()))
        .ok_or_else(bad)?;
    match (w, h) {
        (Ok(w), Ok(h)) if (1.0..=10_000.0).contains(&w) && (1.0..=10_000.0).contains(&h) => {
            Ok(Stock::Sheet {
                name: format!("{}x{} mm", mm(w), mm(h)),
                w_mm: w,
                h_mm: h,
            })
        }
        _ => Err(bad()),
    }
}

/// What to fit and on what.
#[derive(Clone, Debug, PartialEq)]
pub struct FitRequest {
    /// The picture's size in pixels (from its header).
    pub picture_px: (u32, u32),
    /// The size asked for.
    pub size: Size,
    /// `--margin-mm`.
    pub margin_mm: f64,
    /// Whether the margin counts: something is cut or marked at the sheet's edge (always for a
    /// [`Stock::Sheet`]).
    pub margin_counts: bool,
    /// What it must fit on.
    pub stock: Stock,
}

/// The size decided.
#[derive(Clone, Debug, PartialEq)]
pub enum Fitted {
    /// The size asked for fits.
    AsAsked,
    /// Scaled to fit: the picture would have been `from_mm` wide; it is `width_mm` wide (the
    /// stock turned a quarter turn when `turned`).
    Scaled {
        /// The size asked for, mm.
        from_mm: [f64; 2],
        /// The width chosen, mm.
        width_mm: f64,
        /// The height that follows, mm.
        height_mm: f64,
        /// The stock is turned a quarter turn.
        turned: bool,
    },
}

/// A size that cannot fit.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FitError {
    /// The picture does not fit, even turned.
    #[error(
        "the picture is {} x {} mm{}, which does not fit {stock}; the largest width that fits is {} mm",
        mm(size_mm[0]),
        mm(size_mm[1]),
        if *margin_mm > 0.0 { format!(" with a {} mm margin on each side", mm(*margin_mm)) } else { String::new() },
        mm(*largest_width_mm)
    )]
    TooLarge {
        /// Its size, mm.
        size_mm: [f64; 2],
        /// The margin that counted (0 when it did not).
        margin_mm: f64,
        /// What it was to fit on.
        stock: Stock,
        /// The largest width that fits, mm.
        largest_width_mm: f64,
    },
    /// The margins take the whole stock.
    #[error("a {} mm margin on each side leaves nothing of {stock}", mm(*margin_mm))]
    MarginTooLarge {
        /// The margin on each side, mm.
        margin_mm: f64,
        /// The stock.
        stock: Stock,
    },
}

/// A size that cannot be made, found before any work.
#[derive(Debug, thiserror::Error)]
pub enum SizingError {
    /// A gobo was asked of a mesh.
    #[error("a gobo is made from a picture: a mesh is drawn at its own size")]
    GoboMesh,
    /// The gobo is larger than the machine's bed.
    #[error("a {gobo} gobo is {od_mm} mm across, larger than {bed}")]
    GoboBed {
        /// The gobo size's name.
        gobo: String,
        /// Its outside diameter, mm.
        od_mm: f64,
        /// The bed.
        bed: Stock,
    },
    /// The picture does not fit the sheet or bed.
    #[error(transparent)]
    Fit(#[from] FitError),
    /// The crop reaches outside the picture.
    #[error(
        "the crop reaches outside the picture, which is {:.1} x {:.1} mm at this size ({mm_per_px:.3} mm per pixel)",
        picture_mm[0], picture_mm[1]
    )]
    CropOutside {
        /// The crop asked for: X, Y, W, H, mm.
        crop_mm: [f64; 4],
        /// The whole picture's width and height at this size, mm.
        picture_mm: [f64; 2],
        /// Millimetres per picture pixel at this size.
        mm_per_px: f64,
    },
}

/// A number of mm as printed: at most one decimal, rounded down for a largest size (so what is
/// printed still fits).
fn mm(v: f64) -> String {
    let r = (v * 10.0).floor() / 10.0;
    if (r - r.round()).abs() < 1e-9 {
        format!("{}", r.round())
    } else {
        format!("{r:.1}")
    }
}

/// The picture's size in mm at `size` (before any fitting).
pub(crate) fn picture_mm(px: (u32, u32), size: Size) -> [f64; 2] {
    let (w, h) = (px.0.max(1) as f64, px.1.max(1) as f64);
    let s = match size {
        Size::Default => Scale::default(),
        Size::WidthMm(mm) => Scale::from_width(px.0, mm),
        Size::Dpi(d) => Scale::from_dpi(d),
    };
    [w * s.mm_per_px, h * s.mm_per_px]
}

/// Decide the size: the one asked for when it fits; scaled to the stock when none was asked for
/// (down to a bed; to fill a sheet); refused when the one asked for does not fit.
pub fn fit(r: &FitRequest) -> Result<Fitted, FitError> {
    let sheet = matches!(r.stock, Stock::Sheet { .. });
    let m = if r.margin_counts || sheet {
        r.margin_mm
    } else {
        0.0
    };
    let (sw, sh) = r.stock.dims();
    let (pw, ph) = (r.picture_px.0.max(1) as f64, r.picture_px.1.max(1) as f64);
    // The widest the picture can be in each orientation of the stock (a bed is not turned).
    let widest = |aw: f64, ah: f64| (aw - 2.0 * m).min((ah - 2.0 * m) * pw / ph);
    let upright = widest(sw, sh);
    let turned = if sheet {
        widest(sh, sw)
    } else {
        f64::NEG_INFINITY
    };
    let (largest, is_turned) = if turned > upright + 1e-9 {
        (turned, true)
    } else {
        (upright, false)
    };
    if largest <= 0.0 {
        return Err(FitError::MarginTooLarge {
            margin_mm: m,
            stock: r.stock.clone(),
        });
    }
    // Printed and used rounded down to 0.1 mm, so the size said to fit does fit.
    let largest = (largest * 10.0).floor() / 10.0;
    let asked = picture_mm(r.picture_px, r.size);
    let fits = asked[0] <= largest + 1e-6;
    match (r.size, fits) {
        // A sheet is filled; a bed (never turned) only when the picture would not fit on it.
        (Size::Default, fits) if sheet || !fits => Ok(Fitted::Scaled {
            from_mm: asked,
            width_mm: largest,
            height_mm: largest * ph / pw,
            turned: is_turned,
        }),
        (_, true) => Ok(Fitted::AsAsked),
        (_, false) => Err(FitError::TooLarge {
            size_mm: asked,
            margin_mm: m,
            stock: r.stock.clone(),
            largest_width_mm: largest,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bed(w: f64, h: f64) -> Stock {
        Stock::Bed {
            machine: "m".into(),
            w_mm: w,
            h_mm: h,
        }
    }

    fn req(px: (u32, u32), size: Size, counts: bool, stock: Stock) -> FitRequest {
        FitRequest {
            picture_px: px,
            size,
            margin_mm: 5.0,
            margin_counts: counts,
            stock,
        }
    }

    #[test]
    fn a_phone_photo_is_scaled_down_to_the_bed() {
        // 4032 x 3024 px at 0.1 mm/px is 403.2 mm wide: down to the 400 mm bed.
        let f = fit(&req((4032, 3024), Size::Default, false, bed(400.0, 400.0))).unwrap();
        let Fitted::Scaled {
            width_mm,
            height_mm,
            ..
        } = f
        else {
            panic!("{f:?}")
        };
        assert_eq!(width_mm, 400.0);
        assert!((height_mm - 300.0).abs() < 1e-9);
        // With the outline cut, the margin counts: 390 mm.
        let f = fit(&req((4032, 3024), Size::Default, true, bed(400.0, 400.0))).unwrap();
        assert!(matches!(f, Fitted::Scaled { width_mm, .. } if width_mm == 390.0));
        // A tall picture is limited by the bed's depth.
        let f = fit(&req((3000, 6000), Size::Default, false, bed(400.0, 400.0))).unwrap();
        assert!(matches!(f, Fitted::Scaled { width_mm, .. } if width_mm == 200.0));
    }

    #[test]
    fn the_margin_counts_only_where_something_is_cut() {
        let w395 = Size::WidthMm(395.0);
        assert_eq!(
            fit(&req((1000, 500), w395, false, bed(400.0, 400.0))),
            Ok(Fitted::AsAsked)
        );
        let e = fit(&req((1000, 500), w395, true, bed(400.0, 400.0))).unwrap_err();
        assert_eq!(
            e,
            FitError::TooLarge {
                size_mm: [395.0, 197.5],
                margin_mm: 5.0,
                stock: bed(400.0, 400.0),
                largest_width_mm: 390.0
            }
        );
        let msg = e.to_string();
        assert!(
            msg.contains("390 mm") && msg.contains("5 mm margin"),
            "{msg}"
        );
    }

    #[test]
    fn a_sheet_is_filled_turned_if_that_is_larger() {
        let a4 = sheet("a4").unwrap();
        // A landscape picture on A4: turned, 297 - 10 = 287 mm wide (200 mm tall: 210 - 10).
        let f = fit(&req((3000, 2000), Size::Default, false, a4.clone())).unwrap();
        let Fitted::Scaled {
            width_mm,
            height_mm,
            turned,
            ..
        } = f
        else {
            panic!()
        };
        assert!(turned);
        assert!((width_mm - 287.0).abs() < 1e-9 && height_mm <= 200.0 + 1e-9);
        // A size asked for that is too wide for the sheet is refused.
        assert!(fit(&req((3000, 2000), Size::WidthMm(300.0), false, a4)).is_err());
        assert!(matches!(sheet("300x200"), Ok(Stock::Sheet { w_mm, .. }) if w_mm == 300.0));
        assert!(sheet("B5").is_err() && sheet("0x5").is_err() && sheet("axb").is_err());
        assert!(matches!(
            fit(&FitRequest {
                margin_mm: 200.0,
                ..req((10, 10), Size::Default, true, bed(300.0, 300.0))
            }),
            Err(FitError::MarginTooLarge { .. })
        ));
    }
}
