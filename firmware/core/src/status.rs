//! The `Status` a device reports, assembled in one place from its
//! [`Player`] (slot, step, cycles, queued slot), its [`Policy`] (state, mute
//! reason, correction, last centroid) and what only its own mechanics
//! count. The firmware's handler and the host's AUTD3 backend both call
//! [`status`], so the two report the same fields the same way.

use lm_proto::{Status, UploadHeader};

use crate::player::Player;
use crate::policy::Policy;

/// What a device counts on its own, outside the player and the policy.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Mechanics {
    /// Step deadlines missed (the firmware: boundaries passed before the
    /// step was entered; an AUTD3: steps that sounded past a stop or a
    /// switch because the host made it late).
    pub missed_deadlines: u32,
    /// Bad frames on the framed link (0 without one).
    pub bad_frames: u32,
    /// CRC errors on the framed link (0 without one).
    pub crc_errors: u32,
    /// Nacks sent on the framed link (0 without one).
    pub nacks: u32,
    /// The host lease in force, ms (the LM firmware: the last play's; an
    /// AUTD3: the host-side lease its output is renewed by).
    pub lease_ms: u16,
    /// Milliseconds since reset, wrapping ([`uptime_ms`]; an AUTD3: since
    /// the backend opened it).
    pub uptime_ms: u32,
}

/// `ticks` of a `timer_hz` clock as `Status::uptime_ms`: whole
/// milliseconds, wrapping at `u32::MAX` (49.7 days), without overflow
/// however long the device runs.
pub fn uptime_ms(ticks: u64, timer_hz: u32) -> u32 {
    let hz = u64::from(timer_hz.max(1));
    let ms = ticks / hz * 1000 + ticks % hz * 1000 / hz;
    ms as u32
}

/// The status at `now` of a device whose player is `player`, policy
/// `policy` and whose playing slot (the player's) holds `playing`.
pub fn status(
    player: &Player,
    policy: &Policy,
    playing: Option<&UploadHeader>,
    m: Mechanics,
    now: u64,
) -> Status {
    Status {
        state: policy.state(now),
        slot: player.slot(),
        step: player.step(),
        cycles: player.cycles(),
        missed_deadlines: m.missed_deadlines,
        last_centroid_seq: policy.last_seq(),
        bad_frames: m.bad_frames,
        crc_errors: m.crc_errors,
        nacks: m.nacks,
        correction_um: playing.map_or([0; 3], |h| policy.correction_um(h.center_um)),
        queued_slot: player.pending(),
        mute_reason: policy.mute_reason(now),
        lease_ms: m.lease_ms,
        lease_expiries: policy.lease_expiries(),
        uptime_ms: m.uptime_ms,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::player::Timing;
    use lm_proto::{Centroid, DeviceState, MuteReason};

    #[test]
    fn fields_come_from_the_player_the_policy_and_the_mechanics() {
        let mut player = Player::new(1_000_000);
        let mut policy = Policy::new(100_000, true);
        let t = Timing {
            steps: 4,
            period_us: 1000,
        };
        let header = UploadHeader {
            steps: 4,
            transducers: 1,
            period_us: 1000,
            center_um: [0, 0, 200_000],
            foci_per_step: 1,
            sound_speed_mm_s: 340_000,
            max_offset_um: 20_000,
            intensity: 255,
        };
        assert!(player.start(1, t, 0, 0));
        player.tick(0);
        policy.play(false);
        player.queue(0, t, 10, 0);
        player.tick(600);
        let c = Centroid {
            host_time_us: 0,
            seq: 7,
            present: true,
            pos_um: [1000, 0, 200_000],
        };
        assert_eq!(
            policy.centroid(&c, Some(&header), 600),
            Ok(Some([1000, 0, 200_000]))
        );
        let m = Mechanics {
            missed_deadlines: 3,
            bad_frames: 4,
            crc_errors: 5,
            nacks: 6,
            lease_ms: 1500,
            uptime_ms: 7,
        };
        let st = status(&player, &policy, Some(&header), m, 700);
        assert_eq!(
            (st.state, st.slot, st.step, st.cycles, st.queued_slot),
            (DeviceState::Playing, Some(1), 2, 0, Some(0))
        );
        assert_eq!((st.last_centroid_seq, st.correction_um), (7, [1000, 0, 0]));
        assert_eq!(st.mute_reason, MuteReason::None);
        assert_eq!((st.lease_ms, st.lease_expiries, st.uptime_ms), (1500, 0, 7));
        assert_eq!(
            (st.missed_deadlines, st.bad_frames, st.crc_errors, st.nacks),
            (3, 4, 5, 6)
        );
        // Whole milliseconds of any timer, wrapping after 2^32 of them.
        assert_eq!(uptime_ms(25_000_000 * 3 + 24_999, 25_000_000), 3000);
        assert_eq!(uptime_ms(1_000_000 * 2, 1_000_000), 2000);
        let wrap_us = (1u64 << 32) * 1000;
        assert_eq!(uptime_ms(wrap_us + 5_000, 1_000_000), 5);
        assert_eq!(uptime_ms(wrap_us - 1000, 1_000_000), u32::MAX);
        assert_eq!(uptime_ms(u64::MAX, 1_000_000), (u64::MAX / 1000) as u32);
        // Nothing playing: no correction whatever the policy holds.
        let st = status(&player, &policy, None, Mechanics::default(), 700);
        assert_eq!(st.correction_um, [0; 3]);
    }
}
