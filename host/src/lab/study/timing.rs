//! The timeline's phases as a run plays them (`--time-scale` applied),
//! checked against every stimulus the protocol presents before the device
//! opens and before any file changes.
//!
//! The session refuses a presentation whose on-phase rounds to no step of
//! its stimulus, or whose phase is longer than it plays: checked only as
//! each trial presented, a protocol (or a `--time-scale`) that one of its
//! stimuli cannot play ran the trials before it and then ended the run
//! naming `on_s`, which the protocol gave within its range, with the
//! participant's folder half written; a resume failed the same way. So
//! did an Experiment 3 on-phase too short for one force reading at the
//! gauge's highest rate (1000 Hz: under 1 ms), at its first push.

use std::collections::BTreeSet;

use super::protocol::Protocol;
use crate::InputError;
use crate::device::instruments::gauge::{MAX_RATE_HZ, holds_a_reading};
use crate::lab::session::{MAX_PHASE_S, plays_a_step};
use crate::limits::show;
use crate::plan::scene::Scene;
use crate::plan::stimulus::TargetPlan;
use crate::plan::target::Target;

/// The library entries protocol `p` may present: each condition's, and
/// each grid level's of a staircase or QUEST+.
fn presented(p: &Protocol) -> BTreeSet<&str> {
    let grids = [
        p.staircase.as_ref().map(|s| &s.grid),
        p.quest.as_ref().map(|q| &q.grid),
    ];
    let levels = grids.into_iter().flatten().flat_map(|g| g.entries.iter());
    p.conditions
        .iter()
        .map(|c| c.stimulus.as_str())
        .chain(levels.flatten().map(String::as_str))
        .collect()
}

/// Refuses a run of protocol `p` at time scale `scale` when a phase of
/// its timeline, scaled, is longer than a presentation plays, when its
/// on-phase is shorter than one step at the device's update limit
/// (`scene`'s `min_dwell_ms`, 1 ms by default) or than one force reading
/// (Experiment 3), or when it would play no step of a stimulus it
/// presents (`plans`: the library's entries planned for the device, in
/// library order; `None` when they could not be planned, which the run
/// refuses by that planning).
pub fn check(
    p: &Protocol,
    scene: &Scene,
    plans: Option<&[TargetPlan]>,
    scale: f64,
) -> Result<(), InputError> {
    let tl = &p.timeline;
    let origin = p.path.display();
    // `on_s 0.5 s` or `on_s 0.5 s × --time-scale 0.003 = 0.0015 s`.
    let as_played = |what: &str, s: f64| match scale {
        1.0 => format!("the timeline's {what} {} s", show(s)),
        _ => format!(
            "the timeline's {what} {} s × --time-scale {} = {} s",
            show(s),
            show(scale),
            show(s * scale)
        ),
    };
    for (what, s) in [("on_s", tl.on_s), ("off_s", Some(tl.off_s))] {
        if let Some(s) = s.filter(|s| s * scale > MAX_PHASE_S) {
            return Err(InputError::new(format!(
                "study protocol {origin}: {} is longer than a presentation plays (at most {} s){}",
                as_played(what, s),
                show(MAX_PHASE_S),
                if scale > 1.0 {
                    format!(": give a --time-scale of at most {}", show(MAX_PHASE_S / s))
                } else {
                    String::new()
                }
            )));
        }
    }
    // A pause that rounds to no time the session refuses (`off_s` is
    // 0 for none), by the session's rule: checked here, not as the first
    // trial presents.
    if let Some(m) =
        crate::limits::rounds_to_no_time(&as_played("off_s", tl.off_s), tl.off_s * scale)
    {
        return Err(InputError::new(format!(
            "study protocol {origin}: {m}: give an off_s of 0 or at least {} s",
            show(1e-9 / scale)
        )));
    }
    let Some(on) = tl.on_s else {
        return Ok(());
    };
    // No stimulus steps faster than the device updates (the planner
    // refuses a dwell under `min_dwell_s`): an on-phase shorter than one
    // such step presents nothing whatever the library holds.
    let floor = scene.min_dwell_s;
    if on * scale < floor * (1.0 - 1e-12) {
        return Err(InputError::new(format!(
            "study protocol {origin}: {} is shorter than one step at the device's update limit (the scene's min_dwell_ms, {} ms): the device cannot present it; {}",
            as_played("on_s", on),
            show(floor * 1e3),
            match scale {
                1.0 => format!("give an on_s of at least {} s", show(floor)),
                _ => format!("give a --time-scale of at least {}", show(floor / on)),
            }
        )));
    }
    // Experiment 3 records the gauge over each on-phase: one too short
    // for a reading at the gauge's highest rate would fail the first push
    // mid-run, its trials before it written.
    if p.adjustment.is_some() && !holds_a_reading(on * scale, MAX_RATE_HZ) {
        let least = 1.0 / MAX_RATE_HZ;
        return Err(InputError::new(format!(
            "study protocol {origin}: {} is shorter than one force reading at the gauge's highest rate ({} Hz, one per {} s): the method of adjustment ([adjustment]) records the gauge over each on-phase; {}",
            as_played("on_s", on),
            show(MAX_RATE_HZ),
            show(least),
            match scale {
                1.0 => format!("give an on_s of at least {} s", show(least)),
                _ => format!("give a --time-scale of at least {}", show(least / on)),
            }
        )));
    }
    let Some(plans) = plans else {
        return Ok(());
    };
    for id in presented(p) {
        let Some(i) = p.library.entries.iter().position(|e| e.id == id) else {
            continue;
        };
        let dwell_us = plans[i].plan.sequence.dwell_us();
        if !plays_a_step(on * scale, dwell_us) {
            let least = dwell_us / 2e6;
            return Err(InputError::new(format!(
                "study protocol {origin}: {} is shorter than half a step of `{}` ({} µs): the device plays whole steps; {}",
                as_played("on_s", on),
                id.escape_debug(),
                show(dwell_us),
                match scale {
                    1.0 => format!("give an on_s of at least {} s", show(least)),
                    _ => format!("give a --time-scale of at least {}", show(least / on)),
                }
            )));
        }
    }
    Ok(())
}

/// [`check`] as `study run` applies it on `targets` (the LM firmware, an
/// AUTD3 rig: their timing differs): the library planned for each in
/// `scene`; the first refusal names the device it is for. A target the
/// library cannot be planned for has its timeline checked without the
/// stimuli; when no target of `targets` can be planned for, the first one's
/// planning error is the refusal (`run` would refuse it so), so a protocol
/// called valid plays on at least one of them.
pub fn check_targets(
    p: &Protocol,
    scene: &Scene,
    scale: f64,
    targets: &[Target],
) -> anyhow::Result<()> {
    let mut unplanned = None;
    let mut planned = false;
    for &target in targets {
        let device = match target {
            Target::Lm => "the LM firmware",
            Target::Autd3 => "an AUTD3 rig",
        };
        let plans = match p.library.plan_for(&target, scene) {
            Ok(plans) => {
                planned = true;
                Some(plans)
            }
            Err(e) => {
                unplanned.get_or_insert((e, device));
                None
            }
        };
        check(p, scene, plans.as_deref(), scale)
            .map_err(|e| InputError::new(format!("{e} (as `study run` plans it for {device})")))?;
    }
    match unplanned {
        Some((e, device)) if !planned => {
            Err(e.context(format!("the library cannot be planned for {device}")))
        }
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lab::study::test_files::studies;

    fn load(name: &str) -> Protocol {
        Protocol::load(&studies(name)).unwrap()
    }

    #[test]
    fn an_on_phase_under_one_device_step_is_refused_naming_on_s_scaled() {
        let scene = Scene::default();
        // Exp. 3's 2 s and the staircase's 1 s on-phases, scaled to 0.8 ms.
        for (name, scale, least) in [
            ("paper-exp3.toml", 0.0004, "0.0005"),
            ("staircase-detection.toml", 0.0008, "0.001"),
        ] {
            let mut p = load(name);
            let on = p.timeline.on_s.unwrap();
            let e = check(&p, &scene, None, scale).unwrap_err().to_string();
            let said = format!(
                "the timeline's on_s {on} s × --time-scale {scale} = 0.0008 s is shorter than one step at the device's update limit (the scene's min_dwell_ms, 1 ms)"
            );
            assert!(
                e.contains(&said)
                    && e.ends_with(&format!("give a --time-scale of at least {least}")),
                "{name}: {e}"
            );
            // One step exactly is presented.
            check(&p, &scene, None, 0.001 / on).unwrap();
            // Unscaled, the hint is the on_s itself.
            p.timeline.on_s = Some(0.0008);
            let e = check(&p, &scene, None, 1.0).unwrap_err().to_string();
            assert!(
                e.contains("the timeline's on_s 0.0008 s is shorter than one step")
                    && e.ends_with("give an on_s of at least 0.001 s"),
                "{name}: {e}"
            );
        }
    }

    #[test]
    fn an_experiment_3_on_phase_under_one_force_reading_is_refused() {
        // A device that steps at 4 kHz presents 0.8 ms; the gauge, at
        // most 1000 readings a second, records none of it.
        let scene = Scene {
            min_dwell_s: 0.25e-3,
            ..Scene::default()
        };
        let e = check(&load("paper-exp3.toml"), &scene, None, 0.0004)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(
                "on_s 2 s × --time-scale 0.0004 = 0.0008 s is shorter than one force reading at the gauge's highest rate (1000 Hz"
            ) && e.ends_with("give a --time-scale of at least 0.0005"),
            "{e}"
        );
        check(&load("paper-exp3.toml"), &scene, None, 0.0005).unwrap();
        // Without [adjustment] no gauge samples the on-phase.
        check(&load("staircase-detection.toml"), &scene, None, 0.0008).unwrap();
    }

    #[test]
    fn a_scaled_off_s_that_rounds_to_no_time_is_the_sessions_rule() {
        let mut p = load("paper-exp1.toml");
        p.timeline.off_s = 1e-12;
        let e = check(&p, &Scene::default(), None, 0.5)
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with(
                "the timeline's off_s 1e-12 s × --time-scale 0.5 = 5e-13 s rounds to no time (a duration holds whole nanoseconds): give an off_s of 0 or at least 2e-9 s"
            ),
            "{e}"
        );
        // The session's own words for the same value.
        let e = crate::limits::pause_s("off_s", 5e-13, MAX_PHASE_S).unwrap_err();
        assert!(
            e.to_string().starts_with(
                "off_s 5e-13 s rounds to no time (a duration holds whole nanoseconds): give 0"
            ),
            "{e}"
        );
    }
}
