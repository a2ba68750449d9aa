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
        };
        let st = status(&player, &policy, Some(&header), m, 700);
        assert_eq!(
            (st.state, st.slot, st.step, st.cycles, st.queued_slot),
            (DeviceState::Playing, Some(1), 2, 0, Some(0))
        );
        assert_eq!((st.last_centroid_seq, st.correction_um), (7, [1000, 0, 0]));
        assert_eq!(st.mute_reason, MuteReason::None);
        assert_eq!((st.lease_ms, st.lease_expiries), (1500, 0));
        assert_eq!(
            (st.missed_deadlines, st.bad_frames, st.crc_errors, st.nacks),
            (3, 4, 5, 6)
        );
        // Nothing playing: no correction whatever the policy holds.
        let st = status(&player, &policy, None, Mechanics::default(), 700);
        assert_eq!(st.correction_um, [0; 3]);
    }
}
