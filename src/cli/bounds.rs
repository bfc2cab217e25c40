//! Option parsers that hold numbers to [`stencil_core::limits`]: each refusal names the range. (Ranges
//! that depend on the picture, such as --width-mm's, are checked once its size is known.)

use std::ops::RangeInclusive;

use stencil_core::limits::{self, num};

/// A finite number > 0 (a size whose range depends on the picture).
pub fn positive(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a size: use a finite number > 0")),
    }
}

fn within(v: f64, lo: f64, hi: f64, unit: &str) -> Result<f64, String> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "{} is out of range: use {} to {}{unit}",
            num(v),
            num(lo),
            num(hi)
        ))
    }
}

fn number(s: &str) -> Result<f64, String> {
    s.trim()
        .parse::<f64>()
        .map_err(|_| format!("'{s}' is not a number"))
}

/// A margin in mm: from one smallest pixel to [`limits::MAX_MARGIN_MM`].
pub fn margin_value(v: f64) -> Result<f64, String> {
    within(v, limits::MIN_PIXEL_MM, limits::MAX_MARGIN_MM, " mm")
}

/// `--margin-mm`.
pub fn margin_mm(s: &str) -> Result<f64, String> {
    margin_value(number(s)?)
}

/// A simplification tolerance in mm: 0 (no simplification), or from one smallest pixel to
/// [`limits::MAX_TOLERANCE_MM`].
pub fn tolerance_value(v: f64) -> Result<f64, String> {
    if v == 0.0 {
        return Ok(0.0);
    }
    within(
        v,
        limits::MIN_PIXEL_MM,
        limits::MAX_TOLERANCE_MM,
        " mm (or 0)",
    )
}

/// `--tolerance-mm`.
pub fn tolerance_mm(s: &str) -> Result<f64, String> {
    tolerance_value(number(s)?)
}

/// `--mask-dpi`: within [`limits::MASK_DPI`].
pub fn mask_dpi(s: &str) -> Result<f64, String> {
    within(
        number(s)?,
        *limits::MASK_DPI.start(),
        *limits::MASK_DPI.end(),
        " dpi",
    )
}

/// `--max-pixels`: 1 to [`limits::MAX_PIXELS_CEILING`]; also written `40e6` or `40_000_000`.
pub fn max_pixels(s: &str) -> Result<u64, String> {
    let t = s.trim().replace('_', "");
    let v = t
        .parse::<u64>()
        .ok()
        .or_else(|| {
            t.parse::<f64>()
                .ok()
                .filter(|v| v.fract() == 0.0 && *v >= 0.0 && *v <= u64::MAX as f64)
                .map(|v| v as u64)
        })
        .ok_or_else(|| format!("'{s}' is not a number of pixels"))?;
    if (1..=limits::MAX_PIXELS_CEILING).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "'{s}' is out of range: use 1 to {} (at {} megapixels make needs about 4.5 GB of \
             memory and half a minute)",
            limits::MAX_PIXELS_CEILING,
            limits::MAX_PIXELS_CEILING / 1_000_000
        ))
    }
}

/// A number option that must lie in `range` (clap's message names the option and the value; this
/// says the range).
pub fn number_in(s: &str, range: RangeInclusive<f64>, unit: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if range.contains(&v) => Ok(v),
        _ => Err(format!(
            "must be a number from {} to {}{unit}",
            range.start(),
            range.end()
        )),
    }
}

/// `--timeout-s`: from a tenth of a second (a reply takes milliseconds) to an hour (Grbl answers
/// a status query within a fraction of a second, even mid-move).
pub fn parse_timeout(s: &str) -> Result<f64, String> {
    number_in(s, 0.1..=3600.0, " seconds")
}

/// `--offset X,Y`: a place on some bed. Beyond the largest bed a profile may have (10 m), no
/// job can be on the bed, and a number like 1e308 swallowed the job's size in the bed check
/// ("the job (0.0 x 0.0 mm)"), so it is refused here, as the offset it is.
pub fn parse_offset(s: &str) -> Result<[f64; 2], String> {
    let bad = || format!("'{s}' is not an offset: use X,Y in mm, e.g. 10,20");
    let (x, y) = s.split_once(',').ok_or_else(bad)?;
    let x: f64 = x.trim().parse().map_err(|_| bad())?;
    let y: f64 = y.trim().parse().map_err(|_| bad())?;
    if !(x.is_finite() && y.is_finite()) {
        return Err(bad());
    }
    let far = *stencil_gcode::bounds::BED_MM.end();
    if x.abs() > far || y.abs() > far {
        return Err(format!(
            "'{s}' is beyond any machine's bed: X and Y must be within ±{far} mm (the largest bed \
             a machine profile may have)"
        ));
    }
    Ok([x, y])
}

/// `--feed`, `--frame-feed`, `--speed`: what a profile's feeds may be (the machine's own max is
/// checked once the profile is loaded or the job planned).
pub fn parse_feed(s: &str) -> Result<f64, String> {
    number_in(s, stencil_gcode::bounds::FEED_MM_MIN, " mm/min")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_hold() {
        assert_eq!(max_pixels("40e6"), Ok(40_000_000));
        assert_eq!(max_pixels("1_000"), Ok(1000));
        assert!(max_pixels("0").is_err());
        assert!(max_pixels("1e12").unwrap_err().contains("200000000"));
        assert_eq!(tolerance_mm("0"), Ok(0.0));
        assert!(tolerance_mm("1e-300").is_err());
        assert!(tolerance_mm("nan").is_err());
        assert!(margin_mm("1e300").unwrap_err().contains("0.001 to 1000"));
        assert!(mask_dpi("1e-300").is_err());
        assert!(positive("inf").is_err());
    }
}
