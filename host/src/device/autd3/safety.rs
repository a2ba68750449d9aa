//! Safety equal to the LM firmware's, enforced by the host.
//!
//! - **Policy**: the firmware's own [`lm_fw_core::policy::Policy`] (session,
//!   tracking gate, untracked play, work volume) on a µs clock: muted until
//!   a finger is tracked (unless play is untracked), muted on
//!   `present = false`, after [`STALE_US`] without an update and while the
//!   last centroid lies outside the work volume. AUTD3 firmware has no such
//!   rule, so the host evaluates it on every centroid and every
//!   [`Backend::tick`](crate::device::backend::Backend::tick).
//! - **Mute** is the modulation: `Static(0)` silences every transducer
//!   (through the silencer's intensity ramp) without touching the STM
//!   segments; sounding is a leased modulation at the stimulus's intensity
//!   ([`super::output`]).
//! - **Silencer**: autd3's default, kept on purpose: fixed completion steps,
//!   intensity 10 × 25 µs = 250 µs, phase 40 × 25 µs = 1 ms, strict mode.
//!   It limits how fast drive phase and amplitude may change, which keeps
//!   the T4010A1s within their rated drive and audible noise low; strict
//!   mode makes the firmware refuse any STM sampled faster than the phase
//!   completion time, hence AUTD3's 1 ms minimum dwell (1 kHz update limit).
//! - **Stop** mutes (the segments stay, so a later play resumes as on the
//!   firmware). **Silent on exit**: `Drop` (which runs on error and on panic
//!   unwinding) mutes, then writes a `Null` gain into the playing segment;
//!   autd3's own close then clears the devices. Ctrl-C / SIGTERM become a
//!   flag ([`crate::stop`]) so the polling loop returns and `Drop` runs.
//!   AUTD3 firmware has no host watchdog, so the output carries its own:
//!   a killed (SIGKILL) or hung host leaves it sounding at most one lease
//!   ([`super::output`]), then silent.

use lm_fw_core::policy::Policy;

/// Mute after this long without a centroid update (µs), as the firmware.
pub const STALE_US: u64 = lm_fw_core::DEFAULT_CENTROID_TIMEOUT_US as u64;
/// Modulation intensity that silences the array.
pub const MUTED: u8 = 0;
/// Modulation intensity for full output.
pub const FULL: u8 = 0xFF;

/// The policy of an idle rig: tracking required (unless a play is
/// untracked), stale after [`STALE_US`].
pub fn policy() -> Policy {
    Policy::new(STALE_US, true)
}
