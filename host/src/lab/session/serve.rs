//! `lmhost session`'s run: a [`Session`] behind a control socket (a Unix
//! socket, optionally `127.0.0.1:PORT`, or stdin/stdout), fed by a finger
//! source, its events to the subscribers and to a log file.
//!
//! One thread owns the session and the device; each connection has a
//! reader thread that hands whole lines over a channel. Lines are bounded
//! ([`MAX_COMMAND_BYTES`]); a client that cannot take its output within
//! [`WRITE_TIMEOUT`] is dropped, never waited for.

use std::collections::HashMap;
use std::io::{BufRead as _, BufReader, Read, Write};
use std::os::unix::fs::PermissionsExt as _;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::Session;
use super::protocol::{Command, Event, EventKind, MAX_COMMAND_BYTES, OffsetReason, Reply};
use crate::error::InputError;
use crate::files::AppendLog;
use crate::sense::reader::Next;
use crate::sense::stream::Sample;
use crate::sense::stream::filter::Filter;
use crate::sense::stream::run::{Feed as _, Threaded};
use crate::sense::stream::synthetic::FingerTrack;

/// A client that cannot take a line within this is dropped.
pub const WRITE_TIMEOUT: Duration = Duration::from_millis(500);

/// Most control connections at once.
pub const MAX_CLIENTS: usize = 16;

/// How long the loop waits for a command before running the timelines.
const IDLE: Duration = Duration::from_millis(1);

/// Where commands come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Control {
    /// Commands on stdin, replies and events on stdout (end of input: the
    /// running timed presentation finishes, then the session ends).
    Stdio,
    /// A Unix socket at `unix` (mode 0600), and `127.0.0.1:tcp` if given.
    Socket {
        /// The socket's path.
        unix: PathBuf,
        /// A local TCP port as well.
        tcp: Option<u16>,
    },
}

/// What the session does when the client controlling it goes away.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OnDisconnect {
    /// Stop the presentation (the array goes silent); keep serving.
    Stop,
    /// Carry on.
    Continue,
    /// End the session.
    Quit,
}

/// Where the finger comes from.
pub enum Finger {
    /// No finger source (untracked presentations only sound).
    None,
    /// A synthetic finger resting at the scene's centre (with noise).
    Synthetic,
    /// Samples from a reader thread (a file, stdin, UDP).
    Samples(Threaded),
}

/// A control endpoint, bound before the device opens (so a bad
/// `--control` costs no device time); the Unix socket is removed when it
/// is dropped.
pub struct Endpoint {
    unix: Option<(std::os::unix::net::UnixListener, UnixSocket)>,
    tcp: Option<std::net::TcpListener>,
    stdio: bool,
}

impl Endpoint {
    /// Binds `control`.
    pub fn bind(control: &Control) -> anyhow::Result<Self> {
        match control {
            Control::Stdio => Ok(Self {
                unix: None,
                tcp: None,
                stdio: true,
            }),
            Control::Socket { unix, tcp } => {
                let unix = bind_unix(unix)?;
                let tcp = tcp
                    .map(|port| {
                        std::net::TcpListener::bind(("127.0.0.1", port)).map_err(|e| {
                            anyhow::anyhow!("--tcp 127.0.0.1:{port}: {}", crate::files::reason(&e))
                        })
                    })
                    .transpose()?;
                Ok(Self {
                    unix: Some(unix),
                    tcp,
                    stdio: false,
                })
            }
        }
    }
}

/// How to serve.
pub struct Options {
    /// The control endpoint.
    pub control: Endpoint,
    /// When the controlling client goes away.
    pub on_disconnect: OnDisconnect,
    /// The event log.
    pub events: Option<PathBuf>,
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
    /// Why it ended.
    pub reason: Option<OffsetReason>,
    /// What the session measured.
    pub figures: super::Figures,
}

enum Inbound {
    Line(u64, String),
    TooLong(u64),
    Gone(u64),
}

struct Conn {
    writer: Box<dyn Write + Send>,
    subscribed: bool,
    controller: bool,
}

type Conns = Arc<Mutex<HashMap<u64, Conn>>>;

/// A connection's reading and writing halves.
type Halves = (Box<dyn Read + Send>, Box<dyn Write + Send>);

/// Reads bounded lines from `r` into `tx` as client `id`'s.
fn read_lines(id: u64, r: impl Read, tx: &Sender<Inbound>) {
    let mut r = BufReader::new(r);
    loop {
        let mut buf = Vec::new();
        match (&mut r)
            .take(MAX_COMMAND_BYTES as u64 + 1)
            .read_until(b'\n', &mut buf)
        {
            Ok(0) | Err(_) => break,
            Ok(_) => {}
        }
        if buf.last() != Some(&b'\n') && buf.len() > MAX_COMMAND_BYTES {
            // Refused, and the rest of the line skipped.
            if tx.send(Inbound::TooLong(id)).is_err() {
                return;
            }
            let mut rest = Vec::new();
            if r.read_until(b'\n', &mut rest).map_or(true, |n| n == 0) {
                break;
            }
            continue;
        }
        let line = String::from_utf8_lossy(&buf).trim().to_owned();
        if line.is_empty() {
            continue;
        }
        if tx.send(Inbound::Line(id, line)).is_err() {
            return;
        }
    }
    let _ = tx.send(Inbound::Gone(id));
}

/// A bound Unix socket, removed when dropped.
struct UnixSocket {
    path: PathBuf,
}

impl Drop for UnixSocket {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

fn bind_unix(path: &Path) -> anyhow::Result<(std::os::unix::net::UnixListener, UnixSocket)> {
    use std::os::unix::net::{UnixListener, UnixStream};
    if std::fs::symlink_metadata(path).is_ok() {
        if UnixStream::connect(path).is_ok() {
            return Err(InputError::new(format!(
                "--control {}: another session listens there",
                path.display()
            ))
            .into());
        }
        let is_socket = std::fs::symlink_metadata(path).is_ok_and(|m| {
            use std::os::unix::fs::FileTypeExt as _;
            m.file_type().is_socket()
        });
        if !is_socket {
            return Err(InputError::new(format!(
                "--control {}: exists and is not a socket; give a new path",
                path.display()
            ))
            .into());
        }
        // A socket no one listens on: a session that died.
        std::fs::remove_file(path)
            .map_err(|e| anyhow::anyhow!("removing the stale socket {}: {e}", path.display()))?;
    }
    let l = UnixListener::bind(path).map_err(|e| {
        anyhow::anyhow!("--control {}: {}", path.display(), crate::files::reason(&e))
    })?;
    let guard = UnixSocket {
        path: path.to_owned(),
    };
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o600)).map_err(|e| {
        anyhow::anyhow!("--control {}: {}", path.display(), crate::files::reason(&e))
    })?;
    Ok((l, guard))
}

/// Accepts connections of `accept` on a thread of its own.
fn spawn_acceptor<S>(
    name: &str,
    accept: impl Fn() -> std::io::Result<S> + Send + 'static,
    split: fn(&S) -> std::io::Result<Halves>,
    conns: Conns,
    tx: Sender<Inbound>,
    next_id: Arc<std::sync::atomic::AtomicU64>,
) -> anyhow::Result<()>
where
    S: Send + 'static,
{
    std::thread::Builder::new()
        .name(name.into())
        .spawn(move || {
            while let Ok(s) = accept() {
                let Ok((r, mut w)) = split(&s) else { continue };
                let mut map = conns.lock().unwrap_or_else(|p| p.into_inner());
                if map.len() >= MAX_CLIENTS {
                    let _ = writeln!(
                        w,
                        "{}",
                        serde_json::Value::from(
                            Reply::error("", format!("too many clients (at most {MAX_CLIENTS})")).0
                        )
                    );
                    continue;
                }
                let id = next_id.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                map.insert(
                    id,
                    Conn {
                        writer: w,
                        subscribed: false,
                        controller: false,
                    },
                );
                drop(map);
                let tx = tx.clone();
                let _ = std::thread::Builder::new()
                    .name("lmhost-client".into())
                    .spawn(move || read_lines(id, r, &tx));
            }
        })?;
    Ok(())
}

fn split_unix(s: &std::os::unix::net::UnixStream) -> std::io::Result<Halves> {
    s.set_write_timeout(Some(WRITE_TIMEOUT))?;
    Ok((Box::new(s.try_clone()?), Box::new(s.try_clone()?)))
}

fn split_tcp(s: &std::net::TcpStream) -> std::io::Result<Halves> {
    s.set_write_timeout(Some(WRITE_TIMEOUT))?;
    s.set_nodelay(true)?;
    Ok((Box::new(s.try_clone()?), Box::new(s.try_clone()?)))
}

/// The stdio client's id.
const STDIO: u64 = 0;

struct Out {
    conns: Conns,
    log: Option<AppendLog>,
    stdio: bool,
    events: u64,
}

impl Out {
    fn send_to(&mut self, id: u64, line: &str) -> anyhow::Result<()> {
        if id == STDIO && self.stdio {
            crate::outln!("{line}")?;
            return crate::out::flush_stdout();
        }
        let mut map = self.conns.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(c) = map.get_mut(&id)
            && writeln!(c.writer, "{line}")
                .and_then(|()| c.writer.flush())
                .is_err()
        {
            map.remove(&id);
        }
        Ok(())
    }

    fn events(&mut self, events: Vec<Event>) -> anyhow::Result<()> {
        for e in events {
            let line = serde_json::to_string(&e)?;
            self.events += 1;
            if let Some(log) = &mut self.log {
                log.line(&line)?;
            }
            if self.stdio {
                self.send_to(STDIO, &line)?;
            }
            let mut map = self.conns.lock().unwrap_or_else(|p| p.into_inner());
            map.retain(|_, c| {
                !c.subscribed
                    || writeln!(c.writer, "{line}")
                        .and_then(|()| c.writer.flush())
                        .is_ok()
            });
        }
        if let Some(log) = &mut self.log {
            log.sync()?;
        }
        Ok(())
    }
}

/// A synthetic finger resting at the scene's centre, sampled at its rate.
struct Synthetic {
    samples: Box<dyn Iterator<Item = Sample>>,
    start: Instant,
    next: Option<Sample>,
}

impl Synthetic {
    fn new(center_mm: [f64; 3]) -> Self {
        let track = FingerTrack {
            center_mm,
            away_s: None,
            ..FingerTrack::default()
        };
        Self {
            samples: Box::new(track.samples()),
            start: Instant::now(),
            next: None,
        }
    }

    /// The samples due by now.
    fn due(&mut self) -> Vec<Sample> {
        let t = self.start.elapsed().as_secs_f64();
        let mut out = Vec::new();
        loop {
            let s = match self.next.take() {
                Some(s) => s,
                None => match self.samples.next() {
                    Some(s) => s,
                    None => break,
                },
            };
            if s.t_s > t {
                self.next = Some(s);
                break;
            }
            out.push(s);
        }
        // Catch up without flooding: only the newest matters.
        out.into_iter().last().into_iter().collect()
    }
}

/// Serves `session` until `quit`, Ctrl-C / SIGTERM, the end of stdin
/// (stdio control) or an error; the array is silent when it returns.
pub fn serve(mut session: Session, opts: Options) -> anyhow::Result<Report> {
    crate::stop::graceful();
    let Options {
        control,
        on_disconnect,
        events,
        finger,
        mut filter,
    } = opts;
    let conns: Conns = Arc::new(Mutex::new(HashMap::new()));
    let (tx, rx): (Sender<Inbound>, Receiver<Inbound>) = channel();
    let next_id = Arc::new(std::sync::atomic::AtomicU64::new(1));
    let stdio = control.stdio;
    let _socket = match control {
        Endpoint { stdio: true, .. } => {
            let tx = tx.clone();
            std::thread::Builder::new()
                .name("lmhost-stdin".into())
                .spawn(move || read_lines(STDIO, std::io::stdin(), &tx))?;
            None
        }
        Endpoint { unix, tcp, .. } => {
            let guard = unix.map(|(l, guard)| {
                spawn_acceptor(
                    "lmhost-unix",
                    move || l.accept().map(|(s, _)| s),
                    split_unix,
                    conns.clone(),
                    tx.clone(),
                    next_id.clone(),
                )
                .map(|()| guard)
            });
            if let Some(l) = tcp {
                spawn_acceptor(
                    "lmhost-tcp",
                    move || l.accept().map(|(s, _)| s),
                    split_tcp,
                    conns.clone(),
                    tx.clone(),
                    next_id.clone(),
                )?;
            }
            guard.transpose()?
        }
    };
    drop(tx);
    let log = events.as_deref().map(AppendLog::create).transpose()?;
    let mut out = Out {
        conns: conns.clone(),
        log,
        stdio,
        events: 0,
    };
    let mut report = Report::default();
    let mut synthetic = match finger {
        Finger::Synthetic => Some(Synthetic::new(session.scene().center_mm)),
        _ => None,
    };
    let mut feed = match finger {
        Finger::Samples(t) => Some(t),
        _ => None,
    };
    let mut stdin_done = false;
    let result = (|| -> anyhow::Result<OffsetReason> {
        out.events(session.drain_events())?;
        loop {
            if crate::stop::requested() {
                return Ok(OffsetReason::Quit);
            }
            if let Some(s) = &mut synthetic {
                for x in s.due() {
                    let p = filter.update(&x);
                    session.finger(p)?;
                }
            }
            if let Some(f) = &mut feed {
                loop {
                    match f.next_within(Duration::ZERO) {
                        Next::Ready(s) => {
                            let s = s?;
                            let p = filter.update(&s);
                            session.finger(p)?;
                        }
                        Next::Idle => break,
                        Next::End => {
                            feed = None;
                            break;
                        }
                    }
                }
            }
            match rx.recv_timeout(IDLE) {
                Ok(Inbound::Line(id, line)) => {
                    report.commands += 1;
                    let reply = match Command::parse(&line) {
                        Err(e) => {
                            session_refused(&mut session, "", &e.to_string());
                            Reply::error("", e.to_string())
                        }
                        Ok(cmd) => {
                            if let Some(c) =
                                conns.lock().unwrap_or_else(|p| p.into_inner()).get_mut(&id)
                            {
                                match cmd {
                                    Command::Subscribe => c.subscribed = true,
                                    Command::Present(_)
                                    | Command::Prepare { .. }
                                    | Command::Stop => {
                                        c.controller = true;
                                    }
                                    _ => {}
                                }
                            }
                            let reply = session.handle(&cmd);
                            if cmd == Command::Quit {
                                out.send_to(id, &serde_json::Value::from(reply.0).to_string())?;
                                return Ok(OffsetReason::Quit);
                            }
                            reply
                        }
                    };
                    out.send_to(id, &serde_json::Value::from(reply.0).to_string())?;
                }
                Ok(Inbound::TooLong(id)) => {
                    let msg = format!("bad command: longer than {MAX_COMMAND_BYTES} bytes");
                    session_refused(&mut session, "", &msg);
                    out.send_to(
                        id,
                        &serde_json::Value::from(Reply::error("", msg).0).to_string(),
                    )?;
                }
                Ok(Inbound::Gone(id)) => {
                    if id == STDIO && stdio {
                        stdin_done = true;
                    } else {
                        let was = conns
                            .lock()
                            .unwrap_or_else(|p| p.into_inner())
                            .remove(&id)
                            .is_some_and(|c| c.controller);
                        if was {
                            match on_disconnect {
                                OnDisconnect::Continue => {}
                                OnDisconnect::Stop => session.stop(OffsetReason::Disconnect)?,
                                OnDisconnect::Quit => return Ok(OffsetReason::Disconnect),
                            }
                        }
                    }
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => {
                    // Stdin ended and no listener is left: only the
                    // timelines remain.
                    stdin_done = true;
                    std::thread::sleep(IDLE);
                }
            }
            session.poll()?;
            out.events(session.drain_events())?;
            if stdin_done && !session.presenting() {
                return Ok(OffsetReason::Quit);
            }
            if stdin_done && session.presenting_endless() {
                return Ok(OffsetReason::Quit);
            }
        }
    })();
    let reason = match &result {
        Ok(r) => *r,
        Err(_) => OffsetReason::Error,
    };
    report.reason = Some(reason);
    report.figures = session.figures();
    let last = session.close(reason);
    let written = out.events(last);
    report.events = out.events;
    let reason = result?;
    written?;
    report.reason = Some(reason);
    Ok(report)
}

fn session_refused(session: &mut Session, command: &str, error: &str) {
    session.emit(EventKind::Refused {
        command: command.into(),
        error: error.into(),
    });
}
