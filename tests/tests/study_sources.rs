//! `lmhost study run` takes the finger sources `lmhost session` takes
//! (one set of flags): here a recorded centroid stream, which plays at its
//! time stamps, so a recording longer than the study keeps the finger on
//! the marker for the whole run (read as fast as the disk gives it, it
//! ended at once and the run stopped on it).

use std::path::Path;

#[allow(dead_code)]
mod gated_device;
mod link_support;
use link_support::{send_signal, udp_counts};
#[allow(dead_code)]
mod study_support;
use study_support::*;

/// Two of the paper's stimuli, one set, one question, untracked
/// (`study_support/two.toml`).
fn protocol(d: &Path) -> std::path::PathBuf {
    let p = d.join("two.toml");
    let text =
        include_str!("study_support/two.toml").replace("{library}", &studies("paper-library.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

/// `study run` of [`protocol`] on autd3's emulator for P01 into `d/out`,
/// then `extra`.
fn run_two(d: &Path, extra: &[&str]) -> std::process::Output {
    let proto = protocol(d);
    run_on(
        proto.to_str().unwrap(),
        "autd3:emulator",
        &d.join("out"),
        extra,
    )
    .output()
    .unwrap()
}

#[test]
fn a_recorded_stream_is_a_finger_source_played_at_its_time_stamps() {
    let d = scratch("sources");
    // 120 s of a finger resting at the centre, 20 samples a second.
    let rec = d.join("finger.csv");
    let lines: String = (0..2400)
        .map(|i| format!("{:.2},0,0,200,1\n", i as f64 * 0.05))
        .collect();
    std::fs::write(&rec, lines).unwrap();
    let answers = answers_file(&d, "3\n5\n");
    ok(&run_two(
        &d,
        &[
            "--responses",
            answers.to_str().unwrap(),
            "--stream",
            rec.to_str().unwrap(),
            "--filter",
            "none",
            "--seed",
            "1",
        ],
    ));
    let out = d.join("out");
    n_rows(&out.join("P01"), 2);
    let s = std::fs::read_to_string(out.join("P01/session.json")).unwrap();
    assert!(s.contains("stream:"), "{s}");
}

#[test]
fn the_session_flags_are_the_studys() {
    // Flags only `session` had: refused for what they are, not unknown.
    let d = scratch("sources-flags");
    let o = run_two(&d, &["--responses", "/dev/null", "--depth-stream", "-"]);
    says(
        &refused(&o),
        &["--scene is needed with --depth, --camera and --depth-stream"],
    );
}

/// The two-trial study (answers 3 and 5) on the emulator with its finger
/// on `--udp`, `extra` beside it; returned once the source has bound its
/// port (ours cannot), with that port.
fn study_on_udp(d: &std::path::Path, extra: &[&str]) -> (std::process::Child, u16) {
    study_on_udp_at(d, "autd3:emulator", extra)
}

/// [`study_on_udp`] on the device at `device`.
fn study_on_udp_at(
    d: &std::path::Path,
    device: &str,
    extra: &[&str],
) -> (std::process::Child, u16) {
    let port = {
        let probe = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        probe.local_addr().unwrap().port()
    };
    let answers = answers_file(d, "3\n5\n");
    let proto = protocol(d);
    let port_arg = port.to_string();
    let mut args = vec!["--responses", answers.to_str().unwrap(), "--udp", &port_arg];
    args.extend_from_slice(extra);
    let child = run_on(proto.to_str().unwrap(), device, &d.join("out"), &args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while std::net::UdpSocket::bind(("127.0.0.1", port)).is_ok() {
        assert!(t0.elapsed().as_secs() < 60, "never bound");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    (child, port)
}

#[test]
fn a_udp_finger_source_says_what_it_counted_at_the_end_of_a_study() {
    let d = scratch("sources-udp");
    let (mut child, port) = study_on_udp(&d, &["--filter", "none", "--seed", "1"]);
    // Two bad datagrams (garbage, and an empty one), then a finger resting
    // at the centre until the run ends: each trial waits for it.
    let tx = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    tx.send_to(b"not a centroid", ("127.0.0.1", port)).unwrap();
    tx.send_to(b"", ("127.0.0.1", port)).unwrap();
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let sender = {
        let done = done.clone();
        std::thread::spawn(move || {
            let mut sent = 0u32;
            while !done.load(std::sync::atomic::Ordering::SeqCst) {
                let line = format!("{},0,0,200,1", f64::from(sent) / 50.0);
                tx.send_to(line.as_bytes(), ("127.0.0.1", port)).unwrap();
                sent += 1;
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
        })
    };
    let t0 = std::time::Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(t0.elapsed().as_secs() < 120, "the study did not end");
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    done.store(true, std::sync::atomic::Ordering::SeqCst);
    sender.join().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    assert!(status.success(), "{err}");
    n_rows(&d.join("out/P01"), 2);
    // `lmhost: UDP 127.0.0.1:PORT: N datagrams, 2 skipped as bad, 0 lost ...`
    let head = format!("lmhost: UDP 127.0.0.1:{port}: ");
    let line = err
        .lines()
        .find_map(|l| l.strip_prefix(&head))
        .unwrap_or_else(|| panic!("no UDP line: {err}"));
    let n: u64 = line
        .split(' ')
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!(n >= 3, "{line}");
    assert!(
        line.ends_with("datagrams, 2 skipped as bad, 0 lost in the kernel's receive buffer"),
        "{line}"
    );
}

#[test]
fn a_study_stopped_by_a_signal_still_says_what_its_finger_source_counted() {
    let d = scratch("sources-udp-stop");
    // No finger ever comes: the first trial waits for it until SIGTERM.
    let (mut child, port) = study_on_udp(&d, &[]);
    // Stderr line by line: the signal goes once the first trial has begun
    // (a signal during the set-up ends the run before it has counts).
    let (lines, rx) = std::sync::mpsc::channel::<String>();
    let reader = {
        let stderr = child.stderr.take().unwrap();
        std::thread::spawn(move || {
            for l in std::io::BufRead::lines(std::io::BufReader::new(stderr)) {
                let _ = lines.send(l.unwrap());
            }
        })
    };
    let mut err = String::new();
    while !err.contains("trial 1/2") {
        let l = rx
            .recv_timeout(std::time::Duration::from_secs(60))
            .unwrap_or_else(|e| panic!("no first trial ({e}): {err}"));
        err.push_str(&l);
        err.push('\n');
    }
    // One garbage datagram and one centroid 5 m away, which the gate drops.
    let tx = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    tx.send_to(b"not a centroid", ("127.0.0.1", port)).unwrap();
    tx.send_to(b"1.0,5000,0,200,1", ("127.0.0.1", port))
        .unwrap();
    // Time for the trial's wait to take both (it polls its feed every few
    // milliseconds).
    std::thread::sleep(std::time::Duration::from_millis(1000));
    send_signal(&child, "TERM");
    child.wait().unwrap();
    reader.join().unwrap();
    err.extend(rx.try_iter().map(|l| l + "\n"));
    assert!(
        err.contains(&format!("lmhost: {}", udp_counts(port, 2, 1))),
        "{err}"
    );
    assert!(
        err.contains(
            "lmhost: finger: 1 sample, 1 dropped as implausible (0 out of order, 0 time jumps, 1 out of range, 0 jumps)"
        ),
        "{err}"
    );
    // The event log's `closed` carries the same counts by the same classes.
    let log = std::fs::read_to_string(d.join("out/P01/events.jsonl")).unwrap();
    let closed: serde_json::Value = serde_json::from_str(log.lines().last().unwrap()).unwrap();
    assert_eq!(closed["reason"], "sigterm", "{log}");
    link_support::assert_closed_counts(&closed, 1, [0, 0, 1, 0]);
}

#[test]
fn a_study_stopped_during_its_set_up_says_so_and_leaves_nothing_to_resume() {
    let d = scratch("sources-udp-set-up");
    // The device holds the library's third upload: the signal comes while
    // the study's set-up uploads it.
    let dev = gated_device::Gated::start(3);
    let (child, port) = study_on_udp_at(&d, &dev.port, &["--timeout-ms", "60000"]);
    dev.wait_held(std::time::Duration::from_secs(120));
    send_signal(&child, "TERM");
    dev.release();
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    // As a study stopped mid-run: exit 1, the source's counts, what was
    // kept.
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!("lmhost: {}", udp_counts(port, 0, 0))),
        "{err}"
    );
    assert!(err.contains("lmhost: finger: 0 samples"), "{err}");
    assert!(
        err.contains("error: interrupted by SIGTERM during set-up (uploading stimulus `")
            && err.contains(
                ", 3 of 15); the array is silent; nothing was written; run it again (without --resume)"
            ),
        "{err}"
    );
    assert!(!d.join("out/P01").exists(), "a folder was left");
    // `--resume` agrees.
    let resumed = run_on(
        protocol(&d).to_str().unwrap(),
        &dev.port,
        &d.join("out"),
        &["--resume", "--finger", "synthetic"],
    )
    .output()
    .unwrap();
    let again = String::from_utf8_lossy(&resumed.stderr);
    assert_eq!(resumed.status.code(), Some(2), "{again}");
    assert!(again.contains("nothing to resume"), "{again}");
    let status = std::process::Command::new(link_support::lmhost())
        .args(["status", "--port", &dev.port, "--json"])
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&status.stdout).unwrap();
    assert!(
        matches!(v["state"].as_str(), Some("Stopped" | "Idle")),
        "the device plays: {v}"
    );
}
