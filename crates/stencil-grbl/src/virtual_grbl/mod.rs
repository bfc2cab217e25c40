//! A simulated Grbl 1.1h on a pseudo-terminal, for dry runs and tests.
//!
//! It speaks the real protocol on the far end of a pty pair, so `stencil send` runs exactly the same
//! code against it as against a board. It records every line it received, what it executed and
//! every move it planned, so a test can check the machine got exactly the program, once each, in
//! order, and where the head went.
//!
//! By concern: `config` (the build, its pace, injected faults), `record` (what it saw and did),
//! `sim` (the board, its main loop and the wire: a receive buffer of fixed size that drops and
//! counts overflowing bytes), `parser` (line buffer and G-code lines through the shared
//! interpreter), `planner` (motion at the programmed feeds: `ok` means queued, not executed),
//! `jog`, `realtime` (real-time bytes, status reports), `system` (`$` commands and settings),
//! `card` (grblHAL's and FluidNC's SD card: uploads, runs from it), `storage`, `faults` and `wire` (its end of the link: a pty, or a TCP endpoint).

use std::net::{SocketAddr, TcpListener};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

use serialport::TTYPort;

mod card;
mod config;
mod faults;
mod jog;
mod parser;
mod planner;
mod realtime;
mod record;
mod sim;
mod storage;
mod system;
#[cfg(test)]
mod tests;
mod wire;

pub use self::config::{Fault, FaultKind, Pace, Stutter, VirtualConfig};
pub use self::record::{Event, PlannedMove, Received, Record};

use self::record::lock;
use self::sim::Sim;
use self::wire::Wire;

/// A running virtual Grbl. Dropping it stops the thread and closes its end of the pty.
pub struct VirtualGrbl {
    shared: Arc<Mutex<Record>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl VirtualGrbl {
    /// Start a virtual Grbl on a new pty pair; returns it and the host end to stream to.
    pub fn spawn(cfg: VirtualConfig) -> std::io::Result<(VirtualGrbl, TTYPort)> {
        let (master, host) = TTYPort::pair().map_err(std::io::Error::from)?;
        Ok((VirtualGrbl::start(cfg, Wire::Pty(master))?, host))
    }

    /// Start a virtual controller behind a TCP endpoint on 127.0.0.1 (a WiFi board's telnet
    /// stream; port chosen by the system): returns it and the address to connect to. It takes
    /// one host at a time, and runs on when a host's connection drops (the next one is taken).
    pub fn spawn_tcp(cfg: VirtualConfig) -> std::io::Result<(VirtualGrbl, SocketAddr)> {
        let listener = TcpListener::bind(("127.0.0.1", 0))?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let wire = Wire::Tcp {
            listener,
            conn: None,
        };
        Ok((VirtualGrbl::start(cfg, wire)?, addr))
    }

    fn start(cfg: VirtualConfig, wire: Wire) -> std::io::Result<VirtualGrbl> {
        let shared = Arc::new(Mutex::new(Record::default()));
        let stop = Arc::new(AtomicBool::new(false));
        let mut sim = Sim::new(cfg, wire, shared.clone());
        let stop2 = stop.clone();
        let thread = std::thread::Builder::new()
            .name("virtual-grbl".into())
            .spawn(move || sim.run(&stop2))?;
        Ok(VirtualGrbl {
            shared,
            stop,
            thread: Some(thread),
        })
    }

    /// A snapshot of what the machine saw so far.
    pub fn record(&self) -> Record {
        lock(&self.shared).clone()
    }

    /// Stop the machine and return its final record.
    pub fn stop(mut self) -> Record {
        self.halt();
        self.record()
    }

    fn halt(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for VirtualGrbl {
    fn drop(&mut self) {
        self.halt();
    }
}
