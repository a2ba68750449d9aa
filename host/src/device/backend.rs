//! One device interface for every kind of rig.
//!
//! [`Backend`] is what the subcommands need from a device: `info`,
//! `status`, `upload`, `play`, `stop` and centroid streaming. It is
//! implemented by [`crate::device::connect::LmBackend`] (the LM firmware over
//! serial / pty / TCP) and [`crate::device::autd3::Autd3Backend`] (AUTD3 arrays
//! through the autd3 crates); [`crate::device::connect::open`] picks one from
//! `--port`. This module holds only the interface and the slot rules both
//! follow, so the backends and the streaming loop depend on it and it on
//! none of them.
//!
//! Status is the firmware's own [`lm_proto::Status`] for both (an AUTD3
//! fills the fields it has, `mute_reason` included, and zeroes the wire
//! counters it has no use for). Positions and centroids are in drive
//! coordinates (the mirrored frame when the scene has a reflector), as on
//! the wire.

use lm_proto::{Centroid, DeviceState, Info, NackCode, PlayAt, SelfTest, Status};
use serde::Serialize;

use crate::InputError;
use crate::device::link::LinkError;
use crate::plan::sequence::Plan;

/// What kind of failure a [`BackendError`] is: what a caller may branch on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ErrorKind {
    /// Bad input: a slot the device lacks, a plan it cannot hold (exit 2).
    Input,
    /// The device refused the request with a named code.
    Refused(NackCode),
    /// The link or the device failed (I/O, timeout, no answer).
    Failed,
}

/// A failed device operation: its [`ErrorKind`] and the whole message
/// chain (whose causes stay reachable through `source`, so an
/// [`InputError`] inside still exits 2).
#[derive(Debug)]
pub struct BackendError {
    kind: ErrorKind,
    error: anyhow::Error,
}

/// The result of a device operation.
pub type Result<T> = std::result::Result<T, BackendError>;

impl BackendError {
    /// An error of `kind` saying `error`.
    pub fn new(kind: ErrorKind, error: impl Into<anyhow::Error>) -> Self {
        Self {
            kind,
            error: error.into(),
        }
    }

    /// A refusal with `code`, saying `msg`.
    pub fn refused(code: NackCode, msg: impl std::fmt::Display) -> Self {
        Self::new(ErrorKind::Refused(code), anyhow::anyhow!("{msg}"))
    }

    /// A failure saying `msg`.
    pub fn failed(msg: impl std::fmt::Display) -> Self {
        Self::new(ErrorKind::Failed, anyhow::anyhow!("{msg}"))
    }

    /// What kind of failure it is.
    pub fn kind(&self) -> ErrorKind {
        self.kind
    }

    /// The device's refusal code, when it refused.
    pub fn refusal(&self) -> Option<NackCode> {
        match self.kind {
            ErrorKind::Refused(code) => Some(code),
            _ => None,
        }
    }

    /// Adds context (one more message in front), keeping the kind.
    pub fn context(self, msg: impl std::fmt::Display + Send + Sync + 'static) -> Self {
        Self {
            kind: self.kind,
            error: self.error.context(msg),
        }
    }
}

/// `error` with the context of what was done on the device at `port`:
/// `plain` when the error names the port already (every link error does),
/// else `naming()`, which names it, so a line never says the port twice.
pub fn port_context(
    error: impl Into<anyhow::Error>,
    port: &str,
    plain: &str,
    naming: impl FnOnce() -> String,
) -> anyhow::Error {
    let error = error.into();
    if format!("{error:#}").contains(port) {
        error.context(plain.to_owned())
    } else {
        error.context(naming())
    }
}

impl std::fmt::Display for BackendError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // The head only: the causes follow through `source`.
        write!(f, "{}", self.error)
    }
}

impl std::error::Error for BackendError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(self.error.as_ref())
    }
}

impl From<anyhow::Error> for BackendError {
    /// Classifies by the chain: an [`InputError`] is input, a device's
    /// `Nack` a refusal, anything else a failure.
    fn from(error: anyhow::Error) -> Self {
        let kind = error
            .chain()
            .find_map(|c| {
                if c.is::<InputError>() {
                    Some(ErrorKind::Input)
                } else if let Some(LinkError::Nack { code, .. }) = c.downcast_ref::<LinkError>() {
                    Some(ErrorKind::Refused(*code))
                } else {
                    c.downcast_ref::<BackendError>().map(BackendError::kind)
                }
            })
            .unwrap_or(ErrorKind::Failed);
        Self { kind, error }
    }
}

impl From<InputError> for BackendError {
    fn from(e: InputError) -> Self {
        Self::new(ErrorKind::Input, e)
    }
}

impl From<LinkError> for BackendError {
    fn from(e: LinkError) -> Self {
        anyhow::Error::from(e).into()
    }
}

/// How long a presentation sounds after the host's last renewal before the
/// device ends it on its own (the host died, hung or was killed): the same
/// default for the LM firmware's lease and an AUTD3's
/// ([`Backend::set_lease`]).
pub const DEFAULT_LEASE: std::time::Duration = std::time::Duration::from_secs(1);

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
    /// What this kind of device has of its own (serialised as its
    /// `dwell_grid_us`, null on the LM firmware).
    #[serde(rename = "dwell_grid_us", serialize_with = "Kind::serialize_grid")]
    pub kind: Kind,
}

/// What differs per kind of device: the one place a caller branches on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    /// The LM firmware, with its own `Info`: plays on its own timer while
    /// its host renews the lease, any dwell on its µs timer.
    LmFirmware(Info),
    /// An AUTD3 rig: dwell on the FPGA's sampling grid; output lasts only
    /// while lmhost holds the link.
    Autd3 {
        /// The sampling grid (µs).
        dwell_grid_us: u32,
    },
}

impl Kind {
    /// The dwell grid (µs), when the device samples on one.
    pub fn dwell_grid_us(&self) -> Option<u32> {
        match self {
            Self::LmFirmware(_) => None,
            Self::Autd3 { dwell_grid_us } => Some(*dwell_grid_us),
        }
    }

    fn serialize_grid<S: serde::Serializer>(
        k: &Kind,
        s: S,
    ) -> std::result::Result<S::Ok, S::Error> {
        k.dwell_grid_us().serialize(s)
    }
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
    /// How it got there (serialised as `frames` and `readback_mismatches`).
    #[serde(flatten)]
    pub transfer: Transfer,
}

/// How an upload reached the device, per kind of device.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Transfer {
    /// Over the LM firmware's framed link: its transfer report.
    Wire(crate::device::link::UploadReport),
    /// Through the autd3 crates.
    Autd3 {
        /// Link frames the upload took (counted on the emulator, else 0).
        frames: u64,
        /// Phases read back that differ from the plan (`None` on a real
        /// link, which cannot be read back).
        readback_mismatches: Option<u64>,
    },
}

impl UploadReport {
    /// Phases read back from the device that differ from the plan (`None`
    /// when the device cannot be read back).
    pub fn readback_mismatches(&self) -> Option<u64> {
        self.transfer.readback_mismatches()
    }

    /// Link frames the upload took, where counted.
    pub fn frames(&self) -> Option<u64> {
        self.transfer.frames()
    }

    /// The framed link's transfer report (the LM firmware).
    pub fn wire(&self) -> Option<&crate::device::link::UploadReport> {
        self.transfer.wire()
    }
}

impl Transfer {
    /// Phases read back from the device that differ from the plan (`None`
    /// when the device cannot be read back).
    pub fn readback_mismatches(&self) -> Option<u64> {
        match *self {
            Self::Wire(_) => None,
            Self::Autd3 {
                readback_mismatches,
                ..
            } => readback_mismatches,
        }
    }

    /// Link frames the upload took, where counted.
    pub fn frames(&self) -> Option<u64> {
        match *self {
            Self::Autd3 { frames, .. } if frames > 0 => Some(frames),
            _ => None,
        }
    }

    /// The framed link's transfer report (the LM firmware).
    pub fn wire(&self) -> Option<&crate::device::link::UploadReport> {
        match self {
            Self::Wire(w) => Some(w),
            Self::Autd3 { .. } => None,
        }
    }
}

impl Serialize for Transfer {
    /// As the fields it always had: `frames` (0 where not counted) and
    /// `readback_mismatches` (null where not read back).
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct as _;
        let (frames, readback) = match *self {
            Self::Wire(_) => (0, None),
            Self::Autd3 {
                frames,
                readback_mismatches,
            } => (frames, readback_mismatches),
        };
        let mut st = s.serialize_struct("Transfer", 2)?;
        st.serialize_field("frames", &frames)?;
        st.serialize_field("readback_mismatches", &readback)?;
        st.end()
    }
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
    fn info(&mut self) -> Result<BackendInfo>;
    /// Playing state, in the firmware's terms.
    fn status(&mut self) -> Result<Status>;
    /// Uploads `plan` into `slot` (`None`: a slot neither playing nor
    /// queued) without touching the playing one; a failed upload leaves
    /// the playing slot playing.
    fn upload(&mut self, plan: &Plan, slot: Option<u8>) -> Result<UploadReport>;
    /// Plays `slot` at `at`; muted until tracked unless `untracked`.
    /// `NextCycle` returns at once and the device switches at the end of
    /// the playing cycle (`Status::queued_slot` until then).
    fn play_at(&mut self, slot: u8, at: PlayAt, untracked: bool) -> Result<()>;
    /// Plays `slot`, switching at the end of the playing cycle.
    fn play(&mut self, slot: u8, untracked: bool) -> Result<()> {
        self.play_at(slot, PlayAt::NextCycle, untracked)
    }
    /// Plays `slot` for `steps` steps, then stops as [`stop`](Self::stop)
    /// does (`Status` then shows `Stopped` with `cycles × N + step ==
    /// steps`); 0 = until `stop`, as [`play`](Self::play). Starts at once
    /// from silence, or, while another slot plays, queued at the end of its
    /// cycle, where the count begins.
    ///
    /// Who times it: the LM firmware counts the steps on its own timer and
    /// stops itself at the boundary (`Play.steps`), whatever the link's
    /// latency. An AUTD3 cannot stop itself: the same player
    /// (`lm_fw_core::player`) runs in the host on its clock, and the host
    /// stops the array in [`tick`](Self::tick), [`status`](Self::status)
    /// or [`centroid`](Self::centroid) once the player says `steps` have
    /// played, so it sounds late by as much as those calls are (keep
    /// ticking ≤ every dwell); its `Status` counts as the firmware's
    /// (`cycles × N + step == steps`) and `missed_deadlines` counts the
    /// steps that sounded past the limit.
    fn play_for(&mut self, slot: u8, untracked: bool, steps: u32) -> Result<()>;
    /// Silences the array.
    fn stop(&mut self) -> Result<()>;
    /// Applies a centroid update (correction and safety gate). A centroid
    /// that is not newer than the last is refused with `OutOfOrder`.
    fn centroid(&mut self, c: &Centroid) -> Result<CentroidOutcome>;
    /// Housekeeping the host must run between updates (≥ every 10 ms
    /// while playing): staleness muting, stops, switches and lease renewals
    /// where the device cannot time them (AUTD3), renewing the host lease
    /// when due (the LM firmware).
    fn tick(&mut self) -> Result<()> {
        Ok(())
    }
    /// Sets how long a presentation sounds without the host renewing it
    /// ([`DEFAULT_LEASE`] until set; renewed by [`tick`](Self::tick), so
    /// tick at least every half lease). Out of the device's range is bad
    /// input. A device whose lease is set elsewhere (the LM firmware: the
    /// port's `lease_ms`, sent with every play) keeps this default, which
    /// does nothing.
    fn set_lease(&mut self, lease: std::time::Duration) -> Result<()> {
        let _ = lease;
        Ok(())
    }
    /// Whether output lasts only while lmhost holds the link (and keeps
    /// [`tick`](Self::tick)ing): an AUTD3 always, the LM firmware while
    /// something this host played plays (its host lease ends it otherwise).
    fn needs_host(&self) -> bool {
        false
    }
    /// Runs the device's output self-test (the LM boards' SPI loopback);
    /// `Unsupported` where the device has none.
    fn self_test(&mut self) -> Result<SelfTest> {
        Ok(SelfTest::Unsupported)
    }
    /// Whether a [`play`](Self::play) or [`play_for`](Self::play_for)
    /// while a slot is queued replaces the queued one at once, as the LM
    /// firmware's queue does (the slot it replaced is free again). The
    /// rig session relies on it to replace a presentation waiting for its
    /// switch, or to take the switch back when its client goes away;
    /// where it is false (the default), a session refuses the one and
    /// stops for the other.
    fn replaces_queued(&self) -> bool {
        false
    }
    /// Where [`Status`]'s `step` and `cycles` come from: `"device"` (the
    /// LM firmware counts them on its timer) or `"host clock"` (AUTD3:
    /// autd3 reads back no STM index, so the firmware's player counts the
    /// steps played on the host's clock; the FPGA's index steps with it,
    /// from another point of the cycle, see the tests).
    fn counters_source(&self) -> &'static str {
        "device"
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

/// The one check every backend's `upload` makes of what a plan carries
/// before it sends a byte (SPEC section 3, Lists, at the plan's level): at
/// least one step of at least one transducer, exactly steps × transducers
/// phases, and an intensity table, when there is one, of exactly one level
/// per step. A plan that carries nothing (no steps, an empty table) is bad
/// input (exit 2), refused before anything is sent, so the slot's old
/// entry and what plays stay as they were.
pub fn check_shape(plan: &Plan) -> std::result::Result<(), InputError> {
    let s = &plan.sequence;
    let (steps, t) = (
        usize::from(s.header.steps),
        usize::from(s.header.transducers),
    );
    if steps == 0 || t == 0 {
        return Err(InputError::new(format!(
            "the plan carries no phases ({steps} steps of {t} transducers):              nothing to upload"
        )));
    }
    if s.phases.len() != steps * t {
        return Err(InputError::new(format!(
            "the plan holds {} phases, not its {steps} steps × {t} transducers",
            s.phases.len()
        )));
    }
    match s.intensity_table.as_ref().map(Vec::len) {
        Some(n) if n != steps => Err(InputError::new(format!(
            "the plan's intensity table holds {n} levels, not one for each of its {steps} steps"
        ))),
        _ => Ok(()),
    }
}

/// Checks `slot` exists on the device (bad input otherwise, exit 2).
pub fn check_slot(slot: u8, info: &Info) -> std::result::Result<(), InputError> {
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

    use crate::device::link::client::tests::info;

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

    #[test]
    fn the_port_is_named_once_in_an_error_line() {
        let port = "tcp:127.0.0.1:9";
        for (cause, want) in [
            // The cause names the port: the context does not again.
            (
                format!("no response from {port} to info"),
                "starting the session: no response from tcp:127.0.0.1:9 to info",
            ),
            (
                "the emulator failed".to_owned(),
                "starting the session on tcp:127.0.0.1:9: the emulator failed",
            ),
        ] {
            let e = port_context(anyhow::anyhow!(cause), port, "starting the session", || {
                format!("starting the session on {port}")
            });
            assert_eq!(format!("{e:#}"), want);
        }
    }
}
