//! The paired t-test's effect size and power, which the paper reports
//! beside each Wilcoxon test ("the parametric test corresponding to it").
//!
//! Cohen's d_z = mean(d) / sd(d) over the differences d = x − y (sd with
//! n − 1), so t = d_z √n. The power of the two-sided paired t-test at
//! level α for n pairs and effect d_z is that of statsmodels'
//! `TTestPower().power(d_z, n, α)`:
//!
//! power = P(T > c) + P(T < −c),  T ~ t'(ν = n − 1, δ = d_z √n),
//! c = t_{ν}⁻¹(1 − α/2),
//!
//! with t' the non-central t distribution ([`super::special::nct_sf`],
//! [`super::special::nct_cdf`]).
//! It is the chance that the test rejects at α if the true effect were
//! the observed one (a post-hoc power, as in the paper).

use serde::Serialize;

use super::special::{chi2_sf, nct_cdf, nct_sf, norm_sf, t_isf};
use super::{StatsError, present_pairs};

/// Cohen's d_z and the paired t-test's power for one pair of conditions.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairedT {
    /// Pairs used.
    pub n: usize,
    /// Pairs left out for a missing value.
    pub excluded: usize,
    /// Mean of the differences x − y.
    pub mean_diff: f64,
    /// Their standard deviation (n − 1).
    pub sd_diff: f64,
    /// Cohen's d_z = mean / sd.
    pub d_z: f64,
    /// The paired t statistic d_z √n.
    pub t: f64,
    /// The significance level the power is for.
    pub alpha: f64,
    /// Power of the two-sided paired t-test at `alpha` for effect `d_z`.
    pub power: f64,
}

/// d_z and power for `x` against `y` (pairs with a missing value left
/// out) at significance level `alpha`.
pub fn paired_t(x: &[f64], y: &[f64], alpha: f64) -> Result<PairedT, StatsError> {
    check_alpha(alpha)?;
    let pairs = present_pairs(x, y)?;
    let n = pairs.len();
    StatsError::at_least("the paired t-test", "pairs", 2, n)?;
    let d: Vec<f64> = pairs.iter().map(|(a, b)| a - b).collect();
    let nf = n as f64;
    let mean = d.iter().sum::<f64>() / nf;
    let var = d.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (nf - 1.0);
    let sd = var.sqrt();
    if sd.is_nan() || sd <= 0.0 {
        return Err(StatsError::NoVariation);
    }
    let d_z = mean / sd;
    Ok(PairedT {
        n,
        excluded: x.len() - n,
        mean_diff: mean,
        sd_diff: sd,
        d_z,
        t: d_z * nf.sqrt(),
        alpha,
        power: paired_t_power(d_z, n, alpha)?,
    })
}

fn check_alpha(alpha: f64) -> Result<(), StatsError> {
    if alpha > 0.0 && alpha < 1.0 {
        Ok(())
    } else {
        Err(StatsError::Alpha(alpha))
    }
}

/// Power of the two-sided paired (one-sample) t-test with `n` pairs at
/// level `alpha` when the standardized effect is `d_z` (see the module
/// docs for the formula).
pub fn paired_t_power(d_z: f64, n: usize, alpha: f64) -> Result<f64, StatsError> {
    check_alpha(alpha)?;
    StatsError::at_least("the paired t-test", "pairs", 2, n)?;
    if !d_z.is_finite() {
        return Err(StatsError::NotFinite);
    }
    let df = (n - 1) as f64;
    // The power is even in δ; the series is happiest with δ ≥ 0.
    let delta = d_z.abs() * (n as f64).sqrt();
    let c = t_isf(alpha / 2.0, df);
    // β = P(T ≤ c) ≤ P(Z ≤ −δ/2) + P(c S ≥ δ/2), S = √(χ²_ν/ν): when
    // that bound is below half an ulp of 1 the power is 1.0 in f64,
    // however large δ is (the series stops at |δ| ≈ 1414).
    let bound = norm_sf(delta / 2.0) + chi2_sf(df * (delta / (2.0 * c)).powi(2), df);
    if bound < 1e-17 {
        return Ok(1.0);
    }
    // Both tails directly (no 1 − F): the upper one's terms are all
    // positive for δ ≥ 0; the lower one is at most Φ(−δ)'s size.
    let upper = nct_sf(c, df, delta);
    let lower = nct_cdf(-c, df, delta);
    let power = upper + lower;
    if power.is_nan() {
        return Err(StatsError::OutOfRange(
            "the non-central t distribution is beyond its series for this effect and n",
        ));
    }
    Ok(power.min(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_effect_has_power_alpha() {
        for n in [2, 5, 30] {
            for alpha in [0.05, 0.01] {
                let p = paired_t_power(0.0, n, alpha).unwrap();
                assert!((p - alpha).abs() < 1e-12, "n {n} alpha {alpha}: {p}");
            }
        }
    }

    #[test]
    fn power_grows_with_effect_and_n_and_is_even() {
        let a = paired_t_power(0.3, 10, 0.05).unwrap();
        let b = paired_t_power(0.6, 10, 0.05).unwrap();
        let c = paired_t_power(0.6, 30, 0.05).unwrap();
        assert!(a < b && b < c, "{a} {b} {c}");
        assert_eq!(paired_t_power(-0.6, 10, 0.05).unwrap(), b);
        assert_eq!(paired_t_power(1e6, 10, 0.05).unwrap(), 1.0);
    }

    #[test]
    fn d_z_is_mean_over_sd() {
        let r = paired_t(&[3.0, 5.0, 4.0, f64::NAN], &[1.0, 2.0, 2.0, 0.0], 0.05).unwrap();
        // d = 2, 3, 2: mean 7/3, sd √(1/3).
        assert_eq!((r.n, r.excluded), (3, 1));
        assert!((r.d_z - (7.0 / 3.0) / (1.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((r.t - r.d_z * 3f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn refusals_say_why() {
        assert_eq!(
            paired_t(&[2.0, 3.0], &[1.0, 2.0], 0.05),
            Err(StatsError::NoVariation)
        );
        assert_eq!(
            paired_t(&[2.0, 3.0], &[1.0, 1.0], 1.0),
            Err(StatsError::Alpha(1.0))
        );
        assert!(paired_t_power(0.5, 1, 0.05).is_err());
    }
}
