//! How many tiles, and where their seams may run: along each side the fewest tiles whose
//! largest one (its share of the picture, the band its seams may wander in, the overlap past
//! them, the sheet's margin) fits the stock; or the count asked for, with the band the stock
//! leaves. Pure arithmetic on millimetres and pixels.

use crate::error::TilesError;
use crate::fit::Stock;
use crate::limits::MAX_TILES_PER_SIDE;

/// The widest a seam may wander from its straight line, each way, mm: wider finds quieter
/// paths, but every tile grows by it.
pub const MAX_BAND_MM: f64 = 25.0;

/// The narrowest band a seam may wander in, each way, mm: below it the seam is all but straight.
pub const MIN_BAND_MM: f64 = 2.0;

/// The grid of tiles asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Grid {
    /// The fewest tiles that fit the stock.
    Auto,
    /// Columns and rows.
    Fixed {
        /// Tiles across.
        cols: u32,
        /// Tiles down.
        rows: u32,
    },
}

/// One side's tiles: how many, where their seams' straight lines are, how far seams may wander.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Side {
    /// Tiles along this side.
    pub count: u32,
    /// Each seam's straight line, working px from the picture's left (top) edge.
    pub centres_px: Vec<u32>,
    /// How far a seam may wander each way, working px.
    pub band_px: u32,
}

/// What one side's layout is decided from, in mm (the stock's side, when there is one).
pub(crate) struct SideRequest<'a> {
    /// "vertical" (seams across x) or "horizontal".
    pub axis: &'static str,
    /// The picture's length along this side, working px.
    pub len_px: u32,
    /// Millimetres per working pixel.
    pub mm_per_px: f64,
    /// The stock's length along this side, mm.
    pub stock_mm: Option<f64>,
    /// The count asked for (`None`: the fewest that fit).
    pub count: Option<u32>,
    /// Seam places asked for, mm from the picture's edge.
    pub seams_mm: &'a [f64],
    /// The overlap past a seam, mm.
    pub overlap_mm: f64,
    /// The sheet's margin, mm.
    pub margin_mm: f64,
    /// Working px per input px (a tile's edges fall on input pixels).
    pub factor: u32,
    /// How far a tile's box reaches past its strip on a seam's side, mm (see `WINDOW_MIN`).
    pub window_mm: f64,
}

/// The band a side of `n` tiles leaves for its seams, mm, before the limits (negative: none).
fn band_for(r: &SideRequest, n: u32, len_mm: f64) -> f64 {
    // Rounding a tile's box out to whole input pixels, each side.
    let slack = 2.0 * ((r.factor as f64 + 1.0) * r.mm_per_px + r.window_mm);
    match r.stock_mm {
        // An inner tile has two seams, each wandering `band` and overlapped past by the overlap.
        Some(s) => ((s - 2.0 * r.margin_mm - slack) - len_mm / n as f64) / 2.0 - r.overlap_mm,
        None => (len_mm / n as f64 / 6.0).min(MAX_BAND_MM),
    }
}

/// One side's tiles.
pub(crate) fn side(r: &SideRequest) -> Result<Side, TilesError> {
    let len_mm = r.len_px as f64 * r.mm_per_px;
    let fits_whole = |s: f64| len_mm + 2.0 * r.margin_mm <= s + 1e-9;
    let count = match (r.count, r.stock_mm) {
        (Some(n), _) => n,
        (None, None) => return Err(TilesError::NoStock),
        (None, Some(s)) if fits_whole(s) => 1,
        (None, Some(_)) => (2..=MAX_TILES_PER_SIDE)
            .find(|&n| band_for(r, n, len_mm) >= MIN_BAND_MM)
            .ok_or(TilesError::TooMany {
                cols: MAX_TILES_PER_SIDE + 1,
                rows: MAX_TILES_PER_SIDE + 1,
                max: MAX_TILES_PER_SIDE,
            })?,
    };
    // At most a quarter of a tile's share each way, so seams keep to their own part.
    let band_mm = if count > 1 {
        band_for(r, count, len_mm).clamp(0.0, MAX_BAND_MM.min(len_mm / count as f64 / 4.0))
    } else {
        0.0
    };
    let band_px = (band_mm / r.mm_per_px).floor() as u32;
    let ov_px = (r.overlap_mm / r.mm_per_px).ceil() as u32;
    // Seams apart by at least their bands and overlaps, and a tile's worth of the rest.
    let gap_px = 2 * (band_px + ov_px) + 2;
    let wrong = || TilesError::Seams {
        axis: r.axis,
        given: r.seams_mm.len(),
        want: count as usize - 1,
        size_mm: len_mm,
        gap_mm: gap_px as f64 * r.mm_per_px,
    };
    let centres_px: Vec<u32> = if r.seams_mm.is_empty() {
        (1..count)
            .map(|k| ((k as u64 * r.len_px as u64) / count as u64) as u32)
            .collect()
    } else {
        if r.seams_mm.len() != count as usize - 1 {
            return Err(wrong());
        }
        r.seams_mm
            .iter()
            .map(|&mm| {
                let px = (mm / r.mm_per_px).round();
                if px.is_finite() && px >= 0.0 && px <= r.len_px as f64 {
                    Ok(px as u32)
                } else {
                    Err(wrong())
                }
            })
            .collect::<Result<_, _>>()?
    };
    // Every seam's band inside the picture and clear of the next one's.
    let mut last = 0u32;
    for &c in &centres_px {
        if c < last + gap_px / 2 + 1 || c + gap_px / 2 + 1 > r.len_px {
            return Err(wrong());
        }
        last = c + gap_px / 2;
    }
    Ok(Side {
        count,
        centres_px,
        band_px,
    })
}

/// The stock's width and height, mm.
pub(crate) fn stock_size(s: &Stock) -> (f64, f64) {
    match s {
        Stock::Bed { w_mm, h_mm, .. } | Stock::Sheet { w_mm, h_mm, .. } => (*w_mm, *h_mm),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(len_px: u32, stock: Option<f64>, count: Option<u32>) -> SideRequest<'static> {
        SideRequest {
            axis: "vertical",
            len_px,
            mm_per_px: 1.0,
            stock_mm: stock,
            count,
            seams_mm: &[],
            overlap_mm: 3.0,
            margin_mm: 5.0,
            factor: 1,
            window_mm: 0.0,
        }
    }

    #[test]
    fn fewest_tiles_that_fit() {
        // 1200 mm on a 400 mm bed: 3 tiles of 400 leave no room for seams, 4 do.
        let s = side(&req(1200, Some(400.0), None)).unwrap();
        assert_eq!(s.count, 4);
        assert_eq!(s.centres_px, vec![300, 600, 900]);
        // An inner tile: its share, two bands, two overlaps and two margins within the bed.
        let inner = 300.0 + 2.0 * (s.band_px as f64 + 3.0) + 10.0;
        assert!(inner <= 400.0, "{inner}");
        assert!(s.band_px as f64 >= MIN_BAND_MM);
        // What fits whole is one tile.
        assert_eq!(side(&req(300, Some(400.0), None)).unwrap().count, 1);
    }

    #[test]
    fn seams_given_must_match() {
        let mut r = req(1000, None, Some(2));
        let at = [400.0];
        r.seams_mm = &at;
        assert_eq!(side(&r).unwrap().centres_px, vec![400]);
        let two = [300.0, 600.0];
        r.seams_mm = &two;
        assert!(matches!(side(&r), Err(TilesError::Seams { want: 1, .. })));
        let edge = [2.0];
        r.seams_mm = &edge;
        assert!(side(&r).is_err());
        assert!(matches!(
            side(&req(100, None, None)),
            Err(TilesError::NoStock)
        ));
    }
}
