//! The timeline's phases as a run plays them (`--time-scale` applied),
//! checked against every stimulus the protocol presents before the device
//! opens and before any file changes.
//!
//! The session refuses a presentation whose on-phase rounds to no step of
//! its stimulus, or whose phase is longer than it plays: checked only as
//! each trial presented, a protocol (or a `--time-scale`) that one of its
//! stimuli cannot play ran the trials before it and then ended the run
//! naming `on_s`, which the protocol gave within its range, with the
//! participant's folder half written; a resume failed the same way.

use std::collections::BTreeSet;

use super::protocol::Protocol;
use crate::InputError;
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
/// its timeline, scaled, is longer than a presentation plays or when its
/// on-phase would play no step of a stimulus it presents (`plans`: the
/// library's entries planned for the device, in library order).
pub fn check(p: &Protocol, plans: &[TargetPlan], scale: f64) -> Result<(), InputError> {
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
    // 0 for none): checked here, not as the first trial presents.
    let off = tl.off_s * scale;
    if off > 0.0 && std::time::Duration::try_from_secs_f64(off).is_ok_and(|d| d.is_zero()) {
        return Err(InputError::new(format!(
            "study protocol {origin}: {} rounds to no time (a duration holds whole nanoseconds): give an off_s of 0 or at least {} s",
            as_played("off_s", tl.off_s),
            show(1e-9 / scale)
        )));
    }
    let Some(on) = tl.on_s else {
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
/// library cannot be planned for is left to `run`, which refuses it by
/// that planning.
pub fn check_targets(
    p: &Protocol,
    scene: &Scene,
    scale: f64,
    targets: &[Target],
) -> anyhow::Result<()> {
    for &target in targets {
        let Ok(plans) = p.library.plan_for(&target, scene) else {
            continue;
        };
        check(p, &plans, scale).map_err(|e| {
            let device = match target {
                Target::Lm => "the LM firmware",
                Target::Autd3 => "an AUTD3 rig",
            };
            InputError::new(format!("{e} (as `study run` plans it for {device})"))
        })?;
    }
    Ok(())
}
