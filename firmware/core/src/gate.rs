//! Safety gating: output is allowed only while a hand is tracked.
//!
//! Rules, evaluated at every step boundary (so a change mutes within one
//! step):
//! - the last centroid update said `present = false` → muted;
//! - no centroid update for longer than the timeout (100 ms by default) → muted;
//! - before the first update of a play session: muted if
//!   [`Config::require_tracking`](crate::Config::require_tracking) is on
//!   (the default), playing otherwise;
//! - the next fresh update (higher sequence number, wrapping) with
//!   `present = true` resumes output.
//!
//! Stop mutes at once regardless of tracking (handled by the player).

use lm_proto::MuteReason;

/// Tracking state for the gate.
#[derive(Debug, Clone, Copy)]
pub struct Gate {
    /// Mute after this many counts without an update.
    pub timeout_counts: u64,
    /// Mute until the first update arrives.
    pub require_tracking: bool,
    last: Option<Update>,
    /// Accept the next update whatever its sequence number.
    accept_any: bool,
}

#[derive(Debug, Clone, Copy)]
struct Update {
    seq: u32,
    at: u64,
    present: bool,
}

impl Gate {
    /// A gate with no update yet.
    pub const fn new(timeout_counts: u64, require_tracking: bool) -> Self {
        Self {
            timeout_counts,
            require_tracking,
            last: None,
            accept_any: false,
        }
    }

    /// Forgets past updates (a new play session starts; the host's
    /// sequence numbers may restart).
    pub fn reset(&mut self) {
        self.last = None;
        self.accept_any = false;
    }

    /// Keeps the gate as it is but accepts the next update whatever its
    /// sequence number (a host that restarted mid-play counts from 0 again).
    pub fn restart_sequence(&mut self) {
        self.accept_any = true;
    }

    /// Whether `seq` is newer than the last accepted update. Sequence
    /// number 0 never is: it is the wire's "none" (`Status`'s
    /// `last_centroid_seq`), so a device that took it would report a
    /// centroid it accepted as none (SPEC section 3, `Centroid`).
    pub fn is_fresh(&self, seq: u32) -> bool {
        if seq == 0 {
            return false;
        }
        if self.accept_any {
            return true;
        }
        match self.last {
            None => true,
            Some(u) => (seq.wrapping_sub(u.seq) as i32) > 0,
        }
    }

    /// Records an update received at `now`. Returns false (and changes
    /// nothing) if it is not fresh.
    pub fn update(&mut self, seq: u32, present: bool, now: u64) -> bool {
        if !self.is_fresh(seq) {
            return false;
        }
        self.last = Some(Update {
            seq,
            at: now,
            present,
        });
        self.accept_any = false;
        true
    }

    /// Sequence number of the last accepted update (0 if none: never one's).
    pub fn last_seq(&self) -> u32 {
        self.last.map_or(0, |u| u.seq)
    }

    /// Whether output may sound at `now`.
    pub fn open(&self, now: u64) -> bool {
        self.mute_reason(now) == MuteReason::None
    }

    /// Why the gate is closed at `now` ([`MuteReason::None`] while open).
    pub fn mute_reason(&self, now: u64) -> MuteReason {
        match self.last {
            None if self.require_tracking => MuteReason::WaitingForTracking,
            None => MuteReason::None,
            Some(u) if !u.present => MuteReason::FingerAbsent,
            Some(u) if now.saturating_sub(u.at) > self.timeout_counts => MuteReason::TrackingStale,
            Some(_) => MuteReason::None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn require_tracking_mutes_until_first_update() {
        let mut g = Gate::new(100, true);
        assert!(!g.open(0));
        assert_eq!(g.mute_reason(0), MuteReason::WaitingForTracking);
        assert!(g.update(1, true, 10));
        assert!(g.open(10));
        assert!(g.open(110));
        assert!(!g.open(111));
        assert_eq!(g.mute_reason(111), MuteReason::TrackingStale);
        assert!(g.update(2, true, 200));
        assert!(g.open(200));
    }

    #[test]
    fn presence_false_mutes_and_stale_seq_is_ignored() {
        let mut g = Gate::new(100, false);
        assert!(g.open(0));
        assert!(g.update(5, false, 1));
        assert!(!g.open(2));
        assert_eq!(g.mute_reason(2), MuteReason::FingerAbsent);
        assert!(!g.update(5, true, 3));
        assert!(!g.update(4, true, 3));
        assert!(!g.open(3));
        assert!(g.update(6, true, 4));
        assert!(g.open(4));
        // wrapping sequence numbers
        assert!(!g.update(u32::MAX, true, 5));
        let mut h = Gate::new(100, true);
        assert!(h.update(u32::MAX, true, 0));
        // A host's count wraps past 0, the wire's "none" (as lmhost's
        // centroid numbering does).
        assert!(!h.update(0, true, 1));
        assert_eq!(h.last_seq(), u32::MAX);
        assert!(h.update(1, true, 1));
    }

    /// Sequence number 0 is the wire's "none": never accepted, not as the
    /// first update, not after the last one wrapped, not after a restarted
    /// count; it changes nothing.
    #[test]
    fn sequence_number_zero_is_never_fresh() {
        let mut g = Gate::new(100, true);
        assert!(!g.is_fresh(0));
        assert!(!g.update(0, true, 1));
        assert_eq!(g.mute_reason(1), MuteReason::WaitingForTracking);
        assert!(g.update(7, true, 2));
        g.restart_sequence();
        assert!(!g.update(0, false, 3));
        assert!(g.open(3), "the refused update changed nothing");
        assert!(g.update(1, true, 4), "a restarted count from 1");
    }

    #[test]
    fn restart_sequence_keeps_state_but_accepts_any_seq() {
        let mut g = Gate::new(100, true);
        assert!(g.update(1000, true, 0));
        g.restart_sequence();
        assert!(g.open(50), "no glitch");
        assert!(g.update(1, true, 60));
        assert!(!g.update(1, true, 70), "ordering applies again");
        assert_eq!(g.last_seq(), 1);
    }
}
