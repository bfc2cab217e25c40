//! Everything a request reads from disk besides the input's pixels, read once (through the
//! bounded readers) so that [`crate::resolve::resolve`] reads no file: the picture's header and
//! the keep-out picture. The studio keeps them while the files stay.

use std::sync::Arc;

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
            picture_px: (!crate::pipeline::is_mesh(&m.input))
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
