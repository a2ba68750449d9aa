//! Procedures that choose what a trial presents next from the answers so
//! far. The runner asks a [`Procedure`] for the next stimulus and level,
//! presents it, gives it the participant's answer and stops once it has
//! finished; the dry run of a responses file walks it the same way:
//! Experiment 3's method of adjustment ([`Adjustment`]), the
//! transformed up-down staircase ([`staircase::Staircase`]) and QUEST+
//! ([`quest::Quest`]). A
//! trial without either presents its stimulus as the timeline says (the
//! fixed design).

use super::answers::{Accepts, Asked};
use super::columns::{self, Row};
use super::design::Planned;
use super::protocol;
pub mod quest;
pub mod staircase;

use quest::Quest;
use staircase::Staircase;

/// What to present next.
#[derive(Debug, Clone, PartialEq)]
pub struct Probe {
    /// The library entry.
    pub stimulus: String,
    /// The level, in the procedure's [`Procedure::level_unit`].
    pub level: f64,
}

/// What an answer did.
#[derive(Debug, Clone, PartialEq)]
pub enum Step {
    /// Present again at this level.
    Next(f64),
    /// The answer ended the procedure.
    Done,
    /// The level changed to this, and the procedure ended there (it ran
    /// out of steps); `why` says so in words.
    Last {
        /// The final level.
        level: f64,
        /// Why it ended.
        why: String,
    },
}

/// A procedure over one trial's presentations.
pub trait Procedure {
    /// What to present next; `None` once finished.
    fn next(&self) -> Option<Probe>;
    /// What the participant is asked after each presentation.
    fn asked(&self) -> Asked;
    /// Takes an answer (already checked by [`Asked::parse`]).
    fn respond(&mut self, answer: &str) -> Step;
    /// Whether it has finished.
    fn finished(&self) -> bool {
        self.next().is_none()
    }
    /// The grid of levels it moves over and the library entry of each
    /// level for the trial's condition, if it moves over a grid (a
    /// staircase, QUEST+).
    fn grid(&self) -> Option<(&protocol::Grid, &[String])> {
        None
    }
    /// What its level is and in which unit (`depth`, `mm`): names the log
    /// event (`depth`, field `depth_mm`) and the lines on stderr; a grid's
    /// is `level`, in the grid's unit.
    fn level_unit(&self) -> (String, String) {
        let unit = self.grid().map(|(g, _)| g.unit.clone());
        ("level".into(), unit.unwrap_or_default())
    }
    /// Whether it may present library entry `stimulus` besides the
    /// trial's own (a grid's other levels): the row's timing counts their
    /// phases too.
    fn presents(&self, stimulus: &str) -> bool {
        self.grid()
            .is_some_and(|(_, entries)| entries.iter().any(|e| e == stimulus))
    }
    /// Answers taken so far.
    fn answers(&self) -> usize;
    /// Whether a trial cut short may continue where it was: a grid
    /// procedure follows from its answers alone, so `midtrial` can replay
    /// them.
    fn resumable(&self) -> bool {
        self.grid().is_some()
    }
    /// Writes its columns into the trial's row.
    fn record(&self, row: &mut Row);
}

/// What a grid procedure presents at grid place `place`, if any.
fn grid_probe(g: &protocol::Grid, entries: &[String], place: Option<usize>) -> Option<Probe> {
    place.map(|i| Probe {
        stimulus: entries[i].clone(),
        level: g.values[i],
    })
}

/// The yes/no question of a grid procedure, logged under `column`, asked
/// of a presentation at grid place `place`.
fn grid_asked(column: &str, g: &protocol::Grid, place: usize) -> Asked {
    Asked {
        column: column.into(),
        prompt: format!("{} [1 = {}, 2 = {}]", g.text, g.yes, g.no),
        accepts: Accepts::Choice(g.answers()),
        not_perceived: None,
        perceived_at: Some(g.values[place]),
    }
}

/// The procedure of protocol `p` for planned trial `t`, if it has one.
pub fn start(p: &protocol::Protocol, t: &Planned) -> Option<Box<dyn Procedure>> {
    if let Some(s) = &p.staircase {
        return Some(Box::new(Staircase::new(s, t.condition)));
    }
    if let Some(q) = &p.quest {
        return Some(Box::new(Quest::new(q, t.condition)));
    }
    p.adjustment
        .as_ref()
        .map(|a| Box::new(Adjustment::new(a, &t.stimulus)) as Box<dyn Procedure>)
}

/// The method of adjustment: the experimenter sets a force gauge's pushing
/// depth; after each presentation the participant says whether the gauge
/// felt stronger (the depth decreases by a step), weaker (it increases) or
/// the same (the trial ends), clamped to the protocol's limits, for at
/// most `max` adjustments.
#[derive(Debug, Clone)]
pub struct Adjustment {
    spec: protocol::Adjustment,
    stimulus: String,
    depths: Vec<f64>,
    given: Vec<String>,
    done: bool,
}

impl Adjustment {
    /// Starts at the protocol's first depth.
    pub fn new(spec: &protocol::Adjustment, stimulus: &str) -> Self {
        Self {
            spec: spec.clone(),
            stimulus: stimulus.to_owned(),
            depths: vec![spec.start_mm],
            given: Vec::new(),
            done: false,
        }
    }

    fn depth(&self) -> f64 {
        self.depths.last().copied().unwrap_or(self.spec.start_mm)
    }
}

impl Procedure for Adjustment {
    fn next(&self) -> Option<Probe> {
        (!self.done).then(|| Probe {
            stimulus: self.stimulus.clone(),
            level: self.depth(),
        })
    }

    fn asked(&self) -> Asked {
        let a = &self.spec;
        let text = if a.text.is_empty() {
            "Compared with the ultrasound, the pushing force was"
        } else {
            &a.text
        };
        let shown = a.labels();
        Asked {
            column: "adjust".into(),
            prompt: format!(
                "{text} (depth {:.2} mm) [1 = {}, 2 = {}, 3 = {}]",
                self.depth(),
                shown[0],
                shown[1],
                shown[2]
            ),
            accepts: Accepts::Choice(shown),
            not_perceived: None,
            perceived_at: None,
        }
    }

    fn respond(&mut self, answer: &str) -> Step {
        let a = &self.spec;
        self.given.push(answer.to_owned());
        if answer == a.same {
            self.done = true;
            return Step::Done;
        }
        let step = if answer == a.stronger {
            -a.step_mm
        } else {
            a.step_mm
        };
        let depth = (self.depth() + step).clamp(a.min_mm, a.max_mm);
        self.depths.push(depth);
        if self.depths.len() > a.max as usize {
            self.done = true;
            return Step::Last {
                level: depth,
                why: format!("{} adjustments: the trial ends at {depth:.2} mm", a.max),
            };
        }
        Step::Next(depth)
    }

    fn level_unit(&self) -> (String, String) {
        ("depth".into(), "mm".into())
    }

    fn answers(&self) -> usize {
        self.given.len()
    }

    fn record(&self, row: &mut Row) {
        let sep = columns::LIST_SEPARATOR.to_string();
        row.set(columns::START_DEPTH, format!("{:.2}", self.spec.start_mm));
        row.set(columns::ADJUSTMENTS, (self.depths.len() - 1).to_string());
        row.set(columns::ADJUST_ANSWERS, self.given.join(&sep));
        row.set(
            columns::DEPTHS,
            self.depths
                .iter()
                .map(|d| format!("{d:.2}"))
                .collect::<Vec<_>>()
                .join(&sep),
        );
        row.set(columns::FINAL_DEPTH, format!("{:.2}", self.depth()));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `answer` ends `p` at a last level (`why_last` says why it must):
    /// that level and why, with `p` finished.
    pub(super) fn ends_at(p: &mut impl Procedure, answer: &str, why_last: &str) -> (f64, String) {
        let Step::Last { level, why } = p.respond(answer) else {
            panic!("{why_last}");
        };
        assert!(p.finished() && p.next().is_none(), "{why_last}");
        (level, why)
    }

    fn spec(max: u32) -> protocol::Adjustment {
        protocol::Adjustment {
            text: String::new(),
            start_mm: 4.0,
            step_mm: 0.25,
            max,
            min_mm: 0.0,
            max_mm: 4.25,
            stronger: "stronger".into(),
            weaker: "weaker".into(),
            same: "same".into(),
        }
    }

    #[test]
    fn adjustment_steps_clamps_and_ends_on_same_or_after_max() {
        let mut a = Adjustment::new(&spec(20), "lms");
        assert_eq!(a.next().unwrap().level, 4.0);
        assert_eq!(a.respond("stronger"), Step::Next(3.75));
        assert_eq!(a.respond("weaker"), Step::Next(4.0));
        // Clamped at max_mm.
        assert_eq!(a.respond("weaker"), Step::Next(4.25));
        assert_eq!(a.respond("weaker"), Step::Next(4.25));
        assert!(!a.finished());
        assert_eq!(a.respond("same"), Step::Done);
        assert!(a.finished() && a.next().is_none());
        assert_eq!(a.answers(), 5);
        let mut row = Row::default();
        a.record(&mut row);
        assert_eq!(row.get(columns::ADJUSTMENTS), Some("4"));
        assert_eq!(row.get(columns::DEPTHS), Some("4.00|3.75|4.00|4.25|4.25"));
        assert_eq!(row.get(columns::FINAL_DEPTH), Some("4.25"));
        assert_eq!(
            row.get(columns::ADJUST_ANSWERS),
            Some("stronger|weaker|weaker|weaker|same")
        );
        let mut b = Adjustment::new(&spec(2), "lms");
        assert_eq!(b.respond("stronger"), Step::Next(3.75));
        let (level, why) = ends_at(&mut b, "stronger", "the second adjustment is the last");
        assert_eq!(level, 3.5);
        assert!(why.contains("2 adjustments"), "{why}");
        assert_eq!(b.answers(), 2);
        let q = b.asked();
        assert!(q.prompt.contains("depth 3.50 mm"), "{}", q.prompt);
        assert_eq!(q.parse("3").unwrap(), "same");
    }
}
