//! The study's live view (`study run --view ADDR`): the view started
//! beside the study's session, and the participant's page as the study's
//! answer source (the question's options become the page's choices; when
//! every option is a radius in mm, its circles).

use super::FingerSource;
use super::answers::{Accepts, Answers, Asked, Lines, Piped, Terminal};
use crate::lab::session::Session;
use crate::lab::view::{self, Participant, Question};

/// Starts the live view of `session` at `addr` and prints its pages: the
/// synthetic finger is rendered in colour; tracked centroids bring no
/// colour stream, so their view shows the overlay without video.
pub(super) fn start_view(
    addr: std::net::SocketAddr,
    session: &Session,
    finger: &FingerSource,
) -> anyhow::Result<crate::lab::view::View> {
    let v = view::View::start(view::Options {
        addr,
        scene: session.scene().clone(),
        colour: view::default_colour(),
        frames: match finger {
            FingerSource::Synthetic => view::Frames::Synthetic,
            _ => view::Frames::Pushed,
        },
        stimuli: view::stimuli(session.loaded()),
    })?;
    if !v.addr().ip().is_loopback() {
        crate::errln!(
            "warning: --view {addr} is reachable from other hosts: whoever has the address and its token can watch and answer for the participant"
        );
    }
    crate::errln!(
        "lmhost: view on {}: experimenter {} ; participant {}",
        v.addr(),
        v.experimenter_url(),
        v.participant_url()
    );
    Ok(v)
}

/// Where the study's answers come from: `--responses` first, then the
/// participant's page when a view runs, then the terminal (single keys)
/// or piped stdin.
pub(super) fn answer_source(
    lines: Option<Lines>,
    view: Option<&view::View>,
) -> anyhow::Result<Box<dyn Answers>> {
    Ok(match (lines, view) {
        (Some(l), _) => Box::new(l),
        (None, Some(v)) => Box::new(ViewAnswers::new(v.participant())),
        (None, None) if nix::unistd::isatty(std::io::stdin()).unwrap_or(false) => {
            Box::new(Terminal::open()?)
        }
        (None, None) => Box::new(Piped::open()?),
    })
}

/// The participant's page as the study's answer source.
pub struct ViewAnswers {
    page: Participant,
    asked: Option<(String, u64)>,
    seq: u64,
}

impl ViewAnswers {
    /// Answers from `page`.
    pub fn new(page: Participant) -> Self {
        Self {
            page,
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
        not_perceived: q.not_perceived.clone(),
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
            self.page.ask(Some(shown));
        }
        let seq = self.seq;
        match self.page.take_answer(seq) {
            Some(a) => {
                self.asked = None;
                self.page.ask(None);
                let v = q.parse(&a).map_err(|m| anyhow::anyhow!(m))?;
                crate::errln!("  -> {v}");
                Ok(Some(v))
            }
            None => Ok(None),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_offers_not_perceived_where_the_question_allows_it() {
        // The page sends the study's own "not perceived" value.
        assert_eq!(
            crate::lab::view::NOT_PERCEIVED,
            super::super::columns::NOT_PERCEIVED
        );
        let mut asked = Asked {
            column: "size".into(),
            prompt: "Which circle?".into(),
            accepts: Accepts::Choice(vec!["2".into(), "3".into()]),
            not_perceived: Some("could not perceive the stimulus".into()),
            perceived_at: None,
        };
        let q = question(&asked, 1);
        assert_eq!(
            q.not_perceived.as_deref(),
            Some("could not perceive the stimulus")
        );
        assert!(q.offers("2") && q.offers("na") && !q.offers("4"));
        assert_eq!(asked.parse("na").unwrap(), "na");
        asked.not_perceived = None;
        let q = question(&asked, 2);
        assert!(q.not_perceived.is_none() && !q.offers("na"));
    }
}
