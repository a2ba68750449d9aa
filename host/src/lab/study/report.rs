//! `lmhost study report`: per condition and question, n, median and
//! quartiles over every participant's `trials.csv` (`summary.csv`), the
//! choices' counts (`choices.csv`), the tests (`stats.*`) and a box plot
//! per numeric answer column in the paper's layout ([`super::figure`]: PNG,
//! SVG and PDF at a printed width). Every file is written whole.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::design;
use super::protocol::Unlinked;
use super::record::{self, Expect, SessionFile, Tail};
use crate::error::InputError;
use crate::field::plot::Figure;

/// Quantile `q` of sorted `v` (the one definition, [`crate::clock::quantile`]).
pub use crate::clock::quantile;

pub use super::analysis::Stat;

/// What the report read and wrote.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// Participants read.
    pub participants: usize,
    /// Trial rows read.
    pub rows: usize,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// Folders that are not a participant's, and why.
    pub skipped: Skipped,
    /// Participants whose `trials.csv` ends in a torn row (a run killed
    /// and not resumed): its whole rows are reported.
    pub torn: Vec<PathBuf>,
    /// "Not perceived" answers, left out of every statistic.
    pub not_perceived: usize,
    /// Practice trials' rows, left out of everything reported.
    pub practice: usize,
}

/// Folders skipped, each with the reason.
pub type Skipped = Vec<(PathBuf, String)>;

/// Why folder `d` holds no participant, if it does not: its
/// `session.json` and `trials.csv` must be regular files.
fn not_a_participant(d: &Path) -> Option<String> {
    ["session.json", "trials.csv"].into_iter().find_map(|f| {
        crate::files::check_input(f, &d.join(f))
            .err()
            .map(|e| e.to_string())
    })
}

/// The participant folders `dir` stands for (itself, when it holds a
/// session) and the folders in it skipped, each with the reason.
fn participant_dirs(dir: &Path) -> Result<(Vec<PathBuf>, Skipped), InputError> {
    let holds = |f: &str| std::fs::symlink_metadata(dir.join(f)).is_ok();
    if holds("session.json") || holds("trials.csv") {
        return match not_a_participant(dir) {
            None => Ok((vec![dir.to_owned()], Vec::new())),
            Some(why) => Err(InputError::new(why)),
        };
    }
    // A file given for the folder (a trials.csv, a FIFO) is named as
    // such, not as a path one of whose parts is no folder.
    if let Ok(m) = std::fs::metadata(dir)
        && !m.is_dir()
    {
        return Err(InputError::new(format!(
            "{} is not a folder: give a participant folder (it holds session.json and trials.csv) or the study's --out",
            dir.display()
        )));
    }
    let rd = std::fs::read_dir(dir).map_err(|e| {
        InputError::new(format!(
            "cannot read {}: {}",
            dir.display(),
            crate::files::reason(&e)
        ))
    })?;
    let mut folders: Vec<PathBuf> = rd
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    let (mut ok, mut skipped) = (Vec::new(), Vec::new());
    for d in folders {
        match not_a_participant(&d) {
            None => ok.push(d),
            Some(why) => skipped.push((d, why)),
        }
    }
    if ok.is_empty() {
        return Err(InputError::new(format!(
            "{}: no participant folder in it (one holds session.json and trials.csv; give a participant folder or the study's --out){}",
            dir.display(),
            match skipped.first() {
                None => String::new(),
                // Each folder by its name in `dir`, the first one's reason
                // (a folder of hundreds made one line of kilobytes).
                Some((_, why)) => format!(
                    "; skipped {} (the first: {why})",
                    crate::error::some_of(
                        skipped
                            .iter()
                            .map(|(d, _)| d.file_name().unwrap_or(d.as_os_str()).display()),
                        ", "
                    )
                ),
            }
        )));
    }
    Ok((ok, skipped))
}

/// One participant's session, checked.
struct Participant {
    session: SessionFile,
    protocol: Unlinked,
    plan: Vec<design::Planned>,
    trials: record::Trials,
}

/// Reads and checks participant folder `d`: its protocol, its order from
/// its seed, and every row of its `trials.csv` against both.
fn read_participant(d: &Path) -> Result<Participant, InputError> {
    let sp = d.join("session.json");
    let session = record::read_session(&sp)?;
    let origin = format!("{} (its protocol)", sp.display());
    let protocol = Unlinked::from_toml(&session.protocol, &origin)?;
    let plan = design::plan_of(&protocol, session.seed, session.index);
    if plan != session.trials {
        crate::bad_input!(
            "{}: its trial order does not follow from its seed",
            sp.display()
        );
    }
    session.check(&protocol, &sp)?;
    let expect = Expect::of(&protocol, &session.participant);
    let trials = record::read_trials(&d.join("trials.csv"), &protocol.columns, &plan, &expect)?;
    Ok(Participant {
        session,
        protocol,
        plan,
        trials,
    })
}

/// [`report_to`] with one-column figures in every format.
pub fn report(dir: &Path) -> anyhow::Result<Report> {
    report_to(dir, &Figure::default())
}

/// Reads every participant under `dir` and writes the summary, the tests
/// and the figures (`fig`'s width and formats) into `dir`. Every value
/// summarised is one its column accepts (a Likert point on its scale, a
/// number in its range, finite).
pub fn report_to(dir: &Path, fig: &Figure) -> anyhow::Result<Report> {
    fig.check()?;
    let (dirs, skipped) = participant_dirs(dir)?;
    let mut first: Option<Participant> = None;
    // (condition, stimulus, row) of every participant.
    let mut rows: Vec<(usize, Vec<String>)> = Vec::new();
    let mut out = Report {
        participants: dirs.len(),
        skipped,
        ..Report::default()
    };
    // A participant counted once: a folder copied (a backup beside the
    // original) would weigh them twice in every statistic.
    let mut seen: BTreeMap<String, &Path> = BTreeMap::new();
    for d in &dirs {
        let p = read_participant(d)?;
        if let Some(other) = seen.insert(p.session.participant.clone(), d) {
            crate::bad_input!(
                "{}: participant `{}` again (also in {}): a folder copied? report each participant once",
                d.display(),
                p.session.participant,
                other.display()
            );
        }
        if let Some(f) = &first
            && f.session.protocol != p.session.protocol
        {
            crate::bad_input!(
                "{}: another protocol (`{}`) than {} (`{}`): report one protocol at a time",
                d.join("session.json").display(),
                p.session.protocol_name,
                dirs[0].display(),
                f.session.protocol_name
            );
        }
        if p.trials.tail == Tail::TornRow {
            out.torn.push(d.join("trials.csv"));
        }
        let (practice, kept): (Vec<_>, Vec<_>) = p
            .trials
            .rows
            .iter()
            .zip(&p.plan)
            .partition(|(_, t)| t.practice);
        out.practice += practice.len();
        rows.extend(kept.into_iter().map(|(r, t)| (t.condition, r.clone())));
        first.get_or_insert(p);
    }
    let Some(first) = first else {
        crate::bad_input!("{}: nothing to report", dir.display());
    };
    // Participants without a trial to summarise: a report of nothing
    // (every statistic empty) was written and counted "0 trials".
    if rows.is_empty() {
        crate::bad_input!(
            "{}: no trial to report: {}",
            dir.display(),
            match out.practice {
                0 => "every trials.csv holds no row (runs stopped before their first trial?)"
                    .to_owned(),
                n => format!("only {n} practice trials, which a report leaves out"),
            }
        );
    }
    let cols = &first.protocol.columns;
    let factor_names: Vec<String> = first
        .protocol
        .factors
        .iter()
        .map(|f| f.name.clone())
        .collect();
    let factor_at: Vec<usize> = factor_names.iter().filter_map(|n| cols.index(n)).collect();
    let stim = cols
        .index(super::columns::STIMULUS)
        .ok_or_else(|| InputError::new("trials.csv has no stimulus column"))?;
    let who = cols
        .index(super::columns::PARTICIPANT)
        .ok_or_else(|| InputError::new("trials.csv has no participant column"))?;
    let design = super::analysis::design(
        &first.protocol.report,
        &first.protocol.factors,
        &first.protocol.conditions,
    );
    let mut tests = Vec::new();
    let mut stats: Vec<Stat> = Vec::new();
    let mut choices: BTreeMap<(usize, String, String, String), usize> = BTreeMap::new();
    for (name, kind) in record::columns(cols) {
        let Some(c) = cols.index(&name).filter(|_| kind != "factor") else {
            continue;
        };
        // A column no row fills (force_n of a run without instruments)
        // has nothing to report.
        if rows.iter().all(|(_, r)| r[c].is_empty()) {
            continue;
        }
        let holds = &cols.list()[c].holds;
        // (condition, stimulus) → (levels, values, "not perceived" count).
        type Cell = (Vec<String>, Vec<f64>, usize);
        let mut by: BTreeMap<(usize, String), Cell> = BTreeMap::new();
        for (condition, r) in &rows {
            let key = (*condition, r[stim].clone());
            let levels = factor_at.iter().map(|&i| r[i].clone()).collect();
            let e = by.entry(key.clone()).or_insert((levels, Vec::new(), 0));
            if r[c].is_empty() {
                continue;
            }
            if r[c] == super::columns::NOT_PERCEIVED {
                e.2 += 1;
                continue;
            }
            if kind == "choice" {
                *choices
                    .entry((key.0, key.1, name.clone(), r[c].clone()))
                    .or_default() += 1;
            } else if let Some(v) = holds.number(&r[c]) {
                // read_trials checked it: finite and in range.
                e.1.push(v);
            }
        }
        if kind == "choice" {
            continue;
        }
        for ((_, stimulus), (levels, mut values, not_perceived)) in by {
            values.sort_by(f64::total_cmp);
            stats.push(Stat {
                stimulus,
                levels,
                question: name.clone(),
                values,
                not_perceived,
            });
        }
        let answers: Vec<(String, usize, String)> = rows
            .iter()
            .map(|(condition, r)| (r[who].clone(), *condition, r[c].clone()))
            .collect();
        tests.push(super::analysis::question(
            &name,
            &answers,
            &first.protocol.conditions,
            &design,
        )?);
    }
    out.rows = rows.len();
    let mut head = vec!["stimulus".to_owned()];
    head.extend(factor_names.iter().cloned());
    head.extend(
        [
            "question",
            "n",
            "not_perceived",
            "median",
            "q1",
            "q3",
            "iqr",
        ]
        .map(String::from),
    );
    let mut csv = record::line(&head) + "\n";
    let num = |x: f64| {
        if x.is_nan() {
            String::new()
        } else {
            crate::limits::show(x)
        }
    };
    for st in &stats {
        let (q1, q3) = (quantile(&st.values, 0.25), quantile(&st.values, 0.75));
        let mut f = vec![st.stimulus.clone()];
        f.extend(st.levels.iter().cloned());
        f.extend([
            st.question.clone(),
            st.values.len().to_string(),
            st.not_perceived.to_string(),
            num(quantile(&st.values, 0.5)),
            num(q1),
            num(q3),
            num(q3 - q1),
        ]);
        csv += &(record::line(&f) + "\n");
    }
    let p = dir.join("summary.csv");
    crate::files::write_whole(&p, csv.as_bytes())?;
    out.files.push(p);
    if !choices.is_empty() {
        let mut csv = String::from("stimulus,question,option,count\n");
        for ((_, stimulus, q, o), n) in &choices {
            csv += &(record::line(&[stimulus.clone(), q.clone(), o.clone(), n.to_string()]) + "\n");
        }
        let p = dir.join("choices.csv");
        crate::files::write_whole(&p, csv.as_bytes())?;
        out.files.push(p);
    }
    out.not_perceived = stats.iter().map(|s| s.not_perceived).sum();
    for (file, text) in [
        ("stats.csv", super::analysis::csv(&tests)),
        ("stats.json", serde_json::to_string_pretty(&tests)? + "\n"),
        ("stats.txt", super::analysis::text(&tests)),
    ] {
        let p = dir.join(file);
        crate::files::write_whole(&p, text.as_bytes())?;
        out.files.push(p);
    }
    for b in super::figure::plan(&first.protocol, &stats, &tests) {
        let stem = dir.join(format!("box-{}", b.column));
        out.files.extend(super::figure::write(&stem, &b, fig)?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_interpolate_like_numpy() {
        let v = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(quantile(&v, 0.5), 2.5);
        assert_eq!(quantile(&v, 0.25), 1.75);
        assert_eq!(quantile(&v, 0.75), 3.25);
        assert_eq!(quantile(&[5.0], 0.25), 5.0);
        assert!(quantile(&[], 0.5).is_nan());
    }
}
