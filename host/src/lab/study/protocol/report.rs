//! The protocol's `[report]` table: what `study report` tests. Pairs are
//! named by a factor whose levels are compared within each level of the
//! other factors (the paper's "between the LM types at each radius"), a
//! family each, Bonferroni-corrected within it; Friedman tests run over
//! the factors named (default: every factor of 3 levels or more).
//!
//! ```toml
//! [report]
//! alpha = 0.05          # the power's significance level
//! repeats = "mean"      # a participant's sets of one condition: mean or median
//! friedman = ["type", "radius"]
//! [[report.pairs]]
//! factor = "type"
//! pairs = [["lms-5hz", "lmm-5hz"]]   # default: every pair of its levels
//! ```

use crate::lab::stats::table::Repeats;

/// What `study report` tests.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportSpec {
    /// The power's significance level.
    pub alpha: f64,
    /// How a participant's repeated answers to a condition combine.
    pub repeats: Repeats,
    /// Wilcoxon pairs: a factor's levels, compared within each level of
    /// the others.
    pub pairs: Vec<PairSpec>,
    /// Factors whose levels a Friedman test compares within each level of
    /// the others.
    pub friedman: Vec<String>,
}

/// One factor's pairs.
#[derive(Debug, Clone, PartialEq)]
pub struct PairSpec {
    /// The factor.
    pub factor: String,
    /// Pairs of its levels (a, b), d = a − b.
    pub pairs: Vec<(String, String)>,
}
