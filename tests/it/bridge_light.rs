//! Bridges priced by the error they add, by output: where an island is better held through a
//! lighter neighbour than straight across the dark to the sheet, the bridges `make` draws (read
//! back from stencil.png) run through the light place and darken the picture less than a
//! shortest-gap bridger's would; on black-and-white art, where no place is lighter than another,
//! `make` says so.

use crate::common::*;

const W: u32 = 160;
const H: u32 = 175;
/// The pale corridor's gray: just under the level 128, so cut, but as light as cut gets.
const PALE: u8 = 126;

/// Paper along the top (the sheet), black elsewhere; two paper islands one above the other in a
/// pale corridor running down from the paper: B 20 px below the paper, A 70 px below B. A's
/// shortest way to the sheet is 35 px straight down over black to the picture's edge; through B
/// it is twice as long but a quarter as dark (a cost with the paper's length term at full weight
/// took the short dark way).
fn picture(x: u32, y: u32) -> u8 {
    let island_b = (70..90).contains(&x) && (30..50).contains(&y);
    let island_a = (70..90).contains(&x) && (120..140).contains(&y);
    let corridor = (62..98).contains(&x) && (10..120).contains(&y);
    if y < 10 || island_a || island_b {
        255
    } else if corridor {
        PALE
    } else {
        0
    }
}

fn darkness(v: u8) -> f64 {
    (1.0 - v as f64 / 255.0).powi(2)
}

#[test]
fn an_island_is_held_through_its_pale_neighbour_not_across_the_dark() {
    let dir = tmp();
    let pic = dir.path().join("corridor.png");
    let data: Vec<u8> = (0..W * H).map(|i| picture(i % W, i / W)).collect();
    write_gray_png(&pic, W, H, &data);
    let out = dir.path().join("out");
    let o = stencil(&[
        "make",
        s(&pic),
        "-o",
        s(&out),
        "--threshold",
        "128",
        "--scale",
        "1",
        "--emit",
        "png",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_valid_stencil(&out);
    let r = report(&out);
    assert_eq!(
        r["bridge_light"]["light_places"], true,
        "{}",
        r["bridge_light"]
    );
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(!said.contains("no light place"), "make's output: {said}");

    // What the bridges cover, read from the written stencil: the pale corridor, not the black.
    let added = added_at(&out);
    assert!(!added.is_empty());
    let pale = added
        .iter()
        .filter(|&&(x, y)| picture(x, y) == PALE)
        .count();
    assert!(
        pale * 100 >= added.len() * 95,
        "{pale} of {} added pixels on the pale corridor",
        added.len()
    );
    // Against a shortest-gap bridger at the narrowest width the bridges have: B straight up 20 px
    // over pale to the paper, A straight down 35 px over black to the picture's edge.
    let width = r["bridges"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b["width_px"].as_f64().unwrap())
        .fold(f64::INFINITY, f64::min);
    let ours: f64 = added.iter().map(|&(x, y)| darkness(picture(x, y))).sum();
    let shortest = width * (20.0 * darkness(PALE) + 35.0 * darkness(0));
    assert!(
        ours < 0.8 * shortest,
        "error {ours:.1} vs the shortest gaps' {shortest:.1} ({width} px wide)"
    );
}

#[test]
fn black_and_white_art_has_no_light_place_and_make_says_so() {
    let dir = tmp();
    let pic = dir.path().join("ring.png");
    // An ink ring around a paper disc: the disc is an island, every cut pixel is black.
    ink_png(&pic, 120, 120, |x, y| {
        let d = ((x as f64 - 60.0).powi(2) + (y as f64 - 60.0).powi(2)).sqrt();
        (20.0..36.0).contains(&d)
    });
    let out = dir.path().join("out");
    let o = stencil(&[
        "make",
        s(&pic),
        "-o",
        s(&out),
        "--scale",
        "1",
        "--emit",
        "png",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_valid_stencil(&out);
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        said.contains("no light place for a bridge"),
        "make's output: {said}"
    );
    let r = report(&out);
    assert_eq!(
        r["bridge_light"]["light_places"], false,
        "{}",
        r["bridge_light"]
    );
    assert!(!r["bridges"].as_array().unwrap().is_empty());
}
