//! Transducer directivity: how the emitted amplitude falls off with the
//! angle θ from the transducer's normal.
//!
//! [`Directivity::T4010A1`] is AUTD3's published model of the Nippon Ceramic
//! T4010A1 (the transducer on every AUTD3 board): a piecewise cubic over
//! 0..90° in 10° segments whose knot values (the `A` column) are the spec
//! sheet's directivity, 0 dB down to −14 dB at 80°. The coefficients are the
//! ones AUTD3's `T4010A1` directivity uses (autd3 `acoustics/directivity`),
//! so a field simulated here matches AUTD3's own simulator in front of the
//! array. Behind the transducer face (θ > 90°) the gain is **zero**: a
//! transducer mounted on its board radiates nothing backwards, so a point
//! behind the array is never reached (AUTD3's table folds there instead,
//! which would make a focus behind the array look real). The gain steps
//! from −15 dB to 0 at exactly 90°.

use serde::{Deserialize, Serialize};

/// Value at the start of each 10° segment (0°, 10°, …, 80°).
#[allow(clippy::excessive_precision, clippy::unreadable_literal)]
const DIR_COEF_A: [f64; 9] = [
    1.0,
    1.0,
    1.0,
    0.891250938,
    0.707945784,
    0.501187234,
    0.354813389,
    0.251188643,
    0.199526231,
];
/// Linear coefficient per segment (per degree).
#[allow(clippy::excessive_precision, clippy::unreadable_literal)]
const DIR_COEF_B: [f64; 9] = [
    0.,
    0.,
    -0.00459648054721,
    -0.0155520765675,
    -0.0208114779827,
    -0.0182211227016,
    -0.0122437497109,
    -0.00780345575475,
    -0.00312857467007,
];
/// Quadratic coefficient per segment (per degree²).
#[allow(clippy::excessive_precision, clippy::unreadable_literal)]
const DIR_COEF_C: [f64; 9] = [
    0.,
    0.,
    -0.000787968093807,
    -0.000307591508224,
    -0.000218348633296,
    0.00047738416141,
    0.000120353137658,
    0.000323676257958,
    0.000143850511,
];
/// Cubic coefficient per segment (per degree³).
#[allow(clippy::excessive_precision, clippy::unreadable_literal)]
const DIR_COEF_D: [f64; 9] = [
    0.,
    0.,
    1.60125528528e-05,
    2.9747624976e-06,
    2.31910931569e-05,
    -1.1901034125e-05,
    6.77743734332e-06,
    -5.99548024824e-06,
    -4.79372835035e-06,
];

/// Directivity model of a transducer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Directivity {
    /// Omnidirectional point source: gain 1 at every angle.
    Omni,
    /// T4010A1 spec-sheet directivity, AUTD3's piecewise cubic table.
    #[default]
    T4010A1,
}

impl Directivity {
    /// Amplitude gain (1 on axis) at angle `theta_rad` from the normal.
    ///
    /// Any finite angle is accepted (the model is symmetric about the
    /// normal, so θ and −θ, or 360° − θ, are the same direction); beyond
    /// 90°, behind the face, the gain is 0. A NaN angle yields NaN.
    pub fn gain(&self, theta_rad: f64) -> f64 {
        match self {
            Directivity::Omni => 1.0,
            Directivity::T4010A1 => t4010a1_gain_deg(theta_rad.to_degrees()),
        }
    }

    /// Gain for a source at the origin with unit `normal` seen from offset
    /// `d` (any length > 0). A zero offset (observer on the source) has no
    /// direction; it gets the on-axis gain so the caller's 1/r decides.
    pub fn gain_towards(&self, normal: [f64; 3], d: [f64; 3]) -> f64 {
        match self {
            Directivity::Omni => 1.0,
            Directivity::T4010A1 => {
                let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                if len == 0.0 {
                    return 1.0;
                }
                let c = (normal[0] * d[0] + normal[1] * d[1] + normal[2] * d[2]) / len;
                self.gain(c.clamp(-1.0, 1.0).acos())
            }
        }
    }
}

fn t4010a1_gain_deg(theta_deg: f64) -> f64 {
    let t = theta_deg.abs() % 360.0;
    let t = if t > 180.0 { 360.0 - t } else { t };
    if t.is_nan() {
        return f64::NAN;
    }
    if t > 90.0 {
        return 0.0;
    }
    let i = (t / 10.0).ceil() as usize;
    if i == 0 {
        return 1.0;
    }
    // 0 < t ≤ 90, so 1 ≤ i ≤ 9.
    let i = i.min(DIR_COEF_A.len());
    let x = t - (i as f64 - 1.0) * 10.0;
    ((DIR_COEF_D[i - 1] * x + DIR_COEF_C[i - 1]) * x + DIR_COEF_B[i - 1]) * x + DIR_COEF_A[i - 1]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t4010a1_matches_the_spec_sheet_knots() {
        // Knots of the table, and AUTD3's value at 90° (−15 dB).
        let want = [
            1.0, 1.0, 1.0, 0.891251, 0.707946, 0.501187, 0.354813, 0.251189, 0.199526, 0.177831,
        ];
        for (i, w) in want.iter().enumerate() {
            let g = Directivity::T4010A1.gain((10.0 * i as f64).to_radians());
            assert!((g - w).abs() < 1e-5, "{}°: {g} vs {w}", 10 * i);
        }
    }

    #[test]
    fn t4010a1_is_continuous_and_monotone_and_zero_behind_the_face() {
        let d = Directivity::T4010A1;
        let mut prev = d.gain(0.0);
        for i in 1..=9000 {
            let g = d.gain((i as f64 * 0.01).to_radians());
            assert!(g <= prev + 1e-12, "rises at {}°", i as f64 * 0.01);
            assert!((prev - g).abs() < 1e-3, "jump at {}°", i as f64 * 0.01);
            prev = g;
        }
        for deg in [5.0, 33.0, 71.5] {
            let a = d.gain(f64::to_radians(deg));
            assert_eq!(a, d.gain(f64::to_radians(-deg)));
            assert_eq!(d.gain(f64::to_radians(180.0 - deg)), 0.0);
            assert_eq!(a, d.gain(f64::to_radians(360.0 - deg)));
        }
        assert!(d.gain(f64::to_radians(90.0)) > 0.17);
        assert_eq!(d.gain(f64::to_radians(90.001)), 0.0);
        assert_eq!(d.gain(std::f64::consts::PI), 0.0);
        // Seen from behind the face: nothing.
        assert_eq!(d.gain_towards([0.0, 0.0, 1.0], [0.0, 0.0, -5.0]), 0.0);
        assert_eq!(d.gain_towards([0.0, 0.0, 1.0], [3.0, 0.0, -1.0]), 0.0);
    }

    #[test]
    fn omni_is_one_and_default_is_t4010a1() {
        assert_eq!(Directivity::Omni.gain(1.2), 1.0);
        assert_eq!(Directivity::default(), Directivity::T4010A1);
        assert!(Directivity::T4010A1.gain(f64::NAN).is_nan());
    }

    #[test]
    fn gain_towards_uses_the_angle_from_the_normal() {
        let d = Directivity::T4010A1;
        let n = [0.0, 0.0, 1.0];
        assert_eq!(d.gain_towards(n, [0.0, 0.0, 5.0]), 1.0);
        let g = d.gain_towards(n, [1.0, 0.0, 1.0]);
        assert!((g - d.gain(std::f64::consts::FRAC_PI_4)).abs() < 1e-12);
        assert_eq!(d.gain_towards(n, [0.0; 3]), 1.0);
    }

    #[test]
    fn serde_names_are_lowercase() {
        let s = serde_json::to_string(&Directivity::T4010A1).unwrap();
        assert_eq!(s, "\"t4010a1\"");
        let d: Directivity = serde_json::from_str("\"omni\"").unwrap();
        assert_eq!(d, Directivity::Omni);
    }
}
