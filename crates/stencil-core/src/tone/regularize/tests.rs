//! The regularisation's tests: the rule holds on what it returns, and each fast path (tiles,
//! kept features, multiplied rows, waves of windows) gives what the plain way gives.

use super::disc::*;
use super::features::*;
use super::local::*;
use super::packed::*;
use super::work::*;
use super::*;
use crate::raster::Run;
use crate::test_rng::Lcg;

/// A `w`×`h` grid of `cell`-pixel blocks, each material with chance `dense` in 10 (drawn
/// from `rnd`, row of blocks by row): noise at cell 1, pieces of many sizes above it.
fn blocky(w: u32, h: u32, cell: u32, dense: u64, rnd: &mut impl FnMut(u64) -> u64) -> BitGrid {
    let noise: Vec<bool> = (0..(w / cell + 1) * (h / cell + 1))
        .map(|_| rnd(10) < dense)
        .collect();
    BitGrid::from_fn(w, h, |x, y| {
        noise[((y / cell) * (w / cell + 1) + x / cell) as usize]
    })
}

fn cfg(px: f64) -> RegularizeConfig {
    RegularizeConfig {
        min_width_px: px,
        threshold: 0.5,
        invert: false,
    }
}

/// The sealed pockets by labelling every cut piece (what the seeded search must match).
fn sealed_by_labels(before: &BitGrid, after: &BitGrid) -> BitGrid {
    let (labels, areas) = crate::raster::components(after, false);
    let (w, h) = (after.width as usize, after.height as usize);
    let mut open = vec![false; areas.len()];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let l = labels[i];
            if l == crate::raster::NOT_LABELLED {
                continue;
            }
            if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
                open[l as usize] = true;
                continue;
            }
            for j in [i - 1, i + 1, i - w, i + w] {
                if after.data[j] && before.data[j] {
                    open[l as usize] = true;
                }
            }
        }
    }
    let mut out = after.clone();
    for (i, &l) in labels.iter().enumerate() {
        if l != crate::raster::NOT_LABELLED && !open[l as usize] {
            out.data[i] = true;
        }
    }
    out
}

#[test]
fn sealed_pockets_are_the_cut_pieces_no_original_material_or_border_touches() {
    let mut rng = Lcg(11u64);
    let mut rnd = |n: u64| rng.below(n);
    let mut filled_some = false;
    for case in 0..300 {
        let (w, h) = (3 + rnd(30) as u32, 3 + rnd(30) as u32);
        let dense = 2 + rnd(6);
        let before = BitGrid::from_fn(w, h, |_, _| rnd(10) < dense);
        let mut after = before.clone();
        // Bridges: random rectangles of added material, some of them rings.
        for _ in 0..1 + rnd(4) {
            let (x0, y0) = (rnd(w as u64) as u32, rnd(h as u64) as u32);
            let (x1, y1) = (x0 + 1 + rnd(10) as u32, y0 + 1 + rnd(10) as u32);
            let ring = rnd(2) == 0;
            for y in y0..y1.min(h) {
                for x in x0..x1.min(w) {
                    let edge = x == x0 || y == y0 || x + 1 == x1 || y + 1 == y1;
                    if !ring || edge {
                        after.set(x, y, true);
                    }
                }
            }
        }
        let want = sealed_by_labels(&before, &after);
        let mut got = after.clone();
        let n = fill_sealed_pockets(&before, &mut got);
        assert_eq!(got, want, "case {case}");
        assert_eq!(n, want.count_material() - after.count_material());
        filled_some |= n > 0;
    }
    assert!(filled_some, "some case had a sealed pocket");
}

/// [`settle_near`] as it was: the clusters settled one after the other, each writing into
/// the bits before the next reads them.
fn settle_near_in_turn(
    bits: &mut BitGrid,
    boxes: &[[u32; 4]],
    min_width_px: f64,
    spread: u32,
) -> usize {
    let disc = Disc::for_width(min_width_px);
    let reach = disc.span + 1;
    let mut added = 0;
    for c in clusters(bits, boxes, reach, spread) {
        for (x, y) in settle_window(bits, c.window, &c.own, &c.near, disc, reach) {
            bits.set(x, y, true);
            added += 1;
        }
    }
    added
}

/// Settling the clusters in waves, each wave in parallel, adds the pixels settling them one
/// after the other adds: random bits, random boxes (clusters whose boxes overlap, L-shaped
/// clusters whose box holds another's windows, far-apart ones).
#[test]
fn settle_near_in_waves_is_settling_in_turn() {
    let mut rng = Lcg(0x5eed_u64);
    let mut rnd = |n: u64| rng.below(n);
    let mut changed = 0;
    for case in 0..60 {
        let (w, h) = (60 + rnd(200) as u32, 60 + rnd(200) as u32);
        let dense = 3 + rnd(5);
        let cell = 1 + rnd(4) as u32;
        let bits = blocky(w, h, cell, dense, &mut rnd);
        let boxes: Vec<[u32; 4]> = (0..1 + rnd(12))
            .map(|_| {
                let (x0, y0) = (rnd(w as u64) as u32, rnd(h as u64) as u32);
                let (x1, y1) = (x0 + 1 + rnd(12) as u32, y0 + 1 + rnd(12) as u32);
                [x0, y0, x1.min(w), y1.min(h)]
            })
            .collect();
        let px = [3.0, 4.5, 6.0][case % 3];
        let (mut want, mut got) = (bits.clone(), bits.clone());
        let n_want = settle_near_in_turn(&mut want, &boxes, px, 1);
        let n_got = settle_near(&mut got, &boxes, px, 1);
        assert_eq!(got, want, "case {case}");
        assert_eq!(n_got, n_want, "case {case}");
        changed += n_got;
    }
    assert!(changed > 0, "some case settled something");
}

/// The depth probed by bit index inside the grid is the depth probed with bounds checks, at
/// every lattice point of random grids (sparse, dense, blocky), odd and even spans.
#[test]
fn depth_by_bit_index_is_depth_with_checks() {
    let mut rng = Lcg(0xd3e9_u64);
    let mut rnd = |n: u64| rng.below(n);
    for case in 0..40 {
        let (w, h) = (1 + rnd(150) as u32, 1 + rnd(60) as u32);
        let dense = rnd(11);
        let cell = 1 + rnd(5) as u32;
        let bits = blocky(w, h, cell, dense, &mut rnd);
        let px = [2.0, 3.0, 4.0, 5.0, 6.0, 11.0, 12.0, 40.0, 71.0][case % 9];
        let disc = Disc::for_width(px);
        let all = [0, 0, w, h];
        let work = Work::new(&bits, all, all, disc, Price::One);
        let c = disc.on_corners() as i64;
        for cy in 0..work.bits.height as i64 + c {
            for cx in 0..work.bits.width as i64 + c {
                assert_eq!(
                    work.lattice_depth(cx, cy),
                    work.lattice_depth_checked(cx, cy),
                    "case {case} span {} at ({cx}, {cy})",
                    disc.span
                );
            }
        }
    }
}

/// Coordinates by the multiply are coordinates by division: random and extreme widths and
/// indices within 32 bits, and the fallback past them.
#[test]
fn rows_by_multiply_are_rows_by_division() {
    let mut rng = Lcg(0xd1f);
    let mut next = || rng.next_u64() >> 32;
    let max = u32::MAX as usize;
    let mut widths: Vec<usize> = vec![1, 2, 3, 7, 63, 64, 65, 1000, 1031, 65535, 65536, max];
    widths.extend((0..200).map(|_| 1 + next() as usize % 5000));
    widths.extend((0..50).map(|_| 2 + next() as usize));
    for &w in &widths {
        let h = (max / w).max(1);
        let rows = Rows::new(w, h);
        let last = (w * h).min(max);
        let mut idx: Vec<usize> = vec![0, 1, w - 1, w, w + 1, last, last - 1, last / 2];
        idx.extend((0..300).map(|_| next() as usize % (last + 1)));
        for i in idx {
            assert_eq!(rows.xy(i), (i % w, i / w), "width {w} index {i}");
        }
    }
    let big = Rows::new(1 << 20, 1 << 20);
    assert_eq!(big.c, 0);
    assert_eq!(big.xy((5 << 20) + 3), (3, 5));
}

/// The depths a refresh keeps, searched from where the point before in the row allows
/// ([`ring_from`]), are the depths searched from the ring's start with bounds checks, at
/// every centre of every thin pixel of random grids (sparse, dense, blocky; odd and even
/// spans, small and large).
#[test]
fn depths_searched_from_the_neighbours_bound_are_full_searches() {
    let mut rng = Lcg(0xdeb7_u64);
    let mut rnd = |n: u64| rng.below(n);
    let mut checked = 0;
    for case in 0..60 {
        let (w, h) = (1 + rnd(220) as u32, 1 + rnd(90) as u32);
        let dense = rnd(11);
        let cell = 1 + rnd(7) as u32;
        let bits = blocky(w, h, cell, dense, &mut rnd);
        let px = [2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 11.0, 12.0, 17.0, 24.0][case % 10];
        let disc = Disc::for_width(px);
        let all = [0, 0, w, h];
        let mut work = Work::new(&bits, all, all, disc, Price::One);
        work.refresh();
        let (pw, ph) = (work.bits.width, work.bits.height);
        let c = disc.on_corners() as usize;
        for y in 0..ph {
            for x in 0..pw {
                if !(work.thin[0].get(x, y) || work.thin[1].get(x, y)) {
                    continue;
                }
                for (ox, oy) in [(0, 0), (c, 0), (0, c), (c, c)] {
                    let (cx, cy) = (x + ox, y + oy);
                    assert_eq!(
                        work.depth2[cy * (pw + c) + cx],
                        work.lattice_depth_checked(cx as i64, cy as i64),
                        "case {case} span {} at ({cx}, {cy})",
                        disc.span
                    );
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 1000, "{checked} depths checked");
}

/// The widening by one scratch kept over features and grids is the pixel-by-pixel one
/// ([`widening_old`]): the same pixels in the same order, for every thin feature of both
/// tones of random grids (sparse, dense, blocky; odd and even spans).
#[test]
fn widening_with_kept_scratch_is_the_pixel_by_pixel_widening() {
    let mut rng = Lcg(0x71de_u64);
    let mut rnd = |n: u64| rng.below(n);
    let mut scratch = WidenScratch::default();
    let mut widened = 0;
    for case in 0..60 {
        let (w, h) = (1 + rnd(260) as u32, 1 + rnd(120) as u32);
        let (cell, dense) = (1 + rnd(7) as u32, rnd(11));
        let bits = blocky(w, h, cell, dense, &mut rnd);
        let px = [2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 11.0, 12.0, 17.0, 24.0][case % 10];
        let disc = Disc::for_width(px);
        let all = [0, 0, w, h];
        let mut work = Work::new(&bits, all, all, disc, Price::One);
        work.refresh();
        let (pw, ph) = (work.bits.width, work.bits.height);
        let mut seen = Packed::new(pw, ph, false);
        let mut depths = Vec::new();
        for phase in [true, false] {
            for g in groups(&work.thin[!phase as usize], None) {
                let want = widening_old(&work, &g, phase, &mut seen, &mut depths);
                let got = widening(&work, &g, phase, &mut scratch);
                assert_eq!(got, want, "case {case}: {w}x{h} span {}", disc.span);
                widened += 1;
            }
        }
        assert!(seen.data.iter().all(|&v| v == 0));
        assert!(scratch.seen.data.iter().all(|&v| v == 0));
        assert!(scratch.depths.iter().all(|&v| v == 0));
    }
    assert!(widened > 1000, "{widened} features widened");
}

/// Rounds after the first recompute thinness and depths only near the pixels changed since
/// and keep the features nothing near changed: the same thin pixels, depths and features
/// (pixels, widening) as a fresh grid's first round, on random blocky two-tones changed at
/// random over several rounds, odd and even spans.
#[test]
fn refresh_near_changes_is_refresh_of_all() {
    let mut rng = Lcg(0x1dc_u64);
    let mut rnd = |n: u64| rng.below(n);
    let mut kept = 0;
    for case in 0..30 {
        let (w, h) = (1 + rnd(400) as u32, 1 + rnd(250) as u32);
        let (cell, dense) = (1 + rnd(5) as u32, rnd(11));
        let bits = blocky(w, h, cell, dense, &mut rnd);
        let disc = Disc::for_width([3.0, 4.0, 5.0, 6.0, 11.0, 12.0][case % 6]);
        let all = [0, 0, w, h];
        let mut work = Work::new(&bits, all, all, disc, Price::One);
        let feats = features(&mut work, true);
        work.keep(feats);
        for round in 0..4 {
            let p = work.pad as usize;
            for _ in 0..rnd(6) {
                let (x0, y0, n) = (rnd(w as u64) as usize, rnd(h as u64) as usize, rnd(4));
                for y in y0..(y0 + n as usize + 1).min(h as usize) {
                    for x in x0..(x0 + n as usize + 1).min(w as usize) {
                        let v = !work.bits.get(x + p, y + p);
                        work.flip(x + p, y + p, v);
                    }
                }
            }
            let got = features(&mut work, true);
            let mut fresh = Work::new(&work.window(), all, all, disc, Price::One);
            let want = features(&mut fresh, true);
            let at = format!("case {case} round {round}: {w}x{h} span {}", disc.span);
            assert_eq!(work.thin, fresh.thin, "{at}");
            for i in 0..work.bits.width * work.bits.height {
                if work.thin[0].at(i) || work.thin[1].at(i) {
                    assert_eq!(work.depth(i), fresh.depth(i), "{at}, pixel {i}");
                }
            }
            assert_eq!(got.len(), want.len(), "{at}");
            for (g, f) in got.iter().zip(&want) {
                assert_eq!((g.phase, &g.pixels), (f.phase, &f.pixels), "{at}");
                assert_eq!(g.widen, f.widen, "{at}");
            }
            kept += got.iter().filter(|f| f.cost.is_some()).count();
            let mut got = got;
            // Mark them as priced, so a feature taken from the kept list shows it.
            got.iter_mut().for_each(|f| f.cost = Some((None, None)));
            work.keep(got);
        }
    }
    assert!(kept > 0, "some features were kept");
}

fn any_thin(bits: &BitGrid, px: f64) -> bool {
    thin_count(bits, px) != [0, 0]
}

#[test]
fn disc_spans_the_smallest_odd_width() {
    assert_eq!(Disc::for_width(5.0).span, 5);
    assert_eq!(Disc::for_width(4.2).span, 5);
    assert_eq!(Disc::for_width(6.0).span, 6);
    assert_eq!(Disc::for_width(0.5).span, 1);
}

#[test]
fn groups_are_the_8_connected_pieces() {
    let mut rng = Lcg(3);
    for (w, h, density) in [
        (70usize, 9usize, 6u64),
        (130, 20, 9),
        (64, 64, 3),
        (1, 5, 8),
    ] {
        let mut mask = Packed::new(w, h, false);
        let mut seeds = Packed::new(w, h, false);
        for y in 0..h {
            for x in 0..w {
                let r = rng.next_u64();
                mask.set(x, y, (r >> 60) < density);
                seeds.set(x, y, (r >> 40) & 31 == 0);
            }
        }
        // Flood fill, pixel by pixel.
        let mut label = vec![usize::MAX; w * h];
        let mut want: Vec<Vec<usize>> = Vec::new();
        for i in 0..w * h {
            if !mask.at(i) || label[i] != usize::MAX {
                continue;
            }
            let mut stack = vec![i];
            label[i] = want.len();
            let mut g = Vec::new();
            while let Some(j) = stack.pop() {
                g.push(j);
                let (x, y) = ((j % w) as i64, (j / w) as i64);
                for (dx, dy) in (-1..=1).flat_map(|a| (-1..=1).map(move |b| (a, b))) {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64 {
                        let k = ny as usize * w + nx as usize;
                        if mask.at(k) && label[k] == usize::MAX {
                            label[k] = want.len();
                            stack.push(k);
                        }
                    }
                }
            }
            g.sort_unstable();
            want.push(g);
        }
        assert_eq!(groups(&mask, None), want, "{w}x{h}");
        // Groups the caller has: no pixel of theirs is fresh and it knows their first pixel.
        let fresh_at = |i: usize| (i % w + 3 * (i / w)).is_multiple_of(11);
        let known = |first: usize| !first.is_multiple_of(3);
        let with_kept: Vec<Group> = want
            .iter()
            .map(|g| {
                if !g.iter().any(|&i| fresh_at(i)) && known(g[0]) {
                    Group::Kept(g[0])
                } else {
                    Group::Pixels(g.clone())
                }
            })
            .collect();
        let fresh = |r: &Run| (r.x0..=r.x1).any(|x| fresh_at(r.y as usize * w + x as usize));
        assert_eq!(
            groups_where(&mask, None, fresh, known),
            with_kept,
            "{w}x{h} kept"
        );
        let seeded: Vec<Vec<usize>> = want
            .into_iter()
            .filter(|g| g.iter().any(|&i| seeds.at(i)))
            .collect();
        assert_eq!(groups(&mask, Some(&seeds)), seeded, "{w}x{h} seeded");
    }
}

#[test]
fn checkerboards_end_with_nothing_thin_and_wide_ones_are_kept() {
    for cell in [1u32, 2, 3, 5, 8, 13] {
        let bits = BitGrid::from_fn(90, 70, |x, y| ((x / cell) + (y / cell)) % 2 == 0);
        let gray = Gray::new(90, 70, 0.5);
        let (out, _) = regularize(&bits, &gray, &cfg(6.0));
        assert!(!any_thin(&out, 6.0), "cell {cell}");
    }
    // Squares wider than the disc touching only at corners: the corners are thin (no width
    // there), the squares' middles stay.
    let bits = BitGrid::from_fn(80, 80, |x, y| ((x / 20) + (y / 20)) % 2 == 0);
    let (out, _) = regularize(&bits, &Gray::new(80, 80, 0.5), &cfg(6.0));
    assert!(!any_thin(&out, 6.0));
    for (x, y) in [(10, 10), (30, 30), (50, 10), (10, 50)] {
        assert_eq!(out.get(x, y), bits.get(x, y), "({x}, {y})");
    }
}

#[test]
fn the_gray_picture_decides_between_removing_and_widening() {
    // A cut line 4 px wide (the disc is 6) across paper. Same bits, two pictures.
    let bits = BitGrid::from_fn(60, 40, |_, y| !(18..22).contains(&y));
    let line_width = |out: &BitGrid| (0..40).filter(|&y| !out.get(30, y)).count();
    // A black line on paper that is barely light: widening (into near-threshold paper) is
    // cheaper than erasing a plainly dark line.
    let mut gray = Gray::new(60, 40, 0.55);
    for y in 18..22 {
        for x in 0..60 {
            gray.set(x, y, 0.0);
        }
    }
    let (out, s) = regularize(&bits, &gray, &cfg(6.0));
    assert_eq!(line_width(&out), 6, "{s:?}");
    // A faint line (just under the threshold) on white paper: erasing it changes less.
    let mut gray = Gray::new(60, 40, 1.0);
    for y in 18..22 {
        for x in 0..60 {
            gray.set(x, y, 0.45);
        }
    }
    let (out, s) = regularize(&bits, &gray, &cfg(6.0));
    assert_eq!(line_width(&out), 0, "{s:?}");
}

#[test]
fn noise_ends_with_nothing_thin() {
    // Pseudo-random noise: the hardest case for deciding; the monotone phase must finish it.
    let mut rng = Lcg(12345);
    let bits = BitGrid::from_fn(80, 60, |_, _| rng.below(2) == 1);
    let gray = Gray::new(80, 60, 0.5);
    let (out, stats) = regularize(&bits, &gray, &cfg(5.0));
    assert!(!any_thin(&out, 5.0), "{stats:?}");
}

/// A pixel's eight neighbours, as offsets: a fixed list [`widening_old`]'s ridge test runs
/// through without building an iterator of pairs per pixel.
#[cfg(test)]
const AROUND: [(i64, i64); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// The pixels of the other tone within the disc of each ridge pixel of a thin feature: its pixels whose depth is at least each of their 8-neighbours' in the feature. The
/// disc is centred on the pixel (odd span) or on its deepest corner (even span), so once painted
/// that centre is a valid one and covers the ridge pixel. `seen` is all clear scratch the size of
/// the grid, left clear.
#[cfg(test)]
fn widening_old(
    work: &Work,
    feature: &[usize],
    phase: bool,
    seen: &mut Packed,
    depths: &mut Vec<u16>,
) -> Vec<usize> {
    let bits = &work.bits;
    let mask = &work.thin[!phase as usize];
    let (w, h) = (bits.width as i64, bits.height as i64);
    // Each pixel's depth once (an even span's is the largest of four corners'), where the
    // ridge test below reads each up to nine times.
    depths.resize(bits.width * bits.height, 0);
    for &i in feature {
        let (x, y) = work.rows.xy(i);
        depths[i] = work.depth_xy(x, y).0;
    }
    let depths = &depths[..];
    // A neighbour's depth, or none when it is not in the feature (a thin pixel of the same tone
    // next to one of the feature is in it: features are 8-connected, so its depth was just set).
    let depth_at = |nx: i64, ny: i64| -> Option<u16> {
        if nx < 0 || ny < 0 || nx >= w || ny >= h || !mask.get(nx as usize, ny as usize) {
            return None;
        }
        Some(depths[(ny * w + nx) as usize])
    };
    let mut out = Vec::new();
    for &i in feature {
        let (x, y) = work.rows.xy(i);
        let d = depths[i];
        let (x, y) = (x as i64, y as i64);
        let ridge = AROUND
            .iter()
            .all(|&(dx, dy)| depth_at(x + dx, y + dy) <= Some(d));
        if !ridge {
            continue;
        }
        // A ridge two pixels thick (a line an even number of pixels wide) keeps one of its rows
        // or columns: discs on both would widen the line by a pixel more than it needs.
        if (depth_at(x, y - 1) == Some(d) && depth_at(x, y + 1) < Some(d))
            || (depth_at(x - 1, y) == Some(d) && depth_at(x + 1, y) < Some(d))
        {
            continue;
        }
        // Row by row, a word at a time: the other tone's pixels in the disc not yet listed.
        let centre = work.depth_xy(x as usize, y as usize).1;
        for &(dy, a, b) in &work.paint[centre] {
            let ny = y + dy;
            let (x0, x1) = ((x + a).max(0), (x + b).min(w - 1));
            if ny < 0 || ny >= h || x0 > x1 {
                continue;
            }
            let (x0, x1, ny) = (x0 as usize, x1 as usize, ny as usize);
            for k in x0 / 64..=x1 / 64 {
                let lo = if k == x0 / 64 { x0 % 64 } else { 0 };
                let hi = if k == x1 / 64 { x1 % 64 } else { 63 };
                let span = (!0u64 << lo) & (!0u64 >> (63 - hi));
                let word = bits.row(ny)[k];
                let other = if phase { !word } else { word };
                let mut hits = other & span & !seen.row(ny)[k];
                seen.data[ny * seen.stride + k] |= hits;
                while hits != 0 {
                    out.push(ny * w as usize + k * 64 + hits.trailing_zeros() as usize);
                    hits &= hits - 1;
                }
            }
        }
    }
    for &j in &out {
        seen.put(j, false);
    }
    out
}
