//! `lmhost session` end to end: the real binary against `lmhost sim` and
//! the AUTD3 emulator, over stdio and the Unix control socket.

use std::io::{BufRead as _, BufReader, Write as _};
use std::os::unix::net::UnixStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[allow(dead_code)]
mod gated_device;
mod link_support;
mod session_support;
use link_support::{Sim, lmhost, ok, one_line_error, run_stdin, send_signal, udp_counts};
use session_support::*;

#[test]
fn stdio_control_presents_timed_on_phases_and_ends_silent() {
    for port in ["autd3:emulator", "sim"] {
        let sim = (port == "sim").then(|| Sim::start(&[]));
        let port = sim.as_ref().map_or(port.to_owned(), |s| s.port.clone());
        let script = concat!(
            r#"{"cmd":"library"}"#,
            "\n",
            r#"{"cmd":"present","stimulus":"lms-25hz-a3","gate":"untracked","on_s":0.4,"off_s":0.1,"repeat":2}"#,
            "\n",
            r#"{"cmd":"present","stimulus":"nope"}"#,
            "\n",
        );
        let out = run_stdin(
            &[
                "session",
                "--library",
                &library(),
                "--port",
                &port,
                "--control",
                "-",
            ],
            script.as_bytes(),
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{port}: {err}");
        let v = lines(&out.stdout);
        let lib = v.iter().find(|r| r["cmd"] == "library").unwrap();
        assert_eq!(lib["stimuli"].as_array().unwrap().len(), 15, "{port}");
        let refused = v.iter().find(|r| r["ok"] == false).unwrap();
        assert!(
            refused["error"]
                .as_str()
                .unwrap()
                .contains("no stimulus `nope`"),
            "{refused}"
        );
        let offsets = events(&v, "offset");
        assert_eq!(offsets.len(), 2, "{port}: {v:?}");
        let dwell_s = lib["stimuli"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["id"] == "lms-25hz-a3")
            .unwrap()["dwell_us"]
            .as_f64()
            .unwrap()
            / 1e6;
        for o in offsets {
            assert_eq!(o["reason"], "timer");
            let d = o["device_presented_s"].as_f64().unwrap();
            assert!(
                (d - 0.4).abs() <= dwell_s + 0.01,
                "{port}: {d} s (dwell {dwell_s})"
            );
        }
        // Ended by the end of its input, and said so.
        assert_eq!(v.last().unwrap()["event"], "closed", "{port}");
        assert_eq!(v.last().unwrap()["reason"], "end_of_input", "{port}");
        assert!(err.contains("session ended (end_of_input)"), "{err}");
        assert!(err.contains("the array is silent"), "{err}");
    }
}

#[test]
fn bad_session_flags_and_files_are_one_line_input_errors() {
    let dir = tempdir();
    let bad_lib = dir.join("bad.toml");
    std::fs::write(&bad_lib, "[[stimulus]]\nid = \"x\"\nradius = -3\n").unwrap();
    let not_socket = dir.join("plain");
    std::fs::write(&not_socket, "").unwrap();
    let lib = library();
    // `session --library L --control C EXTRA… --port autd3:emulator`.
    let cases: [(&str, &str, &[&str], &str); 5] = [
        ("/nonexistent.toml", "-", &[], "nonexistent"),
        (
            bad_lib.to_str().unwrap(),
            "-",
            &[],
            "stimulus 1 (`x`): radius",
        ),
        (&lib, not_socket.to_str().unwrap(), &[], "not a socket"),
        (&lib, "-", &["--tcp", "5000"], "--tcp"),
        (&lib, "-", &["--stream", "-"], "stdin"),
    ];
    for (library, control, extra, needle) in cases {
        let mut args = vec!["session", "--library", library, "--control", control];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--port", "autd3:emulator"]);
        let err = one_line_error(&run_stdin(&args, b""), 2);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

#[test]
fn a_socket_client_going_away_stops_the_stimulus_and_quit_ends_the_session() {
    let sim = Sim::start(&[]);
    let (_dir, sock, log) = socket_and_log();
    let child = session(&[&sim.port], &sock, Some(&log)).spawn().unwrap();
    {
        let (mut s, mut r) = control(&sock);
        use std::os::unix::fs::PermissionsExt as _;
        let mode = std::fs::metadata(&sock).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        accepted(&mut s, &mut r, r#"{"cmd":"subscribe"}"#);
        accepted(
            &mut s,
            &mut r,
            r#"{"cmd":"present","stimulus":"lms-25hz-a4","gate":"untracked"}"#,
        );
        // The onset arrives as an event on this connection.
        loop {
            let mut line = String::new();
            r.read_line(&mut line).unwrap();
            if line.contains(r#""event":"onset""#) {
                break;
            }
        }
        let st = send(&mut s, &mut r, r#"{"cmd":"status"}"#);
        assert_eq!(st["status"]["state"], "playing", "{st}");
        // Dropped here: the controlling client goes away.
    }
    let (mut s, mut r) = control(&sock);
    let end = Instant::now() + Duration::from_secs(10);
    loop {
        let st = send(&mut s, &mut r, r#"{"cmd":"status"}"#);
        if st["status"]["state"] != "playing" {
            break;
        }
        assert!(
            Instant::now() < end,
            "still playing after the client left: {st}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    accepted(&mut s, &mut r, r#"{"cmd":"quit"}"#);
    let out = child.wait_with_output().unwrap();
    exited_0(&out, "");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("session ended (quit)"), "{err}");
    assert!(!sock.exists(), "the socket is removed at the end");
    let text = std::fs::read_to_string(&log).unwrap();
    let v = lines(text.as_bytes());
    let off = events(&v, "offset");
    assert_eq!(off.len(), 1, "{text}");
    assert_eq!(off[0]["reason"], "disconnect");
    assert_eq!(v.last().unwrap()["event"], "closed");
    assert_eq!(v.last().unwrap()["reason"], "quit");
    assert!(text.ends_with('\n'));
}

#[test]
fn sigterm_ends_the_session_silent_with_a_closed_event() {
    let (_dir, sock, log) = socket_and_log();
    let child = session(&["autd3:emulator", "--synthetic"], &sock, Some(&log))
        .args(["--on-disconnect", "continue"])
        .spawn()
        .unwrap();
    {
        let _control = presenting(&sock, r#"{"cmd":"present","stimulus":"lmm-5hz-a3"}"#);
        std::thread::sleep(Duration::from_millis(300));
    }
    send_signal(&child, "TERM");
    exited_0(&child.wait_with_output().unwrap(), "");
    let v = logged(&log);
    assert!(
        !events(&v, "finger").is_empty(),
        "the synthetic finger was seen"
    );
    let off = events(&v, "offset");
    assert_eq!(off.len(), 1);
    assert_eq!(off[0]["reason"], "sigterm");
    assert_eq!(v.last().unwrap()["event"], "closed");
    assert_eq!(v.last().unwrap()["reason"], "sigterm");
}

#[test]
fn the_finger_tracked_in_recorded_depth_frames_gates_a_tracked_presentation() {
    let dir = tempdir();
    let rec = dir.join("d.npy");
    let scene = format!("{}/../scenes/paper.toml", env!("CARGO_MANIFEST_DIR"));
    let rec_arg = rec.to_str().unwrap();
    ok(&[
        "track",
        "--synthetic",
        "--scene",
        &scene,
        "--seconds",
        "1.5",
        "--record",
        rec_arg,
    ]);
    // An endless tracked presentation, stopped once the finger has
    // unmuted it: however slowly the replay runs on a loaded machine.
    let mut child = Command::new(lmhost())
        .args(["session", "--library", &library(), "--scene", &scene])
        .args(["--port", "autd3:emulator", "--control", "-"])
        .args(["--depth", rec.to_str().unwrap()])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // A watchdog: a session that never unmutes ends the test, not CI.
    let pid = child.id().to_string();
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let watch = done.clone();
    std::thread::spawn(move || {
        std::thread::sleep(Duration::from_secs(90));
        if !watch.load(std::sync::atomic::Ordering::SeqCst) {
            let _ = Command::new("kill").args(["-9", &pid]).status();
        }
    });
    let mut stdin = child.stdin.take().unwrap();
    writeln!(stdin, r#"{{"cmd":"present","stimulus":"lms-25hz-a3"}}"#).unwrap();
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    let mut seen = String::new();
    loop {
        let mut line = String::new();
        if stdout.read_line(&mut line).unwrap() == 0 {
            panic!("the session ended before the finger unmuted it: {seen}");
        }
        seen.push_str(&line);
        if line.contains(r#""event":"unmute""#) {
            break;
        }
    }
    writeln!(stdin, r#"{{"cmd":"stop"}}"#).unwrap();
    drop(stdin);
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut stdout, &mut rest).unwrap();
    seen.push_str(&rest);
    let out = child.wait_with_output().unwrap();
    done.store(true, std::sync::atomic::Ordering::SeqCst);
    exited_0(&out, "");
    let out = std::process::Output {
        stdout: seen.into_bytes(),
        ..out
    };
    let v = lines(&out.stdout);
    // The synthetic finger arrives after a while: muted until then.
    assert!(
        events(&v, "finger").iter().any(|e| e["present"] == true),
        "{v:?}"
    );
    assert!(!events(&v, "mute").is_empty(), "{v:?}");
    assert!(!events(&v, "unmute").is_empty(), "{v:?}");
    let off = events(&v, "offset");
    let f = off[0]["present_fraction"].as_f64().unwrap();
    assert!(f > 0.0 && f < 1.0, "{}", off[0]);
    // The recording is 105 MB: not left behind.
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn hostile_control_lines_get_one_line_refusals_and_the_session_stays_up() {
    let (_dir, sock, _) = socket_and_log();
    let child = session(&["autd3:emulator"], &sock, None).spawn().unwrap();
    let (mut s, mut r) = control(&sock);
    let mut reply = |s: &mut UnixStream, bytes: &[u8]| -> serde_json::Value {
        s.write_all(bytes).unwrap();
        let mut line = String::new();
        r.read_line(&mut line).unwrap();
        serde_json::from_str(&line).unwrap_or_else(|e| panic!("{e}: {line}"))
    };
    // A 100 kB line: refused without being buffered whole.
    let mut long = vec![b'x'; 100_000];
    long.push(b'\n');
    let v = reply(&mut s, &long);
    assert_eq!(v["ok"], false);
    assert!(
        v["error"].as_str().unwrap().contains("longer than 4096"),
        "{v}"
    );
    for (bytes, needle) in [
        (&b"\xff\xfe\x00garbage\n"[..], "bad command"),
        (b"[1,2,3]\n", "bad command"),
        (
            b"{\"cmd\":\"present\",\"stimulus\":\"lms-5hz-a3\",\"on_s\":1e308}\n",
            "on_s",
        ),
        (
            b"{\"cmd\":\"present\",\"stimulus\":\"lms-5hz-a3\",\"repeat\":4294967296}\n",
            "bad command",
        ),
        (
            b"{\"cmd\":\"present\",\"stimulus\":\"../../etc/passwd\"}\n",
            "no stimulus",
        ),
    ] {
        let v = reply(&mut s, bytes);
        assert_eq!(v["ok"], false, "{v}");
        let e = v["error"].as_str().unwrap();
        assert!(e.contains(needle) && !e.contains('\n'), "{e}");
    }
    // Still serving.
    let v = reply(&mut s, b"{\"cmd\":\"status\"}\n");
    assert_eq!(v["ok"], true, "{v}");
    // A lone CR ends a command as LF and CRLF do: two commands, two
    // replies (the pair was one line, refused for its CR).
    let v = reply(&mut s, b"{\"cmd\":\"status\"}\r{\"cmd\":\"status\"}\n");
    assert_eq!(v["ok"], true, "{v}");
    let v = reply(&mut s, b"");
    assert_eq!(
        (&v["cmd"], &v["ok"]),
        (&"status".into(), &true.into()),
        "{v}"
    );
    let v = reply(&mut s, b"{\"cmd\":\"quit\"}\n");
    assert_eq!(v["ok"], true, "{v}");
    exited_0(&child.wait_with_output().unwrap(), "");
}

/// Issue 26: a session playing an untracked presentation on the LM
/// firmware (which plays on by itself) is ended by `signal` like SIGTERM:
/// the array is silent afterwards, as `lmhost status` shows.
fn a_signal_leaves_the_array_silent(signal: &str) {
    let sim = Sim::start(&[]);
    let (_dir, sock, log) = socket_and_log();
    let mut child = session(&[&sim.port], &sock, Some(&log))
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    {
        let (mut s, mut r) = presenting(
            &sock,
            r#"{"cmd":"present","stimulus":"lms-5hz-a3","gate":"untracked"}"#,
        );
        let st = send(&mut s, &mut r, r#"{"cmd":"status"}"#);
        assert_eq!(st["status"]["state"], "playing", "{st}");
        send_signal(&child, signal);
        // The connection stays open until the session is gone.
        let end = Instant::now() + Duration::from_secs(20);
        while child.try_wait().unwrap().is_none() {
            assert!(Instant::now() < end, "SIG{signal}: the session did not end");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    let out = child.wait_with_output().unwrap();
    exited_0(&out, &format!("SIG{signal}: "));
    // What ended it, by name: in the end line and in the log.
    let why = format!("sig{}", signal.to_lowercase());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("session ended ({why})")),
        "SIG{signal}: {err}"
    );
    let status = Command::new(lmhost())
        .args(["status", "--port", &sim.port, "--json"])
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&status.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&status.stderr)));
    assert!(
        matches!(v["state"].as_str(), Some("Stopped" | "Idle")),
        "SIG{signal}: the array plays on: {v}"
    );
    let ev = logged(&log);
    assert_eq!(ev.last().unwrap()["event"], "closed", "SIG{signal}");
    assert_eq!(ev.last().unwrap()["reason"], why.as_str(), "SIG{signal}");
    assert_eq!(
        events(&ev, "offset")[0]["reason"],
        why.as_str(),
        "SIG{signal}"
    );
}

/// The state `lmhost status` reads from `port`.
fn device_state(port: &str) -> serde_json::Value {
    let status = Command::new(lmhost())
        .args(["status", "--port", port, "--json"])
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&status.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&status.stderr)));
    v["state"].clone()
}

#[test]
fn a_signal_during_the_set_up_ends_the_session_with_its_end_lines_and_the_array_silent() {
    // The device holds the library's third upload: the signal comes while
    // the session uploads it, two entries resident.
    let dev = gated_device::Gated::start(3);
    let (_dir, sock, log) = socket_and_log();
    let child = session(&[&dev.port, "--timeout-ms", "60000"], &sock, Some(&log))
        .spawn()
        .unwrap();
    dev.wait_held(Duration::from_secs(120));
    send_signal(&child, "TERM");
    dev.release();
    let out = child.wait_with_output().unwrap();
    exited_0(&out, "SIGTERM in the set-up: ");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("lmhost: session interrupted by SIGTERM during set-up (uploading stimulus `")
            && err.contains(", 3 of 15); the array is silent\n"),
        "{err}"
    );
    assert!(!err.contains("error"), "{err}");
    // The log ends as at any end.
    let ev = logged(&log);
    assert_eq!(ev.len(), 1, "{ev:?}");
    assert_eq!(ev[0]["event"], "closed");
    assert_eq!(ev[0]["reason"], "sigterm");
    assert!(!sock.exists(), "the socket is removed at the end");
    let state = device_state(&dev.port);
    assert!(
        matches!(state.as_str(), Some("Stopped" | "Idle")),
        "the device plays: {state}"
    );
}

#[test]
fn a_device_that_restarts_mid_session_ends_it_naming_the_port() {
    let dev = gated_device::Gated::start(0);
    let mut child = Command::new(lmhost())
        .args(["session", "--library", &library(), "--port", &dev.port])
        .args(["--control", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    writeln!(
        stdin,
        r#"{{"cmd":"present","stimulus":"lms-5hz-a3","gate":"untracked"}}"#
    )
    .unwrap();
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    let stdout = child.stdout.take().unwrap();
    std::thread::spawn(move || {
        for l in BufReader::new(stdout).lines() {
            let _ = tx.send(l.unwrap());
        }
    });
    let mut seen = String::new();
    let next = |seen: &mut String| match rx.recv_timeout(Duration::from_secs(60)) {
        Ok(l) => {
            seen.push_str(&l);
            seen.push('\n');
            Some(l)
        }
        Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => None,
        Err(e) => {
            let _ = Command::new("kill")
                .args(["-9", &child.id().to_string()])
                .status();
            panic!("the session went on ({e}): {seen}");
        }
    };
    while !next(&mut seen)
        .unwrap_or_else(|| panic!("the session ended before its onset"))
        .contains(r#""event":"onset""#)
    {}
    // The device resets while it plays: its library is gone. The session
    // ends by itself (stdin stays open).
    dev.restart();
    while next(&mut seen).is_some() {}
    let out = child.wait_with_output().unwrap();
    drop(stdin);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!("the device on {} restarted", dev.port)),
        "{err}"
    );
    assert!(
        err.contains("the sequences lmhost uploaded are gone"),
        "{err}"
    );
    assert!(seen.contains(r#""event":"closed""#), "{seen}");
}

#[test]
fn sigint_leaves_the_array_silent() {
    a_signal_leaves_the_array_silent("INT");
}

#[test]
fn sighup_leaves_the_array_silent() {
    a_signal_leaves_the_array_silent("HUP");
}

#[test]
fn sigquit_leaves_the_array_silent() {
    a_signal_leaves_the_array_silent("QUIT");
}

#[test]
fn sigusr1_leaves_the_array_silent() {
    a_signal_leaves_the_array_silent("USR1");
}

#[test]
fn sigterm_leaves_the_array_silent() {
    a_signal_leaves_the_array_silent("TERM");
}

/// `lmhost session` on the emulator with its finger on `--udp`, `extra`
/// beside it, commands on stdin and stderr piped (stdout as `stdout`
/// says); returned once the source has bound its port (ours cannot),
/// with that port.
fn session_on_udp(extra: &[&str], stdout: Stdio) -> (std::process::Child, u16) {
    let port = {
        let probe = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        probe.local_addr().unwrap().port()
    };
    let child = Command::new(lmhost())
        .args(["session", "--library", &library()])
        .args(["--port", "autd3:emulator", "--control", "-"])
        .args(["--udp", &port.to_string()])
        .args(extra)
        .stdin(Stdio::piped())
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while std::net::UdpSocket::bind(("127.0.0.1", port)).is_ok() {
        assert!(t0.elapsed() < Duration::from_secs(60), "never bound");
        std::thread::sleep(Duration::from_millis(50));
    }
    (child, port)
}

#[test]
fn a_udp_finger_source_says_what_it_counted_at_the_end() {
    let (mut child, port) = session_on_udp(&[], Stdio::null());
    let tx = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    for i in 0..5 {
        let line = format!("{},0,0,200,1", i as f64 / 90.0);
        tx.send_to(line.as_bytes(), ("127.0.0.1", port)).unwrap();
    }
    tx.send_to(b"not a centroid", ("127.0.0.1", port)).unwrap();
    std::thread::sleep(Duration::from_millis(500));
    drop(child.stdin.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(err.contains(&udp_counts(port, 6, 1)), "{err}");
}

#[test]
fn a_streamed_finger_passes_the_plausibility_gate_and_its_counts_end_the_session() {
    let (mut child, port) = session_on_udp(&["--filter", "none"], Stdio::piped());
    let mut stdin = child.stdin.take().unwrap();
    writeln!(stdin, r#"{{"cmd":"present","stimulus":"lms-25hz-a3"}}"#).unwrap();
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    let mut seen = String::new();
    let mut read_until = |what: &[&str], seen: &mut String| loop {
        let mut line = String::new();
        if stdout.read_line(&mut line).unwrap() == 0 {
            panic!("the session ended before {what:?}: {seen}");
        }
        seen.push_str(&line);
        if what.iter().all(|w| line.contains(w)) {
            break;
        }
    };
    read_until(&[r#""event":"onset""#], &mut seen);
    // A finger at rest at 90 Hz, then lifted: sample 3 is stamped 30
    // years ahead, sample 6 lies 5 m away.
    let tx = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    for i in 0..90 {
        let t = if i == 3 {
            1e9
        } else {
            100.0 + f64::from(i) / 90.0
        };
        let x = if i == 6 { 5000.0 } else { 0.0 };
        let line = format!("{t},{x},0,200,1");
        tx.send_to(line.as_bytes(), ("127.0.0.1", port)).unwrap();
        std::thread::sleep(Duration::from_millis(2));
    }
    tx.send_to(b"101.0,0,0,200,0", ("127.0.0.1", port)).unwrap();
    // The lifted finger is the last sample: every one was read once the
    // session says the finger left.
    read_until(&[r#""event":"finger""#, r#""present":false"#], &mut seen);
    writeln!(stdin, r#"{{"cmd":"stop"}}"#).unwrap();
    drop(stdin);
    std::io::Read::read_to_string(&mut stdout, &mut seen).unwrap();
    let out = child.wait_with_output().unwrap();
    exited_0(&out, "");
    let v = lines(seen.as_bytes());
    // The good samples after the wild ones steered it, never out of range.
    assert!(
        events(&v, "mute")
            .iter()
            .all(|e| e["reason"] != "centroid_out_of_range"),
        "{v:?}"
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(
            "lmhost: finger: 91 samples, 2 dropped as implausible (0 out of order, 1 time jump, 1 out of range, 0 jumps)"
        ),
        "{err}"
    );
    // The `closed` event carries the same counts by the same classes.
    link_support::assert_closed_counts(v.last().unwrap(), 91, [0, 1, 1, 0]);
}
