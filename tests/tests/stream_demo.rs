//! `lmhost demo`: the README's main job, run as a user would.

mod link_support;
use link_support::{json, spread};

#[test]
fn demo_uploads_plays_streams_and_mutes() {
    let v = json(&["demo", "--seconds", "2", "--json"]);
    assert_eq!(v["steps"], 82, "{v}");
    assert_eq!(v["transducers"], 996);
    let up = &v["upload"];
    assert!(up["wire_efficiency"].as_f64().unwrap() >= 0.95, "{v}");
    assert!(up["encoded_bytes"].as_u64().unwrap() < up["raw_bytes"].as_u64().unwrap());
    let p = &v["playback"];
    assert!(p["steps_played"].as_u64().unwrap() > 0, "{v}");
    spread(&v, p, "step_late_us");
    let c = &v["centroids"];
    // 2 s at 90 fps, the finger away for 20 % of it: at most the updates
    // with the finger present reach an output frame (about 144 on an idle
    // machine; a loaded one can starve the simulated device's thread for
    // a few hundred ms, and the updates of that stretch go stale unused).
    assert_eq!(c["sent"], 180, "{v}");
    let applied = c["applied"].as_u64().unwrap();
    assert!((90..=146).contains(&applied), "{v}");
    // Centroid → the step that used it, and → the ack: each a spread.
    for key in ["latency_us", "correction_latency_us"] {
        assert!(spread(&v, c, key)[0] > 0.0, "{v}");
    }
    let m = &v["muting"];
    assert_eq!(m["muted_in_every_status_while_away"], true, "{v}");
    // Always there: 0 when stale tracking had muted the output before
    // the finger was seen to leave (a loaded machine's late samples).
    for k in ["mute_after_leave_ms", "resume_after_return_ms"] {
        assert!(m[k].as_f64().is_some_and(|ms| ms >= 0.0), "{k}: {v}");
    }
    assert!(
        m["playing_statuses_while_present"].as_u64().unwrap() > 0,
        "{v}"
    );
}

#[test]
fn demo_runs_over_a_socket_pair_too() {
    let v = json(&["demo", "--seconds", "1", "--link", "socket", "--json"]);
    assert_eq!(v["link"], "socket", "{v}");
    assert_eq!(v["centroids"]["sent"], 90, "{v}");
    assert!(v["centroids"]["applied"].as_u64().unwrap() >= 60, "{v}");
    assert_eq!(v["muting"]["muted_in_every_status_while_away"], true, "{v}");
}
