//! The real `lmhost` binary against `lmhost sim`: info, status, upload,
//! play, stop, selftest, and the errors a user meets.

mod link_support;
use link_support::{
    BRIEF_HOLD, Sim, assert_fields, fails, json, kill_a_holder_of, ok, run, upload_json,
};

#[test]
fn info_reports_device_limits() {
    let sim = Sim::start(&[]);
    let i = json(&["info", "--port", &sim.port, "--json"]);
    assert_eq!(i["max_transducers"], 996);
    assert!(i["slots"].as_u64().unwrap() >= 2, "{i}");
    assert_eq!(i["min_dwell_us"], 1000);
    let text = ok(&["info", "--port", &sim.port]);
    assert!(text.contains("up to 996"), "{text}");
}

#[test]
fn upload_commits_plays_and_switches_slots() {
    let sim = Sim::start(&[]);
    let p = sim.port.as_str();
    assert_eq!(json(&["status", "--port", p, "--json"])["state"], "Idle");
    let up = upload_json(p, &["--foci", "4", "--radius", "3"]);
    assert_eq!(up["steps"], 82, "{up}");
    assert_eq!(up["slot"], 0);
    assert_eq!(up["playing"], true);
    // The firmware mutes until the first centroid arrives.
    assert_eq!(up["state"], "Muted", "{up}");
    // The upload held it briefly, then left it silent.
    let st = json(&["status", "--port", p, "--json"]);
    assert_eq!(
        (
            st["state"].clone(),
            st["mute_reason"].clone(),
            st["slot"].clone()
        ),
        ("Stopped".into(), "stopped".into(), 0.into()),
        "{st}"
    );
    // A second upload goes to the other slot.
    let up2 = upload_json(p, &["--radius", "2", "--no-play"]);
    assert_eq!(up2["slot"], 1);
    let text = ok(&[
        "play",
        "--port",
        p,
        "--slot",
        "1",
        "--immediate",
        "--hold",
        BRIEF_HOLD,
    ]);
    assert_eq!(text.trim(), "playing slot 1");
    let st = json(&["status", "--port", p, "--json"]);
    assert_eq!(st["slot"], 1);
    assert_eq!(st["state"], "Stopped");
    ok(&["stop", "--port", p]);
    let st = json(&["status", "--port", p, "--json"]);
    assert_eq!(st["state"], "Stopped");
    assert_eq!(st["crc_errors"], 0);
    assert_eq!(st["bad_frames"], 0);
    assert_eq!(st["lease_expiries"], 0, "every host stopped what it played");
}

/// The intensity an upload plays at is in its report, text and JSON: a
/// researcher sees the level the wire carries, not just the flag typed.
#[test]
fn upload_reports_the_intensity_it_plays_at() {
    let sim = Sim::start(&[]);
    let full = upload_json(&sim.port, &["--no-play"]);
    assert_eq!(full["intensity_level"], 255, "{full}");
    let half = upload_json(&sim.port, &["--no-play", "--intensity", "0.5"]);
    assert_eq!(half["intensity_level"], 128, "{half}");
    let text = ok(&[
        "upload",
        "--port",
        &sim.port,
        "--no-play",
        "--intensity",
        "0.5",
    ]);
    assert!(
        text.contains("at intensity 0.501961 (128/255) of full output"),
        "{text}"
    );
    let plan = ok(&["plan", "--intensity", "0.25"]);
    assert!(
        plan.contains("intensity 0.25098 (64/255) of full output"),
        "{plan}"
    );
    assert!(!ok(&["plan"]).contains("intensity"));
}

#[test]
fn upload_wire_efficiency_is_at_least_95_percent() {
    let sim = Sim::start(&[]);
    for enc in ["raw", "delta"] {
        let up = upload_json(&sim.port, &["--foci", "4", "--encoding", enc]);
        let eff = up["wire"]["wire_efficiency"].as_f64().unwrap();
        assert!(eff >= 0.95, "{enc}: {up}");
        assert_eq!(up["wire"]["retries"], 0);
    }
}

#[test]
fn sequence_too_big_is_refused_before_sending() {
    // Slots of 10 steps × 996 transducers cannot hold 82 steps.
    let sim = Sim::start(&["--slot-steps", "10"]);
    let out = run(&["upload", "--port", &sim.port, "--foci", "4"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("does not fit") && err.contains("slot"),
        "{err}"
    );
    let st = json(&["status", "--port", &sim.port, "--json"]);
    assert_eq!(st["state"], "Idle");
    assert_eq!(
        st["nacks"], 0,
        "nothing was sent, so nothing was refused: {st}"
    );
}

/// `lmhost selftest`: one line, exit 0 when the loopback passes, 1 when it
/// fails or the board has none.
#[test]
fn selftest_reports_the_boards_spi_loopback_in_one_line() {
    let cases = [
        (
            &["--loopback", "ok"][..],
            Some(0),
            "spi loopback: passed (1024 bytes)",
        ),
        (&["--loopback", "broken"], Some(1), "spi loopback: failed: "),
        (&[], Some(1), "spi loopback: not supported by this board"),
    ];
    for (sim_args, code, want) in cases {
        let sim = Sim::start(sim_args);
        let out = run(&["selftest", "--port", &sim.port]);
        assert_eq!(out.status.code(), code, "{sim_args:?}");
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(text.trim().lines().count(), 1, "{text}");
        assert!(text.contains(want), "{sim_args:?}: {text}");
        let v = json(&["status", "--port", &sim.port, "--json"]);
        assert_eq!(v["nacks"], 0, "{v}");
    }
    let sim = Sim::start(&["--loopback", "broken"]);
    let out = run(&["selftest", "--port", &sim.port, "--json"]);
    assert_eq!(out.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["outcome"], "failed", "{v}");
    assert_fields(
        &v,
        &["bytes", "first_mismatch"],
        serde_json::json!([1024, 0]),
    );
}

#[test]
fn playing_an_empty_slot_fails_clearly() {
    let sim = Sim::start(&[]);
    let out = run(&["play", "--port", &sim.port, "--slot", "1"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("refused play"), "{err}");
    assert!(!err.contains("panicked") && !err.contains("{ "), "{err}");
}

#[test]
fn no_port_lists_what_was_found() {
    let err = fails(&["info"], 2);
    assert!(
        err.contains("no LM board found") && err.contains("--port"),
        "{err}"
    );
}

#[test]
fn missing_port_path_is_an_operation_error() {
    let out = run(&["status", "--port", "/dev/lmhost-no-such-port"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("/dev/lmhost-no-such-port") && !err.contains("os error"),
        "{err}"
    );
}

#[test]
fn silent_port_times_out_with_advice() {
    // A pty nobody answers on: the sim's pty with the sim stopped is gone,
    // so use a fresh sim and a 1-try, short-timeout request to a cut link.
    let sim = Sim::start(&["--faults", "cut=0"]);
    let out = run(&[
        "info",
        "--port",
        &sim.port,
        "--timeout-ms",
        "50",
        "--tries",
        "2",
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no response") && err.contains("2 tries"),
        "{err}"
    );
}

#[test]
fn upload_through_a_noisy_link_retries_and_commits() {
    // Bit errors at 1e-4 and dropped bytes on the device's side of the pty.
    let sim = Sim::start(&["--faults", "ber=1e-4,drop=1e-5", "--seed", "3"]);
    let p = sim.port.as_str();
    let up = upload_json(p, &["--foci", "4", "--timeout-ms", "100"]);
    assert!(up["wire"]["retries"].as_u64().unwrap() > 0, "{up}");
    let st = json(&[
        "status",
        "--port",
        p,
        "--json",
        "--timeout-ms",
        "100",
        "--tries",
        "10",
    ]);
    assert!(
        st["crc_errors"].as_u64().unwrap() + st["bad_frames"].as_u64().unwrap() > 0,
        "{st}"
    );
    assert_eq!(st["slot"], 0, "{st}");
}

/// Issue 30.15: a port's lock dies with its holder. An lmhost killed with
/// SIGKILL (no destructor runs) must not leave the simulated device's pty
/// "in use" for the next command, while a live holder still keeps it.
#[test]
fn a_port_held_by_a_killed_lmhost_is_free_at_once() {
    let sim = Sim::start(&[]);
    let p = sim.port.as_str();
    kill_a_holder_of(p);
    let o = run(&["status", "--port", p]);
    assert!(
        o.status.success(),
        "after the holder died: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    // And twice in a row: nothing of ours stays behind either.
    ok(&["status", "--port", p]);
}
