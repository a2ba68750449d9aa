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
//! - **Host lease**: a play carries a lease ([`Policy::set_lease`], the
//!   firmware's `Play.lease_ms`); every request the device accepts renews
//!   it ([`Policy::renew`]); once it has passed without one, the play ends
//!   as `Stop` ends it, counted, with the reason `LeaseExpired`
//!   ([`Policy::expire_lease`], which the owner calls before it handles a
//!   request or plays a step, so a late call still stops and a late
//!   request never revives it). Every kind of play has one on the
//!   firmware; without [`Policy::set_lease`] (the AUTD3 backend today) a
//!   play has none.
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
/// mute, the last centroid and the host lease.
#[derive(Debug, Clone, Copy)]
pub struct Policy {
    gate: Gate,
    session: Session,
    untracked: bool,
    /// The last present centroid lay outside the playing slot's volume.
    out_of_range: bool,
    /// Last present centroid accepted (µm, drive coordinates).
    centroid_um: Option<[i32; 3]>,
    /// How long a play lasts without hearing from its host (`None`: no
    /// lease).
    lease: Option<u64>,
    /// When the host was last heard from (an accepted request).
    renewed: u64,
    /// The session was ended by its lease (not by `Stop` or its steps).
    lease_ended: bool,
    /// Plays ended by their lease, since reset (wrapping).
    lease_expiries: u32,
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
            lease: None,
            renewed: 0,
            lease_ended: false,
            lease_expiries: 0,
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
        self.lease_ended = false;
    }

    /// A `Stop`: a playing session ends; an idle device stays idle.
    pub fn stop(&mut self) {
        if self.session == Session::Playing {
            self.session = Session::Stopped;
            self.lease_ended = false;
        }
    }

    /// The play session's host lease: it ends `lease` after the last
    /// renewal; this call (with its `Play`) is one, at `now`.
    pub fn set_lease(&mut self, lease: u64, now: u64) {
        self.lease = Some(lease);
        self.renewed = now;
    }

    /// The host was heard from at `now` (the owner accepted a request):
    /// the lease runs from here.
    pub fn renew(&mut self, now: u64) {
        self.renewed = self.renewed.max(now);
    }

    /// When the playing session's lease runs out (`None`: nothing plays,
    /// or no lease): a time the owner must act at, like a step boundary.
    pub fn lease_deadline(&self) -> Option<u64> {
        let lease = self.lease?;
        (self.session == Session::Playing).then(|| self.renewed.saturating_add(lease))
    }

    /// Whether the playing session's lease has run out at `now`.
    pub fn lease_expired(&self, now: u64) -> bool {
        self.lease_deadline().is_some_and(|d| now >= d)
    }

    /// Ends the playing session if its lease has run out at `now` (as a
    /// `Stop`, the reason kept and counted); returns whether it did, so
    /// the owner stops its output too. Call it before handling a request
    /// or playing a step.
    pub fn expire_lease(&mut self, now: u64) -> bool {
        if !self.lease_expired(now) {
            return false;
        }
        self.session = Session::Stopped;
        self.lease_ended = true;
        self.lease_expiries = self.lease_expiries.wrapping_add(1);
        true
    }

    /// Plays ended by their lease since reset.
    pub fn lease_expiries(&self) -> u32 {
        self.lease_expiries
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
            Session::Stopped if self.lease_ended => MuteReason::LeaseExpired,
            Session::Stopped => MuteReason::Stopped,
            Session::Playing if self.untracked => MuteReason::None,
            Session::Playing if self.out_of_range => MuteReason::CentroidOutOfRange,
            Session::Playing => self.gate.mute_reason(now),
        }
    }

    /// Playing, within its lease, and not muted at `now`.
    pub fn sounding(&self, now: u64) -> bool {
        self.session == Session::Playing
            && !self.lease_expired(now)
            && self.mute_reason(now) == MuteReason::None
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

    /// A tracked play (5 mm work volume) whose first centroid, `seq` at the
    /// planned centre, was accepted at 0.
    fn tracked(seq: u32) -> (Policy, UploadHeader) {
        let mut p = Policy::new(100, true);
        let h = header(5000);
        p.play(false);
        p.centroid(&at(seq, 0, true), Some(&h), 0).unwrap();
        (p, h)
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
        let (mut p, h) = tracked(50);
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
        let (mut p, h) = tracked(1);
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

    #[test]
    fn a_play_ends_when_its_host_lease_runs_out() {
        let mut p = Policy::new(100, true);
        p.play(true);
        p.set_lease(1000, 50);
        assert_eq!(p.lease_deadline(), Some(1050));
        p.renew(400);
        p.renew(300); // never backwards
        assert_eq!(p.lease_deadline(), Some(1400));
        assert!(!p.expire_lease(1399));
        assert!(p.sounding(1399));
        assert!(!p.sounding(1400), "not sounding once it ran out");
        // Called late: still ends, once.
        assert!(p.expire_lease(5000));
        assert!(!p.expire_lease(6000));
        assert_eq!(
            (p.state(5000), p.mute_reason(5000)),
            (DeviceState::Stopped, MuteReason::LeaseExpired)
        );
        assert_eq!(p.lease_expiries(), 1);
        assert_eq!(p.lease_deadline(), None, "nothing plays");
        // A renewal after the end revives nothing.
        p.renew(5001);
        assert_eq!(p.state(5001), DeviceState::Stopped);
        // A new play starts afresh; a Stop ends it with its own reason.
        p.play(true);
        p.set_lease(1000, 6000);
        assert_eq!(p.mute_reason(6000), MuteReason::None);
        p.stop();
        assert_eq!(p.mute_reason(6000), MuteReason::Stopped);
        assert!(!p.expire_lease(99_999), "a stopped play has no lease");
        assert_eq!(p.lease_expiries(), 1);
    }

    #[test]
    fn without_a_lease_a_play_lasts() {
        let mut p = Policy::new(100, false);
        p.play(true);
        assert_eq!(p.lease_deadline(), None);
        assert!(!p.expire_lease(u64::MAX));
        assert!(p.sounding(u64::MAX));
    }
}
