//! A simulated observer: answers "perceived?" from a psychometric function
//! with a known threshold, slope, guess and lapse rate, through the same
//! [`Answers`] interface the terminal and a responses file use. It lets a
//! staircase or QUEST+ protocol run end to end without a participant and lets the
//! tests check where an adaptive procedure converges.

use super::answers::{Accepts, Answers, Asked};
use crate::error::InputError;
use crate::rng::SplitMix64;

pub use crate::lab::stats::psychometric::{Psychometric, Shape};

impl Psychometric {
    /// Parses `logistic:threshold=0.5,slope=12,guess=0,lapse=0.02` (or
    /// `weibull:...`); `guess` and `lapse` default to 0 and 0.02, and the
    /// optional `seed=N` is returned beside it (default 1).
    pub fn parse(spec: &str) -> Result<(Self, u64), InputError> {
        let bad = |m: String| {
            InputError::new(format!(
                "--observer `{}`: {m} (give e.g. logistic:threshold=0.5,slope=12,guess=0,lapse=0.02,seed=1)",
                spec.escape_debug()
            ))
        };
        let (shape, rest) = spec.split_once(':').unwrap_or((spec, ""));
        let shape = crate::error::choose("a shape", shape, &Shape::ALL.map(|s| (s.name(), s)))
            .map_err(bad)?;
        let (mut threshold, mut slope, mut guess, mut lapse, mut seed) =
            (None, None, 0.0, 0.02, 1u64);
        for kv in rest.split(',').filter(|s| !s.is_empty()) {
            let (k, v) = kv
                .split_once('=')
                .ok_or_else(|| bad(format!("`{kv}` is not key=value")))?;
            if k == "seed" {
                seed = v
                    .parse()
                    .map_err(|_| bad(format!("seed `{v}` is not a whole number")))?;
                continue;
            }
            let x = match crate::limits::exact_number(v) {
                Ok(x) if x.is_finite() => x,
                Err(m) => return Err(bad(format!("{k}: {m}"))),
                _ => return Err(bad(format!("{k} `{v}` is not a finite number"))),
            };
            match k {
                "threshold" => threshold = Some(x),
                "slope" => slope = Some(x),
                "guess" => guess = x,
                "lapse" => lapse = x,
                _ => return Err(bad(format!("`{k}` is not a parameter"))),
            }
        }
        let threshold = threshold.ok_or_else(|| bad("give threshold=".into()))?;
        let slope = slope.ok_or_else(|| bad("give slope=".into()))?;
        if slope <= 0.0 {
            return Err(bad("slope must be above 0".into()));
        }
        if shape == Shape::Weibull && threshold <= 0.0 {
            return Err(bad("a Weibull threshold must be above 0".into()));
        }
        if !(0.0..1.0).contains(&guess) || !(0.0..1.0).contains(&lapse) || guess + lapse >= 1.0 {
            return Err(bad(
                "guess and lapse must be from 0, below 1 and together below 1".into(),
            ));
        }
        Ok((
            Self {
                shape,
                threshold,
                slope,
                guess,
                lapse,
            },
            seed,
        ))
    }
}

/// Answers a procedure's "perceived?" question by drawing from a
/// [`Psychometric`] function at the level asked about; any other question
/// is an error (a simulated observer has no opinions).
#[derive(Debug, Clone)]
pub struct Observer {
    f: Psychometric,
    rng: SplitMix64,
}

impl Observer {
    /// An observer following `f`, its draws seeded by `seed`.
    pub fn new(f: Psychometric, seed: u64) -> Self {
        Self {
            f,
            rng: SplitMix64::new(seed),
        }
    }

    /// From `--observer`'s text.
    pub fn parse(spec: &str) -> Result<Self, InputError> {
        let (f, seed) = Psychometric::parse(spec)?;
        Ok(Self::new(f, seed))
    }

    /// Whether a stimulus at `level` is perceived this time.
    pub fn perceives(&mut self, level: f64) -> bool {
        self.rng.next_f64() < self.f.p(level)
    }
}

impl Answers for Observer {
    fn poll(&mut self, q: &Asked) -> anyhow::Result<Option<String>> {
        match (q.perceived_at, &q.accepts) {
            (Some(level), Accepts::Choice(c)) if c.len() == 2 => {
                let i = usize::from(!self.perceives(level));
                Ok(Some(c[i].clone()))
            }
            _ => Err(InputError::new(format!(
                "the simulated observer answers only whether a stimulus was perceived, not `{}`: give --responses or answer at the terminal",
                q.column
            ))
            .into()),
        }
    }
}

/// The observer `--observer` asks for, if it does, for protocol `p`: a
/// staircase's or QUEST+'s protocol without questions, else bad input.
pub fn for_run(
    answers: &super::AnswerSource,
    p: &super::protocol::Protocol,
) -> Result<Option<Observer>, InputError> {
    let super::AnswerSource::Observer(spec) = answers else {
        return Ok(None);
    };
    let o = Observer::parse(spec)?;
    let adaptive = p.staircase.is_some() || p.quest.is_some();
    if !adaptive || !p.questions.is_empty() {
        return Err(InputError::new(format!(
            "--observer: study protocol {} {}: a simulated observer answers only a staircase's or QUEST+'s \"perceived?\"",
            p.path.display(),
            if !adaptive {
                "has no [staircase] or [quest]"
            } else {
                "asks questions"
            }
        )));
    }
    Ok(Some(o))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_function_and_its_inverse_agree_and_bad_specs_are_refused() {
        for spec in [
            "logistic:threshold=0.5,slope=12,guess=0,lapse=0.02",
            "weibull:threshold=0.5,slope=3.5,guess=0.5,lapse=0.01,seed=9",
        ] {
            let (f, _) = Psychometric::parse(spec).unwrap();
            for p in [0.6, 0.707, 0.9] {
                let x = f.level_at(p).unwrap();
                assert!((f.p(x) - p).abs() < 1e-9, "{spec} at {p}");
            }
            assert!(f.p(0.0) < 0.51 && f.p(10.0) > 0.97);
        }
        assert_eq!(
            Psychometric::parse("logistic:threshold=1,slope=2")
                .unwrap()
                .1,
            1
        );
        for bad in [
            "probit:threshold=1,slope=1",
            "logistic:slope=1",
            "logistic:threshold=1",
            "logistic:threshold=1,slope=0",
            "logistic:threshold=1,slope=1,lapse=0.6,guess=0.5",
            "logistic:threshold=nan,slope=1",
            "logistic:threshold=1,slope=1,colour=2",
            "weibull:threshold=-1,slope=1",
        ] {
            assert!(Psychometric::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_observer_answers_perceived_questions_at_the_function_rate_only() {
        let (f, _) = Psychometric::parse("logistic:threshold=0.5,slope=12,lapse=0").unwrap();
        let mut o = Observer::new(f, 3);
        let q = |level| Asked {
            column: "staircase".into(),
            prompt: String::new(),
            accepts: Accepts::Choice(vec!["yes".into(), "no".into()]),
            not_perceived: None,
            perceived_at: Some(level),
        };
        let n = 4000;
        let yes = (0..n)
            .filter(|_| o.poll(&q(0.5)).unwrap().unwrap() == "yes")
            .count();
        assert!((yes as f64 / n as f64 - 0.5).abs() < 0.03, "{yes}");
        let high = (0..200)
            .filter(|_| o.poll(&q(2.0)).unwrap().unwrap() == "yes")
            .count();
        assert_eq!(high, 200);
        let mut likert = q(0.5);
        likert.perceived_at = None;
        assert!(o.poll(&likert).is_err());
    }
}
