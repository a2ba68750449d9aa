//! [`CentroidSender`]: the one place centroids are numbered and sent.
//!
//! A device refuses a centroid whose sequence number is not newer than its
//! last accepted one (`OutOfOrder`), and it remembers that number across
//! clients of one play session. So every sender (the streaming loop, the
//! rig session, the Python binding) continues after the device's last
//! number, counts up by one skipping 0 (which means "none"), and keeps the
//! last position for updates that say the finger is gone.

use lm_proto::{Centroid, NackCode};

use crate::device::backend::{Backend, CentroidOutcome, Result as BResult};

/// Numbers centroids for one device and sends them.
#[derive(Debug, Clone)]
pub struct CentroidSender {
    /// Last number sent (0: none yet).
    seq: u32,
    /// Ask the device for its last number before the next centroid.
    ask: bool,
    /// Last present position sent (µm, drive coordinates).
    last_pos_um: [i32; 3],
}

impl Default for CentroidSender {
    fn default() -> Self {
        Self::new()
    }
}

impl CentroidSender {
    /// A sender that asks the device for its last number before its first
    /// centroid.
    pub fn new() -> Self {
        Self {
            seq: 0,
            ask: true,
            last_pos_um: [0; 3],
        }
    }

    /// A sender that continues after `dev`'s last accepted centroid, read
    /// now.
    pub fn after(dev: &mut dyn Backend) -> BResult<Self> {
        Ok(Self::continuing(dev.status()?.last_centroid_seq))
    }

    /// A sender that continues after `seq` (a device's
    /// `Status::last_centroid_seq` the caller has read).
    pub fn continuing(seq: u32) -> Self {
        Self {
            seq,
            ask: false,
            last_pos_um: [0; 3],
        }
    }

    /// The number of the last centroid sent (0: none yet).
    pub fn last_seq(&self) -> u32 {
        self.seq
    }

    /// The last present position sent (µm, drive coordinates).
    pub fn last_pos_um(&self) -> [i32; 3] {
        self.last_pos_um
    }

    /// Sends the finger at `pos_um` (µm, drive coordinates), or gone
    /// (`None`: the last position, `present = false`), stamped
    /// `host_time_us`. A refusal as out of order (another client numbered
    /// past us) is returned, and the next centroid continues after the
    /// device's number.
    pub fn send(
        &mut self,
        dev: &mut dyn Backend,
        pos_um: Option<[i32; 3]>,
        host_time_us: u64,
    ) -> BResult<CentroidOutcome> {
        if self.ask {
            self.seq = dev.status()?.last_centroid_seq;
            self.ask = false;
        }
        let seq = next(self.seq);
        self.seq = seq;
        if let Some(p) = pos_um {
            self.last_pos_um = p;
        }
        let c = Centroid {
            seq,
            pos_um: self.last_pos_um,
            present: pos_um.is_some(),
            host_time_us,
        };
        let r = dev.centroid(&c);
        if let Err(e) = &r
            && e.refusal() == Some(NackCode::OutOfOrder)
        {
            // Continue after the device's own number next time.
            self.ask = true;
        }
        r
    }
}

/// The number after `seq`: 0 means "none" on the wire, so it is skipped.
fn next(seq: u32) -> u32 {
    seq.wrapping_add(1).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::Clock;
    use crate::device::connect::simulated;
    use crate::plan::scene::Scene;
    use crate::plan::stimulus::Stimulus;
    use crate::plan::target::Target;

    #[test]
    fn numbers_continue_after_the_device_and_skip_zero() {
        assert_eq!(next(0), 1);
        assert_eq!(next(41), 42);
        assert_eq!(next(u32::MAX), 1);
        let (mut dev, _) = simulated(Clock::manual_at_us(1_000_000)).unwrap();
        let plan = Stimulus::default()
            .plan_for(&Target::Lm, Scene::default())
            .unwrap()
            .plan;
        let slot = dev.upload(&plan, None).unwrap().slot;
        dev.play(slot, false).unwrap();
        let c = plan.sequence.header.center_um;
        // One client sends three.
        let mut a = CentroidSender::new();
        for _ in 0..3 {
            assert_eq!(
                a.send(&mut dev, Some(c), 0).unwrap(),
                CentroidOutcome::Applied
            );
        }
        assert_eq!(a.last_seq(), 3);
        // Another continues after the device's last: never refused.
        let mut b = CentroidSender::after(&mut dev).unwrap();
        assert_eq!(
            b.send(&mut dev, Some(c), 0).unwrap(),
            CentroidOutcome::Applied
        );
        assert_eq!(b.last_seq(), 4);
        // The first is now behind: refused once, then it continues.
        let e = a.send(&mut dev, Some(c), 0).unwrap_err();
        assert_eq!(e.refusal(), Some(NackCode::OutOfOrder));
        assert_eq!(a.last_seq(), 4, "the number refused");
        a.send(&mut dev, None, 0).unwrap();
        assert_eq!(a.last_seq(), 5);
        // Gone keeps the last position.
        assert_eq!(a.last_pos_um(), c);
        let st = dev.status().unwrap();
        assert_eq!(st.last_centroid_seq, 5);
        assert_eq!(st.mute_reason, lm_proto::MuteReason::FingerAbsent);
    }
}
