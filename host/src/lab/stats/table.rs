//! From a study's answers to the paper's tests: rows of (participant,
//! condition, value) in, [`Analysis`] out. This is what the study report
//! calls; it decides nothing about files or layout.
//!
//! 1. **Cells.** A participant's answers for one condition (the paper's
//!    two sets) become one value by [`Repeats`] (mean or median of the
//!    answers present); a "not perceived" answer (`None`) is left out, and
//!    a cell with no answer left is missing.
//! 2. **Normality.** Shapiro-Wilk for every condition over the
//!    participants whose cell is present.
//! 3. **Pairs.** For each [`PairFamily`] (the paper's "between the LM
//!    types at each radius" is one family per radius), Wilcoxon for each
//!    named pair over the participants with both cells present, its p
//!    Bonferroni-corrected by the family's size m (the pairs named, tested
//!    or not: the correction does not shrink when a pair has no test), and
//!    Cohen's d_z with the paired t-test's power at `alpha` on the same
//!    pairs.
//! 4. **Friedman.** For each [`FriedmanFamily`] (the paper's "LM type"
//!    and "radius" factors), one test per group of conditions over the
//!    participants with every cell of the group present, Bonferroni by the
//!    family's number of groups.
//!
//! A test that cannot be run (too few participants, every difference
//! zero, …) is an [`Outcome::Skipped`] with the reason, never a number.
//! A table or design that cannot be analysed at all (a family naming a
//! condition no row has, an infinite value, α outside (0, 1)) is an
//! [`InputError`].
//!
//! ```
//! use lmhost::lab::stats::table::{analyse, Design, Observation, PairFamily, Repeats};
//! let rows: Vec<Observation> = (0..8)
//!     .flat_map(|p| {
//!         let who = format!("p{p}");
//!         [("a", 2.0 + p as f64 % 3.0), ("b", 4.0 + p as f64 % 2.0)]
//!             .map(|(c, v)| Observation::new(&who, c, Some(v)))
//!     })
//!     .collect();
//! let design = Design {
//!     alpha: 0.05,
//!     repeats: Repeats::Mean,
//!     pairs: vec![PairFamily::new("a vs b", [("a", "b")])],
//!     friedman: vec![],
//! };
//! let analysis = analyse(&rows, &design).unwrap();
//! let pair = &analysis.pairs[0];
//! assert_eq!(pair.n, 8);
//! assert_eq!(pair.stars, "*");
//! ```

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use super::{
    Friedman, PairedT, ShapiroWilk, StatsError, Wilcoxon, bonferroni, friedman, paired_t,
    power_marks, shapiro_wilk, stars, wilcoxon,
};
use crate::error::InputError;

/// One answer.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// Who answered (the participant id).
    pub participant: String,
    /// The condition's name, as the design names it.
    pub condition: String,
    /// The value; `None` for "not perceived" (left out).
    pub value: Option<f64>,
}

impl Observation {
    /// An answer.
    pub fn new(participant: &str, condition: &str, value: Option<f64>) -> Self {
        Observation {
            participant: participant.to_string(),
            condition: condition.to_string(),
            value,
        }
    }
}

/// How a participant's repeated answers to one condition become one value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Repeats {
    /// Their mean.
    Mean,
    /// Their median (the mean of the middle two for an even count).
    Median,
}

/// Pairs of conditions compared by Wilcoxon and corrected together.
#[derive(Debug, Clone, PartialEq)]
pub struct PairFamily {
    /// The family's name ("type at r=3").
    pub name: String,
    /// The pairs (a, b); d = a − b.
    pub pairs: Vec<(String, String)>,
}

impl PairFamily {
    /// A family from string pairs.
    pub fn new<'a>(name: &str, pairs: impl IntoIterator<Item = (&'a str, &'a str)>) -> Self {
        PairFamily {
            name: name.to_string(),
            pairs: pairs
                .into_iter()
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .collect(),
        }
    }
}

/// Groups of conditions, one Friedman test each, corrected together.
#[derive(Debug, Clone, PartialEq)]
pub struct FriedmanFamily {
    /// The family's name (the factor: "radius").
    pub name: String,
    /// Each group: the conditions one test compares (at least 3).
    pub groups: Vec<Vec<String>>,
}

/// What to test.
#[derive(Debug, Clone, PartialEq)]
pub struct Design {
    /// The significance level the power is computed for (the paper's
    /// figures: 0.05).
    pub alpha: f64,
    /// How repeated answers combine.
    pub repeats: Repeats,
    /// Wilcoxon families.
    pub pairs: Vec<PairFamily>,
    /// Friedman families.
    pub friedman: Vec<FriedmanFamily>,
}

/// A test's result, or why there is none.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome<T> {
    /// The result.
    Done(T),
    /// No test, and why (one line).
    Skipped(String),
}

impl<T> Outcome<T> {
    /// The result, if there is one.
    pub fn done(&self) -> Option<&T> {
        match self {
            Outcome::Done(t) => Some(t),
            Outcome::Skipped(_) => None,
        }
    }
}

impl<T> From<Result<T, StatsError>> for Outcome<T> {
    fn from(r: Result<T, StatsError>) -> Self {
        match r {
            Ok(t) => Outcome::Done(t),
            Err(e) => Outcome::Skipped(e.to_string()),
        }
    }
}

/// Shapiro-Wilk for one condition.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NormalityRow {
    /// The condition.
    pub condition: String,
    /// Participants with a value.
    pub n: usize,
    /// The test.
    pub shapiro_wilk: Outcome<ShapiroWilk>,
}

/// One named pair.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairRow {
    /// The family.
    pub family: String,
    /// First condition (d = a − b).
    pub a: String,
    /// Second condition.
    pub b: String,
    /// Participants with both values.
    pub n: usize,
    /// The family's size, the Bonferroni factor.
    pub m: usize,
    /// Wilcoxon's test.
    pub wilcoxon: Outcome<Wilcoxon>,
    /// Its p × m, at most 1.
    pub p_bonferroni: Option<f64>,
    /// The paper's marks for `p_bonferroni` ("", "*", "**", "***").
    pub stars: &'static str,
    /// d_z and the paired t-test's power at the design's alpha.
    pub paired_t: Outcome<PairedT>,
    /// The paper's marks for that power ("", "+", "++", "+++").
    pub power_marks: &'static str,
}

/// One Friedman test.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FriedmanRow {
    /// The family.
    pub family: String,
    /// The conditions compared.
    pub conditions: Vec<String>,
    /// Participants with every value.
    pub n: usize,
    /// The family's number of tests, the Bonferroni factor.
    pub m: usize,
    /// The test.
    pub friedman: Outcome<Friedman>,
    /// Its p × m, at most 1.
    pub p_bonferroni: Option<f64>,
    /// The paper's marks for `p_bonferroni`.
    pub stars: &'static str,
}

/// Every test of a design.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Analysis {
    /// Participants, sorted.
    pub participants: Vec<String>,
    /// How repeated answers were combined.
    pub repeats: Repeats,
    /// The power's significance level.
    pub alpha: f64,
    /// Shapiro-Wilk per condition, in order of first appearance.
    pub normality: Vec<NormalityRow>,
    /// The pairs, family by family.
    pub pairs: Vec<PairRow>,
    /// The Friedman tests, family by family.
    pub friedman: Vec<FriedmanRow>,
}

/// The cell values: one column per condition, one entry per participant
/// (NaN: missing).
struct Cells {
    participants: Vec<String>,
    conditions: Vec<String>,
    columns: BTreeMap<String, Vec<f64>>,
}

impl Cells {
    fn new(rows: &[Observation], repeats: Repeats) -> Result<Cells, InputError> {
        let participants: Vec<String> = rows
            .iter()
            .map(|r| r.participant.clone())
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect();
        let index: BTreeMap<&str, usize> = participants
            .iter()
            .enumerate()
            .map(|(i, p)| (p.as_str(), i))
            .collect();
        let mut conditions = Vec::new();
        let mut answers: BTreeMap<String, Vec<Vec<f64>>> = BTreeMap::new();
        for r in rows {
            if let Some(v) = r.value
                && !v.is_finite()
            {
                return Err(InputError::new(format!(
                    "participant {} condition {}: value {v} is not a finite number",
                    r.participant, r.condition
                )));
            }
            let column = answers.entry(r.condition.clone()).or_insert_with(|| {
                conditions.push(r.condition.clone());
                vec![Vec::new(); participants.len()]
            });
            if let Some(v) = r.value {
                column[index[r.participant.as_str()]].push(v);
            }
        }
        let columns = answers
            .into_iter()
            .map(|(c, cells)| {
                let values = cells.into_iter().map(|v| combine(v, repeats)).collect();
                (c, values)
            })
            .collect();
        Ok(Cells {
            participants,
            conditions,
            columns,
        })
    }

    fn column(&self, what: &str, family: &str, condition: &str) -> Result<&[f64], InputError> {
        self.columns
            .get(condition)
            .map(Vec::as_slice)
            .ok_or_else(|| {
                InputError::new(format!(
                    "{what} family `{family}` names condition `{condition}`, which no answer has"
                ))
            })
    }
}

fn combine(mut v: Vec<f64>, repeats: Repeats) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    match repeats {
        Repeats::Mean => v.iter().sum::<f64>() / v.len() as f64,
        Repeats::Median => {
            v.sort_by(f64::total_cmp);
            let m = v.len() / 2;
            if v.len() % 2 == 1 {
                v[m]
            } else {
                (v[m - 1] + v[m]) / 2.0
            }
        }
    }
}

fn present_in(columns: &[&[f64]]) -> usize {
    (0..columns[0].len())
        .filter(|&i| columns.iter().all(|c| !c[i].is_nan()))
        .count()
}

/// Runs the design's tests on the answers in `rows`.
pub fn analyse(rows: &[Observation], design: &Design) -> Result<Analysis, InputError> {
    if !(design.alpha > 0.0 && design.alpha < 1.0) {
        return Err(InputError::new(format!(
            "alpha {} is not between 0 and 1",
            design.alpha
        )));
    }
    let cells = Cells::new(rows, design.repeats)?;

    let normality = cells
        .conditions
        .iter()
        .map(|c| {
            let x = &cells.columns[c];
            NormalityRow {
                condition: c.clone(),
                n: present_in(&[x]),
                shapiro_wilk: shapiro_wilk(x).into(),
            }
        })
        .collect();

    let mut pairs = Vec::new();
    for family in &design.pairs {
        let m = family.pairs.len();
        for (a, b) in &family.pairs {
            if a == b {
                return Err(InputError::new(format!(
                    "pair family `{}` compares `{a}` with itself",
                    family.name
                )));
            }
            let x = cells.column("pair", &family.name, a)?;
            let y = cells.column("pair", &family.name, b)?;
            let w: Outcome<Wilcoxon> = wilcoxon(x, y).into();
            let p_bonferroni = w.done().map(|w| bonferroni(w.p, m));
            let t: Outcome<PairedT> = paired_t(x, y, design.alpha).into();
            pairs.push(PairRow {
                family: family.name.clone(),
                a: a.clone(),
                b: b.clone(),
                n: present_in(&[x, y]),
                m,
                stars: p_bonferroni.map_or("", stars),
                power_marks: t.done().map_or("", |t| power_marks(t.power)),
                wilcoxon: w,
                p_bonferroni,
                paired_t: t,
            });
        }
    }

    let mut friedman_rows = Vec::new();
    for family in &design.friedman {
        let m = family.groups.len();
        for group in &family.groups {
            if group.len() < 3 {
                return Err(InputError::new(format!(
                    "Friedman family `{}` has a group of {} conditions; a group needs at least 3",
                    family.name,
                    group.len()
                )));
            }
            let columns = group
                .iter()
                .map(|c| cells.column("Friedman", &family.name, c))
                .collect::<Result<Vec<_>, _>>()?;
            let f: Outcome<Friedman> = friedman(&columns).into();
            let p_bonferroni = f.done().map(|f| bonferroni(f.p, m));
            friedman_rows.push(FriedmanRow {
                family: family.name.clone(),
                conditions: group.clone(),
                n: present_in(&columns),
                m,
                friedman: f,
                stars: p_bonferroni.map_or("", stars),
                p_bonferroni,
            });
        }
    }

    Ok(Analysis {
        participants: cells.participants,
        repeats: design.repeats,
        alpha: design.alpha,
        normality,
        pairs,
        friedman: friedman_rows,
    })
}

/// Every unordered pair of `conditions`, in order: (c0, c1), (c0, c2), …,
/// (c1, c2), … — the paper's "between the LM types" within one radius.
pub fn all_pairs(conditions: &[&str]) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for (i, a) in conditions.iter().enumerate() {
        for b in &conditions[i + 1..] {
            out.push((a.to_string(), b.to_string()));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn design(pairs: Vec<PairFamily>, friedman: Vec<FriedmanFamily>) -> Design {
        Design {
            alpha: 0.05,
            repeats: Repeats::Mean,
            pairs,
            friedman,
        }
    }

    #[test]
    fn repeats_combine_and_missing_answers_are_left_out() {
        assert_eq!(combine(vec![1.0, 4.0], Repeats::Mean), 2.5);
        assert_eq!(combine(vec![5.0, 1.0, 4.0], Repeats::Median), 4.0);
        assert_eq!(combine(vec![5.0, 1.0, 4.0, 2.0], Repeats::Median), 3.0);
        assert!(combine(vec![], Repeats::Mean).is_nan());
        let rows = vec![
            Observation::new("p1", "a", Some(1.0)),
            Observation::new("p1", "a", None),
            Observation::new("p2", "a", None),
            Observation::new("p2", "a", None),
        ];
        let cells = Cells::new(&rows, Repeats::Mean).unwrap();
        assert_eq!(cells.columns["a"][0], 1.0);
        assert!(cells.columns["a"][1].is_nan());
    }

    #[test]
    fn bonferroni_uses_the_familys_size_and_skips_say_why() {
        // Three pairs; a vs c has every difference zero.
        let mut rows = Vec::new();
        for p in 0..6 {
            let who = format!("p{p}");
            rows.push(Observation::new(&who, "a", Some(1.0 + p as f64)));
            rows.push(Observation::new(&who, "b", Some(3.0 + p as f64 * 1.5)));
            rows.push(Observation::new(&who, "c", Some(1.0 + p as f64)));
        }
        let d = design(
            vec![PairFamily {
                name: "abc".into(),
                pairs: all_pairs(&["a", "b", "c"]),
            }],
            vec![],
        );
        let out = analyse(&rows, &d).unwrap();
        assert_eq!(out.pairs.len(), 3);
        let ab = &out.pairs[0];
        let w = ab.wilcoxon.done().unwrap();
        assert_eq!(ab.m, 3);
        assert_eq!(ab.p_bonferroni, Some((w.p * 3.0).min(1.0)));
        let ac = &out.pairs[1];
        assert_eq!(
            ac.wilcoxon,
            Outcome::Skipped("every difference is zero".into())
        );
        assert_eq!(ac.p_bonferroni, None);
        assert_eq!(ac.stars, "");
    }

    #[test]
    fn bad_designs_are_input_errors() {
        let rows = vec![Observation::new("p1", "a", Some(1.0))];
        let unknown = design(vec![PairFamily::new("f", [("a", "zz")])], vec![]);
        let e = analyse(&rows, &unknown).unwrap_err().to_string();
        assert!(e.contains("`zz`"), "{e}");
        let same = design(vec![PairFamily::new("f", [("a", "a")])], vec![]);
        assert!(analyse(&rows, &same).is_err());
        let small = design(
            vec![],
            vec![FriedmanFamily {
                name: "g".into(),
                groups: vec![vec!["a".into(), "a".into()]],
            }],
        );
        assert!(analyse(&rows, &small).is_err());
        let inf = vec![Observation::new("p1", "a", Some(f64::INFINITY))];
        assert!(analyse(&inf, &design(vec![], vec![])).is_err());
        let mut alpha = design(vec![], vec![]);
        alpha.alpha = 0.0;
        assert!(analyse(&rows, &alpha).is_err());
    }

    #[test]
    fn all_pairs_in_order() {
        let p = all_pairs(&["x", "y", "z"]);
        let names: Vec<(&str, &str)> = p.iter().map(|(a, b)| (a.as_str(), b.as_str())).collect();
        assert_eq!(names, vec![("x", "y"), ("x", "z"), ("y", "z")]);
    }
}
