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

use serde::Deserialize;
use toml::Spanned;

use super::Factor;
use super::check::Errors;
use super::file::{Label, Name};
use crate::error::InputError;
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

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ReportFile {
    alpha: Option<Spanned<f64>>,
    #[serde(default)]
    repeats: RepeatsFile,
    friedman: Option<Spanned<Vec<Name>>>,
    #[serde(default)]
    pairs: Vec<PairsFile>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
enum RepeatsFile {
    #[default]
    Mean,
    Median,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PairsFile {
    factor: Spanned<Name>,
    pairs: Option<Spanned<Vec<(Label, Label)>>>,
}

/// The report's tests for `factors`; `None`: the defaults.
pub(super) fn check(
    r: Option<ReportFile>,
    factors: &[Factor],
    e: &Errors,
) -> Result<ReportSpec, InputError> {
    let wide = |f: &Factor| f.levels.len() >= 3;
    let Some(r) = r else {
        return Ok(ReportSpec {
            alpha: 0.05,
            repeats: Repeats::Mean,
            pairs: Vec::new(),
            friedman: factors
                .iter()
                .filter(|f| wide(f))
                .map(|f| f.name.clone())
                .collect(),
        });
    };
    let alpha = match &r.alpha {
        Some(a) if !(*a.get_ref() > 0.0 && *a.get_ref() < 1.0) => {
            return Err(e.at(
                a.span(),
                "alpha",
                format!(
                    "{} is not a significance level: give a number between 0 and 1",
                    crate::limits::show(*a.get_ref())
                ),
            ));
        }
        Some(a) => *a.get_ref(),
        None => 0.05,
    };
    let factor = |n: &str, span: std::ops::Range<usize>, field: &str| {
        factors.iter().find(|f| f.name == n).ok_or_else(|| {
            e.at(
                span,
                field,
                format!(
                    "`{n}` is not a factor (the factors: {})",
                    factors
                        .iter()
                        .map(|f| f.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        })
    };
    let mut friedman = Vec::new();
    match &r.friedman {
        Some(list) => {
            for n in list.get_ref() {
                let f = factor(&n.0, list.span(), "friedman")?;
                if !wide(f) {
                    return Err(e.at(
                        list.span(),
                        "friedman",
                        format!(
                            "factor `{}` has {} levels; a Friedman test compares at least 3",
                            f.name,
                            f.levels.len()
                        ),
                    ));
                }
                friedman.push(f.name.clone());
            }
        }
        None => friedman.extend(factors.iter().filter(|f| wide(f)).map(|f| f.name.clone())),
    }
    let mut pairs = Vec::new();
    for p in &r.pairs {
        let f = factor(&p.factor.get_ref().0, p.factor.span(), "factor")?;
        let list = match &p.pairs {
            None => crate::lab::stats::table::all_pairs(
                &f.levels.iter().map(String::as_str).collect::<Vec<_>>(),
            ),
            Some(given) => {
                let mut v = Vec::new();
                for (a, b) in given.get_ref() {
                    for l in [&a.0, &b.0] {
                        if !f.levels.contains(l) {
                            return Err(e.at(
                                given.span(),
                                "pairs",
                                format!(
                                    "`{}` is not a level of factor `{}` ({})",
                                    l.escape_debug(),
                                    f.name,
                                    f.levels.join(", ")
                                ),
                            ));
                        }
                    }
                    if a.0 == b.0 {
                        return Err(e.at(
                            given.span(),
                            "pairs",
                            format!("`{}` is paired with itself", a.0),
                        ));
                    }
                    v.push((a.0.clone(), b.0.clone()));
                }
                v
            }
        };
        if list.is_empty() {
            return Err(e.at(
                p.factor.span(),
                "factor",
                format!("factor `{}` has one level: nothing to pair", f.name),
            ));
        }
        pairs.push(PairSpec {
            factor: f.name.clone(),
            pairs: list,
        });
    }
    Ok(ReportSpec {
        alpha,
        repeats: match r.repeats {
            RepeatsFile::Mean => Repeats::Mean,
            RepeatsFile::Median => Repeats::Median,
        },
        pairs,
        friedman,
    })
}
