//! Judging a filter on a track with known truth: lag and jitter.
//!
//! The filter runs twice in lockstep, on the noisy samples and on the same
//! track without noise, which splits its error into two parts:
//! - **lag**: the time shift τ that best aligns the noise-free output with
//!   the truth, argmin over τ of mean |out(t) − truth(t − τ)|²;
//! - **jitter**: RMS of noisy output − noise-free output (mm, 3-D), the
//!   tracker noise the filter lets through.
//!
//! **Error** is what a user feels: RMS of the noisy output against where the
//! finger is now (mm). Frames within [`WARM_UP_FRAMES`] of the finger
//! arriving are skipped, so every filter is judged in its steady state.

use super::filter::FilterKind;
use super::synthetic::FingerTrack;

/// Frames after (re)acquisition that are not scored.
pub const WARM_UP_FRAMES: usize = 30;

/// A filter's score on a synthetic track.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FilterScore {
    /// Which filter.
    pub filter: FilterKind,
    /// Best-aligning delay (ms); negative means the output leads.
    pub lag_ms: f64,
    /// RMS of the noise passed through (mm).
    pub jitter_mm: f64,
    /// RMS distance from the true current position (mm).
    pub error_mm: f64,
}

/// Run `kind` over `seconds` of `track` and score it.
pub fn score(kind: FilterKind, track: &FingerTrack, seconds: f64) -> FilterScore {
    let clean_track = FingerTrack {
        noise_mm: [0.0; 3],
        ..*track
    };
    let (mut noisy_f, mut clean_f) = (kind.build(), kind.build());
    // (t, noisy output, clean output)
    let mut out = Vec::new();
    let mut since_arrival = 0usize;
    let both = track.samples().zip(clean_track.samples());
    for (s, c) in both.take_while(|(s, _)| s.t_s < seconds) {
        match (noisy_f.update(&s), clean_f.update(&c)) {
            (Some(p), Some(q)) => {
                since_arrival += 1;
                if since_arrival > WARM_UP_FRAMES {
                    out.push((s.t_s, p, q));
                }
            }
            _ => since_arrival = 0,
        }
    }
    let n = out.len().max(1) as f64;
    let dist2 = |a: &[f64; 3], b: &[f64; 3]| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>();
    let mse = |tau_s: f64| {
        out.iter()
            .map(|(t, _, q)| dist2(q, &track.truth(t - tau_s)))
            .sum::<f64>()
            / n
    };
    // Coarse 2 ms grid over −50…+200 ms, then refine to 0.05 ms within
    // ±1 ms of its best; each τ's error computed once.
    let best = |taus: &mut dyn Iterator<Item = f64>| {
        taus.map(|t| (t, mse(t)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(t, _)| t)
    };
    let coarse = best(&mut (-25..=100).map(|i| f64::from(i) * 2e-3)).unwrap_or(0.0);
    let lag_s = best(&mut (-20..=20).map(|i| coarse + f64::from(i) * 5e-5)).unwrap_or(coarse);
    let jitter = (out.iter().map(|(_, p, q)| dist2(p, q)).sum::<f64>() / n).sqrt();
    let error = (out
        .iter()
        .map(|(t, p, _)| dist2(p, &track.truth(*t)))
        .sum::<f64>()
        / n)
        .sqrt();
    FilterScore {
        filter: kind,
        lag_ms: lag_s * 1e3,
        jitter_mm: jitter,
        error_mm: error,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_lag_is_four_and_a_half_frames() {
        let s = score(FilterKind::Gaussian, &FingerTrack::default(), 20.0);
        assert!((s.lag_ms - 50.0).abs() < 3.0, "{s:?}");
    }

    #[test]
    fn raw_has_no_lag_and_full_noise() {
        let s = score(FilterKind::None, &FingerTrack::default(), 20.0);
        assert!(s.lag_ms.abs() < 2.0, "{s:?}");
        // √(0.3² + 0.3² + 0.8²) ≈ 0.906 mm.
        assert!((s.jitter_mm - 0.906).abs() < 0.06, "{s:?}");
    }

    /// The target: the low-lag filter lags at most a third of the
    /// Gaussian at equal or lower jitter.
    #[test]
    fn kalman_beats_gaussian() {
        let track = FingerTrack {
            away_s: Some((10.0, 11.0)),
            ..Default::default()
        };
        let g = score(FilterKind::Gaussian, &track, 30.0);
        let k = score(FilterKind::Kalman, &track, 30.0);
        assert!(k.error_mm < g.error_mm, "{k:?} vs {g:?}");
        assert!(k.lag_ms.abs() <= g.lag_ms / 3.0, "{k:?} vs {g:?}");
        assert!(k.jitter_mm <= g.jitter_mm, "{k:?} vs {g:?}");
    }
}
