//! A transformed up-down staircase (Levitt 1971, "Transformed up-down
//! methods in psychoacoustics", JASA 49, 467–477) over a grid of levels,
//! each level a library entry planned with the rest of the library before
//! the device opens.
//!
//! After `down` "perceived" answers in a row the level goes down a step,
//! after `up` "not perceived" answers in a row it goes up; a change of
//! direction is a reversal, and the step (in grid places) takes the next
//! size of `steps` at each reversal. It ends after `reversals` reversals
//! or `trials` presentations; the threshold is the mean level of the last
//! `threshold_reversals` reversals. 1-up/2-down converges on the level
//! perceived 70.7 % of the time (p² = ½), 1-up/3-down on 79.4 %.
//!
//! Why a grid of planned entries rather than planning each level as it is
//! asked for: every level is planned, checked and sized before the first
//! trial (a bad level is a protocol error, not a failure mid-session), the
//! time between two presentations is a switch or an upload of a planned
//! entry (the session loads on demand, least recently used out) and never
//! a plan, and the row names exactly which entries were presented. A
//! level the grid cannot reach is the grid's end, and each presentation
//! there is counted in the row (`staircase_at_limit`), never silently
//! clamped. The answer that ends the staircase moves it nowhere: its
//! last level is the last one presented.

use super::{Probe, Procedure, Step};
use crate::lab::study::answers::Asked;
use crate::lab::study::columns::{self, Row};
use crate::lab::study::protocol;

/// The staircase's rule and state over grid places `0..levels`.
#[derive(Debug, Clone, PartialEq)]
pub struct Levitt {
    up: u32,
    down: u32,
    steps: Vec<u32>,
    max_reversals: u32,
    max_trials: u32,
    levels: usize,
    place: usize,
    /// Answers in a row of the same kind (perceived when `run_yes`).
    run: u32,
    run_yes: bool,
    /// The direction of the last move: `Some(true)` up.
    last_up: Option<bool>,
    /// The grid place of each reversal.
    reversals: Vec<usize>,
    /// The grid place of each presentation.
    presented: Vec<usize>,
    answers: Vec<bool>,
    /// Presentations answered at a level the grid's end cut short.
    at_limit: u32,
    /// Whether the move to `place` was cut short by the grid's end.
    clamped: bool,
    ended: Option<String>,
}

impl Levitt {
    /// A staircase from `start` over `levels` grid places; `steps` is not
    /// empty and every count is at least 1 (the protocol checks both).
    pub fn new(spec: &protocol::Staircase) -> Self {
        Self {
            up: spec.up,
            down: spec.down,
            steps: spec.steps.clone(),
            max_reversals: spec.reversals,
            max_trials: spec.grid.trials,
            levels: spec.grid.values.len(),
            place: spec.grid.start,
            run: 0,
            run_yes: false,
            last_up: None,
            reversals: Vec::new(),
            presented: Vec::new(),
            answers: Vec::new(),
            at_limit: 0,
            clamped: false,
            ended: None,
        }
    }

    /// The grid place to present next; `None` once ended.
    pub fn place(&self) -> Option<usize> {
        self.ended.is_none().then_some(self.place)
    }

    /// Takes the answer to the presentation at [`Self::place`]: whether
    /// the stimulus was perceived. Returns why it ended, once it has.
    pub fn answer(&mut self, perceived: bool) -> Option<&str> {
        if self.ended.is_some() {
            return self.ended.as_deref();
        }
        self.presented.push(self.place);
        self.answers.push(perceived);
        if self.run_yes == perceived {
            self.run += 1;
        } else {
            (self.run, self.run_yes) = (1, perceived);
        }
        // A presentation at a level the grid's end cut short counts when
        // it is answered: a move a trial never presents counts nothing.
        if std::mem::take(&mut self.clamped) {
            self.at_limit += 1;
        }
        let move_up = match (perceived, self.run) {
            (true, n) if n >= self.down => Some(false),
            (false, n) if n >= self.up => Some(true),
            _ => None,
        };
        if let Some(up) = move_up {
            self.run = 0;
            // The reversal is the level just presented: it counts before
            // the end is decided, the move after it only if one follows.
            if self.last_up.is_some_and(|l| l != up) {
                self.reversals.push(self.place);
            }
            self.last_up = Some(up);
        }
        if self.reversals.len() >= self.max_reversals as usize {
            self.ended = Some(format!("{} reversals", self.reversals.len()));
        } else if self.presented.len() >= self.max_trials as usize {
            self.ended = Some(format!("{} presentations", self.presented.len()));
        }
        // An ended staircase stays at its last presented level.
        if let (Some(up), None) = (move_up, &self.ended) {
            let k = self.reversals.len().min(self.steps.len() - 1);
            let step = self.steps[k] as usize;
            let to = if up {
                self.place.saturating_add(step).min(self.levels - 1)
            } else {
                self.place.saturating_sub(step)
            };
            self.clamped = to.abs_diff(self.place) != step;
            self.place = to;
        }
        self.ended.as_deref()
    }

    /// The grid places of the reversals so far.
    pub fn reversals(&self) -> &[usize] {
        &self.reversals
    }

    /// The grid places presented so far.
    pub fn presented(&self) -> &[usize] {
        &self.presented
    }

    /// The answers so far (perceived or not).
    pub fn answers(&self) -> &[bool] {
        &self.answers
    }

    /// Presentations answered at a level the grid's end cut short (a
    /// move it cut short that was never presented, the trial having
    /// ended or been stopped first, is not one).
    pub fn at_limit(&self) -> u32 {
        self.at_limit
    }

    /// The mean of `values` at the last `n` reversals (fewer when there
    /// are fewer; `None` without any).
    pub fn threshold(&self, values: &[f64], n: usize) -> Option<f64> {
        let last = &self.reversals[self.reversals.len().saturating_sub(n)..];
        (!last.is_empty()).then(|| last.iter().map(|&i| values[i]).sum::<f64>() / last.len() as f64)
    }
}

/// The staircase as a trial's procedure: a presentation per answer, each
/// at its level's library entry for the trial's condition.
#[derive(Debug, Clone)]
pub struct Staircase {
    spec: protocol::Staircase,
    /// The library entry of each level, for this trial's condition.
    entries: Vec<String>,
    rule: Levitt,
}

impl Staircase {
    /// The staircase of `spec` for condition `condition`.
    pub fn new(spec: &protocol::Staircase, condition: usize) -> Self {
        Self {
            entries: spec.grid.entries[condition].clone(),
            rule: Levitt::new(spec),
            spec: spec.clone(),
        }
    }

    /// Its rule and state.
    pub fn rule(&self) -> &Levitt {
        &self.rule
    }

    fn values(&self, places: &[usize]) -> String {
        let sep = columns::LIST_SEPARATOR.to_string();
        places
            .iter()
            .map(|&i| self.spec.grid.labels[i].as_str())
            .collect::<Vec<_>>()
            .join(&sep)
    }
}

impl Procedure for Staircase {
    fn next(&self) -> Option<Probe> {
        super::grid_probe(&self.spec.grid, &self.entries, self.rule.place())
    }

    fn asked(&self) -> Asked {
        super::grid_asked("staircase", &self.spec.grid, self.rule.place().unwrap_or(0))
    }

    fn respond(&mut self, answer: &str) -> Step {
        let perceived = answer == self.spec.grid.yes;
        let presented = self.spec.grid.values[self.rule.place().unwrap_or(0)];
        match self.rule.answer(perceived).map(str::to_owned) {
            None => Step::Next(self.next().map_or(presented, |p| p.level)),
            Some(why) => Step::Last {
                level: presented,
                why: match self.rule.threshold(
                    &self.spec.grid.values,
                    self.spec.threshold_reversals as usize,
                ) {
                    Some(t) => format!("{why}: threshold {t:.4} {}", self.spec.grid.unit),
                    None => format!("{why}: no reversal, no threshold"),
                },
            },
        }
    }

    fn grid(&self) -> Option<(&protocol::Grid, &[String])> {
        Some((&self.spec.grid, &self.entries))
    }

    fn answers(&self) -> usize {
        self.rule.answers().len()
    }

    fn record(&self, row: &mut Row) {
        let r = &self.rule;
        let sep = columns::LIST_SEPARATOR.to_string();
        row.set(columns::STAIRCASE_LEVELS, self.values(r.presented()));
        row.set(
            columns::STAIRCASE_ANSWERS,
            r.answers()
                .iter()
                .map(|&y| {
                    if y {
                        &self.spec.grid.yes
                    } else {
                        &self.spec.grid.no
                    }
                    .as_str()
                })
                .collect::<Vec<_>>()
                .join(&sep),
        );
        row.set(columns::STAIRCASE_REVERSALS, self.values(r.reversals()));
        row.set(columns::STAIRCASE_AT_LIMIT, r.at_limit().to_string());
        row.set(
            columns::THRESHOLD,
            r.threshold(
                &self.spec.grid.values,
                self.spec.threshold_reversals as usize,
            )
            .map(|t| format!("{t:.6}"))
            .unwrap_or_default(),
        );
    }
}

#[cfg(test)]
mod tests;
