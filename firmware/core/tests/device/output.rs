//! What sounds: gating by the centroid, its correction, the work volume, untracked play and frame repeats.

use super::*;

#[test]
fn gating_mutes_and_resumes() {
    let a = Seq::pattern(100, 8, 100_000, 7); // 1 ms steps
    let mut dev = tracked_device(&a);
    let mut cap = Capture::default();
    acks(&mut dev, 1, &play(0, PlayAt::Immediate), 0);
    let mut now = 0;
    // Before the first centroid: muted (require_tracking).
    for _ in 0..3 {
        now = dev.poll(now, &mut cap).unwrap();
    }
    assert!(cap.frames.iter().all(|f| f.3 == 0));
    assert_eq!(status(&mut dev, now).state, DeviceState::Muted);
    acks(&mut dev, 2, &centroid(1, a.center_um, true), now);
    now = dev.poll(now, &mut cap).unwrap();
    assert_eq!(cap.frames.last().unwrap().3, 255);
    // Presence false mutes at once (the next poll re-sends the step muted).
    assert_eq!(
        request(&mut dev, 3, &centroid(2, a.center_um, false), now + 10),
        Reply::Ack
    );
    let n = cap.frames.len();
    dev.poll(now + 10, &mut cap);
    assert_eq!(cap.frames.len(), n + 1);
    assert_eq!(cap.frames.last().unwrap().3, 0);
    // Stale seq is refused and does not resume.
    assert_eq!(
        request(&mut dev, 4, &centroid(2, a.center_um, true), now + 20),
        Reply::Nack(NackCode::OutOfOrder)
    );
    now = dev.poll(now + 20, &mut cap).unwrap();
    now = dev.poll(now, &mut cap).unwrap();
    assert_eq!(cap.frames.last().unwrap().3, 0);
    // Fresh update resumes at the next step.
    acks(&mut dev, 5, &centroid(3, a.center_um, true), now);
    let t_update = now;
    now = dev.poll(now, &mut cap).unwrap();
    now = dev.poll(now, &mut cap).unwrap();
    assert_eq!(cap.frames.last().unwrap().3, 255);
    // Timeout: no update for > 100 ms mutes within one step (1 ms).
    while now <= t_update + 100_000 {
        now = dev.poll(now, &mut cap).unwrap();
        assert_eq!(cap.frames.last().unwrap().3, 255, "at {now}");
    }
    now = dev.poll(now, &mut cap).unwrap();
    let last = cap.frames.last().unwrap();
    assert_eq!(last.3, 0);
    assert!(last.0 <= t_update + 100_000 + 1000);
    // Settable timeout.
    dev.set_centroid_timeout_us(1_000_000);
    now = dev.poll(now, &mut cap).unwrap();
    assert_eq!(cap.frames.last().unwrap().3, 255);
    // Stop mutes at once.
    assert_eq!(request(&mut dev, 6, &Message::Stop, now + 3), Reply::Ack);
    assert_eq!(dev.poll(now + 3, &mut cap), None);
    assert_eq!(cap.frames.last().unwrap().3, 0);
    assert_eq!(status(&mut dev, now).state, DeviceState::Stopped);
}

#[test]
fn centroid_correction_is_added_from_the_next_step() {
    let mut dev = device(config(252), 10 * 252);
    let a = Seq::pattern(10, 252, 10_000, 8);
    a.upload(&mut dev, 0, Encoding::Raw, 0);
    let mut cap = Capture::default();
    request(&mut dev, 1, &play(0, PlayAt::Immediate), 0);
    let now = dev.poll(0, &mut cap).unwrap();
    let c = [3_000, -2_000, 204_000];
    assert!(
        dev.offsets().is_empty(),
        "no correction before the first centroid"
    );
    assert_eq!(
        request(&mut dev, 2, &centroid(9, c, true), now - 1),
        Reply::Ack
    );
    assert_eq!(status(&mut dev, now).correction_um, [3_000, -2_000, 4_000]);
    dev.poll(now, &mut cap).unwrap();
    let (_, _, step, _, ph) = cap.frames.last().unwrap().clone();
    let lsbs = expected_offsets(&a, c, 340_000);
    for (j, lsb) in lsbs.iter().enumerate() {
        let want = a.step(step)[j].wrapping_add(*lsb);
        let diff = ph[j].wrapping_sub(want) as i8;
        assert!(diff.abs() <= 1, "transducer {j}: {} vs {want}", ph[j]);
    }
    let nonzero = lsbs.iter().filter(|&&lsb| lsb != 0).count();
    assert!(nonzero > 200, "a 5 mm shift moves most phases");
    assert_eq!(dev.offsets().len(), 252);
}

/// Offsets (u8 LSB) a sequence planned for `seq.center_um` at `speed_mm_s`
/// needs for centroid `c`, in f64.
fn expected_offsets(seq: &Seq, c: [i32; 3], speed_mm_s: u32) -> Vec<u8> {
    let k = 2.0 * std::f64::consts::PI * 40_000.0 / (f64::from(speed_mm_s) * 1e3); // rad/µm
    seq.positions
        .iter()
        .map(|x| {
            let d = |p: [i32; 3]| {
                (0..3)
                    .map(|i| (f64::from(x[i]) - f64::from(p[i])).powi(2))
                    .sum::<f64>()
                    .sqrt()
            };
            let dphi = k * (d(seq.center_um) - d(c));
            ((dphi / (2.0 * std::f64::consts::PI) * 256.0).round() as i64).rem_euclid(256) as u8
        })
        .collect()
}

/// Transducers whose offset differs from `want` by more than 1 LSB.
fn off_by_more_than_one(got: &[u8], want: &[u8]) -> usize {
    assert_eq!(got.len(), want.len());
    got.iter()
        .zip(want)
        .filter(|(g, w)| (g.wrapping_sub(**w) as i8).abs() > 1)
        .count()
}

#[test]
fn correction_follows_each_slots_uploaded_sound_speed() {
    let mut dev = device(config(252), 10 * 252);
    let a = Seq::pattern(10, 252, 10_000, 8); // planned at 340 m/s
    let mut b = a.clone();
    b.sound_speed_mm_s = 350_000;
    // Zero or implausible speeds are refused before anything changes.
    for (i, speed) in [0, 99_999, 2_000_001].into_iter().enumerate() {
        let mut z = a.clone();
        z.sound_speed_mm_s = speed;
        assert_eq!(
            request(&mut dev, i as u16, &z.begin(0, Encoding::Raw), 0),
            Reply::Nack(NackCode::OutOfRange),
            "{speed} mm/s"
        );
    }
    a.upload(&mut dev, 0, Encoding::Raw, 0);
    b.upload(&mut dev, 1, Encoding::Raw, 0);
    let c = [9_000, -6_000, 212_000];
    let (want_a, want_b) = (
        expected_offsets(&a, c, 340_000),
        expected_offsets(&b, c, 350_000),
    );
    // The two wavenumbers differ by 3 %: enough to move most offsets.
    assert!(off_by_more_than_one(&want_a, &want_b) > 150);

    let mut cap = Capture::default();
    request(&mut dev, 10, &play(0, PlayAt::Immediate), 0);
    let now = dev.poll(0, &mut cap).unwrap();
    acks(&mut dev, 11, &centroid(1, c, true), now);
    assert_eq!(off_by_more_than_one(dev.offsets(), &want_a), 0);

    // Same geometry, same centres, same centroid: only k differs.
    request(&mut dev, 12, &play(1, PlayAt::Immediate), now);
    dev.poll(now, &mut cap).unwrap();
    assert_eq!(off_by_more_than_one(dev.offsets(), &want_b), 0);

    // And back: the slot's own speed comes back with it.
    request(&mut dev, 13, &play(0, PlayAt::Immediate), now + 1);
    dev.poll(now + 1, &mut cap).unwrap();
    assert_eq!(off_by_more_than_one(dev.offsets(), &want_a), 0);
}

/// A step of 300 ms outlasts the driver's 100 ms timeout: its frame goes
/// out again every 50 ms, unchanged, until the next step; Stop ends the
/// repeats with its muted frame; 0 turns them off.
#[test]
fn a_long_dwell_is_repeated_before_the_drivers_timeout_until_stop() {
    for repeat_us in [50_000, 0] {
        let mut cfg = config(8);
        cfg.frame_repeat_us = repeat_us;
        let mut dev = device(cfg, 2 * 8);
        let a = Seq::pattern(2, 8, 600_000, 3);
        a.upload(&mut dev, 0, Encoding::Raw, 0);
        // No request comes while it plays: a lease longer than the run.
        acks(&mut dev, 1, &leased(play_untracked(0), 60_000), 1_000);
        let mut out = Capture::default();
        let mut now = 1_000;
        while now < 1_000 + 1_200_000 {
            now = dev.poll(now, &mut out).unwrap();
        }
        let f = &out.frames;
        if repeat_us == 0 {
            // Only the step boundaries: 300 ms apart.
            assert!(
                f.windows(2).all(|w| w[1].0 - w[0].0 == 300_000),
                "{:?}",
                f.iter().map(|x| x.0).collect::<Vec<_>>()
            );
            continue;
        }
        assert!(
            f.windows(2).all(|w| w[1].0 - w[0].0 <= 50_000),
            "a gap over 50 ms"
        );
        // Six frames per 300 ms step, each the step's phases at full amplitude.
        assert_eq!(
            f.len(),
            4 * 6,
            "{:?}",
            f.iter().map(|x| (x.0, x.2)).collect::<Vec<_>>()
        );
        for (k, x) in f.iter().enumerate() {
            let step = ((k / 6) % 2) as u16;
            assert_eq!(
                (x.2, x.3, x.4.as_slice()),
                (step, 255, a.step(step)),
                "frame {k}"
            );
        }
        // Stop: one muted frame, then nothing more to send.
        acks(&mut dev, 2, &Message::Stop, now);
        out.frames.clear();
        assert_eq!(dev.poll(now, &mut out), None);
        assert_eq!(out.frames.len(), 1);
        assert_eq!(out.frames[0].3, 0);
        assert_eq!(dev.next_deadline(), None);
        assert_eq!(dev.poll(now + 500_000, &mut out), None);
        assert_eq!(out.frames.len(), 1, "no repeats after Stop");
    }
}

#[test]
fn play_while_playing_accepts_a_restarted_centroid_sequence() {
    let a = Seq::pattern(10, 8, 10_000, 9);
    let mut dev = tracked_device(&a);
    let mut cap = Capture::default();
    acks(&mut dev, 1, &play(0, PlayAt::Immediate), 0);
    acks(&mut dev, 2, &centroid(500, a.center_um, true), 0);
    let mut now = dev.poll(0, &mut cap).unwrap();
    nacks(
        &mut dev,
        3,
        &centroid(1, a.center_um, true),
        now,
        NackCode::OutOfOrder,
    );
    // The host restarts and re-plays: its sequence starts at 1 again.
    acks(&mut dev, 4, &play(0, PlayAt::NextCycle), now);
    now = dev.poll(now, &mut cap).unwrap();
    assert_eq!(cap.frames.last().unwrap().3, 255, "no glitch on re-play");
    acks(&mut dev, 5, &centroid(1, a.center_um, true), now);
    assert_eq!(status(&mut dev, now).last_centroid_seq, 1);
    // After Stop, a new session needs fresh tracking again.
    acks(&mut dev, 6, &Message::Stop, now);
    acks(&mut dev, 7, &play(0, PlayAt::Immediate), now);
    dev.poll(now, &mut cap);
    assert_eq!(cap.frames.last().unwrap().3, 0);
}

#[test]
fn centroids_outside_the_work_volume_are_refused_and_mute() {
    let seq = Seq::pattern(10, 16, 10_000, 2);
    let mut dev = tracked_device(&seq);
    acks(&mut dev, 1, &play(0, PlayAt::Immediate), 0);
    let s = status(&mut dev, 0);
    assert_eq!(s.state, DeviceState::Muted);
    assert_eq!(s.mute_reason, MuteReason::WaitingForTracking);
    let c0 = seq.center_um;
    let at = |dx: i32, dy: i32| [c0[0] + dx, c0[1] + dy, c0[2]];
    // 5 mm off the centre: inside the 20 mm work volume, steers.
    acks(&mut dev, 2, &centroid(1, at(3000, 4000), true), 10);
    let mut out = Capture::default();
    dev.poll(10, &mut out);
    assert!(dev.is_sounding(10));
    assert!(dev.offsets().iter().any(|o| *o != 0));
    assert_eq!(status(&mut dev, 10).correction_um, [3000, 4000, 0]);
    // 20.0008 mm away: refused, muted at once, correction dropped.
    for (k, pos) in [
        at(12_000, 16_001),
        [i32::MIN, i32::MAX, i32::MIN],
        [c0[0], c0[1], i32::MAX],
    ]
    .into_iter()
    .enumerate()
    {
        let k = k as u32;
        assert_eq!(
            request(&mut dev, 3, &centroid(2 + k, pos, true), 20),
            Reply::Nack(NackCode::OutOfRange),
            "{pos:?}"
        );
        assert!(!dev.is_sounding(20));
        let s = status(&mut dev, 20);
        assert_eq!(s.state, DeviceState::Muted);
        assert_eq!(s.mute_reason, MuteReason::CentroidOutOfRange);
        assert_eq!(s.correction_um, [0; 3]);
        out.frames.clear();
        dev.poll(20, &mut out);
        assert_eq!(out.frames.last().map(|f| f.3), Some(0), "muted frame");
    }
    // Still muted as time passes (a refused centroid never opens the gate).
    let later = 5_000;
    assert!(!dev.is_sounding(later));
    // An absent finger keeps it muted, for that reason.
    assert_eq!(
        request(&mut dev, 4, &centroid(10, [0; 3], false), 30),
        Reply::Ack
    );
    assert_eq!(status(&mut dev, 30).mute_reason, MuteReason::FingerAbsent);
    // Exactly 20 mm away is inside: sounds again.
    acks(&mut dev, 5, &centroid(11, at(12_000, 16_000), true), 40);
    assert!(dev.is_sounding(40));
    let s = status(&mut dev, 40);
    assert_eq!(
        (s.state, s.mute_reason),
        (DeviceState::Playing, MuteReason::None)
    );
    assert_eq!(s.correction_um, [12_000, 16_000, 0]);
}

#[test]
fn a_queued_slot_with_another_centre_mutes_an_out_of_range_centroid() {
    let a = Seq::pattern(10, 16, 10_000, 2);
    let mut dev = tracked_device(&a);
    let mut b = Seq::pattern(10, 16, 10_000, 3);
    b.center_um = [50_000, 0, 200_000];
    b.upload(&mut dev, 1, Encoding::Raw, 0);
    acks(&mut dev, 1, &play(0, PlayAt::Immediate), 0);
    acks(&mut dev, 2, &centroid(1, a.center_um, true), 0);
    acks(&mut dev, 3, &play(1, PlayAt::NextCycle), 100);
    assert_eq!(status(&mut dev, 100).queued_slot, Some(1));
    let mut out = Capture::default();
    let mut now = 100;
    let mut k = 2;
    while dev.status(now).slot != Some(1) {
        // Fresh tracking at slot 0's centre while slot 0 plays.
        acks(&mut dev, 4, &centroid(k, a.center_um, true), now);
        k += 1;
        now = dev.poll(now, &mut out).unwrap();
        assert!(now < 100_000, "swap never happened");
    }
    let s = status(&mut dev, now);
    assert_eq!(s.queued_slot, None);
    assert_eq!(
        s.mute_reason,
        MuteReason::CentroidOutOfRange,
        "50 mm from slot 1's centre"
    );
    assert_eq!(out.frames.last().map(|f| (f.1, f.3)), Some((1, 0)));
}

#[test]
fn untracked_play_sounds_without_a_finger_until_stop() {
    let seq = Seq::pattern(10, 16, 10_000, 2);
    let mut dev = tracked_device(&seq);
    acks(&mut dev, 1, &play_untracked(0), 0);
    let mut out = Capture::default();
    let mut now = 0;
    for _ in 0..30 {
        now = dev.poll(now, &mut out).unwrap();
    }
    assert!(
        out.frames.iter().all(|f| f.3 == 255),
        "full amplitude throughout"
    );
    // Planned phases, uncorrected, even with a centroid far from the centre.
    let off = [seq.center_um[0] + 5000, seq.center_um[1], seq.center_um[2]];
    acks(&mut dev, 2, &centroid(1, off, true), now);
    assert_eq!(
        request(&mut dev, 3, &centroid(2, [0; 3], false), now),
        Reply::Ack
    );
    out.frames.clear();
    now = dev.poll(now + 10_000, &mut out).unwrap();
    let f = out.frames.last().unwrap();
    assert_eq!((f.3, &f.4[..]), (255, seq.step(f.2)));
    assert!(dev.offsets().is_empty());
    let s = status(&mut dev, now);
    assert_eq!(
        (s.state, s.mute_reason),
        (DeviceState::Playing, MuteReason::None)
    );
    // Stop still stops.
    acks(&mut dev, 4, &Message::Stop, now);
    out.frames.clear();
    dev.poll(now, &mut out);
    assert_eq!(out.frames.last().map(|f| f.3), Some(0));
    let s = status(&mut dev, now);
    assert_eq!(
        (s.state, s.mute_reason),
        (DeviceState::Stopped, MuteReason::Stopped)
    );
    // A tracked Play ends the untracked session.
    acks(&mut dev, 5, &play(0, PlayAt::Immediate), now);
    assert_eq!(
        status(&mut dev, now).mute_reason,
        MuteReason::WaitingForTracking
    );
}
