//! `stencil make --help` reads from the common options to the rare ones (issue 25 item 8): it
//! was 328 lines with the size and material options after 200 lines of mesh and bridge-weight
//! options. The headings come in the order a person needs them.

use crate::common::stencil;

#[test]
fn make_help_groups_options_under_headings_common_first() {
    let o = stencil(&["make", "--help"]);
    assert!(o.status.success(), "make --help failed");
    let help = String::from_utf8_lossy(&o.stdout).into_owned();
    // Headings are the unindented lines ending in a colon.
    let headings: Vec<&str> = help
        .lines()
        .filter(|l| !l.starts_with(' ') && l.ends_with(':'))
        .map(|l| l.trim_end_matches(':'))
        .collect();
    let at = |prefix: &str| {
        headings
            .iter()
            .position(|h| h.starts_with(prefix))
            .unwrap_or_else(|| panic!("no heading starting {prefix:?} in {headings:?}"))
    };
    let order = [
        "Input",
        "Size and material",
        "Picture",
        "Mesh",
        "Bridges",
        "Outputs",
    ];
    let places: Vec<usize> = order.iter().map(|h| at(h)).collect();
    assert!(
        places.windows(2).all(|w| w[0] < w[1]),
        "headings {headings:?}: want {order:?} in that order"
    );
    // Options sit under their heading: size and material before any mesh option.
    // An option's own line starts with it (`--width-mm <WIDTH_MM>`, or `-o, --out <OUT>`);
    // other options' help text may mention it too.
    let line_of = |opt: &str| {
        help.lines()
            .position(|l| {
                let t = l.trim_start();
                t.starts_with(opt)
                    || (t.starts_with('-') && t.get(4..).is_some_and(|r| r.starts_with(opt)))
            })
            .unwrap_or_else(|| panic!("{opt} not in make --help"))
    };
    for (early, late) in [
        ("--width-mm", "--view"),
        ("--material", "--view"),
        ("--threshold", "--view"),
        ("--view", "--w-intensity"),
        ("--w-intensity", "--emit"),
    ] {
        assert!(
            line_of(early) < line_of(late),
            "{early} should come before {late} in make --help"
        );
    }
    // The input and its output folder are the first heading.
    let input = help.lines().position(|l| l.starts_with("Input")).unwrap();
    let out = line_of("--out");
    let size = help
        .lines()
        .position(|l| l.starts_with("Size and material"))
        .unwrap();
    assert!(
        input < out && out < size,
        "-o/--out should be under the first heading"
    );
}

/// `make -h` fits a screen: the options a first stencil needs, a line each, and a line saying
/// that `--help` lists them all (issue 42 item 4: `-h` was 314 lines, `--help` 470).
#[test]
fn make_short_help_fits_a_screen_and_points_to_the_long_one() {
    let short = String::from_utf8_lossy(&stencil(&["make", "-h"]).stdout).into_owned();
    let long = String::from_utf8_lossy(&stencil(&["make", "--help"]).stdout).into_owned();
    assert!(
        short.lines().count() <= 50,
        "make -h is {} lines:\n{short}",
        short.lines().count()
    );
    for opt in [
        "--out",
        "--width-mm",
        "--material",
        "--threshold",
        "--emit",
        "--machine",
        "--layers",
    ] {
        assert!(short.contains(opt), "{opt} not in make -h:\n{short}");
    }
    assert!(
        !short.contains("--w-intensity"),
        "a rare option in make -h:\n{short}"
    );
    assert!(short.contains("`stencil make --help` lists all"), "{short}");
    // The long help keeps every option, with its whole text.
    for opt in [
        "--w-intensity",
        "--contour-threshold",
        "--mask-dpi",
        "--width-mm",
    ] {
        assert!(long.contains(opt), "{opt} not in make --help");
    }
    assert!(
        long.contains("whatever --scale does to the working pixels"),
        "{long}"
    );
    assert!(long.lines().count() > 3 * short.lines().count());
}
