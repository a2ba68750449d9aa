//! The protocol file's TOML schema. A value that is wrong on its own (a
//! name, a label, seconds, a count out of range) is refused while parsing,
//! so the TOML error carries its line and field; fields checked against
//! others keep their place ([`Spanned`]) for [`super::check`]'s messages.

use serde::Deserialize;
use toml::Spanned;

use super::{
    MAX_ADJUSTMENTS, MAX_DEPTH_MM, MAX_NUMBER, MAX_RUN, MAX_SECONDS, MAX_SETS, MAX_STAIRCASE,
};
use crate::lab::session::Gate;
use crate::lab::study::columns::{LIST_SEPARATOR, MAX_LABEL_BYTES};
use crate::limits::show;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct File {
    pub name: Name,
    pub library: Spanned<String>,
    #[serde(default)]
    pub sets: Sets,
    #[serde(default)]
    pub order: OrderFile,
    pub stimulus: Spanned<String>,
    pub timeline: Spanned<TimelineFile>,
    #[serde(default)]
    pub factor: Vec<FactorFile>,
    #[serde(default)]
    pub question: Vec<QuestionFile>,
    pub adjustment: Option<Spanned<AdjustmentFile>>,
    pub staircase: Option<Spanned<StaircaseFile>>,
    pub quest: Option<Spanned<QuestFile>>,
    pub report: Option<ReportFile>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct TimelineFile {
    #[serde(default)]
    pub wait_for_finger: bool,
    pub on_s: Option<Spanned<Seconds<false>>>,
    pub while_touching: Option<Spanned<bool>>,
    #[serde(default)]
    pub off_s: Seconds<true>,
    pub repeat: Option<Spanned<u32>>,
    #[serde(default)]
    pub iti_s: Seconds<true>,
    pub gate: Option<Gate>,
    pub touch_s: Option<Seconds<false>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct FactorFile {
    pub name: Spanned<Name>,
    pub levels: Spanned<Vec<Label>>,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub(super) enum KindFile {
    Likert,
    Choice,
    Number,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct QuestionFile {
    pub id: Spanned<Name>,
    pub kind: KindFile,
    #[serde(default)]
    pub text: String,
    pub points: Option<Spanned<u32>>,
    pub low: Option<Spanned<Label>>,
    pub high: Option<Spanned<Label>>,
    pub items: Option<Spanned<Vec<Name>>>,
    pub options: Option<Spanned<Vec<AnswerLabel>>>,
    pub shuffle: Option<Spanned<bool>>,
    pub min: Option<Spanned<Number>>,
    pub max: Option<Spanned<Number>>,
    pub not_perceived: Option<Spanned<Label>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct AdjustmentFile {
    #[serde(default)]
    pub text: String,
    pub start_mm: Spanned<Depth>,
    #[serde(default = "quarter")]
    pub step_mm: Step,
    #[serde(default)]
    pub max: Adjustments,
    #[serde(default)]
    pub min_mm: Depth,
    #[serde(default = "hundred")]
    pub max_mm: Depth,
    #[serde(default = "stronger")]
    pub stronger: Spanned<AnswerLabel>,
    #[serde(default = "weaker")]
    pub weaker: Spanned<AnswerLabel>,
    #[serde(default = "same")]
    pub same: Spanned<AnswerLabel>,
}

/// The `[staircase]` table (checked in `super::staircase`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct StaircaseFile {
    #[serde(default = "perceived_text")]
    pub text: Label,
    #[serde(default = "level_unit")]
    pub unit: Name,
    pub levels: Spanned<Vec<Label>>,
    pub start: Option<Spanned<Label>>,
    #[serde(default)]
    pub up: Run,
    #[serde(default = "two")]
    pub down: Run,
    pub steps: Option<Spanned<Vec<u32>>>,
    #[serde(default)]
    pub reversals: Reversals,
    #[serde(default)]
    pub trials: Presentations,
    pub threshold_reversals: Option<Spanned<u32>>,
    #[serde(default = "yes")]
    pub yes: Spanned<AnswerLabel>,
    #[serde(default = "no")]
    pub no: Spanned<AnswerLabel>,
}

/// The `[quest]` table (checked in `super::quest`): QUEST+ over a grid
/// of levels, each a library entry. A level, a threshold and `stop_sd`
/// are in `unit`; a logistic's slope is per `unit`, a Weibull's is its
/// exponent.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct QuestFile {
    /// What the participant is asked after each presentation [Did you
    /// feel the stimulus?].
    #[serde(default = "perceived_text")]
    pub text: Label,
    /// What a level is, a name [level].
    #[serde(default = "level_unit")]
    pub unit: Name,
    /// The levels: 2 to 200 numbers as strings, ascending, each filling
    /// `{level}` in the stimulus template to name a library entry
    /// (required).
    pub levels: Spanned<Vec<Label>>,
    /// The psychometric function's core: `logistic` or `weibull`
    /// [logistic].
    #[serde(default)]
    pub shape: ShapeFile,
    /// Candidate thresholds, `unit`: 1 to 200 finite numbers, ascending
    /// (above 0 for a Weibull) [the levels].
    pub thresholds: Option<Spanned<Vec<f64>>>,
    /// Candidate slopes: 1 to 20 numbers above 0 and at most 1e6
    /// (required: a slope's size depends on the unit).
    pub slopes: Spanned<Vec<f64>>,
    /// Candidate lapse rates: 1 to 20 numbers from 0, below 0.5 [0.02].
    pub lapses: Option<Spanned<Vec<f64>>>,
    /// The guess rate, "perceived" far below threshold: from 0, below 1,
    /// and with every lapse rate below 1 [0].
    pub guess: Option<Spanned<f64>>,
    /// Presentations that end it, 1 to 1000 [50].
    #[serde(default)]
    pub trials: Presentations,
    /// Ends it earlier once the threshold's posterior standard deviation
    /// is below this, `unit`, above 0 [none: `trials` presentations].
    pub stop_sd: Option<Spanned<f64>>,
    /// The answer "perceived" [yes].
    #[serde(default = "yes")]
    pub yes: Spanned<AnswerLabel>,
    /// The answer "not perceived" [no].
    #[serde(default = "no")]
    pub no: Spanned<AnswerLabel>,
}

/// A psychometric function's core in a `[quest]` table.
#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum ShapeFile {
    /// `1 / (1 + exp(-slope (x - threshold)))`.
    #[default]
    Logistic,
    /// `1 - exp(-(x / threshold)^slope)`.
    Weibull,
}

/// The `[report]` table (checked in `check::report`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ReportFile {
    pub alpha: Option<Spanned<f64>>,
    #[serde(default)]
    pub repeats: RepeatsFile,
    pub friedman: Option<Spanned<Vec<Name>>>,
    #[serde(default)]
    pub pairs: Vec<PairsFile>,
}

#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum OrderFile {
    #[default]
    Random,
    Sequential,
    FullRandom,
    LatinSquare,
}

#[derive(Debug, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RepeatsFile {
    #[default]
    Mean,
    Median,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PairsFile {
    pub factor: Spanned<Name>,
    pub pairs: Option<Spanned<Vec<(Label, Label)>>>,
}

fn perceived_text() -> Label {
    Label("Did you feel the stimulus?".into())
}
fn level_unit() -> Name {
    Name("level".into())
}
fn two() -> Run {
    Run(2)
}
fn yes() -> Spanned<AnswerLabel> {
    Spanned::new(0..0, AnswerLabel("yes".into()))
}
fn no() -> Spanned<AnswerLabel> {
    Spanned::new(0..0, AnswerLabel("no".into()))
}
fn quarter() -> Step {
    Step(0.25)
}
fn hundred() -> Depth {
    Depth(100.0)
}
// A default has no place in the file: an empty span.
fn stronger() -> Spanned<AnswerLabel> {
    Spanned::new(0..0, AnswerLabel("stronger".into()))
}
fn weaker() -> Spanned<AnswerLabel> {
    Spanned::new(0..0, AnswerLabel("weaker".into()))
}
fn same() -> Spanned<AnswerLabel> {
    Spanned::new(0..0, AnswerLabel("same".into()))
}

/// A value checked on its own as it is parsed: `check` says why not.
macro_rules! checked {
    ($(#[$m:meta])* $name:ident($t:ty as $ts:literal), $default:expr, |$v:ident| $check:expr) => {
        $(#[$m])*
        #[derive(Debug, Clone, PartialEq, Deserialize)]
        #[serde(try_from = $ts)]
        pub(super) struct $name(pub $t);

        impl TryFrom<$t> for $name {
            type Error = String;
            fn try_from($v: $t) -> Result<Self, String> {
                let r: Result<(), String> = $check;
                r.map(|()| Self($v))
            }
        }

        impl Default for $name {
            fn default() -> Self {
                Self($default)
            }
        }
    };
}

checked!(
    /// A name: 1 to 64 letters, digits, `-`, `_` or `.` (a column, an item).
    Name(String as "String"), String::new(), |v| check_name(&v)
);
checked!(
    /// A label shown or recorded: 1 to 200 bytes on one line.
    Label(String as "String"), String::new(), |v| check_label(&v)
);
checked!(
    /// An answer's label: a [`Label`] a participant can type back and that
    /// trials.csv's lists can hold.
    AnswerLabel(String as "String"), String::new(), |v| check_answer_label(&v)
);
checked!(
    /// Sets: each a fresh permutation of every condition.
    Sets(usize as "usize"), 1, |v| in_range(v as f64, 1.0, MAX_SETS as f64)
);
checked!(
    /// Most adjustments per trial.
    Adjustments(u32 as "u32"), 20, |v| in_range(f64::from(v), 1.0, f64::from(MAX_ADJUSTMENTS))
);
checked!(
    /// Answers in a row that move a staircase (its `up` and `down`).
    Run(u32 as "u32"), 1, |v| in_range(f64::from(v), 1.0, f64::from(MAX_RUN))
);
checked!(
    /// Reversals that end a staircase.
    Reversals(u32 as "u32"), 8, |v| in_range(f64::from(v), 1.0, f64::from(MAX_STAIRCASE))
);
checked!(
    /// Presentations that end a staircase.
    Presentations(u32 as "u32"), 50, |v| in_range(f64::from(v), 1.0, f64::from(MAX_STAIRCASE))
);
checked!(
    /// A depth, mm.
    Depth(f64 as "f64"), 0.0, |v| millimetres(v, -MAX_DEPTH_MM, MAX_DEPTH_MM)
);
checked!(
    /// An adjustment step, mm.
    Step(f64 as "f64"), 0.25, |v| step(v)
);
checked!(
    /// A number question's limit.
    Number(f64 as "f64"), 0.0, |v| in_range(v, -MAX_NUMBER, MAX_NUMBER)
);

/// Seconds, from 0 when `ZERO_OK`, else above 0, at most [`MAX_SECONDS`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Deserialize)]
#[serde(try_from = "f64")]
pub(super) struct Seconds<const ZERO_OK: bool>(pub f64);

impl<const ZERO_OK: bool> TryFrom<f64> for Seconds<ZERO_OK> {
    type Error = String;
    fn try_from(s: f64) -> Result<Self, String> {
        if !s.is_finite() || !(0.0..=MAX_SECONDS).contains(&s) || (!ZERO_OK && s == 0.0) {
            return Err(format!(
                "{} is out of range: give seconds {} and at most {MAX_SECONDS}",
                show(s),
                if ZERO_OK { "from 0" } else { "above 0" }
            ));
        }
        Ok(Self(s))
    }
}

fn in_range(v: f64, lo: f64, hi: f64) -> Result<(), String> {
    if v.is_finite() && lo <= v && v <= hi {
        Ok(())
    } else {
        Err(format!(
            "{} is out of range {}..={}",
            show(v),
            show(lo),
            show(hi)
        ))
    }
}

fn millimetres(v: f64, lo: f64, hi: f64) -> Result<(), String> {
    in_range(v, lo, hi).map_err(|m| format!("{m} mm"))
}

fn step(v: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 && v <= 100.0 {
        Ok(())
    } else {
        Err(format!(
            "{} is out of range: give millimetres above 0 and at most 100",
            show(v)
        ))
    }
}

/// 1 to 64 letters, digits, `-`, `_` or `.`.
pub(super) fn check_name(s: &str) -> Result<(), String> {
    if s.is_empty()
        || s.len() > 64
        || !s
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
    {
        return Err(format!(
            "`{}` must be 1 to 64 letters, digits, `-`, `_` or `.`",
            s.escape_debug()
        ));
    }
    Ok(())
}

/// 1 to [`MAX_LABEL_BYTES`] bytes on one line, not blank.
pub(super) fn check_label(s: &str) -> Result<(), String> {
    if s.trim().is_empty() || s.len() > MAX_LABEL_BYTES || s.chars().any(char::is_control) {
        return Err(format!(
            "`{}` must be 1 to {MAX_LABEL_BYTES} characters on one line",
            s.escape_debug()
        ));
    }
    Ok(())
}

/// A label that answers are matched to: an answer is trimmed and a number
/// picks an option by its place, so a label may not have spaces at its
/// ends nor be a whole number; trials.csv joins answers with `|`.
pub(super) fn check_answer_label(s: &str) -> Result<(), String> {
    check_label(s)?;
    if s.trim() != s {
        return Err(format!(
            "`{}` has spaces at an end; answers are trimmed, so it could not be given",
            s.escape_debug()
        ));
    }
    if s.parse::<usize>().is_ok() {
        return Err(format!(
            "`{s}` is a number; answers by number are 1-based indices"
        ));
    }
    if s.contains(LIST_SEPARATOR) {
        return Err(format!(
            "`{s}` holds `{LIST_SEPARATOR}`, which separates answers in trials.csv"
        ));
    }
    Ok(())
}

/// The first label of `v` that repeats an earlier one, ignoring ASCII case
/// as answers are matched.
pub(super) fn repeated(v: &[&str]) -> Option<(usize, usize)> {
    (0..v.len()).find_map(|j| {
        (0..j)
            .find(|&i| v[i].eq_ignore_ascii_case(v[j]))
            .map(|i| (i, j))
    })
}
