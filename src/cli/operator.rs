//! What the operator does while a machine moves (`send`, `frame`): keys from the terminal in raw
//! mode, SIGINT/SIGTERM/SIGHUP taken as aborts, and which of them asked for the abort.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;
use stencil_grbl::{Control, Key, KeySource};

/// What asked for an abort, the first that did: a stop signal or a key, said in the stop's message
/// and the journal (the stream knows only that an abort was asked for).
static ABORT_CAUSE: std::sync::OnceLock<&'static str> = std::sync::OnceLock::new();

/// The stop's first words for an abort: what asked for it.
pub fn abort_cause() -> &'static str {
    ABORT_CAUSE
        .get()
        .copied()
        .unwrap_or("aborted by the operator")
}

/// SIGINT, SIGTERM and SIGHUP take the abort's path, once per process, each named as it arrives.
#[cfg(unix)]
fn on_stop_signals(tx: Sender<Control>) {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
            return;
        };
        std::thread::spawn(move || {
            for sig in signals.forever() {
                let _ = ABORT_CAUSE.set(match sig {
                    SIGINT => "stopped by SIGINT (Ctrl-C)",
                    SIGTERM => {
                        "stopped by SIGTERM (a request to end stencil: `kill`, a service manager \
                         or a shutdown)"
                    }
                    _ => "stopped by SIGHUP (the terminal closed)",
                });
                let _ = tx.send(Control::Abort);
            }
        });
    });
}

/// Ctrl-C (and closing the console) take the abort's path, once per process.
#[cfg(not(unix))]
fn on_stop_signals(tx: Sender<Control>) {
    let _ = ctrlc::set_handler(move || {
        let _ = ABORT_CAUSE.set("stopped by Ctrl-C");
        let _ = tx.send(Control::Abort);
    });
}

/// Keys from the terminal in raw mode (no Enter needed; Ctrl-C arrives as a key). Restores the
/// terminal when dropped, also on error paths.
pub struct Keys {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    pub raw: bool,
}

impl Keys {
    pub fn start(tx: Sender<Control>) -> Keys {
        let stop = Arc::new(AtomicBool::new(false));
        // SIGINT, SIGTERM and SIGHUP (the terminal closed, a service manager stopping us) take
        // the abort's path: hold, wait until the machine stands, reset, laser and air off. One
        // handler per process: `send --frame` starts keys twice on the same channel, so the
        // first handler serves both.
        on_stop_signals(tx.clone());
        let raw = std::io::stdin().is_terminal() && crossterm::terminal::enable_raw_mode().is_ok();
        let stop2 = stop.clone();
        let thread =
            raw.then(|| std::thread::spawn(move || stencil_grbl::pump(&mut Terminal, &tx, &stop2)));
        Keys { stop, thread, raw }
    }
}

impl Drop for Keys {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        if self.raw {
            let _ = crossterm::terminal::disable_raw_mode();
        }
    }
}

/// The terminal in raw mode as a key source (crossterm: already how raw mode is entered here, and
/// it reads keys the same way on Unix and Windows).
struct Terminal;

impl KeySource for Terminal {
    fn next_key(&mut self, wait: Duration) -> std::io::Result<Option<Key>> {
        use crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
        if !event::poll(wait)? {
            return Ok(None);
        }
        let Event::Key(k) = event::read()? else {
            return Ok(None);
        };
        if k.kind == KeyEventKind::Release {
            return Ok(None);
        }
        let key = match k.code {
            KeyCode::Char('c') if k.modifiers.contains(KeyModifiers::CONTROL) => Key::CtrlC,
            KeyCode::Char(c) => Key::Char(c),
            KeyCode::Esc => Key::Esc,
            _ => return Ok(None),
        };
        if stencil_grbl::controls_for(key) == [Control::Abort] {
            let _ = ABORT_CAUSE.set(match key {
                Key::CtrlC => "aborted with Ctrl-C",
                Key::Esc => "aborted with the abort key (Esc)",
                Key::Char('q') => "aborted with the abort key (q)",
                _ => "aborted with the abort key (a)",
            });
        }
        Ok(Some(key))
    }
}
