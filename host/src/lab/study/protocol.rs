//! The protocol file (TOML): which library, how many sets, the trial's
//! timeline, the factors whose product names the conditions, the questions
//! and an optional method-of-adjustment loop. Checked whole before the
//! device opens: a bad field is one line naming the file, line and field.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::error::InputError;
use crate::lab::session::Gate;
use crate::plan::library::Library;

/// Most sets in a protocol.
pub const MAX_SETS: usize = 100;
/// Most conditions (the factors' product).
pub const MAX_CONDITIONS: usize = 1_000;
/// Most questions per trial.
pub const MAX_QUESTIONS: usize = 32;
/// Most Likert points, choice options or Likert items.
pub const MAX_OPTIONS: usize = 9;
/// Longest phase or interval, seconds.
pub const MAX_SECONDS: f64 = 3_600.0;
/// Most adjustments per trial.
pub const MAX_ADJUSTMENTS: u32 = 1_000;

/// `trials.csv`'s own columns (factor and question names may not reuse
/// them; `record` writes them).
pub const FIXED: [&str; 21] = [
    "participant",
    "trial",
    "set",
    "stimulus",
    "steps",
    "dwell_us",
    "freq_hz",
    "step_mm",
    "onset_us",
    "offset_us",
    "device_presented_s",
    "presented_s",
    "present_fraction",
    "on_phases",
    "mutes",
    "switch_ms",
    "start_depth_mm",
    "adjustments",
    "adjust_answers",
    "depths_mm",
    "final_depth_mm",
];

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: String,
    library: PathBuf,
    #[serde(default = "one")]
    sets: usize,
    stimulus: String,
    timeline: TimelineFile,
    #[serde(default)]
    factor: Vec<FactorFile>,
    #[serde(default)]
    question: Vec<QuestionFile>,
    adjustment: Option<AdjustmentFile>,
}

fn one() -> usize {
    1
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TimelineFile {
    #[serde(default)]
    wait_for_finger: bool,
    on_s: Option<f64>,
    #[serde(default)]
    while_touching: bool,
    #[serde(default)]
    off_s: f64,
    repeat: Option<u32>,
    #[serde(default)]
    iti_s: f64,
    gate: Option<Gate>,
    touch_s: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FactorFile {
    name: String,
    levels: Vec<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
enum KindFile {
    Likert,
    Choice,
    Number,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct QuestionFile {
    id: String,
    kind: KindFile,
    #[serde(default)]
    text: String,
    points: Option<u32>,
    low: Option<String>,
    high: Option<String>,
    items: Option<Vec<String>>,
    options: Option<Vec<String>>,
    #[serde(default)]
    shuffle: bool,
    min: Option<f64>,
    max: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct AdjustmentFile {
    #[serde(default)]
    text: String,
    start_mm: f64,
    #[serde(default = "quarter")]
    step_mm: f64,
    #[serde(default = "twenty")]
    max: u32,
    #[serde(default)]
    min_mm: f64,
    max_mm: Option<f64>,
    #[serde(default = "stronger")]
    stronger: String,
    #[serde(default = "weaker")]
    weaker: String,
    #[serde(default = "same")]
    same: String,
}

fn quarter() -> f64 {
    0.25
}
fn twenty() -> u32 {
    20
}
fn stronger() -> String {
    "stronger".into()
}
fn weaker() -> String {
    "weaker".into()
}
fn same() -> String {
    "same".into()
}

/// How a trial plays.
#[derive(Debug, Clone, PartialEq)]
pub struct Timeline {
    /// Wait until the finger is present before presenting.
    pub wait_for_finger: bool,
    /// Seconds per on-phase (`None`: while the finger touches).
    pub on_s: Option<f64>,
    /// Present until the finger leaves (ends an on-phase early too).
    pub while_touching: bool,
    /// Seconds of silence between on-phases.
    pub off_s: f64,
    /// On-phases per trial (an adjustment trial repeats until answered).
    pub repeat: u32,
    /// Seconds between trials.
    pub iti_s: f64,
    /// The gate (`None`: the entry's default).
    pub gate: Option<Gate>,
    /// How long the synthetic finger touches in a `while_touching` trial.
    pub touch_s: f64,
}

/// A factor and its levels.
#[derive(Debug, Clone, PartialEq)]
pub struct Factor {
    /// Its name (a column of `trials.csv`).
    pub name: String,
    /// Its levels.
    pub levels: Vec<String>,
}

/// What a question asks for.
#[derive(Debug, Clone, PartialEq)]
pub enum Kind {
    /// 1..=points, end labels; with `items`, one rating per item.
    Likert {
        /// Scale points.
        points: u32,
        /// Label of 1.
        low: String,
        /// Label of `points`.
        high: String,
        /// One rating per item (`id_item` columns), asked in (shuffled) order.
        items: Vec<String>,
    },
    /// One of the options (by label or 1-based index as shown).
    Choice {
        /// The options.
        options: Vec<String>,
    },
    /// A number in `min..=max`.
    Number {
        /// Least.
        min: f64,
        /// Most.
        max: f64,
    },
}

/// One question.
#[derive(Debug, Clone, PartialEq)]
pub struct Question {
    /// Its id (the column name).
    pub id: String,
    /// What the participant is asked.
    pub text: String,
    /// Its kind.
    pub kind: Kind,
    /// Options or items in a fresh random order each trial (recorded).
    pub shuffle: bool,
}

impl Question {
    /// What the order is drawn over: Likert items or choice options.
    pub fn shuffled_len(&self) -> usize {
        match &self.kind {
            Kind::Likert { items, .. } => items.len(),
            Kind::Choice { options } => options.len(),
            Kind::Number { .. } => 0,
        }
    }

    /// Its columns in `trials.csv`.
    pub fn columns(&self) -> Vec<String> {
        match &self.kind {
            Kind::Likert { items, .. } if !items.is_empty() => {
                items.iter().map(|i| format!("{}_{i}", self.id)).collect()
            }
            _ => vec![self.id.clone()],
        }
    }

    /// Whether its answers are numbers (summarised and plotted).
    pub fn numeric(&self) -> bool {
        !matches!(self.kind, Kind::Choice { .. })
    }
}

/// Experiment 3's method of adjustment.
#[derive(Debug, Clone, PartialEq)]
pub struct Adjustment {
    /// What the participant is asked.
    pub text: String,
    /// First depth, mm.
    pub start_mm: f64,
    /// Change per answer, mm.
    pub step_mm: f64,
    /// Most adjustments.
    pub max: u32,
    /// Depth limits, mm.
    pub min_mm: f64,
    /// Depth limits, mm.
    pub max_mm: f64,
    /// The answer meaning "the comparison felt stronger" (depth decreases).
    pub stronger: String,
    /// The answer meaning "weaker" (depth increases).
    pub weaker: String,
    /// The answer that ends the trial.
    pub same: String,
}

/// One condition: a level per factor and the library entry it names.
#[derive(Debug, Clone, PartialEq)]
pub struct Condition {
    /// Level per factor, in factor order.
    pub levels: Vec<String>,
    /// The library entry's id.
    pub stimulus: String,
}

/// A checked protocol.
#[derive(Debug, Clone)]
pub struct Protocol {
    /// Its name.
    pub name: String,
    /// The file it came from.
    pub path: PathBuf,
    /// Its text (copied to `session.json`, compared on `--resume`).
    pub text: String,
    /// The library file (resolved against the protocol's folder).
    pub library_path: PathBuf,
    /// The library.
    pub library: Library,
    /// Sets; each a fresh permutation of every condition.
    pub sets: usize,
    /// The trial's timeline.
    pub timeline: Timeline,
    /// The factors.
    pub factors: Vec<Factor>,
    /// The factors' product, first factor slowest.
    pub conditions: Vec<Condition>,
    /// The questions, in the order asked.
    pub questions: Vec<Question>,
    /// The method of adjustment, if used.
    pub adjustment: Option<Adjustment>,
}

fn check_name(what: &str, s: &str) -> Result<(), String> {
    if s.is_empty()
        || s.len() > 64
        || !s
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
    {
        return Err(format!(
            "{what} `{}` must be 1 to 64 letters, digits, `-`, `_` or `.`",
            s.escape_debug()
        ));
    }
    Ok(())
}

fn check_label(what: &str, s: &str) -> Result<(), String> {
    if s.trim().is_empty() || s.len() > 200 || s.chars().any(char::is_control) {
        return Err(format!(
            "{what} `{}` must be 1 to 200 characters on one line",
            s.escape_debug()
        ));
    }
    Ok(())
}

fn seconds(what: &str, s: f64, zero_ok: bool) -> Result<f64, String> {
    if !s.is_finite() || !(0.0..=MAX_SECONDS).contains(&s) || (!zero_ok && s == 0.0) {
        return Err(format!(
            "{what} = {} is out of range: give seconds {} and at most {MAX_SECONDS}",
            crate::limits::show(s),
            if zero_ok { "from 0" } else { "above 0" }
        ));
    }
    Ok(s)
}

/// Fills `{factor}` placeholders of `template` with `levels`.
pub fn expand(template: &str, factors: &[Factor], levels: &[String]) -> Result<String, String> {
    let mut out = String::new();
    let mut rest = template;
    while let Some(i) = rest.find('{') {
        out.push_str(&rest[..i]);
        let Some(j) = rest[i..].find('}') else {
            return Err(format!(
                "stimulus template `{template}` has an unclosed `{{`"
            ));
        };
        let name = &rest[i + 1..i + j];
        let k = factors.iter().position(|f| f.name == name).ok_or_else(|| {
            format!("stimulus template `{template}` names `{{{name}}}`, which is not a factor")
        })?;
        out.push_str(&levels[k]);
        rest = &rest[i + j + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

impl Protocol {
    /// Reads and checks the protocol at `path` and its library.
    pub fn load(path: &Path) -> Result<Self, InputError> {
        let text = crate::limits::read_text_file("study protocol", path)?;
        Self::from_toml(&text, path)
    }

    /// Parses and checks protocol `text` (`path` resolves the library and
    /// names the file in errors).
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, InputError> {
        let origin = path.display().to_string();
        let bad = |msg: String| InputError::new(format!("study protocol {origin}: {msg}"));
        let file: File =
            toml::from_str(text).map_err(|e| bad(crate::plan::scene::toml_error_line(text, &e)))?;
        // Field errors after parsing name the field's line too.
        // The line of `field`, the first at or after the line that gives
        // `anchor` (a table's `id` or `name`).
        let line_of = |anchor: Option<(&str, &str)>, field: &str| {
            let lines: Vec<&str> = text.lines().collect();
            let key = |l: &str| l.split('=').next().unwrap_or("").trim().to_owned();
            let from = anchor
                .and_then(|(k, v)| {
                    lines.iter().position(|l| {
                        key(l) == k
                            && l.split('=')
                                .nth(1)
                                .is_some_and(|x| x.trim() == format!("\"{v}\""))
                    })
                })
                .unwrap_or(0);
            lines[from..]
                .iter()
                .position(|l| key(l) == field)
                .map(|n| format!("line {}, ", from + n + 1))
                .unwrap_or_default()
        };
        let at_in = |anchor: Option<(&str, &str)>, field: &str, msg: String| {
            bad(format!("{}field `{field}`: {msg}", line_of(anchor, field)))
        };
        let at = |field: &str, msg: String| at_in(None, field, msg);
        check_name("name", &file.name).map_err(|m| at("name", m))?;
        if !(1..=MAX_SETS).contains(&file.sets) {
            return Err(at(
                "sets",
                format!("{} is out of range 1..={MAX_SETS}", file.sets),
            ));
        }
        let t = &file.timeline;
        let on_s = t
            .on_s
            .map(|s| seconds("on_s", s, false))
            .transpose()
            .map_err(|m| at("on_s", m))?;
        if on_s.is_none() && !t.while_touching {
            return Err(at(
                "on_s",
                "give `on_s` or `while_touching = true` in [timeline]".into(),
            ));
        }
        if t.while_touching && !t.wait_for_finger {
            return Err(at(
                "while_touching",
                "needs `wait_for_finger = true` (it ends when the finger leaves)".into(),
            ));
        }
        let off_s = seconds("off_s", t.off_s, true).map_err(|m| at("off_s", m))?;
        let iti_s = seconds("iti_s", t.iti_s, true).map_err(|m| at("iti_s", m))?;
        let touch_s =
            seconds("touch_s", t.touch_s.unwrap_or(3.0), false).map_err(|m| at("touch_s", m))?;
        let repeat = t.repeat.unwrap_or(1);
        if !(1..=crate::lab::session::MAX_REPEAT).contains(&repeat) {
            return Err(at(
                "repeat",
                format!(
                    "{repeat} is out of range 1..={}",
                    crate::lab::session::MAX_REPEAT
                ),
            ));
        }
        if repeat > 1 && on_s.is_none() {
            return Err(at("repeat", "needs `on_s`".into()));
        }
        if file.adjustment.is_some() && (t.repeat.is_some() || on_s.is_none()) {
            return Err(at(
                "repeat",
                "an [adjustment] trial repeats its on/off phases until answered: give `on_s` and no `repeat`".into(),
            ));
        }
        let timeline = Timeline {
            wait_for_finger: t.wait_for_finger,
            on_s,
            while_touching: t.while_touching,
            off_s,
            repeat,
            iti_s,
            gate: t.gate,
            touch_s,
        };
        if file.factor.is_empty() {
            return Err(bad(
                "no factors: add at least one [[factor]] with `name` and `levels`".into(),
            ));
        }
        let mut factors: Vec<Factor> = Vec::new();
        for f in file.factor {
            check_name("factor name", &f.name).map_err(|m| at("name", m))?;
            if factors.iter().any(|x| x.name == f.name) {
                return Err(at("name", format!("factor `{}` is given twice", f.name)));
            }
            if f.levels.is_empty() {
                return Err(at("levels", format!("factor `{}` has no levels", f.name)));
            }
            for l in &f.levels {
                check_label("level", l).map_err(|m| at("levels", m))?;
            }
            factors.push(Factor {
                name: f.name,
                levels: f.levels,
            });
        }
        let n: usize = factors.iter().map(|f| f.levels.len()).product();
        if n > MAX_CONDITIONS {
            return Err(bad(format!(
                "{n} conditions; at most {MAX_CONDITIONS} fit one protocol"
            )));
        }
        let library_path = path.parent().unwrap_or(Path::new(".")).join(&file.library);
        let library = Library::load(&library_path).map_err(|e| {
            at(
                "library",
                format!("{e} (the path is relative to the protocol file)"),
            )
        })?;
        let mut conditions = Vec::with_capacity(n);
        for k in 0..n {
            let mut rest = k;
            let mut levels = vec![String::new(); factors.len()];
            for (i, f) in factors.iter().enumerate().rev() {
                levels[i] = f.levels[rest % f.levels.len()].clone();
                rest /= f.levels.len();
            }
            let stimulus =
                expand(&file.stimulus, &factors, &levels).map_err(|m| at("stimulus", m))?;
            if library.find(&stimulus).is_none() {
                return Err(at(
                    "stimulus",
                    format!(
                        "condition {} names stimulus `{}`, which is not in {}",
                        levels.join("/"),
                        stimulus.escape_debug(),
                        library_path.display()
                    ),
                ));
            }
            conditions.push(Condition { levels, stimulus });
        }
        if file.question.len() > MAX_QUESTIONS {
            return Err(bad(format!(
                "{} questions; at most {MAX_QUESTIONS}",
                file.question.len()
            )));
        }
        let mut questions: Vec<Question> = Vec::new();
        for q in file.question {
            let id = q.id.clone();
            let qbad = |field: &str, m: String| {
                at_in(Some(("id", &id)), field, format!("question `{id}`: {m}"))
            };
            check_name("question id", &q.id).map_err(|m| qbad("id", m))?;
            if questions.iter().any(|x| x.id == q.id) {
                return Err(qbad("id", "given twice".into()));
            }
            let only = |field: &str, given: bool, kind: &str| {
                if given {
                    Err(qbad(
                        field,
                        format!("`{field}` does not apply to a {kind} question"),
                    ))
                } else {
                    Ok(())
                }
            };
            let list = |field: &str, v: &[String]| -> Result<(), InputError> {
                if v.len() < 2 || v.len() > MAX_OPTIONS {
                    return Err(qbad(field, format!("give 2 to {MAX_OPTIONS} {field}")));
                }
                for (i, s) in v.iter().enumerate() {
                    check_label(field, s).map_err(|m| qbad(field, m))?;
                    if v[..i].contains(s) {
                        return Err(qbad(field, format!("`{s}` is given twice")));
                    }
                }
                Ok(())
            };
            for l in [&q.low, &q.high].into_iter().flatten() {
                check_label("label", l).map_err(|m| qbad("low", m))?;
            }
            let kind = match q.kind {
                KindFile::Likert => {
                    only("options", q.options.is_some(), "likert")?;
                    only("min", q.min.is_some(), "likert")?;
                    only("max", q.max.is_some(), "likert")?;
                    let points = q.points.unwrap_or(7);
                    if !(2..=MAX_OPTIONS as u32).contains(&points) {
                        return Err(qbad(
                            "points",
                            format!("{points} is out of range 2..={MAX_OPTIONS}"),
                        ));
                    }
                    let items = q.items.unwrap_or_default();
                    if !items.is_empty() {
                        list("items", &items)?;
                        for i in &items {
                            check_name("item", i).map_err(|m| qbad("items", m))?;
                        }
                    }
                    if q.shuffle && items.is_empty() {
                        return Err(qbad(
                            "shuffle",
                            "a likert question shuffles its `items`; give them".into(),
                        ));
                    }
                    Kind::Likert {
                        points,
                        low: q.low.unwrap_or_default(),
                        high: q.high.unwrap_or_default(),
                        items,
                    }
                }
                KindFile::Choice => {
                    only("points", q.points.is_some(), "choice")?;
                    only("items", q.items.is_some(), "choice")?;
                    only("min", q.min.is_some(), "choice")?;
                    only("max", q.max.is_some(), "choice")?;
                    let options = q.options.unwrap_or_default();
                    list("options", &options)?;
                    if let Some(o) = options.iter().find(|o| o.parse::<usize>().is_ok()) {
                        return Err(qbad(
                            "options",
                            format!(
                                "option `{o}` is a number; answers by number are 1-based indices"
                            ),
                        ));
                    }
                    Kind::Choice { options }
                }
                KindFile::Number => {
                    only("points", q.points.is_some(), "number")?;
                    only("items", q.items.is_some(), "number")?;
                    only("options", q.options.is_some(), "number")?;
                    only("shuffle", q.shuffle, "number")?;
                    let (min, max) = (q.min.unwrap_or(f64::MIN), q.max.unwrap_or(f64::MAX));
                    if !(min.is_finite() && max.is_finite() && min <= max) {
                        return Err(qbad("max", "give finite `min` <= `max`".into()));
                    }
                    Kind::Number { min, max }
                }
            };
            questions.push(Question {
                id: q.id,
                text: q.text,
                kind,
                shuffle: q.shuffle,
            });
        }
        let adjustment = file
            .adjustment
            .map(|a| -> Result<Adjustment, InputError> {
                let max_mm = a.max_mm.unwrap_or(100.0);
                if !(a.step_mm.is_finite() && a.step_mm > 0.0 && a.step_mm <= 100.0) {
                    return Err(at(
                        "step_mm",
                        "give millimetres above 0 and at most 100".into(),
                    ));
                }
                if !(a.min_mm.is_finite()
                    && max_mm.is_finite()
                    && a.min_mm <= a.start_mm
                    && a.start_mm <= max_mm)
                {
                    return Err(at(
                        "start_mm",
                        "give min_mm <= start_mm <= max_mm (max_mm defaults to 100)".into(),
                    ));
                }
                if !(1..=MAX_ADJUSTMENTS).contains(&a.max) {
                    return Err(at(
                        "max",
                        format!("{} is out of range 1..={MAX_ADJUSTMENTS}", a.max),
                    ));
                }
                for (f, l) in [
                    ("stronger", &a.stronger),
                    ("weaker", &a.weaker),
                    ("same", &a.same),
                ] {
                    check_label(f, l).map_err(|m| at(f, m))?;
                }
                if a.stronger == a.weaker || a.stronger == a.same || a.weaker == a.same {
                    return Err(at("same", "the three answers must differ".into()));
                }
                Ok(Adjustment {
                    text: a.text,
                    start_mm: a.start_mm,
                    step_mm: a.step_mm,
                    max: a.max,
                    min_mm: a.min_mm,
                    max_mm,
                    stronger: a.stronger,
                    weaker: a.weaker,
                    same: a.same,
                })
            })
            .transpose()?;
        let mut cols: Vec<String> = Vec::new();
        let names = factors
            .iter()
            .map(|f| f.name.clone())
            .chain(questions.iter().flat_map(Question::columns));
        {
            for c in names {
                if cols.contains(&c) || FIXED.contains(&c.as_str()) {
                    return Err(bad(format!(
                        "column `{c}` is used twice (factor and question names and trials.csv's own columns must differ)"
                    )));
                }
                cols.push(c);
            }
        }
        Ok(Self {
            name: file.name,
            path: path.to_owned(),
            text: text.to_owned(),
            library_path,
            library,
            sets: file.sets,
            timeline,
            factors,
            conditions,
            questions,
            adjustment,
        })
    }

    /// Trials in all: conditions × sets.
    pub fn trials(&self) -> usize {
        self.conditions.len() * self.sets
    }
}
