//! The session against the simulated LM firmware and the AUTD3 emulator,
//! on the real clock (short stimuli: 25 Hz, a few steps).

use std::time::{Duration, Instant};

use super::*;
use crate::clock::Clock;
use crate::device::autd3::Autd3Backend;
use crate::plan::target::Target;

/// Three short stimuli: 25 Hz LM-S (40 ms cycles) at two radii and an
/// LM-M, plus a 5 Hz one.
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

fn lm_dev() -> Box<dyn Backend> {
    Box::new(crate::device::connect::simulated(Clock::real()).unwrap().0)
}

fn autd3_dev() -> Box<dyn Backend> {
    Box::new(
        Autd3Backend::open_emulator(&Scene::default(), Clock::real(), None)
            .unwrap()
            .0,
    )
}

fn session(target: &Target, dev: Box<dyn Backend>) -> Session {
    let lib = Library::from_toml(LIB, "test").unwrap();
    let plans = lib.plan_for(target, &Scene::default()).unwrap();
    Session::new(dev, &lib, plans, Scene::default()).unwrap()
}

fn both() -> Vec<(&'static str, Session)> {
    vec![
        ("lm", session(&Target::Lm, lm_dev())),
        ("autd3", session(&Target::Autd3, autd3_dev())),
    ]
}

/// Polls until `done` says so (or 5 s), collecting the events.
fn run_until(s: &mut Session, mut done: impl FnMut(&[Event]) -> bool) -> Vec<Event> {
    let mut all = Vec::new();
    let end = Instant::now() + Duration::from_secs(5);
    while Instant::now() < end {
        s.poll().unwrap();
        all.extend(s.drain_events());
        if done(&all) {
            break;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    all
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

fn kinds(events: &[Event]) -> Vec<&EventKind> {
    events.iter().map(|e| &e.kind).collect()
}

#[test]
fn the_whole_library_is_resident_where_the_device_has_the_slots() {
    for (name, mut s) in both() {
        let ev = s.drain_events();
        let pre = ev
            .iter()
            .filter(|e| matches!(e.kind, EventKind::Preloaded { .. }))
            .count();
        let ready = ev.iter().find_map(|e| match &e.kind {
            EventKind::Ready {
                resident, slots, ..
            } => Some((*resident, *slots)),
            _ => None,
        });
        let (resident, slots) = ready.unwrap();
        assert_eq!(resident, pre, "{name}");
        // All three with a slot each, else the first only (the rest on
        // the host, loaded when presented).
        let want = if usize::from(slots) >= 3 { 3 } else { 1 };
        assert_eq!(resident, want, "{name}");
        assert!(s.library().iter().all(|i| i.crc32 != 0), "{name}");
    }
}

#[test]
fn timed_on_phases_last_on_s_by_the_devices_counters_and_repeat() {
    for (name, mut s) in both() {
        s.drain_events();
        s.present(&present(
            "a",
            Some(Gate::Untracked),
            Some(0.3),
            Some(0.1),
            Some(2),
        ))
        .unwrap();
        let ev = run_until(&mut s, |e| {
            e.iter().any(|e| matches!(e.kind, EventKind::Done { .. }))
        });
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
            // The device played on_s: to half a dwell where it times the
            // play itself (the LM firmware), to a dwell plus the host's tick
            // where the host stops it (AUTD3).
            let tol = if name == "lm" {
                dwell_s / 2.0 + 1e-9
            } else {
                dwell_s + 0.01
            };
            assert!(
                (device - 0.3).abs() <= tol,
                "{name}: device {device} s, dwell {dwell_s}"
            );
            assert!((host - 0.3).abs() < 0.05, "{name}: host {host} s");
        }
        let onsets = ev
            .iter()
            .filter(|e| matches!(e.kind, EventKind::Onset { .. }))
            .count();
        assert_eq!(onsets, 2, "{name}");
        assert!(matches!(
            ev.last().unwrap().kind,
            EventKind::Done { reps: 2, .. }
        ));
        assert!(!s.presenting());
        let st = s.status().unwrap();
        assert_ne!(
            st.state, "playing",
            "{name}: silent after the last on-phase"
        );
        assert_eq!(s.figures().timed_on_phases, 2);
    }
}

#[test]
fn a_stimulus_presented_over_another_takes_over_at_the_cycle_end() {
    for (name, mut s) in both() {
        s.present(&present("a", Some(Gate::Untracked), None, None, None))
            .unwrap();
        run_until(&mut s, |_| false).len();
        s.drain_events();
        s.present(&present("b", Some(Gate::Untracked), None, None, None))
            .unwrap();
        let ev = run_until(&mut s, |e| {
            e.iter().any(|e| matches!(e.kind, EventKind::Onset { .. }))
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
                    assert_eq!(from.as_deref(), Some("a"));
                    assert_eq!(to, "b");
                    assert!(latency_ms <= detected_ms, "{latency_ms} > {detected_ms}");
                    Some(*latency_ms)
                }
                _ => None,
            })
            .unwrap_or_else(|| panic!("{name}: no switch in {k:?}"));
        let period_ms = 1e3 / s.loaded()[0].planned.timing.freq_hz;
        assert!(
            latency <= period_ms + 10.0,
            "{name}: {latency} ms > one cycle {period_ms} + 10"
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
        assert_eq!(s.status().unwrap().stimulus.as_deref(), Some("b"));
        s.stop(OffsetReason::Stop).unwrap();
        assert_eq!(s.figures().switches, 1);
    }
}

#[test]
fn a_tracked_presentation_mutes_without_a_finger_and_sounds_with_one() {
    for (name, mut s) in both() {
        s.present(&present("a", None, None, None, None)).unwrap();
        let ev = run_until(&mut s, |e| {
            e.iter().any(|e| matches!(e.kind, EventKind::Mute { .. }))
        });
        assert!(
            ev.iter().any(|e| matches!(&e.kind, EventKind::Mute { reason } if reason == "waiting_for_tracking")),
            "{name}: {:?}",
            kinds(&ev)
        );
        let c = s.scene().center_mm;
        let ev = {
            let mut all = Vec::new();
            let end = Instant::now() + Duration::from_secs(5);
            while Instant::now() < end
                && !all
                    .iter()
                    .any(|e: &Event| matches!(e.kind, EventKind::Unmute))
            {
                s.finger(Some(c)).unwrap();
                s.poll().unwrap();
                all.extend(s.drain_events());
                std::thread::sleep(Duration::from_millis(5));
            }
            all
        };
        assert!(
            ev.iter()
                .any(|e| matches!(e.kind, EventKind::Finger { present: true })),
            "{name}"
        );
        assert!(
            ev.iter().any(|e| matches!(e.kind, EventKind::Unmute)),
            "{name}: {:?}",
            kinds(&ev)
        );
        s.stop(OffsetReason::Stop).unwrap();
        let ev = s.drain_events();
        let frac = ev.iter().find_map(|e| match e.kind {
            EventKind::Offset {
                present_fraction,
                muted_s,
                ..
            } => Some((present_fraction, muted_s)),
            _ => None,
        });
        let (frac, muted) = frac.unwrap();
        assert!(muted > 0.0 && frac < 1.0, "{name}: {frac} {muted}");
    }
}

#[test]
fn bad_commands_are_refused_and_leave_the_device_as_it_was() {
    for (name, mut s) in both() {
        s.present(&present("a", Some(Gate::Untracked), None, None, None))
            .unwrap();
        s.drain_events();
        for (cmd, needle) in [
            (
                Command::Present(present("zz", None, None, None, None)),
                "no stimulus `zz`",
            ),
            (
                Command::Present(present("b", None, None, None, Some(3))),
                "repeat needs on_s",
            ),
            (
                Command::Present(present("b", None, Some(-1.0), None, None)),
                "on_s",
            ),
            (
                Command::Present(present("b", None, Some(1.0), None, Some(0))),
                "repeat 0",
            ),
            (
                Command::Prepare {
                    stimulus: "q".into(),
                },
                "no stimulus `q`",
            ),
        ] {
            let r = s.handle(&cmd);
            assert!(!r.is_ok(), "{name}: {cmd:?}");
            let msg = r.0["error"].as_str().unwrap().to_owned();
            assert!(msg.contains(needle), "{name}: {msg}");
            assert!(matches!(
                &s.drain_events()[..],
                [Event {
                    kind: EventKind::Refused { .. },
                    ..
                }]
            ));
        }
        let st = s.status().unwrap();
        assert_eq!(
            (st.stimulus.as_deref(), st.phase),
            (Some("a"), Some("on")),
            "{name}"
        );
        assert_eq!(st.state, "playing", "{name}");
    }
}

#[test]
fn closing_leaves_the_array_silent_and_says_so() {
    for (name, mut s) in both() {
        s.present(&present("m", None, None, None, None)).unwrap();
        s.poll().unwrap();
        let ev = s.close(OffsetReason::Quit);
        let k = kinds(&ev);
        assert!(
            matches!(
                k.last(),
                Some(EventKind::Closed {
                    reason: OffsetReason::Quit
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
