//! Round 4, the live view (`study run --view`, issue 27): requests whose
//! line or head never ends or is too long, too many headers, a body too
//! large, garbage, unknown paths, no token, connections that send nothing
//! (each answered at once and bounded, the view serving on); and `--view`
//! addresses: bad ones refused in one line, one beyond this host said.

use std::io::{Read as _, Write as _};
use std::net::TcpStream;

use super::*;

/// A study whose view the `during` client attacks; it ends the study with
/// SIGTERM when done (the study waits for the participant's page).
const STUDY: &str = "study run {scenes}/../studies/paper-exp2.toml --port autd3:emulator --finger synthetic --participant V1 --scene {scenes}/paper.toml --out {dir}/v";

/// The view cases.
pub(crate) fn view_cases() -> Vec<Case> {
    vec![
        case(VIEW_HTTP, &format!("{STUDY}/http --view {{viewport}}"))
            .code(1)
            .stderr_file("{dir}/v-http.err")
            .check(|ctx, _| {
                stopped_silent(ctx, "v-http.err", &format!("127.0.0.1:{}", ctx.view_port))
            })
            .during(hostile_requests_are_bounded),
        case(VIEW_ADDRESS, &format!("{STUDY}/a1 --view nope"))
            .err("`nope` is neither a port nor HOST:PORT"),
        case(VIEW_ADDRESS, &format!("{STUDY}/a2 --view 99999")).err("port 99999 is out of range"),
        case(VIEW_ADDRESS, &format!("{STUDY}/a3 --view 127.0.0.1:http")),
        case(VIEW_ADDRESS, &format!("{STUDY}/a4 --view 0.0.0.0:0"))
            .code(1)
            .stderr_file("{dir}/v-a4.err")
            .check(|ctx, _| stopped_silent(ctx, "v-a4.err", "is reachable from other hosts"))
            .during(end_when_listening),
    ]
}

/// The status line of one exchange: `head` (and `body`) sent, the answer
/// read until the server closes.
fn exchange(port: u16, head: &[u8]) -> Result<String, String> {
    let mut s = TcpStream::connect(("127.0.0.1", port)).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(10)))
        .map_err(|e| e.to_string())?;
    s.set_write_timeout(Some(Duration::from_secs(10)))
        .map_err(|e| e.to_string())?;
    // The server may answer and close before all of a long head is sent.
    let _ = s.write_all(head);
    let mut got = Vec::new();
    let _ = s.read_to_end(&mut got);
    let text = String::from_utf8_lossy(&got);
    Ok(text.lines().next().unwrap_or("").to_owned())
}

fn expect(port: u16, what: &str, head: &[u8], status: &str) -> Result<(), String> {
    let line = exchange(port, head)?;
    if line.starts_with(&format!("HTTP/1.1 {status}")) {
        Ok(())
    } else {
        Err(format!("{what}: `{line}`, not {status}"))
    }
}

fn wait_listening(port: u16) -> Result<(), String> {
    let t0 = Instant::now();
    while TcpStream::connect(("127.0.0.1", port)).is_err() {
        if t0.elapsed() > Duration::from_secs(15) {
            return Err("the view never listened".into());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Ok(())
}

fn terminate(pid: u32) -> Result<(), String> {
    Command::new("kill")
        .args(["-TERM", &pid.to_string()])
        .status()
        .map_err(|e| e.to_string())
        .map(|_| ())
}

fn hostile_requests_are_bounded(ctx: &Ctx, pid: u32) -> Result<(), String> {
    let port = ctx.view_port;
    wait_listening(port)?;
    let expect = |what: &str, head: &[u8], status: &str| expect(port, what, head, status);
    let r = (|| {
        let long_line = format!("GET /{} HTTP/1.1\r\n\r\n", "a".repeat(1 << 20));
        expect("a 1 MiB request line", long_line.as_bytes(), "414")?;
        // A request line that never ends is cut at the bound, not read on.
        expect("an endless line", &vec![b'G'; 64 << 10], "414")?;
        let long_header = format!("GET / HTTP/1.1\r\nX-A: {}\r\n\r\n", "b".repeat(100 << 10));
        expect("a 100 KiB header", long_header.as_bytes(), "431")?;
        let many: String = (0..200).map(|i| format!("X-{i}: 1\r\n")).collect();
        expect(
            "200 headers",
            format!("GET / HTTP/1.1\r\n{many}\r\n").as_bytes(),
            "431",
        )?;
        expect(
            "a 1 GB body",
            b"POST /answer?seq=1&choice=4 HTTP/1.1\r\nContent-Length: 1000000000\r\n\r\n",
            "413",
        )?;
        expect("garbage", b"\x00\x01\x02 nonsense\r\n\r\n", "400")?;
        expect(
            "an unknown path",
            b"GET /etc/passwd HTTP/1.1\r\n\r\n",
            "404",
        )?;
        expect("../", b"GET /../../x?token=1 HTTP/1.1\r\n\r\n", "404")?;
        expect("no token", b"GET /frame.png HTTP/1.1\r\n\r\n", "403")?;
        expect(
            "a wrong token",
            b"GET /state.json?token=00 HTTP/1.1\r\n\r\n",
            "403",
        )?;
        expect(
            "a WebSocket without the token",
            b"GET /ws?role=participant HTTP/1.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n",
            "403",
        )?;
        expect(
            "an answer without the token",
            b"POST /answer?seq=1&choice=4.0 HTTP/1.1\r\n\r\n",
            "403",
        )?;
        // Forty connections that send nothing: past the bound they are
        // answered 503 at once; the idle ones are dropped after the read
        // timeout and the view serves again.
        let idle: Vec<TcpStream> = (0..40)
            .filter_map(|_| TcpStream::connect(("127.0.0.1", port)).ok())
            .collect();
        std::thread::sleep(Duration::from_millis(300));
        let t0 = Instant::now();
        expect(
            "a request past 40 idle connections",
            b"GET / HTTP/1.1\r\n\r\n",
            "503",
        )?;
        if t0.elapsed() > Duration::from_secs(2) {
            return Err(format!("the 503 took {:?}", t0.elapsed()));
        }
        std::thread::sleep(Duration::from_secs(6));
        expect(
            "after the idle ones timed out",
            b"GET / HTTP/1.1\r\n\r\n",
            "403",
        )?;
        drop(idle);
        Ok(())
    })();
    terminate(pid)?;
    r
}

/// The study's stderr (`file` in `{dir}`): it says `want`, it was
/// stopped by the signal with the array silent, in one error line.
fn stopped_silent(ctx: &Ctx, file: &str, want: &str) -> Result<(), String> {
    let err = std::fs::read_to_string(ctx.dir.join(file)).map_err(|e| e.to_string())?;
    let errors = err.lines().filter(|l| l.starts_with("error")).count();
    if !err.contains(want)
        || errors != 1
        || !err.contains("error: interrupted by SIGTERM; the array is silent")
        || err.contains("panicked")
    {
        return Err(format!("stderr: {err}"));
    }
    Ok(())
}

fn end_when_listening(_: &Ctx, pid: u32) -> Result<(), String> {
    // The view took any free port: wait for the study to have started,
    // then end it.
    std::thread::sleep(Duration::from_secs(3));
    terminate(pid)
}
