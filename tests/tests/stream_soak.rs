//! Streaming soak: centroid updates at 90 Hz for minutes of device time,
//! accelerated (in-process device, virtual clock). Every update must be
//! acked and applied, none lost, no deadline missed, and memory must not
//! grow with the number of updates.
//!
//! The 10-minute run is `#[ignore]`d; run it with
//! `cargo test --release -p lm-e2e --test stream_soak -- --ignored`.

use std::sync::{Arc, Mutex};

use lm_proto::{Centroid, Encoding, PlayAt};
use lmhost::clock::Clock;
use lmhost::clock::STATS_RING;
use lmhost::device::link::{Client, UploadSpec};
use lmhost::device::simdev::{Core, FwCore, InProcess, SimConfig};
use lmhost::plan::sequence::Plan;

fn rss_kib() -> u64 {
    let statm = std::fs::read_to_string("/proc/self/statm").unwrap();
    let pages: u64 = statm.split_whitespace().nth(1).unwrap().parse().unwrap();
    pages * 4
}

fn lm_m() -> UploadSpec {
    UploadSpec::from_plan(&Plan::paper_lm_m().unwrap(), Encoding::Delta).unwrap()
}

fn soak(minutes: u64) {
    let core = Arc::new(Mutex::new(FwCore::new(SimConfig::default()).unwrap()));
    let time = Clock::manual_at_us(1_000_000);
    let mut client = Client::new(InProcess::new(core.clone(), time.clone()));
    let spec = lm_m();
    let dwell_us = spec.header.period_us as u64 / spec.header.steps as u64;
    client.upload(&spec, 0, 1024, |_, _| {}).unwrap();
    client.play(0, PlayAt::Immediate, false).unwrap();
    let start = time.now_us();
    let updates = minutes * 60 * 90;
    let mut rss_after_first_minute = 0;
    for i in 0..updates {
        // 90 Hz: update i at i / 90 s, in whole µs without drift.
        let t = start + i * 1_000_000 / 90;
        client.transport_mut().advance_to(t);
        let wobble = ((i % 200) as i32 - 100) * 20;
        let c = Centroid {
            seq: i as u32 + 1,
            pos_um: [wobble, -wobble, 200_000],
            present: true,
            host_time_us: t,
        };
        client
            .centroid(c)
            .unwrap_or_else(|e| panic!("update {i}: {e}"));
        if i == 60 * 90 {
            rss_after_first_minute = rss_kib();
        }
    }
    let end = start + updates * 1_000_000 / 90 + 10_000;
    client.transport_mut().advance_to(end);
    let status = client.status().unwrap();
    let stats = core.lock().unwrap().stats();
    assert_eq!(status.last_centroid_seq as u64, updates, "updates lost");
    assert_eq!(stats.centroids_applied, updates, "updates not applied");
    assert_eq!(status.missed_deadlines, 0);
    // Muted from Play until the first update (the firmware waits for a
    // finger), then sounding for good.
    assert!(
        stats.muted_frames <= 1,
        "{} muted frames",
        stats.muted_frames
    );
    assert_eq!(
        stats.mute_changes.back().map(|c| c.1),
        Some(false),
        "ends muted"
    );
    assert!(
        stats.mute_changes.len() <= 2,
        "muted while tracked: {:?}",
        stats.mute_changes
    );
    let played = stats.frames;
    let expected = (end - start) / dwell_us;
    assert!(
        played.abs_diff(expected) <= 2,
        "{played} frames, expected {expected}"
    );
    // Virtual time: every update applies at the next step boundary.
    assert!(
        stats.latencies_us.iter().all(|&l| l <= dwell_us + 1),
        "late update"
    );
    assert!(stats.latencies_us.len() <= STATS_RING && stats.step_late_us.len() <= STATS_RING);
    if minutes >= 5 {
        // A leak of even 50 bytes per update would show as > 2 MiB.
        let grown = rss_kib().saturating_sub(rss_after_first_minute);
        assert!(
            grown < 2048,
            "RSS grew by {grown} KiB after the first minute"
        );
    }
}

#[test]
fn one_minute_at_90_hz() {
    soak(1);
}

/// The 10 minutes of device time at 90 Hz.
#[test]
#[ignore = "long: run in release with --ignored"]
fn ten_minutes_at_90_hz() {
    soak(10);
}
