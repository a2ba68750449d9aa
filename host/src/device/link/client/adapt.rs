//! How big the next frame of an upload is (a sequence chunk, a group of
//! rig positions): sizes from the largest down by halves to a floor, and
//! per size how many frames were sent and how many of them were lost
//! (resent).
//!
//! A loss that grows with a frame's length (bit errors, dropped bytes) is
//! mended by shorter frames; one that does not (a lost reply, a busy
//! device) only multiplies the frames. So a resend moves to the half size
//! unless that size has already been seen to lose as often, and once the
//! current size has been seen to lose as often as the larger ones, the
//! largest of them comes back: a link losing every other reply keeps (or soon regains)
//! the largest frames. A run of clean frames also tries the double again.
//! Old counts fade ([`FADE`] per frame), so a verdict is tried again as
//! the link changes. Decided on counts alone, never on time, so a
//! replayed run decides alike.

/// Frames (faded) a size needs before its loss rate is compared.
const EVIDENCE: f64 = 8.0;
/// A size helps only when it loses less than this share of the larger
/// size's rate.
const HELPS: f64 = 0.75;
/// What every count keeps of itself at each frame recorded (a memory of
/// some 50 frames).
const FADE: f64 = 0.98;

/// Frames of one size: sent (resends included) and lost, faded.
#[derive(Debug, Clone, Copy, Default)]
struct Tally {
    sent: f64,
    lost: f64,
}

impl Tally {
    /// The loss rate, with one loss in two frames assumed before any are
    /// seen (so one frame says little).
    fn rate(self) -> f64 {
        (self.lost + 1.0) / (self.sent + 2.0)
    }
}

/// The size policy of one upload.
#[derive(Debug, Clone)]
pub(crate) struct Sizer {
    /// Sizes, largest first, each with its frames.
    rungs: Vec<(usize, Tally)>,
    /// The rung in use.
    at: usize,
    /// Clean frames in a row at this rung.
    clean_run: u32,
    /// Clean frames in a row that try the double again.
    regrow_after: u32,
}

impl Sizer {
    /// Sizes from `max` down by halves to `floor` (at most `max`), in use
    /// from `max`; `regrow_after` clean frames in a row try the double.
    pub(crate) fn new(max: usize, floor: usize, regrow_after: u32) -> Self {
        let max = max.max(1);
        let floor = floor.clamp(1, max);
        let mut rungs = vec![(max, Tally::default())];
        let mut size = max;
        while size > floor {
            size = (size / 2).max(floor);
            rungs.push((size, Tally::default()));
        }
        Self {
            rungs,
            at: 0,
            clean_run: 0,
            regrow_after: regrow_after.max(1),
        }
    }

    /// The size of the next frame.
    pub(crate) fn size(&self) -> usize {
        self.rungs[self.at].0
    }

    /// Records one frame of [`Self::size`] acked after `resends` resends,
    /// and picks the size of the next.
    pub(crate) fn record(&mut self, resends: u64) {
        for (_, t) in &mut self.rungs {
            t.sent *= FADE;
            t.lost *= FADE;
        }
        let t = &mut self.rungs[self.at].1;
        t.sent += 1.0 + resends as f64;
        t.lost += resends as f64;
        let smaller_helps =
            |small: Tally, big: Tally| small.sent < EVIDENCE || small.rate() < HELPS * big.rate();
        let here = self.rungs[self.at].1;
        // This size loses as often as the double: the loss is not the
        // length, and the double carries twice as much per frame. Up to
        // the largest size none between loses clearly more often.
        if here.sent >= EVIDENCE {
            let up = self.rungs[..self.at]
                .iter()
                .rev()
                .take_while(|(_, big)| !smaller_helps(here, *big))
                .count();
            if up > 0 {
                self.at -= up;
                self.clean_run = 0;
                return;
            }
        }
        if resends > 0 {
            self.clean_run = 0;
            if let Some(&(_, below)) = self.rungs.get(self.at + 1)
                && smaller_helps(below, here)
            {
                self.at += 1;
            }
            return;
        }
        self.clean_run += 1;
        if self.clean_run >= self.regrow_after && self.at > 0 {
            self.at -= 1;
            self.clean_run = 0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    /// Frames sent to carry `bytes` with sizes from `sizer`, and the bytes
    /// they took (20 of framing each), each attempt of an `n`-byte frame
    /// lost when `lost(n, attempt number)` says so.
    fn frames(
        mut sizer: Sizer,
        bytes: usize,
        mut lost: impl FnMut(usize, u64) -> bool,
    ) -> (u64, u64) {
        let (mut sent, mut wire, mut done) = (0u64, 0u64, 0usize);
        while done < bytes {
            let n = sizer.size().min(bytes - done);
            let mut resends = 0;
            loop {
                sent += 1;
                wire += n as u64 + 20;
                if !lost(n, sent) {
                    break;
                }
                resends += 1;
            }
            sizer.record(resends);
            done += n;
        }
        (sent, wire)
    }

    #[test]
    fn sizes_halve_from_the_largest_to_the_floor() {
        let s = Sizer::new(1024, 64, 16);
        let sizes: Vec<usize> = s.rungs.iter().map(|r| r.0).collect();
        assert_eq!(sizes, [1024, 512, 256, 128, 64]);
        let s = Sizer::new(100, 64, 16);
        assert_eq!(s.rungs.iter().map(|r| r.0).collect::<Vec<_>>(), [100, 64]);
        let s = Sizer::new(32, 64, 16);
        assert_eq!(s.rungs.iter().map(|r| r.0).collect::<Vec<_>>(), [32]);
    }

    #[test]
    fn a_loss_that_is_not_the_length_keeps_the_largest_frames() {
        // Every other reply lost: every chunk is sent twice at any size.
        let bytes = 100 * 1024;
        let (sent, _) = frames(Sizer::new(1024, 64, 16), bytes, |_, k| k % 2 == 1);
        // 100 chunks of 1024 twice each, and the few frames spent finding
        // out that shorter ones do not help; halving on every resend sent
        // about 3200 frames of 64 bytes.
        assert!(sent <= 2 * 100 + 60, "{sent} frames");
        // However long it goes on, the frames are full-sized again.
        let mut s = Sizer::new(1024, 64, 16);
        for _ in 0..40 {
            s.record(1);
        }
        assert_eq!(s.size(), 1024);
    }

    #[test]
    fn a_loss_that_grows_with_the_length_shrinks_the_frames() {
        // Each byte of a frame lost with probability 1e-3 (a 1024-byte
        // frame 64 % of the time, a 64-byte one 6 %).
        let lossy =
            |n: usize, rng: &mut SplitMix64| rng.next_f64() < 1.0 - (1.0f64 - 1e-3).powi(n as i32);
        let bytes = 100 * 1024;
        let mut rng = SplitMix64::new(7);
        let (_, adaptive) = frames(Sizer::new(1024, 64, 16), bytes, |n, _| lossy(n, &mut rng));
        // Never shrinking sends each byte about 2.8 times; the shorter
        // frames about 1.4 times.
        let (_, fixed) = frames(Sizer::new(1024, 1024, 16), bytes, |n, _| lossy(n, &mut rng));
        assert!(
            (adaptive as f64) < 0.65 * fixed as f64,
            "{adaptive} bytes adaptive, {fixed} in frames of 1024"
        );
        let mut s = Sizer::new(1024, 64, 16);
        let mut rng = SplitMix64::new(3);
        for _ in 0..400 {
            let n = s.size();
            let mut resends = 0;
            while lossy(n, &mut rng) {
                resends += 1;
            }
            s.record(resends);
        }
        assert!(s.size() <= 256, "settled at {} bytes", s.size());
    }
}
