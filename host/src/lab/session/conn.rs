//! Control connections, off the session's loop: each has a reader thread
//! that hands whole lines of at most [`MAX_COMMAND_BYTES`] to the loop
//! (the rest of a longer line is skipped in fixed-size chunks, never
//! buffered) and a writer thread fed through a bounded queue. The loop
//! only ever queues a line without waiting: a client whose queue is full
//! is dropped, so no client can hold the loop, the finger feed or the
//! device's tick up.

use std::io::{BufReader, Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};

use super::protocol::{MAX_COMMAND_BYTES, Reply};

/// Lines queued for one client before it counts as not reading: it is
/// dropped then (a second of events at their busiest).
pub const CLIENT_QUEUE: usize = 1024;

/// Lines from the clients waiting for the loop: a client that sends
/// faster than the loop takes them waits (its socket's flow control).
pub const INBOUND_QUEUE: usize = 256;

/// Most control connections at once.
pub const MAX_CLIENTS: usize = 16;

/// The stdio client's id (commands on stdin, replies on stdout).
pub const STDIO: u64 = 0;

/// What the connections' threads tell the loop.
pub enum Inbound {
    /// A connection opened (sent before any of its lines).
    Joined(u64, Conn),
    /// A whole line (without its newline).
    Line(u64, String),
    /// A line that is no command whatever it says (longer than
    /// [`MAX_COMMAND_BYTES`], skipped; not UTF-8): the refusal.
    Unreadable(u64, String),
    /// The client went away (its input ended or a write to it failed).
    Gone(u64),
    /// Writing standard output failed: `None` when its reader closed it.
    StdoutFailed(Option<anyhow::Error>),
}

/// The loop's handle on one connection.
pub struct Conn {
    queue: Option<SyncSender<Arc<str>>>,
    /// Yields once the writer has ended.
    done: Option<Receiver<()>>,
    shutdown: Option<Box<dyn Fn() + Send>>,
    live: Option<Arc<AtomicUsize>>,
    /// Whether it receives events.
    pub subscribed: bool,
    /// Whether it may send commands (a TCP client after `auth`).
    pub authed: bool,
    /// When it connected (session clock, µs).
    pub since_us: u64,
}

impl Conn {
    /// Queues `line` for the client without waiting; false when its queue
    /// is full or its writer has ended (the caller drops it).
    pub fn send(&self, line: Arc<str>) -> bool {
        self.queue.as_ref().is_some_and(|q| {
            !matches!(
                q.try_send(line),
                Err(TrySendError::Full(_) | TrySendError::Disconnected(_))
            )
        })
    }

    /// Whether its writer has ended (a write failed; for standard output
    /// its [`Inbound::StdoutFailed`] is then already sent).
    pub fn writer_ended(&self) -> bool {
        use std::sync::mpsc::TryRecvError;
        self.done
            .as_ref()
            .is_some_and(|d| !matches!(d.try_recv(), Err(TryRecvError::Empty)))
    }

    /// Lets the writer write what is queued, waiting for it until
    /// `until` at most, then closes the connection (the session's end).
    pub fn finish(mut self, until: std::time::Instant) {
        self.queue = None;
        if let Some(d) = &self.done {
            let _ = d.recv_timeout(until.saturating_duration_since(std::time::Instant::now()));
        }
    }

    /// Lets the writer write what is queued, then closes the connection:
    /// off the loop, on a short-lived thread that waits for the writer at
    /// most `within` (the loop never waits on a client; the connection
    /// keeps its place among [`MAX_CLIENTS`] until it is closed, which
    /// bounds these threads).
    pub fn close_after_writing(mut self, within: std::time::Duration) {
        self.queue = None;
        let (done, shutdown, live) = (self.done.take(), self.shutdown.take(), self.live.take());
        let close = move || {
            if let Some(d) = done {
                let _ = d.recv_timeout(within);
            }
            if let Some(s) = shutdown {
                s();
            }
            if let Some(l) = live {
                l.fetch_sub(1, Ordering::SeqCst);
            }
        };
        if let Err(e) = std::thread::Builder::new()
            .name("lmhost-client-close".into())
            .spawn(close)
        {
            // No thread to spare: close now (the refusal may be lost).
            crate::errln!("lmhost: closing a client at once: {e}");
        }
    }
}

impl Drop for Conn {
    /// Closes the socket (which ends its reader and a writer blocked on
    /// it) and frees its place among [`MAX_CLIENTS`].
    fn drop(&mut self) {
        if let Some(s) = &self.shutdown {
            s();
        }
        if let Some(l) = &self.live {
            l.fetch_sub(1, Ordering::SeqCst);
        }
    }
}

/// Reads lines from `r`, calling `deliver` with each whole line (split
/// by [`crate::files::lines::LineReader`]: LF, CRLF or a lone CR ends
/// one; the first line's byte-order mark skipped; blank ones skipped) or
/// the refusal of one longer than [`MAX_COMMAND_BYTES`] (its rest read
/// past), not UTF-8 or not text ([`crate::files::text::stream_line`]:
/// UTF-16, a NUL byte, a later byte-order mark); memory stays bounded by
/// that whatever the input. Stops at the end of input, a read error, or
/// when `deliver` says so.
pub fn read_lines(r: impl Read, mut deliver: impl FnMut(Result<String, String>) -> bool) {
    use crate::files::lines::{Line, LineReader};
    let mut lines = LineReader::new(BufReader::with_capacity(8192, r), MAX_COMMAND_BYTES);
    loop {
        let line_no = lines.line_no() + 1;
        let text = match lines.next_line() {
            Ok(None) | Err(_) => return,
            Ok(Some(Line::TooLong)) => {
                if !deliver(Err(format!(
                    "bad command: longer than {MAX_COMMAND_BYTES} bytes"
                ))) || lines.skip_rest().is_err()
                {
                    return;
                }
                continue;
            }
            // Not read lossily: a replaced byte would make another command.
            Ok(Some(Line::Text(line))) => {
                let wide = line_no == 1 && crate::files::text::wide_encoding(line).is_some();
                match crate::files::text::stream_line(line, line_no) {
                    Ok(t) => Ok(t.trim().to_owned()),
                    Err(_) if let (false, Err(e)) = (wide, std::str::from_utf8(line)) => {
                        Err(format!(
                            "bad command: the line is not UTF-8 (byte {} of {})",
                            e.valid_up_to() + 1,
                            line.len()
                        ))
                    }
                    Err(e) => Err(format!("bad command: {e}")),
                }
            }
        };
        if text.as_ref().is_ok_and(String::is_empty) {
            continue;
        }
        if !deliver(text) {
            return;
        }
    }
}

/// Starts `id`'s reader on a thread of its own.
pub fn spawn_reader(
    id: u64,
    r: impl Read + Send + 'static,
    tx: SyncSender<Inbound>,
) -> std::io::Result<()> {
    std::thread::Builder::new()
        .name("lmhost-client".into())
        .spawn(move || {
            read_lines(r, |l| {
                tx.send(match l {
                    Ok(l) => Inbound::Line(id, l),
                    Err(why) => Inbound::Unreadable(id, why),
                })
                .is_ok()
            });
            let _ = tx.send(Inbound::Gone(id));
        })?;
    Ok(())
}

/// Writes the lines of `rx` to `w`, flushing whenever the queue is empty;
/// returns the first error.
fn write_lines(rx: &Receiver<Arc<str>>, mut w: impl Write) -> std::io::Result<()> {
    while let Ok(line) = rx.recv() {
        writeln!(w, "{line}")?;
        while let Ok(more) = rx.try_recv() {
            writeln!(w, "{more}")?;
        }
        w.flush()?;
    }
    Ok(())
}

/// A connection over a socket: its writer thread and its loop handle.
pub fn socket_conn(
    id: u64,
    w: impl Write + Send + 'static,
    shutdown: Box<dyn Fn() + Send>,
    live: Arc<AtomicUsize>,
    authed: bool,
    now_us: u64,
    notify: SyncSender<Inbound>,
) -> std::io::Result<Conn> {
    let (queue, rx) = sync_channel(CLIENT_QUEUE);
    let (done_tx, done) = sync_channel(1);
    std::thread::Builder::new()
        .name("lmhost-client-out".into())
        .spawn(move || {
            if write_lines(&rx, std::io::BufWriter::new(w)).is_err() {
                let _ = notify.send(Inbound::Gone(id));
            }
            let _ = done_tx.send(());
        })?;
    Ok(Conn {
        queue: Some(queue),
        done: Some(done),
        shutdown: Some(shutdown),
        live: Some(live),
        subscribed: false,
        authed,
        since_us: now_us,
    })
}

/// The stdio client: replies and events to standard output through
/// [`crate::out`], from a thread of its own.
pub fn stdout_conn(notify: SyncSender<Inbound>) -> std::io::Result<Conn> {
    let (queue, rx) = sync_channel::<Arc<str>>(CLIENT_QUEUE);
    let (done_tx, done) = sync_channel(1);
    std::thread::Builder::new()
        .name("lmhost-stdout".into())
        .spawn(move || {
            let r = (|| -> anyhow::Result<()> {
                while let Ok(line) = rx.recv() {
                    crate::outln!("{line}")?;
                    while let Ok(more) = rx.try_recv() {
                        crate::outln!("{more}")?;
                    }
                    crate::out::flush_stdout()?;
                }
                Ok(())
            })();
            if let Err(e) = r {
                let closed = e.is::<crate::out::StdoutClosed>();
                let _ = notify.send(Inbound::StdoutFailed((!closed).then_some(e)));
            }
            let _ = done_tx.send(());
        })?;
    Ok(Conn {
        queue: Some(queue),
        done: Some(done),
        shutdown: None,
        live: None,
        subscribed: true,
        authed: true,
        since_us: 0,
    })
}

/// One line refusing a client over [`MAX_CLIENTS`].
pub fn too_many() -> String {
    serde_json::Value::from(Reply::error("", format!("too many clients (at most {MAX_CLIENTS})")).0)
        .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(input: &[u8]) -> Vec<Option<String>> {
        let mut out = Vec::new();
        read_lines(input, |l| {
            out.push(l.ok());
            true
        });
        out
    }

    #[test]
    fn lines_are_whole_and_bounded_and_long_ones_are_skipped() {
        let long = vec![b'x'; 3 * MAX_COMMAND_BYTES + 17];
        let mut input = b"a\r\n\n  \nb\n".to_vec();
        input.extend(&long);
        input.extend(b"\nc\n");
        input.extend(vec![b'y'; MAX_COMMAND_BYTES]);
        input.extend(b"\nlast");
        let got = lines(&input);
        assert_eq!(
            got,
            [
                Some("a".into()),
                Some("b".into()),
                None,
                Some("c".into()),
                Some("y".repeat(MAX_COMMAND_BYTES)),
                Some("last".into()),
            ]
        );
    }

    #[test]
    fn a_lone_cr_ends_a_command_line_as_lf_and_crlf_do() {
        let got = lines(b"{\"cmd\":\"status\"}\r{\"cmd\":\"stop\"}\r\nx\ry\n\rz");
        assert_eq!(
            got,
            ["{\"cmd\":\"status\"}", "{\"cmd\":\"stop\"}", "x", "y", "z"].map(|s| Some(s.into()))
        );
        // An over-long line ended by a CR is refused at its limit, and the
        // next line read.
        let mut input = vec![b'x'; MAX_COMMAND_BYTES + 1];
        input.extend(b"\rok\r");
        assert_eq!(lines(&input), [None, Some("ok".into())]);
    }

    #[test]
    fn a_line_not_utf8_is_refused_not_read_lossily() {
        let mut got = Vec::new();
        read_lines(&b"{\"cmd\":\"st\xffop\"}\nok\n"[..], |l| {
            got.push(l);
            true
        });
        assert_eq!(
            got,
            [
                Err("bad command: the line is not UTF-8 (byte 11 of 15)".into()),
                Ok("ok".into())
            ]
        );
    }

    /// A reader that yields `n` bytes without a newline, in 8 KiB reads.
    struct Endless(u64);

    impl Read for Endless {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let n = (buf.len() as u64).min(self.0) as usize;
            buf[..n].fill(b'z');
            self.0 -= n as u64;
            Ok(n)
        }
    }

    #[test]
    fn a_line_without_end_is_refused_once_and_read_past_in_chunks() {
        // 64 MiB without a newline: refused once, nothing buffered beyond
        // the bound (the line buffer never grows past its capacity).
        let mut seen = Vec::new();
        read_lines(Endless(64 << 20), |l| {
            seen.push(l.map(|s| s.len()).ok());
            true
        });
        assert_eq!(seen, [None]);
    }

    #[test]
    fn a_full_client_queue_says_so_without_waiting() {
        let (queue, _rx) = sync_channel(2);
        let c = Conn {
            queue: Some(queue),
            done: None,
            shutdown: None,
            live: None,
            subscribed: true,
            authed: true,
            since_us: 0,
        };
        let line: Arc<str> = Arc::from("x");
        assert!(c.send(line.clone()) && c.send(line.clone()));
        let t = std::time::Instant::now();
        assert!(!c.send(line), "full");
        assert!(t.elapsed() < std::time::Duration::from_millis(50));
    }
}
