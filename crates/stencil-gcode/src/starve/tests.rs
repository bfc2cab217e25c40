use super::*;
use crate::estimate::estimate_program;
use crate::interpret::interpret_program;

/// A machine with a brisk acceleration (a CO2 gantry's 3000 mm/s²): its 15-block look-ahead
/// lets 0.05 mm segments run at 67 mm/s, which the serial line cannot feed.
fn brisk() -> Motion {
    Motion {
        max_feed_mm_min: 6000.0,
        rapid_mm_min: 6000.0,
        accel_mm_s2: 3000.0,
        junction_deviation_mm: 0.01,
        homing: false,
        axis_rate_mm_min: None,
        axis_accel_mm_s2: None,
        steps_per_mm: None,
        profile_steps_per_mm: None,
        idle_lock_ms: None,
    }
}

/// A square of 20 mm sides cut in long moves, then a 30 mm line of `step` mm segments at
/// `feed` mm/min, then travel home.
fn job(step: f64, feed: f64) -> String {
    let mut p =
        String::from("G21 G90\nG0 X10 Y10\nM4 S500\nG1 X30 F1200\nG1 Y30\nG1 X10\nG1 Y10\n");
    p.push_str(&format!("G1 X10 Y40 F{feed}\n"));
    let n = (30.0 / step).round() as usize;
    for i in 1..=n {
        p.push_str(&format!(
            "G1 X{:.3} Y{:.3}\n",
            10.0 + i as f64 * step,
            40.0 + (i % 2) as f64 * 0.002
        ));
    }
    p.push_str("M5\nG0 X0 Y0\nM2\n");
    p
}

fn streamed(text: &str, link: Link) -> (Estimate, Streamed) {
    let p = interpret_program(text).unwrap();
    let plain = estimate_program(&p, &brisk(), CutRule::Spindle);
    (
        plain,
        estimate_streamed(&p, text, &brisk(), &link, CutRule::Spindle),
    )
}

#[test]
fn a_fed_planner_times_as_the_plain_estimate() {
    // 1 mm segments at 1200 mm/min: 20 lines a second, where 115200 baud brings hundreds.
    let text = job(1.0, 1200.0);
    let (plain, s) = streamed(&text, Link::default());
    assert!(s.starved.is_empty(), "{:?}", s.starved);
    assert_eq!(s.estimate, plain);
}

#[test]
fn tiny_segments_at_a_high_feed_starve_where_they_are() {
    // 0.05 mm segments at 6000 mm/min: 2000 lines a second; at 115200 baud lines of about 18
    // characters come 640 a second.
    let text = job(0.05, 6000.0);
    let (plain, s) = streamed(&text, Link::default());
    assert_eq!(s.starved.len(), 1, "{:?}", s.starved);
    let st = &s.starved[0];
    // The tiny segments are lines 9..=608; the square before them is fed.
    assert!((9..=60).contains(&st.first_line), "{st:?}");
    assert!((590..=609).contains(&st.last_line), "{st:?}");
    assert!(st.from[1] >= 39.9 && st.to[0] > 35.0, "{st:?}");
    assert!(st.lines_per_s_needed > 1.5 * st.lines_per_s_link, "{st:?}");
    // The line cannot bring the segments faster than its characters a second: the stretch takes
    // at least its lines' bytes' time over the line, where the plain estimate says less.
    let lines = &text.lines().collect::<Vec<_>>()[st.first_line - 1..st.last_line];
    let bytes: usize = lines.iter().map(|l| clean_line(l).len() + 1).sum();
    let serial_s = bytes as f64 / 11520.0;
    let plain_s = lines.len() as f64 / st.lines_per_s_needed;
    assert!(plain_s < 0.8 * serial_s, "{plain_s} {serial_s}");
    assert!(plain_s + st.lost_s > 0.97 * serial_s, "{st:?} {serial_s}");
    assert!(plain_s + st.lost_s < 1.1 * serial_s, "{st:?} {serial_s}");
    assert!((s.estimate.total_s - plain.total_s - st.lost_s).abs() < 1e-9);
    assert!((s.estimate.cut_s - plain.cut_s - st.lost_cut_s).abs() < 1e-9);
    // The feed the line keeps fed: its characters a second over the characters per mm.
    let want = 60.0 * 11520.0 * 30.0 / bytes as f64;
    assert!((st.fed_mm_min - want).abs() < 0.1 * want, "{st:?} {want}");
}

#[test]
fn a_faster_line_or_bigger_buffers_starve_less() {
    let text = job(0.05, 6000.0);
    let lost = |link: Link| streamed(&text, link).1.lost_s();
    let slow = lost(Link {
        baud: 57_600,
        ..Link::default()
    });
    let stock = lost(Link::default());
    let fast = lost(Link {
        baud: 2_000_000,
        ..Link::default()
    });
    assert!(slow > stock && stock > fast, "{slow} {stock} {fast}");
    // A 32-bit port's buffers at the same baud: a longer look-ahead runs faster, so it needs
    // the lines even faster, but the plain estimate it is measured against grows with it.
    let big = lost(Link {
        rx_buffer_bytes: 1024,
        planner_blocks: 64,
        ..Link::default()
    });
    assert!(big > 0.0, "{big}");
}
