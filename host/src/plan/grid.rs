//! The FPGA's 25 µs sampling grid: choosing `N` and the dwell.
//!
//! An AUTD3 FPGA advances a GainSTM every `freq_div` periods of its
//! 40 kHz ultrasound clock, so a dwell is a whole number of 25 µs periods.
//! When the target is an AUTD3 the planner picks the step count `N` and the
//! divide so the realised LM frequency `1 / (N · dwell)` and step width
//! `2πA / N` are closest to what was asked (sum of relative errors). The
//! paper's N = 82 at 5 Hz wants 2439 µs; the grid gives 2450 µs, 4.98 Hz.

use crate::error::InputError;
use crate::plan::trajectory::{LmParams, Steps};

/// FPGA sampling period (µs): one period of the 40 kHz carrier.
pub const SAMPLING_PERIOD_US: u32 = 25;
/// Fewest patterns a GainSTM holds (autd3 `STM_BUF_SIZE_MIN`).
pub const MIN_PATTERNS: usize = autd3::core::firmware::STM_BUF_SIZE_MIN;
/// Most patterns a GainSTM holds (autd3 `GAIN_STM_BUF_SIZE_MAX`).
pub const MAX_PATTERNS: usize = autd3::core::firmware::GAIN_STM_BUF_SIZE_MAX;
/// Largest sampling divide (the FPGA register is a u16).
pub const MAX_DIVIDE: u32 = u16::MAX as u32;
/// Smallest divide the silencer (1 ms phase completion, strict mode, see
/// [`crate::device::autd3::safety`]) accepts: 40 × 25 µs = 1 ms, the rig's 1 kHz update limit.
pub const SILENCER_MIN_DIVIDE: u32 = 40;

/// The realised timing of an LM cycle on the 25 µs grid.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct GridTiming {
    /// Steps per cycle `N`.
    pub steps: usize,
    /// Sampling divide: dwell = `divide` × 25 µs.
    pub divide: u16,
    /// Dwell per step (µs), a multiple of 25.
    pub dwell_us: u32,
    /// Realised LM frequency `1 / (N · dwell)` (Hz).
    pub freq_hz: f64,
    /// Realised step width `2πA / N` (mm).
    pub step_mm: f64,
    /// Requested LM frequency (Hz).
    pub requested_freq_hz: f64,
    /// Requested step width (mm); for a step count, `2πA / count`.
    pub requested_step_mm: f64,
    /// `freq_hz - requested_freq_hz` (Hz).
    pub freq_error_hz: f64,
    /// `step_mm - requested_step_mm` (mm).
    pub step_error_mm: f64,
}

impl GridTiming {
    /// `p` with the realised `N` and frequency, ready for
    /// [`Trajectory::plan`](crate::plan::trajectory::Trajectory::plan).
    pub fn apply(&self, p: &LmParams) -> LmParams {
        let mut p = p.clone();
        p.cycle.steps = Steps::Count(self.steps);
        p.cycle.freq_hz = self.freq_hz;
        p
    }
}

/// Dwell (µs) of a divide.
pub fn dwell_us(divide: u32) -> u32 {
    divide * SAMPLING_PERIOD_US
}

/// The divide for a dwell in seconds, if it lies on the grid (within 1 ns).
pub fn divide_for_dwell(dwell_s: f64) -> Option<u16> {
    let d = dwell_s * 1e6 / f64::from(SAMPLING_PERIOD_US);
    let r = d.round();
    ((d - r).abs() * f64::from(SAMPLING_PERIOD_US) < 1e-3 && r >= 1.0 && r <= f64::from(MAX_DIVIDE))
        .then_some(r as u16)
}

/// Picks `N` and the divide for an LM of radius `radius_mm`, frequency
/// `freq_hz` and `steps`, with a dwell of at least `min_dwell_s` (and at least
/// the silencer's 1 ms). Errors name the limit that was hit.
pub fn grid_timing(
    radius_mm: f64,
    freq_hz: f64,
    steps: Steps,
    min_dwell_s: f64,
) -> Result<GridTiming, InputError> {
    if !(freq_hz.is_finite() && freq_hz > 0.0) {
        return Err(InputError::new(format!(
            "frequency (--freq) must be a finite number > 0 Hz, got {}",
            crate::limits::show(freq_hz)
        )));
    }
    if !(radius_mm.is_finite() && radius_mm >= 0.0) {
        return Err(InputError::new(format!(
            "radius (--radius) must be a finite number ≥ 0 mm, got {}",
            crate::limits::show(radius_mm)
        )));
    }
    if !(min_dwell_s.is_finite() && min_dwell_s >= 0.0) {
        return Err(InputError::new(format!(
            "minimum dwell must be finite and ≥ 0 s, got {min_dwell_s}"
        )));
    }
    let min_div = SILENCER_MIN_DIVIDE
        .max((min_dwell_s * 1e6 / f64::from(SAMPLING_PERIOD_US) - 1e-9).ceil() as u32);
    let circumference = 2.0 * std::f64::consts::PI * radius_mm;
    let (candidates, requested_step_mm): (Vec<usize>, f64) = match steps {
        Steps::Count(n) => {
            if !(MIN_PATTERNS..=MAX_PATTERNS).contains(&n) {
                return Err(InputError::new(format!(
                    "AUTD3 GainSTM holds {MIN_PATTERNS}..={MAX_PATTERNS} patterns, got {n} steps"
                )));
            }
            (vec![n], circumference / n as f64)
        }
        Steps::Width(w) => {
            if !(w.is_finite() && w > 0.0) {
                return Err(InputError::new(format!(
                    "step (--step) must be a finite number > 0 mm, got {}",
                    crate::limits::show(w)
                )));
            }
            let ideal = circumference / w;
            if ideal > MAX_PATTERNS as f64 * 1.5 {
                return Err(InputError::new(format!(
                    "step width {w} mm at radius {radius_mm} mm needs {ideal:.0} steps; AUTD3 GainSTM holds at most {MAX_PATTERNS}"
                )));
            }
            let lo = ((ideal * 0.8).floor() as usize).clamp(MIN_PATTERNS, MAX_PATTERNS);
            let hi = ((ideal * 1.25).ceil() as usize).clamp(MIN_PATTERNS, MAX_PATTERNS);
            ((lo..=hi).collect(), w)
        }
    };
    let mut best: Option<(f64, GridTiming)> = None;
    for n in candidates {
        let ideal_div = 1e6 / (freq_hz * n as f64 * f64::from(SAMPLING_PERIOD_US));
        let div = ideal_div.round();
        if div < f64::from(min_div) || div > f64::from(MAX_DIVIDE) {
            continue;
        }
        let div = div as u32;
        let dwell = dwell_us(div);
        let f = 1e6 / (n as f64 * f64::from(dwell));
        let s = circumference / n as f64;
        let cost = (f / freq_hz - 1.0).abs()
            + if requested_step_mm > 0.0 {
                (s / requested_step_mm - 1.0).abs()
            } else {
                0.0
            };
        if best.as_ref().is_none_or(|(c, _)| cost < *c) {
            best = Some((
                cost,
                GridTiming {
                    steps: n,
                    divide: div as u16,
                    dwell_us: dwell,
                    freq_hz: f,
                    step_mm: s,
                    requested_freq_hz: freq_hz,
                    requested_step_mm,
                    freq_error_hz: f - freq_hz,
                    step_error_mm: s - requested_step_mm,
                },
            ));
        }
    }
    best.map(|(_, g)| g).ok_or_else(|| {
        let n = match steps {
            Steps::Count(n) => n,
            Steps::Width(w) => ((circumference / w).round() as usize).max(MIN_PATTERNS),
        };
        let want_us = 1e6 / (freq_hz * n as f64);
        // Which way to move: a dwell too long wants more steps a second.
        let advice = match want_us > f64::from(dwell_us(MAX_DIVIDE)) {
            true => "raise the frequency or the step count",
            false => "lower the frequency or the step count",
        };
        InputError::new(format!(
            "LM at {} Hz with {n} steps needs a {:.1} µs dwell; AUTD3 takes {}..={} µs in 25 µs steps (silencer and update limit); {advice}",
            crate::limits::show(freq_hz),
            crate::limits::Num(want_us),
            dwell_us(min_div),
            dwell_us(MAX_DIVIDE)
        ))
    })
}

/// Plans `p` for an AUTD3 rig: grid timing first (scene's minimum dwell),
/// then the trajectory and the phases with the realised `N` and frequency.
pub fn plan(
    p: &LmParams,
    scene: &crate::plan::scene::Scene,
    synthesis: &crate::plan::sequence::Synthesis,
) -> Result<(crate::plan::sequence::Plan, GridTiming), InputError> {
    let c = &p.cycle;
    // The flags' and the firmware's rule first: the grid search below
    // would clamp a step wider than the path to its fewest patterns.
    c.check()?;
    // The grid search works on the cycle's length: a circle's radius is
    // the length over 2π.
    let length_radius = c.path.length_mm(c.radius_mm) / (2.0 * std::f64::consts::PI);
    let g = grid_timing(length_radius, c.freq_hz, c.steps, scene.min_dwell_s)?;
    let trajectory = crate::plan::trajectory::Trajectory::plan(&g.apply(p), scene)?;
    let sequence = crate::plan::sequence::Sequence::synthesize(scene, &trajectory, synthesis)?;
    Ok((
        crate::plan::sequence::Plan {
            scene: scene.clone(),
            trajectory,
            sequence,
            am: None,
        },
        g,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_lm_at_5_hz_is_82_steps_of_2450_us() {
        // The paper: A = 3 mm, 0.23 mm steps, 5 Hz → N = 82, 2439 µs wanted.
        let g = grid_timing(3.0, 5.0, Steps::Width(0.23), 1e-3).unwrap();
        assert_eq!(g.steps, 82);
        assert_eq!(g.divide, 98);
        assert_eq!(g.dwell_us, 2450);
        assert!((g.freq_hz - 4.977).abs() < 1e-3, "{}", g.freq_hz);
        assert_eq!(format!("{:.2}", g.freq_hz), "4.98");
        assert!((g.freq_error_hz + 0.0229).abs() < 1e-3);
        assert!((g.step_mm - 2.0 * std::f64::consts::PI * 3.0 / 82.0).abs() < 1e-12);
        // Asking for N = 82 directly gives the same.
        let c = grid_timing(3.0, 5.0, Steps::Count(82), 1e-3).unwrap();
        assert_eq!((c.steps, c.dwell_us), (82, 2450));
    }

    #[test]
    fn realised_timing_is_on_the_grid_and_closest() {
        for a in [2.0, 3.0, 4.0, 5.0, 6.0] {
            for f in [5.0, 25.0] {
                let w = if f == 5.0 { 0.23 } else { 4.0 };
                let g = grid_timing(a, f, Steps::Width(w), 1e-3).unwrap();
                assert_eq!(g.dwell_us % 25, 0);
                assert!(g.dwell_us >= 1000);
                assert!(
                    (g.freq_hz * g.steps as f64 * f64::from(g.dwell_us) * 1e-6 - 1.0).abs() < 1e-12
                );
                // No neighbouring divide gets the frequency closer for this N.
                for d in [u32::from(g.divide) - 1, u32::from(g.divide) + 1] {
                    let f2 = 1e6 / (g.steps as f64 * f64::from(dwell_us(d)));
                    assert!((f2 - f).abs() >= (g.freq_hz - f).abs() - 1e-12);
                }
                assert_eq!(
                    divide_for_dwell(f64::from(g.dwell_us) * 1e-6),
                    Some(g.divide)
                );
            }
        }
        assert_eq!(divide_for_dwell(2439e-6), None);
    }

    #[test]
    fn limits_give_one_line_errors() {
        for (radius_mm, freq_hz, steps, says) in [
            // 100 Hz with 82 steps: 122 µs dwell, below the 1 ms silencer limit.
            (3.0, 100.0, Steps::Count(82), "1000..=1638375 µs"),
            // Too many patterns.
            (3.0, 0.1, Steps::Count(2000), "1024"),
            (50.0, 0.1, Steps::Width(0.01), "1024"),
            // Too slow: a dwell beyond the u16 divide.
            (3.0, 0.001, Steps::Count(4), "dwell"),
        ] {
            let e = grid_timing(radius_mm, freq_hz, steps, 1e-3)
                .unwrap_err()
                .to_string();
            assert!(e.contains(says), "{e}");
        }
        // A longer minimum dwell from the scene is respected.
        assert!(grid_timing(3.0, 5.0, Steps::Count(82), 3e-3).is_err());
        for e in [
            grid_timing(f64::NAN, 5.0, Steps::Count(8), 1e-3),
            grid_timing(3.0, -1.0, Steps::Count(8), 1e-3),
            grid_timing(3.0, 5.0, Steps::Width(0.0), 1e-3),
        ] {
            assert!(!e.unwrap_err().to_string().contains('\n'));
        }
    }
}
