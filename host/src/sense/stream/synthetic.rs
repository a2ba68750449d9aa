//! A synthetic finger: smooth motion like a real fingertip resting on a
//! mid-air marker, sampled at 90 fps with depth-camera-like noise, and a
//! known ground truth to judge filters against.

use super::Sample;
use crate::error::InputError;
use crate::limits::show;
use crate::rng::SplitMix64;

/// Parameters of the synthetic finger.
#[derive(Debug, Clone, Copy)]
pub struct FingerTrack {
    /// Where the finger rests (mm), e.g. the stimulus centre.
    pub center_mm: [f64; 3],
    /// Frame rate (Hz); the paper's RealSense ran at 90 fps.
    pub rate_hz: f64,
    /// Noise per axis (mm, 1 σ): lateral centroids are averaged over the
    /// contact area, depth is noisier.
    pub noise_mm: [f64; 3],
    /// The finger is away during `[leave_s, return_s)`.
    pub away_s: Option<(f64, f64)>,
    /// Seed of the noise and of the motion's phases.
    pub seed: u64,
}

impl Default for FingerTrack {
    fn default() -> Self {
        Self {
            center_mm: [0.0, 0.0, 200.0],
            rate_hz: 90.0,
            noise_mm: [0.3, 0.3, 0.8],
            away_s: None,
            seed: 1,
        }
    }
}

/// Motion components per axis: (amplitude mm, frequency Hz). A resting
/// finger drifts a few millimetres and trembles a little; peaks near
/// 25 mm/s, like a finger settling on a target.
const MOTION: [[(f64, f64); 3]; 3] = [
    [(4.0, 0.31), (1.5, 0.87), (0.3, 2.3)],
    [(3.0, 0.23), (1.2, 0.71), (0.3, 2.9)],
    [(1.5, 0.17), (0.6, 0.53), (0.2, 1.9)],
];

impl FingerTrack {
    fn phases(&self) -> [[f64; 3]; 3] {
        let mut rng = SplitMix64::new(self.seed ^ 0xF1_9E12);
        std::array::from_fn(|_| std::array::from_fn(|_| rng.next_f64() * std::f64::consts::TAU))
    }

    /// The true centroid at time `t_s`.
    pub fn truth(&self, t_s: f64) -> [f64; 3] {
        let ph = self.phases();
        self.truth_with(&ph, t_s)
    }

    fn truth_with(&self, ph: &[[f64; 3]; 3], t_s: f64) -> [f64; 3] {
        std::array::from_fn(|a| {
            self.center_mm[a]
                + MOTION[a]
                    .iter()
                    .zip(&ph[a])
                    .map(|((amp, f), p)| amp * (std::f64::consts::TAU * f * t_s + p).sin())
                    .sum::<f64>()
        })
    }

    /// Whether the finger is present at `t_s`.
    pub fn present(&self, t_s: f64) -> bool {
        !matches!(self.away_s, Some((a, b)) if t_s >= a && t_s < b)
    }

    /// The index of the first frame at or after `t_s`, as `samples` times
    /// frame `i` (`i / rate_hz`, rounding included).
    fn first_frame_at(&self, t_s: f64) -> u64 {
        let mut i = (t_s * self.rate_hz).ceil().max(0.0) as u64;
        while i > 0 && (i - 1) as f64 / self.rate_hz >= t_s {
            i -= 1;
        }
        while (i as f64 / self.rate_hz) < t_s {
            i += 1;
        }
        i
    }

    /// Refuses an away window (`--away START,END`) that changes nothing
    /// in a stream of `seconds` (frames at `i / rate_hz` before it): one
    /// starting at or after the stream's end, or holding no frame; and one
    /// holding every frame, which streams no finger at all (a window
    /// larger than the run: `--away 0,100 --seconds 1`).
    pub fn check_away(&self, seconds: f64) -> Result<(), InputError> {
        let Some((a, b)) = self.away_s else {
            return Ok(());
        };
        let window = format!("--away {},{}", show(a), show(b));
        if a >= seconds {
            return Err(InputError::new(format!(
                "{window} starts at or after the stream's end (--seconds {}): give a START below {} s",
                show(seconds),
                show(seconds)
            )));
        }
        let i = self.first_frame_at(a);
        let t = i as f64 / self.rate_hz;
        if t >= b || t >= seconds {
            return Err(InputError::new(format!(
                "{window} holds no frame of the stream ({} frames a second, before --seconds {}): give a window holding at least one",
                show(self.rate_hz),
                show(seconds)
            )));
        }
        // The frames before `seconds`: `0..n`.
        let n = self.first_frame_at(seconds);
        let last = n.saturating_sub(1) as f64 / self.rate_hz;
        if i == 0 && b > last {
            return Err(InputError::new(format!(
                "{window} holds every frame of the stream (--seconds {}): the finger would never show; give a window that leaves it at least one frame",
                show(seconds)
            )));
        }
        Ok(())
    }

    /// An endless stream of noisy samples, frame by frame.
    pub fn samples(&self) -> impl Iterator<Item = Sample> + use<> {
        let track = *self;
        let ph = self.phases();
        let mut rng = SplitMix64::new(self.seed);
        (0u64..).map(move |i| {
            let t_s = i as f64 / track.rate_hz;
            let truth = track.truth_with(&ph, t_s);
            let pos_mm = std::array::from_fn(|a| truth[a] + track.noise_mm[a] * rng.normal());
            Sample {
                t_s,
                pos_mm,
                present: track.present(t_s),
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn track_is_reproducible_and_noisy() {
        let t = FingerTrack::default();
        let a: Vec<_> = t.samples().take(100).collect();
        let b: Vec<_> = t.samples().take(100).collect();
        assert_eq!(a, b);
        let rms: f64 = (a
            .iter()
            .map(|s| (s.pos_mm[0] - t.truth(s.t_s)[0]).powi(2))
            .sum::<f64>()
            / 100.0)
            .sqrt();
        assert!(rms > 0.2 && rms < 0.4, "{rms}");
    }

    #[test]
    fn an_away_window_that_changes_nothing_is_refused() {
        let away = |a, b| FingerTrack {
            away_s: Some((a, b)),
            ..Default::default()
        };
        assert!(away(0.5, 3.0).check_away(1.0).is_ok());
        assert!(away(0.0, 1.0 / 90.0).check_away(1.0).is_ok());
        assert!(away(89.0 / 90.0, 2.0).check_away(1.0).is_ok());
        let e = away(2.0, 3.0).check_away(1.0).unwrap_err().to_string();
        assert_eq!(
            e,
            "--away 2,3 starts at or after the stream's end (--seconds 1): give a START below 1 s"
        );
        assert!(away(1.0, 3.0).check_away(1.0).is_err());
        // Every frame away: no finger at all.
        for (a, b) in [(0.0, 100.0), (0.0, 1.0), (0.0, 89.5 / 90.0)] {
            let e = away(a, b).check_away(1.0).unwrap_err().to_string();
            assert!(e.contains("holds every frame of the stream"), "{e}");
        }
        assert!(away(0.0, 89.0 / 90.0).check_away(1.0).is_ok());
        for (a, b) in [(0.001, 0.002), (0.995, 2.0)] {
            let e = away(a, b).check_away(1.0).unwrap_err().to_string();
            assert!(
                e.contains("holds no frame of the stream (90 frames a second"),
                "{e}"
            );
        }
    }

    #[test]
    fn finger_leaves_and_returns() {
        let t = FingerTrack {
            away_s: Some((1.0, 1.5)),
            ..Default::default()
        };
        let s: Vec<_> = t.samples().take(180).collect();
        assert!(s[89].present && !s[90].present && !s[134].present && s[135].present);
    }
}
