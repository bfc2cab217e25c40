//! Mesh rendering options (`make` and `tone` on an .obj).

use clap::{Args, ValueEnum};

use stencil_core::tone::mesh::{LineMode, MeshConfig, RenderSize, Up};

/// Options that apply when the input is an OBJ mesh.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Mesh input (.obj)")]
pub struct MeshArgs {
    /// The view: "AZ,EL" in degrees, the camera's azimuth around the model's up axis (--up)
    /// and elevation above its horizon ("0,0" looks at the model's front), or a name: front,
    /// back, left, right, side (= right), top, bottom, three-quarter (= 30,20).
    #[arg(
        long,
        value_name = "AZ,EL|NAME",
        default_value = "30,20",
        allow_hyphen_values = true
    )]
    pub view: String,
    /// The model's up axis: X, Y, Z, -X, -Y or -Z. Y for most OBJ exports (Blender's default
    /// OBJ export turns Z-up to Y-up); Z for CAD and many scanners. The view's azimuth turns
    /// around it, "top" looks down it.
    #[arg(
        long,
        value_name = "AXIS",
        default_value = "Y",
        allow_hyphen_values = true
    )]
    pub up: String,
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
    /// The key light: "AZ,EL" in degrees relative to the view, as a photographer places it
    /// (0,0 = from the camera, 90,0 = from the right, -90,0 = from the left, 0,90 = from above,
    /// 180,.. = from behind), at 3 bounding radii from the model's centre; or "X,Y,Z", a point
    /// light's position in bounding radii in the camera's frame (X right, Y up, Z towards the
    /// viewer). The default is above, to the left and in front.
    #[arg(
        long,
        value_name = "AZ,EL|X,Y,Z",
        default_value = "-1.5,1.5,1.5",
        allow_hyphen_values = true
    )]
    pub light: String,
    /// Ambient light, 0..1 (below 1): the share of light that comes from everywhere, so the side
    /// the key leaves dark shows this much gray instead of black (a cut) [default: 0, none].
    #[arg(long, value_name = "A", default_value_t = 0.0)]
    pub ambient: f32,
    /// A fill light of this strength relative to the key (0..1; 0 = none), diffuse, placed as the
    /// key mirrored left-right across the view: it lifts the shadow side.
    #[arg(long, value_name = "F", default_value_t = 0.0)]
    pub fill: f32,
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

/// The key light's distance from the model's centre when given by direction, in bounding radii:
/// close enough that the light falls off across the model as a studio lamp's does (the default
/// light stands at 2.6), far enough to light a whole side.
pub const LIGHT_DISTANCE_RADII: f32 = 3.0;

/// `--view`: "AZ,EL" or a name (see [`MeshArgs::view`]).
fn view_angles(s: &str) -> anyhow::Result<[f32; 2]> {
    Ok(match s.trim().to_ascii_lowercase().as_str() {
        "front" => [0.0, 0.0],
        "back" => [180.0, 0.0],
        "left" => [-90.0, 0.0],
        "right" | "side" => [90.0, 0.0],
        "top" => [0.0, 90.0],
        "bottom" => [0.0, -90.0],
        "three-quarter" => [30.0, 20.0],
        _ => numbers::<2>(
            "--view",
            s,
            "AZ,EL in degrees, such as 30,20, or a view: front, back, left, right, side, top, \
             bottom, three-quarter",
        )?,
    })
}

/// `--light`: "AZ,EL" (a direction relative to the view, placed at [`LIGHT_DISTANCE_RADII`]) or
/// "X,Y,Z" (a position), as the position in the camera's frame the renderer reads.
fn light_position(s: &str) -> anyhow::Result<[f32; 3]> {
    let what = "AZ,EL in degrees relative to the view, such as -45,30, or X,Y,Z in bounding \
                radii, such as -1.5,1.5,1.5";
    if s.split(',').count() == 2 {
        let [az, el] = numbers::<2>("--light", s, what)?;
        if !(-90.0..=90.0).contains(&el) {
            anyhow::bail!("--light '{s}': elevation {el} is not a direction: use -90..90 degrees");
        }
        let (az, el) = (az.to_radians(), el.to_radians());
        let d = LIGHT_DISTANCE_RADII;
        return Ok([
            d * az.sin() * el.cos(),
            d * el.sin(),
            d * az.cos() * el.cos(),
        ]);
    }
    numbers::<3>("--light", s, what)
}

/// `--up`: an axis with an optional sign.
fn parse_up(s: &str) -> anyhow::Result<Up> {
    Ok(match s.trim().to_ascii_uppercase().as_str() {
        "X" | "+X" => Up::X,
        "Y" | "+Y" => Up::Y,
        "Z" | "+Z" => Up::Z,
        "-X" => Up::NegX,
        "-Y" => Up::NegY,
        "-Z" => Up::NegZ,
        _ => anyhow::bail!("--up '{s}': expected an axis: X, Y, Z, -X, -Y or -Z"),
    })
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
        let [az, el] = view_angles(&self.view)?;
        let light = light_position(&self.light)?;
        let cfg = MeshConfig {
            azimuth_deg: az,
            elevation_deg: el,
            distance: self.distance,
            fov_deg: (!self.ortho).then_some(self.fov),
            size: parse_size(&self.size)?,
            light,
            ambient: self.ambient,
            fill: self.fill,
            up: parse_up(&self.up)?,
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
