//! Safety equal to the LM firmware's, enforced by the host.
//!
//! - **Gate**: the firmware's own [`lm_fw_core::gate::Gate`] on a µs clock:
//!   muted until a finger is tracked (unless play is untracked), muted on
//!   `present = false` and after [`STALE_US`] without an update. AUTD3
//!   firmware has no such rule, so the host evaluates the gate on every
//!   centroid and every [`Backend::tick`](crate::backend::Backend::tick).
//! - **Mute** is the modulation: `Static(0)` silences every transducer
//!   (through the silencer's intensity ramp) without touching the STM
//!   segments, `Static(255)` restores full intensity.
//! - **Silencer**: autd3's default, kept on purpose: fixed completion steps,
//!   intensity 10 × 25 µs = 250 µs, phase 40 × 25 µs = 1 ms, strict mode.
//!   It limits how fast drive phase and amplitude may change, which keeps
//!   the T4010A1s within their rated drive and audible noise low; strict
//!   mode makes the firmware refuse any STM sampled faster than the phase
//!   completion time, hence AUTD3's 1 ms minimum dwell (1 kHz update limit).
//! - **Silent on exit**: stop (and `Drop`, which runs on error and on panic
//!   unwinding) mutes, then writes a `Null` gain into the playing segment;
//!   autd3's own close then clears the devices. Ctrl-C / SIGTERM become a
//!   flag ([`crate::stop`]) so the polling loop returns and `Drop` runs.
//!   AUTD3 firmware has no host watchdog here: output lasts only while
//!   lmhost holds the link, and a killed (SIGKILL) host leaves it playing.

use lm_fw_core::gate::Gate;

/// Mute after this long without a centroid update (µs), as the firmware.
pub const STALE_US: u64 = 100_000;
/// Modulation intensity that silences the array.
pub const MUTED: u8 = 0;
/// Modulation intensity for full output.
pub const FULL: u8 = 0xFF;

/// A new gate: tracking required unless `untracked`.
pub fn gate(untracked: bool) -> Gate {
    Gate::new(STALE_US, !untracked)
}
