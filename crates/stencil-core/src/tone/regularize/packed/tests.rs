//! Tests of the bit-packed thinness: each fast path gives the plain pixel-by-pixel opening's pixels.

use super::*;
use crate::test_rng::Lcg;

/// The rule, pixel by pixel: a pixel of the tone is thin when no lattice point whose disc
/// lies wholly in the tone (material past the edges) holds it.
fn brute(bits: &[bool], w: usize, h: usize, phase: bool, disc: Disc) -> Vec<bool> {
    let at = |x: i64, y: i64| {
        if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
            true
        } else {
            bits[y as usize * w + x as usize]
        }
    };
    let shape = Shape::of(disc);
    let c = disc.on_corners() as i64;
    let holds = |cx: i64, cy: i64, x: i64, y: i64| {
        let r = y - cy - shape.dy0;
        r >= 0
            && (r as usize) < shape.rows.len()
            && (shape.rows[r as usize].0..=shape.rows[r as usize].1).contains(&(x - cx))
    };
    let valid = |cx: i64, cy: i64| {
        (shape.dy0..shape.dy0 + shape.rows.len() as i64).all(|dy| {
            let (a, b) = shape.rows[(dy - shape.dy0) as usize];
            (a..=b).all(|dx| at(cx + dx, cy + dy) == phase)
        })
    };
    let mut out = vec![false; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            if at(x, y) != phase {
                continue;
            }
            let k = disc.reach() + 1;
            let covered = (y - k..=y + k).any(|cy| {
                (x - k..=x + k).any(|cx| {
                    (0..w as i64 + c).contains(&cx)
                        && (0..h as i64 + c).contains(&cy)
                        && holds(cx, cy, x, y)
                        && valid(cx, cy)
                })
            });
            out[y as usize * w + x as usize] = !covered;
        }
    }
    out
}

#[test]
fn thin_matches_the_rule_pixel_by_pixel() {
    let mut rng = Lcg(99);
    for (w, h) in [(70usize, 13usize), (129, 9), (64, 20), (5, 5)] {
        for density in [1u64, 3, 8] {
            let bits: Vec<bool> = (0..w * h)
                .map(|_| (rng.next_u64() >> 60) >= density)
                .collect();
            let mut p = Packed::new(w, h, true);
            for (i, &b) in bits.iter().enumerate() {
                p.put(i, b);
            }
            for span in [2.0, 3.0, 4.0, 5.0, 6.0, 9.0] {
                let disc = Disc::for_width(span);
                for phase in [true, false] {
                    let mut got = Packed::new(0, 0, false);
                    thin(&p, phase, disc, &mut ThinScratch::default(), &mut got);
                    let want = brute(&bits, w, h, phase, disc);
                    for (i, &t) in want.iter().enumerate() {
                        assert_eq!(
                            got.at(i),
                            t,
                            "{w}x{h} density {density} span {span} phase {phase} at {i}"
                        );
                    }
                    assert_eq!(got.count(), want.iter().filter(|&&t| t).count());
                }
            }
        }
    }
}

/// Thinness recomputed in the tiles near changed pixels is thinness over the whole new grid:
/// random blocky grids, random changes (single pixels and blocks), odd and even spans, spans
/// reaching past a word.
#[test]
fn thin_in_tiles_near_changes_is_thin_of_all() {
    let mut rng = Lcg(0x711e_u64);
    let mut rnd = |n: u64| rng.below(n);
    let both = |p: &Packed, disc: Disc| {
        let mut out = [Packed::default(), Packed::default()];
        thin(p, true, disc, &mut ThinScratch::default(), &mut out[0]);
        thin(p, false, disc, &mut ThinScratch::default(), &mut out[1]);
        out
    };
    let mut tiled = 0;
    for case in 0..600 {
        let (w, h) = (1 + rnd(700) as usize, 1 + rnd(300) as usize);
        let (cell, dense) = (1 + rnd(6) as usize, rnd(11));
        let noise: Vec<bool> = (0..(w / cell + 1) * (h / cell + 1))
            .map(|_| rnd(10) < dense)
            .collect();
        let mut p = Packed::new(w, h, true);
        for y in 0..h {
            for x in 0..w {
                p.set(x, y, noise[(y / cell) * (w / cell + 1) + x / cell]);
            }
        }
        let span = [2.0, 3.0, 5.0, 6.0, 11.0, 12.0, 40.0, 71.0][case % 8];
        let disc = Disc::for_width(span);
        let mut got = both(&p, disc);
        let mut changed = Packed::new(w, h, false);
        for _ in 0..1 + rnd(5) {
            let (x0, y0, n) = (rnd(w as u64) as usize, rnd(h as u64) as usize, rnd(5));
            for y in y0..(y0 + n as usize + 1).min(h) {
                for x in x0..(x0 + n as usize + 1).min(w) {
                    if rnd(3) > 0 {
                        p.set(x, y, !p.get(x, y));
                        changed.set(x, y, true);
                    }
                }
            }
        }
        let m = 2 * disc.reach() as usize + 2;
        let mut dirty = tiles_near(&changed, m + 1);
        // Tiles marked that need not be (a change's reach is an upper bound) change nothing.
        if case % 3 == 0 {
            for d in dirty.iter_mut() {
                *d |= rnd(4) == 0;
            }
        }
        tiled += dirty.iter().any(|&d| d) as usize;
        thin_in_tiles(&p, disc, &dirty, &mut got, &mut Default::default());
        assert_eq!(got, both(&p, disc), "case {case}: {w}x{h} span {span}");
    }
    assert!(tiled > 100, "the tiles were recomputed in {tiled} cases");
}

/// Packing bools eight at a time by a multiply, and unpacking a shifted row 64 at a time,
/// are setting and reading bit by bit: random rows, offsets, lengths and old contents.
#[test]
fn packing_and_unpacking_rows_is_bit_by_bit() {
    let mut rng = Lcg(0xb175_u64);
    let mut rnd = |n: u64| rng.below(n);
    let mut scratch = Vec::new();
    for case in 0..400 {
        let width = 1 + rnd(300) as usize;
        let x0 = rnd(width as u64) as usize;
        let len = rnd((width - x0) as u64 + 1) as usize;
        let dense = rnd(11);
        let src: Vec<bool> = (0..len).map(|_| rnd(10) < dense).collect();
        let mut got = Packed::new(width, 1, rnd(2) == 0);
        for w in &mut got.data {
            *w ^= (rnd(1 << 31) << 33) ^ rnd(1 << 31);
        }
        let mut want = got.clone();
        put_bits(&mut got.data, x0, &src);
        for (k, &b) in src.iter().enumerate() {
            want.set(x0 + k, 0, b);
        }
        assert_eq!(got, want, "case {case}: put {len} at {x0} of {width}");
        let mut out = vec![false; len];
        get_bits(got.row(0), x0, &mut out, &mut scratch);
        let bits: Vec<bool> = (0..len).map(|k| got.get(x0 + k, 0)).collect();
        assert_eq!(out, bits, "case {case}: get {len} at {x0} of {width}");
    }
}

#[test]
fn shifts_match_bit_by_bit() {
    let mut rng = Lcg(5u64);
    let mut next = || rng.next_u64();
    for n in [1usize, 2, 3, 5] {
        let row: Vec<u64> = (0..n).map(|_| next()).collect();
        for m in [1usize, n, n + 2] {
            for s in -200i64..200 {
                for fill in [0u64, !0] {
                    let mut out = vec![0u64; m];
                    shift(&row, s, fill, &mut out);
                    for x in 0..m * 64 {
                        let j = x as i64 + s;
                        let want = if (0..(n * 64) as i64).contains(&j) {
                            row[j as usize / 64] >> (j % 64) & 1
                        } else {
                            fill & 1
                        };
                        assert_eq!(out[x / 64] >> (x % 64) & 1, want, "n {n} m {m} s {s}");
                    }
                }
            }
        }
    }
}

#[test]
fn runs_and_shifts_read_fill_past_the_ends() {
    let row = [0b1011u64, 1 << 63];
    let mut out = [0u64; 2];
    shift(&row, 1, 0, &mut out);
    assert_eq!(out, [0b101, 1 << 62]);
    shift(&row, -1, !0, &mut out);
    assert_eq!(out, [0b10111, 0]);
    shift(&row, 64, 0, &mut out);
    assert_eq!(out, [1 << 63, 0]);
    let mut s = RunScratch::default();
    runs_of(
        &[0b0111_0110u64],
        &[(1, 1), (0, 2)],
        true,
        0,
        1,
        &mut out,
        &mut s,
    );
    assert_eq!(out, [0b0111_0110 >> 1, 0b0001_0000]);
    runs_of(
        &[0b1000_0001u64],
        &[(0, 0), (-1, 1)],
        false,
        0,
        1,
        &mut out,
        &mut s,
    );
    assert_eq!(out, [0b1000_0001, 0b1_1100_0011]);
}

/// The runs by doubling are the runs built span by span, on random rows, for the spans of
/// discs of several sizes, both ops, both fills, output rows longer than the input.
#[test]
fn runs_by_doubling_are_runs_by_steps() {
    let mut rng = Lcg(17u64);
    let mut next = || rng.next_u64();
    let mut s = RunScratch::default();
    for span in [2.0, 3.0, 4.0, 5.0, 6.0, 9.0, 11.0, 12.0, 30.0, 75.0, 140.0] {
        let shape = Shape::of(Disc::for_width(span));
        let spans = shape.spans();
        let mirrored: Vec<(i64, i64)> = spans.iter().map(|&(a, b)| (-b, -a)).collect();
        for len in [1usize, 2, 3, 7] {
            for n in [len, len + 1] {
                for _ in 0..4 {
                    let dense = next() % 4;
                    let row: Vec<u64> = (0..len)
                        .map(|_| match dense {
                            0 => next() & next() & next(),
                            1 => next() | next() | next(),
                            _ => next(),
                        })
                        .collect();
                    for sp in [&spans, &mirrored] {
                        for (and, fill) in [(true, 0), (true, !0), (false, 0), (false, !0)] {
                            let mut got = vec![0u64; sp.len() * n];
                            let mut want = vec![0u64; sp.len() * n];
                            runs_of(&row, sp, and, fill, n, &mut got, &mut s);
                            runs_of_by_steps(&row, sp, and, fill, n, &mut want);
                            assert_eq!(got, want, "span {span} len {len} n {n} and {and}");
                            // All rows at once: a grid of such rows, in bands.
                            let h = 1 + (next() % 70) as usize;
                            let grid = Packed {
                                width: len * 64,
                                height: h,
                                stride: len,
                                data: (0..h * len).map(|_| next()).collect(),
                            };
                            let mut got = vec![0u64; h * sp.len() * n];
                            runs_of_rows(&grid, sp, and, fill, n, &mut got, h.is_multiple_of(2));
                            for y in 0..h {
                                let k = sp.len() * n;
                                runs_of_by_steps(grid.row(y), sp, and, fill, n, &mut want);
                                assert_eq!(&got[y * k..(y + 1) * k], &want[..], "row {y}");
                            }
                        }
                    }
                }
            }
        }
    }
}
