//! Amplitude modulation (AM) of a stimulus: an envelope on the output
//! level, as pyautd3's `Sine` and `Square`, alongside the LM path.
//!
//! The envelope `e(t)` runs from 1 (the stimulus's intensity) down to
//! `1 − depth`: a sine `1 − depth·(1 − cos 2πf t)/2` (starting at its
//! peak) or a square at 1 for the first half period and `1 − depth` for
//! the second. The array's sound pressure follows `e(t)`, so the
//! radiation pressure follows `e(t)²`.
//!
//! On an AUTD3 it is autd3's modulation, sampled at [`SAMPLE_RATE_HZ`]
//! (the silencer's strict mode refuses a modulation sampled faster than
//! its 250 µs intensity completion time, so 4 kHz is the fastest): `f` is
//! realised as `4000 / S` Hz with `S` whole samples per period
//! ([`Am::samples_per_period`]).
//!
//! On the LM firmware (protocol v6) it is the entry's intensity table, one
//! level per step ([`Am::lm_table`]): the envelope sampled at each step's
//! start, `round(255 · e)`, which the device multiplies into the entry's
//! intensity. The loop restarts the table every cycle, so a cycle must
//! hold a whole number of AM periods (or the envelope would jump at the
//! loop) of at least [`MIN_LM_STEPS_PER_PERIOD`] steps each; another
//! frequency is refused with the ones that fit, never moved to one.

use crate::error::InputError;
use crate::limits;

/// Lowest AM frequency (Hz).
pub const MIN_FREQ_HZ: f64 = 0.5;
/// Highest AM frequency (Hz): 16 samples per period at 4 kHz, and above
/// the skin's most sensitive band (~200 Hz); the silencer's 250 µs
/// intensity ramp rounds a square's edges there.
pub const MAX_FREQ_HZ: f64 = 250.0;
/// Modulation sample rate on an AUTD3 (Hz): its 40 kHz clock divided by
/// [`SAMPLE_DIVIDE`].
pub const SAMPLE_RATE_HZ: f64 = 4000.0;
/// autd3's modulation sampling divide (of its 40 kHz clock) for AM: the
/// silencer's intensity completion steps, the smallest strict mode takes.
pub const SAMPLE_DIVIDE: u16 = 10;

/// Fewest steps per AM period an LM intensity table carries: fewer cannot
/// tell a sine's peak from its trough, nor keep a square's two halves.
pub const MIN_LM_STEPS_PER_PERIOD: usize = 4;

/// An AM realised on the LM firmware: the entry's intensity table.
#[derive(Debug, Clone, PartialEq)]
pub struct LmAm {
    /// One level per step, `round(255 · e(t_j))`, 255 = the entry's intensity.
    pub table: Vec<u8>,
    /// Whole AM periods per LM cycle.
    pub periods_per_cycle: usize,
    /// The frequency the device plays (Hz): periods per cycle over the
    /// cycle's whole-µs period.
    pub freq_hz: f64,
}

/// The envelope's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AmShape {
    /// `1 − depth·(1 − cos 2πf t)/2`.
    Sine,
    /// 1, then `1 − depth`, half a period each.
    Square,
}

impl AmShape {
    /// Its name in summaries and the library file.
    pub fn name(self) -> &'static str {
        match self {
            AmShape::Sine => "sine",
            AmShape::Square => "square",
        }
    }
}

/// An amplitude modulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Am {
    /// Envelope shape.
    pub shape: AmShape,
    /// Modulation frequency (Hz), [`MIN_FREQ_HZ`]..=[`MAX_FREQ_HZ`].
    pub freq_hz: f64,
    /// Modulation depth, 0..=1 (1: down to silence).
    pub depth: f64,
}

impl Am {
    /// Checks frequency and depth (one-line [`InputError`]s).
    pub fn check(&self) -> Result<(), InputError> {
        if !self.freq_hz.is_finite() || !self.depth.is_finite() {
            return Err(InputError::new(format!(
                "modulation frequency and depth must be finite, got {} Hz and {}",
                limits::show(self.freq_hz),
                limits::show(self.depth)
            )));
        }
        limits::in_range(
            "modulation frequency",
            self.freq_hz,
            MIN_FREQ_HZ,
            MAX_FREQ_HZ,
            "Hz",
        )?;
        limits::in_range("modulation depth", self.depth, 0.0, 1.0, "")?;
        Ok(())
    }

    /// Samples per period at [`SAMPLE_RATE_HZ`]: the nearest whole number.
    pub fn samples_per_period(&self) -> usize {
        ((SAMPLE_RATE_HZ / self.freq_hz).round() as usize).max(2)
    }

    /// The frequency an AUTD3 plays (Hz): [`SAMPLE_RATE_HZ`] over whole
    /// samples per period. Simulations use it too, so a figure shows what
    /// the device plays.
    pub fn realised_freq_hz(&self) -> f64 {
        SAMPLE_RATE_HZ / self.samples_per_period() as f64
    }

    /// The envelope at phase `x` of its period (`x` in periods; any real).
    pub fn envelope_at_phase(&self, x: f64) -> f64 {
        // The nudge keeps a phase computed in floating point (`t·f`) that
        // should be whole or half on its side of the square's edges.
        let x = (x + 1e-9).rem_euclid(1.0);
        match self.shape {
            AmShape::Sine => {
                1.0 - self.depth * (1.0 - (2.0 * std::f64::consts::PI * x).cos()) / 2.0
            }
            AmShape::Square => {
                if x < 0.5 {
                    1.0
                } else {
                    1.0 - self.depth
                }
            }
        }
    }

    /// The intensity table of this AM on the LM firmware for a cycle of
    /// `steps` steps lasting `period_us` µs, or a one-line [`InputError`]
    /// naming the frequencies that fit when a cycle does not hold a whole
    /// number of periods of at least [`MIN_LM_STEPS_PER_PERIOD`] steps.
    /// "Whole" is as exact as the cycle itself: its period is whole µs, so
    /// a multiple of the asked LM frequency may miss by that rounding.
    pub fn lm_table(&self, steps: usize, period_us: u32) -> Result<LmAm, InputError> {
        self.check()?;
        let period_s = f64::from(period_us) * 1e-6;
        let cycle_hz = 1.0 / period_s;
        let periods = self.freq_hz * period_s;
        let m = periods.round();
        let tol = m.max(1.0) * 0.5 / f64::from(period_us);
        let most =
            (steps / MIN_LM_STEPS_PER_PERIOD).min((MAX_FREQ_HZ / cycle_hz + 1e-9).floor() as usize);
        let least = ((MIN_FREQ_HZ / cycle_hz - 1e-9).ceil() as usize).max(1);
        let whole = m >= 1.0 && (periods - m).abs() <= tol;
        if whole && (least..=most).contains(&(m as usize)) {
            let m = m as usize;
            // Step j starts at phase j·m/N of the AM: exact in integers.
            let table = (0..steps)
                .map(|j| {
                    let x = ((j * m) % steps) as f64 / steps as f64;
                    (255.0 * self.envelope_at_phase(x)).round() as u8
                })
                .collect();
            return Ok(LmAm {
                table,
                periods_per_cycle: m,
                freq_hz: m as f64 * cycle_hz,
            });
        }
        let show = |k: usize| limits::show(k as f64 * cycle_hz);
        let fits = if least > most {
            "none does: use more steps per cycle".to_string()
        } else {
            let lo = (periods.floor() as usize).clamp(least, most);
            let hi = (periods.ceil() as usize).clamp(least, most);
            let nearest = if lo == hi {
                format!("{} Hz", show(lo))
            } else {
                format!("{} or {} Hz", show(lo), show(hi))
            };
            format!(
                "those that fit are the multiples of {} Hz from {} to {} Hz (nearest: {nearest})",
                limits::show(cycle_hz),
                show(least),
                show(most)
            )
        };
        Err(InputError::new(format!(
            "amplitude modulation at {} Hz does not fit the LM firmware's steps at this dwell \
             ({steps} steps of {} µs, a {} Hz cycle): a cycle must hold a whole number of AM \
             periods of at least {MIN_LM_STEPS_PER_PERIOD} steps each; {fits}",
            limits::show(self.freq_hz),
            limits::show(f64::from(period_us) / steps.max(1) as f64),
            limits::show(cycle_hz),
        )))
    }

    /// The envelope at time `t_s` (s) at the realised frequency.
    pub fn envelope(&self, t_s: f64) -> f64 {
        self.envelope_at_phase(t_s * self.realised_freq_hz())
    }

    /// Sample `k` of the modulation at `level` (0..=255) as autd3 plays
    /// it: `round(level × e)` at sample `k mod S`.
    pub fn sample(&self, level: u8, k: u64) -> u8 {
        let s = self.samples_per_period() as u64;
        let x = (k % s) as f64 / s as f64;
        (f64::from(level) * self.envelope_at_phase(x)).round() as u8
    }

    /// The mean of `e²` over a period: the factor on the time-averaged
    /// radiation pressure.
    pub fn mean_square(&self) -> f64 {
        let s = self.samples_per_period().max(64);
        (0..s)
            .map(|k| self.envelope_at_phase(k as f64 / s as f64).powi(2))
            .sum::<f64>()
            / s as f64
    }

    /// The amplitude `|c₁|` of `e²`'s component at the AM frequency
    /// (`e² = c₀ + Σ 2|c_k| cos(…)`; returns `2|c₁|`, the sinusoid's
    /// amplitude): radiation pressure at the AM frequency per unit mean
    /// pressure without modulation.
    pub fn square_first_harmonic(&self) -> f64 {
        let s = self.samples_per_period().max(64);
        let (mut re, mut im) = (0.0, 0.0);
        for k in 0..s {
            let x = k as f64 / s as f64;
            let e2 = self.envelope_at_phase(x).powi(2);
            let (sn, cs) = (2.0 * std::f64::consts::PI * x).sin_cos();
            re += e2 * cs;
            im -= e2 * sn;
        }
        2.0 * re.hypot(im) / s as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn am(shape: AmShape, freq_hz: f64, depth: f64) -> Am {
        Am {
            shape,
            freq_hz,
            depth,
        }
    }

    #[test]
    fn the_envelope_runs_from_one_to_one_minus_depth() {
        let s = am(AmShape::Sine, 200.0, 0.6);
        assert_eq!(s.samples_per_period(), 20);
        assert_eq!(s.realised_freq_hz(), 200.0);
        assert!((s.envelope_at_phase(0.0) - 1.0).abs() < 1e-12);
        assert!((s.envelope_at_phase(0.5) - 0.4).abs() < 1e-12);
        assert_eq!(s.sample(255, 0), 255);
        assert_eq!(s.sample(255, 10), 102);
        assert_eq!(s.sample(255, 30), 102, "periodic");
        let q = am(AmShape::Square, 150.0, 1.0);
        // 4000 / 150 = 26.7 → 27 samples: 148.1 Hz.
        assert_eq!(q.samples_per_period(), 27);
        assert!((q.realised_freq_hz() - 148.148).abs() < 1e-3);
        assert_eq!((q.sample(200, 13), q.sample(200, 14)), (200, 0));
    }

    #[test]
    fn the_lm_table_samples_the_envelope_at_each_step() {
        // The paper's 5 Hz cycle: 82 steps over 200 ms. 20 Hz is 4 periods.
        let s = am(AmShape::Sine, 20.0, 1.0);
        let t = s.lm_table(82, 200_000).unwrap();
        assert_eq!(
            (t.periods_per_cycle, t.freq_hz, t.table.len()),
            (4, 20.0, 82)
        );
        // Step j at phase 4j/82: the peak at 0, the trough half a period on
        // (step 10.25: none lands on it), periodic over the cycle.
        assert_eq!(t.table[0], 255);
        let want = |j: usize| {
            let x = (4 * j % 82) as f64 / 82.0;
            (255.0 * (1.0 + (2.0 * std::f64::consts::PI * x).cos()) / 2.0).round() as u8
        };
        assert!((0..82).all(|j| t.table[j] == want(j)), "{:?}", t.table);
        assert_eq!(t.table.iter().min(), Some(&0), "depth 1 reaches silence");
        // A square at depth 0.5, 4 steps a period on an 8-step cycle.
        let q = am(AmShape::Square, 5.0, 0.5).lm_table(8, 400_000).unwrap();
        assert_eq!(q.table, [255, 255, 128, 128, 255, 255, 128, 128]);
        assert_eq!((q.periods_per_cycle, q.freq_hz), (2, 5.0));
    }

    #[test]
    fn a_frequency_the_steps_cannot_carry_is_refused_naming_those_that_fit() {
        // 200 Hz on the 5 Hz, 82-step cycle: 2.05 steps a period.
        let e = am(AmShape::Sine, 200.0, 1.0)
            .lm_table(82, 200_000)
            .unwrap_err()
            .to_string();
        assert!(!e.contains('\n'), "{e}");
        assert!(e.contains("200 Hz") && e.contains("82 steps"), "{e}");
        assert!(e.contains("from 5 to 100 Hz (nearest: 100 Hz)"), "{e}");
        // 12.5 Hz: 2.5 periods a cycle, the loop would jump.
        let e = am(AmShape::Square, 12.5, 1.0)
            .lm_table(82, 200_000)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("whole number") && e.contains("nearest: 10 or 15 Hz"),
            "{e}"
        );
        // Three steps cannot carry any period.
        let e = am(AmShape::Sine, 5.0, 1.0)
            .lm_table(3, 200_000)
            .unwrap_err();
        assert!(e.to_string().contains("none does"), "{e}");
        // A multiple of a whole-µs cycle's frequency fits as exactly as the
        // cycle: 7 Hz is 142857 µs, 70 Hz is 10 periods of it.
        let t = am(AmShape::Sine, 70.0, 0.5).lm_table(140, 142_857).unwrap();
        assert_eq!(t.periods_per_cycle, 10);
        assert!((t.freq_hz - 70.0).abs() < 1e-3, "{}", t.freq_hz);
        assert!(
            am(AmShape::Sine, 70.01, 0.5)
                .lm_table(140, 142_857)
                .is_err()
        );
    }

    #[test]
    fn mean_square_and_the_am_harmonic_match_their_closed_forms() {
        // e = (1 + cos)/2 at depth 1: mean e² = 3/8, its cos term 1/2.
        let s = am(AmShape::Sine, 100.0, 1.0);
        assert!((s.mean_square() - 0.375).abs() < 1e-9);
        assert!((s.square_first_harmonic() - 0.5).abs() < 1e-9);
        // A square at depth 1: e² is a square 0/1, mean 1/2, fundamental 2/π.
        let q = am(AmShape::Square, 100.0, 1.0);
        assert!((q.mean_square() - 0.5).abs() < 1e-9);
        assert!((q.square_first_harmonic() - 2.0 / std::f64::consts::PI).abs() < 0.02);
        // No depth, no modulation.
        let z = am(AmShape::Sine, 100.0, 0.0);
        assert_eq!(
            (z.mean_square(), z.square_first_harmonic() < 1e-12),
            (1.0, true)
        );
    }

    #[test]
    fn out_of_range_modulations_are_one_line_errors() {
        for (a, says) in [
            (am(AmShape::Sine, 0.1, 1.0), "frequency"),
            (am(AmShape::Sine, 300.0, 1.0), "frequency"),
            (am(AmShape::Sine, f64::NAN, 1.0), "finite"),
            (am(AmShape::Square, 100.0, 1.5), "depth"),
            (am(AmShape::Square, 100.0, -0.1), "depth"),
        ] {
            let e = a.check().unwrap_err().to_string();
            assert!(e.contains(says) && !e.contains('\n'), "{e}");
        }
    }
}
