//! The byte link to a controller: any port that reads with a timeout and writes, read line by
//! line, with silence detection.

use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

use crate::protocol::RT_STATUS;

/// A byte link to a controller: read with a timeout, write. Implemented for serial ports and ptys.
pub trait BytePort: Read + Write + Send {
    /// How long a `read` may block before failing with `TimedOut`.
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()>;
    /// The port's name for messages.
    fn describe(&self) -> String;
}

impl BytePort for TTYPort {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        SerialPort::set_timeout(self, timeout).map_err(io::Error::from)
    }
    fn describe(&self) -> String {
        SerialPort::name(self).unwrap_or_else(|| "pseudo-terminal".into())
    }
}

impl BytePort for Box<dyn SerialPort> {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.set_timeout(timeout).map_err(io::Error::from)
    }
    fn describe(&self) -> String {
        self.name().unwrap_or_else(|| "serial port".into())
    }
}

/// Why the link failed: the port went away, or the controller said nothing for too long (s).
pub(super) enum LinkFault {
    Lost(String),
    Silent(f64),
}

/// Line-oriented reading and raw writing, with silence detection.
pub(super) struct Link<'a> {
    pub(super) port: &'a mut dyn BytePort,
    pub(super) buf: Vec<u8>,
    pub(super) last_heard: Instant,
    pub(super) timeout: Duration,
    /// Status requests (`?` bytes) written so far: Grbl takes every `?` byte as one, wherever it
    /// stands in the stream.
    pub(super) polls_sent: u64,
    /// Status reports read so far, never counted past [`Link::polls_sent`] (a report nobody here
    /// asked for, such as one left over from an earlier sender, answers none of our requests).
    ///
    /// The `k`-th report was written after Grbl had read our `k`-th `?`: every report answers at
    /// least one request not answered before (Grbl folds requests that arrive together into one
    /// report, and a request or report lost on the wire only makes the count lag). So the report
    /// counted `k` describes Grbl after it read every byte written before that `?`.
    pub(super) reports_seen: u64,
}

impl<'a> Link<'a> {
    pub(super) fn new(port: &'a mut dyn BytePort, timeout: Duration) -> Link<'a> {
        Link {
            port,
            buf: Vec::new(),
            last_heard: Instant::now(),
            timeout,
            polls_sent: 0,
            reports_seen: 0,
        }
    }
}

impl Link<'_> {
    pub(super) fn write(&mut self, bytes: &[u8]) -> Result<(), LinkFault> {
        self.port
            .write_all(bytes)
            .and_then(|_| self.port.flush())
            .map_err(|e| LinkFault::Lost(e.to_string()))?;
        self.polls_sent += bytes.iter().filter(|&&b| b == RT_STATUS).count() as u64;
        Ok(())
    }

    /// The next complete line, waiting at most `wait`; `None` if none came.
    pub(super) fn line(&mut self, wait: Duration) -> Result<Option<String>, LinkFault> {
        loop {
            if let Some(i) = self.buf.iter().position(|&b| b == b'\n') {
                let raw: Vec<u8> = self.buf.drain(..=i).collect();
                let s = String::from_utf8_lossy(&raw).trim().to_string();
                if s.is_empty() {
                    continue;
                }
                if s.starts_with('<') && s.ends_with('>') {
                    self.reports_seen = (self.reports_seen + 1).min(self.polls_sent);
                }
                return Ok(Some(s));
            }
            let silent = self.last_heard.elapsed();
            if silent > self.timeout {
                return Err(LinkFault::Silent(silent.as_secs_f64()));
            }
            let wait = wait
                .min(self.timeout - silent)
                .max(Duration::from_millis(1));
            self.port
                .set_read_timeout(wait)
                .map_err(|e| LinkFault::Lost(e.to_string()))?;
            let mut chunk = [0u8; 1024];
            match self.port.read(&mut chunk) {
                Ok(0) => return Ok(None),
                Ok(n) => {
                    self.last_heard = Instant::now();
                    self.buf.extend_from_slice(&chunk[..n]);
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::TimedOut
                            | io::ErrorKind::WouldBlock
                            | io::ErrorKind::Interrupted
                    ) =>
                {
                    return Ok(None)
                }
                Err(e) => return Err(LinkFault::Lost(e.to_string())),
            }
        }
    }
}
