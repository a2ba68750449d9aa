//! The host lease: a play ends when the host goes quiet.

use super::*;

/// An untracked play of a 10-step, 1 ms-a-step slot, started at `t0` with
/// a `lease_ms` lease (1 MHz timer: counts are µs).
fn leased_device(lease_ms: u16, t0: u64) -> lm_fw_core::Device<'static> {
    let (mut dev, _) = device_with_a();
    acks(&mut dev, 1, &leased(play_untracked(0), lease_ms), t0);
    dev
}

/// The host goes quiet after its `Play`: the play ends exactly one lease
/// later, at a deadline `poll` itself asked for; every frame before it
/// sounds, the frame at it is muted, none follows; `Status` says why and
/// counts it.
#[test]
fn a_play_ends_when_its_host_lease_expires() {
    let t0 = 5_000;
    let mut dev = leased_device(1000, t0);
    let expiry = t0 + 1_000_000;
    let mut out = Capture::default();
    let end = poll_out(&mut dev, t0, &mut out, 100_000);
    assert_eq!(end, expiry, "the last deadline is the lease's end");
    let (last, before) = out.frames.split_last().unwrap();
    assert!(before.iter().all(|f| f.3 == 255 && f.0 < expiry));
    // Every step up to the expiry played (1 ms each).
    assert_eq!(before.len(), 1000);
    assert_eq!((last.0, last.3), (expiry, 0), "muted at the expiry");
    assert_eq!(dev.poll(expiry + 60_000_000, &mut out), None);
    assert_eq!(out.frames.len(), 1001, "no frame after the expiry");
    let st = status(&mut dev, expiry + 1);
    assert_eq!(
        (st.state, st.mute_reason, st.lease_ms, st.lease_expiries),
        (DeviceState::Stopped, MuteReason::LeaseExpired, 1000, 1)
    );
    assert_eq!(dev.counters().lease_expiries, 1);
    // A status request after the end does not revive it.
    assert_eq!(status(&mut dev, expiry + 2).state, DeviceState::Stopped);
    assert_eq!(dev.next_deadline(), None);
}

/// Every accepted request renews the lease: `Renew`, `GetStatus`, a
/// centroid, an upload's chunk; a refused one does not.
#[test]
fn accepted_requests_renew_the_lease_and_refused_ones_do_not() {
    let t0 = 0;
    let mut dev = leased_device(1000, t0);
    let mut out = Capture::default();
    let mut now = t0;
    for k in 0..9u16 {
        // 900 ms apart, for 8 s: eight leases' worth.
        now += 900_000;
        assert!(dev.poll(now, &mut out).is_some());
        let renewal = match k % 3 {
            0 => Message::Renew,
            1 => Message::GetStatus,
            _ => centroid(u32::from(k), [0, 0, 200_000], true),
        };
        let r = request(&mut dev, 10 + k, &renewal, now);
        assert!(!matches!(r, Reply::Nack(_)), "{r:?}");
        assert!(dev.is_sounding(now), "still playing at {now}");
    }
    assert_eq!(status(&mut dev, now).state, DeviceState::Playing);
    // A refused request (no such slot) is not a renewal.
    let last = now;
    nacks(
        &mut dev,
        30,
        &play(40, PlayAt::Immediate),
        last + 500_000,
        NackCode::BadSlot,
    );
    let end = poll_out(&mut dev, last + 500_000, &mut out, 100_000);
    assert_eq!(end, last + 1_000_000);
    assert_eq!(out.frames.last().unwrap().3, 0);
    // The status request at `last` renewed it, the nack did not.
    let st = status(&mut dev, end);
    assert_eq!(
        (st.state, st.mute_reason),
        (DeviceState::Stopped, MuteReason::LeaseExpired)
    );
    assert!(
        out.frames
            .iter()
            .all(|f| f.3 == 0 || f.0 < last + 1_000_000)
    );
}

/// A poll long after the expiry (a busy or sleeping board) still stops at
/// once with a muted frame, and hands out none of the steps it missed; a
/// request arriving late stops the play before it is answered, so it
/// cannot revive it.
#[test]
fn a_late_poll_or_request_still_stops_and_never_revives() {
    let mut dev = leased_device(1000, 0);
    let mut out = Capture::default();
    dev.poll(0, &mut out);
    assert_eq!(out.frames.len(), 1);
    dev.poll(7_000_000, &mut out);
    assert_eq!(out.frames.len(), 2);
    assert_eq!(out.frames[1].3, 0, "the late poll's frame is muted");
    assert_eq!(dev.poll(7_000_001, &mut out), None);
    assert_eq!(
        status(&mut dev, 7_000_002).mute_reason,
        MuteReason::LeaseExpired
    );

    let mut dev = leased_device(1000, 0);
    let mut out = Capture::default();
    dev.poll(0, &mut out);
    // No poll since: the request comes 3 s late.
    acks(&mut dev, 5, &Message::Renew, 3_000_000);
    assert!(!dev.is_sounding(3_000_000));
    dev.poll(3_000_000, &mut out);
    assert_eq!(out.frames.last().unwrap().3, 0);
    let st = status(&mut dev, 3_000_001);
    assert_eq!((st.state, st.lease_expiries), (DeviceState::Stopped, 1));
}

/// Every kind of play has the lease: tracked (even while muted), and timed
/// (a long timed play ends at the lease, not at its steps); a long frame
/// repeat ends with it. A `Stop` before the expiry is a plain stop.
#[test]
fn every_play_has_the_lease_and_stop_is_not_an_expiry() {
    // Tracked, waiting for a finger.
    let mut cfg = config(8);
    cfg.require_tracking = true;
    let mut dev = device(cfg, 10 * 8);
    Seq::pattern(10, 8, 10_000, 5).upload(&mut dev, 0, Encoding::Raw, 0);
    acks(&mut dev, 1, &leased(play(0, PlayAt::Immediate), 250), 0);
    assert_eq!(
        status(&mut dev, 1).mute_reason,
        MuteReason::WaitingForTracking
    );
    let mut out = Capture::default();
    // The status request at 1 µs renewed it.
    assert_eq!(poll_out(&mut dev, 1, &mut out, 10_000), 250_001);
    assert_eq!(
        status(&mut dev, 250_002).mute_reason,
        MuteReason::LeaseExpired
    );

    // Timed: 100 000 steps of 1 ms would take 100 s.
    let (mut dev, _) = device_with_a();
    acks(
        &mut dev,
        1,
        &leased(play_steps(0, PlayAt::Immediate, 100_000), 100),
        0,
    );
    let mut out = Capture::default();
    assert_eq!(poll_out(&mut dev, 0, &mut out, 1_000_000), 100_000);
    assert_eq!(out.frames.iter().filter(|f| f.3 == 255).count(), 100);

    // A 300 ms dwell repeated every 50 ms: the repeats end at the expiry.
    let mut dev = device(config(8), 2 * 8);
    Seq::pattern(2, 8, 600_000, 3).upload(&mut dev, 0, Encoding::Raw, 0);
    acks(&mut dev, 1, &leased(play_untracked(0), 1000), 0);
    let mut out = Capture::default();
    assert_eq!(poll_out(&mut dev, 0, &mut out, 10_000), 1_000_000);
    let (last, before) = out.frames.split_last().unwrap();
    assert!(before.iter().all(|f| f.3 == 255 && f.0 < 1_000_000));
    assert_eq!(last.3, 0);

    // Stop within the lease: reason Stopped, nothing counted.
    let mut dev = leased_device(1000, 0);
    acks(&mut dev, 2, &Message::Stop, 500_000);
    let mut out = Capture::default();
    assert_eq!(dev.poll(500_000, &mut out), None);
    let st = status(&mut dev, 5_000_000);
    assert_eq!(
        (st.mute_reason, st.lease_expiries),
        (MuteReason::Stopped, 0)
    );
}

/// `Play.lease_ms` outside 100 ..= 60000 is out of range (0 included:
/// there is no "forever"), checked after the slot number and before the
/// entry; a refused play changes nothing.
#[test]
fn a_lease_outside_its_bounds_is_refused() {
    let (mut dev, _) = device_with_a();
    for bad in [0, 1, 99, 60_001, u16::MAX] {
        nacks(
            &mut dev,
            1,
            &leased(play(0, PlayAt::Immediate), bad),
            0,
            NackCode::OutOfRange,
        );
        nacks(
            &mut dev,
            2,
            &leased(play(40, PlayAt::Immediate), bad),
            0,
            NackCode::BadSlot,
        );
        nacks(
            &mut dev,
            3,
            &leased(play(5, PlayAt::Immediate), bad),
            0,
            NackCode::OutOfRange,
        );
    }
    assert_eq!(status(&mut dev, 0).state, DeviceState::Idle);
    for ok in [100, 1000, 60_000] {
        acks(&mut dev, 4, &leased(play(0, PlayAt::Immediate), ok), 0);
        assert_eq!(status(&mut dev, 0).lease_ms, ok);
    }
}
