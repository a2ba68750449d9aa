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
//!   flag ([`catch_interrupts`]) so the polling loop returns and `Drop` runs.
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

use std::sync::atomic::{AtomicBool, Ordering};

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

extern "C" fn on_interrupt(_: nix::libc::c_int) {
    // Async-signal-safe: one atomic store.
    INTERRUPTED.store(true, Ordering::SeqCst);
}

/// Turns SIGINT and SIGTERM into a flag ([`interrupted`]) so a loop that
/// holds an AUTD3 link returns an error and the backend's `Drop` silences
/// the array, instead of the process dying with the array playing.
/// Install it only in commands that poll the flag (stream, demo, hold).
pub fn catch_interrupts() -> anyhow::Result<()> {
    use nix::sys::signal::{SaFlags, SigAction, SigHandler, SigSet, Signal, sigaction};
    let action = SigAction::new(
        SigHandler::Handler(on_interrupt),
        SaFlags::SA_RESTART,
        SigSet::empty(),
    );
    for sig in [Signal::SIGINT, Signal::SIGTERM] {
        // SAFETY: the handler only stores to an atomic.
        unsafe { sigaction(sig, &action) }?;
    }
    Ok(())
}

/// Whether SIGINT or SIGTERM arrived since [`catch_interrupts`].
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// Errors once interrupted, for `?` in a streaming loop.
pub fn check_interrupted() -> anyhow::Result<()> {
    if interrupted() {
        anyhow::bail!("interrupted; the array was left silent");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigterm_sets_the_flag_instead_of_killing() {
        catch_interrupts().unwrap();
        assert!(check_interrupted().is_ok());
        nix::sys::signal::raise(nix::sys::signal::Signal::SIGTERM).unwrap();
        assert!(interrupted());
        assert!(check_interrupted().is_err());
        INTERRUPTED.store(false, Ordering::SeqCst);
    }
}
