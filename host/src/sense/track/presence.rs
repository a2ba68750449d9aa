//! Presence with hysteresis for the device gate: one noisy frame neither
//! mutes nor unmutes.
//!
//! The gate opens after [`Hysteresis::enter`] consecutive frames with a
//! contact area and closes after [`Hysteresis::leave`] consecutive frames
//! without. The default is 2 and 2: a single dropout or a single speck is
//! ignored, and the gate is at most one frame late at a real transition.

/// Presence hysteresis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Hysteresis {
    /// Consecutive present frames that open the gate.
    pub enter: u32,
    /// Consecutive absent frames that close it.
    pub leave: u32,
    open: bool,
    run: u32,
}

impl Default for Hysteresis {
    fn default() -> Self {
        Self::new(2, 2)
    }
}

impl Hysteresis {
    /// A closed gate with the given counts (each at least 1).
    pub fn new(enter: u32, leave: u32) -> Self {
        Self {
            enter: enter.max(1),
            leave: leave.max(1),
            open: false,
            run: 0,
        }
    }

    /// Feed one frame's raw presence; returns the gated presence.
    pub fn update(&mut self, raw: bool) -> bool {
        if raw == self.open {
            self.run = 0;
        } else {
            self.run += 1;
            let need = if self.open { self.leave } else { self.enter };
            if self.run >= need {
                self.open = raw;
                self.run = 0;
            }
        }
        self.open
    }

    /// Whether the gate is open.
    pub fn is_open(&self) -> bool {
        self.open
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_frames_are_ignored_and_transitions_are_one_frame_late() {
        let mut h = Hysteresis::default();
        let raw = [
            false, true, false, true, true, true, false, true, true, false, false, false,
        ];
        let out: Vec<bool> = raw.iter().map(|&r| h.update(r)).collect();
        assert_eq!(
            out,
            [
                false, false, false, false, true, true, true, true, true, true, false, false
            ]
        );
        let mut h = Hysteresis::new(2, 3);
        let out: Vec<bool> = [true, true, false, false, false]
            .iter()
            .map(|&r| h.update(r))
            .collect();
        assert_eq!(out, [false, true, true, true, false]);
    }
}
