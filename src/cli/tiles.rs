//! `stencil make`'s tile options (a stencil larger than the bed or sheet, cut in tiles along
//! seams through the quiet parts of the picture), running them and saying what was made.

use clap::Args;

use stencil_core::fit::Stock;
use stencil_core::pipeline::MakeConfig;
use stencil_core::tiles::{Grid, MarkPlace, Tiled, TilesConfig, TilesError, DEFAULT_OVERLAP_MM};

/// `auto` or `CxR`.
fn parse_grid(s: &str) -> Result<Grid, String> {
    if s.eq_ignore_ascii_case("auto") {
        return Ok(Grid::Auto);
    }
    let bad = || format!("'{s}' is not a tile grid: use auto, or CxR such as 3x2 (columns x rows)");
    let lower = s.to_ascii_lowercase();
    let (c, r) = lower.split_once('x').ok_or_else(bad)?;
    let n = |v: &str| v.trim().parse::<u32>().map_err(|_| bad());
    let (cols, rows) = (n(c)?, n(r)?);
    let most = stencil_core::limits::MAX_TILES_PER_SIDE;
    if cols == 0 || rows == 0 || cols > most || rows > most {
        return Err(format!("'{s}': from 1 to {most} tiles along each side"));
    }
    Ok(Grid::Fixed { cols, rows })
}

/// A list of seam places, mm.
fn parse_mm(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!(
            "'{s}' is not a place on the picture (mm from its edge, >= 0)"
        )),
    }
}

/// Tile options.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Tiles")]
pub struct TileArgs {
    /// Cut a stencil larger than the bed or sheet as tiles: `auto` (the fewest tiles that fit
    /// --sheet, or else the machine's bed, --machine) or CxR (columns x rows, e.g. 3x2). Each tile
    /// is a whole stencil (one piece, bridged, checked) in OUT/tile-R-C/; the seams between them
    /// follow the picture's light, quiet parts; OUT/tiles.png maps them (numbered in cutting
    /// order) and OUT/report.json gives each tile's place and size.
    #[arg(long, value_name = "auto|CxR", value_parser = parse_grid)]
    pub tiles: Option<Grid>,
    /// With --tiles: how far each tile keeps a strip of material past its seams, mm (the
    /// tiles overlap by twice this on the wall; the registration pin holes sit in it).
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_OVERLAP_MM, requires = "tiles")]
    pub tile_overlap_mm: f64,
    /// With --tiles: where the vertical seams run, mm from the picture's left edge,
    /// comma-separated, one per seam (default: evenly); each still finds its own path near there.
    #[arg(long, value_name = "MM,...", value_delimiter = ',', value_parser = parse_mm, requires = "tiles")]
    pub seam_x: Vec<f64>,
    /// With --tiles: where the horizontal seams run, mm from the picture's top edge.
    #[arg(long, value_name = "MM,...", value_delimiter = ',', value_parser = parse_mm, requires = "tiles")]
    pub seam_y: Vec<f64>,
}

impl TileArgs {
    /// Whether tiles were asked for.
    pub fn asked(&self) -> bool {
        self.tiles.is_some()
    }

    /// The tiles asked for, fitted to `sheet` or else the machine's bed (`bed` loads it).
    pub fn config(
        &self,
        sheet: Option<&Stock>,
        bed: impl FnOnce() -> anyhow::Result<Stock>,
    ) -> anyhow::Result<Option<TilesConfig>> {
        let Some(grid) = self.tiles else {
            return Ok(None);
        };
        let stock = match sheet {
            Some(s) => s.clone(),
            None => bed()?,
        };
        Ok(Some(TilesConfig {
            grid,
            overlap_mm: self.tile_overlap_mm,
            stock: Some(stock),
            seam_x_mm: self.seam_x.clone(),
            seam_y_mm: self.seam_y.clone(),
            layers: None,
        }))
    }
}

/// What to change when a tiled run is refused.
pub fn help(t: &TilesError) -> &'static str {
    match t {
        TilesError::NoStock => "give --sheet or --machine, or --tiles CxR",
        TilesError::StockTooSmall { .. } => "use a smaller --margin-mm or --tile-overlap-mm",
        TilesError::TooMany { .. } => "make it smaller (--width-mm) or use a larger --sheet",
        TilesError::TileTooLarge { .. } => {
            "use more tiles (--tiles auto finds how many), a smaller --tile-overlap-mm, or move \
             --seam-x/--seam-y"
        }
        TilesError::Seams { .. } => "see --seam-x and --seam-y",
        TilesError::Overlap(_) => "see --tile-overlap-mm",
        TilesError::Unsupported(_) => "leave out --tiles, or that option",
    }
}

/// What a tiled run made, as `make` says it.
pub fn print(cfg: &MakeConfig, t: &Tiled) {
    print_tiles(cfg, t);
    let failed = t.report.tiles.iter().filter(|t| !t.check_passed).count();
    if failed > 0 {
        eprintln!(
            "warning: {failed} tile(s) failed the check (their report.json lists why; --allow-thin wrote them)"
        );
    }
}

fn print_tiles(cfg: &MakeConfig, t: &Tiled) {
    let r = &t.report;
    println!(
        "{}: {} x {} tiles of a {:.1} x {:.1} mm stencil{}, overlap {} mm past each seam, material {}",
        cfg.out_dir.display(),
        r.grid[0],
        r.grid[1],
        r.width_mm,
        r.height_mm,
        r.stock
            .as_ref()
            .map(|(name, _, _)| format!(" for {name}"))
            .unwrap_or_default(),
        r.overlap_mm,
        cfg.physical.material.name,
    );
    for s in &r.seams {
        println!(
            "  seam {} at {:.1} mm (within {:.1} mm): {:.1} mm long, {:.1} mm through the cut in {} run(s) (the earlier tile's strip bridges them), {:.1} mm through features thinner than the material's smallest",
            s.axis,
            s.at_mm,
            s.band_mm,
            s.length_mm,
            s.through_cut_mm,
            s.bridges_mm.len(),
            s.through_thin_mm
        );
    }
    for tile in &r.tiles {
        println!(
            "  {} {}: at {:.1},{:.1} mm, {:.1} x {:.1} mm sheet, {} islands, {} bridges, {} pin hole(s){}",
            tile.number,
            tile.folder,
            tile.x_mm,
            tile.y_mm,
            tile.sheet_mm[0],
            tile.sheet_mm[1],
            tile.islands,
            tile.bridges,
            tile.pins_mm.len(),
            if tile.check_passed { "" } else { " (CHECK FAILED)" }
        );
        for l in tile.layers.iter().chain(&tile.fill_in) {
            println!(
                "    {}: level {}, {} islands, {} bridges{}",
                l.folder,
                l.level,
                l.islands,
                l.bridges,
                if l.check_passed {
                    ""
                } else {
                    " (CHECK FAILED)"
                }
            );
        }
    }
    let marks: usize = r.seams.iter().map(|s| s.marks.len()).sum();
    let pads = r.seams.iter().flat_map(|s| &s.marks);
    let pads = pads.filter(|m| m.place == MarkPlace::Pad).count();
    println!(
        "tiles.png maps the seams and numbers the tiles in cutting order; {marks} registration pin holes {:.1} mm across on the seams, each through both tiles (pin or tape them together there){}",
        r.pin_mm,
        if pads > 0 {
            format!(", {pads} of them on a pad of material put into a dark part of the picture")
        } else {
            String::new()
        }
    );
    let unregistered: usize = r.seams.iter().map(|s| s.unregistered_segments).sum();
    if unregistered > 0 {
        eprintln!(
            "warning: {unregistered} pair(s) of tiles have fewer than two registration pin holes (the overlap is too narrow for one, or thin features fill the seam): line them up by the picture (a wider --tile-overlap-mm makes room)"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids() {
        assert_eq!(parse_grid("auto"), Ok(Grid::Auto));
        assert_eq!(parse_grid("3x2"), Ok(Grid::Fixed { cols: 3, rows: 2 }));
        assert!(parse_grid("3").unwrap_err().contains("CxR"));
        assert!(parse_grid("0x2").unwrap_err().contains("from 1 to"));
    }
}
