//! The controller over the network: FluidNC's and grblHAL's telnet-style stream (a raw TCP
//! socket carrying the same bytes as the serial line).

use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::time::Duration;

use super::link::BytePort;

/// A TCP connection to a controller. Unlike a serial port, a socket says when the other end is
/// gone: a read of nothing is the link dropping (WiFi lost, the board rebooted), reported as an
/// error so the stream stops and says so, instead of waiting for a silence timeout.
pub struct TcpPort {
    stream: TcpStream,
    name: String,
}

impl TcpPort {
    /// Connect to `host:port`, trying each address it resolves to for at most `timeout`.
    pub fn connect(host_port: &str, timeout: Duration) -> io::Result<TcpPort> {
        let addrs: Vec<SocketAddr> = host_port.to_socket_addrs()?.collect();
        let mut last = io::Error::new(io::ErrorKind::NotFound, "the name resolves to no address");
        for a in addrs {
            match TcpStream::connect_timeout(&a, timeout) {
                Ok(stream) => {
                    // Lines are short and answered one by one: no batching delay.
                    stream.set_nodelay(true)?;
                    return Ok(TcpPort {
                        stream,
                        name: format!("tcp://{host_port}"),
                    });
                }
                Err(e) => last = e,
            }
        }
        Err(last)
    }
}

impl Read for TcpPort {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self.stream.read(buf) {
            Ok(0) if !buf.is_empty() => Err(closed()),
            Err(e) if gone(&e) => Err(closed()),
            // A read timeout is `WouldBlock` on Unix sockets; the link reads it as no data.
            r => r,
        }
    }
}

/// The other end shut the connection: whether a read or a write finds out first (a write to
/// a socket the board closed fails with a broken pipe or a reset), it is the same event.
fn gone(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::BrokenPipe
            | io::ErrorKind::ConnectionReset
            | io::ErrorKind::ConnectionAborted
    )
}

fn closed() -> io::Error {
    io::Error::new(
        io::ErrorKind::ConnectionAborted,
        "the controller closed the network connection",
    )
}

impl Write for TcpPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.stream
            .write(buf)
            .map_err(|e| if gone(&e) { closed() } else { e })
    }
    fn flush(&mut self) -> io::Result<()> {
        self.stream.flush()
    }
}

impl BytePort for TcpPort {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.stream
            .set_read_timeout(Some(timeout.max(Duration::from_millis(1))))
    }
    fn describe(&self) -> String {
        self.name.clone()
    }
}
