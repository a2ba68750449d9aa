//! `lmhost stream` against `lmhost sim`: every input kind, filters, the
//! reflector mirror, and bad input.

use std::process::{Command, Stdio};

mod link_support;
use link_support::{
    BRIEF_HOLD, Sim, assert_fields, json, lmhost, ok, run, scratch_dir, spread, stream_json,
    stream_stdin, success_json,
};

#[test]
fn stdin_csv_and_json_lines_all_reach_the_device() {
    let sim = Sim::uploaded(&[]);
    let mut input = String::from("t,x,y,z,present\n");
    for i in 0..50 {
        input.push_str(&format!("{},0.5,0,200,1\n", i as f64 / 90.0));
    }
    input.push_str(r#"{"t": 0.6, "x": 0.5, "y": 0, "z": 200}"#);
    input.push('\n');
    let out = stream_stdin(&sim.port, &["--json", "--filter", "gaussian"], &input);
    let v = success_json(&out);
    assert_eq!(v["samples"], 51, "{v}");
    assert_eq!(v["acked"], 51);
    // Each ack's latency, summarised: host receipt → device ack.
    assert!(spread(&v, &v, "ack_us")[0] > 0.0, "{v}");
    assert_eq!(v["device_last_seq"], v["last_seq"], "{v}");
    assert_eq!(v["device_state"], "Playing", "{v}");
}

#[test]
fn a_bad_line_is_a_one_line_input_error() {
    let sim = Sim::start(&[]);
    let out = stream_stdin(&sim.port, &[], "0,0,0,200,1\n0.1,0,0,200,maybe\n");
    assert_eq!(out.status.code(), Some(2));
    // The device's summary (it plays the default stimulus: nothing had
    // played), then the one error line.
    let err = String::from_utf8_lossy(&out.stderr);
    let errors: Vec<_> = err.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 1, "{err}");
    assert_eq!(err.lines().last(), errors.first().copied(), "{err}");
    assert!(
        errors[0].contains("line 2") && errors[0].contains("present"),
        "{err}"
    );
}

/// Each stream plays the entry the device played last again (a
/// presentation lasts only while its host holds it) and reports the
/// device's state at its end.
#[test]
fn finger_leaving_mutes_and_returning_resumes() {
    let sim = Sim::uploaded(&[]);
    let state = |input: &str| {
        success_json(&stream_stdin(&sim.port, &["--json"], input))["device_state"].clone()
    };
    assert_eq!(state("0,0,0,200,1\n0.011,0,0,200,1\n"), "Playing");
    assert_eq!(state("0,0,0,200,1\n0.011,0,0,200,0\n"), "Muted");
    assert_eq!(state("0,0,0,200,0\n0.011,0,0,200,1\n"), "Playing");
    // Each stream left it silent.
    let st = json(&["status", "--port", &sim.port, "--json"]);
    assert_fields(&st, &["state", "slot"], serde_json::json!(["Stopped", 0]));
}

#[test]
fn centroids_are_mirrored_through_the_scene_reflector() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/paper.toml");
    let sim = Sim::start(&[]);
    ok(&[
        "upload", "--port", &sim.port, "--scene", scene, "--hold", BRIEF_HOLD,
    ]);
    // The finger 1 mm along x and 2 mm above the paper's centre (0, 30, 30);
    // the reflector is z = 0, so in drive space that is 2 mm further down.
    let out = stream_stdin(
        &sim.port,
        &["--scene", scene, "--filter", "none", "--json"],
        "0,1,30,32,1\n",
    );
    let v = success_json(&out);
    assert_eq!(
        v["device_correction_um"],
        serde_json::json!([1000, 0, -2000]),
        "{v}"
    );
}

#[test]
fn udp_datagrams_are_streamed() {
    let sim = Sim::uploaded(&[]);
    let port = {
        let probe = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        probe.local_addr().unwrap().port()
    };
    let child = Command::new(lmhost())
        .args([
            "stream",
            "--port",
            &sim.port,
            "--udp",
            &port.to_string(),
            "--seconds",
            "1",
            "--json",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(500));
    let tx = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    for i in 0..20 {
        let line = format!(r#"{{"t":{},"x":0,"y":0,"z":200}}"#, i as f64 / 90.0);
        tx.send_to(line.as_bytes(), ("127.0.0.1", port)).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(11));
    }
    let out = child.wait_with_output().unwrap();
    let v = success_json(&out);
    assert_eq!(v["acked"], 20, "{v}");
}

#[test]
fn synthetic_finger_reports_every_filter() {
    let sim = Sim::uploaded(&[]);
    let v = stream_json(&sim.port, &["--synthetic", "--seconds", "1", "--fast"]);
    assert_eq!(v["acked"], 90, "{v}");
    let filters = v["filters"].as_array().unwrap();
    assert_eq!(filters.len(), 4);
    let lag = |name: &str| {
        filters.iter().find(|f| f["filter"] == name).unwrap()["lag_ms"]
            .as_f64()
            .unwrap()
    };
    assert!(lag("kalman") <= lag("gaussian") / 3.0, "{v}");
}

#[test]
fn recorded_file_replays() {
    let sim = Sim::uploaded(&[]);
    let dir = scratch_dir("recorded-file-replays");
    let path = dir.join("track.csv");
    let text: String = (0..30)
        .map(|i| format!("{},0,0,200,1\n", i as f64 / 90.0))
        .collect();
    std::fs::write(&path, text).unwrap();
    let v = stream_json(&sim.port, &["--input", path.to_str().unwrap()]);
    assert_eq!(v["acked"], 30, "{v}");
    // Replayed at its time stamps: 29 frame intervals.
    assert!(v["seconds"].as_f64().unwrap() >= 29.0 / 90.0, "{v}");
    let out = run(&[
        "stream",
        "--port",
        &sim.port,
        "--input",
        "/nonexistent/track.csv",
    ]);
    assert_eq!(out.status.code(), Some(2));
}
