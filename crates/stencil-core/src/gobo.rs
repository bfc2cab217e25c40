//! Gobos: a round sheet for a lighting fixture's gate, its picture in the image area.
//!
//! A disc of outside diameter OD; the fixture projects the centred image area of diameter IA. The
//! picture is inscribed in the image area (its diagonal is IA) or, with `crop`, fills it (its
//! shorter side is IA) with metal outside the circle. The rim (OD) is cut in every output.
//!
//! Letter sizes are Rosco's, from the "Rosco Labs" row of the Stage Lighting Primer's table
//! (<https://stagelightingprimer.com/slfs-gobos.html>, "Standard Sizes"): A 100 / 75 mm,
//! B 86 / 64.5 mm, M 66 / 48 mm, E 37.5 / 28 mm (OD / IA); any other size as `OD,IA` in mm.
//!
//! Polarity: metal stays where the stencil is material, so a bright subject projects dark unless
//! the tones are swapped (`--invert`): [`GoboReport::warning`] says so when most of it is clear.

use geo::{Area, Rect};

use crate::raster::{BitGrid, Gray};
use crate::vector::CutGeometry;
pub(crate) use crate::vector::Rim;

/// The table the letter sizes come from (named in the report and the help).
pub(crate) const TABLE: &str =
    "Rosco (Rosco Labs row of the Stage Lighting Primer's gobo size table, \
                         https://stagelightingprimer.com/slfs-gobos.html)";

/// Rosco's letter sizes: (letter, outside diameter mm, image area mm). See the module's notes.
pub(crate) const ROSCO: &[(&str, f64, f64)] = &[
    ("A", 100.0, 75.0),
    ("B", 86.0, 64.5),
    ("M", 66.0, 48.0),
    ("E", 37.5, 28.0),
];

/// Largest gobo accepted, mm (a 1 m disc is far beyond any fixture's gate, and a sure typo).
pub const MAX_OD_MM: f64 = 1000.0;

/// A gobo's size and how its picture is placed.
#[derive(Clone, Debug, PartialEq)]
pub struct Gobo {
    /// The letter size (`"B"`), or `None` for an `OD,IA` given in mm.
    pub letter: Option<String>,
    /// Outside diameter, mm.
    pub od_mm: f64,
    /// Image area (the opening's diameter), mm.
    pub ia_mm: f64,
    /// Fill the image area (the picture's shorter side is IA) and leave metal outside its
    /// circle, instead of inscribing the whole picture in it.
    pub crop: bool,
}

/// `--gobo SIZE`: a letter of `ROSCO` (any case) or `OD,IA` in mm.
pub fn parse(s: &str) -> Result<Gobo, String> {
    let t = s.trim();
    if let Some(&(l, od, ia)) = ROSCO.iter().find(|(l, _, _)| l.eq_ignore_ascii_case(t)) {
        return Ok(Gobo {
            letter: Some(l.into()),
            od_mm: od,
            ia_mm: ia,
            crop: false,
        });
    }
    let letters: Vec<&str> = ROSCO.iter().map(|r| r.0).collect();
    let bad = || {
        format!(
            "'{s}' is not a gobo size: use {} (Rosco's sizes) or OD,IA in mm (e.g. 53.3,38)",
            letters.join(", ")
        )
    };
    let (od, ia) = t.split_once(',').ok_or_else(bad)?;
    let (od, ia): (f64, f64) = match (od.trim().parse(), ia.trim().parse()) {
        (Ok(o), Ok(i)) => (o, i),
        _ => return Err(bad()),
    };
    if !(od.is_finite() && ia.is_finite() && ia > 0.0 && od <= MAX_OD_MM) {
        return Err(format!(
            "'{s}': the image area must be above 0 mm and the outside diameter at most {MAX_OD_MM} mm"
        ));
    }
    if ia >= od {
        return Err(format!(
            "'{s}': the image area ({ia} mm) must be smaller than the outside diameter ({od} mm): the rim holds the gobo in its holder"
        ));
    }
    Ok(Gobo {
        letter: None,
        od_mm: od,
        ia_mm: ia,
        crop: false,
    })
}

impl Gobo {
    /// The picture's width in mm for a `w` × `h` px picture: its diagonal IA (inscribed), or its
    /// shorter side IA (`crop`).
    pub fn picture_width_mm(&self, w: u32, h: u32) -> f64 {
        let (w, h) = (w.max(1) as f64, h.max(1) as f64);
        if self.crop {
            self.ia_mm * w / w.min(h)
        } else {
            self.ia_mm * w / w.hypot(h)
        }
    }

    /// The name as printed: "B (86 / 64.5 mm)" or "86 / 64.5 mm".
    pub fn name(&self) -> String {
        let d = format!("{} / {} mm", self.od_mm, self.ia_mm);
        match &self.letter {
            Some(l) => format!("{l} ({d})"),
            None => d,
        }
    }

    /// The image area's circle in pixels of a `w` × `h` picture, (cx, cy, r): what `crop` keeps.
    pub(crate) fn image_circle_px(&self, w: u32, h: u32) -> [f64; 3] {
        let r = 0.5 * (w.min(h) as f64);
        [0.5 * w as f64, 0.5 * h as f64, r]
    }
}

/// Put the gobo on a traced stencil: the rim at the picture's centre, the sheet's outline the
/// rim's square grown by `margin_mm` (what the masks cover; their registration marks sit in its
/// corners, outside the disc).
pub(crate) fn place(geom: &mut CutGeometry, gobo: &Gobo, margin_mm: f64) {
    let rim = Rim {
        centre_mm: [geom.width_mm / 2.0, geom.height_mm / 2.0],
        od_mm: gobo.od_mm,
        ia_mm: gobo.ia_mm,
    };
    let (lo, hi, m) = (rim.bounds().min(), rim.bounds().max(), margin_mm);
    geom.outline = Rect::new((lo.x - m, lo.y - m), (hi.x + m, hi.y + m));
    geom.rim = Some(rim);
}

/// The gobo's sheet in the picture's pixels: the grid `stencil.png` and `preview.png` are drawn
/// on for a gobo, so that they show the round sheet and its rim as the SVG, DXF and masks do
/// (the sheet's outline, `place`'s rim square grown by the margin, around the picture at its
/// centre; the rim a cut ring a pixel and a half wide just outside the disc, as the rim's
/// tool path runs just outside it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SheetPx {
    /// The sheet's size, px.
    pub(crate) width: u32,
    pub(crate) height: u32,
    /// Where the picture's top-left pixel lands on it.
    left: u32,
    top: u32,
    /// The rim's centre (px, the sheet's pixel corners) and its cut ring's radii, px.
    centre: [f64; 2],
    ring: [f64; 2],
}

/// Largest gobo sheet drawn, px a side: beyond it the PNGs stay the picture (a 1 m gobo at a
/// fine scale would be gigapixels).
const MAX_SHEET_PX: f64 = 20_000.0;

impl SheetPx {
    /// The sheet of a gobo placed on `geom` (`None` without a gobo, or for a sheet too large to
    /// draw) for a picture of `w` × `h` px.
    pub(crate) fn of(geom: &CutGeometry, w: u32, h: u32) -> Option<SheetPx> {
        let rim = geom.rim?;
        let mm = geom.width_mm / w.max(1) as f64;
        if !(mm > 0.0 && mm.is_finite()) {
            return None;
        }
        // The same whole number of pixels on either side (the rim is centred on the picture),
        // so the picture is the sheet's middle ([`picture_of_sheet`] finds it again).
        let o = geom.outline;
        let left = ((o.width() - geom.width_mm) / 2.0 / mm).ceil().max(0.0);
        let top = ((o.height() - geom.height_mm) / 2.0 / mm).ceil().max(0.0);
        let (sw, sh) = (2.0 * left + w as f64, 2.0 * top + h as f64);
        if sw > MAX_SHEET_PX || sh > MAX_SHEET_PX {
            return None;
        }
        let r = rim.od_mm / 2.0 / mm;
        Some(SheetPx {
            width: sw as u32,
            height: sh as u32,
            left: left as u32,
            top: top as u32,
            centre: [left + rim.centre_mm[0] / mm, top + rim.centre_mm[1] / mm],
            ring: [r, r + 1.5],
        })
    }

    /// Whether the sheet's pixel (x, y) is on the rim's cut ring (its centre within the ring).
    fn on_rim(&self, x: u32, y: u32) -> bool {
        let d = (x as f64 + 0.5 - self.centre[0]).hypot(y as f64 + 0.5 - self.centre[1]);
        d >= self.ring[0] && d < self.ring[1]
    }

    /// The picture's pixel at the sheet's (x, y), if the picture covers it.
    fn picture_px(&self, x: u32, y: u32, w: u32, h: u32) -> Option<(u32, u32)> {
        let (px, py) = (x.checked_sub(self.left)?, y.checked_sub(self.top)?);
        (px < w && py < h).then_some((px, py))
    }

    /// `bits` on the sheet: material around the picture, the rim cut.
    pub(crate) fn bits(&self, bits: &BitGrid) -> BitGrid {
        BitGrid::from_fn(self.width, self.height, |x, y| {
            !self.on_rim(x, y)
                && self
                    .picture_px(x, y, bits.width, bits.height)
                    .is_none_or(|(px, py)| bits.get(px, py))
        })
    }

    /// `gray` on the sheet: white around the picture (the rim's colour comes from the bits).
    pub(crate) fn gray(&self, gray: &Gray) -> Gray {
        let mut out = Gray::new(self.width, self.height, 1.0);
        for y in 0..gray.height {
            let row = gray.idx(0, y);
            let at = out.idx(self.left, self.top + y);
            out.data[at..at + gray.width as usize]
                .copy_from_slice(&gray.data[row..row + gray.width as usize]);
        }
        out
    }

    /// A picture's pixel index (of a `w` px wide picture) as the sheet's.
    pub(crate) fn index(&self, i: u32, w: u32) -> u32 {
        let (x, y) = (i % w.max(1), i / w.max(1));
        (self.top + y) * self.width + self.left + x
    }
}

/// The picture's `w` × `h` pixels of a gobo's `stencil.png` drawn on its sheet (the picture in
/// its middle, the same number of pixels on either side); `None` when `bits` is not such a
/// sheet (the picture itself, or another size). Why: `stencil check` of a gobo's folder judges the
/// picture as `make` did, not the disc its rim frees.
pub fn picture_of_sheet(bits: &BitGrid, w: u32, h: u32) -> Option<BitGrid> {
    let (dw, dh) = (bits.width.checked_sub(w)?, bits.height.checked_sub(h)?);
    if (dw == 0 && dh == 0) || dw % 2 != 0 || dh % 2 != 0 {
        return None;
    }
    let (left, top) = (dw / 2, dh / 2);
    Some(BitGrid::from_fn(w, h, |x, y| bits.get(x + left, y + top)))
}

/// What the gobo is, for report.json and the console.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GoboReport {
    /// The letter size, when one was given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub letter: Option<String>,
    /// Where the letter sizes come from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub table: Option<String>,
    /// Outside diameter, mm.
    pub od_mm: f64,
    /// Image area diameter, mm.
    pub ia_mm: f64,
    /// "inscribed" (the whole picture inside the image area) or "cropped" (the image area
    /// filled, metal outside its circle).
    pub placement: String,
    /// The picture on the gobo, mm.
    pub picture_mm: [f64; 2],
    /// Metal and light, in words.
    pub polarity: String,
    /// The share of the image area that is cut (passes light), percent.
    pub clear_pct: f64,
    /// Set when most of the image area passes light while the picture's light parts stay metal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
}

pub use crate::export::POLARITY;

/// The gobo's report: its sizes, how much of the image area passes light, and the warning when
/// that is most of it with the tones as they are (`tone_inverted`: `--invert` was given).
pub(crate) fn report(geom: &CutGeometry, gobo: &Gobo, tone_inverted: bool) -> GoboReport {
    let ia_area = std::f64::consts::PI * gobo.ia_mm * gobo.ia_mm / 4.0;
    // Every cut is inside the image area (inscribed: inside the picture, which is inside it;
    // cropped: outside its circle is metal), so their area is the clear area.
    let clear_pct = 100.0 * geom.design_cuts.unsigned_area() / ia_area;
    let warning = (clear_pct > 50.0 && !tone_inverted).then(|| {
        format!(
            "{clear_pct:.0} % of the gobo's image area passes light and the picture's light parts \
             stay as metal: a bright subject on a dark ground would be projected dark in a field \
             of light; swapping the tones (metal where the picture is dark) projects it as light"
        )
    });
    GoboReport {
        letter: gobo.letter.clone(),
        table: gobo.letter.as_ref().map(|_| TABLE.to_string()),
        od_mm: gobo.od_mm,
        ia_mm: gobo.ia_mm,
        placement: if gobo.crop { "cropped" } else { "inscribed" }.into(),
        picture_mm: [geom.width_mm, geom.height_mm],
        polarity: POLARITY.into(),
        clear_pct,
        warning,
    }
}

/// The disc of OD as a polygon.
#[cfg(test)]
fn disc(rim: &Rim) -> geo::Polygon<f64> {
    geo::Polygon::new(rim.ring(rim.od_mm / 2.0), vec![])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn letters_come_from_one_table_and_other_sizes_in_mm() {
        let b = parse("b").unwrap();
        assert_eq!(
            (b.od_mm, b.ia_mm, b.letter.as_deref()),
            (86.0, 64.5, Some("B"))
        );
        assert_eq!(parse("A").unwrap().od_mm, 100.0);
        let d = parse("53.3, 38").unwrap();
        assert_eq!((d.od_mm, d.ia_mm, d.letter), (53.3, 38.0, None));
        for bad in ["Q", "40,40", "30,40", "0,0", "2000,10", "x,y", "NaN,3"] {
            assert!(parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_picture_is_inscribed_in_the_image_area_or_fills_it() {
        let mut b = parse("B").unwrap();
        // 400 x 300 px: diagonal 500 px = 64.5 mm, so 51.6 mm wide.
        assert!((b.picture_width_mm(400, 300) - 51.6).abs() < 1e-9);
        b.crop = true;
        // The shorter side is the image area: 300 px = 64.5 mm, 86 mm wide.
        assert!((b.picture_width_mm(400, 300) - 86.0).abs() < 1e-9);
    }

    #[test]
    fn the_rim_ring_stays_within_its_tolerance_of_the_circle() {
        let rim = Rim {
            centre_mm: [10.0, 20.0],
            od_mm: 86.0,
            ia_mm: 64.5,
        };
        let r = rim.ring(43.0);
        assert_eq!(r.0.first(), r.0.last());
        for w in r.0.windows(2) {
            let m = [
                (w[0].x + w[1].x) / 2.0 - 10.0,
                (w[0].y + w[1].y) / 2.0 - 20.0,
            ];
            let d = 43.0 - m[0].hypot(m[1]);
            assert!((0.0..=0.005 + 1e-12).contains(&d), "{d}");
        }
        let a = disc(&rim).unsigned_area();
        assert!((a - std::f64::consts::PI * 43.0 * 43.0).abs() < 1.0, "{a}");
    }
}
