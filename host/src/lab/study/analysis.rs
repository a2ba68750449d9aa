//! `study report`'s statistics: the protocol's `[report]` turned into the
//! paper's tests ([`crate::lab::stats::table`]) over every numeric answer
//! column, "not perceived" answers left out and counted. Written as
//! `stats.csv` (a row per test), `stats.json` (every result with its
//! method, n and what was left out) and `stats.txt` (a table to read).
//!
//! A condition is named by its levels joined with `/` (`lms-5hz/2`).

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::Serialize;

use super::columns::NOT_PERCEIVED;
use super::protocol::{Condition, Factor, ReportSpec};
use crate::lab::stats::table::{
    Analysis, Design, FriedmanFamily, Observation, Outcome, PairFamily, analyse,
};

/// One condition's numbers for one question.
#[derive(Debug, Clone, PartialEq)]
pub struct Stat {
    /// The stimulus.
    pub stimulus: String,
    /// Factor levels.
    pub levels: Vec<String>,
    /// The question column.
    pub question: String,
    /// The values, sorted.
    pub values: Vec<f64>,
    /// "Not perceived" answers (left out of `values`).
    pub not_perceived: usize,
}

/// A condition's name in the statistics: its levels joined with `/`.
pub fn condition_name(c: &Condition) -> String {
    c.levels.join("/")
}

/// One answer column's tests.
#[derive(Debug, Clone, Serialize)]
pub struct QuestionStats {
    /// The column.
    pub question: String,
    /// "Not perceived" answers left out, in all.
    pub not_perceived: usize,
    /// ... and per condition (those with any).
    pub not_perceived_by_condition: BTreeMap<String, usize>,
    /// The tests.
    pub analysis: Analysis,
}

/// The conditions that differ from `c` only in factor `k`, in `k`'s level
/// order: a group or a family, and the other factors' levels naming it.
fn groups(factors: &[Factor], conditions: &[Condition], k: usize) -> Vec<(String, Vec<usize>)> {
    let mut out: Vec<(Vec<&String>, String, Vec<usize>)> = Vec::new();
    for (i, c) in conditions.iter().enumerate() {
        let key: Vec<&String> = c
            .levels
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != k)
            .map(|(_, l)| l)
            .collect();
        match out.iter_mut().find(|g| g.0 == key) {
            Some(g) => g.2.push(i),
            None => {
                let name = factors
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| *j != k)
                    .zip(&key)
                    .map(|((_, f), l)| format!("{}={l}", f.name))
                    .collect::<Vec<_>>()
                    .join(", ");
                out.push((key, name, vec![i]));
            }
        }
    }
    out.into_iter().map(|(_, n, v)| (n, v)).collect()
}

/// The tests the protocol's `[report]` names, over `conditions`.
pub fn design(spec: &ReportSpec, factors: &[Factor], conditions: &[Condition]) -> Design {
    let at = |name: &str| factors.iter().position(|f| f.name == name);
    let mut pairs = Vec::new();
    for p in &spec.pairs {
        let Some(k) = at(&p.factor) else { continue };
        for (within, members) in groups(factors, conditions, k) {
            let find = |level: &str| {
                members
                    .iter()
                    .map(|&i| &conditions[i])
                    .find(|c| c.levels[k] == level)
                    .map(condition_name)
            };
            let named: Vec<(String, String)> = p
                .pairs
                .iter()
                .filter_map(|(a, b)| Some((find(a)?, find(b)?)))
                .collect();
            pairs.push(PairFamily {
                name: if within.is_empty() {
                    p.factor.clone()
                } else {
                    format!("{} at {within}", p.factor)
                },
                pairs: named,
            });
        }
    }
    let friedman = spec
        .friedman
        .iter()
        .filter_map(|name| {
            let k = at(name)?;
            Some(FriedmanFamily {
                name: name.clone(),
                groups: groups(factors, conditions, k)
                    .into_iter()
                    .map(|(_, m)| m.iter().map(|&i| condition_name(&conditions[i])).collect())
                    .collect(),
            })
        })
        .collect();
    Design {
        alpha: spec.alpha,
        repeats: spec.repeats,
        pairs,
        friedman,
    }
}

/// The tests of answer column `question` over `rows` of (participant,
/// condition index, value as recorded): `na` is left out and counted, an
/// empty value (not asked) is no answer. Every condition is in the
/// analysis, answered or not, so a design naming one never fails on it.
pub fn question(
    question: &str,
    rows: &[(String, usize, String)],
    conditions: &[Condition],
    design: &Design,
) -> anyhow::Result<QuestionStats> {
    // Every condition first, in the protocol's order (a missing value
    // changes no cell).
    let who = rows.first().map_or("-", |r| r.0.as_str()).to_owned();
    let mut obs: Vec<Observation> = conditions
        .iter()
        .map(|c| Observation::new(&who, &condition_name(c), None))
        .collect();
    let mut by: BTreeMap<String, usize> = BTreeMap::new();
    for (who, c, v) in rows {
        let name = condition_name(&conditions[*c]);
        if v == NOT_PERCEIVED {
            *by.entry(name.clone()).or_default() += 1;
            obs.push(Observation::new(who, &name, None));
        } else if let Ok(x) = v.parse::<f64>() {
            obs.push(Observation::new(who, &name, Some(x)));
        }
    }
    let analysis = analyse(&obs, design)?;
    Ok(QuestionStats {
        question: question.to_owned(),
        not_perceived: by.values().sum(),
        not_perceived_by_condition: by,
        analysis,
    })
}

fn num(x: f64) -> String {
    format!("{x:.6}")
}

fn p_value(x: f64) -> String {
    format!("{x:.6e}")
}

/// `stats.csv`'s columns, in order.
const STATS_COLUMNS: [&str; 17] = [
    "question",
    "test",
    "family",
    "conditions",
    "n",
    "excluded",
    "m",
    "statistic",
    "p",
    "p_bonferroni",
    "method",
    "effect",
    "effect_size",
    "d_z",
    "power",
    "marks",
    "note",
];

/// One line of `stats.csv` by column ([`STATS_COLUMNS`]); a cell a test
/// does not have stays empty.
#[derive(Default)]
struct Line {
    question: String,
    test: &'static str,
    family: String,
    conditions: String,
    n: String,
    excluded: String,
    m: String,
    statistic: String,
    p: String,
    p_bonferroni: String,
    method: &'static str,
    effect: &'static str,
    effect_size: String,
    d_z: String,
    power: String,
    marks: String,
    note: String,
}

impl Line {
    /// `outcome`'s cells (statistic, p, method, excluded count, effect
    /// size), the rest empty; a skipped test's reason in `note`. `f` gives
    /// a result's statistic, p, method, excluded count and effect size.
    fn of<T>(
        outcome: &Outcome<T>,
        f: impl FnOnce(&T) -> (f64, f64, crate::lab::stats::Method, usize, Option<f64>),
    ) -> Self {
        match outcome {
            Outcome::Done(x) => {
                let (stat, p, method, excluded, effect) = f(x);
                Self {
                    statistic: num(stat),
                    p: p_value(p),
                    method: method.name(),
                    excluded: excluded.to_string(),
                    effect_size: effect.map(num).unwrap_or_default(),
                    ..Self::default()
                }
            }
            Outcome::Skipped(why) => Self {
                excluded: "0".into(),
                note: why.clone(),
                ..Self::default()
            },
        }
    }

    /// Its cells in [`STATS_COLUMNS`]' order.
    fn cells(self) -> [String; 17] {
        [
            self.question,
            self.test.into(),
            self.family,
            self.conditions,
            self.n,
            self.excluded,
            self.m,
            self.statistic,
            self.p,
            self.p_bonferroni,
            self.method.into(),
            self.effect.into(),
            self.effect_size,
            self.d_z,
            self.power,
            self.marks,
            self.note,
        ]
    }
}

/// `stats.csv`: a row per test.
pub fn csv(all: &[QuestionStats]) -> String {
    let mut out = super::record::line(&STATS_COLUMNS) + "\n";
    for q in all {
        let a = &q.analysis;
        let mut row = |l: Line| out += &(super::record::line(&l.cells()) + "\n");
        for r in &a.normality {
            row(Line {
                question: q.question.clone(),
                test: "shapiro-wilk",
                conditions: r.condition.clone(),
                n: r.n.to_string(),
                ..Line::of(&r.shapiro_wilk, |s| (s.w, s.p, s.method, s.excluded, None))
            });
        }
        for r in &a.friedman {
            row(Line {
                question: q.question.clone(),
                test: "friedman",
                family: r.family.clone(),
                conditions: r.conditions.join(" "),
                n: r.n.to_string(),
                m: r.m.to_string(),
                p_bonferroni: r.p_bonferroni.map(p_value).unwrap_or_default(),
                effect: "kendall_w",
                marks: r.stars.into(),
                ..Line::of(&r.friedman, |f| {
                    (f.statistic, f.p, f.method, f.excluded, Some(f.kendall_w))
                })
            });
        }
        for r in &a.pairs {
            let mut line = Line {
                question: q.question.clone(),
                test: "wilcoxon",
                family: r.family.clone(),
                conditions: format!("{} {}", r.a, r.b),
                n: r.n.to_string(),
                m: r.m.to_string(),
                p_bonferroni: r.p_bonferroni.map(p_value).unwrap_or_default(),
                effect: "r",
                marks: format!("{}{}", r.stars, r.power_marks),
                ..Line::of(&r.wilcoxon, |w| {
                    (w.statistic, w.p, w.method, w.excluded, Some(w.r))
                })
            };
            match &r.paired_t {
                Outcome::Done(t) => (line.d_z, line.power) = (num(t.d_z), num(t.power)),
                Outcome::Skipped(why) if line.note.is_empty() => {
                    line.note = format!("t-test power: {why}");
                }
                Outcome::Skipped(_) => {}
            }
            row(line);
        }
    }
    out
}

/// A p-value to read: 4 decimals, or 3 significant digits below 0.001
/// (the paper's marks go down to 0.0005).
fn p_text(p: f64) -> String {
    if p.is_nan() {
        "-".into()
    } else if p >= 1e-3 || p == 0.0 {
        format!("{p:.4}")
    } else {
        format!("{p:.2e}")
    }
}

/// A test's figures as `done` writes them, or why there is no test.
fn result<T>(outcome: &Outcome<T>, done: impl FnOnce(&T) -> String) -> String {
    match outcome {
        Outcome::Done(t) => done(t),
        Outcome::Skipped(why) => format!("no test: {why}"),
    }
}

/// `stats.txt`: the tests as a table to read.
pub fn text(all: &[QuestionStats]) -> String {
    let mut s = String::new();
    for q in all {
        let a = &q.analysis;
        let _ = writeln!(
            s,
            "== {} ({} participants; {} \"not perceived\" left out{})",
            q.question,
            a.participants.len(),
            q.not_perceived,
            if q.not_perceived_by_condition.is_empty() {
                String::new()
            } else {
                format!(
                    ": {}",
                    q.not_perceived_by_condition
                        .iter()
                        .map(|(c, n)| format!("{c} {n}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
        );
        let _ = writeln!(s, "Shapiro-Wilk per condition:");
        for r in &a.normality {
            let head = format!("{:<24} n={:<3}", r.condition, r.n);
            let tail = result(&r.shapiro_wilk, |t| {
                format!("W={:.4} p={}", t.w, p_text(t.p))
            });
            let _ = writeln!(s, "  {head} {tail}");
        }
        if !a.friedman.is_empty() {
            let _ = writeln!(s, "Friedman (Bonferroni within each factor):");
        }
        for r in &a.friedman {
            let head = format!(
                "{:<10} {:<40} n={:<3}",
                r.family,
                r.conditions.join(" "),
                r.n
            );
            let tail = result(&r.friedman, |t| {
                format!(
                    "chi2={:.3} p={} p_bonf={} W={:.3} {}",
                    t.statistic,
                    p_text(t.p),
                    p_text(r.p_bonferroni.unwrap_or(f64::NAN)),
                    t.kendall_w,
                    r.stars
                )
            });
            let _ = writeln!(s, "  {head} {tail}");
        }
        if !a.pairs.is_empty() {
            let _ = writeln!(
                s,
                "Wilcoxon signed-rank (Bonferroni within each family), d_z and paired t power at alpha {}:",
                a.alpha
            );
        }
        for r in &a.pairs {
            let power = r.paired_t.done().map_or("-".into(), |t| {
                format!("d_z={:.3} power={:.3}", t.d_z, t.power)
            });
            let head = format!("{:<24} {} vs {} n={:<3}", r.family, r.a, r.b, r.n);
            let tail = result(&r.wilcoxon, |t| {
                format!(
                    "W={} p={} ({}) p_bonf={} r={:.3} {power} {}{}",
                    t.statistic,
                    p_text(t.p),
                    t.method.name(),
                    p_text(r.p_bonferroni.unwrap_or(f64::NAN)),
                    t.r,
                    r.stars,
                    r.power_marks
                )
            });
            let _ = writeln!(s, "  {head} {tail}");
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests;
