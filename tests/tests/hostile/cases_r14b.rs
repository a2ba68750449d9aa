//! Round 14b: the device side, the live inputs and Python.
//!
//! - r14b-1 (Python's own, in `python/tests/test_hostile_r14b.py`): a
//!   numpy scalar is judged as the value it stands for: `np.True_` and a
//!   numpy complex number were numbers through their `__float__`
//!   (`plan(radius=np.True_)` planned 1 mm), and the tracker's intrinsics
//!   dict refused a numpy int or float32 as "must be a number".
//! - r14b-2: a session client that half-closes its socket after its
//!   commands (`nc -N`, `socat`, `shutdown(SHUT_WR)` — its input ended,
//!   it still reads) gets every reply: the end of its input closed the
//!   connection at once, before the writer had sent the replies queued
//!   for its last lines, so about half of such clients got nothing back.
//! - r14b-3: a number beyond a float on a control line or a centroid line
//!   is refused as itself, naming its key, and a control line's refusal
//!   names its command: `serde_json` stopped at `"on_s":1e999` with
//!   "number out of range" (no key, no value), answered as `"cmd":""`
//!   with the hint on what JSON a command is; a `1e-320` there was
//!   refused naming its key but as `"cmd":""` too.
//!
//! Fixtures in `{dir}/r14b`.

use std::io::BufRead;
use std::net::{Shutdown, TcpStream};
use std::os::unix::net::UnixStream;

use super::*;

pub(crate) fn round14b_fixtures(dir: &Path) {
    std::fs::create_dir_all(dir.join("r14b")).unwrap();
}

/// A session on the AUTD3 emulator over stdin.
const STDIN_SESSION: &str =
    "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator --control -";

pub(crate) fn round14b_cases() -> Vec<Case> {
    let mut v = vec![
        case(
            R14B_HALF_CLOSED,
            "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator --control {dir}/r14b/half.sock --tcp {tcp}",
        )
        .ok()
        .during(half_closed_clients_get_every_reply),
    ];
    let too_large = "is too large to represent (it would be read as";
    let most = "give a magnitude of at most 1.79769e308";
    for (field, value, read_as) in [
        ("on_s", "1e999", "inf"),
        ("off_s", "-2E400", "-inf"),
        ("repeat", "1e309", "inf"),
    ] {
        let line = format!(
            r#"{{"cmd":"present","stimulus":"lms-5hz-a3","gate":"untracked","{field}":{value}}}"#
        );
        v.push(
            case(R14B_BEYOND_FLOAT, STDIN_SESSION)
                .stdin(format!("{line}\n{{\"cmd\":\"status\"}}\n"))
                .ok()
                .out(&format!(
                    r#""cmd":"present","error":"bad command: `{field}`: {value} {too_large} {read_as}): {most}","ok":false"#
                ))
                .out("\"state\":\"idle\""),
        );
    }
    // Below the smallest normal number: refused as before, now in its
    // command's name.
    v.push(
        case(R14B_BEYOND_FLOAT, STDIN_SESSION)
            .stdin("{\"cmd\":\"present\",\"stimulus\":\"lms-5hz-a3\",\"on_s\":1e-320}\n")
            .ok()
            .out(
                r#""cmd":"present","error":"bad command: `on_s`: 1e-320 is too small to represent"#,
            ),
    );
    v.push(
        case(R14B_BEYOND_FLOAT, "stream --port {port}")
            .stdin(
                "{\"t\":0,\"x\":0,\"y\":0,\"z\":200}\n{\"t\":0.01,\"x\":1e999,\"y\":0,\"z\":200}\n",
            )
            .err("line 2: ")
            .err(&format!("`x`: 1e999 {too_large} inf): {most}")),
    );
    v
}

/// The session's socket, once it listens.
fn connect_unix(path: &Path) -> Result<UnixStream, String> {
    let t0 = Instant::now();
    loop {
        match UnixStream::connect(path) {
            Ok(u) => return Ok(u),
            Err(_) if t0.elapsed() < Duration::from_secs(30) => {
                std::thread::sleep(Duration::from_millis(50))
            }
            Err(e) => return Err(format!("{}: {e}", path.display())),
        }
    }
}

/// Writes `lines`, half-closes, and reads until the session closes: the
/// `cmd` of every reply, in order.
fn half_closed<S: Read + Write>(
    mut s: S,
    lines: &[&str],
    shut: impl Fn(&S) -> std::io::Result<()>,
) -> Result<Vec<String>, String> {
    for l in lines {
        writeln!(s, "{l}").map_err(|e| e.to_string())?;
    }
    shut(&s).map_err(|e| e.to_string())?;
    let mut got = Vec::new();
    for line in std::io::BufReader::new(s).lines() {
        let line = line.map_err(|e| format!("{e} after {got:?}"))?;
        let v: serde_json::Value = serde_json::from_str(&line).map_err(|e| e.to_string())?;
        got.push(v["cmd"].as_str().unwrap_or("?").to_owned());
    }
    Ok(got)
}

fn half_closed_clients_get_every_reply(ctx: &Ctx, _: u32) -> Result<(), String> {
    let path = ctx.dir.join("r14b/half.sock");
    let control = connect_unix(&path)?;
    let r = (|| {
        let lines = [
            r#"{"cmd":"status"}"#,
            r#"{"cmd":"library"}"#,
            r#"{"cmd":"nonsense"}"#,
        ];
        // Each round lost its replies about every other time: 20 rounds.
        for round in 0..20 {
            let u = connect_unix(&path)?;
            u.set_read_timeout(Some(Duration::from_secs(10)))
                .map_err(|e| e.to_string())?;
            let got = half_closed(u, &lines, |u| u.shutdown(Shutdown::Write))?;
            if got != ["status", "library", ""] {
                return Err(format!("Unix socket, round {round}: replies {got:?}"));
            }
        }
        let token = std::fs::read_to_string(ctx.dir.join("r14b/half.sock.token"))
            .map_err(|e| e.to_string())?;
        let auth = format!(r#"{{"cmd":"auth","token":"{}"}}"#, token.trim());
        for round in 0..10 {
            let s = TcpStream::connect(("127.0.0.1", ctx.tcp)).map_err(|e| e.to_string())?;
            s.set_read_timeout(Some(Duration::from_secs(10)))
                .map_err(|e| e.to_string())?;
            let got = half_closed(s, &[&auth, r#"{"cmd":"status"}"#], |s| {
                s.shutdown(Shutdown::Write)
            })?;
            if got != ["auth", "status"] {
                return Err(format!("TCP, round {round}: replies {got:?}"));
            }
        }
        Ok(())
    })();
    let mut w = control.try_clone().map_err(|e| e.to_string())?;
    writeln!(w, r#"{{"cmd":"quit"}}"#).map_err(|e| e.to_string())?;
    let _ = std::io::BufReader::new(control).lines().next();
    r
}
