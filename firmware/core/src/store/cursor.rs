//! Where the playing Delta entry's decoding stands, so that playing it
//! step by step decodes each step once.

use lm_proto::UploadHeader;
use lm_proto::codec::{Encoding, StepDecoder};

use super::RING;

/// The decoder of one Delta entry and its ring of decoded steps.
#[derive(Debug, Clone)]
pub(super) struct Cursor {
    slot: Option<u8>,
    dec: StepDecoder,
    ring: [u8; RING],
}

impl Cursor {
    /// On no entry.
    pub(super) fn new() -> Self {
        Self {
            slot: None,
            dec: StepDecoder::new(Encoding::Delta, 0, 0),
            ring: [0; RING],
        }
    }

    /// Leaves `slot` (its entry was dropped).
    pub(super) fn forget(&mut self, slot: u8) {
        if self.slot == Some(slot) {
            self.slot = None;
        }
    }

    /// Phases of step `step` (below `h.steps`) of `slot`, a Delta entry with
    /// header `h` and stream `data`: from the last step decoded for this
    /// slot (the next step costs one step of decoding; an earlier one, e.g.
    /// step 0 of a new cycle, restarts at step 0).
    pub(super) fn step(
        &mut self,
        slot: u8,
        h: &UploadHeader,
        data: &[u8],
        step: u16,
    ) -> Option<&[u8]> {
        if self.slot != Some(slot) {
            self.slot = Some(slot);
            self.dec = StepDecoder::new(Encoding::Delta, h.steps, h.transducers);
        }
        let done = self.dec.steps_done();
        if step + 1 != done {
            if step < done {
                self.dec.restart();
            }
            let more = step + 1 - self.dec.steps_done();
            let at = self.dec.consumed();
            // The stream was checked at commit; an error cannot happen, and
            // would only silence this step.
            self.dec
                .feed(data.get(at..)?, &mut self.ring, more, |_, _| {})
                .ok()?;
            if self.dec.steps_done() != step + 1 {
                self.slot = None;
                return None;
            }
        }
        Some(StepDecoder::row(
            &self.ring,
            usize::from(h.transducers),
            step,
        ))
    }
}
