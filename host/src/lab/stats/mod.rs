//! The paper's statistics, as pure functions: plain slices in, a result
//! struct out, no I/O. They reproduce `scipy.stats` (the version pinned in
//! `cargo xtask python`) to a relative error of 1e-6 or better, checked by
//! `host/tests/stats_scipy.rs` against a fixture that scipy writes
//! (`host/tests/stats/scipy_reference.py`).
//!
//! | function | test | scipy |
//! |---|---|---|
//! | [`shapiro_wilk`] | Shapiro-Wilk W and p (Royston's AS R94), 3 ≤ n ≤ 5000 | `shapiro` |
//! | [`wilcoxon()`] | Wilcoxon signed-rank, two-sided; effect sizes r and the rank-biserial | `wilcoxon` (defaults) |
//! | [`friedman()`] | Friedman chi-square over k ≥ 3 conditions, tie-corrected; Kendall's W | `friedmanchisquare` |
//! | [`paired_t`], [`paired_t_power`] | Cohen's d_z and the power of the two-sided paired t-test | statsmodels `TTestPower().power` |
//! | [`bonferroni`] | p × m, at most 1 | |
//!
//! The paper (Experiments 1-3, "Results and Analysis") runs Shapiro-Wilk
//! per condition, Wilcoxon between named pairs with Bonferroni correction,
//! the power of the paired t-test on the same pairs, and Friedman tests
//! over each factor with Bonferroni correction; its figures mark p < 0.05,
//! 0.005, 0.0005 with [`stars`] and power > 0.8, 0.98, 0.998 with
//! [`power_marks`].
//!
//! **Missing values.** A value that is NaN is missing (a "not perceived"
//! answer) and is left out: by value in [`shapiro_wilk`], by pair in
//! [`wilcoxon()`] and [`paired_t`], by block (participant) in [`friedman()`].
//! Each result says how many values it used (`n`) and how many it left out
//! (`excluded`). An infinite value is refused ([`StatsError::NotFinite`]).
//!
//! **No test.** Where scipy answers NaN or warns that its answer means
//! nothing (every difference zero, every block tied, a range below AS
//! R94's 1e-19), these functions return a [`StatsError`] that says why;
//! the caller prints "no test" rather than a number. One difference from
//! scipy: with every difference zero, scipy's Wilcoxon answers p = 1 for
//! n ≤ 13 (its permutation test) and NaN above; here it is always
//! [`StatsError::NoNonZeroDifference`], since the test has no pairs left.
//!
//! **A study's table.** [`table::analyse`] turns rows of (participant,
//! condition, value) into the paper's tests for the pairs and condition
//! groups a caller names, with per-family Bonferroni correction: the
//! entry point for the study report. Its results serialize with serde
//! (for a JSON file) and carry the marks for the figures.
//!
//! The special functions (normal, chi-square, Student t, non-central t)
//! are in [`special`], on `statrs`' erfc, log-gamma and incomplete beta
//! and gamma functions, and are checked against scipy in the same test.

pub mod friedman;
pub mod paired;
pub mod psychometric;
pub mod quest;
pub mod shapiro;
pub mod special;
pub mod table;
pub mod wilcoxon;

pub use friedman::{Friedman, friedman};
pub use paired::{PairedT, paired_t, paired_t_power};
pub use shapiro::{ShapiroWilk, shapiro_wilk};
pub use wilcoxon::{Wilcoxon, wilcoxon};

use serde::Serialize;

/// How a p-value was computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// The exact null distribution (Wilcoxon with no ties and no zeros,
    /// n ≤ 50).
    Exact,
    /// Every assignment of signs to the differences, enumerated: exact
    /// given the tied ranks and zeros (Wilcoxon with ties or zeros,
    /// n ≤ 13; scipy's permutation test, which enumerates all 2^n).
    Permutation,
    /// The normal approximation (Wilcoxon, tie-corrected, without a
    /// continuity correction as in scipy's default).
    Normal,
    /// The chi-square approximation (Friedman).
    ChiSquare,
    /// Royston's approximation (Shapiro-Wilk; exact for n = 3).
    Royston,
}

impl Method {
    /// The name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            Method::Exact => "exact",
            Method::Permutation => "permutation",
            Method::Normal => "normal",
            Method::ChiSquare => "chi-square",
            Method::Royston => "royston",
        }
    }
}

/// Why a test gave no result.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StatsError {
    /// Too few values left after the missing ones were left out.
    #[error("{test} needs at least {needed} {what}, has {got}")]
    TooFew {
        /// The test.
        test: &'static str,
        /// What is counted ("values", "pairs", "blocks", "conditions").
        what: &'static str,
        /// The least it needs.
        needed: usize,
        /// What it has.
        got: usize,
    },
    /// More values than the method is defined for.
    #[error("{test} takes at most {max} values, has {got}")]
    TooMany {
        /// The test.
        test: &'static str,
        /// The most it takes.
        max: usize,
        /// What it has.
        got: usize,
    },
    /// Paired samples of different lengths.
    #[error("paired samples of different lengths ({left} and {right})")]
    LengthMismatch {
        /// The first sample's length.
        left: usize,
        /// The second's.
        right: usize,
    },
    /// An infinite value.
    #[error("a value is infinite")]
    NotFinite,
    /// Shapiro-Wilk on values that are all (nearly) the same.
    #[error("the values' range is below 1e-19 (all the same)")]
    ZeroRange,
    /// Wilcoxon with no non-zero difference left.
    #[error("every difference is zero")]
    NoNonZeroDifference,
    /// Friedman where every block ranks its conditions all tied.
    #[error("every participant gave every condition the same value")]
    EveryBlockTied,
    /// d_z (and so the power) with differences that do not vary.
    #[error("the differences do not vary (d_z is undefined)")]
    NoVariation,
    /// A significance level outside (0, 1).
    #[error("alpha {0} is not between 0 and 1")]
    Alpha(f64),
    /// A value beyond what the numerical method covers.
    #[error("{0}")]
    OutOfRange(&'static str),
}

impl StatsError {
    /// [`StatsError::TooFew`] unless `test` has at least `needed` of
    /// `what` (it has `got`).
    pub(crate) fn at_least(
        test: &'static str,
        what: &'static str,
        needed: usize,
        got: usize,
    ) -> Result<(), StatsError> {
        if got < needed {
            return Err(StatsError::TooFew {
                test,
                what,
                needed,
                got,
            });
        }
        Ok(())
    }
}

/// Bonferroni's correction of one of `m` p-values: p × m, at most 1.
/// NaN stays NaN; `m` = 0 is taken as 1.
pub fn bonferroni(p: f64, m: usize) -> f64 {
    if p.is_nan() {
        // `f64::min` would turn NaN into 1.
        return p;
    }
    (p * m.max(1) as f64).min(1.0)
}

/// The paper's significance marks: "***" for p < 0.0005, "**" for
/// p < 0.005, "*" for p < 0.05, "" otherwise (NaN included).
pub fn stars(p: f64) -> &'static str {
    if p < 0.0005 {
        "***"
    } else if p < 0.005 {
        "**"
    } else if p < 0.05 {
        "*"
    } else {
        ""
    }
}

/// The paper's power marks: "+++" for power > 0.998, "++" for > 0.98,
/// "+" for > 0.8, "" otherwise (NaN included).
pub fn power_marks(power: f64) -> &'static str {
    if power > 0.998 {
        "+++"
    } else if power > 0.98 {
        "++"
    } else if power > 0.8 {
        "+"
    } else {
        ""
    }
}

/// Average ranks (1-based) of `v`, and the sizes of its groups of ties
/// (one entry per distinct value, in ascending order). Values compare
/// exactly, as scipy's `rankdata` does; `v` holds no NaN.
pub(crate) fn average_ranks(v: &[f64]) -> (Vec<f64>, Vec<usize>) {
    let mut order: Vec<usize> = (0..v.len()).collect();
    order.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let mut ranks = vec![0.0; v.len()];
    let mut ties = Vec::new();
    let mut start = 0;
    while start < order.len() {
        let mut end = start + 1;
        // `==`, not `total_cmp`: -0.0 and 0.0 are one value, as in numpy.
        while end < order.len() && v[order[end]] == v[order[start]] {
            end += 1;
        }
        // Ranks start..end (0-based) share (start+1 + end) / 2.
        let rank = (start + 1 + end) as f64 / 2.0;
        for &i in &order[start..end] {
            ranks[i] = rank;
        }
        ties.push(end - start);
        start = end;
    }
    (ranks, ties)
}

/// The values of `x` that are not NaN, or an error for an infinite one.
pub(crate) fn present(x: &[f64]) -> Result<Vec<f64>, StatsError> {
    if x.iter().any(|v| v.is_infinite()) {
        return Err(StatsError::NotFinite);
    }
    Ok(x.iter().copied().filter(|v| !v.is_nan()).collect())
}

/// The pairs of `x` and `y` where neither value is NaN.
pub(crate) fn present_pairs(x: &[f64], y: &[f64]) -> Result<Vec<(f64, f64)>, StatsError> {
    if x.len() != y.len() {
        return Err(StatsError::LengthMismatch {
            left: x.len(),
            right: y.len(),
        });
    }
    if x.iter().chain(y).any(|v| v.is_infinite()) {
        return Err(StatsError::NotFinite);
    }
    Ok(x.iter()
        .zip(y)
        .filter(|(a, b)| !a.is_nan() && !b.is_nan())
        .map(|(&a, &b)| (a, b))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bonferroni_multiplies_and_caps_at_one() {
        assert_eq!(bonferroni(0.25, 3), 0.75);
        assert_eq!(bonferroni(0.4, 3), 1.0);
        assert_eq!(bonferroni(0.2, 0), 0.2);
        assert!(bonferroni(f64::NAN, 3).is_nan());
    }

    #[test]
    fn marks_follow_the_papers_thresholds() {
        let p = [0.0004, 0.0005, 0.004, 0.049, 0.05, f64::NAN];
        let stars_of = ["***", "**", "**", "*", "", ""];
        let power = [0.9981, 0.998, 0.981, 0.81, 0.8, f64::NAN];
        let plus_of = ["+++", "++", "++", "+", "", ""];
        for i in 0..p.len() {
            assert_eq!(stars(p[i]), stars_of[i], "p = {}", p[i]);
            assert_eq!(power_marks(power[i]), plus_of[i], "power = {}", power[i]);
        }
    }

    #[test]
    fn average_ranks_share_ties() {
        let (r, t) = average_ranks(&[3.0, 2.0, 1.0, 2.0, 2.0, 2.0, 1.0]);
        assert_eq!(r, vec![7.0, 4.5, 1.5, 4.5, 4.5, 4.5, 1.5]);
        assert_eq!(t, vec![2, 4, 1]);
        let (r, t) = average_ranks(&[-0.0, 0.0, 1.0]);
        assert_eq!(r, vec![1.5, 1.5, 3.0]);
        assert_eq!(t, vec![2, 1]);
    }

    #[test]
    fn missing_values_are_left_out_and_infinite_ones_refused() {
        assert_eq!(present(&[1.0, f64::NAN, 2.0]).unwrap(), vec![1.0, 2.0]);
        assert_eq!(present(&[1.0, f64::INFINITY]), Err(StatsError::NotFinite));
        let pairs = present_pairs(&[1.0, f64::NAN, 3.0], &[4.0, 5.0, f64::NAN]).unwrap();
        assert_eq!(pairs, vec![(1.0, 4.0)]);
        assert!(matches!(
            present_pairs(&[1.0], &[]),
            Err(StatsError::LengthMismatch { left: 1, right: 0 })
        ));
    }
}
