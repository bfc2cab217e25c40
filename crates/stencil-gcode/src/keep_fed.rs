//! Keep the machine fed: where a written job's lines arrive slower than its feed uses them up
//! (the starvation estimate), lower the feed there until they do, and say so.
//!
//! Lowering the feed is the fix that keeps every output exactly as drawn (merging the tiny
//! pieces would move the cut by up to the fit's tolerance a second time). A stall is worse than
//! a steady slower feed: the head stops and starts at every stall and a laser leaves a dark dot
//! there, where at a steady feed it cuts evenly. The lowered stretch carries its own `F`; the
//! first cutting move after it carries the job's feed again.

use std::collections::BTreeMap;

use crate::estimate::Estimate;
use crate::interpret::{clean_line, interpret_program, CutRule, GcodeError, Program};
use crate::limits::MAX_LINE_BYTES;
use crate::machine::{Link, Motion};
use crate::num::num;
use crate::starve::{estimate_streamed, Starve, Streamed};

/// The share of what the serial line can feed that a lowered stretch asks for first: junctions
/// and the ramps at its ends make it use lines a little faster than its feed alone says.
const FIRST_SHARE: f64 = 0.97;

/// Each further round lowers a stretch that still starves by this factor.
const NEXT_SHARE: f64 = 0.95;

/// Rounds of lowering before giving up (and saying where it still starves).
const ROUNDS: usize = 6;

/// A stretch whose feed was lowered.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Slowed {
    /// First program line of the stretch.
    pub first_line: usize,
    /// Last program line of the stretch.
    pub last_line: usize,
    /// Where it begins, machine mm.
    pub from: [f64; 2],
    /// Where it ends, machine mm.
    pub to: [f64; 2],
    /// The feed the job asked for there, mm/min.
    pub was_mm_min: f64,
    /// The feed written there now, mm/min.
    pub now_mm_min: f64,
}

/// What the starvation check found in a written job and what it did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Feeding {
    /// The serial speed it was checked for, baud.
    pub baud: u32,
    /// Where the job as first written starves the planner.
    pub starved: Vec<Starve>,
    /// Seconds those stretches lose.
    pub lost_s: f64,
    /// Where the feed was lowered so that it does not.
    pub slowed: Vec<Slowed>,
    /// Where the written job still starves (lowering was not asked for, or did not suffice).
    pub still: Vec<Starve>,
}

impl Feeding {
    /// Nothing starved: nothing to say.
    pub fn is_quiet(&self) -> bool {
        self.starved.is_empty()
    }
}

/// Check a written job's lines against `link`; with `lower`, lower the feed where it starves.
/// Returns the job's text (changed only where lowered), its estimate with what starvation
/// remains, and what was found and done.
pub fn keep_fed(
    text: String,
    limits: &Motion,
    link: &Link,
    rule: impl Fn(&Program) -> CutRule,
    lower: bool,
) -> Result<(String, Estimate, Feeding), GcodeError> {
    let program = interpret_program(&text)?;
    let first = estimate_streamed(&program, &text, limits, link, rule(&program));
    let mut feeding = Feeding {
        baud: link.baud,
        lost_s: first.lost_s(),
        starved: first.starved.clone(),
        ..Feeding::default()
    };
    if first.starved.is_empty() || !lower {
        feeding.still = first.starved.clone();
        return Ok((text, first.estimate, feeding));
    }
    // Per line, the feed written there; lowered again each round where it still starves.
    let mut lowered: BTreeMap<usize, f64> = BTreeMap::new();
    let (mut text, mut program, mut now): (String, Program, Streamed) = (text, program, first);
    let original = text.clone();
    let original_program = program.clone();
    for round in 0..ROUNDS {
        if now.starved.is_empty() {
            break;
        }
        for s in &now.starved {
            let share = if round == 0 { FIRST_SHARE } else { NEXT_SHARE };
            let current = lowered
                .range(s.first_line..=s.last_line)
                .map(|(_, &f)| f)
                .fold(s.feed_mm_min, f64::min);
            let target = if round == 0 {
                s.fed_mm_min * share
            } else {
                current * share
            };
            let f = target.min(current).floor().max(1.0);
            for line in s.first_line..=s.last_line {
                lowered.insert(line, f);
            }
        }
        text = rewrite(&original, &original_program, &lowered);
        program = interpret_program(&text)?;
        now = estimate_streamed(&program, &text, limits, link, rule(&program));
    }
    feeding.slowed = slowed_stretches(&original_program, &lowered);
    feeding.still = now.starved.clone();
    Ok((text, now.estimate, feeding))
}

/// The lowered lines as stretches, each with its feed before and after.
fn slowed_stretches(program: &Program, lowered: &BTreeMap<usize, f64>) -> Vec<Slowed> {
    let mut out: Vec<Slowed> = Vec::new();
    for m in program.moves.iter().filter(|m| !m.rapid) {
        let Some(&f) = lowered.get(&m.line) else {
            continue;
        };
        match out.last_mut() {
            Some(s) if s.now_mm_min == f && m.line <= s.last_line + 1 + 8 => {
                s.last_line = m.line;
                s.to = [m.to[0], m.to[1]];
                s.was_mm_min = s.was_mm_min.max(m.feed);
            }
            _ => out.push(Slowed {
                first_line: m.line,
                last_line: m.line,
                from: [m.from[0], m.from[1]],
                to: [m.to[0], m.to[1]],
                was_mm_min: m.feed,
                now_mm_min: f,
            }),
        }
    }
    out
}

/// `text` with the feed of every cutting move on a `lowered` line set to its lowered value, and
/// the first cutting move after each lowered stretch set back to the feed it had.
fn rewrite(text: &str, program: &Program, lowered: &BTreeMap<usize, f64>) -> String {
    // The F each line must carry: the lowered one where the feed changes to it, the original
    // one on the first cutting move after a lowered stretch.
    let mut carry: BTreeMap<usize, f64> = BTreeMap::new();
    // The feed in force before each move in the rewritten text, and in the original one: where
    // both agree and the move keeps its feed, the original words already say it.
    let (mut written, mut original): (Option<f64>, Option<f64>) = (None, None);
    for m in program.moves.iter().filter(|m| !m.rapid) {
        let want = lowered.get(&m.line).copied().unwrap_or(m.feed).min(m.feed);
        if written != Some(want) && !(want == m.feed && written == original) {
            carry.insert(m.line, want);
        }
        written = Some(want);
        original = Some(m.feed);
    }
    let mut out = String::with_capacity(text.len() + 16 * carry.len());
    for (i, line) in text.lines().enumerate() {
        match carry.get(&(i + 1)) {
            Some(&f) => out.push_str(&with_feed(line, f)),
            None => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

/// `line` (a writer's move: words separated by spaces) with its F word set to `f`, or `line`
/// unchanged if that would make it longer than Grbl takes.
fn with_feed(line: &str, f: f64) -> String {
    let word = format!("F{}", num(f));
    let mut words: Vec<&str> = line.split(' ').collect();
    match words.iter().position(|w| w.starts_with('F')) {
        Some(k) => words[k] = &word,
        None => words.push(&word),
    }
    let new = words.join(" ");
    if clean_line(&new).len() > MAX_LINE_BYTES {
        line.to_string()
    } else {
        new
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{gcode_for, machine, CutLoops, CutSettings, PlanConfig};
    use geo::{LineString, MultiPolygon, Polygon, Rect};

    /// A round hole of 15 mm radius drawn as 0.05 mm segments (a fine polygon written without
    /// arcs), cut at 6000 mm/min on the CO2 profile (3000 mm/s²): 115200 baud brings about 680
    /// lines a second, the feed would use over a thousand.
    fn fine_circle(keep_feed: bool) -> (String, crate::GcodeSummary) {
        let n = 1885;
        let ring: Vec<(f64, f64)> = (0..=n)
            .map(|i| {
                let a = std::f64::consts::TAU * f64::from(i % n) / f64::from(n);
                (30.0 + 15.0 * a.cos(), 30.0 + 15.0 * a.sin())
            })
            .collect();
        let loops = CutLoops::drawn(
            Rect::new((0., 0.), (60., 60.)),
            MultiPolygon(vec![Polygon::new(LineString::from(ring), vec![])]),
        );
        let m = machine::load(Some("co2-600x400")).unwrap();
        let settings = CutSettings {
            power_pct: 50.0,
            speed_mm_min: 6000.0,
            passes: 1,
            blade_offset_mm: 0.0,
            air_assist: false,
        };
        let mut cfg = PlanConfig::new(settings);
        cfg.keep_feed = keep_feed;
        gcode_for(&loops, &m, &cfg, &[]).unwrap()
    }

    fn feeds(text: &str) -> Vec<f64> {
        text.lines()
            .filter_map(|l| l.split(' ').find_map(|w| w.strip_prefix('F')))
            .map(|f| f.parse().unwrap())
            .collect()
    }

    fn moves_of(text: &str) -> Vec<String> {
        text.lines()
            .filter(|l| l.starts_with('G'))
            .map(|l| {
                l.split(' ')
                    .filter(|w| !w.starts_with('F'))
                    .collect::<Vec<_>>()
                    .join(" ")
            })
            .collect()
    }

    #[test]
    fn a_starving_job_is_written_with_a_feed_the_line_keeps_fed() {
        let (kept, k) = fine_circle(true);
        let (fed, f) = fine_circle(false);
        // Asked to keep the feed: the job says where it starves and keeps 6000 mm/min.
        assert!(!k.feeding.still.is_empty() && k.feeding.slowed.is_empty());
        assert!(
            feeds(&kept).iter().all(|&v| v == 6000.0),
            "{:?}",
            feeds(&kept)
        );
        // By default the feed is lowered there, and the written job no longer starves
        // (checked by timing what was written over the serial line).
        assert!(f.feeding.still.is_empty(), "{:?}", f.feeding.still);
        assert_eq!(f.feeding.starved, k.feeding.starved);
        let s = &f.feeding.slowed;
        assert!(!s.is_empty());
        assert!(
            s.iter()
                .all(|s| s.now_mm_min < 6000.0 && s.was_mm_min == 6000.0),
            "{s:?}"
        );
        let m = machine::load(Some("co2-600x400")).unwrap();
        let p = interpret_program(&fed).unwrap();
        let again = estimate_streamed(&p, &fed, &m.motion, &m.link, m.cut_rule(&p.moves));
        assert!(again.starved.is_empty(), "{:?}", again.starved);
        assert_eq!(again.estimate, f.estimate);
        // Only F words changed: the same moves, in the same order.
        assert_eq!(moves_of(&kept), moves_of(&fed));
        assert!(feeds(&fed).iter().any(|&v| v < 6000.0));
    }

    #[test]
    fn the_feed_word_is_set_or_added() {
        assert_eq!(
            with_feed("G1 X1 Y2 S800 F6000", 2400.0),
            "G1 X1 Y2 S800 F2400"
        );
        assert_eq!(with_feed("G1 X1 Y2", 2400.5), "G1 X1 Y2 F2400.5");
        let long = format!("G1 X{} Y1", "1".repeat(74));
        assert_eq!(with_feed(&long, 100.0), long);
    }
}
