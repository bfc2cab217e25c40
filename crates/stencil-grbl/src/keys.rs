//! The operator's keys while a job streams, and what each one does.
//!
//! Reading the keyboard is behind [`KeySource`]: `stencil send` reads a terminal in raw mode
//! (crossterm), tests feed keys from a script, and both go through the same [`pump`] and the same
//! key map, so what a test presses is what a user presses.

use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::time::Duration;

use super::stream::{Control, Override};

/// A key press, as far as the sender cares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Key {
    /// A key by its character (see [`SEND_KEY_HELP`]).
    Char(char),
    /// The Escape key.
    Esc,
    /// Ctrl-C (in raw mode it arrives as a key, not as a signal).
    CtrlC,
}

/// Where key presses come from.
pub trait KeySource: Send {
    /// The next key, waiting at most `wait`; `Ok(None)` if none came. An error ends the pump
    /// (the terminal went away, or a script ran out).
    fn next_key(&mut self, wait: Duration) -> io::Result<Option<Key>>;
}

/// The keys, for the help line and the README.
pub const SEND_KEY_HELP: &str = "! or h = feed hold, ~ or r = resume, + / - = feed ±10 %, ] / [ = \
power ±10 %, 0 = both back to 100 %, a / q / Esc / Ctrl-C = abort";

/// What a key does: nothing, or one or more commands (`0` resets both overrides).
pub fn controls_for(key: Key) -> &'static [Control] {
    use Control::*;
    match key {
        Key::CtrlC | Key::Esc | Key::Char('a') | Key::Char('q') => &[Abort],
        Key::Char('!') | Key::Char('h') | Key::Char(' ') => &[FeedHold],
        Key::Char('~') | Key::Char('r') => &[Resume],
        // `=` is `+` without Shift on most keyboards.
        Key::Char('+') | Key::Char('=') => &[Override(self::Override::FeedPlus10)],
        Key::Char('-') | Key::Char('_') => &[Override(self::Override::FeedMinus10)],
        Key::Char(']') => &[Override(self::Override::PowerPlus10)],
        Key::Char('[') => &[Override(self::Override::PowerMinus10)],
        Key::Char('0') => &[
            Override(self::Override::FeedReset),
            Override(self::Override::PowerReset),
        ],
        _ => &[],
    }
}

/// Read keys and pass on their commands until `stop` is set, the source fails, or the receiver
/// is gone.
pub fn pump(source: &mut dyn KeySource, tx: &Sender<Control>, stop: &AtomicBool) {
    while !stop.load(Ordering::SeqCst) {
        let key = match source.next_key(Duration::from_millis(100)) {
            Ok(Some(k)) => k,
            Ok(None) => continue,
            Err(_) => return,
        };
        for &c in controls_for(key) {
            if tx.send(c).is_err() {
                return;
            }
        }
    }
}

/// The overrides as the progress line shows them: `Ov F110% S90%` (rapid only when not 100 %).
pub fn overrides_text(ov: [u32; 3]) -> String {
    let [f, r, s] = ov;
    let rapid = if r != 100 {
        format!(" R{r}%")
    } else {
        String::new()
    };
    format!("Ov F{f}% S{s}%{rapid}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc::channel;

    struct Script(Vec<Key>);
    impl KeySource for Script {
        fn next_key(&mut self, _wait: Duration) -> io::Result<Option<Key>> {
            if self.0.is_empty() {
                return Err(io::ErrorKind::UnexpectedEof.into());
            }
            Ok(Some(self.0.remove(0)))
        }
    }

    #[test]
    fn keys_map_to_grbl_real_time_bytes() {
        let (tx, rx) = channel();
        let keys = "+=-][0x!~".chars().map(Key::Char).chain([Key::CtrlC]);
        pump(&mut Script(keys.collect()), &tx, &AtomicBool::new(false));
        let bytes: Vec<u8> = rx
            .try_iter()
            .map(|c| match c {
                Control::Override(o) => o.byte(),
                Control::FeedHold => b'!',
                Control::Resume => b'~',
                Control::Abort => 0x18,
            })
            .collect();
        assert_eq!(
            bytes,
            [0x91, 0x91, 0x92, 0x9A, 0x9B, 0x90, 0x99, b'!', b'~', 0x18]
        );
        assert_eq!(overrides_text([110, 100, 90]), "Ov F110% S90%");
        assert_eq!(overrides_text([100, 50, 100]), "Ov F100% S100% R50%");
    }
}
