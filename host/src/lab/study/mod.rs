//! Studies on the rig session: `lmhost study run` presents a protocol's
//! conditions in seeded random order through a [`Session`] held in
//! process, runs the protocol's [`procedure`] while the stimulus repeats
//! (Experiment 3's method of adjustment), asks the questions after each
//! trial, and appends every finished trial to `trials.csv` before the next
//! one starts; `lmhost study report` summarises the answers.
//!
//! The files of a participant, in `OUT/ID/`: `trials.csv` (a row per
//! finished trial, whole lines, synced), `session.json` (the protocol's
//! text, seed, trial order with shown option orders, device, library
//! CRCs; written whole) and `events.jsonl` (every session event and the
//! runner's `trial` and `depth` or `level` lines). `--resume` continues at
//! the first trial not on disk, in the order `session.json` holds, after
//! [`start`] has checked every file and changed none; a staircase or
//! QUEST+ trial cut short continues after its logged answers
//! ([`midtrial`]). A signal during the set-up (planning, connecting,
//! uploading the library) ends the run before any file changed: nothing
//! to resume when it was new, the same point to resume from otherwise.
//!
//! By role: `protocol` (the file, checked), `design` (the seeded order),
//! `columns` (trials.csv's header, once), `answers` (what is asked, where
//! answers come from), `procedure`, `trial` (a trial's answers and row),
//! `record` (the files, read back checked), `start` (new or resumed), this
//! module's runner (presenting through the session), `report`.
//!
//! This module never parses flags or maps errors to exit codes; bad input
//! is an [`InputError`] (exit 2 in `main`).

pub mod analysis;
pub mod answers;
pub mod columns;
pub mod design;
mod ending;
pub mod figure;
pub mod live;
pub mod midtrial;
pub mod observer;
pub mod options;
pub mod outline;
pub mod procedure;
pub mod protocol;
pub mod provenance;
pub mod push;
pub mod record;
mod repeat;
pub mod report;
pub mod schema;
pub mod start;
#[cfg(test)]
pub(crate) mod test_files;
mod timing;
pub mod trial;

use std::time::Duration;

use crate::clock::monotonic_us;
use crate::error::InputError;
use crate::files::AppendLog;
use crate::lab::session::driver::{Driver, Finger};
use crate::lab::session::{Event, EventKind, OffsetReason, Present, Session};
use crate::plan::target::Target;
use crate::sense::stream::filter::Passthrough;

use answers::{Answers, Asked};
use columns::Row;
use design::Planned;
use protocol::Protocol;
use record::Expect;
use start::Start;

pub use options::{AnswerSource, FingerSource, RunOptions, RunReport, check_participant};

/// The device is polled at least this often while a trial runs.
pub const POLL: Duration = Duration::from_millis(1);
/// The synthetic finger's sample period (~90 Hz, a depth camera's rate).
pub const FINGER_PERIOD_US: u64 = 11_111;
/// Largest `--time-scale`.
pub const MAX_TIME_SCALE: f64 = 100.0;

/// The run was stopped by a signal ([`crate::stop::cause`] says which).
#[derive(Debug, thiserror::Error)]
#[error("interrupted")]
struct Interrupted;

/// Refuses a `--time-scale` outside above 0 to [`MAX_TIME_SCALE`].
pub fn check_time_scale(scale: f64) -> Result<(), InputError> {
    if !(scale.is_finite() && scale > 0.0 && scale <= MAX_TIME_SCALE) {
        crate::bad_input!(
            "--time-scale {}: give a factor above 0 and at most {MAX_TIME_SCALE}",
            crate::limits::show(scale)
        );
    }
    Ok(())
}

/// `lmhost study check`'s test of the timeline, the one `run` applies
/// before the device opens (its `timing` module), for the device kind
/// `target` the protocol will run on, or (`None`) every kind it may: `check`
/// has no port, and called "valid" a protocol whose on-phase `run` then
/// refused as shorter than half a step of a stimulus.
pub fn check_timeline(
    p: &Protocol,
    scene: Option<&std::path::Path>,
    scale: f64,
    target: Option<Target>,
) -> anyhow::Result<()> {
    check_time_scale(scale)?;
    let (scene, _) = provenance::load_scene(scene)?;
    let targets = match target {
        Some(t) => vec![t],
        None => Target::ALL.to_vec(),
    };
    timing::check_targets(p, &scene, scale, &targets)
}

/// Runs (or resumes) one participant's session.
pub fn run(mut o: RunOptions) -> anyhow::Result<RunReport> {
    // Graceful from the start: a signal during the set-up (planning,
    // connecting, uploading the library) ends it with its end lines, the
    // array silent and the folder as it was.
    crate::stop::graceful();
    check_participant(&o.participant)?;
    check_time_scale(o.time_scale)?;
    if o.hooks.answers.is_some() && o.answers != AnswerSource::Interactive {
        crate::bad_input!(
            "answers come either from the program or from --responses/--observer, not both"
        );
    }
    let p = Protocol::load(&o.protocol)?;
    let observer = observer::for_run(&o.answers, &p)?;
    if p.timeline.wait_for_finger && matches!(o.finger, FingerSource::None) {
        crate::bad_input!(
            "study protocol {}: the timeline waits for the finger: give --finger synthetic or a tracked source (--stream, --udp, --depth, --camera, --depth-stream)",
            o.protocol.display()
        );
    }
    // As in `lmhost session`: a tracked presentation without a finger
    // source would stay muted through every trial.
    if matches!(o.finger, FingerSource::None)
        && let Some(c) = p.conditions.iter().find(|c| {
            let untracked = p
                .library
                .entries
                .iter()
                .find(|e| e.id == c.stimulus)
                .is_some_and(|e| e.untracked);
            match p.timeline.gate {
                Some(g) => g == crate::lab::session::Gate::Tracked,
                None => !untracked,
            }
        })
    {
        crate::bad_input!(
            "study protocol {}: stimulus `{}` plays tracked, but there is no finger source, so every trial would stay muted: give --finger synthetic or a tracked source (--stream, --udp, --depth, --camera, --depth-stream), or set the timeline's gate = \"untracked\"",
            o.protocol.display(),
            c.stimulus
        );
    }
    if let Some(i) = &o.instruments {
        let Some(a) = &p.adjustment else {
            crate::bad_input!(
                "study protocol {}: --stage and --gauge run the method of adjustment ([adjustment]), which it has not",
                o.protocol.display()
            );
        };
        if tl_on_missing(&p) {
            crate::bad_input!(
                "study protocol {}: with --stage and --gauge every push lasts one on-phase: give the timeline's on_s",
                o.protocol.display()
            );
        }
        i.check(a.max_mm)?;
        crate::device::instruments::check_rig(&i.stage, &i.gauge)?;
    }
    crate::files::not_an_input("--out", &o.out)?;
    let paths = start::Paths::new(&o.out, &o.participant);
    // Everything is checked (and a responses file dry-run) before the
    // device opens and before any file changes.
    let mut st: Start = if o.resume {
        start::resume(&o, &p, &paths)?
    } else {
        start::fresh(&o, &p, &paths)?
    };
    let (scene, scene_record) = provenance::load_scene(o.scene.as_deref())?;
    let target = o.port.device()?;
    let plans = p.library.plan_for(&target.target(), &scene)?;
    timing::check(&p, &scene, Some(&plans), o.time_scale)?;
    crate::stop::check_set_up("planning the stimulus library")
        .map_err(|e| ending::set_up_stopped(&e, &o, "the device was not opened"))?;
    let mut warned = std::collections::BTreeSet::new();
    for w in plans.iter().flat_map(|x| &x.warnings) {
        if warned.insert(w.clone()) {
            crate::errln!("warning: {w}");
        }
    }
    let first = st.done + 1;
    // The stage at rest before the array can sound.
    let pusher = o.instruments.clone().map(push::Pusher::start).transpose()?;
    let dev = crate::device::connect::open(&o.port, &scene)?;
    let where_ = dev.describe();
    let session = match Session::new(dev, &p.library, plans, scene, crate::clock::Clock::real()) {
        Ok(s) => s,
        Err(e) => {
            // The stage goes back to rest, whatever ended the set-up.
            let stage_end = pusher.map(push::Pusher::finish);
            if let Some(i) = e.downcast_ref::<crate::stop::SetUpInterrupted>() {
                let then = match stage_end {
                    Some(end) => format!("the array is silent ({end})"),
                    None => "the array is silent".to_owned(),
                };
                return Err(ending::set_up_stopped(i, &o, &then));
            }
            return Err(crate::device::backend::port_context(
                e,
                &where_,
                "starting the session",
                || format!("starting the session on {where_}"),
            ));
        }
    };
    let mut this_run = provenance::run_record(&session, first, &o, scene_record)?;
    // A resumed session continues on the rig it ran on, or says what
    // differs (before any file changes; the array has not sounded).
    if let Err(e) = provenance::check_rig(&st.file.runs, &mut this_run, o.resume_anyway) {
        drop(session.close(OffsetReason::Quit));
        return Err(e.into());
    }
    let view = match o.view {
        Some(addr) => Some(live::start_view(addr, &session, &o.finger)?),
        None => None,
    };
    // `--responses -` answers each question as it is asked, from stdin.
    let answers: Box<dyn Answers> = if let Some(own) = o.hooks.answers.take() {
        own
    } else if let Some(obs) = observer {
        Box::new(obs)
    } else if o.answers == AnswerSource::File("-".into()) {
        Box::new(answers::Piped::named("--responses -")?)
    } else {
        live::answer_source(st.lines.take(), view.as_ref())?
    };
    st.file.runs.push(this_run);
    // session.json first: a run stopped before its trials.csv header is
    // still resumable.
    let _made = crate::files::output_dir("--out", &paths.dir)?;
    crate::files::write_whole(&paths.session, &serde_json::to_vec_pretty(&st.file)?)?;
    let mut trials_log = st.open_trials(&p, &paths.trials)?;
    let events_log = st.open_events(o.resume, &paths.events)?;
    let (file, plan, resumed) = (st.file, st.plan, st.resumed);
    let driver = match std::mem::replace(&mut o.finger, FingerSource::None) {
        FingerSource::Samples {
            feed,
            intake,
            filter,
            ..
        } => Driver::new(session, Finger::Samples(Box::new(feed), *intake), filter),
        // Off the array until a trial waits for it.
        FingerSource::Synthetic => {
            Driver::new(session, Finger::Synthetic, Box::new(Passthrough)).lifted()
        }
        FingerSource::None => Driver::new(session, Finger::None, Box::new(Passthrough)),
    };
    let mut r = Runner {
        driver: Some(driver),
        events: events_log,
        answers,
        finger_present: None,
        scale: o.time_scale,
        trial_events: Vec::new(),
        all_events: Vec::new(),
        view,
        pusher,
        dir: paths.dir.clone(),
        resumed,
    };
    let mut report = RunReport {
        dir: paths.dir.clone(),
        trials: plan.len(),
        first,
        seed: file.seed,
        ..RunReport::default()
    };
    crate::errln!(
        "lmhost: study `{}`, participant {}: {} trials (seed {}){} on {where_}",
        p.name,
        o.participant,
        plan.len(),
        file.seed,
        if first > 1 {
            format!(", resuming at trial {first}")
        } else {
            String::new()
        }
    );
    let expect = Expect::of(&p, &o.participant);
    let mut rows = o.hooks.rows.take();
    let result = run_trials(
        &mut r,
        &p,
        &expect,
        &plan,
        first,
        &mut trials_log,
        &mut report,
        &mut rows,
    );
    let reason = match &result {
        Ok(()) => OffsetReason::Finished,
        Err(e) if e.is::<Interrupted>() => OffsetReason::stopped(),
        Err(_) => OffsetReason::Error,
    };
    let last = r.driver.take().map(|d| d.close(reason)).unwrap_or_default();
    // The array is silent; now the stage goes back (or says where it is).
    let stage_end = r.pusher.take().map(push::Pusher::finish);
    let result = match (result, stage_end) {
        (Err(e), Some(end)) if e.is::<push::InstrumentFailed>() => {
            Err(anyhow::anyhow!("{} ({end})", crate::error::one_line(&e)))
        }
        (Err(e), Some(end)) if e.is::<Interrupted>() => {
            Err(anyhow::anyhow!("{} ({end})", crate::stop::interrupted()))
        }
        (r, Some(end)) if !end.starts_with("stage back") => {
            crate::errln!("warning: {end}");
            r
        }
        (r, _) => r,
    };
    let logged = r.log_events(last).and_then(|()| Ok(r.events.sync()?));
    for l in r.all_events.iter() {
        match &l.kind {
            EventKind::Switch { latency_ms, .. } => report.switch_ms.push(*latency_ms),
            EventKind::Preloaded { seconds, .. } => {
                report.uploads += 1;
                report.upload_mean_s += seconds;
            }
            _ => {}
        }
    }
    if report.uploads > 0 {
        report.upload_mean_s /= report.uploads as f64;
    }
    if let Err(e) = result {
        let interrupted = e.is::<Interrupted>();
        return Err(ending::stopped(e, interrupted, &o, &report, &paths.trials));
    }
    logged?;
    Ok(report)
}

fn tl_on_missing(p: &Protocol) -> bool {
    p.timeline.on_s.is_none()
}

/// Runs trials `first..` of `plan`, each row on disk (and given to
/// `rows`) before the next.
#[allow(clippy::too_many_arguments)]
fn run_trials(
    r: &mut Runner,
    p: &Protocol,
    expect: &Expect,
    plan: &[Planned],
    first: usize,
    trials_log: &mut AppendLog,
    report: &mut RunReport,
    rows: &mut Option<Box<dyn FnMut(options::RowFields) + Send>>,
) -> anyhow::Result<()> {
    r.drain()?;
    if let Some(t) = plan.get(first - 1) {
        r.session().prepare(&t.stimulus)?;
        r.drain()?;
    }
    for (i, t) in plan.iter().enumerate().skip(first - 1) {
        let t0 = monotonic_us();
        let block = t.block.checked_sub(1).and_then(|b| p.blocks.get(b));
        if let Some(b) = block
            && (i + 1 == first || plan[i - 1].block != t.block)
        {
            r.log(serde_json::json!({
                "event": "block", "block": b.name, "practice": b.practice,
                "trials": b.trials(),
            }))?;
            crate::errln!(
                "block `{}`{}: {} trials{}",
                b.name,
                if b.practice { " (practice)" } else { "" },
                b.trials(),
                b.text
                    .as_ref()
                    .map(|x| format!(": {x}"))
                    .unwrap_or_default()
            );
        }
        let (row, presented) = r.trial(p, expect, t, plan.get(i + 1))?;
        let fields = p.columns.fields(&row).map_err(|m| anyhow::anyhow!(m))?;
        trials_log.line(&record::line(&fields))?;
        trials_log.sync()?;
        r.events.sync()?;
        if let Some(f) = rows {
            let names = p.columns.names().into_iter().map(str::to_owned);
            f(names.zip(fields).collect());
        }
        report.ran += 1;
        report
            .trial_s
            .push(monotonic_us().saturating_sub(t0) as f64 / 1e6);
        report.presented_s.push(presented);
        if let Some(next) = plan.get(i + 1) {
            // A block's break, the array silent, before the next block.
            if let Some(b) = block.filter(|b| b.break_s > 0.0 && next.block != t.block) {
                r.log(serde_json::json!({
                    "event": "break", "block": b.name, "s": b.break_s * r.scale,
                }))?;
                crate::errln!("break: {} s", crate::limits::show(b.break_s * r.scale));
                r.wait(b.break_s * r.scale)?;
            }
            r.wait(p.timeline.iti_s * r.scale)?;
        }
    }
    Ok(())
}

struct Runner {
    /// The session and the finger, turned by the study's loop.
    driver: Option<Driver>,
    events: AppendLog,
    answers: Box<dyn Answers>,
    finger_present: Option<bool>,
    scale: f64,
    trial_events: Vec<Event>,
    all_events: Vec<Event>,
    view: Option<crate::lab::view::View>,
    /// The stage and gauge, when Experiment 3 runs with them.
    pusher: Option<push::Pusher>,
    /// The participant's folder (the gauge's series go there).
    dir: std::path::PathBuf,
    /// The answers the first trial run had taken when a run was cut
    /// short (`start::Start::resumed`); taken by that trial.
    resumed: Vec<(String, f64)>,
}

impl Runner {
    fn driver(&mut self) -> &mut Driver {
        self.driver
            .as_mut()
            .expect("the session is open until the end")
    }

    fn session(&mut self) -> &mut Session {
        self.driver().session()
    }

    fn log_events(&mut self, events: Vec<Event>) -> anyhow::Result<()> {
        if let Some(v) = &self.view {
            v.events(&events);
        }
        for e in events {
            self.events.line(&serde_json::to_string(&e)?)?;
            if let EventKind::Finger { present } = e.kind {
                self.finger_present = Some(present);
            }
            if matches!(
                e.kind,
                EventKind::Switch { .. } | EventKind::Preloaded { .. }
            ) {
                self.all_events.push(e.clone());
            }
            self.trial_events.push(e);
        }
        Ok(())
    }

    fn log(&mut self, v: serde_json::Value) -> anyhow::Result<()> {
        let mut m = serde_json::Map::new();
        m.insert("t_host_us".into(), monotonic_us().into());
        if let serde_json::Value::Object(o) = v {
            m.extend(o);
        }
        self.events
            .line(&serde_json::Value::Object(m).to_string())?;
        Ok(())
    }

    fn drain(&mut self) -> anyhow::Result<()> {
        let e = self.session().drain_events();
        self.log_events(e)
    }

    /// One turn of the session's driver (the finger when due, the
    /// timelines, the device's housekeeping), its events to the log, a
    /// stop request.
    fn tick(&mut self) -> anyhow::Result<()> {
        if crate::stop::requested() {
            return Err(Interrupted.into());
        }
        if let Some(p) = self.pusher.as_mut() {
            p.check()?;
        }
        let events = self.driver().turn()?;
        // The finger as sent to the device, to the view.
        if let (Some(p), Some(v)) = (self.driver().take_finger(), &self.view) {
            v.finger(p);
        }
        if self.driver().feed_ended() {
            return Err(
                InputError::new("the finger's centroid stream ended before the session").into(),
            );
        }
        self.log_events(events)
    }

    /// Waits until the driver's next turn, at most [`POLL`] (answers and
    /// the finger are looked at that often).
    fn pause(&mut self) {
        self.driver().wait(POLL);
    }

    fn touch(&mut self, on: bool) -> anyhow::Result<()> {
        self.driver().touch(on)?;
        self.tick()
    }

    /// Keeps the device served for `s` seconds.
    fn wait(&mut self, s: f64) -> anyhow::Result<()> {
        let until = monotonic_us() + (s * 1e6) as u64;
        loop {
            self.tick()?;
            if monotonic_us() >= until {
                return Ok(());
            }
            self.pause();
        }
    }

    /// The answer to `q` and its response time, s. An answer already
    /// there (a responses file's, a click made) is taken before the
    /// session turns again: a turn may pass the end of an off-phase, and a
    /// process running late would otherwise play another on-phase before
    /// an answer that came in time.
    fn ask(&mut self, q: &Asked) -> anyhow::Result<(String, f64)> {
        let asked = monotonic_us();
        loop {
            if let Some(a) = self.answers.poll(q)? {
                return Ok((a, monotonic_us().saturating_sub(asked) as f64 / 1e6));
            }
            self.tick()?;
            self.pause();
        }
    }

    /// Runs trial `t` (the first one's procedure continuing after the
    /// answers of a run cut short, [`Runner::resumed`]) and returns its
    /// row and host-timed on-time.
    fn trial(
        &mut self,
        p: &Protocol,
        expect: &Expect,
        t: &Planned,
        next: Option<&Planned>,
    ) -> anyhow::Result<(Row, f64)> {
        let tl = &p.timeline;
        let resumed = std::mem::take(&mut self.resumed);
        self.trial_events.clear();
        let mut line = serde_json::json!({
            "event": "trial", "trial": t.trial, "set": t.set, "stimulus": t.stimulus,
        });
        if !resumed.is_empty() {
            line["resumed_presentations"] = resumed.len().into();
        }
        self.log(line)?;
        // The participant may see this line: the stimulus is in the
        // event log only.
        crate::errln!("trial {}/{} (set {})", t.trial, p.trials(), t.set);
        let time_utc = provenance::now_utc();
        let before = self.session().device_counters().ok();
        if tl.wait_for_finger {
            self.touch(true)?;
            while self.finger_present != Some(true) {
                self.tick()?;
                self.pause();
            }
        }
        let mut procedure = procedure::start(p, t);
        if let Some(pr) = procedure.as_deref_mut().filter(|_| !resumed.is_empty()) {
            // `start::resume` checked the same replay.
            midtrial::replay(pr, &resumed).map_err(anyhow::Error::msg)?;
            crate::errln!("  resumed after {} presentations", resumed.len());
        }
        // With the instruments, each push of the adjustment is one
        // on-phase of its own.
        let pushing = p.adjustment.is_some() && self.pusher.is_some();
        let on_s = tl.on_s.map(|s| s * self.scale);
        let mut req = Present {
            // A resumed procedure continues at its own level.
            stimulus: procedure
                .as_deref()
                .and_then(|pr| pr.next())
                .map_or_else(|| t.stimulus.clone(), |n| n.stimulus),
            gate: tl.gate,
            on_s,
            off_s: Some(tl.off_s * self.scale),
            repeat: Some(match (pushing, procedure.is_some()) {
                (true, _) => 1,
                (false, true) => crate::lab::session::MAX_REPEAT,
                (false, false) => tl.repeat,
            }),
        };
        if !pushing {
            self.session().present(&req)?;
            // A new play forgets old centroids: track again at once.
            self.driver().track_now()?;
        }
        let t_on = monotonic_us();
        let touch_until = t_on + (tl.touch_s * self.scale * 1e6) as u64;
        let mut rts = Vec::new();
        let mut measured = None;
        if let Some(pr) = procedure.as_deref_mut() {
            if pushing {
                if let Some(first) = pr.next() {
                    let (what, unit) = pr.level_unit();
                    crate::errln!("  {what} {:.2} {unit}", first.level);
                    self.level_event(pr, t.trial, first.level, None)?;
                }
                let off_s = tl.off_s * self.scale;
                measured = Some(self.pushes(pr, &req, off_s, t.trial, &mut rts)?);
                if self.session().presenting() {
                    self.session().stop(OffsetReason::Stop)?;
                }
            } else {
                self.follow(pr, t, &mut req, &mut rts)?;
            }
        } else {
            while self.session().presenting() {
                self.tick()?;
                if tl.while_touching {
                    if self.driver().synthetic() && monotonic_us() >= touch_until {
                        self.touch(false)?;
                    }
                    if self.finger_present == Some(false) {
                        self.session().stop(OffsetReason::Stop)?;
                    }
                }
                self.pause();
            }
        }
        self.drain()?;
        // Over the presentation: the answers that follow play nothing.
        let after = self.session().device_counters().ok();
        let health = trial::Health {
            time_utc,
            missed_deadlines: before.zip(after).map(|(b, a)| a.0.wrapping_sub(b.0)),
            lease_expiries: before.zip(after).map(|(b, a)| a.1.wrapping_sub(b.1)),
        };
        self.touch(false)?;
        // The next stimulus loads while the participant answers.
        if let Some(n) = next {
            self.session().prepare(&n.stimulus)?;
            self.drain()?;
        }
        let timing_events = std::mem::take(&mut self.trial_events);
        let given = trial::ask_each(p, t, |q| self.ask(q))?;
        self.trial_events = timing_events;
        self.drain()?;
        let timing = self
            .session()
            .loaded()
            .iter()
            .find(|l| l.id == t.stimulus)
            .map(|l| l.planned.timing.clone());
        let (mut row, presented) = trial::row(
            expect,
            t,
            &self.trial_events,
            timing.as_ref(),
            &health,
            &given,
            procedure.as_deref(),
        );
        if p.adjustment.is_some() {
            let rts: Vec<String> = rts.iter().map(|s| format!("{s:.4}")).collect();
            row.set(
                columns::ADJUST_RT,
                rts.join(&columns::LIST_SEPARATOR.to_string()),
            );
        }
        if let Some(m) = measured {
            // The series first: a row never names a force whose series is
            // missing.
            let name = format!("force-trial-{:03}.csv", t.trial);
            crate::files::write_whole(&self.dir.join(&name), m.csv().as_bytes())?;
            let median = m.series.median_n().unwrap_or(0.0).max(0.0);
            row.set(columns::FORCE, format!("{median:.3}"));
            crate::errln!("  force {median:.3} N (series in {name})");
        }
        Ok((row, presented))
    }
}
