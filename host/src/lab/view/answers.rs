//! Answers from the participant's page: the study's question goes to the
//! page, the participant's click or key comes back as the answer.

use std::sync::Arc;

use super::state::{Question, Shared};
use crate::lab::study::answers::{Accepts, Answers, Asked};

/// Experiment 2's circle radii (mm): the paper's stimulus radii.
pub const EXPERIMENT2_RADII_MM: [f64; 5] = [2.0, 3.0, 4.0, 5.0, 6.0];

/// The participant's page as the study's answer source.
pub struct ViewAnswers {
    shared: Arc<Shared>,
    asked: Option<(String, u64)>,
    seq: u64,
}

impl ViewAnswers {
    pub(super) fn new(shared: Arc<Shared>) -> Self {
        Self {
            shared,
            asked: None,
            seq: 0,
        }
    }
}

/// What the page offers for `q`: its options, and circles when every
/// option is a radius in millimetres.
pub fn question(q: &Asked, seq: u64) -> Question {
    let options: Vec<String> = match &q.accepts {
        Accepts::Likert(points) => (1..=*points).map(|p| p.to_string()).collect(),
        Accepts::Choice(o) => o.clone(),
        // A number is typed at the terminal or given in --responses.
        Accepts::Number(..) => Vec::new(),
    };
    let radii: Option<Vec<f64>> = match &q.accepts {
        Accepts::Choice(o) => o
            .iter()
            .map(|l| {
                l.trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|r| *r > 0.0 && *r <= 50.0)
            })
            .collect(),
        _ => None,
    };
    Question {
        seq,
        prompt: q.prompt.clone(),
        options,
        radii_mm: radii,
    }
}

impl Answers for ViewAnswers {
    fn poll(&mut self, q: &Asked) -> anyhow::Result<Option<String>> {
        if self.asked.as_ref().map(|a| &a.0) != Some(&q.prompt) {
            self.seq += 1;
            self.asked = Some((q.prompt.clone(), self.seq));
            let shown = question(q, self.seq);
            if shown.options.is_empty() {
                crate::bad_input!(
                    "`{}` asks for a number: the participant's page offers choices only (give --responses)",
                    q.column
                );
            }
            crate::errln!("{} (answer on the participant's page)", q.prompt);
            self.shared.ask(Some(shown));
        }
        let seq = self.seq;
        match self.shared.take_answer(seq) {
            Some(a) => {
                self.asked = None;
                self.shared.ask(None);
                let v = q.parse(&a).map_err(|m| anyhow::anyhow!(m))?;
                crate::errln!("  -> {v}");
                Ok(Some(v))
            }
            None => Ok(None),
        }
    }
}
