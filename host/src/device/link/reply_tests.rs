//! Tests of `reply.rs`: the checks of `Info`, `Status` and
//! `SelfTestResult`, and what a restart looks like.

use super::*;
use crate::device::link::client::tests::info;

fn playing(slot: u8) -> Status {
    Status {
        state: DeviceState::Playing,
        slot: Some(slot),
        lease_ms: 1000,
        ..Status::default()
    }
}

#[test]
fn an_info_outside_the_spec_is_refused_naming_its_field() {
    assert_eq!(check_info(&info(32)), Ok(()));
    assert_eq!(check_info(&info(255)), Ok(()), "slots 0-254");
    let bad = [
        (
            Info {
                proto_version: 5,
                ..info(32)
            },
            "protocol version 5",
        ),
        (info(0), "slots 0"),
        (
            Info {
                max_chunk: 0,
                ..info(32)
            },
            "max_chunk 0",
        ),
        (
            Info {
                max_chunk: 1025,
                ..info(32)
            },
            "max_chunk 1025 above",
        ),
        (
            Info {
                max_transducers: 0,
                ..info(32)
            },
            "max_transducers 0",
        ),
        (
            Info {
                timer_hz: 0,
                ..info(32)
            },
            "timer_hz 0",
        ),
        (
            Info {
                library_free: u32::MAX,
                ..info(32)
            },
            "library_free 4294967295",
        ),
        (
            Info {
                rig_transducers: 997,
                ..info(32)
            },
            "a rig of 997 transducers",
        ),
        (
            Info {
                min_dwell_us: u32::MAX,
                ..info(32)
            },
            "min_dwell_us 4294967295 above",
        ),
        (
            Info {
                min_dwell_us: 1_000_001,
                ..info(32)
            },
            "min_dwell_us 1000001 above",
        ),
    ];
    // A second's dwell is the longest a device may ask for.
    let slow = Info {
        min_dwell_us: 1_000_000,
        ..info(32)
    };
    assert_eq!(check_info(&slow), Ok(()));
    for (i, want) in bad {
        let e = check_info(&i).unwrap_err();
        assert!(e.contains(want), "{e}");
    }
}

/// Status replies `elapsed` apart on a link with the default timeout,
/// from a device on a crystal.
fn restart(before: &Status, now: &Status, elapsed_ms: u64) -> Option<String> {
    restart_on(ClockSource::Crystal, before, now, elapsed_ms)
}

/// [`restart`] from a device whose clock is `clock`.
fn restart_on(
    clock: ClockSource,
    before: &Status,
    now: &Status,
    elapsed_ms: u64,
) -> Option<String> {
    restarted(
        before,
        now,
        Duration::from_millis(elapsed_ms),
        Duration::from_millis(300),
        clock,
    )
}

/// `st` at `uptime_ms`.
fn at(st: Status, uptime_ms: u32) -> Status {
    Status { uptime_ms, ..st }
}

#[test]
fn counters_going_back_or_idle_after_a_play_is_a_restart() {
    let before = Status {
        nacks: 3,
        lease_expiries: 1,
        ..playing(0)
    };
    assert_eq!(restart(&before, &before, 0), None);
    let more = Status {
        nacks: 4,
        state: DeviceState::Stopped,
        mute_reason: MuteReason::Stopped,
        ..before
    };
    assert_eq!(restart(&before, &more, 0), None, "counters only grow");
    let reset = Status::default();
    assert_eq!(
        restart(&before, &reset, 0).as_deref(),
        Some("its nacks went back from 3 to 0")
    );
    // Nothing counted yet: the state tells.
    assert_eq!(
        restart(&playing(0), &reset, 0).as_deref(),
        Some("state idle (nothing played since reset) after playing")
    );
    assert_eq!(restart(&reset, &reset, 0), None, "idle before");
}

#[test]
fn a_restart_with_every_counter_at_0_and_nothing_played_is_seen_by_the_uptime() {
    let fresh = Status::default();
    // The uptime went back: restarted after the first reply.
    assert_eq!(
        restart(&at(fresh, 5_000), &at(fresh, 1_200), 1_300).as_deref(),
        Some("its uptime went back from 5000 ms to 1200 ms")
    );
    // Restarted right after a reply at 200 ms, read 10 s later: up
    // 9 s, which it was not 10 s ago.
    let e = restart(&at(fresh, 200), &at(fresh, 9_000), 10_000).unwrap();
    assert_eq!(
        e,
        "its uptime advanced 8800 ms (from 200 to 9000) while 10000 ms passed on the host"
    );
    // Not restarted: the uptime kept pace.
    assert_eq!(restart(&at(fresh, 200), &at(fresh, 10_200), 10_000), None);
}

#[test]
fn the_uptime_wraps_at_u32_max_without_a_restart() {
    let fresh = Status::default();
    let before = at(fresh, u32::MAX - 100);
    assert_eq!(restart(&before, &at(fresh, 400), 500), None);
    assert_eq!(restart(&before, &at(fresh, 0), 101), None);
    // Wrapped, but 5 s short of the host's 10 s.
    assert!(restart(&before, &at(fresh, 4_899), 10_000).is_some());
    // Over half the range apart, the uptime cannot tell.
    let long = u64::from(u32::MAX / 2) + 1;
    assert_eq!(restart(&at(fresh, 9), &at(fresh, 3), long), None);
}

#[test]
fn a_slow_link_within_the_tolerance_is_no_restart() {
    let fresh = Status::default();
    // 2 × 300 ms + 1 % of 10 s = 700 ms of slack.
    let t = Duration::from_millis(300);
    assert_eq!(
        uptime_slack(Duration::from_secs(10), t, ClockSource::Crystal),
        Some(Duration::from_millis(700))
    );
    assert_eq!(
        uptime_slack(Duration::from_secs(10), t, ClockSource::InternalRc),
        Some(Duration::from_millis(800))
    );
    assert_eq!(restart(&at(fresh, 1_000), &at(fresh, 10_300), 10_000), None);
    assert!(restart(&at(fresh, 1_000), &at(fresh, 10_299), 10_000).is_some());
    // A clock 1 % slow over a minute, replies at once.
    assert_eq!(restart(&at(fresh, 0), &at(fresh, 59_400), 60_000), None);
}

#[test]
fn the_uptime_going_back_is_a_restart_whatever_the_time() {
    let fresh = Status::default();
    assert!(restart(&at(fresh, 1_000), &at(fresh, 999), 0).is_some());
    assert!(restart(&at(fresh, 1_000), &at(fresh, 999), 600).is_some());
    assert_eq!(restart(&at(fresh, 1_000), &at(fresh, 1_000), 0), None);
}

/// An emulated clock (QEMU under `-icount`: a second of the guest is
/// 10^9 instructions, however long they take) or an unknown one need
/// not keep the host's pace: only going back tells.
#[test]
fn an_emulated_clock_is_held_only_to_going_forward() {
    let fresh = Status::default();
    for clock in [ClockSource::Emulated, ClockSource::Unknown] {
        let slow = restart_on(clock, &at(fresh, 6), &at(fresh, 648), 4_184);
        assert_eq!(slow, None, "{clock:?}");
        let back = restart_on(clock, &at(fresh, 5_000), &at(fresh, 20), 100);
        assert_eq!(
            back.as_deref(),
            Some("its uptime went back from 5000 ms to 20 ms")
        );
    }
    // The same pace from a crystal is a restart.
    assert!(restart(&at(fresh, 6), &at(fresh, 648), 4_184).is_some());
}

#[test]
fn a_status_no_firmware_reports_is_refused() {
    let none = |_| None;
    assert_eq!(check_status(&Status::default(), &info(32), none), Ok(()));
    assert_eq!(check_status(&playing(31), &info(32), none), Ok(()));
    let muted_at_expiry = Status {
        state: DeviceState::Muted,
        ..playing(0)
    };
    assert_eq!(check_status(&muted_at_expiry, &info(32), none), Ok(()));
    let bad = [
        (playing(32), "slot 32, and the device has 32 slots"),
        (
            Status {
                slot: None,
                ..playing(0)
            },
            "state playing without a slot",
        ),
        (
            Status {
                queued_slot: Some(1),
                state: DeviceState::Stopped,
                mute_reason: MuteReason::Stopped,
                ..playing(0)
            },
            "state stopped with a queued slot",
        ),
        (
            Status {
                mute_reason: MuteReason::Stopped,
                ..playing(0)
            },
            "state playing with mute reason `stopped`",
        ),
        (
            Status {
                lease_ms: 0,
                ..playing(0)
            },
            "a host lease of 0 ms in state playing",
        ),
        (
            Status {
                slot: Some(0),
                ..Status::default()
            },
            "state idle",
        ),
    ];
    for (st, want) in bad {
        let e = check_status(&st, &info(32), none).unwrap_err();
        assert!(e.contains(want), "{e}");
    }
    let step = Status {
        step: 40,
        ..playing(3)
    };
    let e = check_status(&step, &info(32), |s| (s == 3).then_some(40)).unwrap_err();
    assert!(e.contains("step 40 of slot 3, which has 40 steps"), "{e}");
    assert_eq!(
        check_status(&step, &info(32), |s| (s == 3).then_some(41)),
        Ok(())
    );
}

/// Fields the firmware holds at 0 in a state, a correction beyond any
/// work volume, a rig CRC without a rig and self-test counts that
/// contradict each other: each refused naming its field.
#[test]
fn fields_held_at_zero_and_counts_that_contradict_are_refused() {
    let none = |_| None;
    let idle = Status::default();
    let stopped = Status {
        state: DeviceState::Stopped,
        mute_reason: MuteReason::Stopped,
        ..playing(0)
    };
    let bad = [
        (Status { step: 3, ..idle }, "step 3 in state idle"),
        (Status { cycles: 9, ..idle }, "cycles 9 in state idle"),
        (
            Status {
                lease_ms: 1000,
                ..idle
            },
            "lease_ms 1000 in state idle",
        ),
        (
            Status {
                correction_um: [0, 1, 0],
                ..stopped
            },
            "correction_um [0, 1, 0] in state stopped",
        ),
        (
            Status {
                state: DeviceState::Muted,
                mute_reason: MuteReason::WaitingForTracking,
                correction_um: [5, 0, 0],
                ..playing(0)
            },
            "with mute reason `waiting for tracking`",
        ),
        (
            Status {
                correction_um: [60_000, 80_001, 0],
                ..playing(0)
            },
            "farther than the largest work volume (100000 µm)",
        ),
        (
            Status {
                correction_um: [i32::MIN; 3],
                ..playing(0)
            },
            "farther than the largest work volume",
        ),
    ];
    for (st, want) in bad {
        let e = check_status(&st, &info(32), none).unwrap_err();
        assert!(e.contains(want), "{e}");
    }
    // What the firmware does report: a correction held while the
    // finger is gone, one at the edge of the largest volume, a stopped
    // play's frozen count.
    let good = [
        Status {
            state: DeviceState::Muted,
            mute_reason: MuteReason::FingerAbsent,
            correction_um: [1000, 0, 0],
            ..playing(0)
        },
        Status {
            correction_um: [60_000, 80_000, 0],
            ..playing(0)
        },
        Status {
            step: 2,
            cycles: 7,
            ..stopped
        },
    ];
    for st in good {
        assert_eq!(check_status(&st, &info(32), none), Ok(()), "{st:?}");
    }
    let rigless = Info {
        rig_transducers: 0,
        rig_crc32: 0x1234,
        ..info(32)
    };
    let e = check_info(&rigless).unwrap_err();
    assert!(e.contains("rig_crc32 0x00001234 without a rig"), "{e}");
    let failed = |bytes, mismatches, first_mismatch, sent, got| SelfTest::Failed {
        bytes,
        mismatches,
        first_mismatch,
        sent,
        got,
    };
    assert_eq!(check_self_test(&SelfTest::Unsupported), Ok(()));
    assert_eq!(check_self_test(&SelfTest::Passed { bytes: 1024 }), Ok(()));
    assert_eq!(check_self_test(&failed(1024, 1020, 3, 3, 0xFF)), Ok(()));
    let bad = [
        (SelfTest::Passed { bytes: 0 }, "passed over 0 bytes"),
        (failed(1024, 0, 0, 1, 2), "failed with 0 mismatches in 1024"),
        (failed(4, 5, 0, 1, 2), "failed with 5 mismatches in 4"),
        (failed(0, 1, 0, 1, 2), "failed with 1 mismatches in 0"),
        (failed(4, 1, 4, 1, 2), "first_mismatch 4 past the 4 bytes"),
        (failed(4, 1, 0, 7, 7), "sent and got the same 0x07"),
    ];
    for (t, want) in bad {
        let e = check_self_test(&t).unwrap_err();
        assert!(e.contains(want), "{e}");
    }
}
