//! Text from a user's file quoted back in a message: cut short, so that a megabyte-long number or
//! line does not become a megabyte-long error, and with its control characters written out, so
//! that a file cannot drive the terminal it is printed on (an ESC sequence in a G-code header or
//! a journal could recolour, retitle or clear the screen, or hide the rest of a warning).

/// The most characters of a value quoted in a message.
pub const EXCERPT_CHARS: usize = 40;

/// `s` as quoted in a message: whole when short, else its first `EXCERPT_CHARS` (40) characters, an
/// ellipsis and how long it is; control characters written out as [`printable`] does.
pub fn excerpt(s: &str) -> String {
    let n = s.chars().count();
    if n <= EXCERPT_CHARS {
        printable(s)
    } else {
        let head: String = s.chars().take(EXCERPT_CHARS).collect();
        format!("{}… ({n} characters)", printable(&head))
    }
}

/// The most characters of a file name quoted whole: a name is read by its start and its end (the
/// extension), so a longer one keeps both, cut in the middle.
pub const NAME_CHARS: usize = 100;

/// A file name as quoted in a message: whole when up to `NAME_CHARS` (100) characters, else its first
/// 60 and last 30 around an ellipsis, and how long it is; control characters written out.
pub fn excerpt_name(s: &str) -> String {
    let n = s.chars().count();
    if n <= NAME_CHARS {
        return printable(s);
    }
    let head: String = s.chars().take(60).collect();
    let tail: String = s.chars().skip(n - 30).collect();
    format!("{}…{} ({n} characters)", printable(&head), printable(&tail))
}

/// `s` with every character that could act on a terminal written out as an escape instead: the
/// C0 and C1 controls (ESC is `\u{1b}`, a line end `\n`) and the bidirectional overrides (which
/// reorder what is shown). Everything else, other scripts included, is kept as it is.
pub fn printable(s: &str) -> String {
    let acts = |c: char| {
        c.is_control()
            || matches!(c, '\u{200e}' | '\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
    };
    if !s.chars().any(acts) {
        return s.to_string();
    }
    let mut out = String::with_capacity(s.len() + 8);
    for c in s.chars() {
        if acts(c) {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_name_keeps_its_start_and_its_extension() {
        let name = "chelsea_the_cat_in_the_garden_long_name.png";
        assert_eq!(
            excerpt_name(name),
            name,
            "a name of 43 characters is quoted whole"
        );
        let long = format!("{}.png", "a".repeat(80) + &"b".repeat(40));
        let e = excerpt_name(&long);
        assert!(e.starts_with(&"a".repeat(60)), "{e}");
        assert!(
            e.contains(&format!("…{}.png (124 characters)", "b".repeat(26))),
            "{e}"
        );
        assert!(!excerpt_name("x\u{1b}[2J.png").contains('\u{1b}'));
    }

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

    #[test]
    fn control_characters_are_written_out() {
        assert_eq!(printable("a\u{1b}[2Jb"), "a\\u{1b}[2Jb");
        assert_eq!(printable("line\nnext\r"), "line\\nnext\\r");
        assert_eq!(printable("\u{9b}31m"), "\\u{9b}31m");
        assert_eq!(printable("abc\u{202e}def"), "abc\\u{202e}def");
        assert_eq!(printable("Grüße, 日本"), "Grüße, 日本");
        let e = excerpt(&format!("{}\u{1b}]0;title\u{7}", "x".repeat(45)));
        assert!(
            !e.contains('\u{1b}') && e.ends_with("(55 characters)"),
            "{e}"
        );
        let e = excerpt("\u{1b}[31mred");
        assert_eq!(e, "\\u{1b}[31mred");
    }
}
