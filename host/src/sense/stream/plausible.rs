//! The plausibility check in front of the filters: a tracker sample that cannot
//! be a finger is dropped and counted, never filtered or sent.
//!
//! Rules (the paper drops outliers too), limits in [`crate::limits`]:
//! - a time stamp older than the last accepted one is **out of order**, and
//!   so is one more than [`MAX_TIME_AHEAD_S`] after it (a clock that
//!   jumped), unless [`JUMPS_TO_ACCEPT`] such samples in a row agree (each
//!   within [`MAX_TIME_AHEAD_S`] after the one before): then the tracker
//!   really paused. One wild time stamp so never drops what follows it;
//! - a present centroid with a coordinate beyond ±[`MAX_CENTROID_MM`] is
//!   **out of range**;
//! - a present centroid more than [`MAX_JUMP_MM`] from the last accepted
//!   present one is a **jump**, unless [`JUMPS_TO_ACCEPT`] jumps in a row
//!   agree (within [`MAX_JUMP_MM`] of each other): then the finger really
//!   moved and the gate follows it.
//!
//! Non-finite values never get here: the parser refuses them.
//! A sample without a finger (`present = false`) only needs its time stamp.

use super::Sample;
use crate::limits::{JUMPS_TO_ACCEPT, MAX_CENTROID_MM, MAX_JUMP_MM, MAX_TIME_AHEAD_S};

/// Why a sample was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reject {
    /// Its time stamp is older than the last accepted sample's.
    OutOfOrder,
    /// A coordinate is beyond the plausible range.
    OutOfRange,
    /// Too far from the last accepted centroid.
    Jump,
}

/// Counts of dropped samples, by reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct PlausibilityCounts {
    /// Time stamps going backwards or jumping ahead.
    pub out_of_order: u64,
    /// Coordinates beyond ±`MAX_CENTROID_MM`.
    pub out_of_range: u64,
    /// Jumps larger than `MAX_JUMP_MM`.
    pub jumps: u64,
}

impl PlausibilityCounts {
    /// All dropped samples.
    pub fn total(&self) -> u64 {
        self.out_of_order + self.out_of_range + self.jumps
    }
}

/// The gate's state: the last accepted sample and the current run of jumps.
#[derive(Debug, Clone, Default)]
pub struct Plausibility {
    last_t_s: Option<f64>,
    last_pos_mm: Option<[f64; 3]>,
    jump_run: Vec<[f64; 3]>,
    /// The run of time stamps far ahead: the last one and how many.
    time_run: Option<(f64, u32)>,
    /// What was dropped so far.
    pub counts: PlausibilityCounts,
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

impl Plausibility {
    /// Checks `s`; `Ok` means it may go to the filter.
    pub fn check(&mut self, s: &Sample) -> Result<(), Reject> {
        let r = self.judge(s);
        match r {
            Ok(()) => {
                self.last_t_s = Some(s.t_s);
                self.last_pos_mm = s.present.then_some(s.pos_mm);
            }
            Err(Reject::OutOfOrder) => self.counts.out_of_order += 1,
            Err(Reject::OutOfRange) => self.counts.out_of_range += 1,
            Err(Reject::Jump) => self.counts.jumps += 1,
        }
        r
    }

    fn judge(&mut self, s: &Sample) -> Result<(), Reject> {
        if !s.t_s.is_finite() || self.last_t_s.is_some_and(|t| s.t_s < t) {
            return Err(Reject::OutOfOrder);
        }
        if self.last_t_s.is_some_and(|t| s.t_s - t > MAX_TIME_AHEAD_S) {
            let n = match self.time_run {
                Some((p, n)) if s.t_s >= p && s.t_s - p <= MAX_TIME_AHEAD_S => n + 1,
                _ => 1,
            };
            if n < JUMPS_TO_ACCEPT {
                self.time_run = Some((s.t_s, n));
                return Err(Reject::OutOfOrder);
            }
        }
        self.time_run = None;
        if !s.present {
            self.jump_run.clear();
            return Ok(());
        }
        if !s
            .pos_mm
            .iter()
            .all(|x| x.is_finite() && x.abs() <= MAX_CENTROID_MM)
        {
            return Err(Reject::OutOfRange);
        }
        let Some(last) = self.last_pos_mm else {
            self.jump_run.clear();
            return Ok(());
        };
        if dist(last, s.pos_mm) <= MAX_JUMP_MM {
            self.jump_run.clear();
            return Ok(());
        }
        // A jump: keep it only when the run of jumps agrees.
        if self
            .jump_run
            .last()
            .is_some_and(|p| dist(*p, s.pos_mm) > MAX_JUMP_MM)
        {
            self.jump_run.clear();
        }
        self.jump_run.push(s.pos_mm);
        if self.jump_run.len() as u32 >= JUMPS_TO_ACCEPT {
            self.jump_run.clear();
            return Ok(());
        }
        Err(Reject::Jump)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(t_s: f64, x: f64) -> Sample {
        Sample {
            t_s,
            pos_mm: [x, 0.0, 200.0],
            present: true,
        }
    }

    #[test]
    fn drops_out_of_order_out_of_range_and_single_jumps() {
        let mut g = Plausibility::default();
        assert_eq!(g.check(&at(1.0, 0.0)), Ok(()));
        assert_eq!(g.check(&at(-1e300, 0.0)), Err(Reject::OutOfOrder));
        assert_eq!(g.check(&at(1.1, 1e30)), Err(Reject::OutOfRange));
        assert_eq!(g.check(&at(1.2, 500.0)), Err(Reject::Jump));
        assert_eq!(g.check(&at(1.3, 1.0)), Ok(()));
        assert_eq!(
            g.counts,
            PlausibilityCounts {
                out_of_order: 1,
                out_of_range: 1,
                jumps: 1
            }
        );
        assert_eq!(g.counts.total(), 3);
    }

    #[test]
    fn a_real_move_is_followed_after_three_agreeing_jumps() {
        let mut g = Plausibility::default();
        assert_eq!(g.check(&at(0.0, 0.0)), Ok(()));
        assert_eq!(g.check(&at(0.1, 100.0)), Err(Reject::Jump));
        assert_eq!(g.check(&at(0.2, 101.0)), Err(Reject::Jump));
        assert_eq!(g.check(&at(0.3, 102.0)), Ok(()));
        assert_eq!(g.check(&at(0.4, 103.0)), Ok(()));
        // Scattered outliers never agree.
        for (i, x) in [300.0, -300.0, 300.0, -300.0].iter().enumerate() {
            assert_eq!(g.check(&at(0.5 + i as f64, *x)), Err(Reject::Jump));
        }
    }

    #[test]
    fn one_time_stamp_far_ahead_is_dropped_and_drops_nothing_after_it() {
        let mut g = Plausibility::default();
        assert_eq!(g.check(&at(1.0, 0.0)), Ok(()));
        // A year ahead: were it accepted, every later sample would be
        // older than it and dropped as out of order.
        assert_eq!(g.check(&at(3.2e7, 0.0)), Err(Reject::OutOfOrder));
        assert_eq!(g.check(&at(1.1, 0.0)), Ok(()));
        assert_eq!(g.check(&at(1.2, 0.0)), Ok(()));
        assert_eq!(g.counts.out_of_order, 1);
    }

    #[test]
    fn a_real_pause_is_followed_after_three_agreeing_time_stamps() {
        let mut g = Plausibility::default();
        assert_eq!(g.check(&at(1.0, 0.0)), Ok(()));
        let later = 1.0 + 2.0 * MAX_TIME_AHEAD_S;
        assert_eq!(g.check(&at(later, 0.0)), Err(Reject::OutOfOrder));
        assert_eq!(g.check(&at(later + 0.1, 0.0)), Err(Reject::OutOfOrder));
        assert_eq!(g.check(&at(later + 0.2, 0.0)), Ok(()));
        assert_eq!(g.check(&at(later + 0.3, 0.0)), Ok(()));
    }

    #[test]
    fn absent_samples_only_need_their_time_stamp() {
        let mut g = Plausibility::default();
        let gone = Sample {
            t_s: 0.0,
            pos_mm: [1e300, 0.0, 0.0],
            present: false,
        };
        assert_eq!(g.check(&gone), Ok(()));
        assert_eq!(g.check(&at(0.1, 500.0)), Ok(()));
    }
}
