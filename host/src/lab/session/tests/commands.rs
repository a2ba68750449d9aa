//! Commands against the session: refusals that change nothing, a
//! present replacing one that waits for its switch, clients going away.

use super::*;

#[test]
fn a_tracked_presentation_without_a_finger_source_is_refused() {
    for (name, mut d, _) in both(no_finger) {
        let r = d
            .session()
            .handle(&Command::Present(present("a", None, None, None, None)), 1);
        assert!(!r.is_ok(), "{name}");
        let msg = r.0["error"].as_str().unwrap();
        assert!(
            msg.contains("no finger source") && msg.contains("untracked"),
            "{msg}"
        );
        // The entry's own gate counts too; untracked ones play.
        assert!(
            d.session()
                .handle(&Command::Present(untracked("a")), 1)
                .is_ok()
        );
        assert!(
            d.session()
                .handle(&Command::Present(present("m", None, None, None, None)), 1)
                .is_ok()
        );
    }
}

#[test]
fn bad_commands_are_refused_and_leave_the_device_as_it_was() {
    for (name, mut d, _) in both(synthetic) {
        d.session().present(&untracked("a")).unwrap();
        d.session().drain_events();
        let long = "q".repeat(4000);
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
            (
                Command::Present(present(&long, None, None, None, None)),
                "(4000 bytes)",
            ),
        ] {
            let r = d.session().handle(&cmd, 1);
            assert!(!r.is_ok(), "{name}: {cmd:?}");
            let msg = r.0["error"].as_str().unwrap().to_owned();
            assert!(msg.contains(needle), "{name}: {msg}");
            assert!(msg.len() < 400, "{name}: the id is not echoed whole");
            assert!(matches!(
                &d.session().drain_events()[..],
                [Event {
                    kind: EventKind::Refused { .. },
                    ..
                }]
            ));
        }
        let st = d.session().status().unwrap();
        assert_eq!(
            (st.stimulus.as_deref(), st.phase),
            (Some("a"), Some("on")),
            "{name}"
        );
        assert_eq!(st.state, "playing", "{name}");
    }
}

#[test]
fn a_third_present_replaces_the_one_waiting_for_its_switch() {
    for (name, mut d, clock) in both(no_finger) {
        a_then_b(&mut d, &clock, Duration::from_millis(45));
        let r = d.session().handle(&Command::Present(untracked("m")), 1);
        if name == "autd3" {
            // An AUTD3 cannot take a queued switch back (yet): refused
            // with the reason, and the switch to `b` goes ahead.
            assert!(!r.is_ok());
            let msg = r.0["error"].as_str().unwrap();
            assert!(msg.contains("cannot replace `b`"), "{msg}");
            let ev = run_until(&mut d, &clock, Duration::from_secs(1), |e| {
                has(e, |k| matches!(k, EventKind::Switch { .. }))
            });
            assert!(has(
                &ev,
                |k| matches!(k, EventKind::Switch { to, .. } if to == "b")
            ));
            continue;
        }
        assert!(r.is_ok(), "{name}: {r:?}");
        let ev = run_until(&mut d, &clock, Duration::from_secs(1), |e| {
            has(e, |k| matches!(k, EventKind::Switch { .. }))
        });
        assert!(
            has(
                &ev,
                |k| matches!(k, EventKind::Cancelled { stimulus } if stimulus == "b")
            ),
            "{name}: {:?}",
            kinds(&ev)
        );
        assert!(
            has(
                &ev,
                |k| matches!(k, EventKind::Switch { from: Some(f), to, .. } if f == "a" && to == "m")
            ),
            "{name}: {:?}",
            kinds(&ev)
        );
        assert!(!has(
            &ev,
            |k| matches!(k, EventKind::Onset { stimulus, .. } if stimulus == "b")
        ));
        let st = d.session().status().unwrap();
        assert_eq!(
            (st.stimulus.as_deref(), st.state.as_str()),
            (Some("m"), "playing")
        );
        // The same again while `a` → `b` waits: `a` plays on through its
        // cycle end.
        a_then_b(&mut d, &clock, Duration::from_millis(10));
        d.session().present(&untracked("m")).unwrap();
        let ev = run_until(&mut d, &clock, Duration::from_secs(1), |e| {
            has(e, |k| matches!(k, EventKind::Onset { .. }))
        });
        assert!(
            has(
                &ev,
                |k| matches!(k, EventKind::Onset { stimulus, .. } if stimulus == "m")
            ),
            "{:?}",
            kinds(&ev)
        );
    }
}

#[test]
fn a_client_going_away_stops_only_what_it_presented() {
    for (name, mut d, clock) in both(no_finger) {
        // Client 1 presents; client 2 goes away: nothing changes.
        d.session().handle(&Command::Present(untracked("a")), 1);
        run_for(&mut d, &clock, Duration::from_millis(20));
        assert!(!d.session().client_gone(2).unwrap(), "{name}");
        assert_eq!(d.session().status().unwrap().state, "playing");
        // Client 2 asks for `b`, then goes away before the switch: its
        // `b` is cancelled; `a` plays on where the device can take the
        // switch back, else everything stops.
        run_for(&mut d, &clock, Duration::from_millis(3));
        d.session().handle(&Command::Present(untracked("b")), 2);
        assert!(d.session().client_gone(2).unwrap(), "{name}");
        let ev = run_for(&mut d, &clock, Duration::from_millis(120));
        assert!(
            !has(
                &ev,
                |k| matches!(k, EventKind::Onset { stimulus, .. } if stimulus == "b")
            ),
            "{name}: {:?}",
            kinds(&ev)
        );
        let st = d.session().status().unwrap();
        if name == "lm" {
            assert_eq!(
                (st.stimulus.as_deref(), st.state.as_str()),
                (Some("a"), "playing"),
                "{name}"
            );
            assert!(
                !has(&ev, |k| matches!(k, EventKind::Offset { .. })),
                "{name}: {:?}",
                kinds(&ev)
            );
        } else {
            assert_ne!(st.state, "playing", "{name}");
            continue;
        }
        // Client 1 goes away: its `a` stops.
        assert!(d.session().client_gone(1).unwrap());
        let ev = d.session().drain_events();
        assert!(has(&ev, |k| matches!(
            k,
            EventKind::Offset {
                reason: OffsetReason::Disconnect,
                ..
            }
        )));
        assert_ne!(d.session().status().unwrap().state, "playing");
    }
}
