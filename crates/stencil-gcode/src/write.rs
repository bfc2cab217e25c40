//! The G-code writer: a planned [`Job`] as text Grbl 1.1 runs without error.
//!
//! Rules (from Grbl 1.1h's parser, `gcode.c` and `protocol.c`, and what trips up other senders):
//! `G21 G90 G94` header; an F before the first G1; G0/G1 straight moves and, when the job asks
//! for them, G2/G3 arcs in the XY plane with I/J centre offsets (never G5 splines, never R arcs);
//! numbers with at most 3 decimals; no line numbers; comments only on their own `;` lines, with
//! any parentheses written as brackets (Grbl ends a `( )` comment at the first `)` and cannot nest
//! them; brackets mean nothing to any reader) and wrapped at word breaks onto further `;` lines
//! rather than cut off; every line within Grbl's 79-character limit; the tool off on every G0
//! (laser: `S0` on the G0 line, pen/knife: lifted); at the end `M5` (and `M9` with air assist), a
//! return to X0 Y0 and `M2`, the program end Grbl and G-code checkers expect.
//!
//! Air assist (laser, `air_assist` in the machine or material profile): `M8` (Grbl's flood coolant
//! output, where air assist pumps are wired) right before the first cut, `M9` with the final `M5`.
//! `M2` turns both off again in Grbl, so a program cut short still ends dark and quiet.
//!
//! Laser jobs use `M4` (dynamic power) and change power with S words on G0/G1 lines, which Grbl's
//! laser mode (`$32=1`) applies without stopping motion; M3/M4/M5 changes would stop the planner.

use crate::blade::{self, walk};
use crate::machine::{Machine, PenLift, Tool};
use stencil_geom::curve;

use crate::job::{CutSettings, Job, Loop};
use crate::num::num;
use crate::toolpath::laser_s;

/// One loop's own settings and a comment line written before it (the test grid cuts each square
/// at its own power and speed, and a knife's at its own depth).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct LoopSettings {
    pub settings: CutSettings,
    /// Knife or pen on Z: the depth this loop is cut at instead of the profile's `z_down_mm`.
    pub z_down_mm: Option<f64>,
    pub comment: String,
}

/// Longest line the writer emits: one under Grbl's [`crate::limits::MAX_LINE_BYTES`] (79), a
/// margin for a sender that counts the line's end.
pub(crate) const MAX_LINE: usize = crate::limits::MAX_LINE_BYTES - 1;

/// Comment lines: `; text`, printable ASCII with parentheses as brackets, wrapped at spaces so
/// each line fits [`MAX_LINE`] (a word longer than a line is split); nothing is cut off.
///
/// Grbl takes `?`, `!` and `~` (status, feed hold, cycle start) and every byte above 0x7F
/// (safety door, overrides) out of the serial stream wherever they stand, comments included,
/// so none of them may appear: a `!` in a picture's file name would pause the job. Dashes
/// and the multiplication sign become their ASCII look-alikes, anything else a `_`.
fn comment(out: &mut String, text: &str) {
    let clean: String = text
        .chars()
        .map(|c| match c {
            '(' => '[',
            ')' => ']',
            '?' | '!' => '.',
            '~' | '\u{2010}'..='\u{2015}' | '\u{2212}' => '-',
            '\u{d7}' => 'x',
            c if c.is_ascii_graphic() || c == ' ' => c,
            _ => '_',
        })
        .collect();
    let width = MAX_LINE - 2;
    let mut line = String::new();
    let mut flush = |line: &mut String| {
        out.push_str("; ");
        out.push_str(line.trim_end());
        out.push('\n');
        line.clear();
    };
    for word in clean.split(' ').filter(|w| !w.is_empty()) {
        let mut word = word;
        if !line.is_empty() && line.len() + 1 + word.len() > width {
            flush(&mut line);
        }
        // A word longer than a line (a long path): split it.
        while word.len() > width {
            if !line.is_empty() {
                flush(&mut line);
            }
            let (head, tail) = word.split_at(width);
            line.push_str(head);
            flush(&mut line);
            word = tail;
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() || clean.trim().is_empty() {
        flush(&mut line);
    }
}

/// One note of a header again from the comment lines the writer wrapped it into (without their
/// `; `): a full line was a long word split, the rest were wrapped at a space. A note whose
/// spaces fell exactly at a line's end reads without that space: the header is for people.
pub fn unwrap_comment(lines: &[&str]) -> String {
    let mut note = String::new();
    for (i, l) in lines.iter().enumerate() {
        if i > 0 && lines[i - 1].len() < MAX_LINE - 2 {
            note.push(' ');
        }
        note.push_str(l);
    }
    note
}

/// Emits moves, skipping those that round to where the head already is.
struct Writer {
    out: String,
    /// The head position as written (rounded strings).
    at: (String, String),
    /// Air assist is to be turned on before the next cut (`M8`).
    air_pending: bool,
}

impl Writer {
    fn line(&mut self, s: &str) {
        self.out.push_str(s);
        self.out.push('\n');
    }

    /// A move to `p`; `extra` words follow the coordinates. Returns false if it rounds to no move.
    fn go(&mut self, g: u8, p: [f64; 2], extra: &str) -> bool {
        let (x, y) = (num(p[0]), num(p[1]));
        if (x.as_str(), y.as_str()) == (self.at.0.as_str(), self.at.1.as_str()) {
            if !extra.is_empty() {
                // Keep the words (power, feed) even if the move vanishes.
                self.line(extra.trim_start());
            }
            return false;
        }
        self.line(&format!("G{g} X{x} Y{y}{extra}"));
        self.at = (x, y);
        true
    }

    /// The arc of `bulge` ([`curve::Piece`]'s: `tan(sweep / 4)`, positive counter-clockwise with
    /// y up) from the head's position to `to`. The centre is computed from the two ends *as
    /// written* (rounded to the micrometre), so both lie on the written circle up to the rounding
    /// of I and J (under 0.001 mm): Grbl's parser (`gc_execute_line`) refuses an arc whose start
    /// and target are farther apart from the centre than 0.005 mm and 0.1 % of the radius
    /// (`error:33`), which is then checked on the numbers written. An arc that rounds to no move
    /// (Grbl would cut a full circle) or whose bow is under the written resolution is a G1.
    fn arc(&mut self, to: [f64; 2], bulge: f64, extra: &str) -> bool {
        let (x, y) = (num(to[0]), num(to[1]));
        let v = |s: &str| s.parse::<f64>().unwrap_or(f64::NAN);
        let (sx, sy, xv, yv) = (v(&self.at.0), v(&self.at.1), v(&x), v(&y));
        let Some(a) = curve::arc_of([sx, sy], [xv, yv], bulge) else {
            return self.go(1, to, extra);
        };
        // The arc's bow off its chord: below half the last written digit a G1 is the same path.
        let bow = a.radius * (1.0 - (a.sweep / 2.0).cos());
        if (x.as_str(), y.as_str()) == (self.at.0.as_str(), self.at.1.as_str()) || bow < 5e-4 {
            return self.go(1, to, extra);
        }
        let (i, j) = (num(a.center[0] - sx), num(a.center[1] - sy));
        let (iv, jv) = (v(&i), v(&j));
        let r0 = iv.hypot(jv);
        let r1 = (xv - sx - iv).hypot(yv - sy - jv);
        let off = (r1 - r0).abs();
        // Never expected (the rounding of I and J moves either radius by under 0.0008 mm), but
        // the file must pass: a G1 rather than an error:33.
        if off.is_nan() || off > GRBL_ARC_RADIUS_SLACK_MM / 2.0 || r0 < 0.001 {
            return self.go(1, to, extra);
        }
        let g = if a.sweep > 0.0 { 3 } else { 2 };
        self.line(&format!("G{g} X{x} Y{y} I{i} J{j}{extra}"));
        self.at = (x, y);
        true
    }
}

/// Grbl 1.1h's arc check (`gcode.c`): a target farther from the centre than the start by more
/// than 0.005 mm (and 0.1 % of the radius) is `error:33`.
const GRBL_ARC_RADIUS_SLACK_MM: f64 = 0.005;

/// The axis path of a drag knife for one pass around a loop ([`blade::drag_knife_path`]) with
/// the default corner rule: what the tests of the compensation check.
#[cfg(test)]
pub(crate) fn drag_knife_path(points: &[[f64; 2]], r: f64) -> Vec<[f64; 2]> {
    blade::drag_knife_path(points, r, crate::machine::DEFAULT_SWIVEL_MIN_DEG)
}

/// The G-code text of a job. `notes` become extra header comment lines (source, material).
pub(crate) fn write(job: &Job, machine: &Machine, notes: &[String]) -> String {
    write_each(job, machine, notes, &[])
}

/// [`write`] with loop `i` cut as `each[i]` says (loops past its end use the job's settings).
/// Same header, laser mode and end as every job.
pub(crate) fn write_each(
    job: &Job,
    machine: &Machine,
    notes: &[String],
    each: &[LoopSettings],
) -> String {
    let s = &job.settings;
    let feed = num(s.speed_mm_min);
    let laser = matches!(machine.tool, Tool::Laser { .. });
    let air = laser && s.air_assist;
    let mut w = Writer {
        out: String::new(),
        at: (String::new(), String::new()),
        air_pending: air,
    };
    header_comments(&mut w.out, job, machine, notes, air);
    w.line("G21 G90 G94");
    match machine.tool {
        Tool::Laser { .. } => w.line(&format!("M4 S0 F{feed}")),
        Tool::Pen(PenLift::Spindle { .. }) => w.line(&format!("M5 F{feed}")),
        Tool::Pen(PenLift::Z(z)) | Tool::Knife { z, .. } => {
            w.line(&format!("G0 Z{} F{feed}", num(z.up_mm)))
        }
    }
    for l in &job.lines {
        write_line(&mut w, l, machine, &job.settings);
    }
    for (i, l) in job.loops.iter().enumerate() {
        match each.get(i) {
            Some(e) => {
                comment(&mut w.out, &e.comment);
                let mut m = machine.clone();
                if let (Some(d), Tool::Pen(PenLift::Z(z)) | Tool::Knife { z, .. }) =
                    (e.z_down_mm, &mut m.tool)
                {
                    z.down_mm = d;
                }
                write_loop(&mut w, l, &m, &e.settings);
            }
            None => write_loop(&mut w, l, machine, &job.settings),
        }
    }
    match machine.tool {
        Tool::Laser { .. } => w.line("M5 S0"),
        _ => w.line("M5"),
    }
    if air {
        w.line("M9");
    }
    // The return move, written even if the head is already there, then the program end.
    let home = job.home;
    w.line(&format!("G0 X{} Y{}", num(home[0]), num(home[1])));
    w.line("M2");
    w.out
}

/// The comment lines a program starts with: what made it, for which machine and tool, with what
/// settings, and the job's size, place and lengths.
fn header_comments(o: &mut String, job: &Job, machine: &Machine, notes: &[String], air: bool) {
    comment(
        o,
        &format!(
            "stencil {} for {}: {}",
            env!("CARGO_PKG_VERSION"),
            machine.name,
            machine.description
        ),
    );
    for n in notes {
        comment(o, n);
    }
    comment(
        o,
        &format!(
            "mm G21, absolute G90; machine origin {}; Grbl 1.1, {}",
            machine.bed.origin.name(),
            if job.arc_tolerance_mm > 0.0 && !matches!(machine.tool, Tool::Knife { .. }) {
                format!(
                    "arcs G2/G3 within {} mm of the outline",
                    num(job.arc_tolerance_mm)
                )
            } else if !machine.arcs {
                "no arcs: the machine profile says arcs = false".to_string()
            } else {
                "no arcs".to_string()
            }
        ),
    );
    tool_comments(o, machine, &job.settings, air);
    comment(
        o,
        &format!(
            "job {} x {} mm at X{}..{} Y{}..{}; {} loops{}",
            num(job.sheet_mm[0]),
            num(job.sheet_mm[1]),
            num(job.min[0]),
            num(job.max[0]),
            num(job.min[1]),
            num(job.max[1]),
            job.stats.loops,
            match job.lines.len() {
                0 => String::new(),
                n => format!(", {n} open paths"),
            }
        ),
    );
    comment(
        o,
        &format!(
            "cut {:.1} mm; travel {:.1} mm, input order would be {:.1} mm",
            job.stats.cut_mm, job.stats.travel_mm, job.stats.naive_travel_mm
        ),
    );
}

/// The tool's lines of the header: how it is switched (laser mode and power scale, pen lift,
/// knife depth), its power or depth, feed and passes, so that whoever runs the file can check
/// the machine is set up for it.
fn tool_comments(o: &mut String, machine: &Machine, s: &CutSettings, air: bool) {
    let feed = num(s.speed_mm_min);
    match machine.tool {
        Tool::Laser { s_max, s_min } => {
            comment(
                o,
                "laser: set Grbl laser mode $32=1 first; M4 dynamic power, off in G0",
            );
            if air {
                comment(
                    o,
                    "air assist: M8 on before the first cut, M9 off at the end",
                );
            }
            comment(
                o,
                &format!(
                    "$30={} $31={}; power {} % = S{}; feed {feed} mm/min; passes {}",
                    num(s_max),
                    num(s_min),
                    num(s.power_pct),
                    num(laser_s(s.power_pct, s_max)),
                    s.passes
                ),
            );
        }
        Tool::Pen(PenLift::Spindle { down_s }) => comment(
            o,
            &format!(
                "pen on the spindle output: M3 S{} down, M5 up; feed {feed} mm/min",
                num(down_s)
            ),
        ),
        Tool::Pen(PenLift::Z(z)) | Tool::Knife { z, .. } => comment(
            o,
            &format!(
                "{} on Z: up Z{}, down Z{} at F{}; feed {feed} mm/min; passes {}",
                machine.tool.kind(),
                num(z.up_mm),
                num(z.down_mm),
                num(z.plunge_mm_min),
                s.passes
            ),
        ),
    }
}

/// An open path: travel to its start, tool on, along it, and back and forth for further passes
/// (a drag knife's corners are not compensated on an open path: it has no inside to swivel
/// around), tool off.
fn write_line(w: &mut Writer, points: &[[f64; 2]], machine: &Machine, s: &CutSettings) {
    let mut first = tool_on(w, points[0], machine, s);
    for pass in 0..s.passes {
        let along: Box<dyn Iterator<Item = &[f64; 2]>> = if pass % 2 == 0 {
            Box::new(points.iter().skip(1))
        } else {
            Box::new(points.iter().rev().skip(1))
        };
        for &p in along {
            w.go(1, p, &first);
            first.clear();
        }
    }
    tool_off(w, machine);
}

/// Travel to `start` with the tool off, then switch it on (lower the pen or knife); returns the
/// words the first cutting move carries (the power and the feed).
fn tool_on(w: &mut Writer, start: [f64; 2], machine: &Machine, s: &CutSettings) -> String {
    let feed = format!(" F{}", num(s.speed_mm_min));
    match machine.tool {
        Tool::Laser { .. } => {
            w.go(0, start, " S0");
        }
        Tool::Pen(PenLift::Spindle { down_s }) => {
            w.go(0, start, "");
            w.line(&format!("M3 S{}", num(down_s)));
        }
        Tool::Pen(PenLift::Z(z)) | Tool::Knife { z, .. } => {
            w.go(0, start, "");
            w.line(&format!("G1 Z{} F{}", num(z.down_mm), num(z.plunge_mm_min)));
        }
    }
    if w.air_pending {
        w.line("M8");
        w.air_pending = false;
    }
    match machine.tool {
        Tool::Laser { s_max, .. } => format!(" S{}{feed}", num(laser_s(s.power_pct, s_max))),
        _ => feed,
    }
}

/// The tool off before any travel.
fn tool_off(w: &mut Writer, machine: &Machine) {
    match machine.tool {
        Tool::Laser { .. } => {}
        Tool::Pen(PenLift::Spindle { .. }) => w.line("M5"),
        Tool::Pen(PenLift::Z(z)) | Tool::Knife { z, .. } => {
            w.line(&format!("G0 Z{}", num(z.up_mm)));
        }
    }
}

/// One closed loop: travel to its start, tool on, every pass, (a knife's overcut), tool off.
/// A loop the planner fitted with arcs ([`Loop::curve`]) is written as its lines and G2/G3 arcs.
fn write_loop(w: &mut Writer, l: &Loop, machine: &Machine, s: &CutSettings) {
    let knife = matches!(machine.tool, Tool::Knife { .. });
    let slowed;
    let (points, s) = match machine.tool {
        Tool::Knife {
            swivel_min_deg,
            small_feature_mm,
            small_feature_speed_pct,
            ..
        } => {
            // A small feature is cut slower, so the blade turns cleanly in it.
            let s = if small_feature_mm > 0.0 && longer_side(&l.points) < small_feature_mm {
                slowed = CutSettings {
                    speed_mm_min: s.speed_mm_min * small_feature_speed_pct / 100.0,
                    ..*s
                };
                &slowed
            } else {
                s
            };
            let path = blade::drag_knife_path(&l.points, s.blade_offset_mm, swivel_min_deg);
            (path, s)
        }
        _ => (l.points.clone(), s),
    };
    // Travel, tool off, then tool on; the first cutting move carries the power and the feed.
    let mut first = tool_on(w, points[0], machine, s);
    let n = points.len();
    if !knife && !l.curve.is_empty() {
        let pieces = &l.curve;
        let m = pieces.len();
        for _ in 0..s.passes {
            for k in 0..m {
                let to = pieces[(k + 1) % m].from;
                let bulge = pieces[k].bulge;
                if bulge == 0.0 {
                    w.go(1, to, &first);
                } else {
                    w.arc(to, bulge, &first);
                }
                first.clear();
            }
        }
        tool_off(w, machine);
        return;
    }
    for _ in 0..s.passes {
        for i in 1..=n {
            w.go(1, points[i % n], &first);
            first.clear();
        }
    }
    if let Tool::Knife { overcut_mm, .. } = machine.tool {
        if overcut_mm > 0.0 {
            for p in walk(&points, overcut_mm) {
                w.go(1, p, "");
            }
        }
    }
    tool_off(w, machine);
}

/// The longer side of a loop's bounding box, mm.
fn longer_side(points: &[[f64; 2]]) -> f64 {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points {
        for a in 0..2 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (hi[0] - lo[0]).max(hi[1] - lo[1])
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_wrapped_note_reads_back_whole() {
        for note in [
            format!("from /{}/a picture.png", "p".repeat(200)),
            "from a/b.png".to_string(),
            format!("from {} {}", "w".repeat(70), "x".repeat(5)),
        ] {
            let mut s = String::new();
            comment(&mut s, &note);
            let lines: Vec<&str> = s.lines().map(|l| &l[2..]).collect();
            assert!(lines.len() > 1 || note.len() < MAX_LINE, "{s}");
            assert_eq!(unwrap_comment(&lines), note, "{s}");
        }
    }

    use super::*;
    use stencil_geom::ring::dist;

    #[test]
    fn numbers_have_at_most_three_decimals() {
        assert_eq!(num(1.0), "1");
        assert_eq!(num(1.23456), "1.235");
        assert_eq!(num(-0.0001), "0");
        assert_eq!(num(-2.5), "-2.5");
        assert_eq!(num(399.9999), "400");
    }

    #[test]
    fn drag_knife_overshoots_and_swivels_around_corners() {
        let sq = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        let p = drag_knife_path(&sq, 0.5);
        // Tip at (0,0) arriving from (0,10) heading down: the axis is 0.5 below the corner.
        assert_eq!(p[0], [0.0, -0.5]);
        // Every point is the corner it swivels around plus r, or a shifted edge point.
        let near_corner = |q: [f64; 2]| sq.iter().any(|c| (dist(*c, q) - 0.5).abs() < 1e-9);
        assert!(p.iter().all(|&q| near_corner(q)), "{p:?}");
        // A 90° turn in 10° steps: 9 arc points per corner plus the arrival point.
        assert_eq!(p.len(), 4 * 10);
        // The axis overshoots (10, 0) to (10.5, 0) before swivelling.
        assert!(p.contains(&[10.5, 0.0]));
        assert_eq!(drag_knife_path(&sq, 0.0), sq.to_vec());
    }

    #[test]
    fn comments_hold_no_byte_grbl_takes_as_a_realtime_command() {
        let mut s = String::new();
        comment(
            &mut s,
            "from /tmp/what?!~.png, diode 5\u{2013}20 W, 3\u{d7}4 mm, caf\u{e9}",
        );
        for b in s.bytes() {
            assert!(!matches!(b, b'?' | b'!' | b'~') && b < 0x80, "{s}");
        }
        assert!(s.contains("diode 5-20 W, 3x4 mm, caf_"), "{s}");
    }

    #[test]
    fn comments_wrap_whole_words_and_keep_brackets() {
        let mut s = String::new();
        let text = format!(
            "Pen plotter, A3 bed (420 x 297 mm), pen on Z; {} end",
            "word ".repeat(30)
        );
        comment(&mut s, &text);
        let lines: Vec<&str> = s.lines().collect();
        assert!(lines.len() >= 2, "{s}");
        for l in &lines {
            assert!(l.starts_with("; ") && l.len() <= MAX_LINE, "{l}");
        }
        assert!(s.contains("A3 bed [420 x 297 mm], pen on Z"), "{s}");
        // Nothing lost: the words, joined back, are the text.
        let back: Vec<&str> = lines.iter().flat_map(|l| l[2..].split(' ')).collect();
        let want: Vec<String> = text
            .replace('(', "[")
            .replace(')', "]")
            .split_whitespace()
            .map(String::from)
            .collect();
        assert_eq!(back, want);
        // A word longer than a line is split, not cut.
        let mut s = String::new();
        comment(&mut s, &format!("from /{}", "p".repeat(200)));
        assert_eq!(s.matches('p').count(), 200);
        assert!(s.lines().all(|l| l.len() <= MAX_LINE));
    }
}
