//! Why a mesh could not be read or drawn (a leaf: the loader and the renderer share it).

use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// Refused by the bounded reader: too large for a mesh, not a regular file, or not UTF-8.
    #[error(transparent)]
    Read(#[from] stencil_io::ReadError),
    #[error("{path}: cannot open the mesh: {source}")]
    Open {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not a text OBJ file (invalid UTF-8 at byte {offset}); export the model as Wavefront OBJ")]
    NotText { path: PathBuf, offset: usize },
    #[error("{}:{line}: {msg}; fix or re-export the file", path.display())]
    Malformed {
        path: PathBuf,
        line: usize,
        msg: String,
    },
    #[error("{}:{line}: {msg}; the file is truncated or damaged", path.display())]
    BadIndex {
        path: PathBuf,
        line: usize,
        msg: String,
    },
    #[error("{}:{line}: coordinate '{token}' is not a finite number; fix or re-export the file", path.display())]
    NonFinite {
        path: PathBuf,
        line: usize,
        token: String,
    },
    /// A few vertices so far from the rest that framing the whole model would shrink the rest to
    /// a dot (the line of the farthest one, when it can be found).
    #[error(
        "{}{}: {msg}",
        path.display(),
        line.map(|l| format!(":{l}")).unwrap_or_default()
    )]
    Outlier {
        path: PathBuf,
        line: Option<usize>,
        msg: String,
    },
    #[error("{path}: the OBJ parser failed: {msg}")]
    Parse { path: PathBuf, msg: String },
    #[error("{path}: the mesh is empty: {detail}; nothing to render")]
    Empty { path: PathBuf, detail: String },
    /// A render setting out of its range.
    #[error("{0}")]
    Setting(MeshSetting),
}

/// A render setting out of its range, with the value given (the `stencil` binary words it with
/// the option that sets it).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum MeshSetting {
    #[error(
        "view {azimuth_deg},{elevation_deg} is not a view: azimuth any finite angle, elevation \
         -90..90 degrees"
    )]
    View {
        azimuth_deg: f32,
        elevation_deg: f32,
    },
    #[error(
        "camera distance {0} must be above 1 and at most 1000 bounding radii (the camera stays \
         outside the model)"
    )]
    Distance(f32),
    #[error("field of view {0} degrees is not a lens: use 0.5..170, or an orthographic view")]
    Fov(f32),
    #[error("render size {width}x{height} is too small: at least 16 pixels a side")]
    TooSmall { width: u32, height: u32 },
    #[error("supersampling {0} is out of range: use 1 to 4")]
    Supersample(u32),
    #[error(
        "render size {width}x{height} supersampled {supersample} times is {megapixels:.0} \
         megapixels of work, above the limit of {limit_megapixels:.0}"
    )]
    TooMuchWork {
        width: u32,
        height: u32,
        supersample: u32,
        megapixels: f64,
        limit_megapixels: f64,
    },
    #[error("light position {0:?} must be three finite numbers (bounding radii)")]
    Light([f32; 3]),
    #[error("ambient light {0} is out of range: use 0 (none) up to but not including 1")]
    Ambient(f32),
    #[error("fill light {0} is out of range: use 0 (none) to 1 (as strong as the key)")]
    Fill(f32),
    #[error("specular strength {0} is out of range: use 0 (matte) to 10")]
    Specular(f32),
    #[error("shininess {0} is out of range: use 1 to 10000")]
    Shininess(f32),
    #[error("line width {0} is out of range: use 0.5 to 64 pixels")]
    LinePx(f32),
    #[error("contour threshold {0} must be a finite number >= 0")]
    ContourThreshold(f32),
}
impl MeshError {
    /// The mesh this error is about (its message starts with it); `None` for a render setting.
    pub fn subject(&self) -> Option<&Path> {
        use MeshError::*;
        match self {
            Read(e) => Some(e.subject()),
            Setting(_) => None,
            Open { path, .. }
            | NotText { path, .. }
            | Malformed { path, .. }
            | BadIndex { path, .. }
            | NonFinite { path, .. }
            | Outlier { path, .. }
            | Parse { path, .. }
            | Empty { path, .. } => Some(path),
        }
    }
}
