//! The time base shared by the emulator link and the safety gate.
//!
//! A real clock for the CLI and the demo; a manual clock for tests, whose
//! `sleep` advances time instead of waiting, so loop-end swaps and the
//! 100 ms staleness rule are tested without wall-clock timing.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// A monotonic clock, cheap to clone (clones share the time).
#[derive(Debug, Clone)]
pub enum Clock {
    /// Wall time since the clock was made.
    Real(Instant),
    /// Nanoseconds set by the test.
    Manual(Arc<AtomicU64>),
}

impl Clock {
    /// Wall time from now on.
    pub fn real() -> Self {
        Self::Real(Instant::now())
    }

    /// A manual clock at `t = 0`.
    pub fn manual() -> Self {
        Self::Manual(Arc::new(AtomicU64::new(0)))
    }

    /// Time since the clock's start.
    pub fn now(&self) -> Duration {
        match self {
            Self::Real(t0) => t0.elapsed(),
            Self::Manual(ns) => Duration::from_nanos(ns.load(Ordering::SeqCst)),
        }
    }

    /// Waits `d` (real) or moves time on by `d` (manual).
    pub fn sleep(&self, d: Duration) {
        match self {
            Self::Real(_) => std::thread::sleep(d),
            Self::Manual(_) => self.advance(d),
        }
    }

    /// Moves a manual clock on by `d`; a real clock ignores it.
    pub fn advance(&self, d: Duration) {
        if let Self::Manual(ns) = self {
            ns.fetch_add(d.as_nanos() as u64, Ordering::SeqCst);
        }
    }
}
