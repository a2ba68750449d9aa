//! The files a study writes and reads back, under the fuzz run: a
//! participant's `trials.csv` and `session.json` as `study run --resume`
//! reads them, and a study folder as `study report` reads it. A researcher
//! may hand-edit them, copy them between machines or find them cut by a
//! crash. The seeds are real runs, made once through the library on the
//! in-process AUTD3 emulator: a blocked study (a practice block, Likert
//! with "not perceived", a shuffled choice, a number) for two
//! participants, and a staircase answered by a simulated observer.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use super::harness::{Outcome, Reader, Verdict, finite, refused};
use crate::device::link::PortSpec;
use crate::files::{Scratch, scratch};
use crate::lab::study::columns::Holds;
use crate::lab::study::protocol::Protocol;
use crate::lab::study::provenance;
use crate::lab::study::record::{self, Expect, Tail};
use crate::lab::study::start::{self, Paths};
use crate::lab::study::{AnswerSource, FingerSource, RunOptions};

/// The blocked study: 5 trials (1 practice), three kinds of answer.
const MIXED: &str = include_str!("fuzz-mixed.toml");

/// A participant's three files as a run left them.
#[derive(Clone)]
pub struct Files {
    pub session: Vec<u8>,
    pub trials: Vec<u8>,
    pub events: Vec<u8>,
}

/// A study run for the seeds: its protocol file and each participant's
/// files.
pub struct Study {
    pub protocol: PathBuf,
    pub participants: Vec<(String, u64, Files)>,
    /// Answers given (`None`: the observer).
    pub answers: Option<PathBuf>,
    /// The first participant's last run, as `session.json` records it.
    pub last_run: Option<record::Run>,
    _dir: Scratch,
}

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// Runs `protocol` (its text, `{library}` filled in) for each of
/// `participants` (id, seed) answered by `answers`.
fn run_study(
    name: &str,
    text: &str,
    library: &str,
    participants: &[(&str, u64)],
    time_scale: f64,
    answers: impl Fn(&Path) -> AnswerSource,
) -> Study {
    let dir = scratch(&format!("fuzz-study-{name}"));
    let protocol = dir.join("protocol.toml");
    let lib = repo(library).display().to_string();
    std::fs::write(&protocol, text.replace("{library}", &lib)).unwrap();
    let out = dir.join("out");
    let mut done = Vec::new();
    let mut given = None;
    for (id, seed) in participants {
        let a = answers(&dir);
        if let AnswerSource::File(p) = &a {
            given = Some(p.clone());
        }
        let o = RunOptions {
            protocol: protocol.clone(),
            port: PortSpec::new(Some("autd3:emulator".into())),
            scene: None,
            participant: (*id).into(),
            out: out.clone(),
            seed: Some(*seed),
            index: None,
            answers: a,
            finger: FingerSource::None,
            time_scale,
            resume: false,
            resume_anyway: false,
            view: None,
            instruments: None,
            hooks: Default::default(),
        };
        crate::lab::study::run(o).unwrap_or_else(|e| panic!("seed study {name}: {e:#}"));
        let p = Paths::new(&out, id);
        let read = |f: &Path| std::fs::read(f).unwrap_or_default();
        done.push((
            (*id).to_owned(),
            *seed,
            Files {
                session: read(&p.session),
                trials: read(&p.trials),
                events: read(&p.events),
            },
        ));
    }
    let last_run = done.first().and_then(|(_, _, f)| {
        let s: record::SessionFile = serde_json::from_slice(&f.session).ok()?;
        s.runs.last().cloned()
    });
    Study {
        protocol,
        last_run,
        participants: done,
        answers: given,
        _dir: dir,
    }
}

/// The seed studies, run once.
pub fn studies() -> &'static [Study] {
    static ONCE: OnceLock<Vec<Study>> = OnceLock::new();
    ONCE.get_or_init(|| {
        // 5 trials × 3 answers: Likert (now and then `na`), a choice by
        // its position or label, a number.
        let mixed = |dir: &Path| {
            let a: Vec<String> = (0..5)
                .flat_map(|t| {
                    let likert = if t == 2 {
                        "na".into()
                    } else {
                        (t + 2).to_string()
                    };
                    let choice = if t % 2 == 0 {
                        "2".into()
                    } else {
                        "4.0".to_string()
                    };
                    [likert, choice, format!("{}", 0.25 * t as f64 - 1.0)]
                })
                .collect();
            let p = dir.join("answers.txt");
            std::fs::write(&p, a.join("\n") + "\n").unwrap();
            AnswerSource::File(p)
        };
        let staircase = std::fs::read_to_string(repo("studies/staircase-detection.toml"))
            .unwrap()
            .replace(
                "library = \"staircase-library.toml\"",
                "library = \"{library}\"",
            )
            .replace("trials = 80", "trials = 8")
            .replace("reversals = 12", "reversals = 3")
            .replace("threshold_reversals = 8", "threshold_reversals = 2");
        vec![
            run_study(
                "mixed",
                MIXED,
                "studies/paper-library.toml",
                &[("P01", 7), ("P02", 8)],
                0.05,
                mixed,
            ),
            run_study(
                "staircase",
                &staircase,
                "studies/staircase-library.toml",
                &[("P01", 3)],
                0.01,
                |_| AnswerSource::Observer("logistic:threshold=0.4,slope=12".into()),
            ),
        ]
    })
}

/// Which of a participant's files a reader's input stands for.
#[derive(Clone, Copy)]
enum Which {
    Session,
    Trials,
}

/// A scratch study folder holding `study`'s participants, the first's
/// `which` file replaced by each input.
struct Folder {
    out: PathBuf,
    _dir: Scratch,
}

impl Folder {
    fn new(name: &str, study: &Study) -> Self {
        let dir = scratch(&format!("fuzz-{name}"));
        let out = dir.join("out");
        for (id, _, f) in &study.participants {
            std::fs::create_dir_all(out.join(id)).unwrap();
            let p = Paths::new(&out, id);
            std::fs::write(&p.session, &f.session).unwrap();
            std::fs::write(&p.trials, &f.trials).unwrap();
            std::fs::write(&p.events, &f.events).unwrap();
        }
        Self { out, _dir: dir }
    }

    /// The first participant's files, `which` holding `input`.
    fn put(&self, study: &Study, which: Which, input: &[u8]) -> Result<Paths, String> {
        let (id, _, f) = &study.participants[0];
        let p = Paths::new(&self.out, id);
        let (session, trials) = match which {
            Which::Session => (input, &f.trials[..]),
            Which::Trials => (&f.session[..], input),
        };
        let w = |at: &Path, b: &[u8]| std::fs::write(at, b).map_err(|e| format!("writing: {e}"));
        w(&p.session, session)?;
        w(&p.trials, trials)?;
        w(&p.events, &f.events)?;
        Ok(p)
    }
}

/// What every value of an accepted row holds as a run writes it: its
/// trial's number, a finite number in range where the column holds one,
/// a procedure's threshold within its levels.
fn row_ok(p: &Protocol, k: usize, row: &[String]) -> Result<(), String> {
    let cols = p.columns.list();
    if row.len() != cols.len() {
        return Err(format!("row {} has {} fields", k + 1, row.len()));
    }
    for (c, v) in cols.iter().zip(row) {
        let bad = || format!("row {}: column `{}` holds `{v}`", k + 1, c.name);
        if c.name == crate::lab::study::columns::TRIAL && *v != (k + 1).to_string() {
            return Err(bad());
        }
        let Some(x) = c.holds.number(v) else { continue };
        finite(&c.name, &[x])?;
        let within = match c.holds {
            Holds::Likert(points) => x.fract() == 0.0 && (1.0..=f64::from(points)).contains(&x),
            Holds::Number(lo, hi) | Holds::Depth(lo, hi) => (lo..=hi).contains(&x),
            Holds::Force => (0.0..=crate::lab::study::columns::MAX_FORCE_N).contains(&x),
            Holds::Estimate(..) => {
                // Among the procedure's levels or candidate thresholds.
                let v: &[f64] = match (&p.staircase, &p.quest) {
                    (Some(s), _) => &s.grid.values,
                    (_, Some(q)) => &q.model().thresholds,
                    _ => &[],
                };
                let tol = crate::lab::study::columns::ESTIMATE_ROUNDING;
                v.iter().any(|l| *l <= x + tol) && v.iter().any(|h| x - tol <= *h)
            }
            _ => true,
        };
        if !within {
            return Err(bad());
        }
    }
    Ok(())
}

/// `study run --resume` of `study`'s first participant.
fn resume(study: &Study, p: &Protocol, paths: &Paths) -> Outcome {
    let (id, _, _) = &study.participants[0];
    let o = RunOptions {
        protocol: study.protocol.clone(),
        port: PortSpec::new(Some("autd3:emulator".into())),
        scene: None,
        participant: id.clone(),
        out: paths.dir.parent().unwrap_or(Path::new(".")).to_owned(),
        seed: None,
        index: None,
        answers: match &study.answers {
            Some(a) => AnswerSource::File(a.clone()),
            None => AnswerSource::Observer("logistic:threshold=0.4,slope=12".into()),
        },
        finger: FingerSource::None,
        time_scale: 1.0,
        resume: true,
        resume_anyway: false,
        view: None,
        instruments: None,
        hooks: Default::default(),
    };
    let s = match start::resume(&o, p, paths) {
        Ok(s) => s,
        Err(e) => return refused(format!("{e:#}")),
    };
    if s.done > s.plan.len() || (s.tail == Tail::NoHeader && s.done != 0) {
        return Err(format!("{} of {} trials done", s.done, s.plan.len()));
    }
    let f = &s.file;
    let questions: Vec<&str> = p.questions.iter().map(|q| q.id.as_str()).collect();
    if f.trials != s.plan
        || f.participant != *id
        || f.protocol_name != p.name
        // Files written before the order was recorded have none.
        || !(f.order.is_empty() || f.order == p.order.name())
        || f.question_order != questions
        || f.columns != record::columns(&p.columns)
    {
        return Err("a session.json that does not follow from its protocol".into());
    }
    if f.index.is_some() != crate::lab::study::design::orders_by_index(p)
        || f.index.is_some_and(|i| !(1..=1_000_000).contains(&i))
    {
        return Err(format!("participant index {:?}", f.index));
    }
    let mut first = 1;
    for r in &f.runs {
        let scale = r.time_scale > 0.0 && r.time_scale <= crate::lab::study::MAX_TIME_SCALE;
        if !scale || !(first..=s.plan.len() + 1).contains(&r.first_trial) {
            return Err(format!(
                "a run from trial {} at time scale {}",
                r.first_trial, r.time_scale
            ));
        }
        first = r.first_trial;
    }
    // The run then checks its rig against the last run's: this one's
    // record is the seed's last run (the same rig).
    if let Some(last) = &study.last_run
        && let Err(e) = provenance::check_rig(&f.runs, &mut last.clone(), false)
    {
        return refused(e);
    }
    let expect = Expect::of(p, id);
    let t = record::read_trials(&paths.trials, &p.columns, &s.plan, &expect)
        .map_err(|e| format!("read again: {e}"))?;
    for (k, row) in t.rows.iter().enumerate() {
        row_ok(p, k, row)?;
    }
    Ok(Verdict::Accepted)
}

/// `study report` over `study`'s folder: what it read and what it wrote
/// hold rows of the design and finite numbers.
fn report(study: &Study, p: &Protocol, out: &Path) -> Outcome {
    let fig = crate::field::plot::Figure {
        formats: vec![crate::field::plot::Format::Svg],
        ..Default::default()
    };
    let r = match crate::lab::study::report::report_to(out, &fig) {
        Ok(r) => r,
        Err(e) => return refused(format!("{e:#}")),
    };
    let n = study.participants.len();
    let trials = crate::lab::study::design::plan_of(p, 1, None).len();
    if r.participants != n || r.rows + r.practice > n * trials {
        return Err(format!(
            "{} participants, {} rows and {} practice rows of {n} × {trials}",
            r.participants, r.rows, r.practice
        ));
    }
    for f in ["summary.csv", "stats.csv", "stats.json"] {
        let text = std::fs::read_to_string(out.join(f)).map_err(|e| format!("{f}: {e}"))?;
        if let Some(w) = text
            .split([',', '\n', ' ', ':', '"'])
            .find(|w| w.parse::<f64>().is_ok_and(|x| !x.is_finite()))
        {
            return Err(format!("{f} holds `{w}`"));
        }
    }
    Ok(Verdict::Accepted)
}

/// What reads a mutated file back: `study run --resume` or `study report`.
#[derive(Clone, Copy)]
enum Reads {
    Resume,
    Report,
}

/// `reads` over `study`'s first participant with its `which` file the
/// mutant, seeded by that file as the run wrote it.
fn study_reader(
    name: &'static str,
    reads: Reads,
    study: &'static Study,
    which: Which,
    cases: usize,
) -> Reader {
    let p = Protocol::load(&study.protocol).unwrap();
    let folder = Folder::new(name, study);
    let f = &study.participants[0].2;
    let seed = match which {
        Which::Session => f.session.clone(),
        Which::Trials => f.trials.clone(),
    };
    Reader {
        name,
        seeds: vec![seed],
        cases,
        read: Box::new(move |b| {
            let paths = folder.put(study, which, b)?;
            match reads {
                Reads::Resume => resume(study, &p, &paths),
                Reads::Report => report(study, &p, &folder.out),
            }
        }),
    }
}

/// The study readers with their seeds (the seed studies run on first use).
pub fn readers() -> Vec<Reader> {
    let [mixed, staircase] = studies() else {
        unreachable!("two seed studies")
    };
    use Reads::{Report, Resume};
    use Which::{Session, Trials};
    vec![
        study_reader("resume: trials.csv", Resume, mixed, Trials, 5_000),
        study_reader("resume: session.json", Resume, mixed, Session, 5_000),
        study_reader("resume: staircase trials", Resume, staircase, Trials, 5_000),
        study_reader(
            "resume: staircase session",
            Resume,
            staircase,
            Session,
            2_000,
        ),
        study_reader("report: trials.csv", Report, mixed, Trials, 3_000),
        study_reader("report: session.json", Report, mixed, Session, 2_000),
        study_reader("report: staircase trials", Report, staircase, Trials, 2_000),
    ]
}

/// A report counts each participant once: a folder copied beside its
/// original (same session, same rows) is refused, naming both.
#[test]
fn a_participant_folder_copied_is_refused_by_the_report() {
    let study = &studies()[0];
    let folder = Folder::new("report-copy", study);
    let fig = crate::field::plot::Figure {
        formats: Vec::new(),
        ..Default::default()
    };
    let r = crate::lab::study::report::report_to(&folder.out, &fig).unwrap();
    assert_eq!(r.participants, 2);
    let (id, _, f) = &study.participants[1];
    let copy = Paths::new(&folder.out, &format!("{id}-backup"));
    std::fs::create_dir_all(&copy.dir).unwrap();
    std::fs::write(&copy.session, &f.session).unwrap();
    std::fs::write(&copy.trials, &f.trials).unwrap();
    let e = crate::lab::study::report::report_to(&folder.out, &fig)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(&format!("participant `{id}` again")) && e.contains(&format!("out/{id}")),
        "{e}"
    );
}
