//! A streaming session's device (`stream`, `track --port`): one rule on
//! every backend. A stimulus named by the plan flags is planned for the
//! device (AUTD3's 25 µs grid included), uploaded into a free slot, read
//! back where the device can be, and played; with no plan flag the LM
//! firmware plays the entry it plays or played last, tracked (its library
//! outlives a presentation, which lasts only while a host holds it), and
//! otherwise, like an AUTD3 (which holds a sequence only while lmhost
//! holds the link), the device plays the default stimulus.

use lmhost::device::backend::Backend;
use lmhost::device::connect::{open, open_with};
use lmhost::device::link::PortSpec;
use lmhost::device::upload::{Play, UploadOutcome, upload};
use lmhost::plan::scene::Scene;
use lmhost::plan::stimulus::Stimulus;
use lmhost::plan::target::Target;

/// Opens the device for a streaming session and, as the module doc says,
/// plans, uploads and plays `stimulus` in `scene` first (`None`: on the LM
/// firmware the entry it plays or played last, else the default; the
/// default on an AUTD3). Prints the one-line upload summary on stderr
/// when it uploads; returns the device and the upload report.
pub fn open_playing(
    port: &PortSpec,
    scene: &Scene,
    stimulus: Option<&Stimulus>,
) -> anyhow::Result<(Box<dyn Backend>, Option<UploadOutcome>)> {
    let target = port.device()?.target();
    let default = Stimulus::default();
    let stimulus = match (stimulus, &target) {
        (Some(s), _) => s,
        (None, Target::Autd3) => &default,
        (None, Target::Lm) => {
            let mut dev = open(port, scene)?;
            // Quietly: nothing is uploaded. What plays (another host's,
            // within its lease) is taken over at its cycle's end, tracked,
            // so this host renews it and leaves it silent at the end.
            if let Some(slot) = dev.status()?.slot {
                dev.play(slot, false)?;
                return Ok((dev, None));
            }
            // Nothing ever played: as on an AUTD3.
            &default
        }
    };
    let planned = stimulus.plan_for(&target, scene.clone())?;
    for w in &planned.warnings {
        lmhost::errln!("warning: {w}");
    }
    let mut dev = open_with(port, &planned.plan.scene, lm_proto::Encoding::Delta, false)?;
    // A read-back that differs fails the upload itself.
    let o = upload(dev.as_mut(), &planned, None, Play::Tracked)?;
    lmhost::errln!("{}", summary(&o, dev.needs_host()));
    Ok((dev, Some(o)))
}

/// The one-line summary of a session's upload, alike on every backend.
pub fn summary(o: &UploadOutcome, needs_host: bool) -> String {
    let t = &o.timing;
    format!(
        "{}: uploaded {} steps, dwell {:.1} µs, {:.3} Hz (asked {} Hz), step {:.4} mm, crc32 {:08x}, read-back {}; \
         {} slot {}, muted until tracked{}",
        o.port,
        t.steps,
        t.dwell_us,
        t.freq_hz,
        t.requested_freq_hz,
        t.step_mm,
        o.crc32,
        o.transfer
            .readback_mismatches()
            .map_or("not available".into(), |n| format!("{n} mismatches")),
        if o.queued { "queued" } else { "playing" },
        o.slot,
        if needs_host {
            "; left silent on exit"
        } else {
            ""
        }
    )
}
