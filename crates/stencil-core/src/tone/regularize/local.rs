//! The local settle: the monotone phase alone over the whole stencil or only in windows around
//! the bridges, after they are drawn into a regularised two-tone, and the filling of the pockets
//! of cut that overlapping bridges seal off.

use rayon::prelude::*;

use super::disc::Disc;
use super::packed::Packed;
use super::settle::settle;
use super::stats::RegularizeStats;
use super::work::{Price, Work};
use crate::raster::BitGrid;

/// How many pixels of material and of cut are thin for a web or hole `min_width_px` wide: both 0
/// for what [`super::regularize`] returns (the tests' measure of it).
#[cfg(test)]
pub(super) fn thin_count(bits: &BitGrid, min_width_px: f64) -> [usize; 2] {
    let disc = Disc::for_width(min_width_px);
    if disc.span <= 1 || bits.is_empty() {
        return [0, 0];
    }
    let all = [0, 0, bits.width, bits.height];
    let mut work = Work::new(bits, all, all, disc, Price::One);
    work.refresh();
    work.thin.each_ref().map(|m| m.count())
}

/// Settle the whole stencil with the monotone phase alone: fill thin holes and widen thin webs,
/// only adding material, until nothing is thin. After bridges are drawn into a regularised
/// two-tone, every thin pixel is one a bridge made (a cut sliver beside it, a notch in its edge),
/// so this tidies exactly where bridges meet the picture; being monotone it never cuts a bridge
/// and ends (see the module comment). Returns the number of pixels added.
pub(crate) fn settle_all(bits: &mut BitGrid, min_width_px: f64) -> usize {
    let disc = Disc::for_width(min_width_px);
    if disc.span <= 1 || bits.is_empty() {
        return 0;
    }
    let all = [0, 0, bits.width, bits.height];
    let mut work = Work::new(bits, all, all, disc, Price::One);
    settle(&mut work, &mut RegularizeStats::default());
    let out = work.window();
    let added = out.count_material() - bits.count_material();
    *bits = out;
    added
}

/// Fill the pockets of cut that bridges sealed off: cut pieces of `after` whose every material
/// neighbour is material `after` added to `before` (overlapping bridges enclose a piece of the
/// picture's cut). Such a pocket shows nothing of the picture's outline and its ring lies wholly
/// inside bridges, where it only weakens them. Only adds material. Returns the pixels filled.
pub(crate) fn fill_sealed_pockets(before: &BitGrid, after: &mut BitGrid) -> usize {
    // A sealed pocket's material neighbours are all added, so it lies beside an added pixel:
    // only the cut pieces beside added pixels are searched, each until it shows itself open
    // (the picture's border, original material, or a pixel of a piece already found open). So
    // the cost follows the bridges, not the picture; the pieces filled are those a labelling of
    // every cut piece finds sealed.
    let (w, h) = (after.width as usize, after.height as usize);
    if w == 0 || h == 0 {
        return 0;
    }
    const UNSEEN: u8 = 0;
    const OPEN: u8 = 1;
    const HERE: u8 = 2;
    let mut state = vec![UNSEEN; w * h];
    // Breadth first, so a search stops at the original material nearest its seed.
    let (mut queue, mut piece) = (std::collections::VecDeque::new(), Vec::new());
    let mut filled = 0;
    // The added pixels are few and bunched: runs of 64 pixels with none are skipped by one
    // branch-free test (read when the scan reaches them, as the pixel loop would).
    const RUN: usize = 64;
    for run in (0..w * h).step_by(RUN) {
        let end = (run + RUN).min(w * h);
        let any = after.data[run..end]
            .iter()
            .zip(&before.data[run..end])
            .fold(false, |acc, (&a, &b)| acc | (a & !b));
        if !any {
            continue;
        }
        for i in run..end {
            if !after.data[i] || before.data[i] {
                continue;
            }
            for s in crate::raster::edge_neighbours(i, w, h)
                .into_iter()
                .flatten()
            {
                if after.data[s] || state[s] != UNSEEN {
                    continue;
                }
                queue.clear();
                piece.clear();
                state[s] = HERE;
                queue.push_back(s);
                let mut open = false;
                'fill: while let Some(p) = queue.pop_front() {
                    piece.push(p);
                    let (x, y) = (p % w, p / w);
                    if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
                        open = true;
                        break;
                    }
                    for q in [p - 1, p + 1, p - w, p + w] {
                        if after.data[q] {
                            if before.data[q] {
                                open = true;
                                break 'fill;
                            }
                        } else if state[q] == OPEN {
                            open = true;
                            break 'fill;
                        } else if state[q] == UNSEEN {
                            state[q] = HERE;
                            queue.push_back(q);
                        }
                    }
                }
                if open {
                    for &p in piece.iter().chain(&queue) {
                        state[p] = OPEN;
                    }
                } else {
                    for &p in &piece {
                        after.data[p] = true;
                    }
                    filled += piece.len();
                }
            }
        }
    }
    filled
}

/// Where bridges meet the picture: settle the pixels within reach of the bridges' bounding boxes
/// (`[x0, y0, x1, y1)` in pixels), only adding material, so no cut sliver and no web narrower than
/// the material's smallest feature is left beside a bridge. Only the pixels within `spread` disc
/// spans of a box may change; thin features holding none of them are left as they are. Returns
/// the number of pixels added.
pub(crate) fn settle_near(
    bits: &mut BitGrid,
    boxes: &[[u32; 4]],
    min_width_px: f64,
    spread: u32,
) -> usize {
    let disc = Disc::for_width(min_width_px);
    if disc.span <= 1 || bits.is_empty() {
        return 0;
    }
    let reach = disc.span + 1;
    // Boxes whose windows overlap are settled together, in one window with a margin of two spans
    // past the reach (thinness depends on the pixels within two spans); pixels within the margin
    // may be misjudged and may not change ([`clusters`]). Clusters whose boxes do not overlap are
    // independent: they run in waves, a wave's clusters in parallel after every earlier overlapping
    // one, setting the same pixels as settling them one after the other.
    let jobs = clusters(bits, boxes, reach, spread);
    let mut wave = vec![0usize; jobs.len()];
    for j in 0..jobs.len() {
        wave[j] = (0..j)
            .filter(|&i| meets(jobs[i].window, jobs[j].window))
            .map(|i| wave[i] + 1)
            .max()
            .unwrap_or(0);
    }
    let mut added = 0;
    for now in 0..=wave.iter().copied().max().unwrap_or(0) {
        let snapshot: &BitGrid = bits;
        let found: Vec<Vec<(u32, u32)>> = jobs
            .par_iter()
            .zip(&wave)
            .filter(|(_, &k)| k == now)
            .map(|(c, _)| settle_window(snapshot, c.window, &c.own, &c.near, disc, reach))
            .collect();
        for (x, y) in found.into_iter().flatten() {
            bits.set(x, y, true);
            added += 1;
        }
    }
    added
}

/// A cluster of [`settle_near`]'s boxes: the box holding its windows, in which it is settled,
/// and its members' own boxes and their surroundings (`spread` reaches around each).
pub(super) struct Cluster {
    pub(super) window: [u32; 4],
    pub(super) own: Vec<[u32; 4]>,
    pub(super) near: Vec<[u32; 4]>,
}

/// [`settle_near`]'s clusters, in cluster-number order: each box's window (its box grown by two
/// spans past `spread` reaches, clipped to the picture), windows that overlap in one cluster.
pub(super) fn clusters(
    bits: &BitGrid,
    boxes: &[[u32; 4]],
    reach: u32,
    spread: u32,
) -> Vec<Cluster> {
    let (w, h) = (bits.width, bits.height);
    let grow = |b: [u32; 4], m: u32| {
        [
            b[0].saturating_sub(m),
            b[1].saturating_sub(m),
            (b[2] + m).min(w),
            (b[3] + m).min(h),
        ]
    };
    let windows: Vec<[u32; 4]> = boxes
        .iter()
        .map(|&b| grow(b, (2 + spread) * reach))
        .collect();
    let cluster = overlapping(&windows);
    let mut ids = cluster.clone();
    ids.sort_unstable();
    ids.dedup();
    ids.iter()
        .map(|&id| {
            let members: Vec<usize> = (0..boxes.len()).filter(|&i| cluster[i] == id).collect();
            let window = members
                .iter()
                .map(|&i| windows[i])
                .reduce(|a, b| {
                    [
                        a[0].min(b[0]),
                        a[1].min(b[1]),
                        a[2].max(b[2]),
                        a[3].max(b[3]),
                    ]
                })
                .expect("a cluster has a box");
            Cluster {
                window,
                own: members.iter().map(|&i| grow(boxes[i], 0)).collect(),
                near: members
                    .iter()
                    .map(|&i| grow(boxes[i], spread * reach))
                    .collect(),
            }
        })
        .collect()
}

/// Whether two boxes `[x0, y0, x1, y1)` share a pixel.
fn meets(a: [u32; 4], b: [u32; 4]) -> bool {
    a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
}

/// A cluster number per window: windows that overlap, directly or through others, share the
/// smallest of their numbers. Past a few hundred windows, one cluster for all: clustering would
/// cost more than it saves.
fn overlapping(windows: &[[u32; 4]]) -> Vec<usize> {
    let n = windows.len();
    if n > 512 {
        return vec![0; n];
    }
    let mut cluster: Vec<usize> = (0..n).collect();
    loop {
        let mut merged = false;
        for i in 0..n {
            for j in 0..i {
                if cluster[i] != cluster[j] && meets(windows[i], windows[j]) {
                    let (from, to) = (cluster[i].max(cluster[j]), cluster[i].min(cluster[j]));
                    cluster
                        .iter_mut()
                        .filter(|c| **c == from)
                        .for_each(|c| *c = to);
                    merged = true;
                }
            }
        }
        if !merged {
            return cluster;
        }
    }
}

/// [`settle_near`] in one window: the thin features holding a pixel of `boxes` are resolved, and
/// only the pixels in `near` may change (both in picture coordinates). Returns the pixels it
/// turns into material (it leaves `bits` as it is).
pub(super) fn settle_window(
    bits: &BitGrid,
    window: [u32; 4],
    boxes: &[[u32; 4]],
    near: &[[u32; 4]],
    disc: Disc,
    reach: u32,
) -> Vec<(u32, u32)> {
    let (w, h) = (bits.width, bits.height);
    let m = 2 * reach;
    let core = [
        if window[0] == 0 { 0 } else { window[0] + m },
        if window[1] == 0 { 0 } else { window[1] + m },
        if window[2] == w { w } else { window[2] - m },
        if window[3] == h { h } else { window[3] - m },
    ];
    let rel = [
        core[0] - window[0],
        core[1] - window[1],
        core[2].max(core[0]) - window[0],
        core[3].max(core[1]) - window[1],
    ];
    let mut work = Work::new(bits, window, rel, disc, Price::One);
    // What may change: each box and `spread` spans around it, so what a widening there pushes
    // outward is settled too.
    let pad = work.pad;
    let mask = |rects: &[[u32; 4]]| {
        let mut m = Packed::new(work.bits.width, work.bits.height, false);
        for &g in rects {
            for y in g[1]..g[3] {
                for x in g[0]..g[2] {
                    m.set(
                        (x - window[0] + pad) as usize,
                        (y - window[1] + pad) as usize,
                        true,
                    );
                }
            }
        }
        m
    };
    work.seeds = Some(mask(boxes));
    work.allowed = Some(mask(near));
    settle(&mut work, &mut RegularizeStats::default());
    let out = work.window();
    let mut added = Vec::new();
    for y in core[1]..core[3] {
        for x in core[0]..core[2] {
            let v = out.get(x - window[0], y - window[1]);
            if v && !bits.get(x, y) {
                added.push((x, y));
            }
        }
    }
    added
}
