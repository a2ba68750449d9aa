//! What the device does and says, through the real `lmhost` binary against
//! `lmhost sim`: untracked play, the mute reason, queued plays, slot choice
//! and slot validation. (Wire-level cases such as a repeated commit are in
//! the proto byte vectors, replayed by the firmware core's tests.)

mod link_support;
use link_support::{Sim, json, ok, run, upload_json};

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
    let out = run(&["upload", "--port", p, "--untracked"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr_of(&out));
    let err = stderr_of(&out);
    let warnings: Vec<_> = err.lines().filter(|l| l.contains("untracked")).collect();
    assert_eq!(warnings.len(), 1, "one warning line: {err}");
    assert!(warnings[0].starts_with("warning:"), "{err}");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("playing slot 0, untracked"), "{text}");
    let st = status(p);
    assert_eq!(st["state"], "Playing", "{st}");
    assert_eq!(st["mute_reason"], "none", "{st}");
    ok(&["stop", "--port", p]);
    let st = status(p);
    assert_eq!(st["state"], "Stopped", "{st}");
    assert_eq!(st["mute_reason"], "stopped", "{st}");
}

#[test]
fn tracked_upload_is_muted_and_says_why_and_how_to_get_sound() {
    let sim = Sim::start(&[]);
    let p = sim.port.as_str();
    let text = ok(&["upload", "--port", p, "--radius", "3", "--foci", "4"]);
    assert!(text.contains("playing slot 0"), "{text}");
    assert!(text.contains("waiting for tracking"), "{text}");
    assert!(text.contains("lmhost stream"), "{text}");
    assert!(text.contains("--untracked"), "{text}");
    let st = status(p);
    assert_eq!(st["state"], "Muted", "{st}");
    assert_eq!(st["mute_reason"], "waiting_for_tracking", "{st}");
    assert_eq!(st["queued_slot"], serde_json::Value::Null, "{st}");
    let t = ok(&["status", "--port", p]);
    assert!(t.contains("mute reason:      waiting for tracking"), "{t}");
    // `play --untracked` turns the same session into untracked play.
    let out = run(&["play", "--port", p, "--slot", "0", "--untracked"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr_of(&out));
    assert!(stderr_of(&out).starts_with("warning:"));
    assert_eq!(status(p)["state"], "Playing");
}

#[test]
fn play_while_playing_is_queued_and_upload_picks_a_free_slot() {
    let sim = Sim::start(&[]);
    let p = sim.port.as_str();
    // A 20 s cycle, so the queued switch stays queued while we look.
    let up = upload_json(p, &["--freq", "0.05", "--untracked"]);
    assert_eq!(up["slot"], 0, "{up}");
    assert_eq!(up["queued"], false, "{up}");
    // Slot 0 plays: an upload without --slot takes slot 1.
    let up = upload_json(p, &["--radius", "2", "--no-play"]);
    assert_eq!(up["slot"], 1, "{up}");
    let text = ok(&["play", "--port", p, "--slot", "1"]);
    assert_eq!(text.trim(), "slot 1 queued for the next cycle boundary");
    let st = status(p);
    assert_eq!(st["slot"], 0, "{st}");
    assert_eq!(st["queued_slot"], 1, "{st}");
    let t = ok(&["status", "--port", p]);
    assert!(t.contains("queued slot:      1"), "{t}");
    // Slot 0 plays and slot 1 is queued: the library's next entry is free.
    let up = upload_json(p, &["--radius", "4", "--no-play"]);
    assert_eq!(up["slot"], 2, "{up}");
    // Nothing was disturbed.
    let st = status(p);
    assert_eq!(
        (st["slot"].clone(), st["queued_slot"].clone()),
        (0.into(), 1.into())
    );
    // After a stop every slot is free; the upload avoids the last played.
    ok(&["stop", "--port", p]);
    let st = status(p);
    assert_eq!(st["queued_slot"], serde_json::Value::Null, "{st}");
    let up = upload_json(p, &["--no-play"]);
    assert_eq!(up["slot"], 1, "{up}");
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
        let out = run(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr_of(&out));
        let err = stderr_of(&out);
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
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
