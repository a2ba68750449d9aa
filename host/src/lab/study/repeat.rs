//! A trial that follows a procedure: the stimulus repeats its on/off
//! phases, one answer is asked per finished on-phase, every level goes to
//! the event log, and when the next level is another library entry (a
//! staircase's grid) that entry is presented in its place.

use super::Runner;
use super::design::Planned;
use super::procedure::{Procedure, Step};
use crate::lab::session::{EventKind, OffsetReason, Present};

impl Runner {
    /// On-phases that ended in this trial so far.
    fn offsets(&self) -> usize {
        self.trial_events
            .iter()
            .filter(|e| matches!(e.kind, EventKind::Offset { .. }))
            .count()
    }

    /// Runs procedure `pr` over trial `t`, presented as `req` (whose
    /// stimulus follows the procedure's), until it has finished or the
    /// presentation ended; each answer's response time goes to `rts`; the
    /// array is stopped after.
    pub(super) fn follow(
        &mut self,
        pr: &mut dyn Procedure,
        t: &Planned,
        req: &mut Present,
        rts: &mut Vec<f64>,
    ) -> anyhow::Result<()> {
        if let Some(first) = pr.next() {
            let (what, unit) = pr.level_unit();
            crate::errln!("  {what} {:.2} {unit}", first.level);
            self.level_event(pr, t.trial, first.level, None)?;
        }
        // On-phases and answers before the stimulus last changed:
        // one answer per finished on-phase of what plays now.
        let (mut phases_before, mut answers_before) = (0, 0);
        while !pr.finished() {
            let offsets = self.offsets();
            if offsets - phases_before <= pr.answers() - answers_before {
                self.tick()?;
                if !self.session().presenting() {
                    break;
                }
                self.pause();
                continue;
            }
            let (ans, rt) = self.ask(&pr.asked())?;
            rts.push(rt);
            self.answered(pr, t.trial, &ans)?;
            // A staircase's next level is another library entry.
            if let Some(next) = pr.next().filter(|n| n.stimulus != req.stimulus) {
                self.session().stop(OffsetReason::Stop)?;
                self.drain()?;
                req.stimulus = next.stimulus;
                self.session().present(req)?;
                self.drain()?;
                (phases_before, answers_before) = (self.offsets(), pr.answers());
            }
        }
        if self.session().presenting() {
            self.session().stop(OffsetReason::Stop)?;
        }
        Ok(())
    }

    /// Logs the procedure's level (the `depth` event).
    pub(super) fn level_event(
        &mut self,
        pr: &dyn Procedure,
        trial: usize,
        level: f64,
        answer: Option<&str>,
    ) -> anyhow::Result<()> {
        let (what, unit) = pr.level_unit();
        let mut v = serde_json::json!({"event": what, "trial": trial, "answer": answer});
        v[format!("{what}_{unit}")] = level.into();
        self.log(v)
    }

    /// Gives the procedure an answer, logs and says what it did; the new
    /// level, if it changed.
    pub(super) fn answered(
        &mut self,
        pr: &mut dyn Procedure,
        trial: usize,
        ans: &str,
    ) -> anyhow::Result<Option<f64>> {
        let (what, unit) = pr.level_unit();
        Ok(match pr.respond(ans) {
            Step::Done => None,
            Step::Next(level) => {
                self.level_event(pr, trial, level, Some(ans))?;
                // On disk before the next presentation: `--resume`
                // continues the trial from these.
                self.events.sync()?;
                crate::errln!("  next {what} {level:.2} {unit} ({ans})");
                Some(level)
            }
            Step::Last { level, why } => {
                self.level_event(pr, trial, level, Some(ans))?;
                self.events.sync()?;
                crate::errln!("  {why}");
                Some(level)
            }
        })
    }
}
