//! The virtual board's end of the link: a pty (a USB serial port), or a TCP endpoint on
//! 127.0.0.1 (a WiFi board's telnet-style stream) that takes one host at a time and runs on when
//! that host's connection drops, as FluidNC and grblHAL boards do.

use std::io::{self, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::time::Duration;

use serialport::{SerialPort, TTYPort};

pub(super) enum Wire {
    Pty(TTYPort),
    Tcp {
        listener: TcpListener,
        conn: Option<TcpStream>,
    },
}

impl Wire {
    /// Read what arrived, waiting at most `wait`; `Ok(0)` when nothing did. Over TCP a new host
    /// is taken when none is connected, and a host that hung up leaves the board unconnected.
    pub(super) fn read(&mut self, buf: &mut [u8], wait: Duration) -> io::Result<usize> {
        match self {
            Wire::Pty(p) => {
                let _ = p.set_timeout(wait);
                match p.read(buf) {
                    Err(e) if e.kind() == io::ErrorKind::TimedOut => Ok(0),
                    r => r,
                }
            }
            Wire::Tcp { listener, conn } => {
                if conn.is_none() {
                    match listener.accept() {
                        Ok((s, _)) => {
                            s.set_nodelay(true)?;
                            *conn = Some(s);
                        }
                        Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                            std::thread::sleep(wait.min(Duration::from_millis(5)));
                            return Ok(0);
                        }
                        Err(e) => return Err(e),
                    }
                }
                let Some(s) = conn.as_mut() else {
                    return Ok(0);
                };
                s.set_read_timeout(Some(wait.max(Duration::from_millis(1))))?;
                match s.read(buf) {
                    Ok(0) => {
                        *conn = None;
                        Ok(0)
                    }
                    Err(e)
                        if matches!(
                            e.kind(),
                            io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                        ) =>
                    {
                        Ok(0)
                    }
                    Err(_) => {
                        *conn = None;
                        Ok(0)
                    }
                    r => r,
                }
            }
        }
    }

    /// Send to the host; over TCP with nobody connected the bytes are lost, as a WiFi board's are.
    pub(super) fn write_all(&mut self, bytes: &[u8]) {
        match self {
            Wire::Pty(p) => {
                let _ = p.set_timeout(Duration::from_millis(200));
                let _ = p.write_all(bytes);
            }
            Wire::Tcp { conn, .. } => {
                if let Some(s) = conn.as_mut() {
                    if s.write_all(bytes).is_err() {
                        *conn = None;
                    }
                }
            }
        }
    }

    /// The network link drops (the board runs on). False on a pty, which has no such link.
    pub(super) fn drop_link(&mut self) -> bool {
        match self {
            Wire::Pty(_) => false,
            Wire::Tcp { conn, .. } => {
                if let Some(s) = conn.take() {
                    let _ = s.shutdown(std::net::Shutdown::Both);
                }
                true
            }
        }
    }
}
