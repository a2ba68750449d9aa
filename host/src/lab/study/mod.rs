//! Studies on the rig session: `lmhost study run` presents a protocol's
//! conditions in seeded random order through a [`Session`] held in
//! process, asks the questions after each trial (or runs Experiment 3's
//! method of adjustment while the stimulus repeats), and appends every
//! finished trial to `trials.csv` before the next one starts;
//! `lmhost study report` summarises the answers.
//!
//! The files of a participant, in `OUT/ID/`: `trials.csv` (a row per
//! finished trial, whole lines, synced), `session.json` (the protocol's
//! text, seed, trial order with shown option orders, device, library
//! CRCs; written whole) and `events.jsonl` (every session event and the
//! runner's `trial` and `depth` lines). `--resume` continues at the first
//! trial not on disk, in the order `session.json` holds.
//!
//! This module never parses flags or maps errors to exit codes; bad input
//! is an [`InputError`] (exit 2 in `main`).

pub mod answers;
pub mod design;
pub mod protocol;
pub mod record;
pub mod report;

use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::clock::monotonic_us;
use crate::device::link::PortSpec;
use crate::error::InputError;
use crate::files::AppendLog;
use crate::lab::session::driver::{Driver, Finger};
use crate::lab::session::{Event, EventKind, OffsetReason, Present, Session};
use crate::plan::scene::Scene;
use crate::sense::stream::filter::Passthrough;

use answers::{Answers, Asked};
use design::Planned;
use protocol::Protocol;
use record::{Run, SessionFile};

/// The device is polled at least this often while a trial runs.
pub const POLL: Duration = Duration::from_millis(1);
/// The synthetic finger's sample period (~90 Hz, a depth camera's rate).
pub const FINGER_PERIOD_US: u64 = 11_111;
/// Largest `--time-scale`.
pub const MAX_TIME_SCALE: f64 = 100.0;

/// Where the finger comes from.
pub enum FingerSource {
    /// None: the protocol may not wait for the finger.
    None,
    /// A finger at the scene's centre that touches for each trial and
    /// leaves between trials.
    Synthetic,
    /// Tracked centroids (a file, stdin, UDP: `lmhost track --json`'s
    /// lines) through a filter; the finger is present when they say so.
    Samples {
        /// The reader thread.
        feed: crate::sense::stream::run::Threaded,
        /// The centroid filter.
        filter: Box<dyn crate::sense::stream::filter::Filter + Send>,
        /// What it is, for `session.json`.
        name: String,
    },
}

impl FingerSource {
    fn name(&self) -> String {
        match self {
            Self::None => "none".into(),
            Self::Synthetic => "synthetic".into(),
            Self::Samples { name, .. } => name.clone(),
        }
    }
}

impl std::fmt::Debug for FingerSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

/// Where answers come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum AnswerSource {
    /// A file of one answer per line in the order asked (`-`: stdin).
    File(PathBuf),
    /// The terminal (single keys) when stdin is one, else stdin's lines as
    /// they arrive.
    Interactive,
}

/// What `lmhost study run` was asked to do.
#[derive(Debug)]
pub struct RunOptions {
    /// The protocol file.
    pub protocol: PathBuf,
    /// The device.
    pub port: PortSpec,
    /// The scene file (default: the built-in scene).
    pub scene: Option<PathBuf>,
    /// The participant's id (a folder name).
    pub participant: String,
    /// The study's output folder.
    pub out: PathBuf,
    /// The order's seed (default: from the clock; recorded).
    pub seed: Option<u64>,
    /// Answers.
    pub answers: AnswerSource,
    /// The finger.
    pub finger: FingerSource,
    /// Multiplies every duration.
    pub time_scale: f64,
    /// Continue an interrupted run.
    pub resume: bool,
}

/// What a run did.
#[derive(Debug, Clone, Default)]
pub struct RunReport {
    /// The participant's folder.
    pub dir: PathBuf,
    /// Trials in the session.
    pub trials: usize,
    /// The first trial this run presented (1-based).
    pub first: usize,
    /// Trials this run finished.
    pub ran: usize,
    /// The seed.
    pub seed: u64,
    /// Seconds each trial took from its start to its row on disk.
    pub trial_s: Vec<f64>,
    /// Host-timed on-time per trial, s.
    pub presented_s: Vec<f64>,
    /// Switch latencies seen, ms.
    pub switch_ms: Vec<f64>,
    /// Uploads during the run (`preloaded` events) and their mean time, s.
    pub uploads: usize,
    /// Mean upload time, s.
    pub upload_mean_s: f64,
}

/// A participant id: 1 to 64 letters, digits, `-`, `_`, `.` (not only dots).
pub fn check_participant(id: &str) -> Result<(), InputError> {
    if id.is_empty()
        || id.len() > 64
        || id.chars().all(|c| c == '.')
        || !id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
    {
        return Err(InputError::new(format!(
            "--participant `{}`: give 1 to 64 letters, digits, `-`, `_` or `.` (it names a folder)",
            id.escape_debug()
        )));
    }
    Ok(())
}

fn unix_s() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

fn resume_hint(o: &RunOptions) -> String {
    format!(
        "lmhost study run {} --participant {} --out {} --resume (and the same --port, --finger and --responses)",
        o.protocol.display(),
        o.participant,
        o.out.display()
    )
}

/// The run was stopped by Ctrl-C / SIGTERM.
#[derive(Debug, thiserror::Error)]
#[error("interrupted")]
struct Interrupted;

/// Runs (or resumes) one participant's session.
pub fn run(mut o: RunOptions) -> anyhow::Result<RunReport> {
    check_participant(&o.participant)?;
    if !(o.time_scale.is_finite() && o.time_scale > 0.0 && o.time_scale <= MAX_TIME_SCALE) {
        crate::bad_input!(
            "--time-scale {}: give a factor above 0 and at most {MAX_TIME_SCALE}",
            crate::limits::show(o.time_scale)
        );
    }
    let p = Protocol::load(&o.protocol)?;
    if p.timeline.wait_for_finger && matches!(o.finger, FingerSource::None) {
        crate::bad_input!(
            "study protocol {}: the timeline waits for the finger: give --finger synthetic or a tracked source (--stream, --udp)",
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
            "study protocol {}: stimulus `{}` plays tracked, but there is no finger source, so every trial would stay muted: give --finger synthetic or a tracked source (--stream, --udp), or set the timeline's gate = \"untracked\"",
            o.protocol.display(),
            c.stimulus
        );
    }
    let dir = o.out.join(&o.participant);
    let session_path = dir.join("session.json");
    let trials_path = dir.join("trials.csv");
    let events_path = dir.join("events.jsonl");
    let header = record::header(&p);
    let (mut file, plan) = if o.resume {
        let text = std::fs::read_to_string(&session_path).map_err(|e| {
            InputError::new(format!(
                "--resume: cannot read {}: {} (nothing to resume; run without --resume)",
                session_path.display(),
                crate::files::reason(&e)
            ))
        })?;
        let f: SessionFile = serde_json::from_str(&text)
            .map_err(|e| InputError::new(format!("--resume: {}: {e}", session_path.display())))?;
        if f.protocol != p.text {
            crate::bad_input!(
                "--resume: {} was written for another protocol (`{}`); {} differs",
                session_path.display(),
                f.protocol_name,
                o.protocol.display()
            );
        }
        if f.participant != o.participant {
            crate::bad_input!(
                "--resume: {} belongs to participant `{}`, not `{}`",
                session_path.display(),
                f.participant,
                o.participant
            );
        }
        if let Some(s) = o.seed
            && s != f.seed
        {
            crate::bad_input!(
                "--resume: the session's seed is {}, not --seed {s} (leave --seed out)",
                f.seed
            );
        }
        let plan = design::plan(&p, f.seed);
        if plan != f.trials {
            crate::bad_input!(
                "--resume: {}'s trial order does not follow from its seed",
                session_path.display()
            );
        }
        (f, plan)
    } else {
        if std::fs::read_dir(&dir).is_ok_and(|mut d| d.next().is_some()) {
            crate::bad_input!(
                "{} is not empty: give --resume to continue that session, or another --participant / --out",
                dir.display()
            );
        }
        let seed = o.seed.unwrap_or_else(design::clock_seed);
        let plan = design::plan(&p, seed);
        let f = SessionFile {
            protocol_name: p.name.clone(),
            protocol_file: o.protocol.display().to_string(),
            protocol: p.text.clone(),
            library_file: p.library_path.display().to_string(),
            participant: o.participant.clone(),
            seed,
            question_order: p.questions.iter().map(|q| q.id.clone()).collect(),
            columns: record::columns(&p),
            trials: plan.clone(),
            runs: Vec::new(),
        };
        (f, plan)
    };
    // A responses file is read (and checked to exist) before the device
    // opens.
    let lines = match &o.answers {
        AnswerSource::File(path) => Some(answers::Lines::open(path)?),
        AnswerSource::Interactive => None,
    };
    if let Some(l) = &lines
        && !o.resume
    {
        answers::dry_run(&p, &plan, &mut l.clone())?;
    }
    let scene = Scene::load_or_default(o.scene.as_deref())?;
    let target = o.port.device()?;
    let plans = p.library.plan_for(&target.target(), &scene)?;
    let mut warned = std::collections::BTreeSet::new();
    for w in plans.iter().flat_map(|x| &x.warnings) {
        if warned.insert(w.clone()) {
            crate::errln!("warning: {w}");
        }
    }
    crate::files::output_dir("--out", &dir)?;
    // The rows already on disk (a torn last line dropped).
    let (mut trials_log, done) = if o.resume {
        let (log, lines) = AppendLog::open(&trials_path)?;
        let rows = record::check_rows(&lines, &header, &plan, &trials_path.display().to_string())
            .map_err(InputError::new)?;
        (log, rows)
    } else {
        (AppendLog::create(&trials_path)?, Vec::new())
    };
    if done.is_empty() && o.resume {
        // A run killed before its header: start the file again.
        trials_log = AppendLog::create(&trials_path)?;
    }
    if done.is_empty() {
        trials_log.line(&record::line(&header))?;
        trials_log.sync()?;
    }
    let answers: Box<dyn Answers> = match lines {
        Some(mut l) => {
            l.skip(
                done.iter()
                    .map(|r| record::answers_used(&p, &header, r))
                    .sum(),
            );
            if o.resume {
                answers::dry_run(&p, &plan[done.len()..], &mut l.clone())?;
            }
            Box::new(l)
        }
        None if nix::unistd::isatty(std::io::stdin()).unwrap_or(false) => {
            Box::new(answers::Terminal::open()?)
        }
        None => Box::new(answers::Piped::open()?),
    };
    let events_log = if o.resume {
        AppendLog::open(&events_path)?.0
    } else {
        AppendLog::create(&events_path)?
    };
    let first = done.len() + 1;
    let dev = crate::device::connect::open(&o.port, &scene)?;
    let where_ = dev.describe();
    let session = Session::new(dev, &p.library, plans, scene, crate::clock::Clock::real())
        .map_err(|e| e.context(format!("starting the session on {where_}")))?;
    file.runs.push(Run {
        started_unix_s: unix_s(),
        first_trial: first,
        lmhost_version: env!("CARGO_PKG_VERSION").into(),
        device: serde_json::to_value(session.info())?,
        library: session
            .loaded()
            .iter()
            .map(|l| {
                serde_json::json!({
                    "id": l.id,
                    "crc32": format!("{:08x}", l.crc32),
                    "timing": l.planned.timing,
                })
            })
            .collect(),
        time_scale: o.time_scale,
        finger: o.finger.name(),
    });
    crate::files::write_whole(&session_path, &serde_json::to_vec_pretty(&file)?)?;
    crate::stop::graceful();
    let driver = match std::mem::replace(&mut o.finger, FingerSource::None) {
        FingerSource::Samples { feed, filter, .. } => {
            Driver::new(session, Finger::Samples(Box::new(feed)), filter)
        }
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
    };
    let mut report = RunReport {
        dir: dir.clone(),
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
    let result = (|| -> anyhow::Result<()> {
        r.drain()?;
        if let Some(t) = plan.get(first - 1) {
            r.session().prepare(&t.stimulus)?;
            r.drain()?;
        }
        for (i, t) in plan.iter().enumerate().skip(first - 1) {
            let t0 = monotonic_us();
            let (row, presented) = r.trial(&p, t, plan.get(i + 1))?;
            trials_log.line(&record::line(&row))?;
            trials_log.sync()?;
            r.events.sync()?;
            report.ran += 1;
            report
                .trial_s
                .push(monotonic_us().saturating_sub(t0) as f64 / 1e6);
            report.presented_s.push(presented);
            if i + 1 < plan.len() {
                r.wait(p.timeline.iti_s * r.scale)?;
            }
        }
        Ok(())
    })();
    let reason = match &result {
        Ok(()) => OffsetReason::Quit,
        Err(e) if e.is::<Interrupted>() => OffsetReason::Quit,
        Err(_) => OffsetReason::Error,
    };
    let last = r
        .driver
        .take()
        .map(|d| d.into_session().close(reason))
        .unwrap_or_default();
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
        let done = first - 1 + report.ran;
        let what = if e.is::<Interrupted>() {
            "interrupted".to_owned()
        } else {
            crate::error::one_line(&e)
        };
        let kept = if done == 0 {
            "no trial is finished".to_owned()
        } else {
            format!(
                "trials 1..={done} of {} are in {}",
                plan.len(),
                trials_path.display()
            )
        };
        let msg = format!(
            "{what}; the array is silent; {kept}; continue with: {}",
            resume_hint(&o)
        );
        return Err(if e.chain().any(|c| c.is::<InputError>()) {
            InputError::new(msg).into()
        } else {
            anyhow::anyhow!(msg)
        });
    }
    logged?;
    Ok(report)
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
        let events = self.driver().turn()?;
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

    fn ask(&mut self, q: &Asked) -> anyhow::Result<String> {
        loop {
            self.tick()?;
            if let Some(a) = self.answers.poll(q)? {
                return Ok(a);
            }
            self.pause();
        }
    }

    /// Runs trial `t` and returns its row and host-timed on-time.
    fn trial(
        &mut self,
        p: &Protocol,
        t: &Planned,
        next: Option<&Planned>,
    ) -> anyhow::Result<(Vec<String>, f64)> {
        let tl = &p.timeline;
        self.trial_events.clear();
        self.log(serde_json::json!({
            "event": "trial", "trial": t.trial, "set": t.set, "stimulus": t.stimulus,
        }))?;
        crate::errln!(
            "trial {}/{} (set {}): {}",
            t.trial,
            p.trials(),
            t.set,
            t.stimulus
        );
        if tl.wait_for_finger {
            self.touch(true)?;
            while self.finger_present != Some(true) {
                self.tick()?;
                self.pause();
            }
        }
        let adjusting = p.adjustment.is_some();
        let on_s = tl.on_s.map(|s| s * self.scale);
        let req = Present {
            stimulus: t.stimulus.clone(),
            gate: tl.gate,
            on_s,
            off_s: Some(tl.off_s * self.scale),
            repeat: Some(if adjusting {
                crate::lab::session::MAX_REPEAT
            } else {
                tl.repeat
            }),
        };
        self.session().present(&req)?;
        // A new play forgets old centroids: track again at once.
        self.driver().track_now()?;
        let t_on = monotonic_us();
        let touch_until = t_on + (tl.touch_s * self.scale * 1e6) as u64;
        let mut adjust = None;
        if let Some(a) = &p.adjustment {
            let mut depth = a.start_mm;
            let mut depths = vec![depth];
            let mut given = Vec::new();
            crate::errln!("  depth {depth:.2} mm");
            self.log(serde_json::json!({"event": "depth", "trial": t.trial, "depth_mm": depth, "answer": null}))?;
            loop {
                let offsets = self
                    .trial_events
                    .iter()
                    .filter(|e| matches!(e.kind, EventKind::Offset { .. }))
                    .count();
                if offsets <= given.len() {
                    self.tick()?;
                    if !self.session().presenting() {
                        break;
                    }
                    self.pause();
                    continue;
                }
                let q = Asked::adjustment(a, depth);
                let ans = self.ask(&q)?;
                given.push(ans.clone());
                if ans == a.same {
                    break;
                }
                let step = if ans == a.stronger {
                    -a.step_mm
                } else {
                    a.step_mm
                };
                depth = (depth + step).clamp(a.min_mm, a.max_mm);
                depths.push(depth);
                self.log(serde_json::json!({"event": "depth", "trial": t.trial, "depth_mm": depth, "answer": ans}))?;
                if depths.len() as u32 > a.max {
                    crate::errln!("  {} adjustments: the trial ends at {depth:.2} mm", a.max);
                    break;
                }
                crate::errln!("  next depth {depth:.2} mm ({ans})");
            }
            if self.session().presenting() {
                self.session().stop(OffsetReason::Stop)?;
            }
            adjust = Some((a.start_mm, depths, given));
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
        self.touch(false)?;
        // The next stimulus loads while the participant answers.
        if let Some(n) = next {
            self.session().prepare(&n.stimulus)?;
            self.drain()?;
        }
        let timing_events = std::mem::take(&mut self.trial_events);
        let mut answers: Vec<(String, String)> = Vec::new();
        for (q, order) in p.questions.iter().zip(&t.orders) {
            for asked in Asked::of(q, order) {
                let a = self.ask(&asked)?;
                answers.push((asked.column, a));
            }
        }
        self.trial_events = timing_events;
        self.drain()?;
        Ok(self.row(p, t, &answers, adjust))
    }

    fn row(
        &self,
        p: &Protocol,
        t: &Planned,
        answers: &[(String, String)],
        adjust: Option<(f64, Vec<f64>, Vec<String>)>,
    ) -> (Vec<String>, f64) {
        let s = self.driver.as_ref().expect("open").session_ref();
        let mut onset = None;
        let mut offset = None;
        let (mut presented, mut muted, mut device, mut device_known) = (0.0, 0.0, 0.0, true);
        let (mut phases, mut mutes, mut switch) = (0usize, 0usize, None);
        for e in &self.trial_events {
            match &e.kind {
                EventKind::Onset { stimulus, .. } if *stimulus == t.stimulus => {
                    onset.get_or_insert(e.t_host_us);
                }
                EventKind::Offset {
                    stimulus,
                    presented_s,
                    device_presented_s,
                    muted_s,
                    ..
                } if *stimulus == t.stimulus => {
                    offset = Some(e.t_host_us);
                    phases += 1;
                    presented += presented_s;
                    muted += muted_s;
                    match device_presented_s {
                        Some(d) => device += d,
                        None => device_known = false,
                    }
                }
                EventKind::Mute { .. } => mutes += 1,
                EventKind::Switch { to, latency_ms, .. } if *to == t.stimulus => {
                    switch = Some(*latency_ms);
                }
                _ => {}
            }
        }
        let timing = s
            .loaded()
            .iter()
            .find(|l| l.id == t.stimulus)
            .map(|l| l.planned.timing.clone());
        let opt = |v: Option<String>| v.unwrap_or_default();
        let mut row = vec![
            s_participant(&self.events),
            t.trial.to_string(),
            t.set.to_string(),
            t.stimulus.clone(),
        ];
        row.extend(p.conditions[t.condition].levels.iter().cloned());
        row.extend([
            opt(timing.as_ref().map(|x| x.steps.to_string())),
            opt(timing.as_ref().map(|x| format!("{:.3}", x.dwell_us))),
            opt(timing.as_ref().map(|x| format!("{:.4}", x.freq_hz))),
            opt(timing.as_ref().map(|x| format!("{:.4}", x.step_mm))),
            opt(onset.map(|v| v.to_string())),
            opt(offset.map(|v| v.to_string())),
            if phases > 0 && device_known {
                format!("{device:.4}")
            } else {
                String::new()
            },
            format!("{presented:.4}"),
            if presented > 0.0 {
                format!("{:.4}", (1.0 - muted / presented).clamp(0.0, 1.0))
            } else {
                String::new()
            },
            phases.to_string(),
            mutes.to_string(),
            opt(switch.map(|v| format!("{v:.3}"))),
        ]);
        for q in &p.questions {
            for c in q.columns() {
                row.push(
                    answers
                        .iter()
                        .find(|(k, _)| *k == c)
                        .map(|(_, v)| v.clone())
                        .unwrap_or_default(),
                );
            }
            if q.shuffle {
                let i = p.questions.iter().position(|x| x.id == q.id).unwrap_or(0);
                let names: Vec<String> = t.orders[i]
                    .iter()
                    .map(|&k| match &q.kind {
                        protocol::Kind::Likert { items, .. } => items[k].clone(),
                        protocol::Kind::Choice { options } => options[k].clone(),
                        protocol::Kind::Number { .. } => String::new(),
                    })
                    .collect();
                row.push(names.join("|"));
            }
        }
        if let Some((start, depths, given)) = adjust {
            row.push(format!("{start:.2}"));
            row.push((depths.len() - 1).to_string());
            row.push(given.join("|"));
            row.push(
                depths
                    .iter()
                    .map(|d| format!("{d:.2}"))
                    .collect::<Vec<_>>()
                    .join("|"),
            );
            row.push(format!("{:.2}", depths.last().copied().unwrap_or(start)));
        }
        (row, presented)
    }
}

/// The participant, from the log's folder name.
fn s_participant(log: &AppendLog) -> String {
    log.path()
        .parent()
        .and_then(Path::file_name)
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn studies(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../studies")
            .join(name)
    }

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("lmhost-study-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn the_paper_protocols_have_15_conditions_in_2_sets() {
        let p = Protocol::load(&studies("paper-exp1.toml")).unwrap();
        assert_eq!(p.conditions.len(), 15);
        assert_eq!(p.trials(), 30);
        assert_eq!(p.conditions[0].stimulus, "lms-5hz-a2");
        assert_eq!(p.conditions[14].stimulus, "lms-25hz-a6");
        assert_eq!(p.conditions[5].levels, ["lmm-5hz", "2"]);
        assert!(p.timeline.while_touching && p.adjustment.is_none());
        let q: Vec<String> = p.questions.iter().flat_map(|q| q.columns()).collect();
        assert_eq!(
            q,
            [
                "vibration",
                "movement",
                "shape_flat",
                "shape_convex",
                "shape_concave"
            ]
        );
        let p3 = Protocol::load(&studies("paper-exp3.toml")).unwrap();
        let a = p3.adjustment.as_ref().unwrap();
        assert_eq!((a.step_mm, a.max, a.start_mm), (0.25, 20, 4.0));
        assert_eq!(p3.timeline.on_s, Some(2.0));
        assert_eq!(p3.timeline.off_s, 2.0);
        assert_eq!(p3.timeline.gate, Some(crate::lab::session::Gate::Untracked));
    }

    #[test]
    fn each_set_is_a_permutation_and_the_seed_fixes_the_order() {
        let p = Protocol::load(&studies("paper-exp1.toml")).unwrap();
        let a = design::plan(&p, 7);
        assert_eq!(a.len(), 30);
        for set in 1..=2 {
            let mut c: Vec<usize> = a
                .iter()
                .filter(|t| t.set == set)
                .map(|t| t.condition)
                .collect();
            c.sort_unstable();
            assert_eq!(c, (0..15).collect::<Vec<_>>());
        }
        assert!(a.iter().enumerate().all(|(i, t)| t.trial == i + 1));
        for t in &a {
            assert_eq!(t.stimulus, p.conditions[t.condition].stimulus);
            let mut o = t.orders[2].clone();
            o.sort_unstable();
            assert_eq!(o, [0, 1, 2], "the shape items are a permutation");
            assert_eq!(t.orders[0], Vec::<usize>::new());
        }
        assert_eq!(a, design::plan(&p, 7));
        let b = design::plan(&p, 8);
        assert_ne!(
            a.iter().map(|t| t.condition).collect::<Vec<_>>(),
            b.iter().map(|t| t.condition).collect::<Vec<_>>()
        );
        // The two sets are drawn independently.
        let sets: Vec<Vec<usize>> = a
            .chunks(15)
            .map(|c| c.iter().map(|t| t.condition).collect())
            .collect();
        assert_ne!(sets[0], sets[1]);
        // Every order of 3 items turns up over many trials.
        let mut seen = std::collections::BTreeSet::new();
        for s in 0..20 {
            for t in design::plan(&p, s) {
                seen.insert(t.orders[2].clone());
            }
        }
        assert_eq!(seen.len(), 6);
    }

    #[test]
    fn bad_protocols_are_one_line_errors_naming_file_line_and_field() {
        let base = std::fs::read_to_string(studies("paper-exp1.toml")).unwrap();
        let path = studies("test.toml");
        for (from, to, needle) in [
            ("sets = 2", "sets = 0", "line 21, field `sets`"),
            ("sets = 2", "sets = 2\ncolour = 1", "unknown field `colour`"),
            (
                "\"2\", \"3\"",
                "\"7\", \"3\"",
                "stimulus `lms-5hz-a7`, which is not in",
            ),
            (
                "{type}-a{radius}",
                "{type}-a{size}",
                "`{size}`, which is not a factor",
            ),
            (
                "points = 7\nlow = \"not",
                "points = 12\nlow = \"not",
                "line 42, field `points`",
            ),
            (
                "id = \"movement\"\nkind = \"likert\"\npoints = 7",
                "id = \"movement\"\nkind = \"likert\"\npoints = 1",
                "line 50, field `points`: question `movement`",
            ),
            (
                "kind = \"likert\"\npoints = 7\nlow = \"does",
                "kind = \"number\"\npoints = 7\nlow = \"does",
                "does not apply",
            ),
            (
                "library = \"paper-library.toml\"",
                "library = \"nope.toml\"",
                "field `library`",
            ),
            (
                "while_touching = true",
                "while_touching = false",
                "give `on_s`",
            ),
            ("iti_s = 1.0", "iti_s = -1", "field `iti_s`"),
            ("id = \"movement\"", "id = \"vibration\"", "given twice"),
            (
                "id = \"movement\"",
                "id = \"trial\"",
                "column `trial` is used twice",
            ),
            (
                "gate = \"tracked\"",
                "gate = \"loose\"",
                "unknown variant `loose`",
            ),
        ] {
            assert!(base.contains(from), "{from}");
            let text = base.replacen(from, to, 1);
            let e = Protocol::from_toml(&text, &path).unwrap_err().to_string();
            assert!(e.contains(needle), "{to}: {e}");
            assert!(e.starts_with("study protocol "), "{e}");
            assert!(e.contains("test.toml"), "{e}");
            assert!(!e.contains('\n'), "{e}");
        }
        let base = std::fs::read_to_string(studies("paper-exp3.toml")).unwrap();
        let text = base.replacen("off_s = 2.0", "off_s = 2.0\nrepeat = 3", 1);
        let e = Protocol::from_toml(&text, &path).unwrap_err().to_string();
        assert!(e.contains("field `repeat`"), "{e}");
        let text = base.replacen("same = \"same\"", "same = \"weaker\"", 1);
        assert!(Protocol::from_toml(&text, &path).is_err());
    }

    #[test]
    fn resume_keeps_the_whole_rows_of_a_torn_trials_csv() {
        let p = Protocol::load(&studies("paper-exp1.toml")).unwrap();
        let plan = design::plan(&p, 7);
        let header = record::header(&p);
        let row = |t: &Planned| {
            let mut r = vec![
                "P".to_owned(),
                t.trial.to_string(),
                t.set.to_string(),
                t.stimulus.clone(),
            ];
            r.resize(header.len(), "1".into());
            record::line(&r)
        };
        let d = scratch("resume");
        let path = d.join("trials.csv");
        let mut text = record::line(&header) + "\n";
        for t in &plan[..3] {
            text += &(row(t) + "\n");
        }
        // kill -9 in the middle of the fourth row.
        text += &row(&plan[3])[..20];
        std::fs::write(&path, &text).unwrap();
        let (_, lines) = AppendLog::open(&path).unwrap();
        let rows = record::check_rows(&lines, &header, &plan, "trials.csv").unwrap();
        assert_eq!(rows.len(), 3, "the torn row is dropped: trial 4 runs again");
        assert_eq!(rows[2][3], plan[2].stimulus);
        // 5 answers per Experiment 1 trial to skip in a responses file.
        assert_eq!(record::answers_used(&p, &header, &rows[0]), 5);
        // Rows out of the session's order are refused.
        let swapped = vec![lines[0].clone(), lines[2].clone()];
        let e = record::check_rows(&swapped, &header, &plan, "trials.csv").unwrap_err();
        assert!(e.contains("expected trial 1"), "{e}");
        let mut wrong = header.clone();
        wrong.pop();
        assert!(record::check_rows(&lines, &wrong, &plan, "t").is_err());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn participant_ids_name_a_folder() {
        for ok in ["P01", "s-3_a.b"] {
            assert!(check_participant(ok).is_ok());
        }
        for bad in ["", "..", "a/b", "a b", &"x".repeat(65)] {
            assert!(check_participant(bad).is_err(), "{bad}");
        }
    }
}
