//! The device's safety policy: when a playing array may sound and where it
//! may steer. The one home of these rules: the firmware's handler
//! ([`Device`](crate::Device)) and the host's AUTD3 backend both hold a
//! [`Policy`] and ask it, so the two cannot disagree; each keeps only its
//! own mechanics (the firmware its player and offset tables, the AUTD3
//! backend its STM segments, modulation and `PhaseCorrection`).
//!
//! Rules:
//! - **Session**: `Idle` until the first `Play`; `Stop` ends a playing
//!   session (`Stopped`, muted, reason `Stopped`); `Stop` while idle stays
//!   idle. A `Play` while not playing starts a new session: old centroids
//!   are forgotten and tracking starts afresh. A `Play` while playing (a
//!   re-planned or next stimulus) keeps the session: the gate stays as it
//!   is, but the next centroid is accepted whatever its sequence number (a
//!   restarted host counts from 0 again).
//! - **Untracked** play (the `Play` flag) is neither gated nor corrected,
//!   until the next `Play` or `Stop`.
//! - **Gate** ([`Gate`]): muted before the first centroid of a session
//!   when tracking is required, on `present = false`, and when the last
//!   centroid is older than the timeout.
//! - **Work volume**: a present centroid outside the playing slot's work
//!   volume ([`UploadHeader::in_work_volume`]) is refused
//!   ([`NackCode::OutOfRange`]) and mutes (`CentroidOutOfRange`) until a
//!   centroid inside it (or one saying the finger left) arrives; a slot
//!   taking over re-checks the last centroid against its own volume
//!   ([`Policy::steer_for`]). The array never steers outside the volume.
//! - **Stale** centroids (sequence number not newer) are refused
//!   ([`NackCode::OutOfOrder`]) and change nothing.
//!
//! Times are in whatever unit the owner's clock counts (timer counts on
//! the firmware, µs on the host); the timeout is in the same unit.

use lm_proto::{Centroid, DeviceState, MuteReason, NackCode, UploadHeader};

use crate::gate::Gate;

/// Where a device's play session stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Session {
    /// Nothing played since reset.
    Idle,
    /// A slot plays (sounding or muted).
    Playing,
    /// Stopped by `Stop` (silent until the next `Play`).
    Stopped,
}

/// The safety policy's state: session, gate, untracked flag, work-volume
/// mute and the last centroid.
#[derive(Debug, Clone, Copy)]
pub struct Policy {
    gate: Gate,
    session: Session,
    untracked: bool,
    /// The last present centroid lay outside the playing slot's volume.
    out_of_range: bool,
    /// Last present centroid accepted (µm, drive coordinates).
    centroid_um: Option<[i32; 3]>,
}

impl Policy {
    /// An idle device: mutes after `timeout` without a centroid and, with
    /// `require_tracking`, from `Play` until the first centroid.
    pub const fn new(timeout: u64, require_tracking: bool) -> Self {
        Self {
            gate: Gate::new(timeout, require_tracking),
            session: Session::Idle,
            untracked: false,
            out_of_range: false,
            centroid_um: None,
        }
    }

    /// Changes the staleness timeout (same unit as `now`).
    pub fn set_timeout(&mut self, timeout: u64) {
        self.gate.timeout_counts = timeout;
    }

    /// Turns muting before the first centroid on or off.
    pub fn set_require_tracking(&mut self, on: bool) {
        self.gate.require_tracking = on;
    }

    /// The session.
    pub fn session(&self) -> Session {
        self.session
    }

    /// Whether the session plays untracked.
    pub fn untracked(&self) -> bool {
        self.untracked
    }

    /// Sequence number of the last accepted centroid (0 if none).
    pub fn last_seq(&self) -> u32 {
        self.gate.last_seq()
    }

    /// A `Play` the device accepted (its player or segments switched).
    pub fn play(&mut self, untracked: bool) {
        if self.session == Session::Playing {
            self.gate.restart_sequence();
        } else {
            self.gate.reset();
            self.centroid_um = None;
            self.out_of_range = false;
        }
        self.session = Session::Playing;
        self.untracked = untracked;
    }

    /// A `Stop`: a playing session ends; an idle device stays idle.
    pub fn stop(&mut self) {
        if self.session == Session::Playing {
            self.session = Session::Stopped;
        }
    }

    /// A centroid update at `now`, checked against `volume`, the header of
    /// the slot that plays (`None`: nothing to check against). `Ok(Some(c))`:
    /// steer to `c`; `Ok(None)`: the finger left (the gate mutes). A refusal
    /// changes the gate nothing; `OutOfRange` mutes until a centroid inside
    /// the volume arrives.
    pub fn centroid(
        &mut self,
        c: &Centroid,
        volume: Option<&UploadHeader>,
        now: u64,
    ) -> Result<Option<[i32; 3]>, NackCode> {
        if !self.gate.is_fresh(c.seq) {
            return Err(NackCode::OutOfOrder);
        }
        if c.present && volume.is_some_and(|h| !h.in_work_volume(c.pos_um)) {
            self.out_of_range = true;
            return Err(NackCode::OutOfRange);
        }
        self.gate.update(c.seq, c.present, now);
        self.out_of_range = false;
        if c.present {
            self.centroid_um = Some(c.pos_um);
            Ok(Some(c.pos_um))
        } else {
            Ok(None)
        }
    }

    /// The centroid to steer the slot with header `h` to, checking the last
    /// centroid against `h`'s work volume (a slot taking over with another
    /// centre or volume): `None` when there is none, play is untracked, or
    /// it lies outside (which then mutes).
    pub fn steer_for(&mut self, h: &UploadHeader) -> Option<[i32; 3]> {
        let c = self.centroid_um?;
        if !h.in_work_volume(c) {
            self.out_of_range = true;
            return None;
        }
        (!self.untracked && !self.out_of_range).then_some(c)
    }

    /// Whether correction offsets apply now (playing, tracked, a centroid
    /// inside the volume known).
    pub fn correcting(&self) -> bool {
        self.session == Session::Playing
            && !self.untracked
            && !self.out_of_range
            && self.centroid_um.is_some()
    }

    /// The correction `Status` reports for a slot planned at `center_um`:
    /// the centroid's offset from it while correcting, else zero.
    pub fn correction_um(&self, center_um: [i32; 3]) -> [i32; 3] {
        match self.centroid_um {
            Some(c) if self.correcting() => {
                core::array::from_fn(|i| c[i].wrapping_sub(center_um[i]))
            }
            _ => [0; 3],
        }
    }

    /// Why the output is silent at `now` ([`MuteReason::None`] while it
    /// sounds or nothing plays).
    pub fn mute_reason(&self, now: u64) -> MuteReason {
        match self.session {
            Session::Idle => MuteReason::None,
            Session::Stopped => MuteReason::Stopped,
            Session::Playing if self.untracked => MuteReason::None,
            Session::Playing if self.out_of_range => MuteReason::CentroidOutOfRange,
            Session::Playing => self.gate.mute_reason(now),
        }
    }

    /// Playing and not muted at `now`.
    pub fn sounding(&self, now: u64) -> bool {
        self.session == Session::Playing && self.mute_reason(now) == MuteReason::None
    }

    /// The `Status` state at `now`.
    pub fn state(&self, now: u64) -> DeviceState {
        match self.session {
            Session::Idle => DeviceState::Idle,
            Session::Stopped => DeviceState::Stopped,
            Session::Playing if self.sounding(now) => DeviceState::Playing,
            Session::Playing => DeviceState::Muted,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(max_offset_um: u32) -> UploadHeader {
        UploadHeader {
            steps: 10,
            transducers: 4,
            period_us: 200_000,
            center_um: [0, 0, 200_000],
            foci_per_step: 1,
            sound_speed_mm_s: 346_000,
            max_offset_um,
            intensity: 255,
        }
    }

    fn at(seq: u32, x: i32, present: bool) -> Centroid {
        Centroid {
            host_time_us: 0,
            seq,
            present,
            pos_um: [x, 0, 200_000],
        }
    }

    #[test]
    fn a_session_mutes_until_tracked_and_stop_ends_it() {
        let mut p = Policy::new(100, true);
        assert_eq!(p.state(0), DeviceState::Idle);
        p.stop();
        assert_eq!(p.state(0), DeviceState::Idle, "stop while idle");
        p.play(false);
        assert_eq!(p.mute_reason(0), MuteReason::WaitingForTracking);
        let h = header(5000);
        assert_eq!(
            p.centroid(&at(1, 1000, true), Some(&h), 10),
            Ok(Some([1000, 0, 200_000]))
        );
        assert_eq!(p.state(10), DeviceState::Playing);
        assert_eq!(p.correction_um(h.center_um), [1000, 0, 0]);
        assert_eq!(p.state(111), DeviceState::Muted, "stale");
        p.stop();
        assert_eq!(
            (p.state(0), p.mute_reason(0)),
            (DeviceState::Stopped, MuteReason::Stopped)
        );
        assert_eq!(p.correction_um(h.center_um), [0; 3]);
        p.play(false);
        assert_eq!(
            p.mute_reason(0),
            MuteReason::WaitingForTracking,
            "a new session forgets"
        );
    }

    #[test]
    fn play_while_playing_keeps_the_gate_and_accepts_a_restarted_count() {
        let mut p = Policy::new(100, true);
        let h = header(5000);
        p.play(false);
        p.centroid(&at(50, 0, true), Some(&h), 0).unwrap();
        p.play(false);
        assert!(p.sounding(1), "no glitch on a switch");
        assert_eq!(
            p.centroid(&at(1, 0, true), Some(&h), 2),
            Ok(Some([0, 0, 200_000]))
        );
        assert_eq!(
            p.centroid(&at(1, 0, true), Some(&h), 3),
            Err(NackCode::OutOfOrder)
        );
    }

    #[test]
    fn out_of_volume_refuses_mutes_and_never_steers() {
        let mut p = Policy::new(100, true);
        let h = header(5000);
        p.play(false);
        p.centroid(&at(1, 0, true), Some(&h), 0).unwrap();
        assert_eq!(
            p.centroid(&at(2, 6000, true), Some(&h), 1),
            Err(NackCode::OutOfRange)
        );
        assert_eq!(p.mute_reason(1), MuteReason::CentroidOutOfRange);
        assert_eq!(p.steer_for(&h), None);
        assert_eq!(p.correction_um(h.center_um), [0; 3]);
        assert_eq!(p.centroid(&at(3, 0, false), Some(&h), 2), Ok(None));
        assert_eq!(p.mute_reason(2), MuteReason::FingerAbsent);
        p.centroid(&at(4, 4000, true), Some(&h), 3).unwrap();
        assert!(p.sounding(3));
        // A slot with a smaller volume takes over: the last centroid is
        // outside it.
        assert_eq!(p.steer_for(&header(3000)), None);
        assert_eq!(p.mute_reason(3), MuteReason::CentroidOutOfRange);
    }

    #[test]
    fn untracked_play_is_neither_gated_nor_corrected() {
        let mut p = Policy::new(100, true);
        let h = header(5000);
        p.play(true);
        assert!(p.sounding(0));
        p.centroid(&at(1, 1000, true), Some(&h), 0).unwrap();
        assert_eq!(p.steer_for(&h), None);
        assert_eq!(p.correction_um(h.center_um), [0; 3]);
        assert!(p.sounding(1_000_000), "never stale");
        p.play(false);
        assert_eq!(p.steer_for(&h), Some([1000, 0, 200_000]), "tracked again");
    }
}
