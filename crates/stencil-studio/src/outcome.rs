//! A finished run as the page sees it ([`Done`]): what it computed (one stencil through the
//! engine, or a set or tiles as `make` cuts them), the input file's identity on disk when it was read
//! (`Stamp`), and the page's images, encoded once ([`Done::cached`], [`Reuse`]).

use std::sync::{Arc, Mutex};
use stencil_core::Stamp;

use axum::body::Bytes;
use stencil_core::export::png;
use stencil_core::layers::{Layered, LayersConfig};
use stencil_core::pipeline::{Cleaned, Made};
use stencil_core::raster::Gray;
use stencil_core::tiles::{Tiled, TilesConfig};

use crate::engine::{fast_png, Computed, Pixels};
use crate::params::Params;

/// How many encoded images one result keeps (a set of six layers and its fill-in has 36
/// names; the page shows one or two at a time).
const IMAGE_CACHE: usize = 12;

/// What a run computed: one stencil, through the incremental engine, a set, or tiles.
#[derive(Clone)]
pub(crate) enum Shown {
    One(Arc<Computed>),
    Set(Arc<SetRun>),
    Tiles(Arc<TilesRun>),
}

impl Shown {
    /// One of the page's images of this result (see each kind's `image`).
    pub(crate) fn image(&self, name: &str) -> Option<Vec<u8>> {
        match self {
            Shown::One(c) => c.image(name),
            Shown::Set(set) => set.image(name),
            Shown::Tiles(t) => t.image(name),
        }
    }
}

/// Tiles (`--tiles`, with `--layers` or not) as `make` computes them, by
/// `stencil_core::tiles::run`. Not incremental: the seams run through the whole picture and
/// each tile's stencil depends on them, so a change (a seam moved) runs the tiling again.
pub(crate) struct TilesRun {
    pub(crate) cfg: stencil_core::MakeConfig,
    pub(crate) tc: TilesConfig,
    pub(crate) tiled: Tiled,
}

impl TilesRun {
    /// The tiles' stencils in cutting order (each tile's layers in painting order).
    pub(crate) fn stencils(&self) -> Vec<&Made> {
        self.tiled.tiles.iter().flatten().collect()
    }

    /// One of the page's images: `tiles` (make's tiles.png: the seams, the overlaps, the pins
    /// and the numbers over the whole picture), or `tK-NAME` for stencil K (1-based, in the
    /// order of [`TilesRun::stencils`]) with a NAME as [`Computed::image`] has.
    pub(crate) fn image(&self, name: &str) -> Option<Vec<u8>> {
        if name == "tiles" {
            let (w, h, rgb) = &self.tiled.map;
            return Some(fast_png(*w, *h, rgb, Pixels::Rgb));
        }
        let (k, what) = numbered(name, 't')?;
        stencil_image(self.stencils().get(k.checked_sub(1)?)?, what)
    }
}

/// `K` and `NAME` of `{prefix}K-NAME`, K a canonical number (`s1`, not `s01` or `s+1`: one name
/// per image).
fn numbered(name: &str, prefix: char) -> Option<(usize, &str)> {
    let (k, what) = name.strip_prefix(prefix)?.split_once('-')?;
    Some((
        k.parse::<usize>().ok().filter(|n| n.to_string() == k)?,
        what,
    ))
}

/// A made stencil's image `what`, as [`Computed::image`] names them.
fn stencil_image(m: &Made, what: &str) -> Option<Vec<u8>> {
    let (w, h) = (m.bridged.bits.width, m.bridged.bits.height);
    let gray = &m.twotone.gray;
    Some(match what {
        "gray" => fast_png(w, h, &gray.to_u8(), Pixels::Gray),
        "twotone" => fast_png(w, h, &m.twotone.bits.to_u8(), Pixels::Gray),
        "stencil" => fast_png(w, h, &m.bridged.bits.to_u8(), Pixels::Gray),
        "picture" => fast_png(w, h, &m.picture.to_u8(), Pixels::Gray),
        "preview" => {
            let rgb = png::preview_rgb(
                gray,
                &m.picture,
                &m.twotone.bits,
                &m.bridged.bits,
                &m.dropped_px,
                1,
            );
            fast_png(w, h, &rgb, Pixels::Rgb)
        }
        _ => return None,
    })
}

/// A set (`--layers`, `--fill-in`, registration marks for a mask) as `make` computes it, by
/// `stencil_core::layers::run`. Not incremental: each layer's bridges depend on the darker
/// layers' stencils, so a change runs the whole set again, and a newer change waits for it.
pub(crate) struct SetRun {
    pub(crate) cfg: stencil_core::MakeConfig,
    pub(crate) lc: LayersConfig,
    pub(crate) set: Layered,
}

impl SetRun {
    /// The stencils in painting order: the layers, then the fill-in.
    pub(crate) fn stencils(&self) -> Vec<&Made> {
        self.set.layers.iter().chain(&self.set.fill_in).collect()
    }

    /// One of the page's images: `composite` (the painted set, the picture's size), or
    /// `NAME` / `sK-NAME` for stencil K (1-based, in painting order, the fill-in last) with a
    /// NAME as [`Computed::image`] has.
    pub(crate) fn image(&self, name: &str) -> Option<Vec<u8>> {
        if name == "composite" {
            let (w, h) = (self.set.tones.luma.width, self.set.tones.luma.height);
            return Some(fast_png(w, h, &self.set.composite, Pixels::Rgb));
        }
        let (k, what) = match name.split_once('-') {
            Some(_) => numbered(name, 's')?,
            None => (1, name),
        };
        stencil_image(self.stencils().get(k.checked_sub(1)?)?, what)
    }
}

/// One finished run, as the page sees it.
pub(crate) struct Done {
    pub(crate) version: u64,
    /// The options it was computed from (the command line an export of it shows).
    pub(crate) params: Params,
    /// The input file it was computed from.
    pub(crate) stamp: Option<Stamp>,
    /// Set when this run read the input again because it changed on disk.
    pub(crate) notice: Option<String>,
    pub(crate) outcome: Result<Shown, String>,
    /// Why `make` would write nothing for it, in `make`'s words.
    pub(crate) refused: Option<String>,
    /// The preview only: the trace and the check of this version are still running.
    pub(crate) checking: bool,
    pub(crate) ms: f64,
    /// Encoded images of this run, by canonical name, made on first request; at most
    /// [`IMAGE_CACHE`], the oldest dropped first.
    pub(crate) images: Mutex<Vec<(String, Bytes)>>,
}

impl Done {
    /// The image `name` when it was encoded before.
    pub(crate) fn cached(&self, name: &str) -> Option<Bytes> {
        let images = self.images.lock().unwrap_or_else(|e| e.into_inner());
        images
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, b)| b.clone())
    }

    /// Keep the encoded image `name` (the oldest kept is dropped past [`IMAGE_CACHE`]).
    pub(crate) fn cache(&self, name: &str, png: &Bytes) {
        let mut images = self.images.lock().unwrap_or_else(|e| e.into_inner());
        if images.iter().any(|(n, _)| n == name) {
            return;
        }
        if images.len() >= IMAGE_CACHE {
            images.remove(0);
        }
        images.push((name.to_string(), png.clone()));
    }
}

pub(crate) type WorkingGray = Arc<Gray>;

/// What the page is sent that depends on one stage's output alone, kept with that output (the
/// `Arc` the engine hands out again for as long as the stage is not re-run): after a change
/// that did not touch the working gray or the clean-up (a bridge weight), the state and the
/// before/after picture are sent without counting or encoding them again.
#[derive(Default)]
pub(crate) struct Reuse(Mutex<Kept>);

/// What [`Reuse`] keeps.
#[derive(Default)]
struct Kept {
    histogram: Option<(WorkingGray, Arc<Vec<u64>>)>,
    gray_png: Option<(WorkingGray, Bytes)>,
    picture_png: Option<(Arc<Cleaned>, Bytes)>,
}

impl Reuse {
    /// The working gray's histogram, counted once per gray.
    pub(crate) fn histogram_of(&self, gray: &WorkingGray) -> Arc<Vec<u64>> {
        let mut r = self.0.lock().unwrap_or_else(|e| e.into_inner());
        kept_for(&r.histogram, gray).unwrap_or_else(|| {
            let h = Arc::new(histogram(gray));
            r.histogram = Some((gray.clone(), h.clone()));
            h
        })
    }

    /// The `gray` or `picture` PNG of `c` when it was made for the same stage output before.
    pub(crate) fn kept_png(&self, c: &Computed, name: &str) -> Option<Bytes> {
        let r = self.0.lock().unwrap_or_else(|e| e.into_inner());
        match name {
            "gray" => kept_for(&r.gray_png, &c.gray),
            "picture" => kept_for(&r.picture_png, &c.cleaned),
            _ => None,
        }
    }

    /// Keep `png` when it is the `gray` or `picture` of `c` (see [`Reuse::kept_png`]).
    pub(crate) fn keep_png(&self, c: &Computed, name: &str, png: &Bytes) {
        let mut r = self.0.lock().unwrap_or_else(|e| e.into_inner());
        match name {
            "gray" => r.gray_png = Some((c.gray.clone(), png.clone())),
            "picture" => r.picture_png = Some((c.cleaned.clone(), png.clone())),
            _ => {}
        }
    }
}

/// What `slot` keeps, when it was made from the very output `of` (the same `Arc`).
fn kept_for<T, V: Clone>(slot: &Option<(Arc<T>, V)>, of: &Arc<T>) -> Option<V> {
    slot.as_ref()
        .filter(|(k, _)| Arc::ptr_eq(k, of))
        .map(|(_, v)| v.clone())
}

/// Pixels per gray level (0..255) of the working gray.
pub(crate) fn histogram(g: &Gray) -> Vec<u64> {
    let mut h = vec![0u64; 256];
    for &v in &g.data {
        h[(v.clamp(0.0, 1.0) * 255.0).round() as usize] += 1;
    }
    h
}
