//! The stages in order, listed once: every way of running the pipeline runs this list.
//!
//! `make` runs it plainly ([`run`]: each output moves on, nothing is kept); the studio with a
//! [`Cache`] that keeps each stage's output beside the parameters and the upstream output it was
//! made from, so a change re-runs only from the first stage whose inputs changed (parameters
//! from `resolve::stage_params` compare with `==`: no table of which option touches which stage;
//! a bridge weight re-runs only the join); a layered set once per layer, with [`Tweaks`].
//!
//! The list (one file each in `pipeline/`; the paper's Stages 1–5, Bronson et al.): `source`
//! (load → draw a mesh's view → light), `resolve::stage_params` (the plan per stage, pure),
//! `two_tone` (gray at the working resolution → threshold → look, the picture's side of the
//! likeness), `clean_up`, `bridges` (walk: the islands and candidate strips → join: the spanning
//! tree, grown to width), `vectors` (trace, check, refuse), `outputs` (G-code, report:
//! [`Cache::checked`], [`finish`]), then `make` writes them (`files`).

use std::sync::Arc;

use crate::error::Error;
use crate::pipeline::bridges::{self, Joined, Prepared, PreparedKey};
use crate::pipeline::clean_up::{self, Cleaned};
use crate::pipeline::outputs::{self, Made};
use crate::pipeline::source::{self, Input, Source};
use crate::pipeline::vectors::{self, Traced};
use crate::pipeline::{
    self, two_tone, CleanParams, JoinParams, MakeConfig, SourceParams, StageParams, ToneParams,
    TraceParams,
};
use crate::raster::{BitGrid, Gray, TwoTone};
use crate::report::Report;
use crate::timing::Timings;
use crate::tone::{self, mesh};

pub use crate::pipeline::outputs::{finish, GeometryEdit};

/// Why a run stopped without a result.
#[derive(Debug, thiserror::Error)]
pub enum Stopped {
    /// The caller said, between two stages, that a newer request replaces this one.
    #[error("superseded by a newer change")]
    Superseded,
    /// A stage failed.
    #[error(transparent)]
    Failed(#[from] Error),
}

/// Where the stages start.
#[derive(Clone, Debug)]
pub enum Start {
    /// The request's input file (`MakeConfig::input`): loaded, a mesh drawn and lit.
    Input,
    /// A picture already in memory (a layered set's gray, shared by its layers).
    Source(Source),
}

/// What a layered set changes in one layer's run; the default changes nothing.
#[derive(Default)]
pub struct Tweaks<'a> {
    /// The two-tone drawn by the set (a fill-in's cut, at level 128) in place of the working
    /// gray and the threshold; the start's picture still sizes the stencil.
    pub two_tone: Option<&'a Edit<'a, (), TwoTone>>,
    /// Applied to the two-tone right after the threshold (a set's registration marks).
    pub after_threshold: Option<&'a Edit<'a, TwoTone, ()>>,
    /// Applied to the cleaned two-tone after its likeness is measured, before the islands (a
    /// darker layer's cut, which a lighter layer cuts too; a fill-in's specks).
    pub after_clean: Option<&'a Edit<'a, TwoTone, ()>>,
    /// The gray the bridges' costs read instead of the two-tone's own (what another stencil
    /// paints costs little); the own gray is put back after the join.
    pub cost_gray: Option<&'a (dyn Fn(&Gray) -> Gray + Sync)>,
    /// Bridge every island, drop none.
    pub keep_all_islands: bool,
    /// Applied to the traced geometry after the check, before any job is planned from it (a
    /// tile's edge trimmed along its seams).
    pub geometry: Option<&'a GeometryEdit<'a>>,
}

/// A set's change to a stage's output: `T` changed in place (or made, for `()`), knowing the
/// resolved parameters.
pub type Edit<'a, T, R> = dyn Fn(&mut T, &StageParams) -> R + Sync + 'a;

/// One stage's output, with what it was made from: its key (the upstream output's generation
/// and the stage's parameters) and its own generation, which downstream keys carry.
struct Slot<K, V> {
    key: K,
    generation: u64,
    value: V,
}

/// A kept stage: its key is the upstream output's generation and the stage's parameters.
type Kept<P, V> = Option<Slot<(u64, P), V>>;

/// The outputs of the last run, stage by stage (or, for `make`, none: `Cache::default()`).
#[derive(Default)]
pub struct Cache {
    keep: bool,
    generations: u64,
    slots: Slots,
}

/// The kept outputs, one slot per stage.
#[derive(Default)]
struct Slots {
    input: Option<Slot<Option<u64>, Input>>,
    /// A mesh's view before it is lit, keyed by everything but the light: a light change
    /// re-lights it (no raster, no lines).
    drawn: Kept<Option<mesh::MeshConfig>, Option<Arc<mesh::Drawn>>>,
    source: Kept<SourceParams, Source>,
    gray: Kept<u32, Arc<Gray>>,
    raw: Kept<ToneParams, Arc<(TwoTone, u8)>>,
    /// The picture's side of the likeness measure, made of the two-tone's gray: kept while that
    /// gray stays (a threshold change keeps it; see `ToneParams::gray_key`).
    look: Kept<Option<([f64; 3], bool)>, Arc<tone::Likeness>>,
    cleaned: Kept<CleanParams, Arc<Cleaned>>,
    /// The islands and their walks, keyed by the join's parameters without the weights: a
    /// weight change re-chooses the bridges from the kept walks.
    prepared: Kept<PreparedKey, Arc<Prepared>>,
    joined: Kept<JoinParams, Arc<Joined>>,
    traced: Kept<TraceParams, Arc<(Joined, Traced)>>,
}

/// The stages' outputs up to the bridges.
pub struct Bridged {
    /// Up to the clean-up.
    pub front: Front,
    /// After the bridges, before the trace's neck repairs.
    pub joined: Arc<Joined>,
    /// The joined output's generation (the trace's key).
    pub joined_generation: u64,
}

impl Bridged {
    /// The report known before the trace (what the studio shows with the preview), with this
    /// run's timings.
    pub fn report(&mut self, cfg: &MakeConfig) -> Report {
        let f = &mut self.front;
        let timer = std::mem::take(&mut f.timer);
        outputs::report_joined(cfg, &f.params, &f.cleaned, &self.joined, timer)
    }
}

/// What [`Cache::checked`] adds to a [`Bridged`]: the stencil as `make` writes it, its report,
/// and why `make` would write nothing (the studio shows a refused stencil too, with the reason).
pub struct Checked {
    /// After the trace: `.0.bridged` is the stencil as `make` writes it.
    pub traced: Arc<(Joined, Traced)>,
    /// The stencil's report.
    pub report: Report,
    /// Why `make` would write nothing, when it would not.
    pub refused: Option<Error>,
}

/// The stages' outputs up to the clean-up, with the parameters they were made with.
pub struct Front {
    /// The parameters the stages ran with.
    pub params: StageParams,
    /// The working gray (what the threshold reads; the two-tones share it) and its generation.
    pub gray: Arc<Gray>,
    /// The working gray's generation: it changes when the gray is made again.
    pub gray_generation: u64,
    /// The clean-up's output.
    pub cleaned: Arc<Cleaned>,
    /// The stages this run computed (the others were kept), in order.
    pub ran: Vec<&'static str>,
    /// How long this run's stages took.
    pub timer: Timings,
}

/// The bookkeeping of one run: whether outputs are kept, the generation counter, what ran.
struct Run<'a> {
    keep: bool,
    generations: &'a mut u64,
    ran: Vec<&'static str>,
    superseded: &'a dyn Fn() -> bool,
}

impl Run<'_> {
    /// `f`'s output for `key`: the slot's when it holds that key, else made (and kept when the
    /// cache keeps). Returns it with its generation.
    fn step<K: PartialEq, V: Clone>(
        &mut self,
        slot: &mut Option<Slot<K, V>>,
        name: &'static str,
        key: K,
        f: impl FnOnce() -> Result<V, Stopped>,
    ) -> Result<(u64, V), Stopped> {
        if let Some(s) = slot.as_ref().filter(|s| s.key == key) {
            return Ok((s.generation, s.value.clone()));
        }
        // A failed stage leaves no stale output behind it.
        *slot = None;
        let value = f()?;
        *self.generations += 1;
        self.ran.push(name);
        if self.keep {
            *slot = Some(Slot {
                key,
                generation: *self.generations,
                value: value.clone(),
            });
        }
        Ok((*self.generations, value))
    }

    fn cancel(&self) -> Result<(), Stopped> {
        if (self.superseded)() {
            Err(Stopped::Superseded)
        } else {
            Ok(())
        }
    }
}

impl Cache {
    /// A cache that keeps every stage's output for the next run (the studio).
    pub fn keeping() -> Cache {
        Cache {
            keep: true,
            ..Cache::default()
        }
    }

    /// Read the input again on the next run (it changed on disk): every stage after it runs
    /// again, as their keys hold the input's generation.
    pub fn forget_input(&mut self) {
        self.slots.input = None;
    }

    /// The stages up to the bridges. `superseded` is asked between stages; when it says yes the
    /// run stops with [`Stopped::Superseded`] (the outputs kept so far stay for the next run).
    pub fn bridged(
        &mut self,
        cfg: &MakeConfig,
        start: &Start,
        tweaks: &Tweaks,
        timer: Timings,
        superseded: &dyn Fn() -> bool,
    ) -> Result<Bridged, Stopped> {
        let (f, joined) = self.stages(cfg, start, tweaks, timer, superseded, true)?;
        let (joined, joined_generation) = joined.expect("run through the join");
        Ok(Bridged {
            front: f,
            joined,
            joined_generation,
        })
    }

    /// The list itself: the stages from `start` through the clean-up, then, when `join`, the
    /// islands and the bridges (returned beside the rest, with their generation).
    #[allow(clippy::type_complexity)]
    fn stages(
        &mut self,
        cfg: &MakeConfig,
        start: &Start,
        tweaks: &Tweaks,
        mut timer: Timings,
        superseded: &dyn Fn() -> bool,
        join: bool,
    ) -> Result<(Front, Option<(Arc<Joined>, u64)>), Stopped> {
        let mut run = Run {
            keep: self.keep,
            generations: &mut self.generations,
            ran: Vec::new(),
            superseded,
        };
        let (sg, source) = match start {
            Start::Source(s) => {
                *run.generations += 1;
                (*run.generations, s.clone())
            }
            Start::Input => {
                let sp = SourceParams::of(cfg)?;
                let input_key = match sp {
                    SourceParams::Picture { max_pixels, .. } => Some(max_pixels),
                    SourceParams::Mesh(_) => None,
                };
                let (ig, input) = run.step(&mut self.slots.input, "load", input_key, || {
                    Ok(timer.time("tone", || source::load(&cfg.input, &sp))?)
                })?;
                run.cancel()?;
                let (dg, drawn) =
                    run.step(&mut self.slots.drawn, "draw", (ig, sp.view_key()), || {
                        Ok(timer.time("tone", || source::draw(&input, &sp))?)
                    })?;
                run.cancel()?;
                let light = (dg, sp.clone());
                run.step(&mut self.slots.source, "light", light, || {
                    Ok(timer.time("tone", || source::light(&input, drawn.as_deref(), &sp))?)
                })?
            }
        };
        run.cancel()?;
        let mut params = timer.time("tone", || crate::resolve::stage_params(cfg, &source))?;
        if tweaks.keep_all_islands {
            params.join.drop_islands = false;
        }
        if let Some(draw) = tweaks.two_tone {
            // Drawn by the set: no gray to make, nothing to threshold (never kept: a set runs
            // without a cache).
            let raw = draw(&mut (), &params);
            *run.generations += 1;
            let (gray, rg) = (Arc::clone(&raw.gray), *run.generations);
            let raw = Arc::new((raw, 128));
            return self.slots.after_threshold(
                run,
                tweaks,
                timer,
                join,
                params,
                (gray, rg),
                (raw, rg),
            );
        }
        let factor = params.working.factor;
        let (gg, gray) = run.step(&mut self.slots.gray, "gray", (sg, factor), || {
            Ok(timer.time("tone", || two_tone::working_gray(source.clone(), factor)))
        })?;
        let (rg, raw) = run.step(&mut self.slots.raw, "threshold", (gg, params.tone), || {
            Ok(timer.time("tone", || {
                // The gray is shared with the two-tone, not copied.
                let (mut raw, level) =
                    two_tone::threshold(&source, Arc::clone(&gray), &params.tone);
                if let Some(stamp) = tweaks.after_threshold {
                    stamp(&mut raw, &params);
                }
                Arc::new((raw, level))
            }))
        })?;
        run.cancel()?;
        self.slots
            .after_threshold(run, tweaks, timer, join, params, (gray, gg), (raw, rg))
    }

    /// The trace and the check of the bridges `joined` (of generation `joined_generation`, made
    /// from `cleaned` with `params`; kept while the join and the trace's parameters stay), what
    /// `make` would refuse, the job time and the full report. `ran` gets "trace" when it ran.
    pub fn checked(
        &mut self,
        cfg: &MakeConfig,
        (joined, joined_generation): (&Arc<Joined>, u64),
        cleaned: &Cleaned,
        params: &StageParams,
        ran: &mut Vec<&'static str>,
    ) -> Result<Checked, Stopped> {
        let mut timer = Timings::new(None);
        let never = || false;
        let mut run = Run {
            keep: self.keep,
            generations: &mut self.generations,
            ran: std::mem::take(ran),
            superseded: &never,
        };
        let key = (joined_generation, params.trace.clone());
        let (_, traced) = run.step(&mut self.slots.traced, "trace", key, || {
            let mut j = (**joined).clone();
            let (twotone, picture) = (&joined.twotone.bits, &cleaned.picture);
            let t = vectors::trace(&mut j.bridged, twotone, picture, &params.trace, &mut timer)?;
            Ok(Arc::new((j, t)))
        })?;
        *ran = run.ran;
        let (j, t) = &*traced;
        let refused = vectors::refuse(&cfg.physical, t.fidelity, &t.check).err();
        // The job time for the chosen machine, as `make` plans it.
        let gcode = match (&cfg.gcode, &refused) {
            (Some(gc), None) => {
                let mut geometry = t.geometry.clone();
                Some(outputs::gcode(cfg, gc, &mut geometry, j, &params.trace, &mut timer)?.1)
            }
            _ => None,
        };
        let report = outputs::report(cfg, params, cleaned, j, t, gcode, timer);
        Ok(Checked {
            traced,
            report,
            refused,
        })
    }
}

impl Slots {
    /// The list after the threshold: look, clean, walk, join.
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn after_threshold(
        &mut self,
        mut run: Run<'_>,
        tweaks: &Tweaks,
        mut timer: Timings,
        join: bool,
        params: StageParams,
        (gray, gg): (Arc<Gray>, u64),
        (raw, rg): (Arc<(TwoTone, u8)>, u64),
    ) -> Result<(Front, Option<(Arc<Joined>, u64)>), Stopped> {
        let superseded = run.superseded;
        let look_key = (gg, params.tone.gray_key());
        let (_, look) = run.step(&mut self.look, "look", look_key, || {
            Ok(timer.time("filter", || Arc::new(two_tone::look(&raw.0))))
        })?;
        // A new clean-up is always followed by new walks (their key holds its generation), and
        // its likeness only reports: so where outputs are kept (a person waits for the page)
        // the walks run beside the likeness, inside the clean-up's step, and the walk step below
        // takes their result (unless a newer change came first).
        let mut walked = None;
        let keep = run.keep && join;
        let (cg, cleaned) = run.step(&mut self.cleaned, "clean", (rg, params.clean), || {
            let (raw, level) = Arc::unwrap_or_clone(raw);
            let clean = &params.clean;
            let mut c = timer.time("filter", || {
                clean_up::clean_unmeasured(raw, level, clean, &look)
            });
            let measure = |c: &Cleaned| clean_up::measure(c, clean, &look);
            if keep && !superseded() && tweaks.after_clean.is_none() {
                let (likeness, w) = rayon::join(
                    || measure(&c),
                    || {
                        let mut t = Timings::new(None);
                        let w = bridges::prepare(c.twotone.clone(), c.level, &params.join, &mut t);
                        (w, t)
                    },
                );
                c.likeness = likeness;
                walked = Some(w);
            } else {
                c.likeness = timer.time("filter", || measure(&c));
            }
            if let Some(edit) = tweaks.after_clean {
                edit(&mut c.twotone, &params);
            }
            Ok(Arc::new(c))
        })?;
        // The picture's side of the likeness is read by the clean-up alone: a run that keeps
        // nothing frees it before the bridges (a few MB of a photo's peak memory).
        drop(look);
        run.cancel()?;
        let mut b = Front {
            params,
            gray,
            gray_generation: gg,
            cleaned,
            ran: Vec::new(),
            timer: Timings::default(),
        };
        if !join {
            b.ran = run.ran;
            b.timer = timer;
            return Ok((b, None));
        }
        let (params, cleaned) = (&b.params, &b.cleaned);
        let walk_key = (cg, PreparedKey::of(&params.join));
        let (pg, prepared) = run.step(&mut self.prepared, "walk", walk_key, || {
            let prepared = match walked.take() {
                Some((w, t)) => {
                    for (name, ms) in t.iter() {
                        timer.add(name, ms);
                    }
                    w?
                }
                None => {
                    let mut twotone = cleaned.twotone.clone();
                    if let Some(cost) = tweaks.cost_gray {
                        twotone.gray = Arc::new(cost(&twotone.gray));
                    }
                    bridges::prepare(twotone, cleaned.level, &params.join, &mut timer)?
                }
            };
            Ok(Arc::new(prepared))
        })?;
        run.cancel()?;
        let (jg, joined) = run.step(&mut self.joined, "join", (pg, params.join.clone()), || {
            // The kept walks are lent to the choice, not copied (a weight change's copy of them
            // and the islands was 3 ms of the 33).
            let mut joined = bridges::bridge_prepared(&prepared, &params.join, &mut timer)?;
            if tweaks.cost_gray.is_some() {
                Arc::make_mut(&mut joined.twotone).gray = Arc::clone(&cleaned.twotone.gray);
            }
            Ok(Arc::new(joined))
        })?;
        b.ran = run.ran;
        b.timer = timer;
        Ok((b, Some((joined, jg))))
    }
}

/// `make` in memory: every stage once, from the request's input; nothing is written.
pub fn run(cfg: &MakeConfig) -> Result<Made, Error> {
    let timer = Timings::new(cfg.progress.clone());
    let b = bridged_once(cfg, &Start::Input, &Tweaks::default(), timer)?;
    finish(
        cfg,
        &b.front.params,
        b.front.cleaned,
        b.joined,
        Some(b.front.timer),
    )
}

/// One run through `make`'s end with nothing kept (a set's layer): the result, and the cleaned
/// two-tone's bits it was bridged from.
pub fn made_once(
    cfg: &MakeConfig,
    start: &Start,
    tweaks: &Tweaks,
) -> Result<(Made, BitGrid), Error> {
    let b = bridged_once(cfg, start, tweaks, Timings::new(cfg.progress.clone()))?;
    let cut = b.front.cleaned.twotone.bits.clone();
    Ok((
        outputs::finish_with(
            cfg,
            &b.front.params,
            (b.front.cleaned, b.joined),
            None,
            tweaks.geometry,
        )?,
        cut,
    ))
}

/// One run of the stages up to the bridges with nothing kept (`make`, a set's layers).
fn bridged_once(
    cfg: &MakeConfig,
    start: &Start,
    tweaks: &Tweaks,
    timer: Timings,
) -> Result<Bridged, Error> {
    match Cache::default().bridged(cfg, start, tweaks, timer, &|| false) {
        Ok(b) => Ok(b),
        Err(Stopped::Failed(e)) => Err(e),
        Err(Stopped::Superseded) => unreachable!("nothing supersedes a run that is never asked"),
    }
}

/// The two-tone `make` writes as twotone.png (when no bridge is placed or kept out by hand): the
/// picture at the working resolution after the clean-up for `cfg`'s material and size. What
/// `stencil tone` writes, so that it shows exactly what `make` will bridge; with the level it was
/// cut at and how that level was chosen.
pub fn clean_two_tone(cfg: &MakeConfig) -> Result<Cleaned, Error> {
    let timer = Timings::new(cfg.progress.clone());
    let none = || false;
    match Cache::default().stages(cfg, &Start::Input, &Tweaks::default(), timer, &none, false) {
        Ok((b, _)) => Ok(Arc::unwrap_or_clone(b.cleaned)),
        Err(Stopped::Failed(e)) => Err(e),
        Err(Stopped::Superseded) => unreachable!("nothing supersedes a run that is never asked"),
    }
}

/// The stages up to the clean-up from `start`, with the parameters they ran with (a tiled
/// stencil's whole picture, whose seams are chosen before it is split).
pub fn cleaned_from(cfg: &MakeConfig, start: &Start) -> Result<(Cleaned, StageParams), Error> {
    let timer = Timings::new(cfg.progress.clone());
    let none = || false;
    match Cache::default().stages(cfg, start, &Tweaks::default(), timer, &none, false) {
        Ok((b, _)) => Ok((Arc::unwrap_or_clone(b.cleaned), b.params)),
        Err(Stopped::Failed(e)) => Err(e),
        Err(Stopped::Superseded) => unreachable!("nothing supersedes a run that is never asked"),
    }
}

/// `make`'s writing of a stencil made already (the studio's export of what it shows): the same
/// files, by the same rules, as [`make`].
pub fn write(cfg: &MakeConfig, made: Made) -> Result<(Made, crate::export::Replaced), Error> {
    pipeline::files::write(cfg, made)
}

/// `stencil make`: run the pipeline and write its outputs into `cfg.out_dir`, all or nothing.
/// Files of [`pipeline::OUTPUT_NAMES`] this run did not write are removed (listed in the result).
pub fn make(cfg: &MakeConfig) -> Result<(Made, crate::export::Replaced), Error> {
    let encode = |m: &mut Made| pipeline::files::encode_outputs(m, &cfg.physical);
    pipeline::files::write_with(cfg, || run(cfg), encode)
}
