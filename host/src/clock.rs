//! The clock the host and the simulated device share ([`monotonic_us`],
//! [`Clock`]: the real one or a manual one tests move), and the bounded
//! statistics measured against it (latency rings, the one percentile).
//!
//! Time is microseconds of `CLOCK_MONOTONIC`, which every process on the
//! machine shares, so a host's `Centroid::host_time_us` stamps can be
//! compared with the moment a simulated device applied the update.

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// Microseconds of `CLOCK_MONOTONIC`: the clock the simulated device and
/// the host share.
pub fn monotonic_us() -> u64 {
    let ts = nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC)
        .expect("CLOCK_MONOTONIC is always available on Linux");
    ts.tv_sec() as u64 * 1_000_000 + ts.tv_nsec() as u64 / 1_000
}

/// A monotonic clock, cheap to clone (clones share the time): the real
/// `CLOCK_MONOTONIC` ([`monotonic_us`]) for the CLI, or a manual clock for
/// tests, whose `sleep` moves time on instead of waiting, so loop-end swaps,
/// staleness rules and retries are tested without wall-clock timing.
#[derive(Debug, Clone)]
pub enum Clock {
    /// `CLOCK_MONOTONIC`.
    Real,
    /// Nanoseconds set by the test.
    Manual(Arc<AtomicU64>),
}

impl Clock {
    /// The real clock.
    pub fn real() -> Self {
        Self::Real
    }

    /// A manual clock at `t = 0`.
    pub fn manual() -> Self {
        Self::manual_at_us(0)
    }

    /// A manual clock at `us` microseconds.
    pub fn manual_at_us(us: u64) -> Self {
        Self::Manual(Arc::new(AtomicU64::new(us.saturating_mul(1000))))
    }

    /// Whether time moves only when a test moves it.
    pub fn is_manual(&self) -> bool {
        matches!(self, Self::Manual(_))
    }

    /// Now.
    pub fn now(&self) -> Duration {
        match self {
            Self::Real => Duration::from_micros(monotonic_us()),
            Self::Manual(ns) => Duration::from_nanos(ns.load(Ordering::SeqCst)),
        }
    }

    /// Now, µs.
    pub fn now_us(&self) -> u64 {
        self.now().as_micros() as u64
    }

    /// Waits `d` (real) or moves time on by `d` (manual).
    pub fn sleep(&self, d: Duration) {
        match self {
            Self::Real => std::thread::sleep(d),
            Self::Manual(_) => self.advance(d),
        }
    }

    /// Moves a manual clock on by `d`; the real clock ignores it.
    pub fn advance(&self, d: Duration) {
        if let Self::Manual(ns) = self {
            ns.fetch_add(d.as_nanos() as u64, Ordering::SeqCst);
        }
    }

    /// Sets a manual clock to `us` (never backwards); the real clock
    /// ignores it.
    pub fn set_us(&self, us: u64) {
        if let Self::Manual(ns) = self {
            ns.fetch_max(us.saturating_mul(1000), Ordering::SeqCst);
        }
    }
}

/// How many recent samples a statistics ring keeps (memory stays bounded).
pub const STATS_RING: usize = 16_384;

/// Push into a bounded ring of at most [`STATS_RING`] samples, dropping the
/// oldest.
pub fn push_ring(ring: &mut VecDeque<u64>, v: u64) {
    if ring.len() == STATS_RING {
        ring.pop_front();
    }
    ring.push_back(v);
}

/// Quantile `q` (0–1) of sorted `v` by linear interpolation between the
/// two nearest ranks (numpy's and R's default, type 7): the one
/// definition every percentile, median and quartile in lmhost uses. NaN
/// when `v` is empty.
pub fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let x = q.clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let (i, f) = (x.floor() as usize, x - x.floor());
    match v.get(i + 1) {
        Some(next) => v[i] + f * (next - v[i]),
        None => v[i],
    }
}

/// The summary every latency figure in lmhost gives: median, 99th
/// percentile ([`quantile`]) and maximum, from one sort of the samples.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Spread<T> {
    /// Median.
    pub p50: T,
    /// 99th percentile.
    pub p99: T,
    /// Largest.
    pub max: T,
}

impl Spread<f64> {
    /// Of `values`; `None` when there are none (NaN sorts last and is
    /// then the maximum).
    pub fn of_f64(values: impl IntoIterator<Item = f64>) -> Option<Self> {
        let mut v: Vec<f64> = values.into_iter().collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        Some(Spread {
            p50: quantile(&v, 0.50),
            p99: quantile(&v, 0.99),
            max: v[v.len() - 1],
        })
    }
}

impl Spread<u64> {
    /// Of integer samples (µs), each figure rounded to the nearest
    /// integer; `None` when there are none.
    pub fn of(values: impl IntoIterator<Item = u64>) -> Option<Self> {
        Spread::of_f64(values.into_iter().map(|x| x as f64)).map(|s| s.map(|x| x.round() as u64))
    }

    /// µs → ms.
    pub fn ms(self) -> Spread<f64> {
        self.map(|us| us as f64 / 1e3)
    }
}

impl<T> Spread<T> {
    /// `p50 …, p99 …, max …`, each figure written by `f`: how a spread
    /// reads in a summary line.
    pub fn describe(&self, f: impl Fn(&T) -> String) -> String {
        format!(
            "p50 {}, p99 {}, max {}",
            f(&self.p50),
            f(&self.p99),
            f(&self.max)
        )
    }

    /// [`Self::describe`], or `n/a` where there were no samples.
    pub fn describe_or(spread: Option<&Self>, f: impl Fn(&T) -> String) -> String {
        spread.map_or_else(|| "n/a".to_owned(), |s| s.describe(f))
    }

    /// Each figure through `f` (a change of unit).
    pub fn map<U>(self, f: impl Fn(T) -> U) -> Spread<U> {
        Spread {
            p50: f(self.p50),
            p99: f(self.p99),
            max: f(self.max),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_percentile_interpolates_like_numpy() {
        // numpy.percentile([1, 2, 3, 4, 5], [50, 100, 25, 90]).
        let s = Spread::of([5, 1, 4, 2, 3]).unwrap();
        assert_eq!((s.p50, s.max), (3, 5));
        assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.25), 2.0);
        assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.5), 2.5);
        assert!((quantile(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.9) - 4.6).abs() < 1e-12);
        assert_eq!(Spread::of((1..=100).rev()).unwrap().p99, 99);
        assert_eq!(Spread::of([10, 20]).unwrap().p50, 15);
        assert_eq!(Spread::of([]), None);
        assert!(quantile(&[], 0.5).is_nan());
    }

    /// A plain reference for the spread's figures, written apart from
    /// [`quantile`]: sort, then interpolate between the two ranks around
    /// `p`% of the way from the first to the last sample.
    fn sort_and_index(v: &[f64], p: f64) -> f64 {
        let mut v = v.to_vec();
        v.sort_by(|a, b| a.partial_cmp(b).unwrap());
        let rank = p / 100.0 * (v.len() - 1) as f64;
        let (lo, hi) = (rank.floor() as usize, rank.ceil() as usize);
        v[lo] + (rank - lo as f64) * (v[hi] - v[lo])
    }

    #[test]
    fn a_spread_is_the_one_percentile_at_50_99_and_100() {
        assert_eq!(Spread::of([]), None);
        assert_eq!(Spread::of_f64([]), None);
        let one = Spread {
            p50: 7,
            p99: 7,
            max: 7,
        };
        assert_eq!(Spread::of([7]), Some(one));
        // Against the reference on random data, of several sizes and
        // spreads, in the order drawn (the summary sorts for itself).
        let mut r = crate::rng::SplitMix64::new(11);
        for n in [2usize, 3, 10, 101, 1000, 4096] {
            let range = [10u64, 100_000, u64::from(u32::MAX)][n % 3];
            let v: Vec<u64> = (0..n).map(|_| r.below(range)).collect();
            let f: Vec<f64> = v.iter().map(|&x| x as f64).collect();
            let s = Spread::of(v.iter().copied()).unwrap();
            let want = |p| sort_and_index(&f, p).round() as u64;
            assert_eq!(
                (s.p50, s.p99, s.max),
                (want(50.0), want(99.0), want(100.0)),
                "n {n}"
            );
            assert_eq!(s.max, *v.iter().max().unwrap());
            assert!(s.p50 <= s.p99 && s.p99 <= s.max);
            assert_eq!(s.ms(), s.map(|us| us as f64 / 1e3));

            let x: Vec<f64> = (0..n).map(|_| r.uniform(-5.0, 50.0)).collect();
            let s = Spread::of_f64(x.iter().copied()).unwrap();
            for (got, p) in [(s.p50, 50.0), (s.p99, 99.0), (s.max, 100.0)] {
                assert!((got - sort_and_index(&x, p)).abs() < 1e-9, "n {n}, p{p}");
            }
        }
        // Interpolated, not the nearest rank: p99 of 1, 2, 3 is 2.98.
        let f = Spread::of_f64([3.0, 1.0, 2.0]).unwrap();
        assert_eq!((f.p50, f.max), (2.0, 3.0));
        assert!((f.p99 - 2.98).abs() < 1e-12);
        assert_eq!(
            f.describe(|v| format!("{v:.1} ms")),
            "p50 2.0 ms, p99 3.0 ms, max 3.0 ms"
        );
        assert_eq!(Spread::<u64>::describe_or(None, |v| v.to_string()), "n/a");
    }

    #[test]
    fn ring_stays_bounded() {
        let mut r = VecDeque::new();
        for i in 0..(STATS_RING as u64 + 10) {
            push_ring(&mut r, i);
        }
        assert_eq!(r.len(), STATS_RING);
        assert_eq!(r.front(), Some(&10));
    }

    #[test]
    fn monotonic_clock_does_not_go_back() {
        let a = monotonic_us();
        let b = monotonic_us();
        assert!(b >= a);
    }
}
