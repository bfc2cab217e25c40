//! Mesh rendering options (`make` and `tone` on an .obj).

use clap::{Args, ValueEnum};

use stencil_core::tone::mesh::{LineMode, MeshConfig, RenderSize};

/// Options that apply when the input is an OBJ mesh.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Mesh input (.obj)")]
pub struct MeshArgs {
    /// Camera position on its orbit around the model: azimuth around the vertical (Y) axis and
    /// elevation above the horizon, in degrees ("0,0" looks along -Z at the model's front).
    #[arg(
        long,
        value_name = "AZ,EL",
        default_value = "30,20",
        allow_hyphen_values = true
    )]
    pub view: String,
    /// Camera distance from the model's centre, in bounding-sphere radii (> 1) [default: the
    /// distance at which the bounding sphere fills --fov]. Closer = stronger perspective.
    #[arg(long, value_name = "RADII")]
    pub distance: Option<f32>,
    /// Lens field of view in degrees. The model is always framed to fill the image; the lens sets
    /// the default distance, hence how strong the perspective looks.
    #[arg(long, value_name = "DEG", default_value_t = 30.0)]
    pub fov: f32,
    /// Orthographic projection instead of perspective (no foreshortening; --fov is ignored).
    #[arg(long)]
    pub ortho: bool,
    /// Image size: "N" pixels on the long side (the other side follows the model's outline), or
    /// "WxH" exactly. The model fills it with a 5% margin.
    #[arg(long, value_name = "N|WxH", default_value = "1024")]
    pub size: String,
    /// Point light position relative to the model's centre, in bounding radii, in the camera's
    /// frame: X right, Y up, Z towards the viewer. The default is above, to the left and in front.
    #[arg(
        long,
        value_name = "X,Y,Z",
        default_value = "-1.5,1.5,1.5",
        allow_hyphen_values = true
    )]
    pub light: String,
    /// Weight of the Blinn-Phong highlight (0 = matte).
    #[arg(long, default_value_t = 0.3)]
    pub specular: f32,
    /// Blinn-Phong exponent: larger = smaller, sharper highlight.
    #[arg(long, default_value_t = 32.0)]
    pub shininess: f32,
    /// Lines cut into the stencil: none, silhouettes (occluding contours), or silhouettes plus
    /// suggestive contours (DeCarlo et al. 2003).
    #[arg(long, value_enum, default_value = "suggestive")]
    pub lines: LinesArg,
    /// Line thickness in output pixels. `make` widens lines that are thinner than the material's
    /// smallest feature (see --filter-radius), so the filter does not erase them.
    #[arg(long, value_name = "PX", default_value_t = 3.0)]
    pub line_px: f32,
    /// Render at K times the size and average down before thresholding (1..4; anti-aliasing).
    #[arg(long, value_name = "K", default_value_t = 2)]
    pub supersample: u32,
    /// Suggestive contours are drawn where the radial curvature's derivative (times radius²)
    /// exceeds this: higher = fewer, stronger contours.
    #[arg(long, value_name = "T", default_value_t = 1.0)]
    pub contour_threshold: f32,
}

/// `--lines` values.
#[derive(ValueEnum, Debug, Clone, Copy)]
pub enum LinesArg {
    None,
    Silhouette,
    Suggestive,
}

fn numbers<const N: usize>(flag: &str, s: &str, what: &str) -> anyhow::Result<[f32; N]> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let bad = || anyhow::anyhow!("{flag} '{s}': expected {what}");
    if parts.len() != N {
        return Err(bad());
    }
    let mut out = [0f32; N];
    for (o, p) in out.iter_mut().zip(&parts) {
        *o = p.parse::<f32>().map_err(|_| bad())?;
        if !o.is_finite() {
            return Err(bad());
        }
    }
    Ok(out)
}

fn parse_size(s: &str) -> anyhow::Result<RenderSize> {
    let bad = || {
        anyhow::anyhow!(
            "--size '{s}': expected N (long side) or WxH in pixels, such as 1024 or 800x600"
        )
    };
    if let Some((w, h)) = s.split_once(['x', 'X']) {
        let w: u32 = w.trim().parse().map_err(|_| bad())?;
        let h: u32 = h.trim().parse().map_err(|_| bad())?;
        Ok(RenderSize::Exact {
            width: w,
            height: h,
        })
    } else {
        Ok(RenderSize::LongSide(s.trim().parse().map_err(|_| bad())?))
    }
}

impl MeshArgs {
    pub fn to_config(&self) -> anyhow::Result<MeshConfig> {
        let [az, el] = numbers::<2>("--view", &self.view, "AZ,EL in degrees, such as 30,20")?;
        let light = numbers::<3>(
            "--light",
            &self.light,
            "X,Y,Z in bounding radii, such as -1.5,1.5,1.5",
        )?;
        let cfg = MeshConfig {
            azimuth_deg: az,
            elevation_deg: el,
            distance: self.distance,
            fov_deg: (!self.ortho).then_some(self.fov),
            size: parse_size(&self.size)?,
            light,
            specular: self.specular,
            shininess: self.shininess,
            lines: match self.lines {
                LinesArg::None => LineMode::None,
                LinesArg::Silhouette => LineMode::Silhouette,
                LinesArg::Suggestive => LineMode::Suggestive,
            },
            line_px: self.line_px,
            min_line_px: 0.0,
            supersample: self.supersample,
            contour_threshold: self.contour_threshold,
        };
        cfg.validate()?;
        Ok(cfg)
    }
}
