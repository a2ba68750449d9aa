//! The `[staircase]` table, checked: a grid of levels, each a number that
//! fills the stimulus template's `{level}` to name a library entry, and
//! Levitt's rule (see `study::staircase`).

use toml::Spanned;

use super::errors::Errors;
use super::file::{AnswerLabel, File, Label, StaircaseFile, repeated};
use super::{Factor, MAX_LEVELS};
use crate::error::InputError;

/// A transformed up-down staircase over a grid of levels.
#[derive(Debug, Clone, PartialEq)]
pub struct Staircase {
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
    /// "Not perceived" answers in a row that move the level up.
    pub up: u32,
    /// "Perceived" answers in a row that move it down.
    pub down: u32,
    /// The step in grid places before the first reversal, after the
    /// first, …; the last stays.
    pub steps: Vec<u32>,
    /// Reversals that end it.
    pub reversals: u32,
    /// Presentations that end it.
    pub trials: u32,
    /// The threshold is the mean level of this many last reversals.
    pub threshold_reversals: u32,
    /// The answer "perceived".
    pub yes: String,
    /// The answer "not perceived".
    pub no: String,
}

/// The placeholder the levels fill.
pub const LEVEL: &str = "level";

/// The label of the start level of the file's staircase, if it has one
/// (the conditions' own stimulus: what a trial prepares first).
pub(super) fn start_label(file: &File) -> Option<String> {
    let s = file.staircase.as_ref()?.get_ref();
    Some(match &s.start {
        Some(l) => l.get_ref().0.clone(),
        None => s.levels.get_ref().last()?.0.clone(),
    })
}

/// Checks the file's `[staircase]` and names each condition's entries.
pub(super) fn check(
    file: Option<Spanned<StaircaseFile>>,
    has_adjustment: bool,
    template: &Spanned<String>,
    factors: &[Factor],
    conditions: &[Vec<String>],
    e: &Errors,
) -> Result<Option<Staircase>, InputError> {
    let Some(file) = file else {
        return Ok(None);
    };
    let span = file.span();
    let s = file.into_inner();
    if has_adjustment {
        return Err(e.at(
            span,
            "staircase",
            "a trial follows one procedure: give [adjustment] or [staircase], not both",
        ));
    }
    template_names_level("staircase", span.clone(), template, factors, e)?;
    let (labels, values) = levels(&s.levels, e)?;
    let start = match &s.start {
        None => labels.len() - 1,
        Some(l) => labels
            .iter()
            .position(|x| *x == l.get_ref().0)
            .ok_or_else(|| {
                e.at(
                    l.span(),
                    "start",
                    format!("`{}` is not one of the levels", l.get_ref().0),
                )
            })?,
    };
    let steps = match &s.steps {
        None => vec![1],
        Some(v) => {
            let n = labels.len() as u32;
            if v.get_ref().is_empty() || v.get_ref().iter().any(|&k| !(1..n).contains(&k)) {
                return Err(e.at(
                    v.span(),
                    "steps",
                    format!("give 1 or more steps, each 1 to {} grid places", n - 1),
                ));
            }
            v.get_ref().clone()
        }
    };
    let reversals = s.reversals.0;
    let threshold_reversals = match &s.threshold_reversals {
        None => reversals.min(super::file::DEFAULT_THRESHOLD_REVERSALS),
        Some(n) => {
            let v = *n.get_ref();
            if !(1..=reversals).contains(&v) {
                return Err(e.at(
                    n.span(),
                    "threshold_reversals",
                    format!("{v} is out of range 1..={reversals} (the reversals that end it)"),
                ));
            }
            v
        }
    };
    answers_differ(&s.yes, &s.no, span, e)?;
    let entries = entries(&labels, template, factors, conditions, e)?;
    Ok(Some(Staircase {
        text: s.text.0,
        unit: s.unit.0,
        labels,
        values,
        entries,
        start,
        up: s.up.0,
        down: s.down.0,
        steps,
        reversals,
        trials: s.trials.0,
        threshold_reversals,
        yes: s.yes.into_inner().0,
        no: s.no.into_inner().0,
    }))
}

/// Checks that the stimulus template names the level (`{level}`) and no
/// factor takes its name; `table` names the procedure's table.
pub(super) fn template_names_level(
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
pub(super) fn levels(
    levels: &Spanned<Vec<Label>>,
    e: &Errors,
) -> Result<(Vec<String>, Vec<f64>), InputError> {
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
pub(super) fn answers_differ(
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
