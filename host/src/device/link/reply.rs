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
    ClockSource, DeviceState, Info, MAX_CHUNK, MAX_OFFSET_UM, MIN_DWELL_US, MuteReason,
    PROTOCOL_VERSION, SelfTest, Status,
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
    if info.rig_transducers == 0 && info.rig_crc32 != 0 {
        return Err(format!(
            "rig_crc32 {:#010x} without a rig (rig_transducers 0; 0 when none)",
            info.rig_crc32
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
    // What the firmware's player and policy hold at 0 in a state: Idle
    // (nothing played since reset) has no step, cycle or lease, and no
    // correction applies while idle, stopped, waiting for the first
    // centroid or out of the work volume.
    let zero = [
        ("step", u64::from(st.step), st.state == DeviceState::Idle),
        (
            "cycles",
            u64::from(st.cycles),
            st.state == DeviceState::Idle,
        ),
        (
            "lease_ms",
            u64::from(st.lease_ms),
            st.state == DeviceState::Idle,
        ),
    ];
    if let Some((name, v, _)) = zero.iter().find(|(_, v, held)| *held && *v != 0) {
        return Err(format!("{name} {v} in state {state}"));
    }
    let uncorrected = matches!(st.state, DeviceState::Idle | DeviceState::Stopped)
        || matches!(
            st.mute_reason,
            MuteReason::WaitingForTracking | MuteReason::CentroidOutOfRange
        );
    let c = st.correction_um;
    if uncorrected && c != [0; 3] {
        return Err(format!(
            "correction_um {c:?} in state {state} with mute reason `{}` (no correction \
             applies there)",
            st.mute_reason
        ));
    }
    // A correction steers within a work volume: at most MAX_OFFSET_UM.
    let max = i128::from(*MAX_OFFSET_UM.end());
    if c.iter().map(|v| i128::from(*v).pow(2)).sum::<i128>() > max * max {
        return Err(format!(
            "correction_um {c:?}, farther than the largest work volume ({max} µm)"
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

/// Why `t` cannot be a `SelfTestResult` of the LM firmware, if it
/// cannot: the parser holds each outcome to its own fields (SPEC section
/// 3); these are the counts' relations: a test passed or failed over some
/// bytes, a failure has a mismatch, no more mismatches than bytes, its
/// first one among them, and a byte read back that differs from the one
/// sent there.
pub fn check_self_test(t: &SelfTest) -> Result<(), String> {
    match *t {
        SelfTest::Passed { bytes: 0 } => Err("outcome passed over 0 bytes".into()),
        SelfTest::Failed {
            bytes, mismatches, ..
        } if mismatches == 0 || mismatches > bytes => Err(format!(
            "outcome failed with {mismatches} mismatches in {bytes} bytes"
        )),
        SelfTest::Failed {
            bytes,
            first_mismatch,
            ..
        } if first_mismatch >= bytes => Err(format!(
            "first_mismatch {first_mismatch} past the {bytes} bytes tested"
        )),
        SelfTest::Failed {
            first_mismatch,
            sent,
            got,
            ..
        } if sent == got => Err(format!(
            "a mismatch at byte {first_mismatch} that sent and got the same {sent:#04x}"
        )),
        SelfTest::Unsupported | SelfTest::Passed { .. } | SelfTest::Failed { .. } => Ok(()),
    }
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
#[path = "reply_tests.rs"]
mod tests;
