//! Numbers as every G-code line of this crate writes them.

/// A number with at most 3 decimals, no trailing zeros, no `-0`.
pub fn num(v: f64) -> String {
    let r = (v * 1000.0).round() / 1000.0;
    if r == 0.0 {
        return "0".into();
    }
    let s = format!("{r:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}
