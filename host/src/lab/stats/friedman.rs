//! Friedman's test of k ≥ 3 related samples (conditions measured on the
//! same participants), as `scipy.stats.friedmanchisquare`.
//!
//! Each block (participant) ranks its k values, ties sharing the average
//! rank; with R_j the rank sum of condition j over n blocks,
//!
//! χ²_F = (12 / (n k (k+1)) Σ R_j² − 3 n (k+1)) / C,
//! C = 1 − Σ (t³ − t) / (n k (k² − 1)) over every block's tie groups t,
//!
//! and p = P(χ²_{k−1} > χ²_F). Kendall's W = χ²_F / (n (k − 1)) is the
//! effect size (0: no agreement among participants, 1: all rank the
//! conditions alike).

use serde::Serialize;

use super::special::chi2_sf;
use super::{Method, StatsError, average_ranks};

/// A Friedman test.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Friedman {
    /// χ²_F, tie-corrected.
    pub statistic: f64,
    /// P(χ²_{k−1} > statistic).
    pub p: f64,
    /// Conditions (k).
    pub k: usize,
    /// Complete blocks used.
    pub n: usize,
    /// Blocks left out for a missing value.
    pub excluded: usize,
    /// Kendall's coefficient of concordance W = χ²_F / (n (k − 1)).
    pub kendall_w: f64,
    /// Always [`Method::ChiSquare`].
    pub method: Method,
}

/// Friedman's test: `samples[j][i]` is condition j in block i. A block
/// with any missing (NaN) value is left out.
pub fn friedman(samples: &[&[f64]]) -> Result<Friedman, StatsError> {
    let k = samples.len();
    StatsError::at_least("Friedman", "conditions", 3, k)?;
    let blocks = samples[0].len();
    for s in samples {
        if s.len() != blocks {
            return Err(StatsError::LengthMismatch {
                left: blocks,
                right: s.len(),
            });
        }
        if s.iter().any(|v| v.is_infinite()) {
            return Err(StatsError::NotFinite);
        }
    }
    let complete: Vec<usize> = (0..blocks)
        .filter(|&i| samples.iter().all(|s| !s[i].is_nan()))
        .collect();
    let n = complete.len();
    StatsError::at_least("Friedman", "complete blocks", 1, n)?;
    let mut rank_sums = vec![0.0; k];
    let mut ties = 0.0;
    let mut row = vec![0.0; k];
    for &i in &complete {
        for (j, s) in samples.iter().enumerate() {
            row[j] = s[i];
        }
        let (ranks, groups) = average_ranks(&row);
        for (sum, r) in rank_sums.iter_mut().zip(&ranks) {
            *sum += r;
        }
        ties += groups
            .iter()
            .map(|&t| {
                let t = t as f64;
                t * (t * t - 1.0)
            })
            .sum::<f64>();
    }
    let (kf, nf) = (k as f64, n as f64);
    let c = 1.0 - ties / (kf * (kf * kf - 1.0) * nf);
    if c <= 0.0 {
        return Err(StatsError::EveryBlockTied);
    }
    let ssbn: f64 = rank_sums.iter().map(|r| r * r).sum();
    let statistic = (12.0 / (kf * nf * (kf + 1.0)) * ssbn - 3.0 * nf * (kf + 1.0)) / c;
    Ok(Friedman {
        statistic,
        p: chi2_sf(statistic, kf - 1.0),
        k,
        n,
        excluded: blocks - n,
        kendall_w: statistic / (nf * (kf - 1.0)),
        method: Method::ChiSquare,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perfect_agreement_gives_w_one() {
        // Every block ranks a < b < c: R = (n, 2n, 3n), χ² = 2n, W = 1.
        let a = [1.0, 2.0, 3.0, 4.0];
        let b = [2.0, 3.0, 4.0, 5.0];
        let c = [3.0, 4.0, 5.0, 6.0];
        let r = friedman(&[&a, &b, &c]).unwrap();
        assert!((r.statistic - 8.0).abs() < 1e-12);
        assert!((r.kendall_w - 1.0).abs() < 1e-12);
        assert!((r.p - (-4.0f64).exp()).abs() < 1e-15, "χ²₂ sf(8) = e^-4");
    }

    #[test]
    fn missing_values_drop_their_block() {
        let a = [1.0, f64::NAN, 3.0, 1.0];
        let b = [2.0, 2.0, 1.0, 3.0];
        let c = [3.0, 1.0, 2.0, 2.0];
        let r = friedman(&[&a, &b, &c]).unwrap();
        assert_eq!((r.n, r.excluded), (3, 1));
    }

    #[test]
    fn refusals_say_why() {
        let a = [1.0, 2.0];
        assert!(matches!(
            friedman(&[&a, &a]),
            Err(StatsError::TooFew {
                what: "conditions",
                ..
            })
        ));
        assert_eq!(friedman(&[&a, &a, &a]), Err(StatsError::EveryBlockTied));
        assert!(matches!(
            friedman(&[&a, &a, &[1.0]]),
            Err(StatsError::LengthMismatch { .. })
        ));
    }
}
