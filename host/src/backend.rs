//! One device interface for every kind of rig.
//!
//! [`Backend`] is what the subcommands need from a device: `info`,
//! `status`, `upload`, `play`, `stop` and centroid streaming. Backends:
//! - [`crate::autd3::Autd3Backend`]: AUTD3 arrays through the autd3 crates
//!   (`--port autd3:...`), its own firmware emulator included;
//! - the LM firmware over serial / pty / TCP ([`crate::link::Client`]).
//!
//! Positions and centroids are in drive coordinates (the mirrored frame
//! when the scene has a reflector), as on the wire.

use serde::Serialize;

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
}

/// A device's playing state.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BackendStatus {
    /// Slot playing, if any.
    pub playing: Option<u8>,
    /// Steps held per slot (`None`: empty).
    pub slots: Vec<Option<usize>>,
    /// Output is muted (not tracked, stale, stopped).
    pub muted: bool,
    /// Play was started without requiring tracking.
    pub untracked: bool,
    /// Centroid updates applied since the device was opened.
    pub centroids: u64,
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
    /// Link frames the upload took.
    pub frames: u64,
    /// Phases read back from the device that differ from the plan
    /// (`None` when the device cannot be read back).
    pub readback_mismatches: Option<u64>,
}

/// One centroid update.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct CentroidUpdate {
    /// Sequence number (wrapping; older ones are refused).
    pub seq: u32,
    /// Whether a finger is tracked.
    pub present: bool,
    /// Centroid in drive coordinates (µm).
    pub pos_um: [i32; 3],
}

/// A device lmhost can drive.
pub trait Backend {
    /// Identity and capabilities.
    fn info(&mut self) -> anyhow::Result<BackendInfo>;
    /// Playing state.
    fn status(&mut self) -> anyhow::Result<BackendStatus>;
    /// Uploads `plan` into `slot` (`None`: the idle slot) without touching
    /// the playing one; a failed upload leaves the playing slot playing.
    fn upload(&mut self, plan: &Plan, slot: Option<u8>) -> anyhow::Result<UploadReport>;
    /// Plays `slot`, switching at the end of the playing loop; muted until
    /// tracked unless `untracked`.
    fn play(&mut self, slot: u8, untracked: bool) -> anyhow::Result<()>;
    /// Silences the array.
    fn stop(&mut self) -> anyhow::Result<()>;
    /// Applies a centroid update (correction and safety gate).
    fn centroid(&mut self, c: &CentroidUpdate) -> anyhow::Result<()>;
    /// Housekeeping the host must run between updates (≥ every 10 ms
    /// while playing): staleness muting where the device cannot time it.
    fn tick(&mut self) -> anyhow::Result<()> {
        Ok(())
    }
}
