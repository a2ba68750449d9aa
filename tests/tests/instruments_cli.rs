//! `lmhost gauge read` and `lmhost stage move|position|home` end to end:
//! the simulated twins (`--port sim`), and the real serial drivers over a
//! pty whose other end speaks the instrument's protocol (an IMADA gauge,
//! a Mark-10 that refuses, a Chuo Seiki QT controller); bad input is one
//! line and exit 2, a failed instrument one line and exit 1.

use std::io::{Read, Write};
use std::process::Output;

use lmhost::device::instruments::FingerPad;

mod link_support;
use link_support::{ok, one_line_error, run};

fn fails(o: &Output, code: i32, needle: &str) {
    let err = one_line_error(o, code);
    assert!(err.contains(needle), "{err}");
}

#[test]
fn the_gauge_twin_reads_the_finger_pad_at_its_depth() {
    // `gauge read` of the twin 2 mm into the pad for `secs`, and `more`.
    let read = |secs: &str, more: &[&str]| {
        let mut args = vec!["gauge", "read", "--port", "sim", "--sim-depth", "2"];
        args.extend(["--for", secs]);
        args.extend_from_slice(more);
        ok(&args)
    };
    let out = read("0.4", &["--json"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let want = FingerPad::TYPICAL.force_at_depth_n(2.0);
    let median = v["median_n"].as_f64().unwrap();
    assert!((median - want).abs() <= 0.011, "{median} vs {want}");
    assert_eq!(v["series"]["samples"].as_array().unwrap().len(), 20);
    // As text: the readings counted as read (a series of one period
    // takes one; a shorter one is refused, as taking one whatever it asks).
    for (secs, said) in [
        ("0.4", "of 20 readings over 0.4 s"),
        ("0.02", "of 1 reading over 0.02 s"),
    ] {
        let out = read(secs, &[]);
        assert!(out.contains(said), "{out}");
    }
    // Off the finger: zero, within the noise.
    let out = ok(&["gauge", "read", "--port", "sim"]);
    let f: f64 = out.trim().trim_end_matches(" N").parse().unwrap();
    assert!(f.abs() <= 0.01, "{out}");
}

#[test]
fn the_stage_twin_moves_at_its_speed() {
    let out = ok(&["stage", "move", "--port", "sim", "--to", "1", "--json"]);
    let m: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(m["at_mm"].as_f64(), Some(1.0));
    // 1 mm at 5 mm/s cannot take less than 0.2 s.
    assert!(m["took_s"].as_f64().unwrap() >= 0.19, "{out}");
    assert_eq!(
        ok(&["stage", "position", "--port", "sim"]).trim(),
        "at 0 mm"
    );
}

#[test]
fn bad_input_is_one_line_and_exit_2() {
    let table: [(&[&str], &str); 9] = [
        (
            &["stage", "move", "--port", "sim", "--to", "60"],
            "outside the stage's soft limits 0..=50 mm",
        ),
        (
            &["stage", "move", "--port", "/dev/ttyUSB9", "--to", "1"],
            "both --min and --max",
        ),
        (
            &[
                "stage", "move", "--port", "sim", "--min", "5", "--max", "1", "--to", "1",
            ],
            "min < max",
        ),
        (
            &[
                "stage", "move", "--port", "sim", "--to", "1", "--speed", "0",
            ],
            "stage speed 0 mm/s",
        ),
        (
            &["gauge", "read", "--port", "sim", "--for", "-1"],
            "sampling duration -1 s",
        ),
        (
            &[
                "gauge", "read", "--port", "sim", "--for", "1", "--rate", "5000",
            ],
            "sampling rate 5000 Hz",
        ),
        (
            &["gauge", "read", "--port", "sim", "--for", "0.001"],
            "sampling rate 50 Hz is less than one reading in 0.001 s: allowed 1000..=1000 Hz",
        ),
        (
            &["gauge", "read", "--port", "/dev/null", "--sim-depth", "1"],
            "needs port sim",
        ),
        (
            &["gauge", "read", "--port", "sim", "--model", "kistler"],
            "kistler",
        ),
    ];
    for (args, needle) in table {
        fails(&run(args), 2, needle);
    }
}

#[test]
fn a_missing_port_is_a_failed_operation_naming_it() {
    fails(
        &run(&["gauge", "read", "--port", "/dev/lmhost-no-gauge"]),
        1,
        "/dev/lmhost-no-gauge: no such file",
    );
    let o = run(&[
        "stage",
        "move",
        "--port",
        "/dev/lmhost-no-stage",
        "--min",
        "0",
        "--max",
        "5",
        "--to",
        "1",
    ]);
    fails(&o, 1, "/dev/lmhost-no-stage: no such file");
}

/// A pty whose master end answers each request line with `answer`. The
/// slave is held open for the test's life, so the peer never sees a
/// hang-up between the binary's open and close; the peer thread ends with
/// the test process.
fn peer(answer: impl Fn(&str) -> String + Send + 'static) -> (String, std::os::fd::OwnedFd) {
    let (master, slave, path) = lmhost::device::simdev::raw_pty().unwrap();
    let mut master = std::fs::File::from(master);
    std::thread::spawn(move || {
        let mut line = Vec::new();
        let mut b = [0u8; 64];
        while let Ok(n) = master.read(&mut b) {
            for &c in &b[..n] {
                if c != b'\r' && c != b'\n' {
                    line.push(c);
                } else if !line.is_empty() {
                    let reply = answer(&String::from_utf8_lossy(&line));
                    if master.write_all(reply.as_bytes()).is_err() {
                        return;
                    }
                    line.clear();
                }
            }
        }
    });
    (path, slave)
}

#[test]
fn an_imada_gauge_set_to_kgf_is_read_in_newtons() {
    let (path, _slave) = peer(|req| {
        if req == "D" {
            "+0.050KTO\r".into()
        } else {
            String::new()
        }
    });
    let out = ok(&["gauge", "read", "--port", &path, "--model", "imada"]);
    assert_eq!(out.trim(), "0.490 N (0.05 kgf as sent)");
}

#[test]
fn a_mark10_that_refuses_says_so() {
    let (path, _slave) = peer(|_| "*10\r\n".into());
    let o = run(&["gauge", "read", "--port", &path, "--model", "mark10"]);
    fails(&o, 1, &format!("{path}: gauge answered ? with error *10"));
}

#[test]
fn a_qt_controller_moves_the_stage() {
    use std::sync::{Arc, Mutex};
    let target = Arc::new(Mutex::new(0i64));
    let t = target.clone();
    let (path, _slave) = peer(move |req| {
        let mut at = t.lock().unwrap();
        let reply = match req {
            "?:CHUOSEIKI" => "CHUOSEIKI".to_owned(),
            "Q:A0" => format!("{}{:08}K", if *at < 0 { '-' } else { '+' }, at.abs()),
            "Q:A2" => "K".to_owned(),
            _ if req.starts_with("AGO:A") => {
                *at = req[5..].parse().unwrap();
                String::new()
            }
            _ => String::new(),
        };
        format!("{reply}\r\n")
    });
    let out = ok(&[
        "stage",
        "move",
        "--port",
        &path,
        "--min",
        "0",
        "--max",
        "20",
        "--to",
        "4",
        "--step-um",
        "0.5",
    ]);
    assert!(out.starts_with("at 4 mm (from 0 mm"), "{out}");
    assert_eq!(*target.lock().unwrap(), 8000, "4 mm at 0.5 µm per pulse");
}
