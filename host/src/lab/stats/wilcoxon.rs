//! Wilcoxon's signed-rank test of paired samples, two-sided, as
//! `scipy.stats.wilcoxon(x, y)` with its defaults: `zero_method='wilcox'`,
//! `correction=False` (no continuity correction: scipy's default),
//! `method='auto'`.
//!
//! - Differences d = x − y; pairs with a missing value are left out, then
//!   zero differences are dropped (Wilcoxon's own rule); the rest are
//!   ranked by |d| with average ranks for ties.
//! - R+ and R− are the rank sums of the positive and negative differences;
//!   the statistic is min(R+, R−).
//! - The p-value follows scipy's `method='auto'` (scipy 1.17,
//!   `_wilcoxon.py`): more than 50 pairs → the normal approximation; else
//!   no ties and no zeros → the exact distribution; else ≤ 13 pairs →
//!   every sign assignment enumerated (scipy's permutation test); else
//!   the normal approximation. "Pairs" counts the zeros too.
//! - Exact and permutation p = min(1, 2 min(P(R+ ≤ r), P(R+ ≥ r))), from
//!   the exact count of sign assignments, on doubled ranks so that tied
//!   (half-integer) ranks stay integers.
//! - Normal: z = (R+ − n(n+1)/4) / σ, σ² = (n(n+1)(2n+1) − Σ(t³ − t)/2) / 24
//!   over the non-zero n and the tie groups t, and p = 2 (1 − Φ(|z|)).
//!
//! Effect sizes: r = z / √n with that z (signed: positive when x tends to
//! be larger; tie-corrected, no continuity correction) and the non-zero
//! n, whatever method gave p; and the matched-pairs rank-biserial
//! correlation (R+ − R−) / (R+ + R−) (Kerby 2014).

use serde::Serialize;

use super::special::norm_sf;
use super::{Method, StatsError, average_ranks, present_pairs};

/// Most pairs for the exact distribution (scipy's `method='auto'`).
pub const EXACT_MAX: usize = 50;
/// Most pairs for the permutation distribution when there are ties or
/// zeros (scipy's `method='auto'`: 2^13 sign assignments).
pub const PERMUTATION_MAX: usize = 13;

/// A Wilcoxon signed-rank test of x against y.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Wilcoxon {
    /// min(R+, R−), scipy's two-sided statistic.
    pub statistic: f64,
    /// The two-sided p-value.
    pub p: f64,
    /// How p was computed.
    pub method: Method,
    /// Pairs used (zero differences included).
    pub n: usize,
    /// Pairs with a non-zero difference: the test's own n.
    pub n_nonzero: usize,
    /// Pairs left out for a missing value.
    pub excluded: usize,
    /// Rank sum of the positive differences (x > y).
    pub r_plus: f64,
    /// Rank sum of the negative differences.
    pub r_minus: f64,
    /// The normal approximation's z (tie-corrected, no continuity
    /// correction), signed like R+ − R−.
    pub z: f64,
    /// Effect size r = z / √n_nonzero.
    pub r: f64,
    /// Matched-pairs rank-biserial correlation (R+ − R−) / (R+ + R−).
    pub rank_biserial: f64,
}

/// Wilcoxon's signed-rank test of `x` against `y` (paired by index).
pub fn wilcoxon(x: &[f64], y: &[f64]) -> Result<Wilcoxon, StatsError> {
    let pairs = present_pairs(x, y)?;
    let n = pairs.len();
    let excluded = x.len() - n;
    StatsError::at_least("Wilcoxon", "pairs", 1, n)?;
    let d: Vec<f64> = pairs
        .iter()
        .map(|(a, b)| a - b)
        .filter(|d| *d != 0.0)
        .collect();
    let nz = d.len();
    if nz == 0 {
        return Err(StatsError::NoNonZeroDifference);
    }
    let zeros = n - nz;
    let abs: Vec<f64> = d.iter().map(|v| v.abs()).collect();
    let (ranks, ties) = average_ranks(&abs);
    let has_ties = ties.iter().any(|&t| t > 1);
    // Twice the ranks: integers even for tied (half-integer) ranks.
    let doubled: Vec<u32> = ranks.iter().map(|r| (2.0 * r) as u32).collect();
    let r_plus2: u32 = d
        .iter()
        .zip(&doubled)
        .filter(|(v, _)| **v > 0.0)
        .map(|(_, r)| r)
        .sum();
    let r_plus = f64::from(r_plus2) / 2.0;
    let nzf = nz as f64;
    let total = nzf * (nzf + 1.0) / 2.0;
    let r_minus = total - r_plus;

    let mean = nzf * (nzf + 1.0) * 0.25;
    let tie_sum: f64 = ties.iter().map(|&t| (t as f64).powi(3) - t as f64).sum();
    let se = ((nzf * (nzf + 1.0) * (2.0 * nzf + 1.0) - tie_sum / 2.0) / 24.0).sqrt();
    let z = (r_plus - mean) / se;

    let method = if n > EXACT_MAX {
        Method::Normal
    } else if !has_ties && zeros == 0 {
        Method::Exact
    } else if n <= PERMUTATION_MAX {
        Method::Permutation
    } else {
        Method::Normal
    };
    let p = match method {
        Method::Normal => 2.0 * norm_sf(z.abs()),
        _ => exact_p(&doubled, r_plus2),
    };
    Ok(Wilcoxon {
        statistic: r_plus.min(r_minus),
        p,
        method,
        n,
        n_nonzero: nz,
        excluded,
        r_plus,
        r_minus,
        z,
        r: z / nzf.sqrt(),
        rank_biserial: (r_plus - r_minus) / total,
    })
}

/// Two-sided p of the observed doubled R+ over all 2^n sign assignments
/// of the doubled ranks: min(1, 2 min(P(S ≤ obs), P(S ≥ obs))). Zero
/// differences would only double every count, so they are not needed.
/// n ≤ 50 keeps every count below 2^50, exact in u64 and in f64.
fn exact_p(doubled: &[u32], observed: u32) -> f64 {
    let max: usize = doubled.iter().map(|&r| r as usize).sum();
    let mut counts = vec![0u64; max + 1];
    counts[0] = 1;
    let mut reach = 0;
    for &r in doubled {
        let r = r as usize;
        // Each difference adds its rank to S or not; descending so that
        // each is used once.
        for s in (0..=reach).rev() {
            if counts[s] != 0 {
                counts[s + r] += counts[s];
            }
        }
        reach += r;
    }
    let all = (doubled.len() as f64).exp2();
    let obs = observed as usize;
    let below: u64 = counts[..=obs].iter().sum();
    let above: u64 = counts[obs..].iter().sum();
    (2.0 * below.min(above) as f64 / all).min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_positive_differences_give_the_smallest_exact_p() {
        // R+ = 15 of 15 for n = 5: p = 2 / 2^5.
        let r = wilcoxon(&[2.0, 3.0, 4.0, 5.0, 6.0], &[1.0, 1.1, 1.2, 1.3, 1.4]).unwrap();
        assert_eq!(r.method, Method::Exact);
        assert_eq!((r.r_plus, r.r_minus, r.statistic), (15.0, 0.0, 0.0));
        assert_eq!(r.p, 2.0 / 32.0);
        assert_eq!(r.rank_biserial, 1.0);
        assert!(r.z > 0.0 && r.r > 0.0);
        // Swapping the samples turns the signs and keeps p.
        let s = wilcoxon(&[1.0, 1.1, 1.2, 1.3, 1.4], &[2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        assert_eq!(s.p, r.p);
        assert_eq!(s.rank_biserial, -1.0);
        assert_eq!(s.z, -r.z);
    }

    #[test]
    fn exact_counts_match_enumeration() {
        // Doubled ranks with a tie (1.5, 1.5, 3 → 3, 3, 6): 8 assignments,
        // sums 0,3,3,6,6,9,9,12. P(S ≤ 3) = 3/8, P(S ≥ 3) = 7/8.
        assert_eq!(exact_p(&[3, 3, 6], 3), 0.75);
        assert_eq!(exact_p(&[3, 3, 6], 0), 0.25);
        assert_eq!(exact_p(&[3, 3, 6], 6), 1.0);
    }

    #[test]
    fn method_follows_scipys_auto_rule() {
        let ramp = |n: usize, f: fn(usize) -> f64| -> (Vec<f64>, Vec<f64>) {
            (
                (0..n).map(|i| i as f64 + f(i)).collect(),
                vec![0.0; n]
                    .into_iter()
                    .enumerate()
                    .map(|(i, _)| i as f64)
                    .collect(),
            )
        };
        // Distinct non-zero differences.
        let (x, y) = ramp(50, |i| 0.5 + i as f64 * 0.01);
        assert_eq!(wilcoxon(&x, &y).unwrap().method, Method::Exact);
        let (x, y) = ramp(51, |i| 0.5 + i as f64 * 0.01);
        assert_eq!(wilcoxon(&x, &y).unwrap().method, Method::Normal);
        // A zero among them.
        let (x, y) = ramp(13, |i| if i == 0 { 0.0 } else { 0.5 + i as f64 * 0.01 });
        assert_eq!(wilcoxon(&x, &y).unwrap().method, Method::Permutation);
        let (x, y) = ramp(14, |i| if i == 0 { 0.0 } else { 0.5 + i as f64 * 0.01 });
        assert_eq!(wilcoxon(&x, &y).unwrap().method, Method::Normal);
    }

    #[test]
    fn no_test_without_non_zero_differences() {
        assert_eq!(
            wilcoxon(&[1.0, 2.0], &[1.0, 2.0]),
            Err(StatsError::NoNonZeroDifference)
        );
        assert!(matches!(
            wilcoxon(&[f64::NAN], &[1.0]),
            Err(StatsError::TooFew { what: "pairs", .. })
        ));
    }
}
