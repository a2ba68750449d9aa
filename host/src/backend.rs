//! One device interface for every kind of rig.
//!
//! [`Backend`] is what the subcommands need from a device: `info`,
//! `status`, `upload`, `play`, `stop` and centroid streaming. It is
//! implemented by [`crate::connect::LmBackend`] (the LM firmware over
//! serial / pty / TCP) and [`crate::autd3::Autd3Backend`] (AUTD3 arrays
//! through the autd3 crates); [`crate::connect::open`] picks one from
//! `--port`. This module holds only the interface and the slot rules both
//! follow, so the backends and the streaming loop depend on it and it on
//! none of them.
//!
//! Status is the firmware's own [`lm_proto::Status`] for both (an AUTD3
//! fills the fields it has, `mute_reason` included, and zeroes the wire
//! counters it has no use for). Positions and centroids are in drive
//! coordinates (the mirrored frame when the scene has a reflector), as on
//! the wire.

use lm_proto::{Centroid, DeviceState, Info, PlayAt, Status};
use serde::Serialize;

use crate::InputError;
use crate::sequence::Plan;

/// What a device says about itself.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BackendInfo {
    /// Backend kind, e.g. `autd3` or `lm-firmware`.
    pub backend: String,
    /// The port it was opened on.
    pub port: String,
    /// Devices (boards) in the rig.
    pub devices: usize,
    /// Transducers in the rig.
    pub transducers: usize,
    /// Sequence slots (an AUTD3's two STM segments).
    pub slots: u8,
    /// Firmware version per device.
    pub firmware: Vec<String>,
    /// Dwell grid (µs), when the device samples on one.
    pub dwell_grid_us: Option<u32>,
    /// The LM firmware's own `Info` (LM firmware only).
    #[serde(skip)]
    pub lm: Option<Info>,
}

/// The result of an upload.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UploadReport {
    /// Slot written.
    pub slot: u8,
    /// Steps per cycle.
    pub steps: usize,
    /// Transducers per step.
    pub transducers: usize,
    /// Dwell per step (µs).
    pub dwell_us: f64,
    /// LM frequency (Hz).
    pub freq_hz: f64,
    /// Link frames the upload took (AUTD3 emulator; 0 where not counted).
    pub frames: u64,
    /// Phases read back from the device that differ from the plan
    /// (`None` when the device cannot be read back).
    pub readback_mismatches: Option<u64>,
    /// The serial link's transfer report (LM firmware only).
    #[serde(skip)]
    pub wire: Option<crate::link::UploadReport>,
}

/// What a centroid update did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CentroidOutcome {
    /// Accepted: the gate and the correction follow it.
    Applied,
    /// Refused: outside the playing slot's work volume; the output mutes
    /// until a present centroid inside it arrives.
    OutOfRange,
}

/// A device lmhost can drive.
pub trait Backend {
    /// Where the device is, for messages (`/dev/ttyACM0`, `autd3:emulator`).
    fn describe(&self) -> String;
    /// Identity and capabilities.
    fn info(&mut self) -> anyhow::Result<BackendInfo>;
    /// Playing state, in the firmware's terms.
    fn status(&mut self) -> anyhow::Result<Status>;
    /// Uploads `plan` into `slot` (`None`: a slot neither playing nor
    /// queued) without touching the playing one; a failed upload leaves
    /// the playing slot playing.
    fn upload(&mut self, plan: &Plan, slot: Option<u8>) -> anyhow::Result<UploadReport>;
    /// Plays `slot` at `at`; muted until tracked unless `untracked`.
    fn play_at(&mut self, slot: u8, at: PlayAt, untracked: bool) -> anyhow::Result<()>;
    /// Plays `slot`, switching at the end of the playing cycle.
    fn play(&mut self, slot: u8, untracked: bool) -> anyhow::Result<()> {
        self.play_at(slot, PlayAt::NextCycle, untracked)
    }
    /// Silences the array.
    fn stop(&mut self) -> anyhow::Result<()>;
    /// Applies a centroid update (correction and safety gate).
    fn centroid(&mut self, c: &Centroid) -> anyhow::Result<CentroidOutcome>;
    /// Housekeeping the host must run between updates (≥ every 10 ms
    /// while playing): staleness muting where the device cannot time it.
    fn tick(&mut self) -> anyhow::Result<()> {
        Ok(())
    }
    /// Whether output lasts only while lmhost holds the link (AUTD3).
    fn needs_host(&self) -> bool {
        false
    }
}

/// The slot an upload without `--slot` writes: one that neither plays nor
/// is queued, preferring one other than the last played.
pub fn free_slot(slots: u8, status: &Status) -> Option<u8> {
    let playing = match status.state {
        DeviceState::Playing | DeviceState::Muted => status.slot,
        _ => None,
    };
    let busy = |s: u8| playing == Some(s) || status.queued_slot == Some(s);
    let free = || (0..slots).filter(|s| !busy(*s));
    free()
        .find(|s| Some(*s) != status.slot)
        .or_else(|| free().next())
}

/// Checks `slot` exists on the device (bad input otherwise, exit 2).
pub fn check_slot(slot: u8, info: &Info) -> Result<(), InputError> {
    if slot >= info.slots {
        return Err(InputError::new(format!(
            "--slot {slot} does not exist: the device has {} slots (0-{})",
            info.slots,
            info.slots.saturating_sub(1)
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info(slots: u8) -> Info {
        Info {
            proto_version: lm_proto::PROTOCOL_VERSION,
            fw_version: [0, 1, 0],
            max_transducers: 996,
            slot_bytes: 200 * 996,
            slots,
            timer_hz: 1_000_000,
            min_dwell_us: 1000,
            max_chunk: 1024,
        }
    }

    fn status(state: DeviceState, slot: Option<u8>, queued: Option<u8>) -> Status {
        Status {
            state,
            slot,
            queued_slot: queued,
            ..Status::default()
        }
    }

    #[test]
    fn free_slot_is_neither_playing_nor_queued() {
        use DeviceState::*;
        let i = info(2);
        assert_eq!(free_slot(i.slots, &status(Idle, None, None)), Some(0));
        assert_eq!(free_slot(i.slots, &status(Playing, Some(0), None)), Some(1));
        assert_eq!(free_slot(i.slots, &status(Muted, Some(1), None)), Some(0));
        assert_eq!(free_slot(i.slots, &status(Playing, Some(0), Some(1))), None);
        // Stopped: every slot is free; prefer the one not played last.
        assert_eq!(free_slot(i.slots, &status(Stopped, Some(0), None)), Some(1));
        assert_eq!(
            free_slot(info(1).slots, &status(Stopped, Some(0), None)),
            Some(0)
        );
        assert_eq!(
            free_slot(info(1).slots, &status(Playing, Some(0), None)),
            None
        );
        assert_eq!(
            free_slot(info(3).slots, &status(Playing, Some(0), Some(1))),
            Some(2)
        );
    }

    #[test]
    fn slots_are_checked_against_the_device() {
        assert!(check_slot(1, &info(2)).is_ok());
        let e = check_slot(7, &info(2)).unwrap_err();
        assert!(e.to_string().contains("2 slots (0-1)"), "{e}");
    }
}
