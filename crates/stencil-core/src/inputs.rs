//! What a request reads from disk besides the input's pixels, read once so that
//! `resolve` reads no file. The studio keeps them while the files stay.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::SystemTime;

use crate::raster::Gray;
use crate::request::Request;
use crate::tone::{self, ToneError};

/// The files read for a [`Request`].
#[derive(Clone, Debug, Default)]
pub struct Inputs {
    /// The whole picture's size as shown (after its EXIF orientation), from its header; `None`
    /// for a mesh, or a header that cannot be read (loading the picture then says why).
    pub picture_px: Option<(u32, u32)>,
    /// The keep-out picture, or why it could not be read (said where the stages reach it).
    pub keep_out: Option<Result<Arc<Gray>, Arc<ToneError>>>,
}

impl Inputs {
    /// Read what `r` names: the picture's header, the keep-out picture (within the pixel limit).
    pub fn load(r: &Request) -> Inputs {
        let m = &r.make;
        Inputs {
            picture_px: (!crate::pipeline::source::is_mesh_path(&m.input))
                .then(|| tone::picture_size(&m.input).ok())
                .flatten(),
            keep_out: r.keep_out.as_ref().map(|p| {
                tone::image::load_gray(p, m.tone.max_pixels)
                    .map(Arc::new)
                    .map_err(Arc::new)
            }),
        }
    }
}

/// [`Inputs`] kept between requests (the studio's): read again only when a request names other
/// files or a limit, or a file named changed on disk (its [`Stamp`]).
#[derive(Default)]
pub struct KeptInputs {
    key: Option<KeptKey>,
    inputs: Inputs,
}

/// What the kept inputs were read for: the files with their stamps, and the pixel limit.
type KeptKey = (Vec<(PathBuf, Option<Stamp>)>, u64);

impl KeptInputs {
    /// The inputs of `r`: the kept ones when they were read for the same files, unchanged.
    pub fn load(&mut self, r: &Request) -> Inputs {
        let files = std::iter::once(&r.make.input).chain(&r.keep_out);
        let key = (
            files.map(|p| (p.clone(), stamp(p))).collect(),
            r.make.tone.max_pixels,
        );
        if self.key.as_ref() != Some(&key) {
            self.inputs = Inputs::load(r);
            self.key = Some(key);
        }
        self.inputs.clone()
    }
}

/// The identity of a file on disk: a file replaced or rewritten has another.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Stamp {
    len: u64,
    modified: Option<SystemTime>,
    /// Device, inode and the change time (Unix): a file renamed over it, or written within the
    /// modification time's resolution, still differs.
    node: [i64; 4],
}

/// A file's stamp now (`None`: it cannot be read; reading it then says why).
pub fn stamp(path: &Path) -> Option<Stamp> {
    let m = std::fs::metadata(path).ok()?;
    #[cfg(unix)]
    let node = {
        use std::os::unix::fs::MetadataExt;
        [m.dev() as i64, m.ino() as i64, m.ctime(), m.ctime_nsec()]
    };
    #[cfg(not(unix))]
    let node = [0; 4];
    Some(Stamp {
        len: m.len(),
        modified: m.modified().ok(),
        node,
    })
}
