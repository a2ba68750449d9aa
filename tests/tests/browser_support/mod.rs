//! The browser tests' WebDriver client, their HTTP requests and the
//! study whose view they open.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use super::link_support::{Scratch, lmhost, scratch_dir};

/// Debian's chromedriver, or `LM_CHROMEDRIVER`.
pub fn chromedriver() -> String {
    std::env::var("LM_CHROMEDRIVER").unwrap_or_else(|_| "/usr/bin/chromedriver".into())
}

/// Debian's Chromium, or `LM_CHROMIUM`.
pub fn chromium() -> String {
    std::env::var("LM_CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into())
}

pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// One HTTP/1.1 request; the status and the body.
pub fn http(port: u16, method: &str, path: &str, body: Option<&str>) -> (u16, Vec<u8>) {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    let body = body.unwrap_or("");
    write!(
        s,
        "{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    )
    .unwrap();
    // Read the head, then exactly the body it announces (chromedriver
    // keeps the connection open after its reply).
    let mut r = BufReader::new(s);
    let mut head = String::new();
    loop {
        let mut l = String::new();
        r.read_line(&mut l)
            .unwrap_or_else(|e| panic!("{method} {path} on port {port}: {e}"));
        if l == "\r\n" || l.is_empty() {
            break;
        }
        head.push_str(&l);
    }
    let status = head.split(' ').nth(1).unwrap().parse().unwrap();
    let lower = head.to_ascii_lowercase();
    let len = lower
        .lines()
        .find_map(|l| l.strip_prefix("content-length:"))
        .map(|v| v.trim().parse::<usize>().unwrap());
    let mut data = Vec::new();
    match len {
        Some(n) => {
            data.resize(n, 0);
            r.read_exact(&mut data).unwrap();
        }
        None => {
            r.read_to_end(&mut data).unwrap();
            if lower.contains("transfer-encoding: chunked") {
                data = dechunk(&data);
            }
        }
    }
    (status, data)
}

pub fn dechunk(mut b: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let line = b.windows(2).position(|w| w == b"\r\n").unwrap();
        let n = usize::from_str_radix(std::str::from_utf8(&b[..line]).unwrap().trim(), 16).unwrap();
        if n == 0 {
            return out;
        }
        out.extend_from_slice(&b[line + 2..line + 2 + n]);
        b = &b[line + 4 + n..];
    }
}

/// A WebDriver session on chromedriver.
pub struct Driver {
    child: Child,
    port: u16,
    session: String,
    /// Chromium's profile, removed after the session (one per driver:
    /// a test may drive two pages at once).
    _profile: super::link_support::Scratch,
}

impl Driver {
    pub fn start() -> Driver {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let child = Command::new(chromedriver())
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let t0 = Instant::now();
        while TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(
                t0.elapsed() < Duration::from_secs(20),
                "chromedriver did not listen"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        static DRIVERS: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = DRIVERS.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        let profile = super::link_support::scratch_dir(&format!("chromium-{n}"));
        let caps = serde_json::json!({"capabilities": {"alwaysMatch": {"goog:chromeOptions": {
            "binary": chromium(),
            "args": ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                     "--no-first-run", "--disable-background-networking",
                     "--disable-component-update", "--disable-sync",
                     "--window-size=1400,600", "--force-device-scale-factor=1",
                     format!("--user-data-dir={}", profile.display())]
        }}}});
        let mut d = Driver {
            child,
            port,
            session: String::new(),
            _profile: profile,
        };
        let v = d.call("POST", "/session", Some(caps));
        d.session = v["sessionId"].as_str().unwrap().to_owned();
        d
    }

    pub fn call(
        &self,
        method: &str,
        path: &str,
        body: Option<serde_json::Value>,
    ) -> serde_json::Value {
        let b = body.map(|b| b.to_string());
        let (status, data) = http(self.port, method, path, b.as_deref());
        let v: serde_json::Value = serde_json::from_slice(&data).unwrap();
        assert_eq!(status, 200, "{method} {path}: {v}");
        v["value"].clone()
    }

    pub fn cmd(&self, method: &str, what: &str, body: serde_json::Value) -> serde_json::Value {
        let b = if method == "GET" { None } else { Some(body) };
        self.call(method, &format!("/session/{}/{what}", self.session), b)
    }

    pub fn js(&self, script: &str) -> serde_json::Value {
        self.cmd(
            "POST",
            "execute/sync",
            serde_json::json!({"script": script, "args": []}),
        )
    }

    /// Polls `script` until it returns true.
    pub fn until(&self, script: &str, max: Duration) {
        let t0 = Instant::now();
        while self.js(script) != serde_json::Value::Bool(true) {
            assert!(
                t0.elapsed() < max,
                "waited {max:?} for `{script}`; the page says {}",
                self.js("return [document.getElementById('status').textContent, window.lmSent, window.lmAnswered]")
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Slows the page's CPU `rate` times (1: its own speed), as a loaded
    /// machine or a throttled tab would (Chrome DevTools over
    /// chromedriver).
    pub fn throttle(&self, rate: f64) {
        self.call(
            "POST",
            &format!("/session/{}/goog/cdp/execute", self.session),
            Some(serde_json::json!({
                "cmd": "Emulation.setCPUThrottlingRate",
                "params": {"rate": rate}
            })),
        );
    }

    /// The page as RGBA pixels.
    pub fn screenshot(&self) -> (Vec<u8>, u32, u32) {
        use base64::Engine as _;
        let b64 = self.cmd("GET", "screenshot", serde_json::Value::Null);
        let png = base64::engine::general_purpose::STANDARD
            .decode(b64.as_str().unwrap())
            .unwrap();
        decode_png(&png)
    }

    pub fn click(&self, css: &str) {
        let e = self.cmd(
            "POST",
            "element",
            serde_json::json!({"using": "css selector", "value": css}),
        );
        let id = e
            .as_object()
            .unwrap()
            .values()
            .next()
            .unwrap()
            .as_str()
            .unwrap()
            .to_owned();
        self.cmd(
            "POST",
            &format!("element/{id}/click"),
            serde_json::json!({}),
        );
    }
}

impl Drop for Driver {
    fn drop(&mut self) {
        if !self.session.is_empty() {
            let _ = http(
                self.port,
                "DELETE",
                &format!("/session/{}", self.session),
                None,
            );
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Whether Chromium and chromedriver are here; without them, a printed
/// reason (skip) or, with `LM_REQUIRE_BROWSER=1`, a failure.
pub fn browser_present() -> bool {
    let missing: Vec<String> = [chromium(), chromedriver()]
        .into_iter()
        .filter(|p| !Path::new(p).exists())
        .collect();
    if missing.is_empty() {
        return true;
    }
    let why = format!(
        "no {} (Debian's chromium and chromium-driver; cargo xtask ci installs them)",
        missing.join(", ")
    );
    assert!(
        std::env::var_os("LM_REQUIRE_BROWSER").is_none_or(|v| v != "1"),
        "LM_REQUIRE_BROWSER=1 and {why}"
    );
    eprintln!("skipped: {why}");
    false
}

/// A browser test's start: without a browser `None` (the test is
/// skipped, see [`browser_present`]); else a scratch folder `name` (its
/// guard), the study's `out` folder in it and the paper's scene file.
pub fn study_folders(name: &str) -> Option<(Scratch, PathBuf, PathBuf)> {
    if !browser_present() {
        return None;
    }
    let scratch = scratch_dir(name);
    let out = scratch.join("out");
    Some((scratch, out, root().join("scenes/paper.toml")))
}

/// `lmhost study run studies/paper-exp2.toml --view 0` on autd3's
/// emulator with the synthetic finger, its view's pages read from stderr.
pub struct Study {
    pub child: Killed,
    pub participant: String,
    pub experimenter: String,
    pub port: u16,
    pub token: String,
    /// The rest of stderr, drained so the study never blocks on it.
    pub log: std::thread::JoinHandle<String>,
}

impl Study {
    pub fn start(out: &Path, scene_file: &Path) -> Study {
        let _ = std::fs::remove_dir_all(out);
        Self::start_as(out, scene_file, "P01", "0")
    }

    /// As [`Study::start`], for `participant` in `out` as it is, its view
    /// on `view` (`--view`: a port, 0 for any).
    pub fn start_as(out: &Path, scene_file: &Path, participant: &str, view: &str) -> Study {
        // Killed if this test fails before the study ends.
        let mut child = Killed(
            Command::new(lmhost())
                .args(["study", "run"])
                .arg(root().join("studies/paper-exp2.toml"))
                .args(["--port", "autd3:emulator", "--finger", "synthetic"])
                .args([
                    "--participant",
                    participant,
                    "--seed",
                    "5",
                    "--time-scale",
                    "0.2",
                ])
                .args(["--view", view, "--out"])
                .arg(out)
                .arg("--scene")
                .arg(scene_file)
                .stdin(Stdio::null())
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap(),
        );
        let mut err = BufReader::new(child.stderr.take().unwrap());
        let mut line = String::new();
        let (experimenter, participant) = loop {
            line.clear();
            assert!(
                err.read_line(&mut line).unwrap() > 0,
                "the study ended before its view"
            );
            // "lmhost: view on ADDR: experimenter URL ; participant URL"
            if let (Some(e), Some(p)) = (
                line.find("experimenter http://"),
                line.find("participant http://"),
            ) {
                let e = line[e + "experimenter ".len()..].split(' ').next().unwrap();
                let p = line[p + "participant ".len()..].trim();
                break (e.to_owned(), p.to_owned());
            }
        };
        // Each line also goes to this test's captured output, so a failed
        // test shows what the study said (why it ended, say).
        let log = std::thread::spawn(move || {
            let mut s = String::new();
            let mut line = Vec::new();
            while err.read_until(b'\n', &mut line).is_ok_and(|n| n > 0) {
                let l = String::from_utf8_lossy(&line);
                eprint!("study: {l}");
                s.push_str(&l);
                line.clear();
            }
            s
        });
        let hostport = participant["http://".len()..].split('/').next().unwrap();
        let port: u16 = hostport.rsplit(':').next().unwrap().parse().unwrap();
        let token = participant.rsplit("token=").next().unwrap().to_owned();
        Study {
            child,
            participant,
            experimenter,
            port,
            token,
            log,
        }
    }
}

/// RGB or RGBA PNG → RGBA pixels.
pub fn decode_png(png: &[u8]) -> (Vec<u8>, u32, u32) {
    let mut r = png::Decoder::new(png).read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size()];
    let info = r.next_frame(&mut buf).unwrap();
    let px = match info.color_type {
        png::ColorType::Rgba => buf[..info.buffer_size()].to_vec(),
        png::ColorType::Rgb => buf[..info.buffer_size()]
            .chunks(3)
            .flat_map(|c| [c[0], c[1], c[2], 255])
            .collect(),
        c => panic!("screenshot colour type {c:?}"),
    };
    (px, info.width, info.height)
}

/// A child process killed (and reaped) when dropped: a test that fails
/// while its study runs leaves no study running behind it.
pub struct Killed(pub Child);

impl std::ops::Deref for Killed {
    type Target = Child;
    fn deref(&self) -> &Child {
        &self.0
    }
}

impl std::ops::DerefMut for Killed {
    fn deref_mut(&mut self) -> &mut Child {
        &mut self.0
    }
}

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}
