//! The plausibility check in front of the filters: a tracker sample that cannot
//! be a finger is dropped and counted, never filtered or sent.
//!
//! Rules (the paper drops outliers too), limits in [`crate::limits`]:
//! - a time stamp older than the last accepted one is **out of order**;
//! - one further ahead of the last accepted one than the time that
//!   passed between their arrivals plus [`MAX_TIME_SKEW_S`] is a **time
//!   jump**, counted apart from out of order, as nothing came in the wrong
//!   order: a wild stamp, or the first of a tracker clock's step. It is
//!   dropped (were a wild stamp taken as the reference, every later,
//!   correct sample would be older and dropped until the stream caught
//!   up with it), unless
//!   [`JUMPS_TO_ACCEPT`] such samples in a row agree (each no further ahead
//!   of the one before than their arrivals are apart plus the skew): then
//!   the tracker's clock really stepped. One wild time stamp so costs one
//!   sample. A tracker that pauses sends nothing meanwhile, so its first
//!   stamp after the pause is as far ahead as it arrived later: kept.
//!   A replay (`--input`, `--stream FILE`) reads each line the moment the
//!   one before it is due, so no arrival time passes between them
//!   ([`Arrival::Replay`]): a step of more than the skew in a recording
//!   needs the agreeing samples (a real pause in it costs two);
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
use crate::limits::{JUMPS_TO_ACCEPT, MAX_CENTROID_MM, MAX_JUMP_MM, MAX_TIME_SKEW_S};

/// When a sample arrived, for the time-stamp rule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Arrival {
    /// A live source (stdin, UDP): the host's monotonic time (s) it was
    /// received at (any origin, the same for every sample).
    Live(f64),
    /// A replayed recording: read as soon as the sample before it was due,
    /// so no time passed between them.
    Replay,
}

/// Why a sample was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reject {
    /// Its time stamp is older than the last accepted sample's.
    OutOfOrder,
    /// Its time stamp is further ahead of the last accepted sample's than
    /// the time since (see the module), and not yet confirmed.
    TimeJump,
    /// A coordinate is beyond the plausible range.
    OutOfRange,
    /// Too far from the last accepted centroid.
    Jump,
}

/// Counts of dropped samples, by reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct PlausibilityCounts {
    /// Time stamps going backwards.
    pub out_of_order: u64,
    /// Time stamps further ahead than the time that passed (a wild stamp,
    /// or one of the first of a clock's step before the next agree).
    pub time_jumps: u64,
    /// Coordinates beyond ±`MAX_CENTROID_MM`.
    pub out_of_range: u64,
    /// Jumps larger than `MAX_JUMP_MM`.
    pub jumps: u64,
}

impl PlausibilityCounts {
    /// All dropped samples.
    pub fn total(&self) -> u64 {
        self.out_of_order + self.time_jumps + self.out_of_range + self.jumps
    }
}

/// The time-stamp rule alone (the module's first two rules): what the
/// gate checks first, and what a replay's pacing checks before it waits
/// for a stamp ([`super::source::paced`]), so a wild one is not slept for.
#[derive(Debug, Clone, Default)]
pub struct Stamps {
    /// The last accepted stamp and its arrival (s; 0 in a replay).
    last: Option<(f64, f64)>,
    /// The run of stamps too far ahead: the last one, its arrival, how many.
    run: Option<(f64, f64, u32)>,
}

impl Stamps {
    /// Whether `t_s`, arrived at `at`, may be taken; if so it is the new
    /// reference.
    pub fn check(&mut self, t_s: f64, at: Arrival) -> Result<(), Reject> {
        let at_s = match at {
            Arrival::Live(s) => s,
            Arrival::Replay => 0.0,
        };
        let Some((last_t, last_at)) = self.last else {
            self.last = Some((t_s, at_s));
            return Ok(());
        };
        if !t_s.is_finite() || t_s < last_t {
            return Err(Reject::OutOfOrder);
        }
        let within =
            |t: f64, a: f64, t0: f64, a0: f64| t - t0 <= (a - a0).max(0.0) + MAX_TIME_SKEW_S;
        if !within(t_s, at_s, last_t, last_at) {
            let n = match self.run {
                Some((p, pa, n)) if t_s >= p && within(t_s, at_s, p, pa) => n + 1,
                _ => 1,
            };
            if n < JUMPS_TO_ACCEPT {
                self.run = Some((t_s, at_s, n));
                return Err(Reject::TimeJump);
            }
        }
        self.run = None;
        self.last = Some((t_s, at_s));
        Ok(())
    }
}

/// The gate's state: the last accepted sample and the current run of jumps.
#[derive(Debug, Clone, Default)]
pub struct Plausibility {
    stamps: Stamps,
    last_pos_mm: Option<[f64; 3]>,
    jump_run: Vec<[f64; 3]>,
    /// What was dropped so far.
    pub counts: PlausibilityCounts,
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

impl Plausibility {
    /// Checks `s`, arrived `at`; `Ok` means it may go to the filter.
    pub fn check(&mut self, s: &Sample, at: Arrival) -> Result<(), Reject> {
        let r = self.judge(s, at);
        match r {
            Ok(()) => self.last_pos_mm = s.present.then_some(s.pos_mm),
            Err(Reject::OutOfOrder) => self.counts.out_of_order += 1,
            Err(Reject::TimeJump) => self.counts.time_jumps += 1,
            Err(Reject::OutOfRange) => self.counts.out_of_range += 1,
            Err(Reject::Jump) => self.counts.jumps += 1,
        }
        r
    }

    fn judge(&mut self, s: &Sample, at: Arrival) -> Result<(), Reject> {
        // The stamp first: a sample dropped for its place below still
        // moved the clock on (it came from the tracker when it says).
        self.stamps.check(s.t_s, at)?;
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
    use Reject::{Jump, OutOfOrder, OutOfRange, TimeJump};

    const OK: Result<(), Reject> = Ok(());

    /// Replays `(t_s, x_mm, verdict)` samples in turn: each is checked
    /// with no arrival time, as a recording is.
    #[track_caller]
    fn replay(g: &mut Plausibility, samples: &[(f64, f64, Result<(), Reject>)]) {
        for (i, &(t_s, x, want)) in samples.iter().enumerate() {
            let got = g.check(&Sample::at(t_s, x), Arrival::Replay);
            assert_eq!(got, want, "sample {i}: {t_s} s at {x} mm");
        }
    }

    #[test]
    fn drops_out_of_order_out_of_range_and_single_jumps() {
        let mut g = Plausibility::default();
        replay(
            &mut g,
            &[
                (1.0, 0.0, OK),
                (-1e300, 0.0, Err(OutOfOrder)),
                (1.1, 1e30, Err(OutOfRange)),
                (1.2, 500.0, Err(Jump)),
                (1.3, 1.0, OK),
            ],
        );
        assert_eq!(
            g.counts,
            PlausibilityCounts {
                out_of_order: 1,
                out_of_range: 1,
                time_jumps: 0,
                jumps: 1
            }
        );
        assert_eq!(g.counts.total(), 3);
    }

    #[test]
    fn a_live_stamp_going_back_is_out_of_order() {
        let mut l = Live::new();
        assert_eq!(l.next(100.0), Ok(()));
        assert_eq!(l.next(100.011), Ok(()));
        // Older than the last taken, by a little or by much.
        assert_eq!(l.next(100.005), Err(OutOfOrder));
        assert_eq!(l.next(3.0), Err(OutOfOrder));
        assert_eq!(l.next(100.033), Ok(()));
        assert_eq!((l.g.counts.out_of_order, l.g.counts.time_jumps), (2, 0));
    }

    #[test]
    fn a_live_stamp_leaping_forward_is_a_time_jump_not_out_of_order() {
        let mut l = Live::new();
        assert_eq!(l.next(100.0), Ok(()));
        // 11 ms later it says 5 s on: further than the time that passed
        // plus the skew, yet nothing came in the wrong order.
        assert_eq!(l.next(105.0), Err(TimeJump));
        // Within the skew of the time that passed is no jump at all.
        assert_eq!(l.next(100.9), Ok(()));
        assert_eq!(l.g.counts.time_jumps, 1);
        assert_eq!(l.g.counts.out_of_order, 0);
        assert_eq!(l.g.counts.total(), 1);
    }

    #[test]
    fn a_real_move_is_followed_after_three_agreeing_jumps() {
        let mut g = Plausibility::default();
        replay(
            &mut g,
            &[
                (0.0, 0.0, OK),
                (0.1, 100.0, Err(Jump)),
                (0.2, 101.0, Err(Jump)),
                (0.3, 102.0, OK),
                (0.4, 103.0, OK),
                // Scattered outliers never agree.
                (0.5, 300.0, Err(Jump)),
                (1.5, -300.0, Err(Jump)),
                (2.5, 300.0, Err(Jump)),
                (3.5, -300.0, Err(Jump)),
            ],
        );
    }

    #[test]
    fn one_time_stamp_far_ahead_is_dropped_and_drops_nothing_after_it() {
        let mut g = Plausibility::default();
        replay(
            &mut g,
            &[
                (1.0, 0.0, OK),
                // A year ahead: were it accepted, every later sample would
                // be older than it and dropped as out of order.
                (3.2e7, 0.0, Err(TimeJump)),
                (1.1, 0.0, OK),
                (1.2, 0.0, OK),
            ],
        );
        assert_eq!((g.counts.out_of_order, g.counts.time_jumps), (0, 1));
    }

    /// A live tracker at 90 Hz on a manual clock: `g` sees sample `i`
    /// stamped `t_s` as it arrives.
    struct Live {
        g: Plausibility,
        clock: crate::clock::Clock,
    }

    impl Live {
        fn new() -> Self {
            Live {
                g: Plausibility::default(),
                clock: crate::clock::Clock::manual(),
            }
        }

        fn next(&mut self, t_s: f64) -> Result<(), Reject> {
            self.clock.advance(std::time::Duration::from_micros(11_111));
            let now = self.clock.now().as_secs_f64();
            self.g.check(&Sample::at(t_s, 0.0), Arrival::Live(now))
        }
    }

    #[test]
    fn a_wild_stamp_minutes_ahead_costs_one_live_sample_not_minutes() {
        let mut l = Live::new();
        for i in 0..10 {
            assert_eq!(l.next(100.0 + f64::from(i) / 90.0), Ok(()));
        }
        // Ten minutes ahead, arrived 11 ms after the last: were it taken
        // as the reference, the next ten minutes of samples would be
        // dropped as going back.
        assert_eq!(l.next(700.0), Err(TimeJump));
        for i in 11..100 {
            assert_eq!(l.next(100.0 + f64::from(i) / 90.0), Ok(()), "sample {i}");
        }
        assert_eq!((l.g.counts.out_of_order, l.g.counts.time_jumps), (0, 1));
    }

    #[test]
    fn a_live_tracker_that_paused_is_followed_at_once() {
        let mut l = Live::new();
        assert_eq!(l.next(100.0), Ok(()));
        // Nothing for ten minutes, then stamps ten minutes on.
        l.clock.advance(std::time::Duration::from_secs(600));
        assert_eq!(l.next(700.0), Ok(()));
        assert_eq!(l.next(700.011), Ok(()));
        assert_eq!(l.g.counts.total(), 0);
    }

    #[test]
    fn a_tracker_clock_that_stepped_is_followed_after_three_agreeing_stamps() {
        let mut l = Live::new();
        assert_eq!(l.next(100.0), Ok(()));
        // The tracker's clock steps an hour on while it keeps sending.
        assert_eq!(l.next(3700.0), Err(TimeJump));
        assert_eq!(l.next(3700.011), Err(TimeJump));
        assert_eq!(l.next(3700.022), Ok(()));
        assert_eq!(l.next(3700.033), Ok(()));
        // Scattered wild stamps never agree.
        for t in [9000.0, 5000.0, 9000.0, 5000.0] {
            assert_eq!(l.next(t), Err(TimeJump));
        }
        assert_eq!(l.next(3700.1), Ok(()));
        assert_eq!((l.g.counts.out_of_order, l.g.counts.time_jumps), (0, 6));
    }

    #[test]
    fn in_a_replay_a_wild_stamp_costs_one_sample_and_a_real_pause_two() {
        let mut g = Plausibility::default();
        replay(
            &mut g,
            &[
                (1.0, 0.0, OK),
                (31.0, 0.0, Err(TimeJump)),
                (1.1, 0.0, OK),
                (1.1 + MAX_TIME_SKEW_S, 0.0, OK),
                // The recording paused 5 s: no arrival time tells it apart
                // from a wild stamp until the samples after it agree.
                (10.0, 0.0, Err(TimeJump)),
                (10.1, 0.0, Err(TimeJump)),
                (10.2, 0.0, OK),
            ],
        );
        assert_eq!((g.counts.out_of_order, g.counts.time_jumps), (0, 3));
    }

    #[test]
    fn absent_samples_only_need_their_time_stamp() {
        let mut g = Plausibility::default();
        let gone = Sample {
            t_s: 0.0,
            pos_mm: [1e300, 0.0, 0.0],
            present: false,
        };
        assert_eq!(g.check(&gone, Arrival::Replay), OK);
        replay(&mut g, &[(0.1, 500.0, OK)]);
    }
}
