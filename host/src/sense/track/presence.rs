//! Presence with hysteresis for the device gate: one noisy frame neither
//! mutes nor unmutes.
//!
//! The gate opens after [`Hysteresis::enter`] consecutive frames with a
//! contact area and closes after [`Hysteresis::leave`] consecutive frames
//! without. The default is 2 and 2: a single dropout or a single speck is
//! ignored, and the gate is at most one frame late at a real transition.

use crate::error::InputError;

/// The default count of each side (`--enter-frames`, `--leave-frames`).
pub const DEFAULT_FRAMES: u32 = 2;

/// The most frames `lmhost track` lets either count be: one second at the
/// camera's 90 fps (a longer gate would mute or unmute a finger that has
/// long moved).
pub const MAX_FRAMES: u32 = 90;

/// Presence hysteresis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Hysteresis {
    /// Consecutive present frames that open the gate (1..=[`MAX_FRAMES`]).
    enter: u32,
    /// Consecutive absent frames that close it (1..=[`MAX_FRAMES`]).
    leave: u32,
    open: bool,
    run: u32,
}

impl Default for Hysteresis {
    fn default() -> Self {
        Self {
            enter: DEFAULT_FRAMES,
            leave: DEFAULT_FRAMES,
            open: false,
            run: 0,
        }
    }
}

impl Hysteresis {
    /// A closed gate opening after `enter` present frames
    /// (`--enter-frames`) and closing after `leave` absent ones
    /// (`--leave-frames`), each in 1..=[`MAX_FRAMES`]; anything else is
    /// refused naming the flag (a count of 0 is not raised to 1).
    pub fn new(enter: u32, leave: u32) -> Result<Self, InputError> {
        for (name, v) in [("--enter-frames", enter), ("--leave-frames", leave)] {
            if !(1..=MAX_FRAMES).contains(&v) {
                crate::bad_input!("{name} {v} must be between 1 and {MAX_FRAMES}");
            }
        }
        Ok(Self {
            enter,
            leave,
            ..Self::default()
        })
    }

    /// Consecutive present frames that open the gate.
    pub fn enter(&self) -> u32 {
        self.enter
    }

    /// Consecutive absent frames that close it.
    pub fn leave(&self) -> u32 {
        self.leave
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
        let mut h = Hysteresis::new(2, 3).unwrap();
        let out: Vec<bool> = [true, true, false, false, false]
            .iter()
            .map(|&r| h.update(r))
            .collect();
        assert_eq!(out, [false, true, true, true, false]);
    }

    #[test]
    fn the_track_gate_takes_1_to_90_frames_each_and_names_the_flag() {
        let h = Hysteresis::new(1, 90).unwrap();
        assert_eq!((h.enter(), h.leave()), (1, 90));
        assert_eq!(Hysteresis::new(2, 2).unwrap(), Hysteresis::default());
        for (enter, leave, e) in [
            (0, 2, "--enter-frames 0 must be between 1 and 90"),
            (91, 2, "--enter-frames 91 must be between 1 and 90"),
            (2, 0, "--leave-frames 0 must be between 1 and 90"),
            (
                2,
                u32::MAX,
                "--leave-frames 4294967295 must be between 1 and 90",
            ),
        ] {
            assert_eq!(Hysteresis::new(enter, leave).unwrap_err().to_string(), e);
        }
    }
}
