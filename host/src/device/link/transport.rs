//! Byte transports to a device: serial ports (real boards, the simulated
//! device's pty, QEMU's UART on a pty) and TCP (QEMU's `-serial tcp:`).

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::Duration;

use anyhow::Context as _;

/// A bidirectional byte pipe with timed reads.
pub trait Transport: Send {
    /// Write all of `bytes`.
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()>;
    /// Read what arrives within `timeout` into `buf`; `Ok(0)` only once
    /// the timeout has passed with nothing read.
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<usize>;
    /// A short human-readable name (port path, address).
    fn describe(&self) -> String;
    /// Drops the bytes that arrived and were not read yet, without
    /// waiting: before a new request they cannot be its reply. The
    /// default keeps them (the reply's echo still refuses a stale one).
    fn discard_input(&mut self) -> std::io::Result<()> {
        Ok(())
    }
    /// Now, on the clock the device's replies are timed by: the host's
    /// monotonic clock, or the virtual clock of an in-process device.
    fn now(&self) -> Duration {
        crate::clock::Clock::real().now()
    }
}

impl<T: Transport + ?Sized> Transport for Box<T> {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        (**self).send(bytes)
    }
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<usize> {
        (**self).recv(buf, timeout)
    }
    fn describe(&self) -> String {
        (**self).describe()
    }
    fn discard_input(&mut self) -> std::io::Result<()> {
        (**self).discard_input()
    }
    fn now(&self) -> Duration {
        (**self).now()
    }
}

fn is_timeout(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
    )
}

/// A timed read, again for what is left of `timeout` when a signal
/// interrupts it (`EINTR`: the ending signals' handler is installed
/// without `SA_RESTART`, and poll-based reads are never restarted anyway),
/// so a SIGUSR1 or SIGHUP mid-request does not fail the request: the
/// caller sees the stop flag once the request is done.
fn retry_interrupted(
    timeout: Duration,
    mut read: impl FnMut(Duration) -> std::io::Result<usize>,
) -> std::io::Result<usize> {
    let end = std::time::Instant::now() + timeout;
    loop {
        let left = end.saturating_duration_since(std::time::Instant::now());
        match read(left) {
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {
                if left.is_zero() {
                    return Ok(0);
                }
            }
            r => return r,
        }
    }
}

/// A serial port or pty, through `serialport` (no libudev).
pub struct Serial {
    port: Box<dyn serialport::SerialPort>,
    path: String,
}

/// Why a serial port did not open, in words: the path's own failure
/// (missing, a directory, not permitted) as files say it, and a path that
/// opened but takes no serial settings (ENOTTY: a regular file,
/// `/dev/null`) as not a serial port rather than the OS's "Not a
/// typewriter".
pub fn serial_open_reason(e: &serialport::Error) -> String {
    let not_a_tty =
        e.description.contains("Not a typewriter") || e.description.contains("Inappropriate ioctl");
    match e.kind {
        _ if not_a_tty => "not a serial port (it takes no serial line settings)".to_owned(),
        serialport::ErrorKind::Io(k) => match k {
            std::io::ErrorKind::NotFound
            | std::io::ErrorKind::PermissionDenied
            | std::io::ErrorKind::IsADirectory
            | std::io::ErrorKind::NotADirectory => crate::files::reason(&k.into()),
            _ => e.description.clone(),
        },
        _ => e.description.clone(),
    }
}

impl Serial {
    /// Open `path` at `baud` (8N1, no flow control, raw), for this process
    /// alone.
    ///
    /// The port is held by an exclusive `flock` on its open file
    /// description, which the kernel drops with the process however it
    /// ends. Not by `TIOCEXCL` (serialport's default): that flag lives on
    /// the tty until its last descriptor closes, so after a `kill -9` it
    /// outlived its holder for as long as the other side held the tty open
    /// (`lmhost sim` holds its pty's slave), and every later open was told
    /// the port was in use.
    pub fn open(path: &str, baud: u32) -> anyhow::Result<Self> {
        let in_use = || {
            anyhow::anyhow!(
                "{path} is in use by another process (another lmhost?); stop it or use another port"
            )
        };
        let port = serialport::new(path, baud)
            .timeout(Duration::from_millis(100))
            .exclusive(false)
            .open_native()
            .map_err(|e| {
                let busy = e.description.contains("lock")
                    || e.description.contains("Device or resource busy");
                if busy {
                    in_use()
                } else {
                    anyhow::anyhow!("opening serial port {path}: {}", serial_open_reason(&e))
                }
            })?;
        // The shared lock serialport took becomes exclusive, or the port is
        // someone else's.
        let fd = std::os::fd::AsRawFd::as_raw_fd(&port);
        // SAFETY: flock(2) on the descriptor `port` owns and keeps open.
        if unsafe { libc::flock(fd, libc::LOCK_EX | libc::LOCK_NB) } != 0 {
            let e = std::io::Error::last_os_error();
            return Err(if e.kind() == std::io::ErrorKind::WouldBlock {
                in_use()
            } else {
                anyhow::anyhow!("locking serial port {path}: {}", crate::files::reason(&e))
            });
        }
        Ok(Self {
            port: Box::new(port),
            path: path.to_owned(),
        })
    }
}

impl Transport for Serial {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.port.write_all(bytes)?;
        self.port.flush()
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<usize> {
        retry_interrupted(timeout, |left| {
            // serialport rejects a zero timeout on some platforms.
            self.port
                .set_timeout(left.max(Duration::from_micros(100)))?;
            match self.port.read(buf) {
                Ok(n) => Ok(n),
                Err(e) if is_timeout(&e) => Ok(0),
                Err(e) => Err(e),
            }
        })
    }

    fn describe(&self) -> String {
        self.path.clone()
    }

    fn discard_input(&mut self) -> std::io::Result<()> {
        // tcflush(TCIFLUSH): the kernel drops what it holds, no wait.
        self.port
            .clear(serialport::ClearBuffer::Input)
            .map_err(std::io::Error::from)
    }
}

/// A connected stream socket with timed reads: [`Tcp`] or [`Unix`].
pub struct Socket<S> {
    stream: S,
    /// What [`Transport::describe`] says.
    name: String,
    /// The error text when the peer closes the stream.
    closed: &'static str,
}

/// The stream sockets a [`Socket`] can hold.
pub trait StreamSocket: Read + Write + Send {
    /// Set (or clear) the read timeout.
    fn set_read_timeout(&self, timeout: Option<Duration>) -> std::io::Result<()>;
    /// Make reads return at once when nothing is there (or block again).
    fn set_nonblocking(&self, on: bool) -> std::io::Result<()>;
}

impl StreamSocket for TcpStream {
    fn set_read_timeout(&self, timeout: Option<Duration>) -> std::io::Result<()> {
        TcpStream::set_read_timeout(self, timeout)
    }
    fn set_nonblocking(&self, on: bool) -> std::io::Result<()> {
        TcpStream::set_nonblocking(self, on)
    }
}

impl StreamSocket for std::os::unix::net::UnixStream {
    fn set_read_timeout(&self, timeout: Option<Duration>) -> std::io::Result<()> {
        std::os::unix::net::UnixStream::set_read_timeout(self, timeout)
    }
    fn set_nonblocking(&self, on: bool) -> std::io::Result<()> {
        std::os::unix::net::UnixStream::set_nonblocking(self, on)
    }
}

/// Reads a non-blocking `stream` until nothing is left, the peer closed
/// it (the next timed read says so) or 64 KiB went: a peer that never
/// stops talking cannot hold the host here.
fn drain(stream: &mut impl Read) -> std::io::Result<()> {
    let mut junk = [0u8; 512];
    for _ in 0..128 {
        match stream.read(&mut junk) {
            Ok(0) => return Ok(()),
            Ok(_) => {}
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return Ok(()),
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

impl<S: StreamSocket> Transport for Socket<S> {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.stream.write_all(bytes)
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<usize> {
        retry_interrupted(timeout, |left| {
            self.stream
                .set_read_timeout(Some(left.max(Duration::from_micros(100))))?;
            stream_read(self.stream.read(buf), self.closed)
        })
    }

    fn discard_input(&mut self) -> std::io::Result<()> {
        self.stream.set_nonblocking(true)?;
        let r = drain(&mut self.stream);
        self.stream.set_nonblocking(false)?;
        r
    }

    fn describe(&self) -> String {
        self.name.clone()
    }
}

/// A TCP connection (QEMU `-serial tcp::PORT,server`).
pub type Tcp = Socket<TcpStream>;

impl Tcp {
    /// Connect to `addr` (`host:port`).
    pub fn connect(addr: &str) -> anyhow::Result<Self> {
        check_tcp_addr(addr)?;
        let stream = TcpStream::connect(addr)
            .map_err(|e| anyhow::anyhow!("connecting to {addr}: {}", crate::files::reason(&e)))?;
        stream.set_nodelay(true).context("setting TCP_NODELAY")?;
        Ok(Self {
            stream,
            name: format!("tcp:{addr}"),
            closed: "the device closed the connection",
        })
    }
}

/// Checks the `HOST:PORT` of a `tcp:` port spec before connecting: a
/// missing or out-of-range port (1..=65535), an empty host or a malformed
/// IPv4 address is bad input, not a failed connection.
pub fn check_tcp_addr(addr: &str) -> Result<(), crate::InputError> {
    let bad = |why: &str| {
        crate::InputError::new(format!(
            "--port tcp:{addr}: {why}; expected tcp:HOST:PORT with PORT in 1..=65535"
        ))
    };
    let Some((host, port)) = addr.rsplit_once(':') else {
        return Err(bad("no port"));
    };
    if host.is_empty() {
        return Err(bad("no host"));
    }
    let bracketed = host.starts_with('[') && host.ends_with(']');
    if !bracketed && host.contains(':') {
        return Err(bad(&format!(
            "`{host}` has a colon: one HOST and one PORT (an IPv6 host goes in brackets, [::1])"
        )));
    }
    if let Some(c) = host
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_' | '[' | ']' | ':')))
    {
        return Err(bad(&format!("host `{host}` has the character {c:?}")));
    }
    match port.parse::<u16>() {
        Ok(p) if p > 0 => {}
        _ => return Err(bad(&format!("port `{port}` is not a number in 1..=65535"))),
    }
    if host.chars().all(|c| c.is_ascii_digit() || c == '.')
        && host.parse::<std::net::Ipv4Addr>().is_err()
    {
        return Err(bad(&format!("`{host}` is not an IPv4 address")));
    }
    if let Some(v6) = host.strip_prefix('[').and_then(|h| h.strip_suffix(']'))
        && v6.parse::<std::net::Ipv6Addr>().is_err()
    {
        return Err(bad(&format!("`{host}` is not an IPv6 address")));
    }
    Ok(())
}

/// A stream socket's read result as [`Transport::recv`] reports it: a
/// timeout is 0 bytes, end of stream is an error saying `closed`.
fn stream_read(read: std::io::Result<usize>, closed: &str) -> std::io::Result<usize> {
    match read {
        Ok(0) => Err(std::io::Error::new(
            std::io::ErrorKind::UnexpectedEof,
            closed.to_owned(),
        )),
        Ok(n) => Ok(n),
        Err(e) if is_timeout(&e) => Ok(0),
        Err(e) => Err(e),
    }
}

/// A Unix stream socket (the in-process simulated device's socket pair).
pub type Unix = Socket<std::os::unix::net::UnixStream>;

impl Unix {
    /// Wrap a connected, blocking socket.
    pub fn new(stream: std::os::unix::net::UnixStream) -> Self {
        Self {
            stream,
            name: "in-process simulated device (socket pair)".into(),
            closed: "the simulated device closed the socket",
        }
    }
}

/// Open a port spec: `tcp:HOST:PORT` for TCP, anything else is a serial
/// device path.
pub fn open(spec: &str, baud: u32) -> anyhow::Result<Box<dyn Transport>> {
    match spec.strip_prefix("tcp:") {
        Some(addr) => Ok(Box::new(Tcp::connect(addr)?)),
        None => Ok(Box::new(Serial::open(spec, baud)?)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_port_that_did_not_open_says_why_in_words() {
        use serialport::{Error, ErrorKind};
        let enotty = Error::new(ErrorKind::Unknown, "Not a typewriter");
        assert_eq!(
            serial_open_reason(&enotty),
            "not a serial port (it takes no serial line settings)"
        );
        let missing = Error::new(
            ErrorKind::Io(std::io::ErrorKind::NotFound),
            "No such file or directory",
        );
        assert_eq!(serial_open_reason(&missing), "no such file or directory");
        let other = Error::new(ErrorKind::NoDevice, "the adapter went away");
        assert_eq!(serial_open_reason(&other), "the adapter went away");
    }

    #[test]
    fn bad_tcp_addresses_are_input_errors() {
        for ok in ["127.0.0.1:4000", "localhost:1", "[::1]:65535"] {
            assert!(check_tcp_addr(ok).is_ok(), "{ok}");
        }
        for bad in [
            "127.0.0.1",
            "127.0.0.1:99999",
            "127.0.0.1:0",
            "127.0.0.1:x",
            "256.1.1.1:1",
            ":4000",
            "[zz]:1",
        ] {
            let e = check_tcp_addr(bad).unwrap_err().to_string();
            assert!(e.contains("1..=65535") && !e.contains('\n'), "{bad}: {e}");
        }
    }
}
