//! `lmhost session`'s run: a [`Session`] behind a control endpoint (a Unix
//! socket, optionally `127.0.0.1:PORT` with a token, or stdin/stdout), fed
//! by a finger source, its events to the subscribers and to a log file.
//!
//! One thread owns the session and the device and turns its
//! [`Driver`]; it waits for client lines only until the driver's next
//! deadline. Every connection has a reader thread (bounded lines) and a
//! writer thread behind a bounded queue (`super::conn`), and the event
//! log has a writer of its own (`super::eventlog`): the loop never
//! waits on a client or a disk.

use std::collections::HashMap;
use std::io::Write as _;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{RecvTimeoutError, SyncSender, sync_channel};
use std::time::{Duration, Instant};

use super::conn::{self, Conn, INBOUND_QUEUE, Inbound, STDIO};
use super::driver::Driver;
use super::endpoint::Token;
use super::eventlog::EventLog;
use super::protocol::{Command, Event, OffsetReason, Reply};
use super::{Owner, Session};
use crate::clock::Clock;
use crate::sense::stream::filter::Filter;

pub use super::conn::{CLIENT_QUEUE, MAX_CLIENTS};
pub use super::driver::Finger;
pub use super::endpoint::{
    Control, Endpoint, MAX_SOCKET_PATH_BYTES, TOKEN_CHARS, default_socket, token_path,
};

/// What the session does when the client controlling it goes away.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OnDisconnect {
    /// Stop what that client presented (the array goes silent); keep
    /// serving.
    Stop,
    /// Carry on.
    Continue,
    /// End the session.
    Quit,
}

/// How to serve.
pub struct Options {
    /// The control endpoint.
    pub control: Endpoint,
    /// When the controlling client goes away.
    pub on_disconnect: OnDisconnect,
    /// The event log, opened before the device is touched
    /// ([`EventLog::prepare`]: a bad path is refused then) and started
    /// once the session has.
    pub events: Option<EventLog>,
    /// The finger source.
    pub finger: Finger,
    /// The centroid filter.
    pub filter: Box<dyn Filter + Send>,
}

/// How a session ended.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// Commands handled.
    pub commands: u64,
    /// Events written.
    pub events: u64,
    /// Clients dropped because they did not take their lines.
    pub dropped_clients: u64,
    /// Why it ended.
    pub reason: Option<OffsetReason>,
    /// What the session measured.
    pub figures: super::Figures,
}

/// Longest wait for client lines between two turns.
const MAX_WAIT: Duration = Duration::from_millis(10);

/// How long a TCP client may take to send its token.
pub const AUTH_WITHIN: Duration = Duration::from_secs(5);

/// How long the end waits for the clients' writers to send the last lines.
const LINGER: Duration = Duration::from_millis(500);

/// How long a client that is dropped but reads (its input ended, or it
/// is refused) has to take the lines queued for it, off the loop.
const FLUSH_WITHIN: Duration = Duration::from_secs(2);

/// How a dropped client's connection closes.
#[derive(Clone, Copy)]
enum Close {
    /// After its writer sent what is queued (at most [`FLUSH_WITHIN`]).
    AfterWriting,
    /// Now: it does not read (its queue is full).
    AtOnce,
}

/// How long the end waits for standard output to take the last lines.
const STDOUT_LINGER: Duration = Duration::from_secs(5);

/// A connection's halves: reader, writer, and how to shut it down.
type Halves = (
    Box<dyn std::io::Read + Send>,
    Box<dyn std::io::Write + Send>,
    Box<dyn Fn() + Send>,
);

/// A stream's reader and writer (two clones of it) and what shuts it
/// down: alike for both kinds of connection.
fn halves<S: std::io::Read + std::io::Write + Send + 'static>(
    s: S,
    try_clone: fn(&S) -> std::io::Result<S>,
    shutdown: fn(&S, std::net::Shutdown) -> std::io::Result<()>,
) -> std::io::Result<Halves> {
    let (r, w) = (try_clone(&s)?, try_clone(&s)?);
    Ok((
        Box::new(r),
        Box::new(w),
        Box::new(move || {
            let _ = shutdown(&s, std::net::Shutdown::Both);
        }),
    ))
}

fn unix_halves(s: std::os::unix::net::UnixStream) -> std::io::Result<Halves> {
    use std::os::unix::net::UnixStream;
    halves(s, UnixStream::try_clone, UnixStream::shutdown)
}

fn tcp_halves(s: std::net::TcpStream) -> std::io::Result<Halves> {
    use std::net::TcpStream;
    s.set_nodelay(true)?;
    halves(s, TcpStream::try_clone, TcpStream::shutdown)
}

/// What the acceptors share.
#[derive(Clone)]
struct Accept {
    tx: SyncSender<Inbound>,
    live: Arc<AtomicUsize>,
    next_id: Arc<AtomicU64>,
    clock: Clock,
}

/// Accepts connections on a thread of its own; `authed`: whether its
/// clients may send commands at once (the Unix socket's mode already
/// keeps others out).
fn spawn_acceptor<S: Send + 'static>(
    name: &str,
    accept: impl Fn() -> std::io::Result<S> + Send + 'static,
    halves: fn(S) -> std::io::Result<Halves>,
    authed: bool,
    a: Accept,
) -> anyhow::Result<()> {
    std::thread::Builder::new()
        .name(name.into())
        .spawn(move || {
            loop {
                let s = match accept() {
                    Ok(s) => s,
                    // A signal landed on this thread: accept again.
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                    Err(_) => break,
                };
                let Ok((r, mut w, shutdown)) = halves(s) else {
                    continue;
                };
                if a.live.fetch_add(1, Ordering::SeqCst) >= MAX_CLIENTS {
                    a.live.fetch_sub(1, Ordering::SeqCst);
                    // Said on this thread: one short line to a new socket.
                    let _ = writeln!(w, "{}", conn::too_many());
                    shutdown();
                    continue;
                }
                let id = a.next_id.fetch_add(1, Ordering::SeqCst);
                let now = a.clock.now_us();
                let Ok(c) =
                    conn::socket_conn(id, w, shutdown, a.live.clone(), authed, now, a.tx.clone())
                else {
                    continue;
                };
                // Joined before any of its lines.
                if a.tx.send(Inbound::Joined(id, c)).is_err()
                    || conn::spawn_reader(id, r, a.tx.clone()).is_err()
                {
                    return;
                }
            }
        })?;
    Ok(())
}

/// Why the loop ended early: standard output failed.
enum Ended {
    Reason(OffsetReason),
    /// Standard output was closed by its reader: a quiet end.
    StdoutClosed,
}

/// The loop's state besides the driver.
struct Loop {
    conns: HashMap<Owner, Conn>,
    log: Option<EventLog>,
    token: Option<Token>,
    on_disconnect: OnDisconnect,
    /// The client that last sent `present`, `prepare` or `stop`.
    controller: Option<Owner>,
    stdin_done: bool,
    report: Report,
}

impl Loop {
    /// Queues `line` for client `id`; a client that cannot take it is
    /// dropped (standard output: the session ends).
    fn send_to(
        &mut self,
        d: &mut Driver,
        id: Owner,
        line: Arc<str>,
    ) -> anyhow::Result<Option<Ended>> {
        match self.conns.get(&id) {
            Some(c) if !c.send(line) => {
                self.report.dropped_clients += 1;
                self.drop_client(d, id, Close::AtOnce)
            }
            _ => Ok(None),
        }
    }

    fn reply(&mut self, d: &mut Driver, id: Owner, r: Reply) -> anyhow::Result<Option<Ended>> {
        let line: Arc<str> = Arc::from(serde_json::Value::from(r.0).to_string());
        self.send_to(d, id, line)
    }

    /// Events to the log and to every subscriber.
    fn events(&mut self, d: &mut Driver, events: Vec<Event>) -> anyhow::Result<Option<Ended>> {
        for e in events {
            let line: Arc<str> = Arc::from(serde_json::to_string(&e)?);
            self.report.events += 1;
            if let Some(log) = &mut self.log {
                log.line(line.clone())?;
            }
            let full: Vec<Owner> = self
                .conns
                .iter()
                .filter(|(_, c)| c.subscribed && !c.send(line.clone()))
                .map(|(id, _)| *id)
                .collect();
            for id in full {
                self.report.dropped_clients += 1;
                if let Some(end) = self.drop_client(d, id, Close::AtOnce)? {
                    return Ok(Some(end));
                }
            }
        }
        Ok(None)
    }

    /// Drops client `id` (it went away or does not read): what it
    /// presented stops, or the session ends, as `--on-disconnect` says.
    /// `close`: whether the replies queued for it go out first.
    fn drop_client(
        &mut self,
        d: &mut Driver,
        id: Owner,
        close: Close,
    ) -> anyhow::Result<Option<Ended>> {
        let Some(c) = self.conns.remove(&id) else {
            return Ok(None);
        };
        if id == STDIO {
            // Its writer failed (the reader closed it, a full disk): the
            // failure it sent ends the session as such, a closed pipe
            // quietly, whichever of the two the loop saw first.
            if c.writer_ended() {
                return Ok(None);
            }
            // Nothing reads the session's output any more.
            anyhow::bail!(
                "standard output fell {} lines behind (nothing reads it); the session ended",
                conn::CLIENT_QUEUE
            );
        }
        if !c.authed {
            // Its refusal is queued: the writer sends that one short line
            // before the socket closes (else the client sees only the
            // close), without the loop waiting for it.
            c.close_after_writing(FLUSH_WITHIN);
            return Ok(None);
        }
        match close {
            // Its input ended (a client that half-closed its socket after
            // its commands, as `nc -N` does): the replies to its last
            // lines are queued and still go out.
            Close::AfterWriting => c.close_after_writing(FLUSH_WITHIN),
            Close::AtOnce => drop(c),
        }
        match self.on_disconnect {
            OnDisconnect::Stop => {
                d.session().client_gone(id)?;
            }
            OnDisconnect::Quit if self.controller == Some(id) => {
                return Ok(Some(Ended::Reason(OffsetReason::Disconnect)));
            }
            _ => {}
        }
        Ok(None)
    }

    fn handle(&mut self, d: &mut Driver, msg: Inbound) -> anyhow::Result<Option<Ended>> {
        match msg {
            Inbound::Joined(id, c) => {
                self.conns.insert(id, c);
                Ok(None)
            }
            Inbound::Line(id, line) => self.line(d, id, &line),
            Inbound::Unreadable(id, msg) => {
                if !self.conns.get(&id).is_some_and(|c| c.authed) {
                    self.reply(d, id, Reply::error("", msg))?;
                    return self.drop_client(d, id, Close::AfterWriting);
                }
                d.session().refused("", &msg);
                self.reply(d, id, Reply::error("", msg))
            }
            Inbound::Gone(id) if id == STDIO => {
                self.stdin_done = true;
                Ok(None)
            }
            Inbound::Gone(id) => self.drop_client(d, id, Close::AfterWriting),
            Inbound::StdoutFailed(None) => Ok(Some(Ended::StdoutClosed)),
            Inbound::StdoutFailed(Some(e)) => Err(e),
        }
    }

    /// One line from client `id`.
    fn line(&mut self, d: &mut Driver, id: Owner, line: &str) -> anyhow::Result<Option<Ended>> {
        let Some(c) = self.conns.get_mut(&id) else {
            return Ok(None);
        };
        if !c.authed {
            // A TCP client: its token first, nothing else.
            let ok = matches!(Command::parse(line), Ok(Command::Auth { token })
                if self.token.as_ref().is_some_and(|t| t.matches(&token)));
            if ok {
                c.authed = true;
                return self.reply(d, id, Reply::ok("auth"));
            }
            self.reply(d, id, Reply::error("auth", self.auth_needed("")))?;
            return self.drop_client(d, id, Close::AfterWriting);
        }
        self.report.commands += 1;
        let cmd = match Command::parse(line) {
            Ok(cmd) => cmd,
            Err(e) => {
                let name = Command::named_in(line);
                d.session().refused(name, &e.to_string());
                return self.reply(d, id, Reply::error(name, e.to_string()));
            }
        };
        match &cmd {
            Command::Subscribe => c.subscribed = true,
            Command::Present(_) | Command::Prepare { .. } | Command::Stop => {
                self.controller = Some(id);
            }
            _ => {}
        }
        let reply = d.session().handle(&cmd, id);
        let end = self.reply(d, id, reply)?;
        if cmd == Command::Quit {
            return Ok(Some(Ended::Reason(OffsetReason::Quit)));
        }
        Ok(end)
    }

    /// The refusal a TCP client gets before it is closed, unauthenticated
    /// (`late`: why, when it sent nothing in time).
    fn auth_needed(&self, late: &str) -> String {
        let file = self.token.as_ref().map(|t| t.path.display().to_string());
        format!(
            "authentication needed{late}: the first line on TCP is {{\"cmd\":\"auth\",\"token\":TOKEN}} with the token in {}; closing",
            file.unwrap_or_default()
        )
    }

    /// Drops TCP clients that did not send their token in time, each with
    /// its one reply (PROTOCOL.md), not a bare close.
    fn expire(&mut self, d: &mut Driver, now_us: u64) -> anyhow::Result<()> {
        let late: Vec<Owner> = self
            .conns
            .iter()
            .filter(|(_, c)| !c.authed && now_us >= c.since_us + AUTH_WITHIN.as_micros() as u64)
            .map(|(id, _)| *id)
            .collect();
        for id in late {
            let late = format!(" (no line within {} s)", AUTH_WITHIN.as_secs());
            self.reply(d, id, Reply::error("auth", self.auth_needed(&late)))?;
            self.drop_client(d, id, Close::AfterWriting)?;
        }
        Ok(())
    }
}

/// Serves `session` until `quit`, a stop signal, the end of stdin (stdio
/// control), the controlling client going away (`--on-disconnect quit`)
/// or an error; the array is silent when it returns.
pub fn serve(session: Session, opts: Options) -> anyhow::Result<Report> {
    crate::stop::graceful();
    let Options {
        mut control,
        on_disconnect,
        events,
        finger,
        filter,
    } = opts;
    let log = events;
    let clock = session.clock().clone();
    let (tx, rx) = sync_channel::<Inbound>(INBOUND_QUEUE);
    // The TCP listener goes to its acceptor; the token to the loop (its
    // file goes when the loop ends).
    let (tcp, token) = match control.tcp.take() {
        Some((l, t)) => (Some(l), Some(t)),
        None => (None, None),
    };
    let mut lp = Loop {
        conns: HashMap::new(),
        log,
        token,
        on_disconnect,
        controller: None,
        stdin_done: false,
        report: Report::default(),
    };
    let accept = Accept {
        tx: tx.clone(),
        live: Arc::new(AtomicUsize::new(0)),
        next_id: Arc::new(AtomicU64::new(STDIO + 1)),
        clock: clock.clone(),
    };
    if control.stdio {
        lp.conns.insert(STDIO, conn::stdout_conn(tx.clone())?);
        conn::spawn_reader(STDIO, std::io::stdin(), tx.clone())?;
    }
    if let Some(l) = control.unix.take() {
        spawn_acceptor(
            "lmhost-unix",
            move || l.accept().map(|(s, _)| s),
            unix_halves,
            true,
            accept.clone(),
        )?;
    }
    if let Some(l) = tcp {
        spawn_acceptor(
            "lmhost-tcp",
            move || l.accept().map(|(s, _)| s),
            tcp_halves,
            false,
            accept.clone(),
        )?;
    }
    drop((tx, accept));
    let mut d = Driver::new(session, finger, filter);
    let result = (|| -> anyhow::Result<Ended> {
        loop {
            if crate::stop::requested() {
                return Ok(Ended::Reason(OffsetReason::stopped()));
            }
            let ev = d.turn()?;
            if let Some(end) = lp.events(&mut d, ev)? {
                return Ok(end);
            }
            lp.expire(&mut d, clock.now_us())?;
            if lp.stdin_done
                && (!d.session_ref().presenting() || d.session_ref().presenting_endless())
            {
                return Ok(Ended::Reason(OffsetReason::EndOfInput));
            }
            let mut msg = match rx.recv_timeout(d.wait_time(MAX_WAIT)) {
                Ok(m) => Some(m),
                Err(RecvTimeoutError::Timeout) => None,
                Err(RecvTimeoutError::Disconnected) => {
                    // No endpoint left (stdin ended): only the timelines.
                    lp.stdin_done = true;
                    d.wait(MAX_WAIT);
                    None
                }
            };
            // Lines until the next turn is due (one at least): a client
            // that floods commands gets the time between the session's
            // deadlines, never the deadlines themselves.
            let due = d.next_wake();
            while let Some(m) = msg.take() {
                if let Some(end) = lp.handle(&mut d, m)? {
                    return Ok(end);
                }
                if clock.now_us() < due {
                    msg = rx.try_recv().ok();
                }
            }
        }
    })();
    let reason = match &result {
        Ok(Ended::Reason(r)) => *r,
        Ok(Ended::StdoutClosed) => OffsetReason::Disconnect,
        Err(_) => OffsetReason::Error,
    };
    lp.report.figures = d.session_ref().figures();
    let last = d.close(reason);
    // The last events go out however the loop ended.
    let written = lp.last_events(last);
    let logged = lp.log.as_mut().map_or(Ok(()), EventLog::finish);
    let until = Instant::now() + LINGER;
    let stdout_until = Instant::now() + STDOUT_LINGER;
    for (id, c) in lp.conns.drain() {
        c.finish(if id == STDIO { stdout_until } else { until });
    }
    drop(control);
    drop(lp.token.take());
    lp.report.reason = Some(reason);
    match result? {
        Ended::StdoutClosed => return Err(crate::out::StdoutClosed.into()),
        Ended::Reason(_) => {}
    }
    written?;
    logged?;
    Ok(lp.report)
}

impl Loop {
    /// The session's last events (after it closed): a client that cannot
    /// take them is left out.
    fn last_events(&mut self, events: Vec<Event>) -> anyhow::Result<()> {
        for e in events {
            let line: Arc<str> = Arc::from(serde_json::to_string(&e)?);
            self.report.events += 1;
            if let Some(log) = &mut self.log {
                log.line(line.clone())?;
            }
            for c in self.conns.values().filter(|c| c.subscribed) {
                c.send(line.clone());
            }
        }
        Ok(())
    }
}
