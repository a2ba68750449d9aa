//! The clock the host and the simulated device share, and the bounded
//! statistics measured against it (latency rings, percentiles).
//!
//! Time is microseconds of `CLOCK_MONOTONIC`, which every process on the
//! machine shares, so a host's `Centroid::host_time_us` stamps can be
//! compared with the moment a simulated device applied the update.

use std::collections::VecDeque;

/// Microseconds of `CLOCK_MONOTONIC`: the clock the simulated device and
/// the host share.
pub fn monotonic_us() -> u64 {
    let ts = nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC)
        .expect("CLOCK_MONOTONIC is always available on Linux");
    ts.tv_sec() as u64 * 1_000_000 + ts.tv_nsec() as u64 / 1_000
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

/// The `p`-th percentile (0–100) of `values`, nearest rank.
pub fn percentile(values: impl IntoIterator<Item = u64>, p: f64) -> Option<u64> {
    let mut v: Vec<u64> = values.into_iter().collect();
    if v.is_empty() {
        return None;
    }
    v.sort_unstable();
    let rank = ((p / 100.0) * v.len() as f64).ceil().max(1.0) as usize;
    Some(v[rank.min(v.len()) - 1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentile_by_nearest_rank() {
        assert_eq!(percentile([5, 1, 4, 2, 3], 50.0), Some(3));
        assert_eq!(percentile([5, 1, 4, 2, 3], 100.0), Some(5));
        assert_eq!(percentile((1..=100).rev(), 99.0), Some(99));
        assert_eq!(percentile([], 99.0), None);
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
