//! The `[quest]` table, checked: a grid of levels as the staircase has
//! (each fills the stimulus template's `{level}` to name a library entry)
//! and QUEST+'s model, whose likelihoods are computed here once for every
//! trial of the session (see `stats::quest`).

use std::sync::Arc;

use toml::Spanned;

use super::errors::Errors;
use super::file::{File, QuestFile, ShapeFile};
use super::grid::{self, Fields, Grid};
use super::{
    DEFAULT_LAPSES, Factor, MAX_LAPSE, MAX_LEVELS, MAX_QUEST_GRID, MAX_QUEST_PARAMS, MAX_SLOPE,
};
use crate::error::InputError;
use crate::lab::stats::psychometric::Shape;
use crate::lab::stats::quest::{Model, Posterior, Table};
use crate::limits::show;

/// QUEST+ over a grid of levels.
#[derive(Debug, Clone, PartialEq)]
pub struct Quest {
    /// The levels, the question and its answers; `grid.start` is the
    /// uniform prior's best.
    pub grid: Grid,
    /// The likelihoods of the model at every level, computed once.
    pub table: Arc<Table>,
    /// The threshold's posterior SD that ends it earlier, in `unit`.
    pub stop_sd: Option<f64>,
}

impl Quest {
    /// Its model.
    pub fn model(&self) -> &Model {
        self.table.model()
    }
}

/// A `[quest]` checked but for its entries, which need the conditions
/// (whose stimulus is the start level's entry).
pub(super) struct Unnamed {
    quest: Quest,
}

impl Unnamed {
    /// The label of the level presented first.
    pub fn start_label(&self) -> &str {
        &self.quest.grid.labels[self.quest.grid.start]
    }

    /// Names each condition's entries.
    pub fn named(
        mut self,
        template: &Spanned<String>,
        factors: &[Factor],
        conditions: &[Vec<String>],
        e: &Errors,
    ) -> Result<Quest, InputError> {
        let grid = &mut self.quest.grid;
        grid.entries = grid::entries(&grid.labels, template, factors, conditions, e)?;
        Ok(self.quest)
    }
}

/// A list of 1 to `max` numbers, each passing `ok` (which says why not).
fn numbers(
    v: &Spanned<Vec<f64>>,
    field: &str,
    max: usize,
    ok: impl Fn(f64) -> Result<(), String>,
    e: &Errors,
) -> Result<Vec<f64>, InputError> {
    let x = v.get_ref();
    if !(1..=max).contains(&x.len()) {
        return Err(e.at(
            v.span(),
            field,
            format!("{} values: give 1 to {max}", x.len()),
        ));
    }
    for &n in x {
        ok(n).map_err(|m| e.at(v.span(), field, format!("{}: {m}", show(n))))?;
    }
    Ok(x.clone())
}

/// Checks the file's `[quest]` (taken out of it) against the rest of
/// `others`.
pub(super) fn check(
    file: Spanned<QuestFile>,
    others: &File,
    factors: &[Factor],
    e: &Errors,
) -> Result<Unnamed, InputError> {
    let span = file.span();
    let q = file.into_inner();
    if others.adjustment.is_some() || others.staircase.is_some() {
        return Err(e.at(
            span,
            "quest",
            "a trial follows one procedure: give one of [adjustment], [staircase] and [quest]",
        ));
    }
    let levels_span = q.levels.span();
    let mut grid = grid::check(
        "quest",
        span.clone(),
        Fields {
            text: q.text,
            unit: q.unit,
            levels: q.levels,
            trials: q.trials.0,
            yes: q.yes,
            no: q.no,
        },
        &others.stimulus,
        factors,
        e,
    )?;
    let values = &grid.values;
    let shape = match q.shape {
        ShapeFile::Logistic => Shape::Logistic,
        ShapeFile::Weibull => Shape::Weibull,
    };
    let thresholds = match &q.thresholds {
        None if shape == Shape::Weibull && values[0] <= 0.0 => {
            return Err(e.at(
                levels_span,
                "levels",
                "a Weibull's thresholds are above 0, and they default to the levels: give `thresholds`",
            ));
        }
        None => values.clone(),
        Some(t) => {
            let weibull = shape == Shape::Weibull;
            let v = numbers(
                t,
                "thresholds",
                MAX_LEVELS,
                |x| match (x.is_finite(), weibull && x <= 0.0) {
                    (false, _) => Err("give finite numbers".into()),
                    (_, true) => Err("a Weibull's thresholds are above 0".into()),
                    _ => Ok(()),
                },
                e,
            )?;
            if v.windows(2).any(|w| w[1] <= w[0]) {
                return Err(e.at(
                    t.span(),
                    "thresholds",
                    "give the thresholds in ascending order, each once",
                ));
            }
            v
        }
    };
    let slopes = numbers(
        &q.slopes,
        "slopes",
        MAX_QUEST_GRID,
        |x| {
            (x > 0.0 && x <= MAX_SLOPE).then_some(()).ok_or(format!(
                "give slopes above 0 and at most {}",
                show(MAX_SLOPE)
            ))
        },
        e,
    )?;
    let lapses = match &q.lapses {
        None => DEFAULT_LAPSES.to_vec(),
        Some(l) => numbers(
            l,
            "lapses",
            MAX_QUEST_GRID,
            |x| {
                ((0.0..MAX_LAPSE).contains(&x))
                    .then_some(())
                    .ok_or(format!("give lapse rates from 0, below {MAX_LAPSE}"))
            },
            e,
        )?,
    };
    let guess = match &q.guess {
        None => 0.0,
        Some(g) => {
            let x = *g.get_ref();
            if !((0.0..1.0).contains(&x) && lapses.iter().all(|l| x + l < 1.0)) {
                return Err(e.at(
                    g.span(),
                    "guess",
                    format!(
                        "{} is out of range: give a rate from 0, below 1 and below 1 with every lapse rate",
                        show(x)
                    ),
                ));
            }
            x
        }
    };
    let params = thresholds.len() * slopes.len() * lapses.len();
    if params > MAX_QUEST_PARAMS {
        return Err(e.at(
            span,
            "quest",
            format!(
                "{} thresholds × {} slopes × {} lapse rates make {params} functions to weigh: at most {MAX_QUEST_PARAMS}",
                thresholds.len(),
                slopes.len(),
                lapses.len()
            ),
        ));
    }
    let stop_sd = match &q.stop_sd {
        None => None,
        Some(s) => {
            let x = *s.get_ref();
            if !(x.is_finite() && x > 0.0) {
                return Err(e.at(
                    s.span(),
                    "stop_sd",
                    format!("{} is out of range: give a standard deviation above 0, in the levels' unit", show(x)),
                ));
            }
            Some(x)
        }
    };
    let table = Arc::new(Table::new(
        values,
        Model {
            shape,
            guess,
            thresholds,
            slopes,
            lapses,
        },
    ));
    // Every trial starts from the same prior, so at the same level.
    grid.start = Posterior::uniform(table.clone()).best();
    Ok(Unnamed {
        quest: Quest {
            grid,
            table,
            stop_sd,
        },
    })
}
