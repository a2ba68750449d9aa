//! Plays of a given number of steps.

use super::*;

#[test]
fn timed_play_outputs_exactly_its_steps_then_mutes_at_the_boundary() {
    // 10 steps of 1 ms.
    let (mut dev, a) = device_with_a();
    acks(&mut dev, 1, &play_steps(0, PlayAt::Immediate, 23), 100);
    let mut out = Capture::default();
    let end = poll_out(&mut dev, 100, &mut out, 1000);
    let sounding: Vec<_> = out.frames.iter().filter(|f| f.3 == 255).collect();
    assert_eq!(sounding.len(), 23);
    for (k, f) in sounding.iter().enumerate() {
        assert_eq!((f.0, f.2), (100 + k as u64 * 1000, (k % 10) as u16));
        assert_eq!(f.4.as_slice(), a.step(f.2));
    }
    // The mute goes out at the 23rd boundary, not later, and is the last frame.
    let last = out.frames.last().unwrap();
    assert_eq!((last.0, last.3), (100 + 23_000, 0));
    assert_eq!(out.frames.len(), 24);
    assert_eq!(dev.next_deadline(), None);
    assert!(!dev.is_sounding(end));
    let s = status(&mut dev, end + 50_000);
    assert_eq!(
        (s.state, s.mute_reason, s.slot, s.queued_slot),
        (DeviceState::Stopped, MuteReason::Stopped, Some(0), None)
    );
    assert_eq!((s.cycles, s.step), (2, 3));
    assert_eq!(s.cycles * 10 + u32::from(s.step), 23);
    assert_eq!(s.missed_deadlines, 0);
    // A later Play starts afresh, without the old limit.
    acks(
        &mut dev,
        2,
        &play_steps(0, PlayAt::Immediate, 0),
        end + 50_000,
    );
    out.frames.clear();
    poll_out(&mut dev, end + 50_000, &mut out, 100);
    assert_eq!(out.frames.len(), 100);
    assert!(out.frames.iter().all(|f| f.3 == 255));
    assert_eq!(status(&mut dev, 0).state, DeviceState::Playing);
}

#[test]
fn queued_timed_play_counts_from_the_takeover() {
    let (mut dev, _, _) = device_with_a_and_b();
    let mut out = Capture::default();
    acks(&mut dev, 1, &play_steps(0, PlayAt::Immediate, 0), 100);
    let mut now = 100;
    for _ in 0..3 {
        now = dev.poll(now, &mut out).unwrap();
    }
    acks(&mut dev, 2, &play_steps(1, PlayAt::NextCycle, 7), now);
    poll_out(&mut dev, now, &mut out, 1000);
    let b_frames: Vec<_> = out.frames.iter().filter(|f| f.1 == 1).collect();
    // 7 sounding steps of slot 1 from the boundary at 10.1 ms, 2 ms each,
    // then the mute at 7 × 2 ms after the takeover.
    assert_eq!(b_frames.iter().filter(|f| f.3 == 255).count(), 7);
    assert_eq!(b_frames[0].0, 100 + 10_000);
    let last = out.frames.last().unwrap();
    assert_eq!((last.0, last.1, last.3), (100 + 10_000 + 14_000, 1, 0));
    let s = status(&mut dev, last.0);
    assert_eq!(
        (s.state, s.slot, s.cycles, s.step, s.missed_deadlines),
        (DeviceState::Stopped, Some(1), 1, 2, 0)
    );
}

#[test]
fn timed_play_missed_deadlines_around_the_limit_still_stop_at_the_limit() {
    let (mut dev, _) = device_with_a();
    acks(&mut dev, 1, &play_steps(0, PlayAt::Immediate, 12), 0);
    let mut out = Capture::default();
    for now in [0, 1000, 2000] {
        dev.poll(now, &mut out);
    }
    // The device stalls from 2.5 ms to 40 ms: steps 3..=11 are never entered.
    assert_eq!(dev.poll(40_000, &mut out), None);
    let last = out.frames.last().unwrap();
    assert_eq!((last.0, last.2, last.3), (12_000, 2, 0));
    assert_eq!(out.frames.iter().filter(|f| f.3 == 255).count(), 3);
    let s = status(&mut dev, 40_000);
    assert_eq!(
        (s.state, s.cycles, s.step, s.missed_deadlines),
        (DeviceState::Stopped, 1, 2, 9)
    );
}

#[test]
fn stop_or_a_new_play_replaces_the_limit() {
    let (mut dev, _) = device_with_a();
    let mut out = Capture::default();
    // Limit 3, replaced at 1.5 ms by a play without one (same slot).
    acks(&mut dev, 1, &play_steps(0, PlayAt::Immediate, 3), 0);
    dev.poll(0, &mut out);
    dev.poll(1000, &mut out);
    acks(&mut dev, 2, &play_steps(0, PlayAt::Immediate, 0), 1500);
    poll_out(&mut dev, 1500, &mut out, 50);
    assert_eq!(status(&mut dev, 0).state, DeviceState::Playing);
    assert!(out.frames.iter().all(|f| f.3 == 255));
    // Stop, then a timed play again: its own limit, from its start.
    acks(&mut dev, 3, &Message::Stop, 100_000);
    acks(&mut dev, 4, &play_steps(0, PlayAt::Immediate, 4), 100_000);
    out.frames.clear();
    poll_out(&mut dev, 100_000, &mut out, 50);
    assert_eq!(out.frames.iter().filter(|f| f.3 == 255).count(), 4);
    assert_eq!(out.frames.last().map(|f| (f.0, f.3)), Some((104_000, 0)));
}
