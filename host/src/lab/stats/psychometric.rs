//! The psychometric function family the adaptive procedures model and the
//! simulated observer answers from: `p(x) = guess + (1 - guess - lapse)
//! F(x)`, with `F` a logistic or a Weibull core. One definition, so QUEST+'s
//! likelihoods and the observer whose threshold it estimates agree.

/// The shape of the psychometric function's core `F(x)` (0 → 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// `1 / (1 + exp(-slope (x - threshold)))`.
    Logistic,
    /// `1 - exp(-(x / threshold)^slope)`, for levels above 0.
    Weibull,
}

impl Shape {
    /// Every shape.
    pub const ALL: [Shape; 2] = [Self::Logistic, Self::Weibull];

    /// Its name in a protocol or `--observer`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Logistic => "logistic",
            Self::Weibull => "weibull",
        }
    }

    /// `F(x)` for `threshold` and `slope`.
    pub fn core(self, x: f64, threshold: f64, slope: f64) -> f64 {
        match self {
            Self::Logistic => 1.0 / (1.0 + (-slope * (x - threshold)).exp()),
            Self::Weibull if x <= 0.0 => 0.0,
            Self::Weibull => 1.0 - (-(x / threshold).powf(slope)).exp(),
        }
    }
}

/// `p(x) = guess + (1 - guess - lapse) F(x)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Psychometric {
    /// The core's shape.
    pub shape: Shape,
    /// Where `F` is ½ (logistic) or 1 - 1/e (Weibull), in level units.
    pub threshold: f64,
    /// Steepness (per level unit for the logistic; the exponent for Weibull).
    pub slope: f64,
    /// Probability of "perceived" far below threshold.
    pub guess: f64,
    /// Probability of a wrong answer far above threshold.
    pub lapse: f64,
}

impl Psychometric {
    /// The probability of "perceived" at level `x`.
    pub fn p(&self, x: f64) -> f64 {
        let f = self.shape.core(x, self.threshold, self.slope);
        self.guess + (1.0 - self.guess - self.lapse) * f
    }

    /// The level where [`Self::p`] is `p` (`None` outside its range).
    pub fn level_at(&self, p: f64) -> Option<f64> {
        let f = (p - self.guess) / (1.0 - self.guess - self.lapse);
        if !(f > 0.0 && f < 1.0) {
            return None;
        }
        Some(match self.shape {
            Shape::Logistic => self.threshold + (f / (1.0 - f)).ln() / self.slope,
            Shape::Weibull => self.threshold * (-(1.0 - f).ln()).powf(1.0 / self.slope),
        })
    }
}
