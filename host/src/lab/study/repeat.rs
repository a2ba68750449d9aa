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

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use lm_proto::{Centroid, PlayAt, SelfTest, Status};

    use super::*;
    use crate::clock::Clock;
    use crate::device::backend::{Backend, BackendInfo, CentroidOutcome, Result, UploadReport};
    use crate::lab::session::driver::{Driver, Finger};
    use crate::lab::session::{Gate, Session};
    use crate::lab::study::answers::Lines;
    use crate::lab::study::procedure::Adjustment;
    use crate::lab::study::protocol;
    use crate::plan::library::Library;
    use crate::plan::scene::Scene;
    use crate::plan::sequence::Plan;
    use crate::plan::target::Target;
    use crate::sense::stream::filter::Passthrough;

    /// The simulated LM device behind a link whose every centroid takes
    /// `lag` to answer (a busy host or a slow serial line): each turn of
    /// the loop that feeds the finger moves the clock on by that much.
    struct Slow {
        dev: Box<dyn Backend>,
        clock: Clock,
        lag: Duration,
    }

    impl Backend for Slow {
        fn describe(&self) -> String {
            self.dev.describe()
        }
        fn info(&mut self) -> Result<BackendInfo> {
            self.dev.info()
        }
        fn status(&mut self) -> Result<Status> {
            self.dev.status()
        }
        fn upload(&mut self, plan: &Plan, slot: Option<u8>) -> Result<UploadReport> {
            self.dev.upload(plan, slot)
        }
        fn play_at(&mut self, slot: u8, at: PlayAt, untracked: bool) -> Result<()> {
            self.dev.play_at(slot, at, untracked)
        }
        fn play_for(&mut self, slot: u8, untracked: bool, steps: u32) -> Result<()> {
            self.dev.play_for(slot, untracked, steps)
        }
        fn stop(&mut self) -> Result<()> {
            self.dev.stop()
        }
        fn centroid(&mut self, c: &Centroid) -> Result<CentroidOutcome> {
            let r = self.dev.centroid(c);
            self.clock.advance(self.lag);
            r
        }
        fn tick(&mut self) -> Result<()> {
            self.dev.tick()
        }
        fn self_test(&mut self) -> Result<SelfTest> {
            self.dev.self_test()
        }
        fn replaces_queued(&self) -> bool {
            self.dev.replaces_queued()
        }
    }

    const LIB: &str = "[[stimulus]]\nid = \"a\"\nradius = 3\nfreq = 25\nstep = 1.0\n";

    /// A runner over the simulated device behind a link slow by `lag`,
    /// with the synthetic finger on the array and `answers` scripted; its
    /// folder goes when the guard beside it drops.
    fn runner(name: &str, lag: Duration, answers: &str) -> (Runner, crate::files::Scratch) {
        let clock = Clock::manual_at_us(1_000_000);
        let (sim, _) = crate::device::connect::simulated(clock.clone()).unwrap();
        let dev = Box::new(Slow {
            dev: Box::new(sim),
            clock: clock.clone(),
            lag,
        });
        let lib = Library::from_toml(LIB, "test").unwrap();
        let plans = lib.plan_for(&Target::Lm, &Scene::default()).unwrap();
        let s = Session::new(dev, &lib, plans, Scene::default(), clock).unwrap();
        let scratch = crate::lab::study::test_files::scratch(name);
        let dir = scratch.to_path_buf();
        let r = Runner {
            driver: Some(Driver::new(s, Finger::Synthetic, Box::new(Passthrough))),
            events: crate::files::AppendLog::create(&dir.join("events.jsonl")).unwrap(),
            answers: Box::new(Lines::from_text("answers".into(), answers)),
            finger_present: None,
            scale: 1.0,
            trial_events: Vec::new(),
            all_events: Vec::new(),
            view: None,
            pusher: None,
            dir,
            resumed: Vec::new(),
        };
        (r, scratch)
    }

    fn adjustment() -> Adjustment {
        let spec = protocol::Adjustment {
            text: String::new(),
            start_mm: 4.0,
            step_mm: 0.25,
            max: 20,
            min_mm: 0.0,
            max_mm: 10.0,
            stronger: "stronger".into(),
            weaker: "weaker".into(),
            same: "same".into(),
        };
        Adjustment::new(&spec, "a")
    }

    fn count(r: &Runner, f: fn(&EventKind) -> bool) -> usize {
        r.trial_events.iter().filter(|e| f(&e.kind)).count()
    }

    /// Each turn of the loop takes longer than the off-phase (the process
    /// runs late): a scripted answer, there as soon as it is asked, still
    /// answers the on-phase that just ended, before the next one starts:
    /// one on-phase per answer, as on an idle machine.
    #[test]
    fn a_late_loop_plays_one_on_phase_per_scripted_answer() {
        for (answers, phases) in [
            ("same", 1),
            ("stronger\nsame", 2),
            ("weaker\nweaker\nsame", 3),
        ] {
            let (mut r, _dir) = runner("late-loop", Duration::from_millis(30), answers);
            let mut req = Present {
                stimulus: "a".into(),
                gate: Some(Gate::Untracked),
                on_s: Some(0.04),
                off_s: Some(0.02),
                repeat: Some(crate::lab::session::MAX_REPEAT),
            };
            r.session().present(&req).unwrap();
            let t = Planned {
                trial: 1,
                set: 1,
                block: 1,
                practice: false,
                condition: 0,
                stimulus: "a".into(),
                orders: Vec::new(),
            };
            let mut pr = adjustment();
            let mut rts = Vec::new();
            r.follow(&mut pr, &t, &mut req, &mut rts).unwrap();
            r.drain().unwrap();
            assert!(pr.finished(), "{answers}");
            assert_eq!(rts.len(), phases, "{answers}");
            let onsets = count(&r, |k| matches!(k, EventKind::Onset { .. }));
            let offsets = count(&r, |k| matches!(k, EventKind::Offset { .. }));
            assert_eq!((onsets, offsets), (phases, phases), "{answers}");
            assert!(!r.session().presenting());
        }
    }
}
