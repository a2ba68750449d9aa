//! The force gauge: one reading in newtons, whatever unit the gauge is
//! set to, and a time-stamped series at a rate over a duration (the
//! paper's 2 s median, Experiment 3).

use serde::Serialize;

use super::error::InstrumentError;
use super::unit::ForceUnit;
use crate::clock::Clock;
use crate::limits::show;

/// The sampling rate asked of a gauge unless told otherwise, Hz: 100
/// readings in the paper's 2 s, well within what a request/response gauge
/// answers at 19200 baud (about 10 ms a reading).
pub const DEFAULT_RATE_HZ: f64 = 50.0;
/// Highest sampling rate asked of a gauge, Hz. A request/response reading
/// over RS-232 takes milliseconds (about 10 characters each way at
/// 19200 baud is 10 ms); asking faster only stacks requests.
pub const MAX_RATE_HZ: f64 = 1_000.0;
/// Longest series, s.
pub const MAX_SERIES_S: f64 = 600.0;
/// Most samples in one series (bounded memory whatever the flags).
pub const MAX_SERIES_SAMPLES: usize = 100_000;

/// One reading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Reading {
    /// When the reply arrived, µs on the gauge's clock.
    pub at_us: u64,
    /// The force, N (compression positive, as the gauges ship).
    pub force_n: f64,
    /// The value as the gauge sent it.
    pub value: f64,
    /// The unit it was in.
    pub unit: ForceUnit,
}

/// Readings at a rate over a duration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Series {
    /// The rate asked for, Hz.
    pub rate_hz: f64,
    /// The duration asked for, s.
    pub duration_s: f64,
    /// The readings, in time order.
    pub samples: Vec<Reading>,
}

impl Series {
    /// The median force, N: the middle reading, or the mean of the two
    /// middle ones for an even count (as numpy's `median`); `None` when
    /// empty.
    pub fn median_n(&self) -> Option<f64> {
        let mut v: Vec<f64> = self.samples.iter().map(|r| r.force_n).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let n = v.len();
        Some(if n % 2 == 1 {
            v[n / 2]
        } else {
            (v[n / 2 - 1] + v[n / 2]) / 2.0
        })
    }

    /// The rate achieved, Hz: samples over the time from the first to the
    /// last (`None` with fewer than two).
    pub fn achieved_rate_hz(&self) -> Option<f64> {
        let (first, last) = (self.samples.first()?, self.samples.last()?);
        let span = last.at_us.checked_sub(first.at_us)? as f64 * 1e-6;
        (span > 0.0).then(|| (self.samples.len() - 1) as f64 / span)
    }
}

/// Whether a series of `duration_s` at `rate_hz` holds a reading: the one
/// rule of [`check_series`] and of a study protocol's on-phase, which the
/// gauge samples (Experiment 3; at [`MAX_RATE_HZ`], one under 1 ms holds
/// none).
pub fn holds_a_reading(duration_s: f64, rate_hz: f64) -> bool {
    duration_s * rate_hz >= 1.0
}

/// `Ok(count)` when a series of `duration_s` at `rate_hz` may be taken.
pub fn check_series(port: &str, duration_s: f64, rate_hz: f64) -> Result<usize, InstrumentError> {
    // Each within (0, max].
    for (what, v, max, unit) in [
        ("rate", rate_hz, MAX_RATE_HZ, "Hz"),
        ("duration", duration_s, MAX_SERIES_S, "s"),
    ] {
        if !(v.is_finite() && v > 0.0 && v <= max) {
            return Err(InstrumentError::limit(
                port,
                format!(
                    "sampling {what} {} {unit} is outside (0, {}] {unit}",
                    show(v),
                    show(max)
                ),
            ));
        }
    }
    // A period longer than the series takes one reading whatever the
    // rate (`--rate 1e-300` read once): a rate that changes nothing.
    if !holds_a_reading(duration_s, rate_hz) {
        let least = 1.0 / duration_s;
        return Err(InstrumentError::limit(
            port,
            if least > MAX_RATE_HZ {
                format!(
                    "sampling duration {} s is shorter than one reading at {} Hz: give at least {} s",
                    show(duration_s),
                    show(MAX_RATE_HZ),
                    show(1.0 / MAX_RATE_HZ)
                )
            } else {
                format!(
                    "sampling rate {} Hz is less than one reading in {} s: allowed {}..={} Hz",
                    show(rate_hz),
                    show(duration_s),
                    show(least),
                    show(MAX_RATE_HZ)
                )
            },
        ));
    }
    let n = (duration_s * rate_hz).round().max(1.0);
    if n > MAX_SERIES_SAMPLES as f64 {
        return Err(InstrumentError::limit(
            port,
            format!(
                "{} s at {} Hz is {} samples, more than {MAX_SERIES_SAMPLES}",
                show(duration_s),
                show(rate_hz),
                show(n)
            ),
        ));
    }
    Ok(n as usize)
}

/// A force gauge that answers a reading request.
pub trait ForceGauge {
    /// The port (or `sim-gauge`), for messages.
    fn port(&self) -> &str;
    /// The clock readings are stamped and paced on.
    fn clock(&self) -> &Clock;
    /// One reading, converted to newtons.
    fn read(&mut self) -> Result<Reading, InstrumentError>;

    /// `round(duration_s × rate_hz)` readings, requested at
    /// `t0 + i / rate_hz` (a slow reply delays the next request, it never
    /// makes two close together), each stamped when it arrived. The first
    /// failed reading ends the series with that error.
    fn sample(&mut self, duration_s: f64, rate_hz: f64) -> Result<Series, InstrumentError> {
        let n = check_series(self.port(), duration_s, rate_hz)?;
        let clock = self.clock().clone();
        let t0 = clock.now();
        let mut samples = Vec::with_capacity(n);
        for i in 0..n {
            if crate::stop::requested() {
                return Err(InstrumentError::Interrupted {
                    port: self.port().to_owned(),
                    detail: format!("sampling interrupted by a stop request after {i} readings"),
                });
            }
            let due = t0 + std::time::Duration::from_secs_f64(i as f64 / rate_hz);
            let now = clock.now();
            if due > now {
                clock.sleep(due - now);
            }
            samples.push(self.read()?);
        }
        Ok(Series {
            rate_hz,
            duration_s,
            samples,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(forces: &[f64]) -> Series {
        Series {
            rate_hz: 10.0,
            duration_s: 1.0,
            samples: forces
                .iter()
                .enumerate()
                .map(|(i, &f)| Reading {
                    at_us: i as u64 * 100_000,
                    force_n: f,
                    value: f,
                    unit: ForceUnit::N,
                })
                .collect(),
        }
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(series(&[3.0, 1.0, 2.0]).median_n(), Some(2.0));
        assert_eq!(series(&[4.0, 1.0, 3.0, 2.0]).median_n(), Some(2.5));
        assert_eq!(series(&[]).median_n(), None);
        assert_eq!(series(&[1.0, 1.0, 1.0]).achieved_rate_hz(), Some(10.0));
    }

    #[test]
    fn series_bounds_are_checked() {
        assert_eq!(check_series("g", 2.0, 50.0).unwrap(), 100);
        assert!(check_series("g", 0.0, 50.0).is_err());
        assert!(check_series("g", 2.0, f64::NAN).is_err());
        assert!(check_series("g", 2.0, 2000.0).is_err());
        assert_eq!(check_series("g", 2.0, 0.5).unwrap(), 1);
        let e = check_series("g", 2.0, 1e-300).unwrap_err().to_string();
        assert!(
            e.ends_with(
                "sampling rate 1e-300 Hz is less than one reading in 2 s: allowed 0.5..=1000 Hz"
            ),
            "{e}"
        );
        let e = check_series("g", 1e-4, 1000.0).unwrap_err().to_string();
        assert!(e.ends_with("sampling duration 0.0001 s is shorter than one reading at 1000 Hz: give at least 0.001 s"), "{e}");
        let e = check_series("g", 600.0, 1000.0).unwrap_err().to_string();
        assert!(e.contains("more than 100000"), "{e}");
    }
}
