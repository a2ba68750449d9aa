//! The force gauge's simulated twin: reads the finger pad
//! ([`FingerPad`]) at the simulated stage's position ([`StageProbe`]), as
//! an IMADA ZTS-50N would: 0.01 N resolution, 50 N capacity, seeded
//! sensor noise of half a resolution step (σ) before rounding to the
//! step, a slow zero drift, and a few milliseconds per reading (what one
//! request and reply take at 19200 baud). It can be told to stop
//! answering at a time, like [`super::SimStage`].

use std::time::Duration;

use super::contact::FingerPad;
use super::error::InstrumentError;
use super::gauge::{ForceGauge, Reading};
use super::sim_stage::StageProbe;
use super::unit::ForceUnit;
use crate::clock::Clock;
use crate::rng::SplitMix64;

/// The twin's name in messages.
pub const SIM_GAUGE_PORT: &str = "sim-gauge";

/// What the simulated gauge is like.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaugeSpec {
    /// Display resolution, N (ZTS-50N: 0.01).
    pub resolution_n: f64,
    /// Capacity, N; beyond it the gauge reports an overload (ZTS-50N: 50).
    pub capacity_n: f64,
    /// Noise σ before rounding, N.
    pub noise_sd_n: f64,
    /// Zero drift, N per second since the gauge was opened.
    pub drift_n_per_s: f64,
    /// Time one reading takes.
    pub latency: Duration,
}

impl GaugeSpec {
    /// The paper's IMADA ZTS-50N: 0.01 N, 50 N, σ 0.005 N, a drift of
    /// 0.01 N per minute, 5 ms a reading.
    pub const ZTS_50N: Self = Self {
        resolution_n: 0.01,
        capacity_n: 50.0,
        noise_sd_n: 0.005,
        drift_n_per_s: 0.01 / 60.0,
        latency: Duration::from_millis(5),
    };
}

/// The simulated gauge.
#[derive(Debug)]
pub struct SimGauge {
    probe: StageProbe,
    pad: FingerPad,
    spec: GaugeSpec,
    rng: SplitMix64,
    opened_us: u64,
    silent_from_us: Option<u64>,
}

impl SimGauge {
    /// A ZTS-50N twin on the probe of a simulated stage, pushing `pad`,
    /// with noise from `seed`.
    pub fn new(probe: StageProbe, pad: FingerPad, seed: u64) -> Self {
        Self::with_spec(probe, pad, GaugeSpec::ZTS_50N, seed)
    }

    /// A twin with another [`GaugeSpec`].
    pub fn with_spec(probe: StageProbe, pad: FingerPad, spec: GaugeSpec, seed: u64) -> Self {
        let opened_us = probe.clock().now_us();
        Self {
            probe,
            pad,
            spec,
            rng: SplitMix64::new(seed),
            opened_us,
            silent_from_us: None,
        }
    }

    /// From `at_us` on the clock, every reading times out.
    pub fn fail_at_us(&mut self, at_us: u64) {
        self.silent_from_us = Some(at_us);
    }

    /// The pad it pushes.
    pub fn pad(&self) -> FingerPad {
        self.pad
    }
}

impl ForceGauge for SimGauge {
    fn port(&self) -> &str {
        SIM_GAUGE_PORT
    }

    fn clock(&self) -> &Clock {
        self.probe.clock()
    }

    fn read(&mut self) -> Result<Reading, InstrumentError> {
        let clock = self.probe.clock().clone();
        if let Some(t) = self.silent_from_us
            && clock.now_us() >= t
        {
            let wait = super::imada::IMADA_REPLY_TIMEOUT;
            clock.advance(wait);
            return Err(InstrumentError::timeout(
                SIM_GAUGE_PORT,
                format!(
                    "no reply to D within {} ms (simulated failure)",
                    wait.as_millis()
                ),
            ));
        }
        // The force at the moment the request is answered.
        clock.advance(self.spec.latency);
        let at_us = clock.now_us();
        let true_n = self.pad.force_n(self.probe.position_mm());
        let drift = self.spec.drift_n_per_s * at_us.saturating_sub(self.opened_us) as f64 * 1e-6;
        let raw = true_n + drift + self.spec.noise_sd_n * self.rng.normal();
        if raw.abs() > self.spec.capacity_n {
            return Err(InstrumentError::refused(
                SIM_GAUGE_PORT,
                format!(
                    "gauge reports an overload ({raw:.2} N beyond {} N); unload it",
                    self.spec.capacity_n
                ),
            ));
        }
        // `+ 0.0` turns a rounded −0 into 0, as a display shows it.
        let shown = (raw / self.spec.resolution_n).round() * self.spec.resolution_n + 0.0;
        Ok(Reading {
            at_us,
            force_n: shown,
            value: shown,
            unit: ForceUnit::N,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::instruments::{SimStage, Stage, StageLimits};

    fn rig(seed: u64) -> (SimStage, SimGauge) {
        let stage =
            SimStage::new(Clock::manual(), StageLimits::new(0.0, 30.0).unwrap(), 0.0).unwrap();
        let gauge = SimGauge::new(stage.probe(), FingerPad::TYPICAL.at(10.0), seed);
        (stage, gauge)
    }

    #[test]
    fn reads_zero_off_the_finger_and_the_model_on_it() {
        let (mut stage, mut gauge) = rig(1);
        let off = gauge.sample(1.0, 50.0).unwrap();
        assert!(
            off.median_n().unwrap().abs() <= 0.01,
            "{:?}",
            off.median_n()
        );
        stage.move_to(12.0).unwrap();
        let on = gauge.sample(2.0, 50.0).unwrap();
        let want = FingerPad::TYPICAL.force_at_depth_n(2.0);
        assert!(
            (on.median_n().unwrap() - want).abs() <= 0.011,
            "{:?} vs {want}",
            on.median_n()
        );
        assert_eq!(on.samples.len(), 100);
        // Every reading is on the 0.01 N grid, and they are not all equal.
        for r in &on.samples {
            assert!(((r.force_n / 0.01).round() * 0.01 - r.force_n).abs() < 1e-9);
        }
        assert!(
            on.samples
                .iter()
                .any(|r| r.force_n != on.samples[0].force_n)
        );
        // 50 Hz stamps, 20 ms apart.
        let dt = on.samples[1].at_us - on.samples[0].at_us;
        assert_eq!(dt, 20_000);
    }

    #[test]
    fn same_seed_same_readings() {
        let read = |seed| {
            let (mut stage, mut gauge) = rig(seed);
            stage.move_to(11.5).unwrap();
            gauge.sample(0.5, 20.0).unwrap()
        };
        assert_eq!(read(7), read(7));
        assert_ne!(read(7), read(8));
    }

    #[test]
    fn drift_shows_over_minutes() {
        let (stage, mut gauge) = rig(3);
        stage.clock().advance(Duration::from_secs(600));
        let r = gauge.sample(1.0, 50.0).unwrap().median_n().unwrap();
        assert!((r - 0.1).abs() <= 0.011, "{r}");
    }

    #[test]
    fn a_silent_gauge_ends_the_series_with_a_timeout() {
        let (_stage, mut gauge) = rig(1);
        gauge.fail_at_us(500_000);
        let err = gauge.sample(2.0, 50.0).unwrap_err();
        assert!(matches!(err, InstrumentError::Timeout { .. }), "{err}");
    }

    #[test]
    fn beyond_capacity_is_an_overload() {
        let (mut stage, mut gauge) = rig(1);
        stage.move_to(30.0).unwrap();
        let err = gauge.read().unwrap_err();
        assert!(err.to_string().contains("overload"), "{err}");
    }
}
