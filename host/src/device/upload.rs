//! Upload a planned stimulus and play it: one sequence of steps and one
//! report ([`UploadOutcome`]) on every backend, so `lmhost upload`, the
//! streaming session and the bindings print the same schema.

use lm_proto::{DeviceState, MuteReason, Status};
use serde::Serialize;

use crate::device::backend::{Backend, Transfer};
use crate::plan::stimulus::{TargetPlan, Timing};

/// How to play what was uploaded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Play {
    /// Upload and commit only.
    No,
    /// Play, muted until a finger is tracked.
    Tracked,
    /// Play without tracking (no gating, no correction).
    Untracked,
}

/// The serial link's transfer figures (LM firmware), the JSON's `wire`.
#[derive(Serialize)]
struct WireFigures {
    /// The link's report.
    #[serde(flatten)]
    report: crate::device::link::UploadReport,
    /// Payload bytes over all wire bytes.
    wire_efficiency: f64,
}

/// `UploadOutcome::transfer` as the keys it always had: `wire_bytes_sent`,
/// `frames`, `readback_mismatches` and `wire`, each `null` where the link
/// has no such figure.
fn outcome_keys<S: serde::Serializer>(t: &Transfer, s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeStruct as _;
    let wire = t.wire();
    let mut st = s.serialize_struct("Transfer", 4)?;
    st.serialize_field("wire_bytes_sent", &wire.map(|w| w.wire_bytes_sent))?;
    st.serialize_field("frames", &t.frames())?;
    st.serialize_field("readback_mismatches", &t.readback_mismatches())?;
    st.serialize_field(
        "wire",
        &wire.map(|&report| WireFigures {
            report,
            wire_efficiency: report.wire_efficiency(),
        }),
    )?;
    st.end()
}

/// What an upload and the play after it did: the same keys on every
/// backend (a figure a backend cannot know is `null`, never missing).
#[derive(Debug, Clone, Serialize)]
pub struct UploadOutcome {
    /// The device, as it describes itself.
    pub port: String,
    /// Slot written.
    pub slot: u8,
    /// Transducers per step.
    pub transducers: usize,
    /// Work volume: the device refuses a centroid farther than this from
    /// the planned centre (µm).
    pub max_offset_um: u32,
    /// Steps, dwell, frequency and step width, realised and requested, and
    /// the AUTD3 `divide` (`null` on the LM firmware).
    #[serde(flatten)]
    pub timing: Timing,
    /// CRC-32 of the phases uploaded (the raw sequence, step-major).
    pub crc32: u32,
    /// The output intensity it plays at, the wire level (255 = full).
    pub intensity_level: u8,
    /// Seconds the upload took (wall clock, the call to the backend).
    pub seconds: f64,
    /// Phase bytes sent: the encoded sequence on the LM firmware, the raw
    /// steps × transducers on an AUTD3.
    pub payload_bytes: u64,
    /// How it travelled: the LM serial link's report, or the autd3
    /// crates' frames and read-back, one or the other whole. In the JSON
    /// the keys `wire_bytes_sent` (bytes the link sent, framing included),
    /// `frames` (counted on autd3's emulator), `readback_mismatches`
    /// (phases read back that differ from the plan) and `wire` (the serial
    /// link's full report), each `null` where this link has no such figure.
    #[serde(flatten, serialize_with = "outcome_keys")]
    pub transfer: Transfer,
    /// Whether it was played.
    pub playing: bool,
    /// Whether the play waits for the playing slot's cycle boundary.
    pub queued: bool,
    /// Whether it plays without tracking.
    pub untracked: bool,
    /// The device's state right after the play.
    pub state: Option<DeviceState>,
    /// Why it is muted, right after the play.
    pub mute_reason: Option<MuteReason>,
}

/// Uploads `planned` into `slot` (`None`: one neither playing nor queued)
/// and plays it as `play` says.
pub fn upload(
    dev: &mut dyn Backend,
    planned: &TargetPlan,
    slot: Option<u8>,
    play: Play,
) -> anyhow::Result<UploadOutcome> {
    let plan = &planned.plan;
    let started = std::time::Instant::now();
    let r = dev.upload(plan, slot)?;
    let seconds = started.elapsed().as_secs_f64();
    let status: Option<Status> = match play {
        Play::No => None,
        Play::Tracked | Play::Untracked => {
            dev.play(r.slot, play == Play::Untracked)?;
            Some(
                dev.status()
                    .map_err(|e| e.context("reading the device status"))?,
            )
        }
    };
    Ok(UploadOutcome {
        port: dev.describe(),
        slot: r.slot,
        transducers: r.transducers,
        max_offset_um: plan.sequence.header.max_offset_um,
        timing: planned.timing.clone(),
        crc32: plan.sequence.crc32(),
        intensity_level: plan.sequence.header.intensity,
        seconds,
        payload_bytes: r
            .wire()
            .map_or(plan.sequence.phases.len() as u64, |w| w.sequence_bytes),
        transfer: r.transfer,
        playing: status.is_some(),
        queued: status.is_some_and(|s| s.queued_slot == Some(r.slot)),
        untracked: play == Play::Untracked,
        state: status.map(|s| s.state),
        mute_reason: status.map(|s| s.mute_reason),
    })
}
