//! What the `lmhost session` tests share: the paper library, a session
//! on a control socket with its event log, the socket's client, signals
//! and the log read back.

use std::io::{BufRead as _, BufReader, Write as _};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::link_support::lmhost;

/// The repository's paper library.
pub fn library() -> String {
    format!(
        "{}/../studies/paper-library.toml",
        env!("CARGO_MANIFEST_DIR")
    )
}

pub fn lines(out: &[u8]) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(out)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

pub fn events<'a>(v: &'a [serde_json::Value], name: &str) -> Vec<&'a serde_json::Value> {
    v.iter().filter(|e| e["event"] == name).collect()
}

/// A fresh scratch folder, named by the time too: this file's tests run
/// side by side.
pub fn tempdir() -> crate::link_support::Scratch {
    crate::link_support::scratch_dir(&format!(
        "session-{}",
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_nanos()
    ))
}

/// A control socket's path and an events log's, in a fresh folder (kept
/// while its guard lives).
pub fn socket_and_log() -> (crate::link_support::Scratch, PathBuf, PathBuf) {
    let dir = tempdir();
    let (sock, log) = (dir.join("lm.sock"), dir.join("events.jsonl"));
    (dir, sock, log)
}

pub fn connect(path: &Path) -> UnixStream {
    let end = Instant::now() + Duration::from_secs(30);
    loop {
        match UnixStream::connect(path) {
            Ok(s) => return s,
            Err(e) if Instant::now() > end => panic!("{}: {e}", path.display()),
            Err(_) => std::thread::sleep(Duration::from_millis(50)),
        }
    }
}

pub fn send(s: &mut UnixStream, r: &mut BufReader<UnixStream>, cmd: &str) -> serde_json::Value {
    writeln!(s, "{cmd}").unwrap();
    loop {
        let mut line = String::new();
        r.read_line(&mut line).unwrap();
        let v: serde_json::Value = serde_json::from_str(&line).unwrap();
        if v.get("cmd").is_some() {
            return v;
        }
    }
}

/// Sends `cmd` and asserts the session accepted it.
#[track_caller]
pub fn accepted(s: &mut UnixStream, r: &mut BufReader<UnixStream>, cmd: &str) {
    let rep = send(s, r, cmd);
    assert_eq!(rep["ok"], true, "{cmd}: {rep}");
}

/// `lmhost session` with the paper library on `port`, controlled on the
/// socket `sock`, logging events to `log` if given; stdout and stderr
/// piped for [`exited_0`].
pub fn session(port: &[&str], sock: &Path, log: Option<&Path>) -> Command {
    let mut c = Command::new(lmhost());
    c.args(["session", "--library", &library(), "--port"])
        .args(port)
        .args(["--control", sock.to_str().unwrap()]);
    if let Some(log) = log {
        c.args(["--events", log.to_str().unwrap()]);
    }
    c.stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    c
}

/// A connection to the control socket and a reader of its replies.
pub fn control(sock: &Path) -> (UnixStream, BufReader<UnixStream>) {
    let s = connect(sock);
    let r = BufReader::new(s.try_clone().unwrap());
    (s, r)
}

/// A connection to the control socket on which `present` was accepted.
pub fn presenting(sock: &Path, present: &str) -> (UnixStream, BufReader<UnixStream>) {
    let (mut s, mut r) = control(sock);
    accepted(&mut s, &mut r, present);
    (s, r)
}

/// Asserts a session ended with exit code 0 (saying `what` and its
/// stderr otherwise).
#[track_caller]
pub fn exited_0(out: &Output, what: &str) {
    assert_eq!(
        out.status.code(),
        Some(0),
        "{what}{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The events a session logged to `log`.
pub fn logged(log: &Path) -> Vec<serde_json::Value> {
    lines(std::fs::read_to_string(log).unwrap().as_bytes())
}
