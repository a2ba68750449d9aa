//! When the AUTD3 backend sounds, switches, stops and falls silent, on the
//! emulator's manual clock: onset from silence, switches at the cycle end,
//! timed plays and counters from the firmware's player, and the lease that
//! silences the array without the host.

use super::*;
use crate::device::backend::ErrorKind;
use lm_proto::PlayAt;

/// Two plans of the same N and dwell (LM-S at 3 and 5 mm) in slots 1 and 0.
fn two_slots(scene: &Scene, b: &mut Autd3Backend) -> (Plan, Plan, GridTiming) {
    let (x, g) = lm(scene, 3.0, 1);
    let mut p = LmParams::paper(scene.center_mm);
    p.cycle.radius_mm = 5.0;
    p.cycle.steps = Steps::Count(g.steps);
    let (y, gy) = timing::plan(&p, scene, &Synthesis::Linear).unwrap();
    assert_eq!((gy.steps, gy.divide), (g.steps, g.divide));
    assert_eq!(b.upload(&x, Some(1)).unwrap().slot, 1);
    assert_eq!(b.upload(&y, Some(0)).unwrap().slot, 0);
    (x, y, g)
}

/// What the array emits: the modulation times the STM's intensity, the
/// largest over every board (0: silent everywhere).
fn output(h: &EmulatorHandle) -> u16 {
    h.with_cpus(|c| {
        c.iter()
            .map(|cpu| {
                let f = cpu.fpga();
                let drive = f.drives().iter().map(|d| d.intensity.0).max().unwrap_or(0);
                u16::from(f.modulation()) * u16::from(drive) / 255
            })
            .max()
            .unwrap_or(0)
    })
}

/// Whether every board plays `plan`'s pattern at the FPGA's STM index, in
/// `slot`'s segment (the stimulus that sounds is that slot's).
fn plays(h: &EmulatorHandle, plan: &Plan, slot: u8) -> bool {
    let t = plan.sequence.header.transducers as usize;
    let seg = if slot == 0 { Segment::S0 } else { Segment::S1 };
    h.with_cpus(|cpus| {
        cpus.iter().all(|cpu| {
            let f = cpu.fpga();
            let corr = f.phase_correction();
            let j = f.current_stm_idx();
            f.current_stm_segment() == seg
                && f.drives().iter().enumerate().all(|(i, d)| {
                    d.phase.0.wrapping_sub(corr[i].0)
                        == plan.sequence.phases[j * t + cpu.idx() * 249 + i]
                })
        })
    })
}

fn count(st: &lm_proto::Status, n: u64) -> u64 {
    u64::from(st.cycles) * n + u64::from(st.step)
}

/// Issue 32.1: from silence a resident stimulus sounds within one dwell
/// and 1 ms wherever it sits (the segment the devices play or the other),
/// whatever the phase of the devices' clock; it used to wait for the rest
/// of the loop (86-182 ms).
#[test]
fn onset_from_silence_is_within_a_dwell_in_either_segment() {
    let (scene, mut b, h, clock) = open_default();
    let (x, y, g) = two_slots(&scene, &mut b);
    let limit = Duration::from_micros(u64::from(g.dwell_us) + 1000);
    let period = Duration::from_micros(g.steps as u64 * u64::from(g.dwell_us));
    for (k, slot) in [1u8, 0, 0, 1, 1, 0].into_iter().enumerate() {
        b.stop().unwrap();
        assert_eq!(output(&h), 0, "silent after stop");
        // Somewhere else in the loop each time.
        clock.advance(period * 3 + period * k as u32 / 7 + Duration::from_micros(313));
        let (t0, f0) = (clock.now(), h.frames());
        b.play(slot, true).unwrap();
        let took = clock.now() - t0;
        assert!(took <= limit, "slot {slot}: {took:?} > {limit:?}");
        // On a real link each frame is 1-2 ms: two (segment and
        // correction, then the output with its lease), never a loop.
        assert!(
            h.frames() - f0 <= 2,
            "slot {slot}: {} frames",
            h.frames() - f0
        );
        assert!(output(&h) > 0, "slot {slot} sounds at once");
        assert!(
            plays(&h, if slot == 0 { &y } else { &x }, slot),
            "slot {slot}"
        );
        let st = b.status().unwrap();
        assert_eq!((st.state, st.slot), (DeviceState::Playing, Some(slot)));
    }
}

/// A slot played while another plays takes over at the playing slot's
/// cycle end (counted from its start), not before; `Immediate` switches at
/// once; `Stop` drops a queued slot and the devices do not switch to it.
#[test]
fn a_queued_slot_takes_over_at_the_cycle_end() {
    let (scene, mut b, h, clock) = open_default();
    let (x, y, g) = two_slots(&scene, &mut b);
    let dwell = Duration::from_micros(u64::from(g.dwell_us));
    let n = g.steps as u32;
    clock.advance(Duration::from_micros(777));
    let t0 = clock.now();
    b.play(1, true).unwrap();
    clock.advance(dwell * (n / 3) + dwell / 2);
    b.play(0, true).unwrap();
    let st = b.status().unwrap();
    assert_eq!((st.slot, st.queued_slot), (Some(1), Some(0)));
    let end = t0 + dwell * n;
    // Ticked every dwell up to the end: slot 1 plays.
    while clock.now() + dwell < end {
        clock.advance(dwell);
        b.tick().unwrap();
        assert!(plays(&h, &x, 1), "switched before the cycle end");
    }
    clock.advance(end - clock.now() - Duration::from_micros(1));
    b.tick().unwrap();
    assert!(plays(&h, &x, 1), "switched before the cycle end");
    clock.advance(Duration::from_micros(1));
    b.tick().unwrap();
    assert!(plays(&h, &y, 0), "slot 0 plays from the cycle end");
    let st = b.status().unwrap();
    assert_eq!(
        (st.slot, st.queued_slot, st.step, st.cycles),
        (Some(0), None, 0, 0)
    );
    assert_eq!(st.missed_deadlines, 0, "switched on time");
    // Immediate: at once.
    b.play_at(1, PlayAt::Immediate, true).unwrap();
    assert!(plays(&h, &x, 1));
    // Queued, then stopped: the devices stay on the playing segment.
    b.play(0, true).unwrap();
    b.stop().unwrap();
    let st = b.status().unwrap();
    assert_eq!(
        (st.state, st.slot, st.queued_slot),
        (DeviceState::Stopped, Some(1), None)
    );
    clock.advance(dwell * (2 * n));
    b.tick().unwrap();
    assert_eq!(stm_segment(&h), Segment::S1);
    assert_eq!(output(&h), 0);
    // A switch the host makes late says by how much.
    b.play(1, true).unwrap();
    b.play(0, true).unwrap();
    clock.advance(dwell * (n + 5) + dwell / 2);
    b.tick().unwrap();
    assert!(plays(&h, &y, 0));
    assert_eq!(b.status().unwrap().missed_deadlines, 5);
    // Uploading into the playing slot is refused.
    assert!(b.upload(&x, Some(0)).is_err());
}

#[test]
fn play_for_is_stopped_by_the_host_once_the_players_steps_have_played() {
    let (scene, mut b, h, clock) = open_default();
    let (plan, g) = lm(&scene, 3.0, 1);
    let n = g.steps as u64;
    let slot = b.upload(&plan, None).unwrap().slot;
    let dwell = Duration::from_micros(u64::from(g.dwell_us));
    let steps = 2 * n as u32 + 3;
    b.play_for(slot, true, steps).unwrap();
    // Ticked every dwell: it sounds until the tick that sees the limit.
    let mut ticks = 0;
    loop {
        b.tick().unwrap();
        let st = b.status().unwrap();
        if st.state == DeviceState::Stopped {
            assert_eq!(count(&st, n), u64::from(steps));
            assert_eq!((st.slot, st.mute_reason), (Some(slot), MuteReason::Stopped));
            assert_eq!(st.missed_deadlines, 0);
            break;
        }
        assert_eq!(st.state, DeviceState::Playing);
        assert!(count(&st, n) < u64::from(steps));
        assert!(output(&h) > 0);
        clock.advance(dwell);
        ticks += 1;
        assert!(ticks <= 3 * n, "never stopped");
    }
    assert_eq!(output(&h), 0);
    // Frozen at the stop.
    let st = b.status().unwrap();
    clock.advance(dwell * 50);
    let later = b.status().unwrap();
    assert_eq!(
        lm_proto::Status {
            uptime_ms: st.uptime_ms,
            ..later
        },
        st
    );
    assert!(later.uptime_ms > st.uptime_ms, "its uptime goes on");
    // A late tick: counted at the limit, as the firmware, and the steps
    // that sounded past it are the host's missed deadlines.
    b.play_for(slot, true, 5).unwrap();
    clock.advance(dwell * 7 + dwell / 2);
    b.tick().unwrap();
    let st = b.status().unwrap();
    assert_eq!(st.state, DeviceState::Stopped);
    assert_eq!(count(&st, n), 5);
    assert_eq!(st.missed_deadlines, 2);
    assert_eq!(output(&h), 0);
    // 0 = until stop, ticked as a host does.
    b.play_for(slot, true, 0).unwrap();
    for _ in 0..(10 * n) {
        clock.advance(dwell);
        b.tick().unwrap();
    }
    assert_eq!(b.status().unwrap().state, DeviceState::Playing);
}

/// The counters are the player's (steps played since the start); the
/// FPGA's index runs on the devices' clock, a fixed offset from them for
/// as long as the slot plays: neither drifts.
#[test]
fn status_counts_the_steps_played_in_step_with_the_fpga() {
    let (scene, mut b, h, clock) = open_default();
    assert_eq!(b.counters_source(), "host clock");
    let (plan, g) = lm(&scene, 3.0, 1);
    let slot = b.upload(&plan, None).unwrap().slot;
    clock.advance(Duration::from_micros(12_345));
    b.play(slot, true).unwrap();
    let dwell = u64::from(g.dwell_us);
    let n = g.steps as u64;
    let offset = |st: &lm_proto::Status| {
        let fpga = h.with_cpus(|c| c[0].fpga().current_stm_idx()) as u64;
        (fpga + n - u64::from(st.step)) % n
    };
    // The player started between two of the FPGA's step boundaries: the
    // offset takes two neighbouring values, never a third.
    let first = offset(&b.status().unwrap());
    let mut seen = std::collections::BTreeSet::new();
    let mut offsets = std::collections::BTreeSet::new();
    // Every third of a dwell over two and a half cycles.
    for k in 0..(5 * n * 3 / 2) {
        clock.advance(Duration::from_micros(dwell / 3 + k % 2));
        let st = b.status().unwrap();
        let o = offset(&st);
        assert!(
            o == first || o == (first + 1) % n || o == (first + n - 1) % n,
            "at {} µs: offset {o}, first {first}",
            clock.now_us()
        );
        offsets.insert(o);
        seen.insert(st.step);
    }
    assert!(offsets.len() <= 2, "{offsets:?}");
    assert_eq!(seen.len() as u64, n, "every index of the cycle seen");
    assert!(b.status().unwrap().cycles >= 2);
}

/// Issue 26.5: a presentation the host stops renewing ends within the
/// lease. The backend is forgotten without its `Drop` (as a killed host
/// leaves it); the emulated FPGA's output is silent on every board once
/// the lease is over, and sounds until then.
#[test]
fn the_array_falls_silent_within_the_lease_once_the_host_is_gone() {
    for lease_ms in [1000u64, 300] {
        let (scene, mut b, h, clock) = open_default();
        if lease_ms != 1000 {
            b.set_lease(Duration::from_millis(lease_ms)).unwrap();
        }
        assert_eq!(b.lease(), Duration::from_millis(lease_ms));
        let (_, slot) = upload_lm_s(&mut b, &scene);
        b.play(slot, true).unwrap();
        // A while of normal play, ticked as a host does.
        for _ in 0..40 {
            clock.advance(Duration::from_millis(50));
            b.tick().unwrap();
        }
        let last = clock.now();
        std::mem::forget(b);
        assert!(output(&h) > 0, "{lease_ms} ms: sounding when the host went");
        let lease = Duration::from_millis(lease_ms);
        clock.set_us((last + lease).as_micros() as u64);
        assert_eq!(output(&h), 0, "{lease_ms} ms: silent at the lease's end");
        clock.advance(Duration::from_secs(3600));
        assert_eq!(output(&h), 0, "{lease_ms} ms: and for good");
    }
}

/// While the host renews, the level never dips: sampled every 1 ms over
/// five leases, across every renewal's switch.
#[test]
fn renewals_keep_the_output_level_without_a_gap() {
    let (scene, mut b, h, clock) = open_default();
    let half = half_intensity(&scene);
    let slot = b.upload(&half, None).unwrap().slot;
    b.play(slot, true).unwrap();
    let mods = |h: &EmulatorHandle| h.with_cpus(|c| c.iter().map(|c| c.fpga().modulation()).min());
    for ms in 0..5000u64 {
        if ms % 100 == 0 {
            b.tick().unwrap();
        }
        assert_eq!(mods(&h), Some(128), "at {ms} ms");
        clock.advance(Duration::from_millis(1));
    }
    // Five leases, renewed at each half: the segments swapped about ten times.
    assert_state(&mut b, DeviceState::Playing, MuteReason::None);
}

/// A host that comes back after its lease ran out finds the play over,
/// as on the LM firmware: the array went silent and stays so.
#[test]
fn a_lapsed_lease_ends_the_play() {
    let (scene, mut b, h, clock) = open_default();
    let (_, slot) = upload_lm_s(&mut b, &scene);
    b.play(slot, true).unwrap();
    clock.advance(Duration::from_millis(1500));
    assert_eq!(output(&h), 0);
    assert_state(&mut b, DeviceState::Stopped, MuteReason::Stopped);
    assert_eq!(output(&h), 0);
    // A new play sounds again.
    b.play(slot, true).unwrap();
    assert!(output(&h) > 0);
    let e = b.set_lease(Duration::from_millis(50)).unwrap_err();
    assert!(e.to_string().contains("0.2..=10 s"), "{e}");
    let e = Backend::set_lease(&mut b, Duration::from_secs(60)).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Input);
}

/// An AM stimulus: its envelope on the array from one switch margin after
/// the play, running on across renewals (every sample of each period seen
/// at its level), muted at once by a stop, and silent by itself within
/// the lease once the host is gone.
#[test]
fn an_am_stimulus_sounds_its_envelope_across_renewals_and_stops() {
    use crate::plan::modulation::{Am, AmShape};
    let (scene, mut b, h, clock) = open_default();
    let am = Am {
        shape: AmShape::Square,
        freq_hz: 100.0,
        depth: 0.5,
    };
    let plan = crate::plan::stimulus::Stimulus {
        am: Some(am),
        ..crate::plan::stimulus::Stimulus::default()
    }
    .plan_for(&crate::plan::target::Target::Autd3, scene.clone())
    .unwrap()
    .plan;
    let up = b.upload(&plan, None).unwrap();
    assert!(
        matches!(
            up.transfer,
            crate::device::backend::Transfer::Autd3 {
                readback_mismatches: Some(0),
                ..
            }
        ),
        "{:?}",
        up.transfer
    );
    b.play(up.slot, true).unwrap();
    let mods = |h: &EmulatorHandle| h.with_cpus(|c| c.iter().map(|c| c.fpga().modulation()).min());
    // Silent until the switch a margin ahead.
    assert_eq!(mods(&h), Some(0));
    clock.advance(Duration::from_micros(
        crate::device::autd3::output::SWITCH_MARGIN_US + 125,
    ));
    // Then 5 ms at 255 and 5 ms at 128, period after period, sampled at
    // the middle of each 250 µs sample over three seconds (six renewals).
    for k in 0..12_000u64 {
        // Ticks 109.25 ms apart: renewals switch mid-period.
        if k % 437 == 0 {
            b.tick().unwrap();
        }
        let want = if k % 40 < 20 { 255 } else { 128 };
        assert_eq!(mods(&h), Some(want), "sample {k}");
        clock.advance(Duration::from_micros(250));
    }
    b.stop().unwrap();
    assert_eq!(mods(&h), Some(0), "a stop mutes at once");
    // Played again and left: silent within the lease, and for good.
    b.play(up.slot, true).unwrap();
    let gone = clock.now_us();
    clock.advance(Duration::from_millis(100));
    assert!(mods(&h).unwrap() > 0);
    std::mem::forget(b);
    clock.set_us(gone + 1_000_000);
    assert_eq!(mods(&h), Some(0), "silent at the lease's end");
    clock.advance(Duration::from_secs(5));
    assert_eq!(mods(&h), Some(0));
}

/// The LM planner refuses an AM its steps cannot carry (200 Hz on 82
/// steps of a 5 Hz cycle) rather than play it at another frequency.
#[test]
fn an_am_the_lm_steps_cannot_carry_is_refused_by_the_lm_planner() {
    let s = crate::plan::stimulus::Stimulus {
        am: Some(crate::plan::modulation::Am {
            shape: crate::plan::modulation::AmShape::Sine,
            freq_hz: 200.0,
            depth: 1.0,
        }),
        ..crate::plan::stimulus::Stimulus::default()
    };
    let e = s
        .plan_for(&crate::plan::target::Target::Lm, Scene::default())
        .unwrap_err();
    assert!(
        e.downcast_ref::<crate::error::InputError>().is_some(),
        "{e}"
    );
    assert!(e.to_string().contains("does not fit"), "{e}");
}
