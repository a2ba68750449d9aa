//! The grid of levels an adaptive procedure moves over (a `[staircase]`'s,
//! a `[quest]`'s), checked once for both: each level is a number that fills
//! the stimulus template's `{level}` to name a library entry; the question,
//! its two answers and the most presentations come with it.

use toml::Spanned;

use super::errors::Errors;
use super::file::{AnswerLabel, Label, Name, repeated};
use super::{Factor, MAX_LEVELS};
use crate::error::InputError;

/// The placeholder the levels fill.
pub const LEVEL: &str = "level";

/// A grid of levels, the question asked at each and its answers.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// What the participant is asked after each presentation.
    pub text: String,
    /// What a level is (`intensity`, `mm`): names the log's field.
    pub unit: String,
    /// The levels as written (they fill `{level}`), ascending.
    pub labels: Vec<String>,
    /// The levels as numbers, in `unit`.
    pub values: Vec<f64>,
    /// Per condition, the library entry of each level.
    pub entries: Vec<Vec<String>>,
    /// The grid place presented first.
    pub start: usize,
    /// Presentations that end it.
    pub trials: u32,
    /// The answer "perceived".
    pub yes: String,
    /// The answer "not perceived".
    pub no: String,
}

impl Grid {
    /// The two answers, "perceived" first.
    pub fn answers(&self) -> Vec<String> {
        vec![self.yes.clone(), self.no.clone()]
    }

    /// For tests: `n` levels `0, 1/(n-1), …, 1` of `intensity` (labels
    /// with four decimals), one condition whose entries are `s-<label>`,
    /// answers `yes` and `no`, starting at the top.
    #[cfg(test)]
    pub(crate) fn even(n: usize, trials: u32) -> Self {
        let values: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
        let labels: Vec<String> = values.iter().map(|v| format!("{v:.4}")).collect();
        Self {
            text: "Did you feel it?".into(),
            unit: "intensity".into(),
            entries: vec![labels.iter().map(|l| format!("s-{l}")).collect()],
            labels,
            values,
            start: n - 1,
            trials,
            yes: "yes".into(),
            no: "no".into(),
        }
    }
}

/// A grid's fields as its table gives them.
pub(super) struct Fields {
    pub text: Label,
    pub unit: Name,
    pub levels: Spanned<Vec<Label>>,
    pub trials: u32,
    pub yes: Spanned<AnswerLabel>,
    pub no: Spanned<AnswerLabel>,
}

/// Checks the grid of table `table` (at `span`): the template names the
/// level, the levels, the answers; `start` and `entries` are left for the
/// procedure (its start) and the conditions (their entries).
pub(super) fn check(
    table: &str,
    span: std::ops::Range<usize>,
    f: Fields,
    template: &Spanned<String>,
    factors: &[Factor],
    e: &Errors,
) -> Result<Grid, InputError> {
    template_names_level(table, span.clone(), template, factors, e)?;
    let (labels, values) = levels(&f.levels, e)?;
    answers_differ(&f.yes, &f.no, span, e)?;
    Ok(Grid {
        text: f.text.0,
        unit: f.unit.0,
        labels,
        values,
        entries: Vec::new(),
        start: 0,
        trials: f.trials,
        yes: f.yes.into_inner().0,
        no: f.no.into_inner().0,
    })
}

/// Checks that the stimulus template names the level (`{level}`) and no
/// factor takes its name; `table` names the procedure's table.
fn template_names_level(
    table: &str,
    span: std::ops::Range<usize>,
    template: &Spanned<String>,
    factors: &[Factor],
    e: &Errors,
) -> Result<(), InputError> {
    if factors.iter().any(|f| f.name == LEVEL) {
        return Err(e.at(
            span,
            table,
            format!("a factor is called `level`, which names the {table}'s level in the stimulus template: rename the factor"),
        ));
    }
    if !template.get_ref().contains("{level}") {
        return Err(e.at(
            template.span(),
            "stimulus",
            format!("a [{table}] names each level's library entry: put `{{level}}` in the stimulus template"),
        ));
    }
    Ok(())
}

/// A grid of levels: 2 to [`MAX_LEVELS`] finite numbers as written, in
/// ascending order, each once; their labels and values.
fn levels(levels: &Spanned<Vec<Label>>, e: &Errors) -> Result<(Vec<String>, Vec<f64>), InputError> {
    let labels: Vec<String> = levels.get_ref().iter().map(|l| l.0.clone()).collect();
    if !(2..=MAX_LEVELS).contains(&labels.len()) {
        return Err(e.at(
            levels.span(),
            "levels",
            format!("{} levels: give 2 to {MAX_LEVELS}", labels.len()),
        ));
    }
    let mut values = Vec::with_capacity(labels.len());
    for l in &labels {
        match l.parse::<f64>() {
            Ok(v) if v.is_finite() => values.push(v),
            _ => {
                return Err(e.at(
                    levels.span(),
                    "levels",
                    format!("`{l}` is not a finite number (each level is its value, in `unit`)"),
                ));
            }
        }
    }
    if let Some(i) = (1..values.len()).find(|&i| values[i] <= values[i - 1]) {
        return Err(e.at(
            levels.span(),
            "levels",
            format!(
                "`{}` after `{}`: give the levels in ascending order, each once",
                labels[i],
                labels[i - 1]
            ),
        ));
    }
    Ok((labels, values))
}

/// Refuses a `yes` and a `no` that are the same answer.
fn answers_differ(
    yes: &Spanned<AnswerLabel>,
    no: &Spanned<AnswerLabel>,
    span: std::ops::Range<usize>,
    e: &Errors,
) -> Result<(), InputError> {
    if repeated(&[yes.get_ref().0.as_str(), no.get_ref().0.as_str()]).is_some() {
        let at = Some(no.span()).filter(|x| !x.is_empty());
        return Err(e.at(
            at.unwrap_or(span),
            "no",
            "`yes` and `no` are the same answer: they must differ, also in case",
        ));
    }
    Ok(())
}

/// Per condition, the library entry of each level `labels`.
pub(super) fn entries(
    labels: &[String],
    template: &Spanned<String>,
    factors: &[Factor],
    conditions: &[Vec<String>],
    e: &Errors,
) -> Result<Vec<Vec<String>>, InputError> {
    let mut entries = Vec::with_capacity(conditions.len());
    for levels_of in conditions {
        let mut row = Vec::with_capacity(labels.len());
        for l in labels {
            let id = super::expand_level(template.get_ref(), factors, levels_of, Some(l))
                .map_err(|m| e.at(template.span(), "stimulus", m))?;
            crate::plan::library::check_id(&id).map_err(|m| {
                e.at(
                    template.span(),
                    "stimulus",
                    format!("condition {}, level {l}: {m}", levels_of.join("/")),
                )
            })?;
            row.push(id);
        }
        entries.push(row);
    }
    Ok(entries)
}
