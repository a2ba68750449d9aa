//! What a participant's run leaves on disk: `trials.csv` (a row per
//! finished trial, appended whole and synced before the next trial),
//! `session.json` (written whole) and `events.jsonl`; and reading them back,
//! checked whole before anything is changed, for `--resume` and the report.
//! Every read is bounded and of regular files only ([`read_own`]): a FIFO
//! or a device node is refused at once, a file larger than the session
//! could have written is refused before it is read.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::columns::{self, Columns, Holds, Row};
use super::design::Planned;
use super::protocol::{Block, Condition, Factor, MAX_TRIALS, Question, Unlinked};
use crate::error::InputError;

/// Largest `session.json`: the most trials a session has
/// ([`super::protocol::MAX_TRIALS`]) with 32 questions of 9 items each
/// (46 MB, see the test), the protocol's text (1 MiB, a few times that
/// escaped) and a few hundred runs' device and library records (8 kB for a
/// library of 2 entries, under 1 MB for 256).
pub const MAX_SESSION_BYTES: u64 = 256 << 20;

/// The scene a run used.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneRecord {
    /// The scene file as given (`None`: the built-in scene).
    pub path: Option<String>,
    /// CRC-32 of the file's text, 8 hex digits (`None`: built-in).
    pub crc32: Option<String>,
}

impl SceneRecord {
    /// The scene file `path` whose text is `text`, or the built-in scene.
    pub fn of(path: Option<&std::path::Path>, text: Option<&str>) -> Self {
        Self {
            path: path.map(|p| p.display().to_string()),
            crc32: text.map(|t| format!("{:08x}", lm_proto::crc32(t.as_bytes()))),
        }
    }

    pub(super) fn show(&self) -> String {
        match (&self.path, &self.crc32) {
            // Quoted: a value read back from session.json is cut to its
            // bounded echo when long.
            (Some(p), Some(c)) => format!("`{p}` (CRC `{c}`)"),
            _ => "the built-in scene".into(),
        }
    }
}

/// One run of the session (the first, and one per `--resume`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Run {
    /// Wall clock at its start (s since 1970).
    #[serde(deserialize_with = "crate::whole::field::<_, _, 0, { u64::MAX }>")]
    pub started_unix_s: u64,
    /// First trial it ran (1-based).
    #[serde(deserialize_with = "crate::whole::field::<_, _, 1, { MAX_TRIALS as u64 }>")]
    pub first_trial: usize,
    /// lmhost's version.
    pub lmhost_version: String,
    /// The device, as it described itself.
    pub device: serde_json::Value,
    /// Every library entry as planned for it: id, CRC-32, realised timing.
    pub library: Vec<serde_json::Value>,
    /// `--time-scale`.
    pub time_scale: f64,
    /// `--finger`.
    pub finger: String,
    /// The scene (file and CRC-32 of its text); absent in files written
    /// before it was recorded, never `null`.
    #[serde(default, deserialize_with = "crate::json::no_null")]
    pub scene: Option<SceneRecord>,
    /// The backend kind (`autd3`, `lm-firmware`, ...).
    #[serde(default)]
    pub backend: String,
    /// The port as given.
    #[serde(default)]
    pub port: String,
    /// What differed from the previous run's rig when `--resume-anyway`
    /// went on regardless; the key is absent from a run that needed no
    /// override (the record holds what happened, and files written before
    /// either key existed read back the same way).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::json::no_null"
    )]
    pub resumed_anyway: Option<String>,
    /// Experiment 3's stage and gauge; absent from a run without them.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::json::no_null"
    )]
    pub instruments: Option<String>,
}

/// `session.json`. A key it does not know (misspelt, or of another
/// program) is refused, not passed over; `device` and `library` hold what
/// the device and the planner said, as they said it. `null` is read only
/// where this file writes it for "none" (`index` without one, a built-in
/// scene's `scene.path` and `scene.crc32`); a key that may be left out is
/// refused as `null` ([`crate::json::no_null`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionFile {
    /// The protocol's name.
    pub protocol_name: String,
    /// The protocol file as given.
    pub protocol_file: String,
    /// Its text, verbatim (a different text refuses `--resume`).
    pub protocol: String,
    /// The library file.
    pub library_file: String,
    /// The participant.
    pub participant: String,
    /// The seed of the order.
    #[serde(deserialize_with = "crate::whole::field::<_, _, 0, { u64::MAX }>")]
    pub seed: u64,
    /// The participant's index (`--index`: the row of a Latin square),
    /// when given.
    #[serde(
        default,
        deserialize_with = "crate::whole::opt_field::<_, _, 1, { MAX_INDEX as u64 }>"
    )]
    pub index: Option<usize>,
    /// The protocol's order (`random`, `sequential`, `full-random`,
    /// `latin-square`).
    #[serde(default)]
    pub order: String,
    /// Questions in the order asked.
    pub question_order: Vec<String>,
    /// `trials.csv`'s condition and answer columns and their kinds
    /// (`factor`, `likert`, `choice`, `number`, `depth`).
    pub columns: Vec<(String, String)>,
    /// Every trial in order, with shown item and option orders.
    pub trials: Vec<Planned>,
    /// The runs so far.
    pub runs: Vec<Run>,
}

/// Largest participant index (`--index`, from 1).
pub const MAX_INDEX: usize = 1_000_000;

impl SessionFile {
    /// Checks what `session.json` records beside its trials against its
    /// protocol `p` (the one its `protocol` text is): the name, the order,
    /// the questions and columns, the participant's index (given exactly
    /// when the order is a Latin square's, 1..=[`MAX_INDEX`]) and every
    /// run's first trial and time scale, as a run writes them. A value no
    /// run can write (an edit, a copy from another study) is refused
    /// rather than carried on by a resume or passed over by a report.
    pub fn check(&self, p: &Unlinked, path: &Path) -> Result<(), InputError> {
        let bad = |field: &str, what: String| {
            InputError::new(format!("{}: field `{field}`: {what}", path.display()))
        };
        if self.protocol_name != p.name {
            return Err(bad(
                "protocol_name",
                format!(
                    "`{}`, but its protocol is named `{}`",
                    self.protocol_name.escape_debug(),
                    p.name
                ),
            ));
        }
        // Files written before the order was recorded have none.
        if !self.order.is_empty() && self.order != p.order.name() {
            return Err(bad(
                "order",
                format!(
                    "`{}`, but its protocol's order is `{}`",
                    self.order.escape_debug(),
                    p.order.name()
                ),
            ));
        }
        let questions: Vec<&str> = p.questions.iter().map(|q| q.id.as_str()).collect();
        if self.question_order != questions {
            return Err(bad(
                "question_order",
                format!("not its protocol's questions ({})", questions.join(", ")),
            ));
        }
        if self.columns != columns(&p.columns) {
            return Err(bad(
                "columns",
                "not its protocol's columns and their kinds".into(),
            ));
        }
        match (super::design::orders_by_index(p), self.index) {
            (true, Some(1..=MAX_INDEX)) | (false, None) => {}
            (true, Some(i)) => {
                return Err(bad(
                    "index",
                    format!("{i}: give the participant's number, 1 to {MAX_INDEX}"),
                ));
            }
            (true, None) => {
                return Err(bad(
                    "index",
                    "missing: its protocol's order is a Latin square by participant".into(),
                ));
            }
            (false, Some(i)) => {
                return Err(bad(
                    "index",
                    format!("{i}, but its protocol's order is not a Latin square: null"),
                ));
            }
        }
        let last = self.trials.len() + 1;
        for (k, r) in self.runs.iter().enumerate() {
            if !(1..=last).contains(&r.first_trial) {
                return Err(bad(
                    &format!("runs[{k}].first_trial"),
                    format!("{}: give 1 to {last}", r.first_trial),
                ));
            }
            let max = super::MAX_TIME_SCALE;
            if !(r.time_scale > 0.0 && r.time_scale <= max) {
                return Err(bad(
                    &format!("runs[{k}].time_scale"),
                    format!(
                        "{}: give a factor above 0 and at most {max}",
                        crate::limits::show(r.time_scale)
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The condition and answer columns of a header with their kinds (the
/// depth the trial ended at, not the one it started from).
pub fn columns(cols: &Columns) -> Vec<(String, String)> {
    cols.list()
        .iter()
        .filter(|c| c.name != columns::START_DEPTH)
        .filter_map(|c| c.holds.kind().map(|k| (c.name.clone(), k.to_owned())))
        .collect()
}

/// Reads a file this command wrote and will continue (`trials.csv` and
/// `session.json` on `--resume`), opened by [`crate::files::open_own`]
/// (a regular file, not remembered as an input, so the run may append to
/// it and replace it afterwards), refused when longer than `max` bytes
/// before it is read.
pub fn read_own(what: &str, path: &Path, max: u64) -> Result<Vec<u8>, InputError> {
    use std::io::Read as _;
    let cannot =
        |why: String| InputError::new(format!("cannot read {what} {}: {why}", path.display()));
    let f = crate::files::open_own(what, path)?;
    let mut bytes = Vec::new();
    f.take(max + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| cannot(crate::files::reason(&e)))?;
    if bytes.len() as u64 > max {
        return Err(InputError::new(format!(
            "{what} {} is larger than {max} bytes, more than this session can have written",
            path.display()
        )));
    }
    Ok(bytes)
}

/// Reads and parses `session.json` at `path`; a bad value names its field.
pub fn read_session(path: &Path) -> Result<SessionFile, InputError> {
    let bytes = read_own("session file", path, MAX_SESSION_BYTES)?;
    let mut de = serde_json::Deserializer::from_slice(&bytes);
    let session = session_of(&mut de, path)?;
    // One value: what follows it was ignored without a word.
    de.end()
        .map_err(|e| InputError::new(format!("{}: {e}", path.display())))?;
    Ok(session)
}

fn session_of(
    de: &mut serde_json::Deserializer<serde_json::de::SliceRead<'_>>,
    path: &Path,
) -> Result<SessionFile, InputError> {
    serde_path_to_error::deserialize(de).map_err(|e| {
        let mut field = e.path().to_string();
        let mut inner = e.inner().to_string();
        // An unknown key is the path's last part, and serde's message names
        // it already: the path shown is where it is, not it again; the key
        // shown is cut before its own backquotes could split its echo.
        if let Some(serde_path_to_error::Segment::Map { key }) = e.path().iter().next_back()
            && let Some(rest) = inner.strip_prefix(&format!("unknown field `{key}`"))
        {
            inner = format!("unknown field `{}`{rest}", crate::error::short_echo(key));
            field = field.strip_suffix(key.as_str()).unwrap_or(&field).into();
            field = field.strip_suffix('.').unwrap_or(&field).into();
            if field.is_empty() {
                field = ".".into();
            }
        }
        InputError::new(if field == "." {
            format!("{}: {inner}", path.display())
        } else {
            format!("{}: field `{field}`: {inner}", path.display())
        })
    })
}

/// One CSV line (no line break) from `fields`, quoted where needed.
pub fn line<S: AsRef<[u8]>>(fields: &[S]) -> String {
    let mut w = csv::WriterBuilder::new()
        .flexible(true)
        .terminator(csv::Terminator::Any(b'\n'))
        .from_writer(Vec::new());
    // Writing to memory fails only for a record of no fields.
    if fields.is_empty() || w.write_record(fields).is_err() {
        return String::new();
    }
    let mut bytes = w.into_inner().unwrap_or_default();
    bytes.pop();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// What every row of a session holds before its trial runs.
#[derive(Debug, Clone, Copy)]
pub struct Expect<'a> {
    /// The participant's id.
    pub participant: &'a str,
    /// The protocol's factors.
    pub factors: &'a [Factor],
    /// Its conditions.
    pub conditions: &'a [Condition],
    /// Its questions.
    pub questions: &'a [Question],
    /// Its blocks (empty: none, and no block columns).
    pub blocks: &'a [Block],
}

impl<'a> Expect<'a> {
    /// What every row of `participant`'s session of protocol `p` holds.
    pub fn of(p: &'a Unlinked, participant: &'a str) -> Self {
        Self {
            participant,
            factors: &p.factors,
            conditions: &p.conditions,
            questions: &p.questions,
            blocks: &p.blocks,
        }
    }

    /// Trial `t`'s values that follow from the plan: participant, trial,
    /// set, stimulus, the condition's levels and the orders shown.
    pub fn row(&self, t: &Planned) -> Row {
        let mut r = Row::default();
        r.set(columns::PARTICIPANT, self.participant);
        r.set(columns::TRIAL, t.trial.to_string());
        r.set(columns::SET, t.set.to_string());
        r.set(columns::STIMULUS, t.stimulus.as_str());
        if let Some(b) = t.block.checked_sub(1).and_then(|i| self.blocks.get(i)) {
            r.set(columns::BLOCK, b.name.as_str());
            r.set(columns::PRACTICE, if t.practice { "1" } else { "0" });
        }
        if let Some(c) = self.conditions.get(t.condition) {
            for (f, l) in self.factors.iter().zip(&c.levels) {
                r.set(&f.name, l.as_str());
            }
        }
        for (q, order) in self.questions.iter().zip(&t.orders) {
            if q.shuffle {
                let names = q.shown_names();
                let shown: Vec<&str> = order
                    .iter()
                    .filter_map(|&i| names.get(i).map(String::as_str))
                    .collect();
                r.set(&format!("{}_order", q.id), shown.join("|"));
            }
        }
        r
    }
}

/// What is after the last whole row of a `trials.csv`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tail {
    /// Nothing: the file ends with a whole row (or its header).
    Clean,
    /// The beginning of the next trial's row, cut by a crash: dropped.
    TornRow,
    /// No whole header (a crash before it was synced, or no file): the
    /// file starts again.
    NoHeader,
}

/// A `trials.csv` read back and checked.
#[derive(Debug, Clone)]
pub struct Trials {
    /// The whole rows, fields in header order.
    pub rows: Vec<Vec<String>>,
    /// What follows them.
    pub tail: Tail,
}

impl Trials {
    /// Answers the rows took (their `answers` column), to skip in a
    /// responses file.
    pub fn answers_used(&self, cols: &Columns) -> usize {
        let Some(i) = cols.index(columns::ANSWERS) else {
            return 0;
        };
        self.rows
            .iter()
            .filter_map(|r| r.get(i)?.parse::<usize>().ok())
            .fold(0, usize::saturating_add)
    }
}

/// Reads the `trials.csv` at `path` written with header `cols` for `plan`
/// and checks all of it before anything may change it: the header is
/// `cols`, row *k* is trial *k* as planned with every value what its
/// column holds, and anything after the last line break is provably the
/// start of the next trial's row (or of the header). A missing file has
/// no header.
pub fn read_trials(
    path: &Path,
    cols: &Columns,
    plan: &[Planned],
    expect: &Expect,
) -> Result<Trials, InputError> {
    if std::fs::symlink_metadata(path).is_err_and(|e| e.kind() == std::io::ErrorKind::NotFound) {
        return Ok(Trials {
            rows: Vec::new(),
            tail: Tail::NoHeader,
        });
    }
    let header = line(&cols.names());
    let max =
        (header.len() + 1) as u64 + (plan.len() as u64).saturating_mul(cols.max_row_bytes() as u64);
    let bytes = read_own("trials file", path, max)?;
    let file = path.display();
    // Saved by a spreadsheet since: its byte-order mark is skipped (CRLF
    // the CSV reader takes), UTF-16 is said as such.
    if let Some(enc) = crate::files::text::wide_encoding(&bytes) {
        return Err(InputError::new(format!(
            "cannot read trials file {file}: it is {enc} text, not UTF-8 (saved by another program?): save it as UTF-8"
        )));
    }
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(&bytes);
    let split = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let (whole, tail) = bytes.split_at(split);
    let bad = |line: usize, msg: String| InputError::new(format!("{file} line {line}: {msg}"));
    if whole.is_empty() {
        // Nothing but, perhaps, a header cut short.
        if header.as_bytes().starts_with(tail) {
            return Ok(Trials {
                rows: Vec::new(),
                tail: Tail::NoHeader,
            });
        }
        return Err(bad(1, "not the start of this protocol's header".into()));
    }
    let whole = std::str::from_utf8(whole)
        .map_err(|_| InputError::new(format!("{file}: not UTF-8 text")))?;
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(whole.as_bytes());
    let mut rows: Vec<Vec<String>> = Vec::new();
    let answer_columns: Vec<usize> = cols
        .list()
        .iter()
        .enumerate()
        .filter(|(_, c)| {
            matches!(
                c.holds,
                Holds::Likert(_) | Holds::Choice(_) | Holds::Number(..)
            )
        })
        .map(|(i, _)| i)
        .collect();
    // A procedure's answers, `|`-joined in one column.
    let adjust = cols
        .index(columns::ADJUST_ANSWERS)
        .or_else(|| cols.index(columns::STAIRCASE_ANSWERS))
        .or_else(|| cols.index(columns::QUEST_ANSWERS));
    let count = cols.index(columns::ANSWERS);
    for (k, rec) in reader.records().enumerate() {
        let rec = rec.map_err(|e| {
            let at = e.position().map_or(k + 1, |p| p.line() as usize);
            bad(at, e.to_string())
        })?;
        let n = rec.position().map_or(k + 1, |p| p.line() as usize);
        let f: Vec<String> = rec.iter().map(str::to_owned).collect();
        if k == 0 {
            if f != cols.names() {
                if let Some(why) = crate::files::text::foreign_csv(
                    whole.lines().next().unwrap_or(""),
                    "this protocol's columns",
                ) {
                    return Err(bad(1, why));
                }
                let at = cols.names().iter().zip(&f).position(|(a, b)| a != b);
                return Err(bad(
                    1,
                    match at {
                        Some(i) => format!(
                            "the header is not this protocol's columns: column {} is `{}`, not `{}`",
                            i + 1,
                            f[i].escape_debug(),
                            cols.names()[i]
                        ),
                        None => format!(
                            "the header has {} columns, this protocol's has {}",
                            f.len(),
                            cols.list().len()
                        ),
                    },
                ));
            }
            continue;
        }
        let Some(t) = plan.get(k - 1) else {
            return Err(bad(
                n,
                format!("the session has only {} trials", plan.len()),
            ));
        };
        if f.len() != cols.list().len() {
            return Err(bad(
                n,
                format!("{} fields, the header has {}", f.len(), cols.list().len()),
            ));
        }
        let want = cols.fields(&expect.row(t)).map_err(|m| bad(n, m))?;
        for ((c, v), w) in cols.list().iter().zip(&f).zip(&want) {
            if !w.is_empty() && v != w {
                return Err(bad(
                    n,
                    format!(
                        "column `{}` is `{}`, but trial {} of the session has `{w}`",
                        c.name,
                        v.escape_debug(),
                        t.trial
                    ),
                ));
            }
            c.check(v).map_err(|m| {
                bad(
                    n,
                    format!("column `{}`: `{}`: {m}", c.name, v.escape_debug()),
                )
            })?;
        }
        if let Some(ci) = count {
            let adjusted = adjust
                .filter(|&i| !f[i].is_empty())
                .map_or(0, |i| f[i].split(columns::LIST_SEPARATOR).count());
            // The answers given, as the runner counts them: an answer
            // emptied after the run no longer matches the count.
            let answered = answer_columns.iter().filter(|&&i| !f[i].is_empty()).count();
            let given = answered + adjusted;
            if f[ci] != given.to_string() {
                return Err(bad(
                    n,
                    format!(
                        "column `{}` is `{}`, but the row holds {given} answers",
                        columns::ANSWERS,
                        f[ci].escape_debug()
                    ),
                ));
            }
        }
        rows.push(f);
    }
    let lines = whole.matches('\n').count();
    if tail.is_empty() {
        return Ok(Trials {
            rows,
            tail: Tail::Clean,
        });
    }
    // A crash cuts a row's one write short: what is left is the start of
    // the next trial's row, whose first columns the plan fixes.
    let torn = plan.get(rows.len()).is_some_and(|t| {
        let known = cols.fields(&expect.row(t)).unwrap_or_default();
        let lead = 4 + expect.factors.len();
        let prefix = line(&known[..lead.min(known.len())]) + ",";
        prefix.as_bytes().starts_with(tail) || tail.starts_with(prefix.as_bytes())
    });
    if !torn {
        return Err(bad(
            lines + 1,
            format!(
                "`{}` is neither a whole row nor the start of trial {}'s row; nothing was cut (fix or remove that line)",
                String::from_utf8_lossy(&tail[..tail.len().min(60)]).escape_debug(),
                rows.len() + 1
            ),
        ));
    }
    Ok(Trials {
        rows,
        tail: Tail::TornRow,
    })
}

#[cfg(test)]
mod tests;
