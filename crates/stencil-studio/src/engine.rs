//! The incremental engine: `make`'s stages (`stencil_core::pipeline`), each output kept with the
//! parameters and the upstream output it was made from, so that a change re-runs only the
//! stages from the first whose inputs changed.
//!
//! Why this shape: the stages are plain functions of (inputs, parameters) and one
//! `pipeline::resolve` turns the whole request into per-stage parameters that compare with `==`.
//! So "what must re-run" is not a table of which option touches which stage (that would drift
//! from the code): it is the first stage whose parameters or upstream output differ. A material
//! change that moves the automatic supersampling changes `working.factor` and re-runs from the
//! gray; a bridge weight changes only `JoinParams`.

use std::sync::Arc;

use stencil_core::driver::{Cache, Start, Stopped, Tweaks};
use stencil_core::export;
use stencil_core::pipeline::{
    self, Cleaned, Joined, Made, MakeConfig, StageParams, Timings, Traced,
};
use stencil_core::raster::Gray;
use stencil_core::report::Report;
use stencil_core::Error;

/// Why a run stopped without a result.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A newer request came in between two stages; its run replaces this one.
    #[error("superseded by a newer change")]
    Cancelled,
    /// A stage failed, as `make` would.
    #[error(transparent)]
    Core(#[from] Error),
}

impl From<Stopped> for RunError {
    fn from(s: Stopped) -> Self {
        match s {
            Stopped::Superseded => RunError::Cancelled,
            Stopped::Failed(e) => RunError::Core(e),
        }
    }
}

/// The outputs of the last run, stage by stage (the driver's [`Cache`]), and the Otsu level of
/// the kept working gray (the page marks it on the histogram: a full pass over the picture,
/// made once per gray rather than once per change).
#[derive(Default)]
pub struct Engine {
    cache: Cache,
    otsu: Option<(u64, u8)>,
}

/// What one run shows: every stage's output up to the bridges (the preview), then the trace
/// and the check, the report, and whether `make` would refuse it (the page shows a refused
/// stencil too, with the reason: that is when a person most needs to see it).
pub struct Computed {
    /// The configuration it ran.
    pub cfg: MakeConfig,
    /// Each stage's parameters, as `cfg` resolves.
    pub params: StageParams,
    /// The working gray (what the threshold reads; the two-tones share it).
    pub gray: Arc<Gray>,
    /// The working gray's Otsu level (the page marks it on the histogram).
    pub otsu: u8,
    /// The threshold's picture after the clean-up.
    pub cleaned: Arc<Cleaned>,
    /// After the bridges, before the trace's neck repairs.
    pub joined: Arc<Joined>,
    /// After the bridges and the trace: `joined.bridged` is the stencil as `make` writes it.
    /// `None` until [`Engine::check`] ran (the preview is shown first).
    pub traced: Option<Arc<(Joined, Traced)>>,
    /// The report; until the check ran, without what the trace measures (the check, the
    /// fidelity, the vector statistics, the size in mm, the job time).
    pub report: Report,
    /// Why `make` would write nothing (too thin, too changed), as the caller words it; known
    /// once the check ran.
    pub refused: Option<Error>,
    /// The stages this run computed (the others were kept), in order.
    pub ran: Vec<&'static str>,
    /// The joined output's generation (the trace's key).
    joined_generation: u64,
}

impl Engine {
    /// An engine that keeps every stage's output.
    pub fn new() -> Self {
        Engine {
            cache: Cache::keeping(),
            otsu: None,
        }
    }

    /// Read the input again on the next run (it changed on disk): every stage after it runs
    /// again, as their keys hold the input's generation.
    pub fn forget_input(&mut self) {
        self.cache.forget_input();
    }

    /// Run `cfg` through the stages, re-using every output whose inputs did not change:
    /// [`Engine::preview`] then [`Engine::check`].
    pub fn run(
        &mut self,
        cfg: &MakeConfig,
        superseded: &dyn Fn() -> bool,
    ) -> Result<Computed, RunError> {
        let c = self.preview(cfg, superseded)?;
        self.check(&c, superseded)
    }

    /// Run `cfg` through the stages up to the bridges (what the preview shows), re-using every
    /// output whose inputs did not change. `superseded` is asked between stages; when it says
    /// yes the run stops with [`RunError::Cancelled`] (the outputs computed so far are kept for
    /// the next run). The result has no trace and no check yet: [`Engine::check`] adds them.
    pub fn preview(
        &mut self,
        cfg: &MakeConfig,
        superseded: &dyn Fn() -> bool,
    ) -> Result<Computed, RunError> {
        let timer = Timings::new(None);
        let b = self
            .cache
            .bridged(cfg, &Start::Input, &Tweaks::default(), timer, superseded)?;
        let otsu = match self.otsu {
            Some((g, level)) if g == b.gray_generation => level,
            _ => {
                let level = stencil_core::tone::otsu_level(&b.gray);
                self.otsu = Some((b.gray_generation, level));
                level
            }
        };
        let report = pipeline::report_joined(cfg, &b.params, &b.cleaned, &b.joined, b.timer);
        Ok(Computed {
            cfg: cfg.clone(),
            params: b.params,
            gray: b.gray,
            otsu,
            cleaned: b.cleaned,
            joined: b.joined,
            traced: None,
            report,
            refused: None,
            ran: b.ran,
            joined_generation: b.joined_generation,
        })
    }

    /// The trace and the check of a [`Engine::preview`] (kept when its inputs did not change),
    /// the refusal, the job time and the full report.
    pub fn check(
        &mut self,
        c: &Computed,
        superseded: &dyn Fn() -> bool,
    ) -> Result<Computed, RunError> {
        if superseded() {
            return Err(RunError::Cancelled);
        }
        let (cfg, params, joined, cleaned) = (&c.cfg, &c.params, &c.joined, &c.cleaned);
        let mut ran = c.ran.clone();
        let mut timer = Timings::new(None);
        let traced = self.cache.traced(
            (joined, c.joined_generation),
            cleaned,
            params,
            &mut timer,
            &mut ran,
        )?;
        let (j, t) = &*traced;
        let refused = pipeline::refuse(&cfg.physical, t.fidelity, &t.check).err();
        // The job time for the chosen machine, as `make` plans it.
        let gcode = match (&cfg.gcode, &refused) {
            (Some(gc), None) => {
                let mut geometry = t.geometry.clone();
                Some(pipeline::gcode(cfg, gc, &mut geometry, j, &params.trace, &mut timer)?.1)
            }
            _ => None,
        };
        let report = pipeline::report(cfg, params, cleaned, j, t, gcode, timer);
        Ok(Computed {
            cfg: cfg.clone(),
            params: params.clone(),
            gray: c.gray.clone(),
            otsu: c.otsu,
            cleaned: cleaned.clone(),
            joined: joined.clone(),
            traced: Some(traced.clone()),
            report,
            refused,
            ran,
            joined_generation: c.joined_generation,
        })
    }
}

impl Computed {
    /// What `make` computes for the same options, from the kept stages (the same functions, so
    /// the same bytes): the trace, the refusal, the G-code, the report.
    pub fn made(&self) -> Result<Made, Error> {
        pipeline::finish_from(&self.cfg, &self.params, &self.cleaned, &self.joined)
    }
}

/// The colour type of a page image.
pub(crate) enum Pixels<'a> {
    Gray,
    /// RGB triples (a set's composite).
    Rgb,
    /// Palette indices, with the palette's RGB triples.
    Indexed(&'a [u8]),
}

/// A PNG made for the page: stored, not compressed, no filter (it is sent once, over a loopback,
/// and made for every change: compressing a 1-megapixel preview even at the fastest level cost
/// a change more than sending the megabyte does; `make`'s files are written by `make`'s
/// encoder).
pub(crate) fn fast_png(width: u32, height: u32, data: &[u8], pixels: Pixels) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len() / 4 + 1024);
    {
        let mut e = png::Encoder::new(&mut out, width, height);
        match pixels {
            Pixels::Gray => e.set_color(png::ColorType::Grayscale),
            Pixels::Rgb => e.set_color(png::ColorType::Rgb),
            Pixels::Indexed(palette) => {
                e.set_color(png::ColorType::Indexed);
                e.set_palette(palette.to_vec());
            }
        }
        e.set_depth(png::BitDepth::Eight);
        e.set_compression(png::Compression::NoCompression);
        e.set_filter(png::Filter::NoFilter);
        // Writing into a Vec cannot fail.
        if let Ok(mut w) = e.write_header() {
            let _ = w.write_image_data(data);
        }
    }
    out
}

impl Computed {
    /// One of the page's images of this run: `gray`, `twotone`, `stencil`, `preview` (in `make`'s
    /// colours, one pixel per working pixel: the page enlarges it), `picture` (thresholded, before
    /// the clean-up).
    pub fn image(&self, name: &str) -> Option<Vec<u8>> {
        let c = self;
        // The stencil as traced once the check ran, else as bridged (the same but for the
        // trace's neck repairs).
        let bridged = match &c.traced {
            Some(t) => &t.0.bridged.bits,
            None => &c.joined.bridged.bits,
        };
        let j = &c.joined;
        let (w, h) = (bridged.width, bridged.height);
        Some(match name {
            "gray" => fast_png(w, h, &c.gray.to_u8(), Pixels::Gray),
            "twotone" => fast_png(w, h, &j.twotone.bits.to_u8(), Pixels::Gray),
            "stencil" => fast_png(w, h, &bridged.to_u8(), Pixels::Gray),
            "picture" => fast_png(w, h, &c.cleaned.picture.to_u8(), Pixels::Gray),
            // In `make`'s colours, as palette indices (a byte a pixel).
            "preview" => {
                let index = export::png::preview_indexed(
                    &c.gray,
                    &c.cleaned.picture,
                    &j.twotone.bits,
                    bridged,
                    &j.dropped_px,
                );
                fast_png(
                    w,
                    h,
                    &index,
                    Pixels::Indexed(&export::png::preview_palette()),
                )
            }
            _ => return None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use stencil_core::tone::Threshold;

    fn rings() -> MakeConfig {
        MakeConfig {
            input: std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../samples/rings.png"),
            ..Default::default()
        }
    }

    /// What a fresh engine (every stage computed) makes of `cfg`.
    fn fresh(cfg: &MakeConfig) -> Computed {
        Engine::new().run(cfg, &|| false).unwrap()
    }

    fn same(a: &Computed, b: &Computed) {
        assert_eq!(a.cleaned.picture, b.cleaned.picture);
        assert_eq!(a.cleaned.twotone.bits, b.cleaned.twotone.bits);
        assert_eq!(a.cleaned.twotone.gray, b.cleaned.twotone.gray);
        assert_eq!(a.cleaned.level, b.cleaned.level);
        assert_eq!(a.joined.bridged.bits, b.joined.bridged.bits);
        assert_eq!(a.image("preview"), b.image("preview"));
    }

    /// Every kept stage gives what a fresh engine computes: a threshold change, a change to the
    /// clean-up alone (an explicit filter radius), to the threshold's way (auto) and back.
    #[test]
    fn kept_stages_give_what_a_fresh_run_gives() {
        let mut e = Engine::new();
        let never = || false;
        let mut cfg = rings();
        let mut steps: Vec<(MakeConfig, Option<&str>)> = Vec::new();
        cfg.tone.threshold = Threshold::Level(100);
        steps.push((cfg.clone(), Some("threshold")));
        cfg.filter.radius = 2;
        cfg.filter.auto_radius = false;
        steps.push((cfg.clone(), Some("clean")));
        cfg.filter.radius = 3;
        steps.push((cfg.clone(), Some("clean")));
        cfg.tone.threshold = Threshold::Auto;
        steps.push((cfg.clone(), None));
        cfg.filter.radius = 1;
        steps.push((cfg.clone(), None));
        cfg.tone.threshold = Threshold::Level(140);
        steps.push((cfg.clone(), None));
        e.run(&rings(), &never).unwrap();
        for (c, first) in steps {
            let got = e.run(&c, &never).unwrap();
            if let Some(first) = first {
                assert_eq!(got.ran[0], first, "{:?}", got.ran);
            }
            same(&got, &fresh(&c));
        }
    }
}
