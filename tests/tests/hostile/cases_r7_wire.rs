//! Round 7b, a sweep of every line, datagram and request lmhost takes at
//! run time: the session's control lines (every command × every field
//! given NaN-like and huge numbers, wrong JSON types, nested objects,
//! duplicate keys, 4095/4096/4097-byte lines, bytes not UTF-8, lone `\r`,
//! blank lines, unknown fields) over stdin, the Unix socket and TCP;
//! `stream --udp` datagrams; the live view's requests. One row per class
//! of what it found and per input kind the class hit.
//!
//! - A key given twice is refused, never its last value taken (`serde_json`
//!   kept the last: `{"cmd":"stop","cmd":"status"}` was a `status`, a
//!   centroid `{"x":0,"x":500}` at 500 mm).
//! - A value repeated in a refusal is cut at 64 characters, also where
//!   serde quotes it in double quotes (a string of the wrong type).
//! - An `on_s` under half a step is refused: the device plays whole steps
//!   and played one, longer than asked, without a word.
//! - A line not UTF-8 is refused as such, not read with its bad bytes
//!   replaced.
//! - A refusal names the command it refuses (it said `"cmd":""` for a
//!   `present` with a field of the wrong type).
//! - A value refused beside its bound is not shown as the bound (`on_s
//!   3600.0000001` read "3600 s is out of range ... at most 3600 s"), on
//!   the control line and on the flags.
//! - A TCP client that sends no token gets its one reply before the close.
//! - The view gives a request one deadline (a byte every 4 s held a
//!   connection for as long as the head took), and telemetry without
//!   numbers is refused, not answered "ok".
//!
//! Clients of a running command are the `during` functions; files in
//! `{dir}/r7`.

use std::io::{BufReader, Read as _, Write as _};
use std::net::TcpStream;
use std::os::unix::net::UnixStream;

use super::*;

/// A session on the AUTD3 emulator over stdin, given `lines`.
const STDIN_SESSION: &str =
    "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator --control -";

/// A session's stdin: `lines`, each with its newline.
fn lines(lines: &[&[u8]]) -> Vec<u8> {
    lines.iter().flat_map(|l| [*l, b"\n"].concat()).collect()
}

/// A line's reply that must be there, beside a status that shows the
/// session still answers.
fn session(class: &'static str, line: &[u8], want: &str) -> Case {
    case(class, STDIN_SESSION)
        .stdin(lines(&[line, br#"{"cmd":"status"}"#]))
        .ok()
        .out(want)
        .out("\"state\":\"idle\"")
}

pub(crate) fn wire_cases() -> Vec<Case> {
    let long = "z".repeat(1000);
    let mut v = vec![
        // 1. A key given twice: on a control line, in a centroid line on
        //    stdin and in a datagram.
        session(
            WIRE_DUPLICATE_KEYS,
            br#"{"cmd":"stop","cmd":"status"}"#,
            r#""cmd":"","error":"bad command: duplicate key `cmd`"#,
        ),
        session(
            WIRE_DUPLICATE_KEYS,
            br#"{"cmd":"present","stimulus":"lms-5hz-a3","gate":"untracked","on_s":1,"on_s":3600}"#,
            "duplicate key `on_s`",
        ),
        case(WIRE_DUPLICATE_KEYS, "stream --port {port}")
            .stdin(r#"{"t":0,"x":0,"x":500,"y":0,"z":200}"#.to_owned() + "\n")
            .err("line 1")
            .err("duplicate key `x`"),
        case(
            WIRE_DUPLICATE_KEYS,
            "stream --port {port} --udp 47071 --seconds 1 --json",
        )
        .udp(
            47071,
            (0..5)
                .map(|i| format!(r#"{{"t":{i},"x":0,"x":500,"y":0,"z":200}}"#).into_bytes())
                .collect(),
        )
        .ok()
        .out("\"bad_datagrams\":5")
        .out("\"outside_work_volume\":0"),
        // 2. A value of the wrong type cut at 64 characters.
        session(
            WIRE_ECHO,
            format!(r#"{{"cmd":"present","stimulus":"lms-5hz-a3","on_s":"{long}"}}"#).as_bytes(),
            "(1000 bytes)",
        ),
        session(
            WIRE_ECHO,
            format!(r#"{{"cmd":"present","stimulus":"lms-5hz-a3","repeat":"{long}"}}"#)
                .as_bytes(),
            // Refused by its rule, the string not repeated at all.
            "`repeat` is a string, not a number: allowed 1..=10000\"",
        ),
        // 3. An on-phase the device would round up to a step.
        session(
            WIRE_ROUNDED,
            br#"{"cmd":"present","stimulus":"lms-5hz-a3","gate":"untracked","on_s":1e-300}"#,
            "on_s 1e-300 s is shorter than half a step",
        ),
        session(
            WIRE_ROUNDED,
            br#"{"cmd":"present","stimulus":"lms-5hz-a3","gate":"untracked","on_s":0.001}"#,
            "give at least 0.001225 s",
        ),
        // 4. Bytes not UTF-8, in the command's name and in a value.
        session(
            WIRE_UTF8,
            b"{\"cmd\":\"st\xff\xfeatus\"}",
            "the line is not UTF-8 (byte 11 of 18)",
        ),
        session(
            WIRE_UTF8,
            b"{\"cmd\":\"present\",\"stimulus\":\"\xc3\x28\"}",
            "the line is not UTF-8",
        ),
        // 5. A refusal in the name of the command refused.
        session(
            WIRE_NAMED,
            br#"{"cmd":"present","stimulus":"lms-5hz-a3","on_s":"a"}"#,
            r#""cmd":"present","error":"bad command: invalid type"#,
        ),
        session(
            WIRE_NAMED,
            br#"{"cmd":"prepare","stimulus":7}"#,
            r#""cmd":"prepare","error":"bad command: `stimulus` is not a string"#,
        ),
        // 6. A value beside its bound, on a control line and on flags.
        session(
            WIRE_BESIDE_BOUND,
            br#"{"cmd":"present","stimulus":"lms-5hz-a3","gate":"untracked","on_s":3600.0000001}"#,
            "on_s 3600.0000001 s is out of range",
        ),
        case(
            WIRE_BESIDE_BOUND,
            "upload --port autd3:emulator --hold 86400.0000001",
        )
        .err("--hold 86400.0000001 s is out of range"),
        case(WIRE_BESIDE_BOUND, "plan --intensity 1.0000000001")
            .err("--intensity 1.0000000001 is out of range"),
        // 7. A TCP client that never sends its token.
        case(
            WIRE_TCP_REPLY,
            "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator --control {dir}/r7/tcp.sock --tcp {tcp}",
        )
        .ok()
        .during(a_silent_tcp_client_gets_its_reply),
    ];
    // 8. The view: a request trickled in, telemetry without numbers.
    v.push(
        case(
            WIRE_VIEW,
            "study run {scenes}/../studies/paper-exp2.toml --port autd3:emulator --finger synthetic --participant W1 --scene {scenes}/paper.toml --out {dir}/r7/v --view {viewport}",
        )
        .code(1)
        .stderr_file("{dir}/r7-view.err")
        .during(a_trickled_request_has_one_deadline),
    );
    v
}

pub(crate) fn wire_fixtures(dir: &Path) {
    std::fs::create_dir_all(dir.join("r7")).unwrap();
}

/// One JSON line from `r`.
fn json_line(r: &mut impl std::io::BufRead) -> Result<serde_json::Value, String> {
    let mut l = String::new();
    match r.read_line(&mut l) {
        Ok(0) => Err("closed without a line".into()),
        Ok(_) => serde_json::from_str(&l).map_err(|e| format!("{e}: {l}")),
        Err(e) => Err(e.to_string()),
    }
}

fn a_silent_tcp_client_gets_its_reply(ctx: &Ctx, _: u32) -> Result<(), String> {
    let path = ctx.dir.join("r7/tcp.sock");
    let t0 = Instant::now();
    let u = loop {
        match UnixStream::connect(&path) {
            Ok(u) => break u,
            Err(_) if t0.elapsed() < Duration::from_secs(20) => {
                std::thread::sleep(Duration::from_millis(50))
            }
            Err(e) => return Err(format!("{}: {e}", path.display())),
        }
    };
    let r = (|| {
        let s = TcpStream::connect(("127.0.0.1", ctx.tcp)).map_err(|e| e.to_string())?;
        s.set_read_timeout(Some(Duration::from_secs(15)))
            .map_err(|e| e.to_string())?;
        // Nothing sent: after the session's 5 s, its one reply, then the end.
        let mut r = BufReader::new(s);
        let v = json_line(&mut r)?;
        if v["ok"] != false
            || v["cmd"] != "auth"
            || !v["error"]
                .as_str()
                .unwrap_or("")
                .contains("no line within 5 s")
        {
            return Err(format!("a client that sent nothing: {v}"));
        }
        if json_line(&mut r).is_ok() {
            return Err("more than one line, or not closed".into());
        }
        Ok(())
    })();
    let mut w = u.try_clone().map_err(|e| e.to_string())?;
    writeln!(w, r#"{{"cmd":"quit"}}"#).map_err(|e| e.to_string())?;
    let _ = json_line(&mut BufReader::new(u));
    r
}

/// The status line the view answers `head` with.
fn status_line(port: u16, head: &[u8]) -> Result<String, String> {
    let mut s = TcpStream::connect(("127.0.0.1", port)).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(10)))
        .map_err(|e| e.to_string())?;
    let _ = s.write_all(head);
    let mut got = Vec::new();
    let _ = s.read_to_end(&mut got);
    Ok(String::from_utf8_lossy(&got)
        .lines()
        .next()
        .unwrap_or("")
        .to_owned())
}

fn a_trickled_request_has_one_deadline(ctx: &Ctx, pid: u32) -> Result<(), String> {
    let port = ctx.view_port;
    let r = (|| {
        let t0 = Instant::now();
        while TcpStream::connect(("127.0.0.1", port)).is_err() {
            if t0.elapsed() > Duration::from_secs(20) {
                return Err("the view never listened".to_owned());
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        // The token is in the address the study prints on stderr.
        let token = loop {
            let out = std::fs::read_to_string(ctx.dir.join("r7-view.err")).unwrap_or_default();
            if let Some(t) = out.split("token=").nth(1) {
                break t
                    .chars()
                    .take_while(char::is_ascii_hexdigit)
                    .collect::<String>();
            }
            if t0.elapsed() > Duration::from_secs(20) {
                return Err(format!("no token in the study's output: {out}"));
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        let drawn = format!("POST /drawn?token={token}&page=x&seq=1 HTTP/1.1\r\n\r\n");
        let line = status_line(port, drawn.as_bytes())?;
        if !line.starts_with("HTTP/1.1 400") {
            return Err(format!("/drawn without numbers: `{line}`"));
        }
        // One byte every 2 s, each within the read timeout: the answer
        // comes at the request's deadline, not after the whole head.
        let mut s = TcpStream::connect(("127.0.0.1", port)).map_err(|e| e.to_string())?;
        s.set_read_timeout(Some(Duration::from_millis(100)))
            .map_err(|e| e.to_string())?;
        let t0 = Instant::now();
        let mut got = Vec::new();
        for b in b"GET / HTTP/1.1\r\nX-Slow: 12345678".iter() {
            // Past 12 s without an answer the deadline was not kept.
            if t0.elapsed() > Duration::from_secs(12) || s.write_all(&[*b]).is_err() {
                break;
            }
            let mut buf = [0u8; 256];
            if let Ok(n) = s.read(&mut buf)
                && n > 0
            {
                got.extend_from_slice(&buf[..n]);
                break;
            }
            std::thread::sleep(Duration::from_secs(2));
        }
        let line = String::from_utf8_lossy(&got)
            .lines()
            .next()
            .unwrap_or("")
            .to_owned();
        if !line.starts_with("HTTP/1.1 408") {
            return Err(format!(
                "a request trickled in for {:?}: `{line}`",
                t0.elapsed()
            ));
        }
        Ok(())
    })();
    Command::new("kill")
        .args(["-TERM", &pid.to_string()])
        .status()
        .map_err(|e| e.to_string())?;
    r
}
