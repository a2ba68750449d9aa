//! The one way finger samples come in: every sample a finger source gives
//! passes the plausibility gate ([`super::plausible`]) here before a filter
//! sees it, in `lmhost stream`'s loop ([`super::run`]) and in a session's
//! driver (`lmhost session`, `lmhost study run`), so one rule holds on
//! every path. What it read and dropped is also kept in [`SharedCounts`],
//! which the end of a run reads however the run ended (an error, a stop):
//! the counts are an end summary, not a result.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::time::Duration;

use super::Sample;
use super::plausible::{Arrival, Plausibility, PlausibilityCounts};
use crate::clock::Clock;
use crate::sense::reader::Next;

/// Where finger samples come from: waits at most `wait` so the loop
/// reading them can run its housekeeping and notice a stop while a live
/// source is silent.
pub trait Feed {
    /// The next sample if one comes within `wait`.
    fn next_within(&mut self, wait: Duration) -> Next<anyhow::Result<Sample>>;
}

/// A plain iterator is a feed that never idles: fine for sources that do
/// not block (files, the synthetic finger); live sources go through
/// [`super::run::on_thread`].
impl<I: Iterator<Item = anyhow::Result<Sample>>> Feed for I {
    fn next_within(&mut self, _wait: Duration) -> Next<anyhow::Result<Sample>> {
        self.next().map_or(Next::End, Next::Ready)
    }
}

/// How a source's samples arrive, for the time-stamp rule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Timing {
    /// As the tracker sends them (stdin, UDP, a camera, a depth stream):
    /// each arrives when it is taken off the feed.
    Live,
    /// A recording replayed at its time stamps (`--input`, `--stream FILE`,
    /// `--depth`): each is read when the one before it is due
    /// ([`Arrival::Replay`]).
    Replay,
}

/// What an [`Intake`] read and dropped, shared with whoever reports it.
#[derive(Debug, Default)]
pub struct SharedCounts {
    read: AtomicU64,
    out_of_order: AtomicU64,
    time_jumps: AtomicU64,
    out_of_range: AtomicU64,
    jumps: AtomicU64,
}

impl SharedCounts {
    /// Samples read from the source, dropped ones included.
    pub fn read(&self) -> u64 {
        self.read.load(Relaxed)
    }

    /// Samples the gate dropped, by reason.
    pub fn dropped(&self) -> PlausibilityCounts {
        PlausibilityCounts {
            out_of_order: self.out_of_order.load(Relaxed),
            time_jumps: self.time_jumps.load(Relaxed),
            out_of_range: self.out_of_range.load(Relaxed),
            jumps: self.jumps.load(Relaxed),
        }
    }

    /// What was read and dropped so far, for the `closed` event.
    pub fn snapshot(&self) -> GateCounts {
        let d = self.dropped();
        GateCounts {
            samples: self.read(),
            dropped: d.total(),
            out_of_order: d.out_of_order,
            time_jumps: d.time_jumps,
            out_of_range: d.out_of_range,
            jumps: d.jumps,
        }
    }

    /// The end line of a session or study with a finger source: how many
    /// samples came and what the gate dropped.
    pub fn summary(&self) -> String {
        let d = self.dropped();
        format!(
            "finger: {}, {} dropped as implausible ({} out of order, {}, {} out of range, {})",
            crate::out::count(self.read(), "sample"),
            d.total(),
            d.out_of_order,
            crate::out::count(d.time_jumps, "time jump"),
            d.out_of_range,
            crate::out::count(d.jumps, "jump")
        )
    }
}

/// What a gate read and dropped, by the classes of its end line
/// ([`SharedCounts::summary`]): the `finger` of a session's `closed`
/// event.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct GateCounts {
    /// Samples read from the source, dropped ones included.
    pub samples: u64,
    /// Samples dropped as implausible: the four below together.
    pub dropped: u64,
    /// Dropped: time stamps going backwards.
    pub out_of_order: u64,
    /// Dropped: time stamps further ahead than the time that passed.
    pub time_jumps: u64,
    /// Dropped: coordinates beyond the work volume.
    pub out_of_range: u64,
    /// Dropped: jumps too large for a finger.
    pub jumps: u64,
}

/// The gate in front of one source: its state, its clock (for a live
/// source's arrival times) and its counts.
#[derive(Debug)]
pub struct Intake {
    gate: Plausibility,
    timing: Timing,
    clock: Clock,
    counts: Arc<SharedCounts>,
}

impl Intake {
    /// A gate for a source arriving by `timing`, counting into `counts`;
    /// live arrivals are read on the real clock until
    /// [`on_clock`](Self::on_clock).
    pub fn new(timing: Timing, counts: Arc<SharedCounts>) -> Self {
        Self {
            gate: Plausibility::default(),
            timing,
            clock: Clock::real(),
            counts,
        }
    }

    /// Live arrivals read on `clock` (a session's, manual in tests).
    pub fn on_clock(mut self, clock: Clock) -> Self {
        self.clock = clock;
        self
    }

    /// What this gate read and dropped so far.
    pub fn counts(&self) -> &SharedCounts {
        &self.counts
    }

    /// The next sample of `feed` the gate lets through, waiting at most
    /// `wait` for the first one; a dropped sample is counted and the
    /// next one already there is looked at (without waiting again), so a
    /// run of dropped samples yields [`Next::Idle`] rather than blocking.
    pub fn next(&mut self, feed: &mut dyn Feed, wait: Duration) -> Next<anyhow::Result<Sample>> {
        let mut wait = wait;
        loop {
            let s = match feed.next_within(wait) {
                Next::Ready(Ok(s)) => s,
                other => return other,
            };
            wait = Duration::ZERO;
            self.counts.read.fetch_add(1, Relaxed);
            let at = match self.timing {
                Timing::Live => Arrival::Live(self.clock.now().as_secs_f64()),
                Timing::Replay => Arrival::Replay,
            };
            let verdict = self.gate.check(&s, at);
            let c = self.gate.counts;
            self.counts.out_of_order.store(c.out_of_order, Relaxed);
            self.counts.time_jumps.store(c.time_jumps, Relaxed);
            self.counts.out_of_range.store(c.out_of_range, Relaxed);
            self.counts.jumps.store(c.jumps, Relaxed);
            if verdict.is_ok() {
                return Next::Ready(Ok(s));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drain(intake: &mut Intake, feed: &mut dyn Feed) -> Vec<Sample> {
        let mut out = Vec::new();
        loop {
            match intake.next(feed, Duration::ZERO) {
                Next::Ready(s) => out.push(s.unwrap()),
                Next::Idle => continue,
                Next::End => return out,
            }
        }
    }

    #[test]
    fn a_replay_passes_the_good_samples_and_counts_the_rest() {
        let counts = Arc::new(SharedCounts::default());
        let mut intake = Intake::new(Timing::Replay, counts.clone());
        let samples = [
            Sample::at(1.0, 0.0),
            Sample::at(3.2e7, 0.0), // a stamp a year ahead
            Sample::at(1.1, 1e4),   // far outside any work volume
            Sample::at(1.2, 1.0),
            Sample::at(0.5, 1.0), // older than the last taken
            Sample::at(1.3, 2.0),
        ];
        let mut feed = samples.into_iter().map(Ok);
        let out = drain(&mut intake, &mut feed);
        assert_eq!(out, [samples[0], samples[3], samples[5]]);
        assert_eq!(counts.read(), 6);
        let d = counts.dropped();
        // Out of order, a time jump, out of range, jumps.
        assert_eq!(
            (d.out_of_order, d.time_jumps, d.out_of_range, d.jumps),
            (1, 1, 1, 0)
        );
        assert_eq!(
            counts.summary(),
            "finger: 6 samples, 3 dropped as implausible (1 out of order, 1 time jump, 1 out of range, 0 jumps)"
        );
        // The `closed` event's counts, by the end line's classes.
        assert_eq!(
            serde_json::to_value(counts.snapshot()).unwrap(),
            serde_json::json!({
                "samples": 6, "dropped": 3, "out_of_order": 1, "time_jumps": 1,
                "out_of_range": 1, "jumps": 0
            })
        );
    }

    #[test]
    fn an_error_or_the_end_of_the_feed_is_passed_on() {
        let mut intake = Intake::new(Timing::Replay, Arc::default());
        let mut feed = [
            Ok(Sample::at(1.0, 0.0)),
            Err(anyhow::anyhow!("line 2: bad")),
        ]
        .into_iter();
        assert!(matches!(
            intake.next(&mut feed, Duration::ZERO),
            Next::Ready(Ok(_))
        ));
        assert!(matches!(
            intake.next(&mut feed, Duration::ZERO),
            Next::Ready(Err(_))
        ));
        assert!(matches!(intake.next(&mut feed, Duration::ZERO), Next::End));
        assert_eq!(intake.counts().read(), 1);
    }
}
