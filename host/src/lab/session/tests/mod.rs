//! The session against the simulated LM firmware and the AUTD3 emulator,
//! each on a manual clock the session shares: whole presentations run
//! under the [`Driver`] with time moved on by the tests, never slept.

use std::time::Duration;

use super::driver::{Driver, Finger};
use super::*;
use crate::clock::Clock;
use crate::device::autd3::Autd3Backend;
use crate::plan::target::Target;
use crate::sense::stream::filter::Passthrough;

/// Three short stimuli: 25 Hz LM-S (40 ms cycles) at two radii and an
/// LM-M, untracked by default.
const LIB: &str = r#"
[[stimulus]]
id = "a"
radius = 3
freq = 25
step = 1.0

[[stimulus]]
id = "b"
radius = 5
freq = 25
step = 1.0

[[stimulus]]
id = "m"
radius = 4
foci = 2
freq = 25
step = 1.0
untracked = true
"#;

/// A session on `dev` over `lib`, driven with `finger`.
fn driver(
    lib: &str,
    target: &Target,
    dev: Box<dyn Backend>,
    clock: &Clock,
    finger: Finger,
) -> Driver {
    let lib = Library::from_toml(lib, "test").unwrap();
    let plans = lib.plan_for(target, &Scene::default()).unwrap();
    let s = Session::new(dev, &lib, plans, Scene::default(), clock.clone()).unwrap();
    Driver::new(s, finger, Box::new(Passthrough))
}

fn lm(clock: &Clock) -> Box<dyn Backend> {
    Box::new(crate::device::connect::simulated(clock.clone()).unwrap().0)
}

fn autd3(clock: &Clock) -> Box<dyn Backend> {
    Box::new(
        Autd3Backend::open_emulator(&Scene::default(), clock.clone(), None)
            .unwrap()
            .0,
    )
}

/// Both backends on clocks of their own, driven with `finger`.
fn both(finger: fn() -> Finger) -> Vec<(&'static str, Driver, Clock)> {
    let (c1, c2) = (
        Clock::manual_at_us(1_000_000),
        Clock::manual_at_us(1_000_000),
    );
    vec![
        ("lm", driver(LIB, &Target::Lm, lm(&c1), &c1, finger()), c1),
        (
            "autd3",
            driver(LIB, &Target::Autd3, autd3(&c2), &c2, finger()),
            c2,
        ),
    ]
}

fn no_finger() -> Finger {
    Finger::None
}

fn synthetic() -> Finger {
    Finger::Synthetic
}

/// Turns `d` and moves the clock on to its next wake until `done` says
/// so or `limit` of session time passed; the events seen.
fn run_until(
    d: &mut Driver,
    clock: &Clock,
    limit: Duration,
    mut done: impl FnMut(&[Event]) -> bool,
) -> Vec<Event> {
    let end = clock.now_us() + limit.as_micros() as u64;
    let mut all = Vec::new();
    while clock.now_us() < end {
        all.extend(d.turn().unwrap());
        if done(&all) {
            break;
        }
        let w = d
            .wait_time(Duration::from_secs(1))
            .max(Duration::from_micros(50));
        clock.advance(w);
    }
    all
}

fn run_for(d: &mut Driver, clock: &Clock, t: Duration) -> Vec<Event> {
    run_until(d, clock, t, |_| false)
}

/// `a` plays for `t`, then `b` is asked for: a switch that waits for
/// `a`'s cycle end.
fn a_then_b(d: &mut Driver, clock: &Clock, t: Duration) {
    d.session().present(&untracked("a")).unwrap();
    run_for(d, clock, t);
    d.session().present(&untracked("b")).unwrap();
}

fn present(
    id: &str,
    gate: Option<Gate>,
    on_s: Option<f64>,
    off_s: Option<f64>,
    repeat: Option<u32>,
) -> Present {
    Present {
        stimulus: id.into(),
        gate,
        on_s,
        off_s,
        repeat,
    }
}

fn untracked(id: &str) -> Present {
    present(id, Some(Gate::Untracked), None, None, None)
}

fn kinds(events: &[Event]) -> Vec<&EventKind> {
    events.iter().map(|e| &e.kind).collect()
}

fn has(events: &[Event], f: impl Fn(&EventKind) -> bool) -> bool {
    events.iter().any(|e| f(&e.kind))
}

#[test]
fn what_fits_is_preloaded_one_slot_each() {
    for (name, mut d, _) in both(no_finger) {
        let ev = d.session().drain_events();
        let pre = ev
            .iter()
            .filter(|e| matches!(e.kind, EventKind::Preloaded { .. }))
            .count();
        let (resident, slots) = ev
            .iter()
            .find_map(|e| match &e.kind {
                EventKind::Ready {
                    resident, slots, ..
                } => Some((*resident, *slots)),
                _ => None,
            })
            .unwrap();
        assert_eq!(resident, pre, "{name}");
        assert_eq!(resident, usize::from(slots).min(3), "{name}");
        assert!(d.session().library().iter().all(|i| i.crc32 != 0), "{name}");
    }
}

#[test]
fn timed_on_phases_last_on_s_by_the_devices_counters_and_repeat() {
    for (name, mut d, clock) in both(no_finger) {
        d.session().drain_events();
        let t0 = clock.now_us();
        d.session()
            .present(&present(
                "a",
                Some(Gate::Untracked),
                Some(0.3),
                Some(0.1),
                Some(2),
            ))
            .unwrap();
        let ev = run_until(&mut d, &clock, Duration::from_secs(5), |e| {
            has(e, |k| matches!(k, EventKind::Done { .. }))
        });
        let s = d.session();
        let dwell_s = s.loaded()[0].planned.timing.dwell_us / 1e6;
        let offsets: Vec<_> = ev
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::Offset {
                    reason,
                    device_presented_s,
                    presented_s,
                    rep,
                    ..
                } => Some((*reason, *device_presented_s, *presented_s, *rep)),
                _ => None,
            })
            .collect();
        assert_eq!(offsets.len(), 2, "{name}: {:?}", kinds(&ev));
        for (i, (reason, device, host, rep)) in offsets.into_iter().enumerate() {
            assert_eq!(reason, OffsetReason::Timer, "{name}");
            assert_eq!(rep, i as u32 + 1);
            let device = device.unwrap();
            // The LM firmware times the play itself (to the step); the
            // host stops an AUTD3 at its next tick.
            let tol = dwell_s / 2.0 + TICK_EVERY.as_secs_f64() + 1e-9;
            assert!((device - 0.3).abs() <= tol, "{name}: device {device} s");
            // On a manual clock, the host's view is as exact as its polls.
            assert!(
                (host - 0.3).abs() <= tol + STATUS_EVERY.as_secs_f64(),
                "{name}: host {host} s"
            );
        }
        let onsets: Vec<u64> = ev
            .iter()
            .filter(|e| matches!(e.kind, EventKind::Onset { .. }))
            .map(|e| e.t_host_us)
            .collect();
        assert_eq!(onsets.len(), 2, "{name}");
        // The second on-phase begins off_s after the first one's offset.
        let gap = (onsets[1] - onsets[0]) as f64 / 1e6;
        assert!((gap - 0.4).abs() < 0.02, "{name}: {gap} s between onsets");
        assert!(matches!(
            ev.last().unwrap().kind,
            EventKind::Done { reps: 2, .. }
        ));
        assert!(!s.presenting());
        assert_ne!(s.status().unwrap().state, "playing", "{name}: silent after");
        assert_eq!(s.figures().timed_on_phases, 2);
        // Session time, not wall time: well under a second of it passed
        // beyond the presentation.
        assert!(clock.now_us() - t0 < 1_500_000, "{name}");
    }
}

#[test]
fn a_stimulus_presented_over_another_takes_over_at_the_cycle_end() {
    for (name, mut d, clock) in both(no_finger) {
        a_then_b(&mut d, &clock, Duration::from_millis(57));
        let ev = run_until(&mut d, &clock, Duration::from_secs(2), |e| {
            has(e, |k| matches!(k, EventKind::Onset { .. }))
        });
        let k = kinds(&ev);
        let latency = ev
            .iter()
            .find_map(|e| match &e.kind {
                EventKind::Switch {
                    latency_ms,
                    detected_ms,
                    from,
                    to,
                } => {
                    assert_eq!((from.as_deref(), to.as_str()), (Some("a"), "b"));
                    assert!(latency_ms <= detected_ms, "{latency_ms} > {detected_ms}");
                    Some(*latency_ms)
                }
                _ => None,
            })
            .unwrap_or_else(|| panic!("{name}: no switch in {k:?}"));
        let period_ms = 1e3 / d.session().loaded()[0].planned.timing.freq_hz;
        // 57 ms into a 40 ms cycle: the cycle ends 23 ms later.
        assert!(
            latency <= period_ms + 1.0,
            "{name}: {latency} ms > one cycle {period_ms}"
        );
        let off = ev.iter().position(|e| {
            matches!(
                e.kind,
                EventKind::Offset {
                    reason: OffsetReason::Switch,
                    ..
                }
            )
        });
        let on = ev
            .iter()
            .position(|e| matches!(e.kind, EventKind::Onset { .. }));
        assert!(off.unwrap() < on.unwrap(), "{name}: {k:?}");
        assert_eq!(d.session().status().unwrap().stimulus.as_deref(), Some("b"));
        d.session().stop(OffsetReason::Stop).unwrap();
        assert_eq!(d.session().figures().switches, 1);
    }
}

#[test]
fn from_silence_a_resident_stimulus_starts_within_one_dwell() {
    let clock = Clock::manual_at_us(1_000_000);
    let mut d = driver(LIB, &Target::Lm, lm(&clock), &clock, Finger::None);
    for (i, id) in ["a", "b", "m", "b", "a"].into_iter().enumerate() {
        // At varied times, from every slot.
        run_for(
            &mut d,
            &clock,
            Duration::from_micros(7_300 * i as u64 + 1_000),
        );
        d.session().present(&untracked(id)).unwrap();
        run_for(&mut d, &clock, Duration::from_millis(30));
        d.session().stop(OffsetReason::Stop).unwrap();
    }
    let s = d.session();
    let dwell_ms = s
        .loaded()
        .iter()
        .map(|l| l.planned.timing.dwell_us / 1e3)
        .fold(0.0, f64::max);
    let f = s.figures();
    assert_eq!(f.onsets, 5);
    assert!(
        f.onset_ms.unwrap().max <= dwell_ms + 1.0,
        "{f:?}, dwell {dwell_ms} ms"
    );
}

#[test]
fn the_figures_summarise_onsets_and_switches_each_on_their_own() {
    let clock = Clock::manual_at_us(1_000_000);
    let mut d = driver(LIB, &Target::Lm, lm(&clock), &clock, Finger::None);
    let s = d.session();
    let f = s.figures();
    assert_eq!((f.onset_ms, f.switch_ms), (None, None));
    // Onsets of 1..=100 ms in a shuffled order (37 steps round 101), and
    // three switches: known samples on the manual clock's own terms.
    s.onset_us = (1..=100).map(|i| i * 37 % 101 * 1000).collect();
    s.switch_us = vec![4_000, 1_000, 2_500];
    let f = s.figures();
    let spread = |p50, p99, max| Some(Spread { p50, p99, max });
    assert_eq!((f.onsets, f.switches), (100, 3));
    assert_eq!(f.onset_ms, spread(50.5, 99.01, 100.0), "{f:?}");
    assert_eq!(f.switch_ms, spread(2.5, 3.97, 4.0), "{f:?}");
}

#[test]
fn a_tracked_presentation_mutes_without_a_finger_and_sounds_with_one() {
    for (name, mut d, clock) in both(synthetic) {
        d.touch(false).unwrap();
        d.session()
            .present(&present("a", None, None, None, None))
            .unwrap();
        let ev = run_until(&mut d, &clock, Duration::from_secs(1), |e| {
            has(e, |k| matches!(k, EventKind::Mute { .. }))
        });
        assert!(
            has(
                &ev,
                |k| matches!(k, EventKind::Mute { reason } if reason == "waiting_for_tracking" || reason == "finger_absent")
            ),
            "{name}: {:?}",
            kinds(&ev)
        );
        d.touch(true).unwrap();
        let ev = run_until(&mut d, &clock, Duration::from_secs(1), |e| {
            has(e, |k| matches!(k, EventKind::Unmute))
        });
        assert!(
            has(&ev, |k| matches!(k, EventKind::Finger { present: true })),
            "{name}"
        );
        assert!(
            has(&ev, |k| matches!(k, EventKind::Unmute)),
            "{name}: {:?}",
            kinds(&ev)
        );
        // The synthetic finger keeps the gate open on the driver's
        // schedule: no mute over half a second.
        let ev = run_for(&mut d, &clock, Duration::from_millis(500));
        assert!(
            !has(&ev, |k| matches!(k, EventKind::Mute { .. })),
            "{name}: {:?}",
            kinds(&ev)
        );
        d.session().stop(OffsetReason::Stop).unwrap();
        let ev = d.session().drain_events();
        let (frac, muted) = ev
            .iter()
            .find_map(|e| match e.kind {
                EventKind::Offset {
                    present_fraction,
                    muted_s,
                    ..
                } => Some((present_fraction, muted_s)),
                _ => None,
            })
            .unwrap();
        assert!(
            muted > 0.0 && frac < 1.0 && frac > 0.5,
            "{name}: {frac} {muted}"
        );
    }
}

#[test]
fn closing_leaves_the_array_silent_and_says_so() {
    for (name, d, _) in both(no_finger) {
        let mut d = d;
        d.session().present(&untracked("m")).unwrap();
        d.turn().unwrap();
        let ev = d.into_session().close(OffsetReason::Quit);
        let k = kinds(&ev);
        assert!(
            matches!(
                k.last(),
                Some(EventKind::Closed {
                    reason: OffsetReason::Quit,
                    finger: None,
                })
            ),
            "{name}: {k:?}"
        );
        assert!(
            k.iter().any(|e| matches!(
                e,
                EventKind::Offset {
                    reason: OffsetReason::Quit,
                    ..
                }
            )),
            "{name}"
        );
    }
}

#[test]
fn the_driver_ticks_the_device_while_nothing_else_is_due() {
    let clock = Clock::manual_at_us(1_000_000);
    let mut d = driver(LIB, &Target::Lm, lm(&clock), &clock, Finger::None);
    d.session().present(&untracked("a")).unwrap();
    // However long the caller would wait, the next turn is due within a
    // tick and a status read.
    for _ in 0..50 {
        d.turn().unwrap();
        let w = d.wait_time(Duration::from_secs(10));
        assert!(w <= TICK_EVERY && w <= STATUS_EVERY, "{w:?}");
        clock.advance(w.max(Duration::from_micros(1)));
    }
}

mod commands;
mod finger_gate;
mod library;

/// A host too late to renew its lease (a loaded machine, a stalled link):
/// the LM firmware silences itself, and the session says so, timed or not,
/// never as an on-phase that ran out (`timer`) or one still sounding.
#[test]
fn a_lapsed_lease_ends_the_presentation_as_such() {
    for on_s in [None, Some(5.0)] {
        let clock = Clock::manual_at_us(1_000_000);
        let mut d = driver(LIB, &Target::Lm, lm(&clock), &clock, Finger::None);
        d.session().drain_events();
        d.session()
            .present(&present("a", Some(Gate::Untracked), on_s, None, None))
            .unwrap();
        run_for(&mut d, &clock, Duration::from_millis(200));
        // No tick for longer than the lease.
        clock.advance(crate::device::backend::DEFAULT_LEASE * 2);
        let ev = run_until(&mut d, &clock, Duration::from_secs(1), |e| {
            has(e, |k| matches!(k, EventKind::Done { .. }))
        });
        let reason = ev.iter().find_map(|e| match &e.kind {
            EventKind::Offset { reason, .. } => Some(*reason),
            _ => None,
        });
        assert_eq!(
            reason,
            Some(OffsetReason::LeaseExpired),
            "on_s {on_s:?}: {:?}",
            kinds(&ev)
        );
        assert!(has(&ev, |k| matches!(k, EventKind::Done { .. })));
        assert!(!d.session().presenting(), "on_s {on_s:?}");
    }
}
