//! What a device's `Info` and `Status` may say: the one check each reply
//! passes before the host uses a number of it (a slot count in a loop, a
//! chunk size in an upload, a state it prints).
//!
//! Whatever answers on the port may not be the LM firmware of this
//! lmhost: a board flashed with another protocol version, a half-flashed
//! one, another program. A field outside what SPEC.md allows, or a
//! combination the firmware's player and policy never produce, is the
//! device's fault: the request fails naming the field (exit 1), rather
//! than the host clamping it, looping on it, or blaming the user's
//! flags for it.

use std::time::Duration;

use lm_proto::{
    ClockSource, DeviceState, Info, MAX_CHUNK, MIN_DWELL_US, MuteReason, PROTOCOL_VERSION, Status,
};

/// Why `info` cannot come from the LM firmware this host speaks to, if
/// it cannot.
pub fn check_info(info: &Info) -> Result<(), String> {
    if info.proto_version != PROTOCOL_VERSION {
        return Err(format!(
            "protocol version {}, and this lmhost speaks {PROTOCOL_VERSION}: flash the firmware \
             of this lmhost's release (`lmhost flash`)",
            info.proto_version
        ));
    }
    let zero = [
        ("slots", info.slots == 0),
        ("max_transducers", info.max_transducers == 0),
        ("slot_bytes", info.slot_bytes == 0),
        ("timer_hz", info.timer_hz == 0),
        ("max_chunk", info.max_chunk == 0),
    ];
    if let Some((name, _)) = zero.iter().find(|(_, z)| *z) {
        return Err(format!("{name} 0"));
    }
    if usize::from(info.max_chunk) > MAX_CHUNK {
        return Err(format!(
            "max_chunk {} above the protocol's {MAX_CHUNK}",
            info.max_chunk
        ));
    }
    if !MIN_DWELL_US.contains(&info.min_dwell_us) {
        return Err(format!(
            "min_dwell_us {} above the protocol's {} (1 s)",
            info.min_dwell_us,
            MIN_DWELL_US.end()
        ));
    }
    if info.library_free > info.slot_bytes {
        return Err(format!(
            "library_free {} above its library's slot_bytes {}",
            info.library_free, info.slot_bytes
        ));
    }
    if info.rig_transducers > info.max_transducers {
        return Err(format!(
            "a rig of {} transducers, above its max_transducers {}",
            info.rig_transducers, info.max_transducers
        ));
    }
    Ok(())
}

/// Why `st` cannot be the status of the device whose (checked) `Info` is
/// `info`, if it cannot. `steps(slot)` is the steps per cycle of a slot
/// this host uploaded, when it knows them.
pub fn check_status(
    st: &Status,
    info: &Info,
    steps: impl Fn(u8) -> Option<u16>,
) -> Result<(), String> {
    for (name, slot) in [("slot", st.slot), ("queued_slot", st.queued_slot)] {
        if let Some(s) = slot
            && s >= info.slots
        {
            return Err(format!(
                "{name} {s}, and the device has {} slots (0-{})",
                info.slots,
                info.slots - 1
            ));
        }
    }
    let playing = matches!(st.state, DeviceState::Playing | DeviceState::Muted);
    let state = format!("{:?}", st.state).to_lowercase();
    if playing && st.slot.is_none() {
        return Err(format!("state {state} without a slot"));
    }
    if st.state == DeviceState::Idle && st.slot.is_some() {
        return Err("state idle (nothing played since reset) with a slot".into());
    }
    if !playing && st.queued_slot.is_some() {
        return Err(format!("state {state} with a queued slot"));
    }
    // The policy's pairs (`lm_fw_core::policy::Policy::mute_reason`):
    // Muted may say None for the instant its lease ran out.
    let mute_fits = match st.state {
        DeviceState::Idle | DeviceState::Playing => st.mute_reason == MuteReason::None,
        DeviceState::Stopped => {
            matches!(
                st.mute_reason,
                MuteReason::Stopped | MuteReason::LeaseExpired
            )
        }
        DeviceState::Muted => !matches!(
            st.mute_reason,
            MuteReason::Stopped | MuteReason::LeaseExpired
        ),
        // The parser lists every state this protocol version has.
        _ => false,
    };
    if !mute_fits {
        return Err(format!(
            "state {state} with mute reason `{}`",
            st.mute_reason
        ));
    }
    let lease_ok = lm_proto::LEASE_MS.contains(&st.lease_ms) || (st.lease_ms == 0 && !playing);
    if !lease_ok {
        return Err(format!(
            "a host lease of {} ms in state {state} (a play's lease is {}..={} ms)",
            st.lease_ms,
            lm_proto::LEASE_MS.start(),
            lm_proto::LEASE_MS.end()
        ));
    }
    if let Some(slot) = st.slot
        && let Some(n) = steps(slot)
        && st.step >= n
    {
        return Err(format!(
            "step {} of slot {slot}, which has {n} steps per cycle",
            st.step
        ));
    }
    Ok(())
}

/// How much less than the host's time the uptime of a device whose clock
/// is `clock` may advance between two `Status` replies without a restart:
/// twice the reply timeout (the link's latency, either way) plus 1 % of
/// the time for a crystal (which errs by 50 ppm), 2 % for an RC
/// oscillator (~1 %) (SPEC section 3). `None` for a clock that need not
/// keep the host's pace: emulated (QEMU under `-icount` counts
/// instructions) or unknown; only its uptime going back tells.
pub fn uptime_slack(
    host_elapsed: Duration,
    reply_timeout: Duration,
    clock: ClockSource,
) -> Option<Duration> {
    let percent = match clock {
        ClockSource::Crystal => 1,
        ClockSource::InternalRc => 2,
        _ => return None,
    };
    Some(reply_timeout.saturating_mul(2) + host_elapsed * percent / 100)
}

/// Why `now` says the device restarted since `before` (a `Status` of the
/// same link), if it does: a counter kept since reset went back, the state
/// is Idle ("nothing played since reset") after it played, or its
/// `uptime_ms` went back or advanced less than `host_elapsed` (the host's
/// time between the two replies, which the caller measures on its own
/// clock) less [`uptime_slack`] for the device's `clock` (`Info::clock`).
/// The uptime wraps at `u32::MAX` ms (49.7 days) and is compared wrapping;
/// over more than half that (24.8 days) between two replies only the
/// counters and the state can tell.
pub fn restarted(
    before: &Status,
    now: &Status,
    host_elapsed: Duration,
    reply_timeout: Duration,
    clock: ClockSource,
) -> Option<String> {
    let since_reset = [
        (
            "missed_deadlines",
            before.missed_deadlines,
            now.missed_deadlines,
        ),
        ("bad_frames", before.bad_frames, now.bad_frames),
        ("crc_errors", before.crc_errors, now.crc_errors),
        ("nacks", before.nacks, now.nacks),
        ("lease_expiries", before.lease_expiries, now.lease_expiries),
    ];
    if let Some((name, b, n)) = since_reset.iter().find(|(_, b, n)| n < b) {
        return Some(format!("its {name} went back from {b} to {n}"));
    }
    if before.state != DeviceState::Idle && now.state == DeviceState::Idle {
        let state = format!("{:?}", before.state).to_lowercase();
        return Some(format!(
            "state idle (nothing played since reset) after {state}"
        ));
    }
    let half = u128::from(u32::MAX / 2);
    let elapsed_ms = host_elapsed.as_millis();
    if elapsed_ms > half {
        return None;
    }
    let (b, n) = (before.uptime_ms, now.uptime_ms);
    let advanced = n.wrapping_sub(b);
    if u128::from(advanced) > half {
        return Some(format!("its uptime went back from {b} ms to {n} ms"));
    }
    let slack = uptime_slack(host_elapsed, reply_timeout, clock)?;
    if u128::from(advanced) + slack.as_millis() < elapsed_ms {
        return Some(format!(
            "its uptime advanced {advanced} ms (from {b} to {n}) while {elapsed_ms} ms passed \
             on the host"
        ));
    }
    None
}

#[cfg(test)]
mod tests {
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
}
