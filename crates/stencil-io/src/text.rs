//! Text from a user's file quoted back in a message: cut short, so that a megabyte-long number or
//! line does not become a megabyte-long error.

/// The most characters of a value quoted in a message.
pub const EXCERPT_CHARS: usize = 40;

/// `s` as quoted in a message: whole when short, else its first [`EXCERPT_CHARS`] characters, an
/// ellipsis and how long it is.
pub fn excerpt(s: &str) -> String {
    let n = s.chars().count();
    if n <= EXCERPT_CHARS {
        s.to_string()
    } else {
        let head: String = s.chars().take(EXCERPT_CHARS).collect();
        format!("{head}… ({n} characters)")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_values_are_cut_and_say_their_length() {
        assert_eq!(excerpt("1.5"), "1.5");
        let long = "7".repeat(1_000_000);
        let e = excerpt(&long);
        assert!(
            e.starts_with(&"7".repeat(40)) && e.ends_with("… (1000000 characters)"),
            "{e}"
        );
        // Characters, not bytes: never cut inside one.
        let e = excerpt(&"é".repeat(50));
        assert!(e.starts_with(&"é".repeat(40)), "{e}");
    }
}
