//! `lmhost ... --port autd3:...` end to end: the real binary against
//! autd3's firmware emulator (upload with read-back, the demo, streaming
//! with mute on absence, untracked play), its JSON reports and exit codes.

use std::path::Path;
use std::process::Command;

mod link_support;
use link_support::{
    emulator_json, fails, lmhost, run, scratch_dir, send_signal, spread, success_json,
};

#[test]
fn upload_to_the_emulator_reports_grid_timing_and_a_clean_readback() {
    let v = emulator_json("upload", &["--scene", &scene("paper.toml"), "--foci", "4"]);
    assert_eq!(v["steps"], 82);
    assert_eq!(v["dwell_us"], 2450.0);
    assert!(
        (v["freq_hz"].as_f64().unwrap() - 4.9776).abs() < 1e-3,
        "{v}"
    );
    assert_eq!(v["readback_mismatches"], 0);
    assert_eq!(v["transducers"], 996);
}

#[test]
fn bad_autd3_ports_and_limits_exit_2_missing_links_exit_1() {
    fails(&["upload", "--port", "autd3:nope"], 2);
    assert!(
        fails(
            &[
                "upload",
                "--port",
                "autd3:emulator",
                "--freq",
                "100",
                "--steps",
                "82",
            ],
            2
        )
        .contains("25 µs")
    );
    assert!(fails(&["upload", "--port", "autd3:ethercrab:eth0"], 1).contains("autd3-ethercrab"));
}

fn scene(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(name)
        .to_str()
        .unwrap()
        .to_owned()
}

#[test]
fn upload_reads_back_byte_exact_for_lm_s_and_lm_m_with_errors_vs_the_request() {
    for (foci, radius) in [("1", "2"), ("1", "6"), ("4", "3"), ("4", "6")] {
        let v = emulator_json("upload", &["--foci", foci, "--radius", radius]);
        assert_eq!(v["readback_mismatches"], 0, "{v}");
        let dwell = v["dwell_us"].as_f64().unwrap();
        assert_eq!(dwell % 25.0, 0.0, "{v}");
        assert!(dwell >= 1000.0, "{v}");
        let steps = v["steps"].as_f64().unwrap();
        let f = v["freq_hz"].as_f64().unwrap();
        assert!((f - 1e6 / (steps * dwell)).abs() < 1e-9, "{v}");
        assert!(
            (v["freq_error_hz"].as_f64().unwrap() - (f - 5.0)).abs() < 1e-9,
            "{v}"
        );
        let step = v["step_mm"].as_f64().unwrap();
        let r: f64 = radius.parse().unwrap();
        assert!(
            (step - 2.0 * std::f64::consts::PI * r / steps).abs() < 1e-9,
            "{v}"
        );
        assert!(
            (v["step_error_mm"].as_f64().unwrap() - (step - 0.23)).abs() < 1e-9,
            "{v}"
        );
        assert!(v["dwell_error_us"].is_number(), "{v}");
        assert_eq!(v["playing"], true);
        assert_eq!(v["mute_reason"], "waiting_for_tracking", "{v}");
    }
}

#[test]
fn untracked_upload_plays_at_once_and_no_play_does_not() {
    // With --hold, the report and then, after the hold, one status line
    // with what played: at least the 0.2 s held, counted in steps.
    let o = run(&[
        "upload",
        "--port",
        "autd3:emulator",
        "--untracked",
        "--hold",
        "0.2",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let [v, last] = &lines[..] else {
        panic!("want two JSON lines, got {lines:?}");
    };
    assert_eq!(v["untracked"], true);
    assert_eq!(v["mute_reason"], "none", "{v}");
    assert_eq!(v["hold_s"], 0.2);
    assert_eq!(last["counters"], "host clock", "{last}");
    let st = &last["status"];
    let (n, dwell) = (
        v["steps"].as_u64().unwrap(),
        v["dwell_us"].as_f64().unwrap(),
    );
    let played = st["cycles"].as_u64().unwrap() * n + st["step"].as_u64().unwrap();
    assert!(st["step"].as_u64().unwrap() < n, "{last}");
    assert!(
        played as f64 * dwell >= 0.19e6,
        "{played} steps of {dwell} µs: {last}"
    );
    let v = emulator_json("upload", &["--no-play"]);
    assert_eq!(v["playing"], false);
    assert!(v["mute_reason"].is_null(), "{v}");
    // --hold is checked before any device is opened, on every backend.
    assert!(fails(&["upload", "--port", "/dev/null", "--hold", "0"], 2).contains("--hold"));
}

#[test]
fn demo_runs_on_the_emulator() {
    let v = emulator_json("demo", &["--seconds", "2"]);
    assert_eq!(v["readback_mismatches"], 0, "{v}");
    assert_eq!(v["dwell_us"], 2450.0);
    assert!(
        (v["freq_hz"].as_f64().unwrap() - 4.9776).abs() < 1e-3,
        "{v}"
    );
    let applied = v["centroids"]["applied"].as_u64().unwrap();
    assert!(applied > 100, "90 fps for 2 s: {v}");
    assert!(spread(&v, &v["centroids"], "correction_latency_us")[0] > 0.0);
    // A figure the AUTD3 cannot give is null, not missing.
    let c = v["centroids"].as_object().unwrap();
    assert!(
        c.contains_key("latency_us") && c["latency_us"].is_null(),
        "{v}"
    );
    let top = v.as_object().unwrap();
    for key in ["playback", "link", "realtime_priority", "tracking"] {
        assert!(top.contains_key(key) && top[key].is_null(), "{key}: {v}");
    }
    assert!(v["muting"]["mute_after_leave_ms"].is_null(), "{v}");
    assert_eq!(v["muting"]["muted_in_every_status_while_away"], true, "{v}");
    assert_eq!(
        v["muting"]["mute_reason_while_away"], "finger_absent",
        "{v}"
    );
    assert!(
        v["muting"]["playing_statuses_while_present"]
            .as_u64()
            .unwrap()
            > 0
    );
    fails(&["demo", "--port", "/dev/ttyACM0"], 2);
}

#[test]
fn synthetic_stream_applies_corrections_and_mutes_on_absence() {
    let v = emulator_json(
        "stream",
        &["--synthetic", "--seconds", "2", "--away", "0.8,1.4"],
    );
    let acked = v["acked"].as_u64().unwrap();
    assert_eq!(v["applied"], acked);
    assert!(acked > 100, "{v}");
    assert_eq!(v["device_last_seq"], v["last_seq"]);
    let absent = v["absent_updates"].as_u64().unwrap();
    assert!(absent > 20, "{v}");
    assert_eq!(
        v["muted_absent_updates"], absent,
        "muted whenever away: {v}"
    );
    assert_eq!(v["upload"]["readback_mismatches"], 0);
    // Plan flags shape what is played before streaming.
    let v = emulator_json(
        "stream",
        &[
            "--synthetic",
            "--seconds",
            "1",
            "--foci",
            "4",
            "--radius",
            "6",
        ],
    );
    assert_eq!(v["upload"]["readback_mismatches"], 0);
    assert!(v["upload"]["step_mm"].as_f64().unwrap() > 0.2, "{v}");
}

#[test]
fn info_status_and_stop_on_the_emulator() {
    let o = run(&[
        "info",
        "--port",
        "autd3:emulator",
        "--scene",
        &scene("paper.toml"),
        "--json",
    ]);
    let v = success_json(&o);
    assert_eq!(v["backend"], "autd3");
    assert_eq!(v["transducers"], 996);
    assert_eq!(v["slots"], 2);
    assert_eq!(v["dwell_grid_us"], 25);
    let v = emulator_json("status", &[]);
    assert_eq!(v["state"], "Idle", "{v}");
    assert_eq!(v["mute_reason"], "none", "{v}");
    let o = run(&["stop", "--port", "autd3:emulator"]);
    assert!(o.status.success());
    // A fresh link holds nothing to play: exit 1, one line, says why.
    assert!(fails(&["play", "--port", "autd3:emulator"], 1).contains("holds the link"));
}

#[test]
fn a_scene_the_rig_cannot_match_is_exit_2() {
    // paper.toml has four devices; a rig of three cannot play it.
    assert!(
        fails(
            &[
                "upload",
                "--port",
                "autd3:emulator:3",
                "--scene",
                &scene("paper.toml"),
            ],
            2
        )
        .contains("has 4 devices but the AUTD3 rig has 3")
    );
    let v = success_json(&run(&[
        "upload",
        "--port",
        "autd3:emulator:4",
        "--scene",
        &scene("paper.toml"),
        "--json",
    ]));
    assert_eq!(v["readback_mismatches"], 0);
    // Two devices at the same place: the rig cannot be built.
    let dir = scratch_dir("autd3");
    let paper = std::fs::read_to_string(scene("paper.toml")).unwrap();
    let first = paper.find("[[device]]").expect("paper.toml lists devices");
    let end = paper[first + 1..]
        .find("[[")
        .map_or(paper.len(), |i| first + 1 + i);
    let dup = format!("{}\n{}", paper, &paper[first..end]);
    let path = dir.join("overlap.toml");
    std::fs::write(&path, dup).unwrap();
    fails(
        &[
            "upload",
            "--port",
            "autd3:emulator",
            "--scene",
            path.to_str().unwrap(),
        ],
        2,
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn autd3_ports_via_the_environment_and_bad_ones_everywhere() {
    let o = Command::new(lmhost())
        .args(["status", "--json"])
        .env("LMHOST_PORT", "autd3:emulator")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for cmd in ["info", "status", "play", "stop", "stream"] {
        fails(&[cmd, "--port", "autd3:soem:bad/if"], 2);
    }
    assert!(fails(&["info", "--port", "autd3:soem:eth0"], 1).contains("autd3-soem"));
}

#[test]
fn track_streams_to_the_emulator_after_uploading() {
    let o = run(&[
        "track",
        "--synthetic",
        "--seconds",
        "2",
        "--fast",
        "--port",
        "autd3:emulator",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("to autd3:emulator"), "{out}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("read-back 0 mismatches"), "{err}");
}

#[test]
fn sigterm_ends_a_hold_and_leaves_the_array_silent() {
    let mut child = Command::new(lmhost())
        .args([
            "upload",
            "--port",
            "autd3:emulator",
            "--untracked",
            "--hold",
            "60",
        ])
        .env_remove("LMHOST_PORT")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Signal once it says it holds the link (signals are caught by then).
    use std::io::BufRead as _;
    let mut err = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut said = String::new();
    while !said.contains("holding") {
        let mut line = String::new();
        assert!(err.read_line(&mut line).unwrap() > 0, "{said}");
        said += &line;
    }
    send_signal(&child, "TERM");
    let start = std::time::Instant::now();
    let o = child.wait_with_output().unwrap();
    assert!(
        start.elapsed() < std::time::Duration::from_secs(20),
        "the hold ended"
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(said.contains("left silent"), "{said}");
}
