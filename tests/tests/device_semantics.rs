//! What the device does and says, through the real `lmhost` binary against
//! `lmhost sim`: untracked play, the mute reason, queued plays, slot choice
//! and slot validation, and the host lease: a presentation lasts only while
//! its host does. (Wire-level cases such as a repeated commit are in the
//! proto byte vectors, replayed by the firmware core's tests.)

use std::time::{Duration, Instant};

mod link_support;
use link_support::{
    BRIEF_HOLD, Holder, Sim, assert_fields, detached, fails, json, ok, run, upload_json,
};

fn status(port: &str) -> serde_json::Value {
    json(&["status", "--port", port, "--json"])
}

fn stderr_of(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn untracked_upload_plays_without_a_finger_and_warns() {
    let sim = Sim::start(&[]);
    let p = sim.port.as_str();
    let out = run(&["upload", "--port", p, "--untracked", "--hold", BRIEF_HOLD]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr_of(&out));
    let err = stderr_of(&out);
    let warnings: Vec<_> = err.lines().filter(|l| l.contains("untracked")).collect();
    assert_eq!(warnings.len(), 1, "one warning line: {err}");
    assert!(warnings[0].starts_with("warning:"), "{err}");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("playing slot 0, untracked"), "{text}");
    // It sounded without a finger, and the upload left it silent.
    let up = upload_json(p, &["--untracked", "--slot", "0"]);
    assert_fields(
        &up,
        &["state", "mute_reason"],
        serde_json::json!(["Playing", "none"]),
    );
    let st = status(p);
    assert_eq!(st["state"], "Stopped", "{st}");
    assert_eq!(st["mute_reason"], "stopped", "{st}");
}

#[test]
fn tracked_upload_is_muted_and_says_why_and_how_to_get_sound() {
    let sim = Sim::start(&[]);
    let p = sim.port.as_str();
    let args = ["--radius", "3", "--foci", "4", "--hold", BRIEF_HOLD];
    let mut all = vec!["upload", "--port", p];
    all.extend_from_slice(&args);
    let text = ok(&all);
    assert!(text.contains("playing slot 0"), "{text}");
    assert!(text.contains("waiting for tracking"), "{text}");
    assert!(text.contains("lmhost stream"), "{text}");
    assert!(text.contains("--untracked"), "{text}");
    let up = upload_json(p, &args);
    assert_eq!(up["state"], "Muted", "{up}");
    assert_eq!(up["mute_reason"], "waiting_for_tracking", "{up}");
    assert_eq!(up["queued"], false, "{up}");
    let t = ok(&["status", "--port", p]);
    assert!(t.contains("mute reason:      stopped"), "{t}");
    // `play --untracked` plays the entry untracked.
    let out = run(&[
        "play",
        "--port",
        p,
        "--slot",
        "0",
        "--untracked",
        "--hold",
        BRIEF_HOLD,
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr_of(&out));
    assert!(stderr_of(&out).starts_with("warning:"));
}

#[test]
fn play_while_playing_is_queued_and_upload_picks_a_free_slot() {
    let sim = Sim::start(&[]);
    let p = sim.port.as_str();
    // A 20 s cycle, so the queued switch stays queued while we look; each
    // playing lmhost dies once it said what it did, and what it played
    // lives on for its lease (each request below renews it).
    let up = detached(&[
        "upload",
        "--port",
        p,
        "--freq",
        "0.05",
        "--untracked",
        "--lease",
        "60",
        "--json",
    ]);
    let up: serde_json::Value = serde_json::from_str(&up).unwrap();
    assert_eq!(up["slot"], 0, "{up}");
    assert_eq!(up["queued"], false, "{up}");
    // Slot 0 plays: an upload without --slot takes slot 1.
    let up = upload_json(p, &["--radius", "2", "--no-play"]);
    assert_eq!(up["slot"], 1, "{up}");
    let text = detached(&["play", "--port", p, "--slot", "1", "--lease", "60"]);
    assert_eq!(text.trim(), "slot 1 queued for the next cycle boundary");
    let st = status(p);
    assert_eq!(st["slot"], 0, "{st}");
    assert_eq!(st["queued_slot"], 1, "{st}");
    assert_eq!(st["lease_ms"], 60_000, "{st}");
    let t = ok(&["status", "--port", p]);
    assert!(t.contains("queued slot:      1"), "{t}");
    // Slot 0 plays and slot 1 is queued: the library's next entry is free.
    let up = upload_json(p, &["--radius", "4", "--no-play"]);
    assert_eq!(up["slot"], 2, "{up}");
    // Nothing was disturbed.
    let st = status(p);
    assert_fields(&st, &["slot", "queued_slot"], serde_json::json!([0, 1]));
    // After a stop every slot is free; the upload avoids the last played.
    ok(&["stop", "--port", p]);
    let st = status(p);
    assert_eq!(st["queued_slot"], serde_json::Value::Null, "{st}");
    let up = upload_json(p, &["--no-play"]);
    assert_eq!(up["slot"], 1, "{up}");
}

/// The host lease end to end: `lmhost play` keeps an untracked
/// presentation going while it holds the port (renewing well past the
/// lease); killed with SIGKILL it renews no more, and the device stops
/// within the lease by itself, which `lmhost status` reports. SIGTERM
/// stops it at once, as a plain stop.
#[test]
fn an_untracked_presentation_ends_within_its_lease_when_its_host_dies() {
    let sim = Sim::start(&[]);
    let p = sim.port.as_str();
    let up = upload_json(p, &["--no-play"]);
    assert_eq!(up["slot"], 0, "{up}");
    let holder = Holder::start(&[
        "play",
        "--port",
        p,
        "--slot",
        "0",
        "--untracked",
        "--lease",
        "0.5",
    ]);
    assert_eq!(holder.line(), "playing slot 0");
    let held = Instant::now();
    std::thread::sleep(Duration::from_millis(1500));
    let killed = Instant::now();
    holder.kill();
    std::thread::sleep(Duration::from_millis(800));
    let st = status(p);
    assert_fields(
        &st,
        &["state", "mute_reason"],
        serde_json::json!(["Stopped", "lease_expired"]),
    );
    assert_fields(
        &st,
        &["lease_ms", "lease_expiries"],
        serde_json::json!([500, 1]),
    );
    // It played while held (three leases and more: renewed) and stopped
    // within a lease of the kill: a 5 Hz cycle is 200 ms.
    let played_s = (st["cycles"].as_f64().unwrap() + st["step"].as_f64().unwrap() / 82.0) * 0.2;
    let held_s = (killed - held).as_secs_f64();
    assert!(
        played_s >= held_s - 0.1 && played_s <= held_s + 0.5 + 0.3,
        "played {played_s:.2} s, held {held_s:.2} s, lease 0.5 s: {st}"
    );
    let t = ok(&["status", "--port", p]);
    assert!(t.contains("Stopped (stopped: host lease expired)"), "{t}");
    assert!(
        t.contains("host lease:       0.5 s (1 plays ended by one"),
        "{t}"
    );
    // SIGTERM: the host stops it itself, no expiry.
    let holder = Holder::start(&["play", "--port", p, "--slot", "0", "--untracked"]);
    assert_eq!(holder.line(), "playing slot 0");
    assert_eq!(holder.terminate(), Some(0));
    let st = status(p);
    assert_fields(
        &st,
        &["mute_reason", "lease_expiries"],
        serde_json::json!(["stopped", 1]),
    );
}

#[test]
fn a_slot_the_device_lacks_is_bad_input() {
    let sim = Sim::start(&[]);
    let p = sim.port.as_str();
    for args in [
        &["play", "--port", p, "--slot", "40"][..],
        &["play", "--port", p, "--slot", "32", "--untracked"],
        &["upload", "--port", p, "--slot", "40"],
    ] {
        let err = fails(args, 2);
        assert!(err.contains("slot") && err.contains("32 slots"), "{err}");
    }
    // Nothing reached the device.
    let st = status(p);
    assert_eq!(st["state"], "Idle", "{st}");
    assert_eq!(st["nacks"], 0, "{st}");
}

#[test]
fn the_work_volume_flag_is_checked() {
    let sim = Sim::start(&[]);
    let p = sim.port.as_str();
    for bad in ["0", "-5", "100.5", "NaN", "inf"] {
        let out = run(&["upload", "--port", p, "--max-offset", bad]);
        assert_eq!(out.status.code(), Some(2), "{bad}: {}", stderr_of(&out));
        let err = stderr_of(&out);
        assert!(
            err.contains("--max-offset") && err.contains("(0, 100] mm"),
            "{err}"
        );
    }
    let up = upload_json(p, &["--max-offset", "100"]);
    assert_eq!(up["max_offset_um"], 100_000, "{up}");
    let up = upload_json(p, &[]);
    assert_eq!(up["max_offset_um"], 20_000, "{up}");
}

/// `--lease` takes 0.1 to 60 s, nothing else (there is no "forever").
#[test]
fn the_lease_flag_is_bounded() {
    let sim = Sim::start(&[]);
    let p = sim.port.as_str();
    for bad in ["0", "0.05", "60.001", "-1", "inf", "nan", "forever"] {
        let out = run(&["play", "--port", p, "--lease", bad]);
        assert_eq!(out.status.code(), Some(2), "{bad}: {}", stderr_of(&out));
        assert!(
            stderr_of(&out).contains("0.1 to 60 s"),
            "{}",
            stderr_of(&out)
        );
    }
    let t = ok(&["info", "--port", p, "--lease", "60"]);
    assert!(t.contains("host lease:      60 s"), "{t}");
}
