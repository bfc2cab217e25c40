//! `stencil jog`: move the head by keys (`$J=` jogs), home, unlock and set work zero. Keys come
//! from the terminal in raw mode, from `--keys`, or as names read from a pipe.

use std::collections::VecDeque;
use std::io::{self, BufRead, IsTerminal, Write};
use std::process::ExitCode;
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::time::Duration;

use anyhow::Context;
use clap::Args;

use stencil_grbl::{
    parse_key, parse_keys, Console, ControllerInfo, JogKey, JogKeys, Jogger, Observer, Script,
    StreamConfig, VirtualConfig,
};

/// Jog, home, unlock and zero the machine from the keyboard.
#[derive(Args, Debug)]
#[command(after_help = "\
Keys: arrows = jog X/Y, PgUp/PgDn = jog Z, 1/2/3 = step 0.1/1/10 mm, + / - = larger/smaller \
step, space = cancel the jog, h = home ($H), u = unlock ($X), 0 = work zero X0 Y0 here \
(G10 L20 P1), q / Esc / Ctrl-C = quit (cancels a running jog, then M5 and M9).
Without a terminal, key names are read from stdin (one or more per line) or given with --keys: \
left, right, up, down, pgup, pgdn, 1, 2, 3, +, -, space, h, u, 0, release, wait, q.
Example: stencil jog --dry-run --keys \"right,right,up,wait,0,q\"")]
pub struct JogArgs {
    #[command(flatten)]
    pub link: super::port::PortArgs,
    /// Step per key press, mm (0.001 to 1000); 1, 2, 3 pick 0.1, 1 and 10 mm.
    #[arg(long, default_value_t = 1.0, value_parser = |s: &str| super::bounds::number_in(s, 0.001..=1000.0, " mm"))]
    pub step: f64,
    /// Jog feed, mm/min.
    #[arg(long, default_value_t = 1000.0, value_parser = super::bounds::parse_feed)]
    pub feed: f64,
    /// Keys to press, by name, instead of reading the keyboard (e.g. "right,right,up,0,q").
    #[arg(long, value_name = "NAMES", value_parser = |s: &str| parse_keys(s).map(KeyScript))]
    pub keys: Option<KeyScript>,
    /// Report the controller as silent after this many seconds without an answer (0.1 to 3600).
    #[arg(long, default_value_t = 10.0, value_parser = super::bounds::parse_timeout)]
    pub timeout_s: f64,
}

/// The keys of `--keys` (a newtype: clap reads a bare `Vec` as a repeated option).
#[derive(Clone, Debug)]
pub struct KeyScript(Vec<JogKey>);

/// The terminal in raw mode: arrows and page keys without Enter; key releases where the
/// terminal reports them (kitty keyboard protocol), so a held key's jog stops when let go.
struct Terminal {
    enhanced: bool,
}

impl Terminal {
    fn start() -> io::Result<Terminal> {
        use crossterm::event::{KeyboardEnhancementFlags, PushKeyboardEnhancementFlags};
        crossterm::terminal::enable_raw_mode()?;
        let enhanced = crossterm::terminal::supports_keyboard_enhancement().unwrap_or(false)
            && crossterm::execute!(
                io::stderr(),
                PushKeyboardEnhancementFlags(KeyboardEnhancementFlags::REPORT_EVENT_TYPES)
            )
            .is_ok();
        Ok(Terminal { enhanced })
    }
}

impl Drop for Terminal {
    fn drop(&mut self) {
        if self.enhanced {
            let _ =
                crossterm::execute!(io::stderr(), crossterm::event::PopKeyboardEnhancementFlags);
        }
        let _ = crossterm::terminal::disable_raw_mode();
    }
}

impl JogKeys for Terminal {
    fn next_key(&mut self, wait: Duration) -> io::Result<Option<JogKey>> {
        use crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
        if !event::poll(wait)? {
            return Ok(None);
        }
        let Event::Key(k) = event::read()? else {
            return Ok(None);
        };
        let key = match k.code {
            KeyCode::Char('c') if k.modifiers.contains(KeyModifiers::CONTROL) => JogKey::CtrlC,
            KeyCode::Left => JogKey::Left,
            KeyCode::Right => JogKey::Right,
            KeyCode::Up => JogKey::Up,
            KeyCode::Down => JogKey::Down,
            KeyCode::PageUp => JogKey::PageUp,
            KeyCode::PageDown => JogKey::PageDown,
            KeyCode::Esc => JogKey::Esc,
            KeyCode::Char(c) => JogKey::Char(c),
            _ => return Ok(None),
        };
        if k.kind == KeyEventKind::Release {
            let jog_key = matches!(
                key,
                JogKey::Left
                    | JogKey::Right
                    | JogKey::Up
                    | JogKey::Down
                    | JogKey::PageUp
                    | JogKey::PageDown
            );
            return Ok(jog_key.then_some(JogKey::Released));
        }
        Ok(Some(key))
    }
}

/// Key names from a pipe, one or more per line; the end of input quits. Ctrl-C quits too.
struct Piped {
    rx: Receiver<JogKey>,
}

impl Piped {
    fn start() -> Piped {
        let (tx, rx) = channel();
        let tx2 = tx.clone();
        // A second handler cannot be installed in one process; then Ctrl-C keeps its default.
        let _ = ctrlc::set_handler(move || {
            let _ = tx2.send(JogKey::CtrlC);
        });
        std::thread::spawn(move || {
            for line in io::stdin().lock().lines() {
                let Ok(line) = line else { break };
                for name in line
                    .split(|c: char| c == ',' || c.is_whitespace())
                    .filter(|s| !s.is_empty())
                {
                    match parse_key(name) {
                        Ok(k) if tx.send(k).is_err() => return,
                        Ok(_) => {}
                        Err(e) => eprintln!("stdin: {e}"),
                    }
                }
            }
            // The end of input quits (the Ctrl-C handler keeps the channel open).
            let _ = tx.send(JogKey::Char('q'));
        });
        Piped { rx }
    }
}

impl JogKeys for Piped {
    fn next_key(&mut self, wait: Duration) -> io::Result<Option<JogKey>> {
        match self.rx.recv_timeout(wait) {
            Ok(k) => Ok(Some(k)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(io::ErrorKind::UnexpectedEof.into()),
        }
    }
}

/// Messages on their own lines; in raw mode the status line is redrawn in place.
struct Screen {
    raw: bool,
}

impl Screen {
    fn message(&self, text: &str) {
        if self.raw {
            eprint!("\r\x1b[K{text}\r\n");
        } else {
            eprintln!("{text}");
        }
    }
}

impl Observer for Screen {
    fn connected(&mut self, info: &ControllerInfo) {
        self.message(&format!("connected to {}", info.name()));
    }
    fn message(&mut self, text: &str) {
        Screen::message(self, text);
    }
}

pub fn run_jog(a: JogArgs) -> anyhow::Result<ExitCode> {
    let mut opened = a.link.open(VirtualConfig::default())?;
    let cfg = StreamConfig {
        timeout: Duration::from_secs_f64(a.timeout_s),
        if_moving: a.link.if_moving(),
        ..StreamConfig::default()
    };
    let raw = io::stdin().is_terminal() && a.keys.is_none();
    let mut keys: Box<dyn JogKeys> = match &a.keys {
        Some(k) => Box::new(Script(VecDeque::from(k.0.clone()))),
        None if raw => Box::new(Terminal::start().context("cannot read the keyboard")?),
        None => Box::new(Piped::start()),
    };
    let mut screen = Screen { raw };
    if raw {
        screen.message(stencil_grbl::JOG_KEY_HELP);
    }
    let mut last_shown = String::new();
    let mut show = |line: &str| {
        if raw {
            eprint!("\r\x1b[K{line}");
            let _ = io::stderr().flush();
        } else if line != last_shown {
            eprintln!("{line}");
        }
        last_shown = line.to_string();
    };
    let label = opened.label.clone();
    let result = (|| -> anyhow::Result<(String, String)> {
        let mut console = Console::connect(opened.port.as_mut(), &cfg, None, &mut screen)?;
        let mut j = Jogger::new(&mut console, a.step, a.feed);
        let done = stencil_grbl::jog_session(&mut j, keys.as_mut(), &mut show)?;
        Ok((done, j.status_line()))
    })();
    drop(keys);
    if raw {
        eprint!("\r\n");
    }
    let (done, status) = result?;
    println!("{status}");
    println!("left {label}: {done}");
    if let Some(vg) = opened.virtual_grbl.take() {
        let r = vg.stop();
        println!(
            "virtual Grbl: machine at X {:.3} Y {:.3} Z {:.3}, work offset X {:.3} Y {:.3} Z {:.3}, {}, laser {}",
            r.position[0],
            r.position[1],
            r.position[2],
            r.wco[0],
            r.wco[1],
            r.wco[2],
            r.state,
            if r.laser_on { "ON" } else { "off" }
        );
    }
    Ok(ExitCode::SUCCESS)
}
