//! Centroid filters: the paper's 10-frame Gaussian and two low-lag ones.
//!
//! All filters are causal, run per axis, take the sample's own time stamp
//! (so dropped frames are handled) and forget everything when the finger
//! leaves (`present == false`): a finger that comes back starts fresh rather
//! than being dragged from where the last one left.

use std::collections::VecDeque;
use std::str::FromStr;

use super::Sample;

/// Longest gap between samples (s) the velocity-based filters (Kalman,
/// one-euro) predict across; a longer gap, or a time stamp going
/// backwards, restarts them from the new measurement.
pub const MAX_COAST_S: f64 = 1.0;

/// Which filter to run, as chosen on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FilterKind {
    /// No smoothing: raw tracker centroids.
    None,
    /// The paper's Gaussian over the last 10 frames (lag ≈ 4.5 frames).
    Gaussian,
    /// Constant-velocity Kalman filter, unbiased on ramps (the default).
    Kalman,
    /// The one-euro filter (speed-adaptive low-pass).
    OneEuro,
}

impl FilterKind {
    /// Every filter, for reports that compare them.
    pub const ALL: [FilterKind; 4] = [Self::None, Self::Gaussian, Self::Kalman, Self::OneEuro];

    /// A fresh filter of this kind with its default tuning.
    pub fn build(self) -> Box<dyn Filter + Send> {
        match self {
            Self::None => Box::new(Passthrough),
            Self::Gaussian => Box::new(Gaussian::paper()),
            Self::Kalman => Box::new(Kalman::default()),
            Self::OneEuro => Box::new(OneEuro::default()),
        }
    }

    /// What it does, in a line (the CLI's help).
    pub fn describe(self) -> &'static str {
        match self {
            Self::None => "No smoothing: raw tracker centroids",
            Self::Gaussian => "The paper's Gaussian over the last 10 frames (lag ≈ 4.5 frames)",
            Self::Kalman => "Constant-velocity Kalman filter, unbiased on ramps (the default)",
            Self::OneEuro => "The one-euro filter (speed-adaptive low-pass)",
        }
    }

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Gaussian => "gaussian",
            Self::Kalman => "kalman",
            Self::OneEuro => "one-euro",
        }
    }
}

impl FromStr for FilterKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        crate::error::choose_any_case("a filter", s, &Self::ALL.map(|k| (k.name(), k)))
    }
}

impl std::fmt::Display for FilterKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A causal centroid filter.
pub trait Filter {
    /// Feed one sample; returns the filtered centroid, or `None` while no
    /// finger is present.
    fn update(&mut self, s: &Sample) -> Option<[f64; 3]>;
}

/// Hands samples through unchanged.
#[derive(Debug, Default)]
pub struct Passthrough;

impl Filter for Passthrough {
    fn update(&mut self, s: &Sample) -> Option<[f64; 3]> {
        s.present.then_some(s.pos_mm)
    }
}

/// Gaussian-weighted mean of the last `N` frames (the paper: 10 frames).
///
/// The window is symmetric about its middle, so on a finger moving at
/// constant speed the output lags by (N − 1)/2 frames.
#[derive(Debug, Clone)]
pub struct Gaussian {
    /// Weight by age (0 = newest), normalised over the full window.
    weights: Vec<f64>,
    window: VecDeque<[f64; 3]>,
}

impl Gaussian {
    /// A Gaussian window over `frames` frames with standard deviation
    /// `sigma_frames`.
    pub fn new(frames: usize, sigma_frames: f64) -> Self {
        let frames = frames.max(1);
        let mid = (frames as f64 - 1.0) / 2.0;
        let weights = (0..frames)
            .map(|age| (-(age as f64 - mid).powi(2) / (2.0 * sigma_frames * sigma_frames)).exp())
            .collect();
        Self {
            weights,
            window: VecDeque::with_capacity(frames),
        }
    }

    /// The paper's filter: 10 frames. The paper gives no σ; 2 frames keeps
    /// the window's ends at ≈ 8 % weight, so all 10 frames count.
    pub fn paper() -> Self {
        Self::new(10, 2.0)
    }
}

impl Filter for Gaussian {
    fn update(&mut self, s: &Sample) -> Option<[f64; 3]> {
        if !s.present {
            self.window.clear();
            return None;
        }
        if self.window.len() == self.weights.len() {
            self.window.pop_back();
        }
        self.window.push_front(s.pos_mm);
        let mut acc = [0.0; 3];
        let mut norm = 0.0;
        for (p, w) in self.window.iter().zip(&self.weights) {
            for (a, x) in acc.iter_mut().zip(p) {
                *a += w * x;
            }
            norm += w;
        }
        Some(acc.map(|a| a / norm))
    }
}

/// Constant-velocity Kalman filter per axis, with optional prediction ahead.
///
/// A white-acceleration model: unbiased on a finger moving at constant speed,
/// so its lag is set only by how fast the finger changes speed.
#[derive(Debug, Clone)]
pub struct Kalman {
    /// Process noise: white-acceleration spectral density (mm²/s³).
    pub accel_psd: f64,
    /// Measurement noise variance per axis (mm²).
    pub meas_var_mm2: [f64; 3],
    /// How far ahead of the last sample to predict (s); use the link latency.
    pub lead_s: f64,
    state: Option<KalmanState>,
}

#[derive(Debug, Clone, Copy)]
struct KalmanState {
    t_s: f64,
    /// Per axis: position, velocity, and covariance [p_pp, p_pv, p_vv].
    x: [[f64; 2]; 3],
    p: [[f64; 3]; 3],
}

impl Default for Kalman {
    fn default() -> Self {
        Self {
            accel_psd: 100.0,
            meas_var_mm2: [0.09, 0.09, 0.64],
            lead_s: 0.0,
            state: None,
        }
    }
}

impl Kalman {
    /// The default tuning, predicting `lead_s` ahead of the last sample.
    pub fn with_lead(lead_s: f64) -> Self {
        Self {
            lead_s,
            ..Self::default()
        }
    }
}

impl Filter for Kalman {
    fn update(&mut self, s: &Sample) -> Option<[f64; 3]> {
        if !s.present {
            self.state = None;
            return None;
        }
        let Some(st) = self.state.as_mut() else {
            let p = self.meas_var_mm2.map(|r| [r, 0.0, 1.0e4]);
            self.state = Some(KalmanState {
                t_s: s.t_s,
                x: s.pos_mm.map(|z| [z, 0.0]),
                p,
            });
            return Some(s.pos_mm);
        };
        // A time stamp that goes backwards, or a gap longer than
        // MAX_COAST_S, says nothing about velocity: start fresh from the
        // measurement instead of predicting across it (a −1e300 s stamp must
        // never become a huge correction). A repeated stamp gets a tiny step.
        let dt = s.t_s - st.t_s;
        if !(dt.is_finite() && (0.0..=MAX_COAST_S).contains(&dt)) {
            self.state = None;
            return self.update(s);
        }
        let dt = dt.max(1e-6);
        st.t_s = s.t_s;
        let q = self.accel_psd;
        for axis in 0..3 {
            let [x, v] = st.x[axis];
            let [pp, pv, vv] = st.p[axis];
            // Predict.
            let x = x + v * dt;
            let pp = pp + 2.0 * dt * pv + dt * dt * vv + q * dt.powi(3) / 3.0;
            let pv = pv + dt * vv + q * dt * dt / 2.0;
            let vv = vv + q * dt;
            // Update with the measured position.
            let r = self.meas_var_mm2[axis];
            let sk = pp + r;
            let (kx, kv) = (pp / sk, pv / sk);
            let innov = s.pos_mm[axis] - x;
            st.x[axis] = [x + kx * innov, v + kv * innov];
            st.p[axis] = [(1.0 - kx) * pp, (1.0 - kx) * pv, vv - kv * pv];
        }
        Some(std::array::from_fn(|a| {
            st.x[a][0] + st.x[a][1] * self.lead_s
        }))
    }
}

/// The one-euro filter (Casiez et al. 2012): a low-pass whose cut-off rises
/// with speed, so it smooths a still finger hard and follows a moving one.
#[derive(Debug, Clone)]
pub struct OneEuro {
    /// Cut-off at rest (Hz).
    pub min_cutoff_hz: f64,
    /// Cut-off increase per mm/s of speed.
    pub beta: f64,
    /// Cut-off of the speed estimate (Hz).
    pub d_cutoff_hz: f64,
    state: Option<(f64, [f64; 3], [f64; 3])>,
}

impl Default for OneEuro {
    fn default() -> Self {
        Self {
            min_cutoff_hz: 1.0,
            beta: 0.05,
            d_cutoff_hz: 1.0,
            state: None,
        }
    }
}

fn smoothing(dt: f64, cutoff_hz: f64) -> f64 {
    let tau = 1.0 / (2.0 * std::f64::consts::PI * cutoff_hz);
    1.0 / (1.0 + tau / dt)
}

impl Filter for OneEuro {
    fn update(&mut self, s: &Sample) -> Option<[f64; 3]> {
        if !s.present {
            self.state = None;
            return None;
        }
        let Some((t, x, dx)) = self.state.as_mut() else {
            self.state = Some((s.t_s, s.pos_mm, [0.0; 3]));
            return Some(s.pos_mm);
        };
        let dt = s.t_s - *t;
        if !(dt.is_finite() && (0.0..=MAX_COAST_S).contains(&dt)) {
            self.state = None;
            return self.update(s);
        }
        let dt = dt.max(1e-6);
        *t = s.t_s;
        let ad = smoothing(dt, self.d_cutoff_hz);
        for a in 0..3 {
            let raw_d = (s.pos_mm[a] - x[a]) / dt;
            dx[a] += ad * (raw_d - dx[a]);
            let cutoff = self.min_cutoff_hz + self.beta * dx[a].abs();
            x[a] += smoothing(dt, cutoff) * (s.pos_mm[a] - x[a]);
        }
        Some(*x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(n: usize, v_mm_s: f64) -> Vec<Sample> {
        (0..n)
            .map(|i| {
                let t_s = i as f64 / 90.0;
                Sample {
                    t_s,
                    pos_mm: [v_mm_s * t_s, 0.0, 200.0],
                    present: true,
                }
            })
            .collect()
    }

    /// The filter's output after the whole track.
    fn last_output(f: &mut impl Filter, track: &[Sample]) -> Option<[f64; 3]> {
        track.iter().fold(None, |_, s| f.update(s))
    }

    #[test]
    fn gaussian_lags_ramp_by_four_and_a_half_frames() {
        let track = ramp(50, 90.0);
        // 90 mm/s at 90 fps = 1 mm per frame, so the lag is 4.5 mm.
        let x = last_output(&mut Gaussian::paper(), &track).unwrap()[0];
        assert!((track[49].pos_mm[0] - x - 4.5).abs() < 1e-9, "{x}");
    }

    #[test]
    fn kalman_follows_ramp_without_lag() {
        let track = ramp(200, 90.0);
        let last = last_output(&mut Kalman::default(), &track).unwrap();
        assert!((track[199].pos_mm[0] - last[0]).abs() < 0.01);
    }

    #[test]
    fn leaving_resets_every_filter() {
        for kind in FilterKind::ALL {
            let mut f = kind.build();
            for s in ramp(20, 90.0) {
                f.update(&s);
            }
            let gone = Sample {
                t_s: 1.0,
                pos_mm: [0.0; 3],
                present: false,
            };
            assert_eq!(f.update(&gone), None, "{kind:?}");
            let back = Sample {
                t_s: 2.0,
                pos_mm: [7.0, 8.0, 9.0],
                present: true,
            };
            assert_eq!(f.update(&back), Some([7.0, 8.0, 9.0]), "{kind:?}");
        }
    }

    #[test]
    fn filter_names_parse() {
        for kind in FilterKind::ALL {
            assert_eq!(kind.name().parse::<FilterKind>().unwrap(), kind);
        }
        assert!("median".parse::<FilterKind>().is_err());
    }

    #[test]
    fn bad_time_stamps_restart_instead_of_correcting() {
        for kind in [FilterKind::Kalman, FilterKind::OneEuro] {
            let mut f = kind.build();
            for s in ramp(30, 90.0) {
                f.update(&s);
            }
            for t_s in [-1e300, 1e300, 0.1] {
                let s = Sample {
                    t_s,
                    pos_mm: [1.0, 2.0, 200.0],
                    present: true,
                };
                let out = f.update(&s).unwrap();
                assert_eq!(out, [1.0, 2.0, 200.0], "{kind:?} at t = {t_s}");
            }
        }
    }
}
