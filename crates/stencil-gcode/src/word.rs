//! One word of a G-code line, read as Grbl 1.1h reads it: a letter and a number by
//! nuts_bolts.c's `read_float`.

use stencil_io::excerpt;

use crate::error::{fail, GcodeError};

/// nuts_bolts.c's `MAX_INT_DIGITS`: `read_float` keeps this many significant digits.
const MAX_INT_DIGITS: u32 = 8;

/// Read one word at `*i`: a letter A–Z (else `error:1`, protocol's `STATUS_EXPECTED_COMMAND_LETTER`)
/// and a number as nuts_bolts.c's `read_float` reads it: an optional sign, digits with at most one
/// point, no exponent, eight significant digits kept; no digit is `error:2`.
pub(crate) fn next_word(
    clean: &str,
    i: &mut usize,
    line: usize,
) -> Result<Option<(char, f64)>, GcodeError> {
    let b = clean.as_bytes();
    let Some(&letter) = b.get(*i) else {
        return Ok(None);
    };
    if !letter.is_ascii_uppercase() {
        return Err(fail(
            line,
            1,
            format!("expected a command letter at '{}'", excerpt(&clean[*i..])),
        ));
    }
    let mut j = *i + 1;
    let negative = b.get(j) == Some(&b'-');
    if matches!(b.get(j), Some(b'-' | b'+')) {
        j += 1;
    }
    let (mut int, mut exp, mut digits, mut decimal) = (0u64, 0i32, 0u32, false);
    while let Some(&c) = b.get(j) {
        if c.is_ascii_digit() {
            digits += 1;
            if digits <= MAX_INT_DIGITS {
                if decimal {
                    exp -= 1;
                }
                int = int * 10 + u64::from(c - b'0');
            } else if !decimal {
                exp += 1;
            }
        } else if c == b'.' && !decimal {
            decimal = true;
        } else {
            break;
        }
        j += 1;
    }
    if digits == 0 {
        return Err(fail(line, 2, format!("'{}' has no number", letter as char)));
    }
    // Dividing by an exact power of ten rounds correctly (25.4, not 254 × 0.1).
    let v = if exp < 0 {
        int as f64 / 10f64.powi(-exp)
    } else {
        int as f64 * 10f64.powi(exp)
    };
    if !v.is_finite() {
        return Err(GcodeError::out_of_range(
            line,
            format!(
                "the number after '{}' ({}) is too large to be a number",
                letter as char,
                excerpt(&clean[*i + 1..j])
            ),
        ));
    }
    *i = j;
    Ok(Some((letter as char, if negative { -v } else { v })))
}
