//! The live view in a real browser: `lmhost study run
//! studies/paper-exp2.toml --view` on autd3's emulator with the synthetic
//! finger, its participant's page opened in headless Chromium driven over
//! WebDriver (`/usr/bin/chromedriver`). Checks that frames arrive and
//! change, that the five circles are drawn at their projected radii
//! (pixels of a screenshot against the library's projection), that the
//! frame endpoint draws the circle where it projects (± 2 px), and that
//! clicks answer the trials: a click on the third video records 4 mm; all
//! 30 trials are answered from the page, three of them with the page's
//! CPU slowed 20 times (a loaded machine) and one across a dropped
//! connection (the page reconnects).
//!
//! The WebDriver client is a few blocking HTTP requests over std's
//! TcpStream: the WebDriver crates (fantoccini, thirtyfour) need tokio.
//! Without Chromium and chromedriver the test says so and passes, unless
//! `LM_REQUIRE_BROWSER=1` is set: then it fails. `cargo xtask ci` installs
//! both (its apt step, before the tests) and sets the variable, so CI never
//! passes without the browser having run.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

#[path = "link_support/mod.rs"]
mod link_support;
use link_support::lmhost;

use lmhost::plan::scene::Scene;
use lmhost::sense::track::camera::CameraSetup;
use lmhost::sense::track::colour::ColourCamera;
use lmhost::sense::track::overlay::ColourView;

/// Debian's chromedriver, or `LM_CHROMEDRIVER`.
fn chromedriver() -> String {
    std::env::var("LM_CHROMEDRIVER").unwrap_or_else(|_| "/usr/bin/chromedriver".into())
}

/// Debian's Chromium, or `LM_CHROMIUM`.
fn chromium() -> String {
    std::env::var("LM_CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into())
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// One HTTP/1.1 request; the status and the body.
fn http(port: u16, method: &str, path: &str, body: Option<&str>) -> (u16, Vec<u8>) {
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

fn dechunk(mut b: &[u8]) -> Vec<u8> {
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
struct Driver {
    child: Child,
    port: u16,
    session: String,
    /// Chromium's profile, removed after the session (one per driver:
    /// a test may drive two pages at once).
    _profile: link_support::Scratch,
}

impl Driver {
    fn start() -> Driver {
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
        let profile = link_support::scratch_dir(&format!("chromium-{n}"));
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

    fn call(&self, method: &str, path: &str, body: Option<serde_json::Value>) -> serde_json::Value {
        let b = body.map(|b| b.to_string());
        let (status, data) = http(self.port, method, path, b.as_deref());
        let v: serde_json::Value = serde_json::from_slice(&data).unwrap();
        assert_eq!(status, 200, "{method} {path}: {v}");
        v["value"].clone()
    }

    fn cmd(&self, method: &str, what: &str, body: serde_json::Value) -> serde_json::Value {
        let b = if method == "GET" { None } else { Some(body) };
        self.call(method, &format!("/session/{}/{what}", self.session), b)
    }

    fn js(&self, script: &str) -> serde_json::Value {
        self.cmd(
            "POST",
            "execute/sync",
            serde_json::json!({"script": script, "args": []}),
        )
    }

    /// Polls `script` until it returns true.
    fn until(&self, script: &str, max: Duration) {
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
    fn throttle(&self, rate: f64) {
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
    fn screenshot(&self) -> (Vec<u8>, u32, u32) {
        use base64::Engine as _;
        let b64 = self.cmd("GET", "screenshot", serde_json::Value::Null);
        let png = base64::engine::general_purpose::STANDARD
            .decode(b64.as_str().unwrap())
            .unwrap();
        decode_png(&png)
    }

    fn click(&self, css: &str) {
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

/// RGB or RGBA PNG → RGBA pixels.
fn decode_png(png: &[u8]) -> (Vec<u8>, u32, u32) {
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

fn blue(px: &[u8], w: u32, x: i64, y: i64) -> bool {
    if x < 0 || y < 0 || x >= i64::from(w) {
        return false;
    }
    let i = (y as usize * w as usize + x as usize) * 4;
    i + 2 < px.len() && px[i + 2] > 140 && px[i] < 90 && px[i + 1] < 90
}

/// The fraction of `pts` that have a blue pixel within `tol` px.
fn on_curve(px: &[u8], w: u32, pts: &[[f64; 2]], tol: i64) -> f64 {
    let hit = pts
        .iter()
        .filter(|p| {
            let (x, y) = (p[0].round() as i64, p[1].round() as i64);
            (-tol..=tol).any(|dy| (-tol..=tol).any(|dx| blue(px, w, x + dx, y + dy)))
        })
        .count();
    hit as f64 / pts.len() as f64
}

/// The largest distance of a blue pixel in `rect` from the curve `pts`.
fn farthest_blue(px: &[u8], w: u32, rect: [f64; 4], pts: &[[f64; 2]]) -> f64 {
    let mut worst: f64 = 0.0;
    for y in rect[1] as i64..(rect[1] + rect[3]) as i64 {
        for x in rect[0] as i64..(rect[0] + rect[2]) as i64 {
            if blue(px, w, x, y) {
                let d = pts
                    .iter()
                    .map(|p| ((x as f64 - p[0]).powi(2) + (y as f64 - p[1]).powi(2)).sqrt())
                    .fold(f64::MAX, f64::min);
                worst = worst.max(d);
            }
        }
    }
    worst
}

/// Mean distance of the blue pixels in `rect` from `c`.
fn blue_radius(px: &[u8], w: u32, rect: [f64; 4], c: [f64; 2]) -> f64 {
    let (mut sum, mut n) = (0.0, 0);
    for y in rect[1] as i64..(rect[1] + rect[3]) as i64 {
        for x in rect[0] as i64..(rect[0] + rect[2]) as i64 {
            if blue(px, w, x, y) {
                sum += ((x as f64 - c[0]).powi(2) + (y as f64 - c[1]).powi(2)).sqrt();
                n += 1;
            }
        }
    }
    assert!(n > 0, "no blue pixel in {rect:?}");
    sum / n as f64
}

/// Whether Chromium and chromedriver are here; without them, a printed
/// reason (skip) or, with `LM_REQUIRE_BROWSER=1`, a failure.
fn browser_present() -> bool {
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

/// `lmhost study run studies/paper-exp2.toml --view 0` on autd3's
/// emulator with the synthetic finger, its view's pages read from stderr.
struct Study {
    child: Child,
    participant: String,
    experimenter: String,
    port: u16,
    token: String,
    /// The rest of stderr, drained so the study never blocks on it.
    log: std::thread::JoinHandle<String>,
}

impl Study {
    fn start(out: &Path, scene_file: &Path) -> Study {
        let _ = std::fs::remove_dir_all(out);
        let mut child = Command::new(lmhost())
            .args(["study", "run"])
            .arg(root().join("studies/paper-exp2.toml"))
            .args(["--port", "autd3:emulator", "--finger", "synthetic"])
            .args(["--participant", "P01", "--seed", "5", "--time-scale", "0.2"])
            .args(["--view", "0", "--out"])
            .arg(out)
            .arg("--scene")
            .arg(scene_file)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
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

#[test]
fn participant_page_shows_the_circles_and_answers_experiment_2() {
    if !browser_present() {
        return;
    }
    let scratch = link_support::scratch_dir("browser");
    let out = scratch.join("out");
    let scene_file = root().join("scenes/paper.toml");
    let Study {
        mut child,
        participant,
        port,
        token,
        log,
        ..
    } = Study::start(&out, &scene_file);
    // No token, no view.
    assert_eq!(http(port, "GET", "/frame.png", None).0, 403);
    assert_eq!(http(port, "GET", "/participant?token=0000", None).0, 403);

    let d = Driver::start();
    d.cmd("POST", "url", serde_json::json!({"url": participant}));
    // Frames arrive...
    d.until("return window.lmFrames > 5", Duration::from_secs(30));
    // The library's projection of the circles (nothing plays while the
    // participant answers, so they are drawn about the scene's centre).
    let scene = Scene::load(&scene_file).unwrap();
    let view = ColourView {
        pose: CameraSetup::of_scene_or_default(&scene).camera,
        cam: ColourCamera::D435_848X480,
    };
    let c = scene.center_mm;
    let [x0, y0, side] = view.crop(c, &scene.lm_plane, 12.0);
    let centre = view.pixel(c).unwrap();

    let mut radius_px_seen = Vec::new();
    let mut figures = Vec::new();
    for trial in 1..=30 {
        // Trials 10-12 on a page 20 times slower than this machine: it
        // cannot draw the video's 30 frames a second, and still hears of
        // each question at once (the view sends it a frame only when it
        // took the last; once they queued at the video's rate, the
        // question behind them, and the view dropped the page).
        match trial {
            10 => d.throttle(20.0),
            13 => d.throttle(1.0),
            _ => {}
        }
        // The question is up when the videos are live.
        d.until(
            "return document.querySelectorAll('.choice.off').length === 0",
            Duration::from_secs(60),
        );
        if trial == 15 {
            // The connection drops with the question up (a network's
            // hiccup, or the view taking the page for gone): the page
            // reconnects and is asked again.
            assert_eq!(
                d.js("window.lmSocket.close(4000); return window.lmConnects"),
                1
            );
            d.until(
                "return window.lmConnects === 2 && document.querySelectorAll('.choice.off').length === 0",
                Duration::from_secs(60),
            );
        }
        if trial == 1 {
            // Let a frame be drawn with the question's circles.
            d.until(
                &format!(
                    "return window.lmFrames > {}",
                    d.js("return window.lmFrames")
                ),
                Duration::from_secs(10),
            );
            let (px, w, _) = d.screenshot();
            for (i, r_mm) in [2.0, 3.0, 4.0, 5.0, 6.0].into_iter().enumerate() {
                let rect = d.js(&format!(
                    "const r = document.querySelectorAll('canvas')[{i}].getBoundingClientRect(); return [r.x, r.y, r.width, r.height];"
                ));
                let rect: Vec<f64> = rect
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|v| v.as_f64().unwrap())
                    .collect();
                let k = rect[2] / side;
                let to_page = |p: [f64; 2]| [rect[0] + (p[0] - x0) * k, rect[1] + (p[1] - y0) * k];
                let pts: Vec<[f64; 2]> = view
                    .circle(c, &scene.lm_plane, r_mm, 96)
                    .into_iter()
                    .map(to_page)
                    .collect();
                let hit = on_curve(&px, w, &pts, 2);
                assert!(
                    hit >= 0.95,
                    "circle {r_mm} mm: {:.0}% of its projection drawn",
                    hit * 100.0
                );
                // Every blue pixel of the video lies on its projected curve
                // (within the 2 px stroke's half width, its antialiased
                // edge and a pixel's rounding; neighbouring radii are
                // 10 px apart on the page).
                let dense: Vec<[f64; 2]> = view
                    .circle(c, &scene.lm_plane, r_mm, 2048)
                    .into_iter()
                    .map(to_page)
                    .collect();
                let off = farthest_blue(&px, w, [rect[0], rect[1], rect[2], rect[3]], &dense);
                assert!(
                    off <= 3.0,
                    "circle {r_mm} mm: a blue pixel {off:.1} px off its projection"
                );
                let got = blue_radius(
                    &px,
                    w,
                    [rect[0], rect[1], rect[2], rect[3]],
                    to_page(centre),
                );
                radius_px_seen.push(got);
            }
            // The frame endpoint: the colour stream's size, the circle
            // where it projects.
            let (status, png) = http(
                port,
                "GET",
                &format!("/frame.png?token={token}&radius_mm=4"),
                None,
            );
            assert_eq!(status, 200);
            let (px, w, h) = decode_png(&png);
            assert_eq!((w, h), (848, 480));
            let pts = view.circle(c, &scene.lm_plane, 4.0, 96);
            let hit = on_curve(&px, w, &pts, 2);
            assert!(
                hit >= 0.99,
                "frame.png: {:.0}% of the 4 mm circle within 2 px",
                hit * 100.0
            );
        }
        // The third video is 4 mm; later trials walk through all five.
        let pick = if trial == 1 { 3 } else { (trial % 5) + 1 };
        let before = if trial == 1 {
            http(port, "GET", &format!("/frame.png?token={token}"), None).1
        } else {
            Vec::new()
        };
        if trial == 30 {
            // The view's figures while it still runs: the last answer
            // ends the study and its view.
            figures = http(port, "GET", &format!("/state.json?token={token}"), None).1;
        }
        if trial == 2 {
            // A double click (both before the page hears back) sends one
            // answer: the question goes off the page at the first.
            let sent = d.js(&format!(
                "const c = document.querySelector('#choice{pick}'); c.click(); c.click(); return window.lmSent;"
            ));
            assert_eq!(
                sent, 2,
                "answers sent by trial 2's double click and trial 1"
            );
        } else {
            d.click(&format!("#choice{pick}"));
        }
        if trial == 1 {
            // ... and frames change: the finger comes back for trial 2.
            let t0 = Instant::now();
            while http(port, "GET", &format!("/frame.png?token={token}"), None).1 == before {
                assert!(
                    t0.elapsed() < Duration::from_secs(20),
                    "the frame never changed"
                );
                std::thread::sleep(Duration::from_millis(50));
            }
        }
        // Taken: counted by the page when the view accepted it (the next
        // question may replace the thanks before a poll sees them). The
        // next trial waits for its question: the page took this one off
        // when it was clicked, so a click never lands on an answered
        // question (the view would refuse it, and the answer be lost).
        d.until(
            &format!("return window.lmAnswered >= {trial}"),
            Duration::from_secs(30),
        );
    }
    // One answer sent and taken per trial, none refused; one connection
    // made again (trial 15's), none lost otherwise.
    let counts = d.js("return [window.lmSent, window.lmAnswered, window.lmConnects]");
    assert_eq!(counts, serde_json::json!([30, 30, 2]));
    assert!(
        radius_px_seen.windows(2).all(|w| w[1] > w[0]),
        "{radius_px_seen:?}"
    );
    let status = child.wait().unwrap();
    let log = log.join().unwrap();
    assert!(status.success(), "{log}");
    // The view said the session ended: the page does not reconnect.
    d.until(
        "return document.getElementById('status').textContent.includes('the session has ended')",
        Duration::from_secs(10),
    );
    let v: serde_json::Value = serde_json::from_slice(&figures).unwrap();
    eprintln!("view figures (debug build, one page): {}", v["figures"]);
    let csv = std::fs::read_to_string(out.join("P01/trials.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows.len(), 31, "{csv}");
    let col = rows[0]
        .split(',')
        .position(|h| h == "perceived_radius_mm")
        .unwrap();
    let got: Vec<&str> = rows[1..]
        .iter()
        .map(|r| r.split(',').nth(col).unwrap())
        .collect();
    assert_eq!(got[0], "4.0", "a click on the third video records 4 mm");
    let labels = ["2.0", "3.0", "4.0", "5.0", "6.0"];
    for (i, g) in got.iter().enumerate().skip(1) {
        assert_eq!(*g, labels[(i + 1) % 5], "trial {}", i + 1);
    }
}

/// BENCHMARKS.md's view figures: two Chromium pages (the experimenter's
/// and the participant's, the Experiment 2 setup) on one view for 70 s,
/// then the view's own figures over the last minute: frame in → drawn
/// latency and frames drawn per second per page. Prints them; no timing
/// is asserted. Run on a release binary:
/// `cargo build --release -p lmhost-cli && LMHOST_BIN=target/release/lmhost
/// cargo test --release -p lm-e2e --test browser -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement for BENCHMARKS.md (70 s)"]
fn measure_two_pages() {
    if !browser_present() {
        return;
    }
    let scratch = link_support::scratch_dir("browser-measure");
    let out = scratch.join("out");
    let mut s = Study::start(&out, &root().join("scenes/paper.toml"));
    let pages = [&s.experimenter, &s.participant].map(|url| {
        let d = Driver::start();
        d.cmd("POST", "url", serde_json::json!({"url": url}));
        d.until("return window.lmFrames > 5", Duration::from_secs(30));
        d
    });
    // The latency samples cover the last minute: the pages' start-up is
    // out of it by then.
    std::thread::sleep(Duration::from_secs(70));
    let state = http(
        s.port,
        "GET",
        &format!("/state.json?token={}", s.token),
        None,
    )
    .1;
    let v: serde_json::Value = serde_json::from_slice(&state).unwrap();
    let f = &v["figures"];
    drop(pages);
    let _ = s.child.kill();
    let _ = s.child.wait();
    let _ = s.log.join();
    println!("view figures, 2 pages, 70 s: {f}");
    assert_eq!(f["fps"].as_array().map(Vec::len), Some(2), "{f}");
}
