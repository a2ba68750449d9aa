//! The `[staircase]` table, checked: a grid of levels, each a number that
//! fills the stimulus template's `{level}` to name a library entry, and
//! Levitt's rule (see `study::staircase`).

use toml::Spanned;

use super::Factor;
use super::errors::Errors;
use super::file::{File, StaircaseFile};
use super::grid::{self, Fields, Grid};
use crate::error::InputError;

/// A transformed up-down staircase over a grid of levels.
#[derive(Debug, Clone, PartialEq)]
pub struct Staircase {
    /// The levels, the question and its answers; `grid.start` is the
    /// file's `start`.
    pub grid: Grid,
    /// "Not perceived" answers in a row that move the level up.
    pub up: u32,
    /// "Perceived" answers in a row that move it down.
    pub down: u32,
    /// The step in grid places before the first reversal, after the
    /// first, …; the last stays.
    pub steps: Vec<u32>,
    /// Reversals that end it.
    pub reversals: u32,
    /// The threshold is the mean level of this many last reversals.
    pub threshold_reversals: u32,
}

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
    file: Spanned<StaircaseFile>,
    has_adjustment: bool,
    template: &Spanned<String>,
    factors: &[Factor],
    conditions: &[Vec<String>],
    e: &Errors,
) -> Result<Staircase, InputError> {
    let span = file.span();
    let s = file.into_inner();
    if has_adjustment {
        return Err(e.at(
            span,
            "staircase",
            "a trial follows one procedure: give [adjustment] or [staircase], not both",
        ));
    }
    let mut grid = grid::check(
        "staircase",
        span,
        Fields {
            text: s.text,
            unit: s.unit,
            levels: s.levels,
            trials: s.trials.0,
            yes: s.yes,
            no: s.no,
        },
        template,
        factors,
        e,
    )?;
    let labels = &grid.labels;
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
            // Each read as any number, so `-1` or `2.5` is refused in
            // these words too, not by a Rust type's range.
            let steps: Option<Vec<u32>> = v
                .get_ref()
                .iter()
                .map(|k| k.whole_in(1, u64::from(n) - 1).ok().map(|k| k as u32))
                .collect();
            match steps {
                Some(steps) if !steps.is_empty() => steps,
                _ => {
                    return Err(e.at(
                        v.span(),
                        "steps",
                        format!("give 1 or more steps, each 1 to {} grid places", n - 1),
                    ));
                }
            }
        }
    };
    let reversals = s.reversals.0;
    let usable = usable_steps(reversals, grid.trials, s.up.0, s.down.0);
    if let Some(v) = s.steps.as_ref().filter(|_| steps.len() > usable.0 as usize) {
        return Err(e.at(
            v.span(),
            "steps",
            format!(
                "{} steps, but only {} can ever be used: {}; give at most {}",
                steps.len(),
                match usable.0 {
                    1 => "the first".to_owned(),
                    n => format!("the first {n}"),
                },
                usable.1,
                usable.0
            ),
        ));
    }
    let threshold_reversals = match &s.threshold_reversals {
        None => reversals.min(super::file::DEFAULT_THRESHOLD_REVERSALS),
        Some(n) => match n.get_ref().whole_in(1, u64::from(reversals)) {
            Ok(v) => v as u32,
            Err(m) => {
                return Err(e.at(
                    n.span(),
                    "threshold_reversals",
                    format!("{m} (the reversals that end it)"),
                ));
            }
        },
    };
    grid.entries = grid::entries(labels, template, factors, conditions, e)?;
    grid.start = start;
    Ok(Staircase {
        grid,
        up: s.up.0,
        down: s.down.0,
        steps,
        reversals,
        threshold_reversals,
    })
}

/// How many of `steps` a staircase can ever use, and why no more: the
/// step after the `k`-th reversal first moves the level at that reversal,
/// which takes at least `k + 1` moves in alternating directions (`up` or
/// `down` answers each), and moves a level that is presented only before
/// the last reversal and the last of `trials` presentations. One at least:
/// `steps` is never empty.
fn usable_steps(reversals: u32, trials: u32, up: u32, down: u32) -> (u32, String) {
    let (lo, hi) = (u64::from(up.min(down)), u64::from(up.max(down)));
    // Fewest answers that make `n` moves, each a reversal after the first.
    let answers = |n: u64| n.div_ceil(2) * lo + n / 2 * hi;
    let by_trials = (0..u64::from(reversals))
        .take_while(|&k| answers(k + 1) < u64::from(trials))
        .count() as u32;
    if by_trials < reversals {
        let most = by_trials.saturating_sub(1);
        (
            by_trials.max(1),
            format!(
                "with up {up} and down {down}, {trials} presentations (`trials`) reach at most {} before the last",
                plural(most)
            ),
        )
    } else {
        (
            reversals,
            format!(
                "a step follows each reversal and the staircase ends at reversal {reversals} (`reversals`)"
            ),
        )
    }
}

fn plural(n: u32) -> String {
    match n {
        1 => "1 reversal".to_owned(),
        n => format!("{n} reversals"),
    }
}
