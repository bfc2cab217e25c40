//! Bridges that hold (issue 13): large islands get two bridges a quarter turn apart, long thin
//! ones are held near both ends, sag beyond the material's limit gets more bridges, and
//! `--bridges-per-island N` gives every island N spread apart. Bridges are found on stencil.png
//! (pixels the bridges added, where they touch the island), the numbers in report.json.

use crate::common::*;
use stencil_core::islands::{self, CUT};
use stencil_core::raster::BitGrid;

/// Run make; panic with its error output if it fails.
fn make(input: &std::path::Path, out: &std::path::Path, args: &[&str]) -> serde_json::Value {
    let mut all = vec!["make", s(input), "-o", s(out)];
    all.extend_from_slice(args);
    let o = stencil(&all);
    assert!(o.status.success(), "{:?}: {}", args, stderr(&o));
    assert_valid_stencil(out);
    report(out)
}

/// The report's strength entry of island `n`.
fn island(r: &serde_json::Value, n: u64) -> serde_json::Value {
    r["strength"]["islands"]
        .as_array()
        .unwrap()
        .iter()
        .find(|i| i["island"] == n)
        .cloned()
        .unwrap_or_else(|| panic!("no strength entry for island {n}"))
}

/// Per island of twotone.png (node order, as in the report): its pixel centroid and, per bridge
/// touching it on stencil.png, where it touches (the centroid of the added pixels beside the
/// island's material), in pixels.
struct Seen {
    centre: Vec<(f64, f64)>,
    touches: Vec<Vec<(f64, f64)>>,
}

fn seen(out: &std::path::Path) -> Seen {
    let two = read_bits(&out.join("twotone.png"));
    let st = read_bits(&out.join("stencil.png"));
    let map = islands::label(&two);
    let added = BitGrid::from_fn(two.width, two.height, |x, y| st.get(x, y) && !two.get(x, y));
    let (bridge_of, count) = pieces(&added);
    let w = two.width as usize;
    let n = map.nodes.len();
    let mut sums = vec![(0.0, 0.0, 0.0); n];
    // Per (island, bridge component): sum of touching added pixels.
    let mut touch = vec![std::collections::HashMap::<u32, (f64, f64, f64)>::new(); n];
    for (i, &l) in map.labels.iter().enumerate() {
        if l == CUT {
            continue;
        }
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        let s = &mut sums[l as usize];
        *s = (s.0 + x as f64 + 0.5, s.1 + y as f64 + 0.5, s.2 + 1.0);
        for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            let (nx, ny) = (x + dx, y + dy);
            if nx < 0 || ny < 0 || nx >= two.width as i64 || ny >= two.height as i64 {
                continue;
            }
            let j = ny as usize * w + nx as usize;
            let b = bridge_of[j];
            if b != CUT {
                let e = touch[l as usize].entry(b).or_default();
                *e = (e.0 + nx as f64 + 0.5, e.1 + ny as f64 + 0.5, e.2 + 1.0);
            }
        }
    }
    assert!(count > 0, "no bridge pixels in {}", out.display());
    Seen {
        centre: sums.iter().map(|s| (s.0 / s.2, s.1 / s.2)).collect(),
        touches: touch
            .iter()
            .map(|m| {
                let mut v: Vec<(u32, (f64, f64))> = m
                    .iter()
                    .map(|(&k, s)| (k, (s.0 / s.2, s.1 / s.2)))
                    .collect();
                v.sort_by_key(|e| e.0);
                v.into_iter().map(|e| e.1).collect()
            })
            .collect(),
    }
}

/// The 4-connected pieces of `bits`' set pixels: a piece number per pixel ([`CUT`] where the
/// pixel is not set) and how many pieces there are. A plain flood fill: scaffolding to read the
/// output, not the library's labelling under test.
fn pieces(bits: &BitGrid) -> (Vec<u32>, usize) {
    let w = bits.width as usize;
    pieces_of(w, bits.height as usize, |i| {
        bits.get((i % w) as u32, (i / w) as u32)
    })
}

/// Angles (degrees) of the touches of island `n`, seen from its centre.
fn angles(v: &Seen, n: usize) -> Vec<f64> {
    let (cx, cy) = v.centre[n];
    v.touches[n]
        .iter()
        .map(|&(x, y)| (y - cy).atan2(x - cx).to_degrees())
        .collect()
}

fn apart(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

/// The widest angle between two of them.
fn widest(a: &[f64]) -> f64 {
    let mut best = 0.0f64;
    for (i, &x) in a.iter().enumerate() {
        for &y in &a[i + 1..] {
            best = best.max(apart(x, y));
        }
    }
    best
}

#[test]
fn a_300_mm_island_is_not_held_by_one_corner_bridge() {
    // 340 mm at 1 mm per pixel: a frame, a 10 mm cut, a 300 × 300 mm island of cardstock.
    let dir = tmp();
    let input = dir.path().join("square.png");
    ink_png(&input, 340, 340, |x, y| {
        let inner = (20..320).contains(&x) && (20..320).contains(&y);
        let island = (30..310).contains(&x) && (30..310).contains(&y);
        inner && !island
    });
    let out = dir.path().join("out");
    let r = make(&input, &out, &["--width-mm", "340", "--scale", "1"]);
    assert_eq!(r["islands"], 1);
    let i = island(&r, 1);
    assert!(i["bridges"].as_u64().unwrap() >= 2, "{i}");
    let why = i["why"].as_array().unwrap();
    assert!(why.contains(&"two_bridges".into()), "{i}");
    // On the stencil: at least two bridges touch the island, two of them at least 90° apart seen
    // from its centre.
    let v = seen(&out);
    let a = angles(&v, 1);
    assert!(a.len() >= 2, "{a:?}");
    assert!(widest(&a) >= 90.0, "{a:?}");
    // The report's bridges for strength are on the picture too.
    let strong = r["bridges"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|b| b["strength"] == true)
        .count();
    assert_eq!(strong as u64, i["extra"].as_u64().unwrap());
    assert_eq!(a.len(), r["bridges"].as_array().unwrap().len(), "{a:?}");
    // 300 mm of cardstock cannot be held within 1 mm from its edge: said, with where.
    assert_eq!(i["held"], false, "{i}");
    let note = i["note"].as_str().unwrap();
    assert!(
        note.contains("island 1 at (") && note.contains("out of reach"),
        "{note}"
    );
    // make says how many islands needed extra bridges.
    let o = stencil(&[
        "make",
        s(&input),
        "-o",
        s(&dir.path().join("again")),
        "--width-mm",
        "340",
        "--scale",
        "1",
    ]);
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        said.contains("strength: 1 of 1 islands needed extra bridges"),
        "{said}"
    );
}

#[test]
fn a_150_by_2_mm_strip_is_held_near_both_ends() {
    // 170 × 40 mm at 0.5 mm per pixel: a 150 × 2 mm strip of card in a cut 10 mm wide all round.
    let dir = tmp();
    let input = dir.path().join("strip.png");
    let (x0, x1, y0, y1) = (20u32, 320u32, 38u32, 42u32);
    ink_png(&input, 340, 80, |x, y| {
        let field = (x0 - 20..x1 + 20).contains(&x) && (y0 - 20..y1 + 20).contains(&y);
        field && !((x0..x1).contains(&x) && (y0..y1).contains(&y))
    });
    let out = dir.path().join("out");
    let r = make(&input, &out, &["--width-mm", "170", "--scale", "1"]);
    assert_eq!(r["islands"], 1);
    let i = island(&r, 1);
    assert!(
        (i["length_mm"].as_f64().unwrap() - 150.0).abs() < 1.0,
        "{i}"
    );
    assert_eq!(i["held"], true, "{i}");
    // On the stencil: a bridge touches the strip within a quarter of its length of each end.
    let v = seen(&out);
    let xs: Vec<f64> = v.touches[1].iter().map(|t| t.0).collect();
    let quarter = (x1 - x0) as f64 / 4.0;
    assert!(xs.iter().any(|&x| x <= x0 as f64 + quarter), "{xs:?}");
    assert!(xs.iter().any(|&x| x >= x1 as f64 - quarter), "{xs:?}");
    // And the report's span is within the ends' reach: no material farther than a quarter of
    // the strip plus half its middle from a bridge.
    assert!(i["span_mm"].as_f64().unwrap() <= 150.0 / 2.0, "{i}");
}

/// A ring 10 mm wide (radius 50 to 60 mm) in a cut 10 mm wide outside it, its hole cut too, at
/// 0.5 mm per pixel.
fn ring(path: &std::path::Path) {
    let c = 80.0;
    ink_png(path, 320, 320, |x, y| {
        let r = (x as f64 + 0.5 - 2.0 * c).hypot(y as f64 + 0.5 - 2.0 * c) / 2.0;
        r < 50.0 || (60.0..70.0).contains(&r)
    });
}

#[test]
fn a_ring_gets_more_bridges_in_paper_than_in_plywood_and_the_sag_says_why() {
    let dir = tmp();
    let input = dir.path().join("ring.png");
    ring(&input);
    let mut counts = Vec::new();
    for material in ["plywood-3mm", "copy-paper"] {
        let out = dir.path().join(material);
        let r = make(
            &input,
            &out,
            &["--material", material, "--width-mm", "160", "--scale", "1"],
        );
        assert_eq!(r["islands"], 1, "{material}");
        let i = island(&r, 1);
        let steps: Vec<f64> = serde_json::from_value(i["sag_steps_mm"].clone()).unwrap();
        let limit = i["limit_mm"].as_f64().unwrap();
        let n = i["bridges"].as_u64().unwrap() as usize;
        // Held: its sag on all its bridges is within the material's limit.
        assert_eq!(i["held"], true, "{material}: {i}");
        assert!(*steps.last().unwrap() <= limit, "{material}: {i}");
        assert_eq!(steps.len(), 1 + i["extra"].as_u64().unwrap() as usize);
        let why = i["why"].as_array().unwrap();
        if why.contains(&"sag".into()) {
            // The last bridge was needed: with one fewer the sag was above the limit.
            assert!(steps[steps.len() - 2] > limit, "{material}: {i}");
        } else {
            // No bridge for sag: the ring, 120 mm across, gets its two for size, and sags within
            // the limit on them.
            assert_eq!(n, 2, "{material}: {i}");
            assert!(why.contains(&"two_bridges".into()), "{material}: {i}");
        }
        // The stencil shows as many bridges touching the ring as the report counts, spread round
        // it.
        let v = seen(&out);
        let a = angles(&v, 1);
        assert_eq!(a.len(), n, "{material}: {a:?}");
        assert!(widest(&a) >= 90.0, "{material}: {a:?}");
        counts.push((n, why.contains(&"sag".into())));
    }
    // Plywood is 30 times thicker and stiffer: two bridges hold it. Copy paper needs more, for
    // its sag.
    let (ply, paper) = (counts[0], counts[1]);
    assert_eq!(ply, (2, false), "{counts:?}");
    assert!(paper.0 > ply.0 && paper.1, "{counts:?}");
}

#[test]
fn bridges_per_island_gives_every_island_that_many_spread_apart() {
    // Three discs of card, radius 12 mm, each in a ring of cut 8 mm wide, at 1 mm per pixel.
    let dir = tmp();
    let input = dir.path().join("discs.png");
    let discs = [(30.0, 30.0), (80.0, 35.0), (55.0, 80.0)];
    ink_png(&input, 110, 110, |x, y| {
        discs.iter().any(|&(cx, cy)| {
            let d = (x as f64 + 0.5 - cx).hypot(y as f64 + 0.5 - cy);
            (12.0..20.0).contains(&d)
        })
    });
    let one = dir.path().join("one");
    let r1 = make(&input, &one, &["--width-mm", "110", "--scale", "1"]);
    let three = dir.path().join("three");
    let r3 = make(
        &input,
        &three,
        &[
            "--width-mm",
            "110",
            "--scale",
            "1",
            "--bridges-per-island",
            "3",
        ],
    );
    assert_eq!(r3["islands"], 3);
    assert_eq!(r3["strength"]["bridges_per_island"], 3);
    let (v1, v3) = (seen(&one), seen(&three));
    for n in 1..=3usize {
        // Without the option a disc 24 mm across (under cardstock's 40 mm) keeps one bridge.
        assert_eq!(angles(&v1, n).len(), 1, "island {n}");
        assert_eq!(island(&r1, n as u64)["bridges"], 1);
        let i = island(&r3, n as u64);
        assert_eq!(i["bridges"], 3, "{i}");
        assert_eq!(i["why"], serde_json::json!(["bridges_per_island"]), "{i}");
        // Three on the stencil, each at least 90° from the others (a few degrees for where the
        // added pixels' middle lies against the strip's start).
        let a = angles(&v3, n);
        assert_eq!(a.len(), 3, "island {n}: {a:?}");
        for (k, &x) in a.iter().enumerate() {
            for &y in &a[k + 1..] {
                assert!(apart(x, y) >= 85.0, "island {n}: {a:?}");
            }
        }
    }
    // Out of range: refused naming the option.
    for bad in ["0", "13", "two"] {
        let o = stencil(&[
            "make",
            s(&input),
            "-o",
            s(&dir.path().join("bad")),
            "--bridges-per-island",
            bad,
        ]);
        assert!(!o.status.success(), "{bad}");
        assert!(
            stderr(&o).contains("--bridges-per-island"),
            "{bad}: {}",
            stderr(&o)
        );
    }
}

#[test]
fn a_profile_with_an_absurd_stiffness_is_refused_naming_the_field() {
    let dir = tmp();
    let input = dir.path().join("dot.png");
    ink_png(&input, 40, 40, |x, y| {
        (10..30).contains(&x) && (10..30).contains(&y)
    });
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("profiles/materials/cardstock.toml"),
    )
    .unwrap()
    .replace("youngs_modulus_gpa = 3.0", "youngs_modulus_gpa = 3e6");
    let profile = dir.path().join("stiff.toml");
    std::fs::write(&profile, text).unwrap();
    let o = stencil(&[
        "make",
        s(&input),
        "-o",
        s(&dir.path().join("out")),
        "--material",
        s(&profile),
    ]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("youngs_modulus_gpa") && e.contains("stiff.toml"),
        "{e}"
    );
}
