//! Starting or resuming a participant's session: every check comes before
//! anything is written. A resume reads `session.json` and `trials.csv`
//! through the bounded regular-file reader, checks them against the
//! protocol and the seed's plan, and only then may the torn tail of
//! `trials.csv` (provably the start of the next row) be cut; a refused
//! resume leaves every file as it was.

use std::path::{Path, PathBuf};

use super::answers::Lines;
use super::design::{self, Planned};
use super::protocol::Protocol;
use super::record::{self, Expect, SessionFile, Tail};
use super::{AnswerSource, RunOptions, trial};
use crate::error::InputError;
use crate::files::AppendLog;

/// A participant's files.
#[derive(Debug, Clone)]
pub struct Paths {
    /// `OUT/ID`.
    pub dir: PathBuf,
    /// `session.json`.
    pub session: PathBuf,
    /// `trials.csv`.
    pub trials: PathBuf,
    /// `events.jsonl`.
    pub events: PathBuf,
}

impl Paths {
    /// The files of participant `id` under `out`.
    pub fn new(out: &Path, id: &str) -> Self {
        let dir = out.join(id);
        Self {
            session: dir.join("session.json"),
            trials: dir.join("trials.csv"),
            events: dir.join("events.jsonl"),
            dir,
        }
    }
}

/// A session checked and ready to (re)start.
#[derive(Debug)]
pub struct Start {
    /// `session.json` as it will be written (this run not yet added).
    pub file: SessionFile,
    /// Every trial in order.
    pub plan: Vec<Planned>,
    /// Trials already on disk.
    pub done: usize,
    /// What follows them in `trials.csv`.
    pub tail: Tail,
    /// A responses file, its used answers skipped and the rest dry-run.
    pub lines: Option<Lines>,
    /// The answers (and the levels they led to) the first trial not on
    /// disk had taken when the run was cut short, logged in
    /// `events.jsonl`: its procedure continues after them.
    pub resumed: Vec<(String, f64)>,
}

/// Checks a new session of `o` for protocol `p`.
pub fn fresh(o: &RunOptions, p: &Protocol, paths: &Paths) -> anyhow::Result<Start> {
    if std::fs::read_dir(&paths.dir).is_ok_and(|mut d| d.next().is_some()) {
        crate::bad_input!(
            "{} is not empty: give --resume to continue that session, or another --participant / --out",
            paths.dir.display()
        );
    }
    let seed = o.seed.unwrap_or_else(design::clock_seed);
    match (design::orders_by_index(p), o.index) {
        (true, None) => crate::bad_input!(
            "study protocol {}: the order is a Latin square by participant: give --index N (the participant's number, from 1; `lmhost study check` prints each one's order)",
            o.protocol.display()
        ),
        // A number that would change nothing is refused, not recorded as
        // though it had chosen the order.
        (true, Some(i)) if !(1..=record::MAX_INDEX).contains(&i) => crate::bad_input!(
            "--index {i}: give the participant's number, 1 to {}",
            record::MAX_INDEX
        ),
        (false, Some(i)) => crate::bad_input!(
            "study protocol {}: --index {i} picks a row of a latin-square order, and this protocol has none: leave --index out (--participant names the participant)",
            o.protocol.display()
        ),
        _ => {}
    }
    let plan = design::plan_for(p, seed, o.index);
    let lines = answers(o, p, &plan, 0, &[])?;
    let file = SessionFile {
        protocol_name: p.name.clone(),
        protocol_file: o.protocol.display().to_string(),
        protocol: p.text.clone(),
        library_file: p.library_path.display().to_string(),
        participant: o.participant.clone(),
        seed,
        index: o.index,
        order: p.order.name().into(),
        question_order: p.questions.iter().map(|q| q.id.clone()).collect(),
        columns: record::columns(&p.columns),
        trials: plan.clone(),
        runs: Vec::new(),
    };
    Ok(Start {
        file,
        plan,
        done: 0,
        tail: Tail::NoHeader,
        lines,
        resumed: Vec::new(),
    })
}

/// Checks the session of `o` on disk for `--resume`.
pub fn resume(o: &RunOptions, p: &Protocol, paths: &Paths) -> anyhow::Result<Start> {
    let refused = |e: InputError| InputError::new(format!("--resume: {e}; nothing was changed"));
    if std::fs::symlink_metadata(&paths.session).is_err() {
        crate::bad_input!(
            "--resume: {} does not exist: nothing to resume (run without --resume{})",
            paths.session.display(),
            if std::fs::read_dir(&paths.dir).is_ok_and(|mut d| d.next().is_some()) {
                format!(" after removing {}", paths.dir.display())
            } else {
                String::new()
            }
        );
    }
    let f = record::read_session(&paths.session).map_err(refused)?;
    let session = paths.session.display();
    if f.protocol != p.text {
        crate::bad_input!(
            "--resume: {session} was written for another protocol (`{}`); {} differs",
            f.protocol_name,
            o.protocol.display()
        );
    }
    if f.participant != o.participant {
        crate::bad_input!(
            "--resume: {session} belongs to participant `{}`, not `{}`",
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
    if let Some(i) = o.index
        && Some(i) != f.index
    {
        crate::bad_input!(
            "--resume: the session's participant index is {}, not --index {i} (leave --index out)",
            f.index.map_or("not given".into(), |x| x.to_string())
        );
    }
    let plan = design::plan_for(p, f.seed, f.index);
    if plan != f.trials {
        crate::bad_input!("--resume: {session}'s trial order does not follow from its seed");
    }
    f.check(p, &paths.session).map_err(refused)?;
    let expect = Expect::of(p, &o.participant);
    let trials = record::read_trials(&paths.trials, &p.columns, &plan, &expect).map_err(refused)?;
    // The event log is appended to: a FIFO or device there would block.
    if std::fs::symlink_metadata(&paths.events).is_ok() {
        crate::files::check_input("event log", &paths.events).map_err(refused)?;
    }
    let done = trials.rows.len();
    let resumed = cut_short(p, plan.get(done), &paths.events).map_err(refused)?;
    let skip = trials.answers_used(&p.columns) + resumed.len();
    let lines = answers(o, p, &plan[done..], skip, &resumed)?;
    Ok(Start {
        file: f,
        plan,
        done,
        tail: trials.tail,
        lines,
        resumed,
    })
}

/// What `events` logged of trial `t` (the first not on disk) before the
/// run was cut short, checked by replaying it into the trial's procedure,
/// when that procedure can continue (a staircase, QUEST+).
fn cut_short(
    p: &Protocol,
    t: Option<&Planned>,
    events: &Path,
) -> Result<Vec<(String, f64)>, InputError> {
    let Some(mut pr) = t
        .and_then(|t| super::procedure::start(p, t))
        .filter(|pr| pr.resumable())
    else {
        return Ok(Vec::new());
    };
    let trial = t.map_or(0, |t| t.trial);
    let (what, unit) = pr.level_unit();
    let logged = super::midtrial::logged(events, trial, &what, &format!("{what}_{unit}"))?;
    super::midtrial::replay(pr.as_mut(), &logged).map_err(|m| {
        InputError::new(format!(
            "{}: trial {trial}'s logged levels do not follow from its answers: {m}",
            events.display()
        ))
    })?;
    Ok(logged)
}

/// The responses file of `o`, `skip` answers used, dry-run over `rest`.
fn answers(
    o: &RunOptions,
    p: &Protocol,
    rest: &[Planned],
    skip: usize,
    resumed: &[(String, f64)],
) -> anyhow::Result<Option<Lines>> {
    // `--responses -` answers each question as it is asked: nothing to
    // read ahead, dry-run or skip.
    let AnswerSource::File(path) = &o.answers else {
        return Ok(None);
    };
    if path.as_os_str() == "-" {
        return Ok(None);
    }
    let mut l = Lines::open(path)?;
    l.skip(skip)?;
    trial::dry_run(p, rest, &mut l.clone(), resumed)?;
    Ok(Some(l))
}

impl Start {
    /// Opens `trials.csv` to append, after [`resume`]'s checks: a torn row
    /// is cut, a file without a whole header starts again with it.
    pub fn open_trials(&self, p: &Protocol, path: &Path) -> anyhow::Result<AppendLog> {
        let mut log = match self.tail {
            Tail::NoHeader => AppendLog::create(path)?,
            Tail::Clean | Tail::TornRow => AppendLog::open(path)?.0,
        };
        if self.tail == Tail::NoHeader {
            log.line(&record::line(&p.columns.names()))?;
            log.sync()?;
        }
        Ok(log)
    }

    /// Opens `events.jsonl`: appended to on resume, new otherwise.
    pub fn open_events(&self, resume: bool, path: &Path) -> anyhow::Result<AppendLog> {
        Ok(if resume {
            AppendLog::open(path)?.0
        } else {
            AppendLog::create(path)?
        })
    }
}
