//! An amplitude modulation on the cycle maps.
//!
//! The envelope `e(t)` scales every transducer's drive, so the sound
//! pressure goes with `e` and the radiation pressure with `e²`. The maps
//! are of one LM cycle at full output; with AM (its period unrelated to
//! the LM steps, as on the devices, which run the two on separate clocks)
//! the time-averaged radiation pressure is the cycle mean times the mean
//! of `e²`, the power at the LM frequency scales with that mean squared,
//! step 0 and the maximum stay at the envelope's peak (`e = 1`), and a new
//! component appears at the AM frequency: the cycle mean times the
//! amplitude of `e²`'s first harmonic, whose power (mean square) is
//! [`AmMaps::power_pa2`].

use crate::field::FieldMaps;
use crate::plan::modulation::Am;

/// Force series samples per second for [`force_spectrum`].
pub const SPECTRUM_RATE_HZ: f64 = 4000.0;

/// What an AM adds to the maps.
#[derive(Debug, Clone, PartialEq)]
pub struct AmMaps {
    /// The modulation, its frequency as the device realises it.
    pub am: Am,
    /// Mean of `e²`: the factor on the time-averaged radiation pressure.
    pub mean_square: f64,
    /// Amplitude of `e²`'s component at the AM frequency.
    pub harmonic: f64,
    /// Power of the radiation pressure at the AM frequency (Pa²): the mean
    /// square of its sinusoid, `(mean · harmonic)² / 2` per point.
    pub power_pa2: Vec<f64>,
}

/// Applies `am` to `maps` (mean pressure and LM power scaled) and returns
/// the AM power map, computed from the unmodulated cycle mean.
pub fn apply(maps: &mut FieldMaps, am: &Am) -> AmMaps {
    let mean_square = am.mean_square();
    let harmonic = am.square_first_harmonic();
    let power_pa2 = maps
        .mean_pressure_pa
        .iter()
        .map(|&m| (m * harmonic).powi(2) / 2.0)
        .collect();
    maps.mean_pressure_pa
        .iter_mut()
        .for_each(|v| *v *= mean_square);
    maps.lm_power_pa2
        .iter_mut()
        .for_each(|v| *v *= mean_square * mean_square);
    AmMaps {
        am: *am,
        mean_square,
        harmonic,
        power_pa2,
    }
}

impl AmMaps {
    /// The summary's `am` object: the modulation as asked and as played,
    /// the factors, the AM power's peak and the force spectrum's peak.
    pub fn summary_json(&self, mean_force_n: f64) -> serde_json::Value {
        let spectrum = force_spectrum(mean_force_n, &self.am);
        serde_json::json!({
            "shape": self.am.shape.name(),
            "freq_hz": self.am.freq_hz,
            "realised_freq_hz": self.am.realised_freq_hz(),
            "depth": self.am.depth,
            "mean_square_envelope": self.mean_square,
            "envelope_square_harmonic": self.harmonic,
            "am_power_peak_pa2": crate::field::peak(&self.power_pa2).map(|p| p.1),
            "force_spectrum_peak_hz": spectrum_peak_hz(&spectrum),
            "force_at_am_n_rms": spectrum.get(self.am.realised_freq_hz().round() as usize).map(|p| p.sqrt()),
        })
    }
}

/// The one-sided power spectrum (N², by 1 Hz bins from 0) of the force
/// `mean_force_n · e(t)²` over one second sampled at
/// [`SPECTRUM_RATE_HZ`]: the force a gauge sees from the modulation. Its
/// largest non-DC bin is the AM frequency the device plays, rounded.
pub fn force_spectrum(mean_force_n: f64, am: &Am) -> Vec<f64> {
    let n = SPECTRUM_RATE_HZ as usize;
    let x: Vec<f64> = (0..n)
        .map(|k| mean_force_n * am.envelope(k as f64 / SPECTRUM_RATE_HZ).powi(2))
        .collect();
    // Up to 500 Hz (twice the highest AM): a plain DFT of 4000 × 501.
    (0..=500)
        .map(|f| {
            let (mut re, mut im) = (0.0, 0.0);
            for (k, v) in x.iter().enumerate() {
                let (s, c) = (2.0 * std::f64::consts::PI * (f * k) as f64 / n as f64).sin_cos();
                re += v * c;
                im -= v * s;
            }
            let a = re.hypot(im) / n as f64;
            if f == 0 { a * a } else { 2.0 * a * a }
        })
        .collect()
}

/// The frequency (Hz) of the largest non-DC bin of a [`force_spectrum`].
pub fn spectrum_peak_hz(spectrum: &[f64]) -> Option<f64> {
    spectrum
        .iter()
        .enumerate()
        .skip(1)
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map(|(f, _)| f as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::modulation::AmShape;

    fn maps() -> FieldMaps {
        FieldMaps {
            nu: 2,
            nv: 1,
            steps: 4,
            amplitude_pa: vec![1.0, 2.0],
            pressure_pa: vec![10.0, 20.0],
            mean_pressure_pa: vec![8.0, 16.0],
            max_pressure_pa: vec![12.0, 24.0],
            lm_power_pa2: vec![4.0, 1.0],
        }
    }

    #[test]
    fn a_full_sine_keeps_three_eighths_of_the_mean_and_adds_its_power() {
        let am = Am {
            shape: AmShape::Sine,
            freq_hz: 200.0,
            depth: 1.0,
        };
        let mut m = maps();
        let a = apply(&mut m, &am);
        assert!((m.mean_pressure_pa[1] - 16.0 * 0.375).abs() < 1e-9);
        assert!((m.lm_power_pa2[0] - 4.0 * 0.375 * 0.375).abs() < 1e-9);
        assert_eq!((m.pressure_pa[0], m.max_pressure_pa[1]), (10.0, 24.0));
        // e² = 3/8 + cos/2 + cos(2·)/8: the AM term's amplitude is 8 × 1/2.
        assert!(
            (a.power_pa2[0] - 16.0 / 2.0).abs() < 1e-9,
            "{:?}",
            a.power_pa2
        );
        let none = apply(&mut maps(), &Am { depth: 0.0, ..am });
        assert!(none.power_pa2.iter().all(|&p| p < 1e-20));
    }

    #[test]
    fn the_force_spectrum_peaks_at_the_frequency_the_device_plays() {
        for (shape, f, want) in [
            (AmShape::Sine, 200.0, 200.0),
            (AmShape::Square, 50.0, 50.0),
            // 4000 / 27 samples = 148.1 Hz, the nearest bin 148.
            (AmShape::Square, 150.0, 148.0),
        ] {
            let am = Am {
                shape,
                freq_hz: f,
                depth: 0.8,
            };
            let s = force_spectrum(0.01, &am);
            assert_eq!(spectrum_peak_hz(&s), Some(want), "{shape:?} {f}");
            // DC is the mean force × mean e², where a second holds whole
            // periods (148.1 Hz leaves a part period over).
            let dc = 0.01 * am.mean_square();
            if want == f {
                assert!((s[0].sqrt() - dc).abs() < 1e-6 * dc, "{} {dc}", s[0].sqrt());
            }
        }
    }
}
