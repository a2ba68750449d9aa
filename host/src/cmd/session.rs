//! A streaming session's device (`stream`, `track`, `demo`): on an AUTD3,
//! which holds a sequence only while lmhost holds the link, plan, upload,
//! read back and play first.

use serde::Serialize;

use crate::cmd::plan::PlanArgs;
use lmhost::backend::{Backend, UploadReport};
use lmhost::connect::{Target, open};
use lmhost::link::PortSpec;
use lmhost::scene::Scene;
use lmhost::stimulus::{Stimulus, TargetPlan, Timing};

/// What [`open_playing`] uploaded before a session (AUTD3 only).
#[derive(Debug, Clone, Serialize)]
pub struct SessionUpload {
    /// The upload.
    pub upload: UploadReport,
    /// Realised timing on the 25 µs grid.
    pub timing: Timing,
}

/// Opens the device for a streaming session (`stream`, `track`, `demo`).
/// The LM firmware already holds its sequence (uploaded and played with
/// `lmhost upload`); an AUTD3 holds one only while lmhost holds the link,
/// so there the plan the flags ask for (or the defaults) is planned on the
/// 25 µs grid, uploaded, read back and played, tracked, first. Returns the
/// device and, on AUTD3, what was uploaded.
pub fn open_playing(
    port: &PortSpec,
    plan: &PlanArgs,
) -> anyhow::Result<(Box<dyn Backend>, Option<SessionUpload>)> {
    open_planned(
        port,
        || Ok(plan.load_scene()?),
        |target| plan.plan_for(target),
    )
}

/// [`open_playing`] with the default stimulus ([`Stimulus::default`], what
/// `lmhost upload --scene FILE` plans with no other flag) in `scene`: the
/// plan `track --port autd3:...` plays.
pub fn open_playing_default(
    port: &PortSpec,
    scene: &Scene,
) -> anyhow::Result<(Box<dyn Backend>, Option<SessionUpload>)> {
    open_planned(
        port,
        || Ok(scene.clone()),
        |target| {
            let planned = Stimulus::default().plan_for(target, scene.clone())?;
            for w in &planned.warnings {
                lmhost::errln!("warning: {w}");
            }
            Ok(planned)
        },
    )
}

/// [`open_playing`] given how to load the scene (the LM firmware) and how
/// to plan the stimulus for a target (an AUTD3).
fn open_planned(
    port: &PortSpec,
    scene: impl FnOnce() -> anyhow::Result<Scene>,
    plan_for: impl FnOnce(&Target) -> anyhow::Result<TargetPlan>,
) -> anyhow::Result<(Box<dyn Backend>, Option<SessionUpload>)> {
    let target = port.target()?;
    let Target::Autd3(_) = &target else {
        return Ok((open(port, &scene()?)?, None));
    };
    let planned = plan_for(&target)?;
    let (plan, timing) = (planned.plan, planned.timing);
    let mut dev = open(port, &plan.scene)?;
    let upload = dev.upload(&plan, None)?;
    let where_ = dev.describe();
    if let Some(n) = upload.readback_mismatches().filter(|&n| n > 0) {
        anyhow::bail!("{where_} holds {n} phases that differ from the plan");
    }
    dev.play(upload.slot, false)?;
    lmhost::errln!(
        "{where_}: uploaded {} steps, dwell {} µs, {:.3} Hz (asked {} Hz), step {:.4} mm, read-back {}; \
         playing slot {}, muted until tracked; left silent on exit",
        upload.steps,
        upload.dwell_us,
        upload.freq_hz,
        timing.requested_freq_hz,
        timing.step_mm,
        upload
            .readback_mismatches()
            .map_or("not available".into(), |n| format!("{n} mismatches")),
        upload.slot
    );
    Ok((dev, Some(SessionUpload { upload, timing })))
}
