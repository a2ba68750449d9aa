//! The byte side of the serial instruments: a [`Port`] (a real serial
//! port through `serialport`, or any in-memory peer a test supplies) and
//! [`LineIo`], the one request/response line exchange the drivers share.
//!
//! These are plain ASCII protocols, one request line and (mostly) one
//! reply line each, not the LM link's framed protocol. A reply ends at CR,
//! LF or CR LF (the instruments differ and the manuals are not all
//! explicit), is at most [`MAX_REPLY_BYTES`] long (so a babbling port
//! cannot grow a buffer), and must arrive within the reply timeout, which
//! is measured on a [`Clock`]: the real one for hardware, a manual one in
//! tests, where each empty read moves time on by [`READ_SLICE`].

use std::io::{ErrorKind, Read, Write};
use std::time::Duration;

use super::error::{InstrumentError, quote};
use crate::clock::Clock;

/// Longest reply line accepted, bytes (the longest real one is ~20).
pub const MAX_REPLY_BYTES: usize = 128;
/// How long one read waits for bytes before the reply deadline is checked.
pub const READ_SLICE: Duration = Duration::from_millis(20);

/// A byte pipe to an instrument: reads block for at most a short time
/// and then fail with `TimedOut` or `WouldBlock` (or return 0).
pub trait Port: Read + Write + Send {
    /// Drop whatever the instrument sent that nobody asked for (a late
    /// reply to a request that already timed out), so the next reply is
    /// the answer to the next request.
    fn discard_input(&mut self) -> std::io::Result<()>;
}

impl Port for Box<dyn serialport::SerialPort> {
    fn discard_input(&mut self) -> std::io::Result<()> {
        self.clear(serialport::ClearBuffer::Input)
            .map_err(std::io::Error::other)
    }
}

/// Open a serial instrument at `baud`, 8 data bits, no parity, one stop
/// bit, no flow control: the factory setting of all three kinds (see each
/// driver's docs).
pub fn open_serial(
    path: &str,
    baud: u32,
) -> Result<Box<dyn serialport::SerialPort>, InstrumentError> {
    serialport::new(path, baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(READ_SLICE)
        .open()
        .map_err(|e| {
            let words = crate::device::link::transport::serial_open_reason(&e);
            let error = match e.kind {
                serialport::ErrorKind::Io(kind) => std::io::Error::new(kind, words),
                _ => std::io::Error::other(words),
            };
            InstrumentError::Io {
                port: path.to_owned(),
                error,
            }
        })
}

/// One request line out, one reply line back, with a deadline.
pub struct LineIo<P> {
    port: P,
    name: String,
    clock: Clock,
    reply_timeout: Duration,
    pending: Vec<u8>,
    /// The last line ended in CR at the end of what was read: a LF that
    /// starts the next read belongs to it.
    skip_lf: bool,
}

impl<P: Port> LineIo<P> {
    /// Lines over `port`, called `name` in messages.
    pub fn new(port: P, name: &str, clock: Clock, reply_timeout: Duration) -> Self {
        Self {
            port,
            name: name.to_owned(),
            clock,
            reply_timeout,
            pending: Vec::new(),
            skip_lf: false,
        }
    }

    /// The port's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The clock replies are timed on.
    pub fn clock(&self) -> &Clock {
        &self.clock
    }

    /// The time one reply may take.
    pub fn reply_timeout(&self) -> Duration {
        self.reply_timeout
    }

    fn io(&self, error: std::io::Error) -> InstrumentError {
        InstrumentError::Io {
            port: self.name.clone(),
            error,
        }
    }

    /// Send `request` followed by `terminator`, after dropping any stale
    /// input.
    pub fn send(&mut self, request: &str, terminator: &str) -> Result<(), InstrumentError> {
        self.pending.clear();
        self.skip_lf = false;
        self.port.discard_input().map_err(|e| self.io(e))?;
        let mut bytes = Vec::with_capacity(request.len() + terminator.len());
        bytes.extend_from_slice(request.as_bytes());
        bytes.extend_from_slice(terminator.as_bytes());
        self.port.write_all(&bytes).map_err(|e| self.io(e))?;
        self.port.flush().map_err(|e| self.io(e))
    }

    /// The next reply line (without its terminator), as text. `what`
    /// names the request in a timeout message.
    pub fn read_line(&mut self, what: &str) -> Result<String, InstrumentError> {
        let start = self.clock.now();
        let mut chunk = [0u8; 64];
        loop {
            if let Some(line) = self.take_line()? {
                return String::from_utf8(line.clone()).map_err(|_| {
                    InstrumentError::protocol(
                        &self.name,
                        format!("reply to {what} is not ASCII: {}", quote(&line)),
                    )
                });
            }
            if self.clock.now().saturating_sub(start) >= self.reply_timeout {
                let got = if self.pending.is_empty() {
                    String::from("nothing")
                } else {
                    format!("only {}", quote(&self.pending))
                };
                return Err(InstrumentError::timeout(
                    &self.name,
                    format!(
                        "no reply to {what} within {} ms (got {got}); is the instrument on, connected and set to this baud rate?",
                        self.reply_timeout.as_millis()
                    ),
                ));
            }
            match self.port.read(&mut chunk) {
                Ok(0) => self.clock.advance(READ_SLICE),
                Ok(n) => self.pending.extend_from_slice(&chunk[..n]),
                Err(e) if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::WouldBlock) => {
                    // The real clock has moved on by the read's own wait;
                    // a manual clock is moved here (the real one ignores it).
                    self.clock.advance(READ_SLICE)
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(self.io(e)),
            }
        }
    }

    /// Send `request` and read its reply line.
    pub fn ask(&mut self, request: &str, terminator: &str) -> Result<String, InstrumentError> {
        self.send(request, terminator)?;
        self.read_line(request)
    }

    /// Split one line off `pending`, if a terminator has arrived.
    fn take_line(&mut self) -> Result<Option<Vec<u8>>, InstrumentError> {
        if self.skip_lf && !self.pending.is_empty() {
            if self.pending[0] == b'\n' {
                self.pending.remove(0);
            }
            self.skip_lf = false;
        }
        let Some(end) = self.pending.iter().position(|&b| b == b'\r' || b == b'\n') else {
            if self.pending.len() > MAX_REPLY_BYTES {
                let head = quote(&self.pending);
                self.pending.clear();
                return Err(InstrumentError::protocol(
                    &self.name,
                    format!("reply longer than {MAX_REPLY_BYTES} bytes without a line end: {head}"),
                ));
            }
            return Ok(None);
        };
        if end > MAX_REPLY_BYTES {
            let head = quote(&self.pending[..end]);
            self.pending.clear();
            return Err(InstrumentError::protocol(
                &self.name,
                format!("reply longer than {MAX_REPLY_BYTES} bytes: {head}"),
            ));
        }
        let line = self.pending[..end].to_vec();
        let mut rest = end + 1;
        if self.pending[end] == b'\r' {
            match self.pending.get(rest) {
                Some(b'\n') => rest += 1,
                Some(_) => {}
                None => self.skip_lf = true,
            }
        }
        self.pending.drain(..rest);
        Ok(Some(line))
    }
}

#[cfg(test)]
pub(crate) mod fake {
    //! An in-memory [`Port`] whose far end is a protocol engine: each
    //! request line written is answered at once (or not at all), so the
    //! drivers' parsing, timeouts and error paths run without hardware.

    use std::collections::VecDeque;
    use std::io::{Read, Write};
    use std::sync::{Arc, Mutex};

    use super::Port;

    /// The instrument's side of a fake port.
    pub trait Engine: Send {
        /// The bytes sent back for one request line (without its
        /// terminator); empty for silence.
        fn answer(&mut self, request: &str) -> Vec<u8>;
    }

    /// A [`Port`] over an [`Engine`]; the engine is shared so a test can
    /// change it (inject a fault) while a driver holds the port.
    pub struct FakePort<E> {
        pub engine: Arc<Mutex<E>>,
        incoming: Vec<u8>,
        outgoing: VecDeque<u8>,
        /// Every request line seen, for assertions on what was sent.
        pub log: Arc<Mutex<Vec<String>>>,
    }

    impl<E: Engine> FakePort<E> {
        pub fn new(engine: E) -> Self {
            Self {
                engine: Arc::new(Mutex::new(engine)),
                incoming: Vec::new(),
                outgoing: VecDeque::new(),
                log: Arc::default(),
            }
        }
    }

    impl<E: Engine> Write for FakePort<E> {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.incoming.extend_from_slice(buf);
            while let Some(end) = self.incoming.iter().position(|&b| b == b'\r' || b == b'\n') {
                let line: Vec<u8> = self.incoming.drain(..=end).collect();
                let text = String::from_utf8_lossy(&line[..end]).into_owned();
                if text.is_empty() {
                    continue; // the LF of a CR LF
                }
                self.log.lock().unwrap().push(text.clone());
                let reply = self.engine.lock().unwrap().answer(&text);
                self.outgoing.extend(reply);
            }
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl<E: Engine> Read for FakePort<E> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            if self.outgoing.is_empty() {
                return Err(std::io::ErrorKind::TimedOut.into());
            }
            let n = buf.len().min(self.outgoing.len());
            for (i, b) in self.outgoing.drain(..n).enumerate() {
                buf[i] = b;
            }
            Ok(n)
        }
    }

    impl<E: Engine> Port for FakePort<E> {
        fn discard_input(&mut self) -> std::io::Result<()> {
            // Replies are produced by writes, so nothing stale can wait
            // here except what a test queued on purpose.
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::fake::{Engine, FakePort};
    use super::*;

    struct Echo(Vec<u8>);
    impl Engine for Echo {
        fn answer(&mut self, _: &str) -> Vec<u8> {
            self.0.clone()
        }
    }

    fn io(reply: &[u8]) -> LineIo<FakePort<Echo>> {
        let port = FakePort::new(Echo(reply.to_vec()));
        LineIo::new(port, "fake", Clock::manual(), Duration::from_millis(500))
    }

    #[test]
    fn lines_end_at_cr_lf_or_crlf() {
        for reply in [&b"abc\r"[..], b"abc\n", b"abc\r\n"] {
            let mut l = io(reply);
            assert_eq!(l.ask("Q", "\r").unwrap(), "abc");
            // A second request sees its own reply, not a stray LF.
            assert_eq!(l.ask("Q", "\r").unwrap(), "abc");
        }
        let mut l = io(b"\r\n");
        assert_eq!(l.ask("X", "\r\n").unwrap(), "", "an empty line is a reply");
    }

    #[test]
    fn silence_times_out_on_the_clock() {
        let mut l = io(b"");
        let t0 = l.clock().now();
        let err = l.ask("D", "\r").unwrap_err();
        assert!(matches!(err, InstrumentError::Timeout { .. }), "{err}");
        let msg = err.to_string();
        assert!(
            msg.starts_with("fake: no reply to D within 500 ms (got nothing)"),
            "{msg}"
        );
        assert_eq!(l.clock().now() - t0, Duration::from_millis(500));
    }

    #[test]
    fn a_half_reply_times_out_and_says_what_came() {
        let mut l = io(b"+12.3");
        let msg = l.ask("D", "\r").unwrap_err().to_string();
        assert!(msg.contains("got only '+12.3'"), "{msg}");
    }

    #[test]
    fn endless_or_binary_replies_are_refused() {
        let mut l = io(&[b'7'; 500]);
        let err = l.ask("D", "\r").unwrap_err();
        assert!(matches!(err, InstrumentError::Protocol { .. }), "{err}");
        let mut l = io(b"\xff\xfe\r");
        let msg = l.ask("D", "\r").unwrap_err().to_string();
        assert!(msg.contains("not ASCII: '\\xff\\xfe'"), "{msg}");
    }
}
