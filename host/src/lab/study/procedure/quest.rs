//! QUEST+ (Watson 2017) as a trial's procedure, over the same kind of grid
//! as the staircase: each level a library entry planned before the first
//! trial, so no plan runs between presentations. After each answer the
//! posterior over the protocol's psychometric functions is updated and the
//! next level is the one expected to leave the least posterior entropy
//! (`stats::quest`). It ends after `trials` presentations, or earlier once
//! the threshold's posterior SD is below `stop_sd`; the row holds every
//! presentation's level and answer and the threshold's posterior mean and
//! SD.

use super::{Probe, Procedure, Step};
use crate::lab::stats::quest::Posterior;
use crate::lab::study::answers::Asked;
use crate::lab::study::columns::{self, Row};
use crate::lab::study::protocol;

/// QUEST+ over one trial's presentations.
#[derive(Debug, Clone)]
pub struct Quest {
    spec: protocol::Quest,
    /// The library entry of each level, for this trial's condition.
    entries: Vec<String>,
    posterior: Posterior,
    /// The grid place to present next.
    place: usize,
    /// The grid place of each presentation.
    presented: Vec<usize>,
    answers: Vec<bool>,
    ended: Option<String>,
}

impl Quest {
    /// QUEST+ of `spec` for condition `condition`, from the uniform prior.
    pub fn new(spec: &protocol::Quest, condition: usize) -> Self {
        Self {
            entries: spec.grid.entries[condition].clone(),
            posterior: Posterior::uniform(spec.table.clone()),
            place: spec.grid.start,
            presented: Vec::new(),
            answers: Vec::new(),
            ended: None,
            spec: spec.clone(),
        }
    }

    /// The posterior so far.
    pub fn posterior(&self) -> &Posterior {
        &self.posterior
    }

    /// The grid place to present next; `None` once ended.
    pub fn place(&self) -> Option<usize> {
        self.ended.is_none().then_some(self.place)
    }

    /// The grid places presented so far.
    pub fn presented(&self) -> &[usize] {
        &self.presented
    }

    /// The threshold's posterior mean and SD, in the levels' unit.
    pub fn threshold(&self) -> (f64, f64) {
        self.posterior.threshold()
    }

    fn label(&self, yes: bool) -> &str {
        if yes {
            &self.spec.grid.yes
        } else {
            &self.spec.grid.no
        }
    }
}

impl Procedure for Quest {
    fn next(&self) -> Option<Probe> {
        super::grid_probe(&self.spec.grid, &self.entries, self.place())
    }

    fn asked(&self) -> Asked {
        super::grid_asked("quest", &self.spec.grid, self.place)
    }

    fn respond(&mut self, answer: &str) -> Step {
        if self.ended.is_some() {
            return Step::Done;
        }
        let perceived = answer == self.spec.grid.yes;
        let at = self.place;
        self.posterior.update(at, perceived);
        self.presented.push(at);
        self.answers.push(perceived);
        let (mean, sd) = self.threshold();
        let unit = &self.spec.grid.unit;
        if self.presented.len() >= self.spec.grid.trials as usize {
            self.ended = Some(format!("{} presentations", self.presented.len()));
        } else if let Some(bound) = self.spec.stop_sd.filter(|&b| sd < b) {
            self.ended = Some(format!(
                "posterior SD {sd:.4} below {bound} {unit} after {} presentations",
                self.presented.len()
            ));
        }
        match &self.ended {
            None => {
                self.place = self.posterior.best();
                Step::Next(self.spec.grid.values[self.place])
            }
            Some(why) => Step::Last {
                level: self.spec.grid.values[at],
                why: format!("{why}: threshold {mean:.4} {unit} (posterior SD {sd:.4})"),
            },
        }
    }

    fn grid(&self) -> Option<(&protocol::Grid, &[String])> {
        Some((&self.spec.grid, &self.entries))
    }

    fn answers(&self) -> usize {
        self.answers.len()
    }

    fn record(&self, row: &mut Row) {
        let sep = columns::LIST_SEPARATOR.to_string();
        let levels: Vec<&str> = self
            .presented
            .iter()
            .map(|&i| self.spec.grid.labels[i].as_str())
            .collect();
        let answers: Vec<&str> = self.answers.iter().map(|&y| self.label(y)).collect();
        row.set(columns::QUEST_LEVELS, levels.join(&sep));
        row.set(columns::QUEST_ANSWERS, answers.join(&sep));
        let (mean, sd) = self.threshold();
        row.set(columns::THRESHOLD, format!("{mean:.6}"));
        row.set(columns::THRESHOLD_SD, format!("{sd:.6}"));
    }
}

#[cfg(test)]
pub(crate) mod tests;
