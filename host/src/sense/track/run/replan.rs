//! `--replan`: the uploads of re-planned stimuli to the device.

use std::cell::RefCell;

use anyhow::Context as _;

use crate::device::backend::Backend;
use crate::geom;
use crate::plan::scene::Scene;
use crate::plan::sequence::Plan;
use crate::sense::track::camera::CameraSetup;

/// Uploads re-planned depth profiles to the device (`replan`), planned by
/// the caller ([`Replan`](super::Replan): the session's stimulus on the device's grid).
pub(super) struct DeviceReplan {
    /// Box c (mm) → LM plane c (mm): ±1, the axes being checked parallel.
    pub(super) sign: f64,
    pub(super) uploaded: u64,
    pub(super) skipped: u64,
    pub(super) failed: u64,
    pub(super) last_failure: Option<String>,
    /// The last plan uploaded: steps, foci per step, dwell (µs).
    pub(super) last_plan: Option<(usize, usize, f64)>,
}

impl DeviceReplan {
    /// The surface profile is sampled on the tracking box's a–b circle, so
    /// the box must lie in the LM plane (axes parallel within 1°).
    pub(super) fn new(scene: &Scene, setup: &CameraSetup) -> anyhow::Result<Self> {
        let b = &setup.track_box;
        let pl = &scene.lm_plane;
        let cos1 = 1f64.to_radians().cos();
        let aligned =
            |u: geom::Vec3, v: geom::Vec3| geom::dot(u, v) >= cos1 * geom::norm(u) * geom::norm(v);
        if !(aligned(b.axes[0], pl.a) && aligned(b.axes[1], pl.b)) {
            crate::bad_input!(
                "--replan needs the tracking box's first two axes along the scene's lm_plane a and b (within 1°): the surface profile is sampled in the box and planned in the LM plane"
            );
        }
        Ok(Self {
            sign: geom::dot(b.axes[2], pl.c).signum(),
            uploaded: 0,
            skipped: 0,
            failed: 0,
            last_failure: None,
            last_plan: None,
        })
    }

    /// Upload and queue the pending profile, if any and a slot is free
    /// (else it stays pending for the next sample).
    pub(super) fn maybe_upload(
        &mut self,
        client: &mut dyn Backend,
        pending: &RefCell<Option<Vec<f64>>>,
        plan_with: &mut dyn FnMut(&[f64]) -> anyhow::Result<Plan>,
    ) -> anyhow::Result<()> {
        let Some(profile) = pending.borrow().clone() else {
            return Ok(());
        };
        let info = client.info().context("re-plan: reading the device info")?;
        let st = client
            .status()
            .context("re-plan: reading the device status")?;
        let Some(slot) = crate::device::backend::free_slot(info.slots, &st) else {
            self.skipped += 1;
            return Ok(());
        };
        let z: Vec<f64> = profile.iter().map(|z| z * self.sign).collect();
        // A measured profile the planner refuses (out of range) is a
        // re-plan failure, counted and reported; the session goes on.
        let plan = match plan_with(&z) {
            Ok(plan) => plan,
            Err(e) => {
                *pending.borrow_mut() = None;
                self.failed += 1;
                self.last_failure = Some(e.to_string());
                return Ok(());
            }
        };
        client
            .upload(&plan, Some(slot))
            .with_context(|| format!("re-plan: uploading to slot {slot}"))?;
        client
            .play(slot, false)
            .with_context(|| format!("re-plan: playing slot {slot}"))?;
        *pending.borrow_mut() = None;
        self.uploaded += 1;
        self.last_plan = Some((
            plan.trajectory.steps,
            plan.trajectory.foci,
            plan.sequence.dwell_us(),
        ));
        Ok(())
    }
}
