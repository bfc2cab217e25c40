//! Lines grblHAL answers differently from Grbl 1.1h, as far as a line's own words show it.
//! Measured against grblHAL's Simulator (core 868991815d, build 20260817, 2026-11-29) on the
//! parser cases Grbl 1.1h's parity suite holds (`grblhal_sim` in the end-to-end tests records
//! all 43 that differ). Named here: the ones that hang on the words alone. Left out: those that
//! hang on where the head is or on the modes before (arcs grblHAL judges with other tolerances,
//! such as full circles; `G53`, `G92`, `G10` without `L`, probing), which a line cannot show.

use stencil_gcode::interpret::words;

/// How grblHAL's answer to `clean` (a line as Grbl's line buffer holds it) differs from
/// Grbl 1.1h's, in words; `None` when nothing in its words says it does.
pub(crate) fn grblhal_differs(clean: &str) -> Option<&'static str> {
    if clean.starts_with('$') {
        return None;
    }
    let w = words(clean, 0).ok()?;
    let has = |l: char, v: f64| w.iter().any(|&(k, x)| k == l && (x - v).abs() < 1e-6);
    let value = |l: char| w.iter().find(|&&(k, _)| k == l).map(|&(_, x)| x);
    if w.iter().any(|&(k, _)| "ABCDEHOQ".contains(k)) {
        return Some("grblHAL answers error:36 (a word it does not use), Grbl 1.1h error:20");
    }
    if has('G', 5.0) || has('G', 81.0) {
        return Some("grblHAL answers error:22 (a G-code it does not support), Grbl 1.1h error:20");
    }
    if has('G', 59.1) {
        return Some(
            "grblHAL accepts it (its extra work coordinate system); Grbl 1.1h answers error:23",
        );
    }
    if has('G', 92.2) || has('M', 7.0) || has('M', 6.0) || has('M', 48.0) {
        return Some("grblHAL accepts it; Grbl 1.1h answers error:20 (unsupported command)");
    }
    if value('T').is_some_and(|t| t > 255.0) {
        return Some("grblHAL accepts it; Grbl 1.1h answers error:38 (tool numbers up to 255)");
    }
    if has('G', 10.0) && has('L', 2.0) && value('P').is_some_and(|p| p > 6.0 && p <= 9.0) {
        return Some(
            "grblHAL accepts it (its work coordinate systems 7 to 9); Grbl 1.1h answers error:29",
        );
    }
    if has('G', 43.1) && (value('X').is_some() || value('Y').is_some()) {
        return Some("grblHAL accepts it; Grbl 1.1h answers error:37 (tool offset on Z only)");
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_measured_word_differences_are_named_and_common_lines_are_not() {
        // From the measured list: (line, Grbl 1.1h, grblHAL).
        for (line, grbl, hal) in [
            ("G0X1E3", "error:20", "error:36"),
            ("G0X1A2", "error:20", "error:36"),
            ("O100", "error:20", "error:36"),
            ("G1X1Q1F10", "error:20", "error:36"),
            ("G5X1", "error:20", "error:22"),
            ("G81X1", "error:20", "error:22"),
            ("G59.1", "error:23", "accepts"),
            ("G92.2", "error:20", "accepts"),
            ("T256", "error:38", "accepts"),
            ("G10L2P7X5", "error:29", "accepts"),
            ("G43.1X1", "error:37", "accepts"),
            ("M7", "error:20", "accepts"),
            ("M6", "error:20", "accepts"),
            ("M48", "error:20", "accepts"),
        ] {
            let said = grblhal_differs(line).unwrap_or_else(|| panic!("{line}"));
            assert!(said.contains(grbl) && said.contains(hal), "{line}: {said}");
        }
        for line in [
            "G21G90",
            "G1X10Y5F1200S300",
            "M4S0",
            "G10L2P1X5",
            "T5",
            "G43.1Z1",
            "$H",
        ] {
            assert_eq!(grblhal_differs(line), None, "{line}");
        }
    }
}
