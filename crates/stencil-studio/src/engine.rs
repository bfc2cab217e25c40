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

use stencil_core::export;
use stencil_core::pipeline::{
    self, Cleaned, Input, Joined, Made, MakeConfig, Prepared, Source, SourceParams, StageParams,
    Timings, ToneParams, Traced,
};
use stencil_core::raster::{Gray, TwoTone};
use stencil_core::report::Report;
use stencil_core::Error;

/// Why a run stopped without a result.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A newer request came in between two stages; its run replaces this one.
    #[error("superseded by a newer change")]
    Cancelled,
    #[error(transparent)]
    Core(#[from] Error),
}

/// One stage's output, with what it was made from: its key (the upstream output's generation
/// and the stage's parameters) and its own generation, which downstream keys carry.
struct Slot<K, V> {
    key: K,
    generation: u64,
    value: V,
}

/// A kept stage: its key is the upstream output's generation and the stage's parameters.
type Kept<P, V> = Option<Slot<(u64, P), V>>;

/// The outputs of the last run, stage by stage.
#[derive(Default)]
pub struct Engine {
    generations: u64,
    input: Option<Slot<Option<u64>, Input>>,
    /// A mesh's view before it is lit, keyed by everything but the light: a light change
    /// re-lights it (no raster, no lines).
    drawn: Kept<
        Option<stencil_core::tone::mesh::MeshConfig>,
        Option<Arc<stencil_core::tone::mesh::Drawn>>,
    >,
    source: Kept<SourceParams, Source>,
    /// The working gray and its Otsu level (the page marks it on the histogram): a full pass
    /// over the picture, made once per gray rather than once per change.
    gray: Kept<u32, (Arc<Gray>, u8)>,
    raw: Kept<ToneParams, Arc<(TwoTone, u8)>>,
    /// The picture's side of the likeness measure, made of the two-tone's gray: kept while that
    /// gray stays (a threshold change keeps it; see `ToneParams::gray_key`).
    look: Kept<Option<([f64; 3], bool)>, Arc<stencil_core::tone::Likeness>>,
    cleaned: Kept<pipeline::CleanParams, Arc<Cleaned>>,
    /// The islands and their walks, keyed by the join's parameters without the weights: a
    /// weight change re-chooses the bridges from the kept walks.
    prepared: Kept<pipeline::JoinParams, Arc<Prepared>>,
    joined: Kept<pipeline::JoinParams, Arc<Joined>>,
    traced: Kept<pipeline::TraceParams, Arc<(Joined, Traced)>>,
}

/// What one run shows: every stage's output up to the bridges (the preview), then the trace
/// and the check, the report, and whether `make` would refuse it (the page shows a refused
/// stencil too, with the reason: that is when a person most needs to see it).
pub struct Computed {
    pub cfg: MakeConfig,
    pub params: StageParams,
    /// The working gray (what the threshold reads; the two-tones share it).
    pub gray: Arc<Gray>,
    pub otsu: u8,
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

/// Run `f` unless the slot holds the output for `key`; returns the output and its generation.
fn step<K: PartialEq, V: Clone, E>(
    slot: &mut Option<Slot<K, V>>,
    generations: &mut u64,
    ran: &mut Vec<&'static str>,
    name: &'static str,
    key: K,
    f: impl FnOnce() -> Result<V, E>,
) -> Result<(u64, V), E> {
    if let Some(s) = slot.as_ref().filter(|s| s.key == key) {
        return Ok((s.generation, s.value.clone()));
    }
    // A failed stage leaves no stale output behind it.
    *slot = None;
    let value = f()?;
    *generations += 1;
    ran.push(name);
    *slot = Some(Slot {
        key,
        generation: *generations,
        value: value.clone(),
    });
    Ok((*generations, value))
}

impl Engine {
    pub fn new() -> Self {
        Engine::default()
    }

    /// Read the input again on the next run (it changed on disk): every stage after it runs
    /// again, as their keys hold the input's generation.
    pub fn forget_input(&mut self) {
        self.input = None;
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
        let mut ran = Vec::new();
        let g = &mut self.generations;
        let cancel = || {
            if superseded() {
                Err(RunError::Cancelled)
            } else {
                Ok(())
            }
        };
        let sp = SourceParams::of(cfg)?;
        let input_key = match sp {
            SourceParams::Picture { max_pixels, .. } => Some(max_pixels),
            SourceParams::Mesh(_) => None,
        };
        let (ig, input) = step(&mut self.input, g, &mut ran, "load", input_key, || {
            pipeline::load(&cfg.input, &sp)
        })?;
        cancel()?;
        let (dg, drawn) = step(
            &mut self.drawn,
            g,
            &mut ran,
            "draw",
            (ig, sp.view_key()),
            || pipeline::draw(&input, &sp),
        )?;
        cancel()?;
        let (sg, source) = step(
            &mut self.source,
            g,
            &mut ran,
            "light",
            (dg, sp.clone()),
            || pipeline::light(&input, drawn.as_deref(), &sp),
        )?;
        cancel()?;
        let params = pipeline::resolve(cfg, &source)?;
        let factor = params.working.factor;
        let (gg, gray_otsu) = step(&mut self.gray, g, &mut ran, "gray", (sg, factor), || {
            let gray = pipeline::working_gray(source.clone(), factor);
            let otsu = stencil_core::tone::otsu_level(&gray);
            Ok::<_, RunError>((gray, otsu))
        })?;
        let (gray, otsu) = gray_otsu;
        let (rg, raw) = step(
            &mut self.raw,
            g,
            &mut ran,
            "threshold",
            (gg, params.tone),
            || {
                // The gray is shared with the two-tone, not copied.
                Ok::<_, RunError>(Arc::new(pipeline::threshold(
                    &source,
                    Arc::clone(&gray),
                    &params.tone,
                )))
            },
        )?;
        cancel()?;
        let (_, look) = step(
            &mut self.look,
            g,
            &mut ran,
            "look",
            (gg, params.tone.gray_key()),
            || Ok::<_, RunError>(Arc::new(pipeline::look(&raw.0))),
        )?;
        let mut timer = Timings::new(None);
        // A new clean-up is always followed by new walks (their key holds its generation), and
        // its likeness only reports: so the walks run beside the likeness, inside the clean-up's
        // step, and the walk step below takes their result (unless a newer change came first).
        let mut walked = None;
        let (cg, cleaned) = step(
            &mut self.cleaned,
            g,
            &mut ran,
            "clean",
            (rg, params.clean),
            || {
                let (tt, level) = (*raw).clone();
                let mut c = pipeline::clean_unmeasured(tt, level, &params.clean, &look);
                let measure = || pipeline::measure(&c, &params.clean, &look);
                c.likeness = if superseded() {
                    measure()
                } else {
                    let (likeness, w) = rayon::join(measure, || {
                        let mut t = Timings::new(None);
                        let w = pipeline::prepare(c.twotone.clone(), c.level, &params.join, &mut t);
                        (w, t)
                    });
                    walked = Some(w);
                    likeness
                };
                Ok::<_, RunError>(Arc::new(c))
            },
        )?;
        cancel()?;
        let (pg, prepared) = step(
            &mut self.prepared,
            g,
            &mut ran,
            "walk",
            (cg, Prepared::key(&params.join)),
            || {
                let prepared = match walked.take() {
                    Some((w, t)) => {
                        for (name, ms) in t.iter() {
                            timer.add(name, ms);
                        }
                        w?
                    }
                    None => pipeline::prepare(
                        cleaned.twotone.clone(),
                        cleaned.level,
                        &params.join,
                        &mut timer,
                    )?,
                };
                Ok::<_, RunError>(Arc::new(prepared))
            },
        )?;
        cancel()?;
        let (jg, joined) = step(
            &mut self.joined,
            g,
            &mut ran,
            "join",
            (pg, params.join.clone()),
            || {
                // The kept walks are lent to the choice, not copied (a weight change's copy
                // of them and the islands was 3 ms of the 33).
                Ok::<_, RunError>(Arc::new(pipeline::bridge_prepared(
                    &prepared,
                    &params.join,
                    &mut timer,
                )?))
            },
        )?;
        let report = pipeline::report_joined(cfg, &params, &cleaned, &joined, timer);
        Ok(Computed {
            cfg: cfg.clone(),
            params,
            gray,
            otsu,
            cleaned,
            joined,
            traced: None,
            report,
            refused: None,
            ran,
            joined_generation: jg,
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
        let (_, traced) = step(
            &mut self.traced,
            &mut self.generations,
            &mut ran,
            "trace",
            (c.joined_generation, params.trace.clone()),
            || {
                let mut j = (**joined).clone();
                let t = pipeline::trace(
                    &mut j.bridged,
                    &joined.twotone.bits,
                    &cleaned.picture,
                    &params.trace,
                    &mut timer,
                )?;
                Ok::<_, RunError>(Arc::new((j, t)))
            },
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
