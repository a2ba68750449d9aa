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
//! connection (the page reconnects); and that a page of a run that died
//! says so once lmhost serves a new run on its address.
//!
//! The WebDriver client is a few blocking HTTP requests over std's
//! TcpStream: the WebDriver crates (fantoccini, thirtyfour) need tokio.
//! Without Chromium and chromedriver the test says so and passes, unless
//! `LM_REQUIRE_BROWSER=1` is set: then it fails. `cargo xtask ci` installs
//! both (its apt step, before the tests) and sets the variable, so CI never
//! passes without the browser having run.

use std::time::{Duration, Instant};

mod browser_support;
#[path = "link_support/mod.rs"]
mod link_support;
use browser_support::{Driver, Study, decode_png, http, study_folders};

use lmhost::plan::scene::Scene;
use lmhost::sense::track::camera::CameraSetup;
use lmhost::sense::track::colour::ColourCamera;
use lmhost::sense::track::overlay::ColourView;

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

#[test]
fn participant_page_shows_the_circles_and_answers_experiment_2() {
    let Some((_scratch, out, scene_file)) = study_folders("browser") else {
        return;
    };
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

/// lmhost started again on the same address (a crash, then a new run
/// with a new token): the earlier run's page, reconnecting, is refused by
/// the new view and says so instead of trying for ever; the new run's
/// own page is served.
#[test]
fn a_page_of_an_earlier_run_on_the_address_says_so() {
    let Some((_scratch, out, scene)) = study_folders("browser-rerun") else {
        return;
    };
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
        .to_string();
    let mut first = Study::start_as(&out, &scene, "P01", &port);
    let d = Driver::start();
    d.cmd("POST", "url", serde_json::json!({"url": first.participant}));
    d.until("return window.lmFrames > 2", Duration::from_secs(30));
    // The first run ends as a crash ends it: no word to the page.
    first.child.kill().unwrap();
    first.child.wait().unwrap();
    let _ = first.log.join();
    d.until(
        "return document.getElementById('status').textContent.startsWith('reconnecting')",
        Duration::from_secs(30),
    );
    let mut second = Study::start_as(&out, &scene, "P02", &port);
    assert_ne!(second.token, first.token);
    d.until("return window.lmRefused === true", Duration::from_secs(30));
    let said = d.js("return document.getElementById('status').textContent");
    assert!(
        said.as_str().unwrap().contains("of an earlier session"),
        "{said}"
    );
    assert_eq!(d.js("return window.lmConnects"), 1, "never connected again");
    // The new run's own page connects.
    d.cmd(
        "POST",
        "url",
        serde_json::json!({"url": second.participant}),
    );
    d.until("return window.lmFrames > 2", Duration::from_secs(30));
    drop(d);
    let _ = second.child.kill();
    let _ = second.child.wait();
    let _ = second.log.join();
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
    let Some((_scratch, out, scene)) = study_folders("browser-measure") else {
        return;
    };
    let mut s = Study::start(&out, &scene);
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
