//! QUEST+ (Watson 2017, "QUEST+: A general multidimensional Bayesian
//! adaptive psychometric method", J Vision 17(3):10) over a grid of
//! stimulus levels and a grid of psychometric functions, as plain f64.
//!
//! The model's parameters are a threshold, a slope and a lapse rate, each
//! a list of candidate values (a slope or lapse of one value is fixed);
//! the guess rate and the shape are fixed. The likelihood of "perceived"
//! for every level and every parameter triple is computed once into a
//! [`Table`] (plan once, run many: a trial's procedure shares it); the
//! posterior over the triples starts uniform and is multiplied by the
//! answer's likelihood after each presentation, then normalised, so it
//! never underflows to nothing. The next level is the one whose answer is
//! expected to leave the least posterior entropy.
//!
//! Every likelihood is kept within [`P_FLOOR`] of 0 and 1: an answer the
//! model calls impossible (a "perceived" far below every threshold with
//! no guesses) would otherwise empty the posterior. The floor is far below
//! any lapse rate worth modelling, so it changes no estimate that matters.

use std::sync::Arc;

use super::psychometric::Shape;

/// The least (and one less the most) likelihood an answer has.
pub const P_FLOOR: f64 = 1e-9;

/// The psychometric functions QUEST+ weighs: every combination of the
/// candidate thresholds, slopes and lapse rates, with one guess rate.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    /// The core's shape.
    pub shape: Shape,
    /// Probability of "perceived" far below threshold.
    pub guess: f64,
    /// Candidate thresholds, in level units.
    pub thresholds: Vec<f64>,
    /// Candidate slopes.
    pub slopes: Vec<f64>,
    /// Candidate lapse rates.
    pub lapses: Vec<f64>,
}

impl Model {
    /// Parameter triples: thresholds × slopes × lapses.
    pub fn params(&self) -> usize {
        self.thresholds.len() * self.slopes.len() * self.lapses.len()
    }

    /// The triple at index `j` (thresholds slowest, lapses fastest).
    pub fn param(&self, j: usize) -> (f64, f64, f64) {
        let (s, l) = (self.slopes.len(), self.lapses.len());
        (
            self.thresholds[j / (s * l)],
            self.slopes[j / l % s],
            self.lapses[j % l],
        )
    }
}

/// The likelihood of "perceived" at every level for every parameter
/// triple of a [`Model`], computed once.
#[derive(Clone, PartialEq)]
pub struct Table {
    model: Model,
    levels: usize,
    params: usize,
    /// `yes[i * params + j]`: P("perceived" | level i, triple j).
    yes: Vec<f64>,
}

impl std::fmt::Debug for Table {
    // Its million numbers say nothing in a log.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Table")
            .field("levels", &self.levels)
            .field("params", &self.params)
            .finish_non_exhaustive()
    }
}

impl Table {
    /// The likelihoods of `model` at `values` (the levels, in level units).
    pub fn new(values: &[f64], model: Model) -> Self {
        let params = model.params();
        let mut yes = Vec::with_capacity(values.len() * params);
        for &x in values {
            for j in 0..params {
                let (t, s, l) = model.param(j);
                let f = model.shape.core(x, t, s);
                let p = model.guess + (1.0 - model.guess - l) * f;
                yes.push(p.clamp(P_FLOOR, 1.0 - P_FLOOR));
            }
        }
        Self {
            model,
            levels: values.len(),
            params,
            yes,
        }
    }

    /// Its model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// Levels.
    pub fn levels(&self) -> usize {
        self.levels
    }

    /// P("perceived" | level `i`, triple `j`).
    pub fn p_yes(&self, i: usize, j: usize) -> f64 {
        self.yes[i * self.params + j]
    }

    fn row(&self, i: usize) -> &[f64] {
        &self.yes[i * self.params..(i + 1) * self.params]
    }
}

/// `-Σ w ln w` over the positive `w` (0 ln 0 = 0).
fn w_ln_w(w: f64) -> f64 {
    if w > 0.0 { w * w.ln() } else { 0.0 }
}

/// The posterior over a [`Table`]'s parameter triples, normalised.
#[derive(Debug, Clone, PartialEq)]
pub struct Posterior {
    table: Arc<Table>,
    w: Vec<f64>,
}

impl Posterior {
    /// The uniform prior over `table`'s triples.
    pub fn uniform(table: Arc<Table>) -> Self {
        let n = table.params;
        Self {
            w: vec![1.0 / n as f64; n],
            table,
        }
    }

    /// Its table.
    pub fn table(&self) -> &Arc<Table> {
        &self.table
    }

    /// The weights, summing to 1.
    pub fn weights(&self) -> &[f64] {
        &self.w
    }

    /// The posterior entropy (nats) expected after presenting level `i`:
    /// `Σ_r q_r H_r`, with `q_r` the answer's probability and `H_r` the
    /// entropy of the posterior it leaves, which is
    /// `q_r ln q_r - Σ_j w_rj ln w_rj` for the unnormalised `w_rj`.
    pub fn expected_entropy(&self, i: usize) -> f64 {
        let (mut q_yes, mut q_no, mut s_yes, mut s_no) = (0.0, 0.0, 0.0, 0.0);
        for (&w, &p) in self.w.iter().zip(self.table.row(i)) {
            let (y, n) = (w * p, w * (1.0 - p));
            q_yes += y;
            q_no += n;
            s_yes += w_ln_w(y);
            s_no += w_ln_w(n);
        }
        w_ln_w(q_yes) - s_yes + w_ln_w(q_no) - s_no
    }

    /// The level that minimises [`Self::expected_entropy`] (the lowest
    /// of equals).
    pub fn best(&self) -> usize {
        let mut best = (0, f64::INFINITY);
        for i in 0..self.table.levels {
            let h = self.expected_entropy(i);
            if h < best.1 {
                best = (i, h);
            }
        }
        best.0
    }

    /// Takes the answer at level `i`: Bayes' rule, then normalised.
    pub fn update(&mut self, i: usize, perceived: bool) {
        let mut sum = 0.0;
        for (w, &p) in self.w.iter_mut().zip(self.table.row(i)) {
            *w *= if perceived { p } else { 1.0 - p };
            sum += *w;
        }
        // At least P_FLOOR: every likelihood is, and the weights summed to 1.
        for w in &mut self.w {
            *w /= sum;
        }
    }

    /// The mean and standard deviation of the parameter `of` picks from a
    /// triple (threshold, slope, lapse) under the posterior.
    pub fn mean_sd(&self, of: impl Fn((f64, f64, f64)) -> f64) -> (f64, f64) {
        let m = &self.table.model;
        let (mut mean, mut sq) = (0.0, 0.0);
        for (j, &w) in self.w.iter().enumerate() {
            let v = of(m.param(j));
            mean += w * v;
            sq += w * v * v;
        }
        (mean, (sq - mean * mean).max(0.0).sqrt())
    }

    /// The threshold's posterior mean and standard deviation.
    pub fn threshold(&self) -> (f64, f64) {
        self.mean_sd(|(t, _, _)| t)
    }
}

#[cfg(test)]
mod tests;
