//! Why a mesh could not be read or drawn (a leaf: the loader and the renderer share it).

use std::path::{Path, PathBuf};

/// Why a mesh could not be loaded or rendered.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// Refused by the bounded reader: too large for a mesh, not a regular file, or not UTF-8.
    #[error(transparent)]
    Read(#[from] stencil_io::ReadError),
    #[error("{path}: not a text OBJ file (invalid UTF-8 at byte {offset}); export the model as Wavefront OBJ")]
    /// Not UTF-8 text.
    NotText {
        /// The mesh file.
        path: PathBuf,
        /// Byte offset of the first invalid byte.
        offset: usize,
    },
    /// A line the OBJ reader cannot read.
    #[error("{}:{line}: {msg}; fix or re-export the file", path.display())]
    Malformed {
        /// The mesh file.
        path: PathBuf,
        /// Line number, from 1.
        line: usize,
        /// What is wrong.
        msg: String,
    },
    /// A face pointing at a vertex that does not exist.
    #[error("{}:{line}: {msg}; the file is truncated or damaged", path.display())]
    BadIndex {
        /// The mesh file.
        path: PathBuf,
        /// Line number, from 1.
        line: usize,
        /// What is wrong.
        msg: String,
    },
    /// A coordinate that is not a finite number.
    #[error("{}:{line}: coordinate '{token}' is not a finite number; fix or re-export the file", path.display())]
    NonFinite {
        /// The mesh file.
        path: PathBuf,
        /// Line number, from 1.
        line: usize,
        /// The coordinate as written.
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
        /// The mesh file.
        path: PathBuf,
        /// Line number of the farthest vertex, from 1.
        line: Option<usize>,
        /// What is wrong.
        msg: String,
    },
    #[error("{path}: the OBJ parser failed: {msg}")]
    /// The OBJ parser failed.
    Parse {
        /// The mesh file.
        path: PathBuf,
        /// What it said.
        msg: String,
    },
    #[error("{path}: the mesh is empty: {detail}; nothing to render")]
    /// Nothing to render.
    Empty {
        /// The mesh file.
        path: PathBuf,
        /// What is missing.
        detail: String,
    },
    /// A render setting out of its range.
    #[error("{0}")]
    Setting(MeshSetting),
}

/// A render setting out of its range, with the value given (the `stencil` binary words it with
/// the option that sets it).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum MeshSetting {
    /// An elevation outside -90..90 or an angle not finite.
    #[error(
        "view {azimuth_deg},{elevation_deg} is not a view: azimuth any finite angle, elevation \
         -90..90 degrees"
    )]
    View {
        /// Azimuth given, degrees.
        azimuth_deg: f32,
        /// Elevation given, degrees.
        elevation_deg: f32,
    },
    /// A camera distance outside (1, 1000] bounding radii.
    #[error(
        "camera distance {0} must be above 1 and at most 1000 bounding radii (the camera stays \
         outside the model)"
    )]
    Distance(f32),
    /// A field of view outside 0.5..170 degrees.
    #[error("field of view {0} degrees is not a lens: use 0.5..170, or an orthographic view")]
    Fov(f32),
    #[error("render size {width}x{height} is too small: at least 16 pixels a side")]
    /// A render size under 16 pixels a side.
    TooSmall {
        /// Width given, px.
        width: u32,
        /// Height given, px.
        height: u32,
    },
    /// Supersampling outside 1..=4.
    #[error("supersampling {0} is out of range: use 1 to 4")]
    Supersample(u32),
    /// More pixels of work than the limit.
    #[error(
        "render size {width}x{height} supersampled {supersample} times is {megapixels:.0} \
         megapixels of work, above the limit of {limit_megapixels:.0}"
    )]
    TooMuchWork {
        /// Width, px.
        width: u32,
        /// Height, px.
        height: u32,
        /// Supersampling factor.
        supersample: u32,
        /// The work, megapixels.
        megapixels: f64,
        /// The limit, megapixels.
        limit_megapixels: f64,
    },
    /// A light position not finite.
    #[error("light position {0:?} must be three finite numbers (bounding radii)")]
    Light([f32; 3]),
    /// Ambient light outside [0, 1).
    #[error("ambient light {0} is out of range: use 0 (none) up to but not including 1")]
    Ambient(f32),
    /// Fill light outside 0..=1.
    #[error("fill light {0} is out of range: use 0 (none) to 1 (as strong as the key)")]
    Fill(f32),
    /// Specular strength outside 0..=10.
    #[error("specular strength {0} is out of range: use 0 (matte) to 10")]
    Specular(f32),
    /// Shininess outside 1..=10000.
    #[error("shininess {0} is out of range: use 1 to 10000")]
    Shininess(f32),
    /// Line width outside 0.5..=64 px.
    #[error("line width {0} is out of range: use 0.5 to 64 pixels")]
    LinePx(f32),
    /// A contour threshold negative or not finite.
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
            NotText { path, .. }
            | Malformed { path, .. }
            | BadIndex { path, .. }
            | NonFinite { path, .. }
            | Outlier { path, .. }
            | Parse { path, .. }
            | Empty { path, .. } => Some(path),
        }
    }
}
