//! Islands and bridges (the paper's Stages 2-5): islands under `min_island_mm2` and those whose
//! dropping changes the picture less than their cheapest bridge cut away (the report and the
//! preview count them as material the picture lost), the islands labelled and walked from
//! ([`prepare`]), the bridges chosen (the spanning tree, the user's places and keep-out areas) and
//! grown to width, the clean-up around them (the settle and the sealed-pocket fill after the
//! regularisation, else the tidy pass; what it put in a keep-out area goes again), and refused if
//! anything floats (a bug, said as such, rather than a stencil in pieces) ([`bridge_prepared`]).

use std::sync::Arc;

use crate::bridge::{self, Bridged};
use crate::error::Error;
use crate::islands;
use crate::plan::{JoinParams, UserParams};
use crate::raster::TwoTone;
use crate::timing::Timings;
use crate::tone::regularize::{fill_sealed_pockets, settle_near};

/// How many disc spans around the bridges the settle after bridging may change (see
/// [`bridge_prepared`]).
const JOIN_SPREAD: u32 = 2;

/// The islands of the cleaned two-tone joined to the frame, and what went into it. The two-tone,
/// the islands and the dropped pixels are [`Prepared`]'s, shared: copying them cost a studio's
/// bridge-weight change more than drawing the bridges did.
#[derive(Clone, Debug)]
pub struct Joined {
    /// The two-tone the bridges were drawn into (the islands under `min_island_mm2` cut away).
    pub twotone: Arc<TwoTone>,
    /// What the user's `--bridge-at` / keep-out requests became, when there were any.
    pub user: Option<crate::report::UserBridgesReport>,
    /// The islands before bridging.
    pub map: Arc<islands::IslandMap>,
    /// The stencil: the two-tone with its bridges.
    pub bridged: Bridged,
    /// Islands dropped instead of bridged (see `bridge::drop`), in mm, and their pixels (cut in
    /// `twotone`; the preview shows them in their own colour).
    pub dropped: Vec<bridge::drop::Dropped>,
    /// The dropped islands' pixels.
    pub dropped_px: Arc<Vec<u32>>,
}

/// What the bridges are chosen from: the two-tone with the small and the dropped islands
/// cut away, its islands and their walks. None of it reads the bridge weights, the support
/// margin or the strength rules, so the studio keeps it while a person tries weights (see
/// [`PreparedKey`]).
#[derive(Clone, Debug)]
pub struct Prepared {
    /// The two-tone with the small and the dropped islands cut away.
    pub twotone: Arc<TwoTone>,
    /// What the user's bridge requests became, when there were any.
    pub user: Option<crate::report::UserBridgesReport>,
    /// Its islands.
    pub map: Arc<islands::IslandMap>,
    /// The islands dropped, in mm.
    pub dropped: Vec<bridge::drop::Dropped>,
    /// Their pixels.
    pub dropped_px: Arc<Vec<u32>>,
    /// The bridge candidates and their walks.
    pub walks: bridge::Walks,
}

/// The parameters a [`Prepared`] depends on: the join's, but for what only the choice of bridges
/// reads (the weights, the support margin, the strength rules).
#[derive(Clone, Debug, PartialEq)]
pub struct PreparedKey {
    walks: bridge::WalkKey,
    user: Option<UserParams>,
    kept_out_px: usize,
    settle_px: Option<f64>,
    tidy_radius: u32,
    mm_per_px: f64,
    drop_islands: bool,
}

impl PreparedKey {
    /// The key of `p`.
    pub fn of(p: &JoinParams) -> PreparedKey {
        PreparedKey {
            walks: bridge::WalkKey::of(&p.bridge),
            user: p.user.clone(),
            kept_out_px: p.kept_out_px,
            settle_px: p.settle_px,
            tidy_radius: p.tidy_radius,
            mm_per_px: p.mm_per_px,
            drop_islands: p.drop_islands,
        }
    }
}

/// The join's first half: islands under `min_island_mm2` cut away, the islands cheaper to drop
/// than to bridge dropped (unless `p.drop_islands` is off; `level` is the threshold the two-tone
/// was cut at, what the change is priced against), the islands labelled and walked from.
pub fn prepare(
    mut twotone: TwoTone,
    level: u8,
    p: &JoinParams,
    timer: &mut Timings,
) -> Result<Prepared, Error> {
    let user = timer.time("user_bridges", || cut_small_islands(&mut twotone, p));
    let (dropped, dropped_px, map) = if p.drop_islands {
        let (dropped, px, map, gone) = timer.time("drop", || drop_islands(&mut twotone, level, p));
        // The map after the drop, from the one the drop chose by (no second labelling).
        let map = timer.time("islands", || islands::without(map, &gone));
        (dropped, px, map)
    } else {
        let map = timer.time("islands", || islands::label(&twotone.bits));
        (Vec::new(), Vec::new(), map)
    };
    let walks = timer.time("bridge", || {
        let mut t = Timings::default();
        bridge::walk(&twotone, &map, &p.bridge, &mut t)
    })?;
    Ok(Prepared {
        twotone: Arc::new(twotone),
        user,
        map: Arc::new(map),
        dropped,
        dropped_px: Arc::new(dropped_px),
        walks,
    })
}

/// The join's second half: the bridges chosen from `prepared` (made by [`prepare`] for the same
/// [`PreparedKey`]) and drawn, the clean-up around them, and the check that nothing floats.
/// `prepared` is only read (the studio keeps it for the next weights): the result shares its
/// two-tone, islands and dropped pixels (and copies the few dropped islands' descriptions), and
/// its walks are lent, not copied.
pub fn bridge_prepared(
    prepared: &Prepared,
    p: &JoinParams,
    timer: &mut Timings,
) -> Result<Joined, Error> {
    let (twotone, map) = (&prepared.twotone, &prepared.map);
    let mut bridged = timer.time("bridge", || {
        let mut t = Timings::default();
        bridge::connect_walked(twotone, map, &p.bridge, &prepared.walks, &mut t)
    })?;
    timer.time("tidy", || match p.settle_px {
        Some(px) => {
            // The regularised two-tone has nothing thin: what is thin now, a bridge made, within
            // a disc span of what it drew. So the settle runs around the bridges only (a span
            // past what they drew, changing up to two spans farther), not over the picture.
            let span = px.ceil() as u32 + 1;
            let (w, h) = (bridged.bits.width, bridged.bits.height);
            let boxes: Vec<[u32; 4]> = bridged
                .drawn_boxes()
                .into_iter()
                .map(|b| {
                    [
                        b[0].saturating_sub(span),
                        b[1].saturating_sub(span),
                        (b[2] + span).min(w),
                        (b[3] + span).min(h),
                    ]
                })
                .collect();
            settle_near(&mut bridged.bits, &boxes, px, JOIN_SPREAD);
            fill_sealed_pockets(&twotone.bits, &mut bridged.bits);
        }
        None => {
            bridged.bits = bridge::tidy::tidy(&twotone.bits, &bridged.bits, p.tidy_radius);
        }
    });
    // The clean-up may round a bridge's corners into a keep-out area: what it added there goes.
    if let Some(f) = &p.bridge.user.keep_out {
        for (i, b) in bridged.bits.data.iter_mut().enumerate() {
            if *b && f.data[i] && !twotone.bits.data[i] {
                *b = false;
            }
        }
    }
    // Counted from what the bridges and the clean-up added (they only add), labelled only when
    // something floats (to say where).
    let floating = timer.time("verify", || {
        islands::floating_after_adding(map, &twotone.bits, &bridged.bits)
    });
    if floating > 0 {
        let after = islands::label(&bridged.bits);
        let node = &after.nodes[1];
        let (x, y) = node.border.first().copied().unwrap_or((0, 0));
        return Err(Error::Floating {
            count: after.island_count(),
            x,
            y,
            area: node.area,
        });
    }
    Ok(Joined {
        twotone: Arc::clone(&prepared.twotone),
        user: prepared.user.clone(),
        map: Arc::clone(&prepared.map),
        bridged,
        dropped: prepared.dropped.clone(),
        dropped_px: Arc::clone(&prepared.dropped_px),
    })
}

/// Drop the islands that are cheaper to drop than to bridge (`bridge::drop::choose`), never one
/// a `--bridge-at` point asks for (the island under the point, or the nearest). Returns them in
/// mm, their pixels, the island map of the bits before the drop and which of its nodes went
/// (for [`islands::without`]).
#[allow(clippy::type_complexity)]
fn drop_islands(
    two: &mut TwoTone,
    level: u8,
    p: &JoinParams,
) -> (
    Vec<bridge::drop::Dropped>,
    Vec<u32>,
    islands::IslandMap,
    Vec<bool>,
) {
    let map = islands::label(&two.bits);
    if map.island_count() == 0 {
        return (Vec::new(), Vec::new(), map, Vec::new());
    }
    let mut protected = vec![false; map.nodes.len()];
    for &[ax, ay] in &p.bridge.user.at {
        // The island under the point, else the one with the nearest border pixel.
        let (x, y) = (ax.max(0.0) as u32, ay.max(0.0) as u32);
        let under = (x < map.width && y < map.height)
            .then(|| map.label(x, y))
            .filter(|&l| l != islands::CUT && l != islands::FRAME);
        let nearest = under.or_else(|| {
            map.nodes
                .iter()
                .enumerate()
                .skip(1)
                .flat_map(|(n, node)| node.border.iter().map(move |&b| (n, b)))
                .min_by(|a, b| {
                    let d =
                        |(bx, by): (u32, u32)| (bx as f64 + 0.5 - ax).hypot(by as f64 + 0.5 - ay);
                    d(a.1).total_cmp(&d(b.1))
                })
                .map(|(n, _)| n as u32)
        });
        if let Some(n) = nearest {
            protected[n as usize] = true;
        }
    }
    let (lo, hi) = (
        p.bridge.min_width_px,
        p.bridge.max_width_px.max(p.bridge.min_width_px),
    );
    let chosen = bridge::drop::choose(&map, &two.gray, level, &protected, |area| {
        ((area as f64).sqrt() / 4.0)
            .ceil()
            .clamp(lo as f64, hi as f64) as u32
    });
    let mm = p.mm_per_px;
    let mut gone = vec![false; map.nodes.len()];
    let mut out = Vec::with_capacity(chosen.len());
    for (n, mut d) in chosen {
        gone[n as usize] = true;
        d.at_mm = [d.at_mm[0] * mm, d.at_mm[1] * mm];
        d.area_mm2 *= mm * mm;
        out.push(d);
    }
    // The dropped islands' pixels become cut, found from their runs (their area, not a pass over
    // the picture), listed in pixel order.
    let w = map.width as usize;
    let mut px: Vec<u32> = Vec::new();
    for n in (0..gone.len()).filter(|&n| gone[n]) {
        for (y, x0, x1) in map.island_runs(n) {
            let row = y as usize * w;
            two.bits.data[row + x0 as usize..=row + x1 as usize].fill(false);
            px.extend(row as u32 + x0..=row as u32 + x1);
        }
    }
    px.sort_unstable();
    (out, px, map, gone)
}

/// Islands under `min_island_mm2` cut away, and the report of the user's bridge options.
fn cut_small_islands(
    two: &mut TwoTone,
    p: &JoinParams,
) -> Option<crate::report::UserBridgesReport> {
    let u = p.user.as_ref()?;
    let mm = u.mm_per_px;
    let mut report = crate::report::UserBridgesReport {
        min_island_mm2: u.min_island_mm2,
        kept_out_px: p.kept_out_px,
        ..Default::default()
    };
    if u.min_island_mm2 > 0.0 {
        let map = islands::label(&two.bits);
        let small: Vec<bool> = map
            .nodes
            .iter()
            .enumerate()
            .map(|(n, node)| {
                n as u32 != islands::FRAME && (node.area as f64) * mm * mm < u.min_island_mm2
            })
            .collect();
        for (i, &l) in map.labels.iter().enumerate() {
            if l != islands::CUT && small[l as usize] {
                two.bits.data[i] = false;
                report.cut_away_mm2 += mm * mm;
            }
        }
        report.islands_cut_away = small.iter().filter(|&&s| s).count();
    }
    Some(report)
}
