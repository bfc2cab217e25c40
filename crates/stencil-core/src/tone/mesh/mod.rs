//! Stage 1 from a mesh: a CPU toon renderer. Load an OBJ ([`load()`]), orbit a camera around its
//! bounding sphere (`camera`), rasterise a visibility buffer (`visibility`), shade it with a point
//! light close to the model (`shade`), draw silhouettes and suggestive contours (`lines`, from
//! the curvature of `curvature`), downsample the supersampled result, and threshold it.
//!
//! The two tones: a model pixel at or above the threshold level is material, one below it is cut
//! (swapped by `invert`); lines are always cut; the background, the sheet around the model, is always
//! material, so the model's outline is part of the stencil.

pub(crate) mod camera;
pub(crate) mod curvature;
pub(crate) mod error;
pub(crate) mod lines;
pub(crate) mod load;
pub(crate) mod shade;
#[cfg(test)]
#[path = "../../../tests/support/shapes.rs"]
mod shapes;
pub(crate) mod visibility;

use std::path::Path;
use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;

use crate::raster::{BitGrid, Gray, TwoTone};
use crate::timing::Timings;
use crate::tone::level::{is_light, otsu_level, Threshold};

pub use camera::{Camera, Orbit, RenderSize, Up};
pub use error::{MeshError, MeshSetting};
pub use lines::LineMode;
pub use load::{load, Mesh};

/// Refuse renders with more working pixels (size × supersample²) than this.
pub(crate) use crate::limits::MESH_MAX_WORKING_PIXELS as MAX_WORKING_PIXELS;

/// Options of the mesh renderer. Lengths are in bounding radii of the model, angles in degrees.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshConfig {
    /// Camera azimuth around the vertical (Y) axis; 0 looks from +Z towards -Z.
    pub azimuth_deg: f32,
    /// Camera elevation above the horizontal plane, -90..90.
    pub elevation_deg: f32,
    /// Eye distance from the centre of the bounding sphere, > 1. `None`: the distance at which the
    /// bounding sphere just fills the field of view.
    pub distance: Option<f32>,
    /// Field of view of the perspective lens; `None` = orthographic projection.
    pub fov_deg: Option<f32>,
    /// The rendering's size in pixels.
    pub size: RenderSize,
    /// Point light in the camera's frame (x right, y up, z towards the viewer) relative to the
    /// model's centre.
    pub light: [f32; 3],
    /// Light from everywhere, 0..1: the side the light leaves dark shows this much (see
    /// `shade::Light::ambient`).
    pub ambient: f32,
    /// A fill light of this strength relative to the key (0 = none), diffuse only, placed as the
    /// key mirrored left-right across the view: it lifts the key's shadow side.
    pub fill: f32,
    /// The model's up axis: the view's azimuth turns around it, its elevation rises towards it.
    pub up: Up,
    /// Strength of the highlight, 0 (matte) to 10.
    pub specular: f32,
    /// Phong exponent: the higher, the smaller the highlight.
    pub shininess: f32,
    /// Which lines to draw as cuts.
    pub lines: LineMode,
    /// Line thickness in output pixels.
    pub line_px: f32,
    /// Lines are drawn at least this wide (output pixels). `make` sets it from the material's
    /// smallest feature, so the topological filter, which removes cuts thinner than the material
    /// can hold, keeps the lines. 0 = no minimum.
    pub min_line_px: f32,
    /// Render at this many times the size, then average down (anti-aliasing), 1..=4.
    pub supersample: u32,
    /// Suggestive contours are kept where D_w κr·radius² exceeds this (DeCarlo's t_d): higher =
    /// fewer, stronger contours.
    pub contour_threshold: f32,
}

impl Default for MeshConfig {
    fn default() -> Self {
        MeshConfig {
            azimuth_deg: 30.0,
            elevation_deg: 20.0,
            distance: None,
            fov_deg: Some(30.0),
            size: RenderSize::LongSide(1024),
            light: [-1.5, 1.5, 1.5],
            ambient: 0.0,
            fill: 0.0,
            up: Up::Y,
            specular: 0.3,
            shininess: 32.0,
            lines: LineMode::Suggestive,
            line_px: 3.0,
            min_line_px: 0.0,
            supersample: 2,
            contour_threshold: 1.0,
        }
    }
}

impl MeshConfig {
    /// Check every setting; the error holds the setting and its value ([`MeshSetting`]).
    pub fn validate(&self) -> Result<(), MeshError> {
        self.check_view()
            .and_then(|()| self.check_size())
            .and_then(|()| self.check_shading())
            .map_err(MeshError::Setting)
    }

    /// The camera: a view, a distance outside the model, a lens.
    fn check_view(&self) -> Result<(), MeshSetting> {
        if !self.azimuth_deg.is_finite() || !(-90.0..=90.0).contains(&self.elevation_deg) {
            return Err(MeshSetting::View {
                azimuth_deg: self.azimuth_deg,
                elevation_deg: self.elevation_deg,
            });
        }
        if let Some(d) = self.distance {
            if !(d.is_finite() && d > 1.0 && d <= 1000.0) {
                return Err(MeshSetting::Distance(d));
            }
        }
        if let Some(f) = self.fov_deg {
            if !(f.is_finite() && f > 0.5 && f < 170.0) {
                return Err(MeshSetting::Fov(f));
            }
        }
        Ok(())
    }

    /// The picture: large enough to draw, and a bounded amount of work once supersampled.
    fn check_size(&self) -> Result<(), MeshSetting> {
        let (width, height) = match self.size {
            RenderSize::LongSide(n) => (n, n),
            RenderSize::Exact { width, height } => (width, height),
        };
        if width < 16 || height < 16 {
            return Err(MeshSetting::TooSmall { width, height });
        }
        if !(1..=4).contains(&self.supersample) {
            return Err(MeshSetting::Supersample(self.supersample));
        }
        let working = width as u64 * height as u64 * (self.supersample as u64).pow(2);
        if working > MAX_WORKING_PIXELS {
            return Err(MeshSetting::TooMuchWork {
                width,
                height,
                supersample: self.supersample,
                megapixels: working as f64 / 1e6,
                limit_megapixels: MAX_WORKING_PIXELS as f64 / 1e6,
            });
        }
        Ok(())
    }

    /// The light, the highlight and the lines.
    fn check_shading(&self) -> Result<(), MeshSetting> {
        if !self
            .light
            .iter()
            .all(|v| v.is_finite() && v.abs() <= 1000.0)
        {
            return Err(MeshSetting::Light(self.light));
        }
        if !(self.ambient.is_finite() && (0.0..1.0).contains(&self.ambient)) {
            return Err(MeshSetting::Ambient(self.ambient));
        }
        if !(self.fill.is_finite() && (0.0..=1.0).contains(&self.fill)) {
            return Err(MeshSetting::Fill(self.fill));
        }
        if !(self.specular.is_finite() && (0.0..=10.0).contains(&self.specular)) {
            return Err(MeshSetting::Specular(self.specular));
        }
        if !(self.shininess.is_finite() && (1.0..=10_000.0).contains(&self.shininess)) {
            return Err(MeshSetting::Shininess(self.shininess));
        }
        if !(self.line_px.is_finite() && (0.5..=64.0).contains(&self.line_px)) {
            return Err(MeshSetting::LinePx(self.line_px));
        }
        if !(self.contour_threshold.is_finite() && self.contour_threshold >= 0.0) {
            return Err(MeshSetting::ContourThreshold(self.contour_threshold));
        }
        Ok(())
    }

    /// The output width the image will have at most (the long side, or the exact width).
    pub(crate) fn max_width_px(&self) -> u32 {
        match self.size {
            RenderSize::LongSide(n) => n,
            RenderSize::Exact { width, .. } => width,
        }
    }

    /// The default distance for the lens, or the chosen one.
    pub fn eye_distance(&self) -> f32 {
        self.distance.unwrap_or_else(|| match self.fov_deg {
            // The bounding sphere just fills the lens.
            Some(f) => 1.0 / (0.5 * f.to_radians()).sin(),
            None => 4.0,
        })
    }
}

/// A rendered view at output resolution, before thresholding.
#[derive(Clone, Debug)]
pub struct Rendering {
    /// The grayscale picture as a user sees it: shaded model, lines black, background white.
    pub gray: Gray,
    /// The model's shading alone (mean over its samples; 1 where no model is seen).
    pub shade: Gray,
    /// Pixels mostly covered by the model.
    pub model: BitGrid,
    /// Pixels mostly covered by a line.
    pub lines: BitGrid,
    /// The camera at output resolution.
    pub camera: Camera,
    /// The mesh's parts, and how many of them this view draws smaller than a pixel.
    pub parts: PartSizes,
    /// Milliseconds per step: `curvature`, `raster`, `shade`, `lines`, `compose`.
    pub timings: Timings,
}

/// Load `path`, render it and threshold it: the mesh path of stage 1. Returns the two-tone (its
/// gray is the rendering) and the threshold level used.
pub fn render(
    path: &Path,
    cfg: &MeshConfig,
    threshold: Threshold,
    invert: bool,
) -> Result<(TwoTone, u8), MeshError> {
    cfg.validate()?;
    let mesh = load(path)?;
    let r = render_mesh(&mesh, cfg)?;
    Ok(two_tone(&r, threshold, invert))
}

/// What a mesh gives every view: its smooth vertex normals, and (when suggestive contours are
/// drawn, on first use) its curvature. Kept by the studio so a new view does not redo them.
#[derive(Debug)]
pub struct Prepared {
    pub(crate) mesh: Mesh,
    normals: Vec<Vec3>,
    curvature: std::sync::OnceLock<curvature::Curvature>,
}

impl Prepared {
    pub(crate) fn new(mesh: Mesh) -> Prepared {
        let normals = mesh.vertex_normals();
        Prepared {
            mesh,
            normals,
            curvature: std::sync::OnceLock::new(),
        }
    }

    fn curvature(&self) -> &curvature::Curvature {
        self.curvature
            .get_or_init(|| curvature::estimate(&self.mesh, &self.normals))
    }
}

/// One view of a mesh before it is lit: each working sample's surface (point, normal, depth,
/// curvature terms) and the lines, which do not depend on the light. `light` turns it into a
/// [`Rendering`]; a new light (the studio's drag) re-lights it without a new raster.
#[derive(Clone, Debug)]
pub struct Drawn {
    /// What the light reads of each working sample (the lines' share of the fragments is done
    /// with once they are found).
    surf: shade::Surfaces,
    line_mask: Vec<bool>,
    /// The camera at working (supersampled) and at output resolution.
    cam: Camera,
    out_cam: Camera,
    k: u32,
    parts: PartSizes,
    /// Milliseconds per step so far: `curvature`, `raster`, `lines`.
    pub timings: Timings,
}

/// The camera of `cfg`'s view of `mesh` at output size, and the mesh's bounding radius.
fn framed(mesh: &Mesh, cfg: &MeshConfig) -> (Camera, f32) {
    let (center, radius) = mesh.bounding_sphere();
    let orbit = camera::Orbit {
        azimuth_deg: cfg.azimuth_deg,
        elevation_deg: cfg.elevation_deg,
        up: cfg.up,
        distance: cfg.eye_distance(),
        orthographic: cfg.fov_deg.is_none(),
    };
    let cam = Camera::frame(center, radius, &orbit, cfg.size, &mesh.positions);
    (cam, radius)
}

/// Render a mesh (no thresholding): `draw` then `light`.
pub fn render_mesh(mesh: &Mesh, cfg: &MeshConfig) -> Result<Rendering, MeshError> {
    cfg.validate()?;
    let prep = Prepared::new(mesh.clone());
    let d = draw(&prep, cfg)?;
    Ok(light(&d, cfg))
}

/// The view of `cfg` (camera, size, lines; not the light): raster, surfaces, lines.
pub(crate) fn draw(prep: &Prepared, cfg: &MeshConfig) -> Result<Drawn, MeshError> {
    cfg.validate()?;
    let mesh = &prep.mesh;
    let mut tm = Timings::default();
    let (out_cam, radius) = framed(mesh, cfg);
    let k = cfg.supersample;
    let cam = out_cam.scaled(k);
    let normals = &prep.normals;

    let view = tm.time("curvature", || {
        (cfg.lines == LineMode::Suggestive).then(|| {
            let c = prep.curvature();
            curvature::view_dependent(mesh, normals, c, |p| cam.view_dir(p), radius)
        })
    });
    let vb = tm.time("raster", || {
        visibility::rasterize(mesh, &cam, mesh.is_closed())
    });
    let (frags, surf) = tm.time("surface", || {
        shade::geometry(mesh, normals, &vb, &cam, view.as_ref())
    });
    let line_mask = tm.time("lines", || {
        let line_px = cfg.line_px.max(cfg.min_line_px);
        let params = lines::LineParams {
            mode: cfg.lines,
            width_px: if k > 1 {
                line_px * k as f32 - 1.0
            } else {
                line_px
            },
            contour_threshold: cfg.contour_threshold,
            max_ndotv: 20f32.to_radians().cos(),
            min_run_px: (4.0 * line_px * k as f32).round() as usize,
            depth_tolerance: 0.02 * radius,
        };
        lines::find(mesh, &cam, &vb, (&frags, &surf), &params)
    });
    Ok(Drawn {
        surf,
        line_mask,
        cam,
        out_cam,
        k,
        parts: part_sizes(mesh, &out_cam),
        timings: tm,
    })
}

/// Light a drawn view with `cfg`'s key light (its position in the view's frame, in bounding
/// radii), ambient share, fill and highlight, and average it down to the output size: each output
/// row lights and averages its k×k blocks at once, rows in parallel, summing in the same order as
/// lighting then averaging would.
pub(crate) fn light(d: &Drawn, cfg: &MeshConfig) -> Rendering {
    let mut tm = d.timings.clone();
    let light = key_light(&d.cam, cfg);
    let mut r = tm.time("shade", || {
        compose(&d.surf, &d.line_mask, &d.cam, &light, d.k, d.out_cam)
    });
    (r.timings, r.parts) = (tm, d.parts);
    r
}

/// `cfg`'s lights in the world's frame for `cam`: the key (given in the view's frame, in
/// bounding radii), its highlight, the ambient share and the fill.
fn key_light(cam: &Camera, cfg: &MeshConfig) -> shade::Light {
    let key = Vec3::from_array(cfg.light);
    shade::Light {
        position: cam.world_from_view(key),
        specular: cfg.specular,
        shininess: cfg.shininess,
        ambient: cfg.ambient,
        // The key mirrored left-right across the view.
        fill: (cfg.fill > 0.0).then(|| {
            (
                cam.world_from_view(Vec3::new(-key.x, key.y, key.z)),
                cfg.fill,
            )
        }),
    }
}

/// Light the working samples and average k×k blocks of them into the output: gray, model
/// shade, coverage. Each output row lights its k working rows ([`shade::Lighter::row`]), then
/// sums each block row by row, left to right, as it always has.
fn compose(
    surf: &shade::Surfaces,
    line_mask: &[bool],
    cam: &Camera,
    light: &shade::Light,
    k: u32,
    out_cam: Camera,
) -> Rendering {
    let (w, h) = (out_cam.width as usize, out_cam.height as usize);
    let kw = cam.width as usize;
    let k = k as usize;
    let n = (k * k) as f32;
    let lighter = shade::Lighter::new(cam, light);
    // Every value is written below.
    let mut gray = vec![0f32; w * h];
    let mut shade = vec![0f32; w * h];
    let mut model = vec![false; w * h];
    let mut lines = vec![false; w * h];
    gray.par_chunks_mut(w)
        .zip(shade.par_chunks_mut(w))
        .zip(model.par_chunks_mut(w))
        .zip(lines.par_chunks_mut(w))
        .enumerate()
        .for_each_init(
            || (vec![0f32; k * kw], vec![0f32; kw]),
            |(lit, ndh), (y, (((gray, shade), model), lines))| {
                for (dy, lit) in lit.chunks_mut(kw).enumerate() {
                    lighter.row(surf, y * k + dy, lit, ndh);
                }
                if k == 1 {
                    // One sample a pixel: its sums are the sample itself (0 + it, as the sums
                    // start at 0) and the means divide by 1, so each is said directly.
                    let (model_in, lines_in) =
                        (&surf.model[y * kw..][..w], &line_mask[y * kw..][..w]);
                    for x in 0..w {
                        let (is_model, is_line, lit) = (model_in[x], lines_in[x], 0.0 + lit[x]);
                        gray[x] = if is_line {
                            0.0
                        } else if is_model {
                            lit
                        } else {
                            1.0
                        };
                        shade[x] = if is_model { lit } else { 1.0 };
                        model[x] = is_model;
                        lines[x] = is_line;
                    }
                    return;
                }
                for x in 0..w {
                    let (mut g, mut s, mut m, mut l) = (0f32, 0f32, 0usize, 0usize);
                    for dy in 0..k {
                        let row = (y * k + dy) * kw;
                        for sx in x * k..x * k + k {
                            let i = row + sx;
                            let is_line = line_mask[i];
                            l += is_line as usize;
                            if surf.model[i] {
                                let lit = lit[dy * kw + sx];
                                m += 1;
                                s += lit;
                                if !is_line {
                                    g += lit;
                                }
                            } else if !is_line {
                                g += 1.0;
                            }
                        }
                    }
                    gray[x] = g / n;
                    shade[x] = if m > 0 { s / m as f32 } else { 1.0 };
                    model[x] = 2 * m >= k * k;
                    lines[x] = 2 * l >= k * k;
                }
            },
        );
    let (w32, h32) = (w as u32, h as u32);
    Rendering {
        gray: Gray {
            width: w32,
            height: h32,
            data: gray,
        },
        shade: Gray {
            width: w32,
            height: h32,
            data: shade,
        },
        model: BitGrid {
            width: w32,
            height: h32,
            data: model,
        },
        lines: BitGrid {
            width: w32,
            height: h32,
            data: lines,
        },
        camera: out_cam,
        parts: PartSizes::default(),
        timings: Timings::default(),
    }
}

/// Threshold a rendering: lines are cut, the background is material, model pixels are material
/// when at or above the level (swapped by `invert`; the same test as a picture's, `super::is_light`).
/// Otsu looks at the model's own pixels only.
/// Returns the two-tone (its gray is the rendering) and the level used.
pub fn two_tone(r: &Rendering, threshold: Threshold, invert: bool) -> (TwoTone, u8) {
    two_tone_with(r, Arc::new(r.gray.clone()), threshold, invert)
}

/// [`two_tone`] with the rendering's gray given (`gray` must be `r.gray`; the pipeline's working
/// gray is already a copy of it, so this saves another).
pub(crate) fn two_tone_with(
    r: &Rendering,
    gray: Arc<Gray>,
    threshold: Threshold,
    invert: bool,
) -> (TwoTone, u8) {
    debug_assert_eq!(gray.data.len(), r.gray.data.len());
    let level = match threshold {
        Threshold::Level(l) => l,
        Threshold::ByPicture => 128,
        Threshold::Otsu | Threshold::Auto => {
            let data: Vec<f32> = (0..r.shade.data.len())
                .filter(|&i| r.model.data[i] && !r.lines.data[i])
                .map(|i| r.shade.data[i])
                .collect();
            if data.is_empty() {
                128
            } else {
                otsu_level(&Gray {
                    width: data.len() as u32,
                    height: 1,
                    data,
                })
            }
        }
    };
    let (lines, model, shade) = (&r.lines.data, &r.model.data, &r.shade.data);
    let mut data = vec![false; lines.len()];
    // Rows in parallel, a few at a time (a row alone is too little work to hand out).
    let chunk = (r.gray.width as usize * 16).max(1);
    data.par_chunks_mut(chunk).enumerate().for_each(|(c, out)| {
        let start = c * chunk;
        let end = start + out.len();
        for (((o, &line), &m), &s) in out
            .iter_mut()
            .zip(&lines[start..end])
            .zip(&model[start..end])
            .zip(&shade[start..end])
        {
            *o = !line && (!m || is_light(s, level) != invert);
        }
    });
    let bits = BitGrid {
        width: r.gray.width,
        height: r.gray.height,
        data,
    };
    (TwoTone { bits, gray }, level)
}

/// How many separate parts a mesh has (triangles joined by shared vertices) and how many of them
/// come out smaller than a pixel in the rendered view, so they leave no mark on the stencil: an
/// OBJ with a small part 1e12 away from the rest frames the view around both, and every part
/// shrinks below a pixel; the stencil came out blank without a word. `make` warns with these.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PartSizes {
    /// Parts in all.
    pub parts: usize,
    /// Parts whose projection spans less than one pixel both ways.
    pub below_a_pixel: usize,
}

/// [`PartSizes`] of `mesh` seen by `cam` (the view's at output size): a union-find over the
/// triangles' corners, each used vertex projected once into its part's box.
fn part_sizes(mesh: &Mesh, cam: &Camera) -> PartSizes {
    let n = mesh.positions.len();
    let (mut parent, mut used): (Vec<u32>, _) = ((0..n as u32).collect(), vec![false; n]);
    fn find(p: &mut [u32], mut i: u32) -> u32 {
        while p[i as usize] != i {
            p[i as usize] = p[p[i as usize] as usize];
            i = p[i as usize];
        }
        i
    }
    for t in &mesh.triangles {
        let a = find(&mut parent, t[0]);
        for &v in t {
            let b = find(&mut parent, v);
            (parent[b as usize], used[v as usize]) = (a, true);
        }
    }
    let (lo, hi) = (f32::INFINITY, f32::NEG_INFINITY);
    let mut boxes = vec![[lo, lo, hi, hi]; n];
    for v in (0..n).filter(|&v| used[v]) {
        let b = &mut boxes[find(&mut parent, v as u32) as usize];
        let q = cam.project(mesh.positions[v]);
        *b = [b[0].min(q.x), b[1].min(q.y), b[2].max(q.x), b[3].max(q.y)];
    }
    let roots = (0..n).filter(|&v| used[v] && parent[v] == v as u32);
    let sizes: Vec<_> = roots.map(|v| boxes[v]).collect();
    PartSizes {
        parts: sizes.len(),
        below_a_pixel: sizes
            .iter()
            .filter(|b| !(b[2] - b[0] >= 1.0 || b[3] - b[1] >= 1.0))
            .count(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The light and the average as two passes, as they were: an image of intensities, then
    /// the k×k means.
    fn light_two_pass(d: &Drawn, cfg: &MeshConfig) -> (Vec<f32>, Vec<f32>, Vec<bool>, Vec<bool>) {
        let cam = &d.cam;
        let light = key_light(cam, cfg);
        // Each sample lit on its own, by the scalar definition.
        let lighter = shade::Lighter::new(cam, &light);
        let shades: Vec<f32> = (0..d.surf.model.len())
            .map(|i| {
                let (p, n) = d.surf.point_normal(i);
                lighter.intensity(p, n)
            })
            .collect();
        let (w, h) = (d.out_cam.width as usize, d.out_cam.height as usize);
        let (kw, k) = (cam.width as usize, d.k as usize);
        let n = (k * k) as f32;
        let (mut gray, mut shade, mut model, mut lines) = (vec![], vec![], vec![], vec![]);
        for y in 0..h {
            for x in 0..w {
                let (mut g, mut s, mut m, mut l) = (0f32, 0f32, 0usize, 0usize);
                for sy in y * k..y * k + k {
                    for sx in x * k..x * k + k {
                        let i = sy * kw + sx;
                        let is_model = d.surf.model[i];
                        let is_line = d.line_mask[i];
                        l += is_line as usize;
                        if is_model {
                            m += 1;
                            s += shades[i];
                        }
                        g += if is_line {
                            0.0
                        } else if is_model {
                            shades[i]
                        } else {
                            1.0
                        };
                    }
                }
                gray.push(g / n);
                shade.push(if m > 0 { s / m as f32 } else { 1.0 });
                model.push(2 * m >= k * k);
                lines.push(2 * l >= k * k);
            }
        }
        (gray, shade, model, lines)
    }

    #[test]
    fn one_pass_light_equals_light_then_average() {
        let prep = Prepared::new(shapes::displaced_sphere(24));
        for (k, fill, ambient, fov) in [
            (1, 0.0, 0.0, Some(30.0)),
            (2, 0.4, 0.2, Some(30.0)),
            (3, 0.0, 0.1, None),
        ] {
            let cfg = MeshConfig {
                size: RenderSize::LongSide(90),
                supersample: k,
                fill,
                ambient,
                fov_deg: fov,
                light: [1.0, 0.5, 2.0],
                ..MeshConfig::default()
            };
            let d = draw(&prep, &cfg).unwrap();
            let r = light(&d, &cfg);
            let (gray, shade, model, lines) = light_two_pass(&d, &cfg);
            assert!(model.iter().filter(|&&m| m).count() > 1000);
            assert!(lines.iter().any(|&l| l));
            assert_eq!(r.gray.data, gray, "k {k}");
            assert_eq!(r.shade.data, shade, "k {k}");
            assert_eq!(r.model.data, model, "k {k}");
            assert_eq!(r.lines.data, lines, "k {k}");
        }
    }

    #[test]
    fn two_tone_cuts_lines_keeps_the_background_and_thresholds_the_model() {
        let prep = Prepared::new(shapes::displaced_sphere(24));
        let cfg = MeshConfig {
            size: RenderSize::LongSide(80),
            ..MeshConfig::default()
        };
        let r = light(&draw(&prep, &cfg).unwrap(), &cfg);
        for (threshold, invert) in [
            (Threshold::Level(128), false),
            (Threshold::Level(90), true),
            (Threshold::Otsu, false),
        ] {
            let (t, level) = two_tone(&r, threshold, invert);
            assert_eq!(*t.gray, r.gray);
            for i in 0..r.gray.data.len() {
                let want = if r.lines.data[i] {
                    false
                } else if !r.model.data[i] {
                    true
                } else {
                    ((r.shade.data[i] * 255.0).round() >= level as f32 || level == 0) != invert
                };
                assert_eq!(t.bits.data[i], want, "pixel {i}");
            }
        }
    }
}
