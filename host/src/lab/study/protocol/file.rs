//! The protocol file's TOML schema. A value that is wrong on its own (a
//! name, a label, seconds, a count out of range) is refused while parsing,
//! so the TOML error carries its line and field; fields checked against
//! others keep their place ([`Spanned`]) for [`super::check`]'s messages.
//!
//! The same types describe the file as a JSON Schema (`study::schema`):
//! each field's doc comment is its description, its range comes from the
//! constant the check uses, and a `Spanned<T>` field is described as `T`.

use schemars::{JsonSchema, Schema};
use serde::{Deserialize, Serialize};
use toml::Spanned;

use super::{
    DEFAULT_LAPSES, MAX_BLOCKS, MAX_LAPSE, MAX_LEVELS, MAX_NUMBER, MAX_OPTIONS, MAX_QUEST_GRID,
    MAX_QUESTIONS, MAX_SLOPE, MAX_STAIRCASE,
};
use crate::lab::session::{Gate, MAX_REPEAT};
use crate::whole::{FileNumber, Whole};

pub(super) use super::values::{
    Adjustments, AnswerLabel, Depth, Label, Name, Number, Presentations, Reversals, Run, Seconds,
    Sets, Step, Text, repeated,
};

/// A Likert question's points when it gives none.
pub(super) const DEFAULT_POINTS: u32 = 7;
/// How long the synthetic finger touches when `touch_s` is not given, s.
pub(super) const DEFAULT_TOUCH_S: f64 = 3.0;
/// The report's significance level when `alpha` is not given.
pub(super) const DEFAULT_ALPHA: f64 = 0.05;
/// Most reversals a staircase's threshold averages when
/// `threshold_reversals` is not given (fewer if it ends sooner).
pub(super) const DEFAULT_THRESHOLD_REVERSALS: u32 = 6;

/// A study protocol: which library, how many sets, the trial's timeline,
/// the factors whose product names the conditions, the questions and an
/// optional procedure (`[adjustment]` or `[staircase]`). `lmhost study
/// check PROTOCOL` checks it and prints its trial plan.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(title = "lmhost study protocol", transform = factor_required)]
pub(super) struct File {
    /// The study's name (in `session.json` and the report).
    pub name: Name,
    /// The stimulus library file, relative to this protocol's folder.
    #[schemars(with = "String")]
    pub library: Spanned<String>,
    /// Sets: each a fresh permutation of every condition.
    #[serde(default)]
    pub sets: Sets,
    /// How the conditions are ordered in each set.
    #[serde(default)]
    pub order: OrderFile,
    /// The library entry a condition presents: a template in which
    /// `{factor}` is the factor's level (and `{level}` a staircase's level),
    /// e.g. `"{type}-a{radius}"`.
    #[schemars(with = "String")]
    pub stimulus: Spanned<String>,
    /// How each trial plays.
    #[schemars(with = "TimelineFile")]
    pub timeline: Spanned<TimelineFile>,
    /// The factors: their product is the conditions, first factor slowest.
    #[serde(default)]
    #[schemars(length(min = 1))]
    pub factor: Vec<FactorFile>,
    /// The questions asked after each presentation, in order.
    #[serde(default)]
    #[schemars(length(max = MAX_QUESTIONS))]
    pub question: Vec<QuestionFile>,
    /// A method-of-adjustment trial (Experiment 3): the participant moves a
    /// depth until the comparison feels the same. Not with `[staircase]`.
    #[schemars(with = "Option<AdjustmentFile>")]
    pub adjustment: Option<Spanned<AdjustmentFile>>,
    /// An adaptive staircase over a grid of levels per condition.
    #[schemars(with = "Option<StaircaseFile>")]
    pub staircase: Option<Spanned<StaircaseFile>>,
    /// QUEST+ (Watson 2017) over a grid of levels per condition. Not with
    /// `[adjustment]` or `[staircase]`.
    #[schemars(with = "Option<QuestFile>")]
    pub quest: Option<Spanned<QuestFile>>,
    /// What `lmhost study report` tests; default: α = 0.05, repeats
    /// averaged, a Friedman test for each factor of 3 or more levels.
    pub report: Option<ReportFile>,
    /// Blocks of trials run one after another (none: one block of every
    /// condition with the protocol's `sets` and `order`).
    #[serde(default)]
    #[schemars(with = "Vec<BlockFile>", length(max = MAX_BLOCKS))]
    pub block: Vec<Spanned<BlockFile>>,
}

/// A block of trials (`[[block]]`, checked in `super::blocks`): the
/// conditions whose levels it names, in sets of its own, then an optional
/// break.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct BlockFile {
    /// The block's name (the `block` column of trials.csv).
    #[schemars(with = "Name")]
    pub name: Spanned<Name>,
    /// A practice block: its rows are written (`practice` = 1) and left
    /// out of `study report`.
    #[serde(default)]
    pub practice: bool,
    /// Sets in the block, each every one of its conditions once (default:
    /// the protocol's `sets`).
    pub sets: Option<Sets>,
    /// How its conditions are ordered in each set (default: the
    /// protocol's `order`).
    pub order: Option<OrderFile>,
    /// Per factor, the levels the block keeps, e.g. `{ radius = ["3"] }`
    /// (a factor not named: all its levels).
    #[serde(default)]
    #[schemars(with = "std::collections::BTreeMap<String, Vec<Label>>")]
    pub levels: std::collections::BTreeMap<String, Spanned<Vec<Label>>>,
    /// Seconds of silence after the block, before the next one (0: none).
    #[serde(default)]
    #[schemars(extend("x-unit" = "s"))]
    pub break_s: Seconds<true>,
    /// Shown to the participant as the block starts.
    pub text: Option<Label>,
}

/// The schema of [`File`]: serde takes a file without factors so that
/// the check can say what to add, but the file needs one.
fn factor_required(schema: &mut Schema) {
    crate::limits::require_in_schema(schema, "factor");
}

/// The `[timeline]` table: how a trial plays.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct TimelineFile {
    /// Wait until a finger is present before presenting.
    #[serde(default)]
    pub wait_for_finger: bool,
    /// Seconds per on-phase; give it or `while_touching = true`.
    #[schemars(with = "Option<Seconds<false>>", extend("x-unit" = "s"))]
    pub on_s: Option<Spanned<Seconds<false>>>,
    /// Present until the finger leaves (ends an on-phase early too); needs
    /// `wait_for_finger = true`.
    #[schemars(with = "Option<bool>", extend("default" = false))]
    pub while_touching: Option<Spanned<bool>>,
    /// Seconds of silence between on-phases; needs `repeat` 2 or more, or
    /// a procedure (whose trial repeats until answered).
    #[serde(default)]
    #[schemars(with = "Seconds<true>", extend("x-unit" = "s", "default" = 0.0))]
    pub off_s: Option<Spanned<Seconds<true>>>,
    /// On-phases per trial; needs `on_s`, not with a procedure (whose
    /// trial repeats until answered).
    #[schemars(with = "Option<u32>", range(min = 1, max = MAX_REPEAT), extend("default" = 1))]
    pub repeat: Option<Spanned<Whole<1, { MAX_REPEAT as u64 }>>>,
    /// Seconds between trials (the answering time comes on top).
    #[serde(default)]
    #[schemars(extend("x-unit" = "s"))]
    pub iti_s: Seconds<true>,
    /// `tracked` (muted until a finger is tracked, steered to it) or
    /// `untracked`; default: each library entry's own.
    pub gate: Option<Gate>,
    /// How long the synthetic finger (`--synthetic-finger`) touches in a
    /// `while_touching` trial.
    #[schemars(extend("x-unit" = "s", "default" = DEFAULT_TOUCH_S))]
    pub touch_s: Option<Seconds<false>>,
}

/// A `[[factor]]`: a name and its levels.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct FactorFile {
    /// Its name: a column of `trials.csv`, `{name}` in the stimulus template.
    #[schemars(with = "Name")]
    pub name: Spanned<Name>,
    /// Its levels, each once.
    #[schemars(with = "Vec<Label>", length(min = 1))]
    pub levels: Spanned<Vec<Label>>,
}

/// What a question asks for.
#[derive(Debug, Clone, Copy, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub(super) enum KindFile {
    /// A rating 1..=`points` between two end labels (one per item if `items`).
    Likert,
    /// One of `options`.
    Choice,
    /// A number within `min`..=`max`.
    Number,
}

/// A `[[question]]`, asked after each presentation.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct QuestionFile {
    /// Its id: the answer's column in `trials.csv`.
    #[schemars(with = "Name")]
    pub id: Spanned<Name>,
    /// `likert`, `choice` or `number`.
    pub kind: KindFile,
    /// What the participant is asked.
    #[serde(default)]
    pub text: Text,
    /// Likert only: the scale's points.
    #[schemars(
        with = "Option<u32>",
        range(min = 2, max = MAX_OPTIONS),
        extend("default" = DEFAULT_POINTS),
    )]
    pub points: Option<Spanned<FileNumber>>,
    /// Likert only: the label of 1.
    #[schemars(with = "Option<Label>")]
    pub low: Option<Spanned<Label>>,
    /// Likert only: the label of `points`.
    #[schemars(with = "Option<Label>")]
    pub high: Option<Spanned<Label>>,
    /// Likert only: one rating per item (columns `id_item`), each once.
    #[schemars(with = "Option<Vec<Name>>", length(min = 2, max = MAX_OPTIONS))]
    pub items: Option<Spanned<Vec<Name>>>,
    /// Choice only: the options, told apart as answers are (ignoring case).
    #[schemars(with = "Option<Vec<AnswerLabel>>", length(min = 2, max = MAX_OPTIONS))]
    pub options: Option<Spanned<Vec<AnswerLabel>>>,
    /// Show a likert question's items or a choice's options in a random
    /// order per trial (recorded in `id_order`).
    #[schemars(with = "Option<bool>", extend("default" = false))]
    pub shuffle: Option<Spanned<bool>>,
    /// Number only: the least answer.
    #[schemars(with = "Option<Number>", extend("default" = -MAX_NUMBER))]
    pub min: Option<Spanned<Number>>,
    /// Number only: the greatest answer (at least `min`).
    #[schemars(with = "Option<Number>", extend("default" = MAX_NUMBER))]
    pub max: Option<Spanned<Number>>,
    /// What "not perceived" is shown as; the participant types `na` for it.
    /// Default: no such answer.
    #[schemars(with = "Option<Label>")]
    pub not_perceived: Option<Spanned<Label>>,
}

/// The `[adjustment]` table: the method of adjustment.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct AdjustmentFile {
    /// What the participant is asked.
    #[serde(default)]
    pub text: Text,
    /// The first depth.
    #[schemars(with = "Depth", extend("x-unit" = "mm"))]
    pub start_mm: Spanned<Depth>,
    /// The change per answer.
    #[serde(default = "quarter")]
    #[schemars(extend("x-unit" = "mm"))]
    pub step_mm: Step,
    /// Most adjustments per trial.
    #[serde(default)]
    pub max: Adjustments,
    /// The least depth.
    #[serde(default)]
    #[schemars(extend("x-unit" = "mm"))]
    pub min_mm: Depth,
    /// The greatest depth.
    #[serde(default = "hundred")]
    #[schemars(extend("x-unit" = "mm"))]
    pub max_mm: Depth,
    /// The answer "the comparison felt stronger" (the depth decreases).
    #[serde(default = "stronger")]
    #[schemars(with = "AnswerLabel")]
    pub stronger: Spanned<AnswerLabel>,
    /// The answer "weaker" (the depth increases).
    #[serde(default = "weaker")]
    #[schemars(with = "AnswerLabel")]
    pub weaker: Spanned<AnswerLabel>,
    /// The answer that ends the trial.
    #[serde(default = "same")]
    #[schemars(with = "AnswerLabel")]
    pub same: Spanned<AnswerLabel>,
}

/// The `[staircase]` table (checked in `super::staircase`): a transformed
/// up-down staircase over a grid of levels, one per condition.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct StaircaseFile {
    /// The yes/no question asked after each presentation.
    #[serde(default = "perceived_text")]
    pub text: Label,
    /// The levels' unit (a column name in the report).
    #[serde(default = "level_unit")]
    pub unit: Name,
    /// The grid: numbers in increasing order, as text (`{level}` in the
    /// stimulus template).
    #[schemars(with = "Vec<Label>", length(min = 2, max = MAX_LEVELS))]
    pub levels: Spanned<Vec<Label>>,
    /// The level it starts at; default the last (strongest).
    #[schemars(with = "Option<Label>")]
    pub start: Option<Spanned<Label>>,
    /// "No" answers in a row that move one step up.
    #[serde(default)]
    pub up: Run,
    /// "Yes" answers in a row that move one step down.
    #[serde(default = "two")]
    pub down: Run,
    /// Grid places per step, by reversals so far (the last repeats), each
    /// 1 to the levels less one, and no more of them than the staircase
    /// can use (at most `reversals`; fewer when `trials` ends it sooner);
    /// default `[1]`.
    #[schemars(
        with = "Option<Vec<u32>>",
        length(min = 1),
        inner(range(min = 1, max = MAX_LEVELS - 1)),
    )]
    pub steps: Option<Spanned<Vec<FileNumber>>>,
    /// Reversals that end it.
    #[serde(default)]
    pub reversals: Reversals,
    /// Presentations that end it.
    #[serde(default)]
    pub trials: Presentations,
    /// The last reversals whose levels average to the threshold, at most
    /// `reversals`; default the least of `reversals` and 6.
    #[schemars(with = "Option<u32>", range(min = 1, max = MAX_STAIRCASE))]
    pub threshold_reversals: Option<Spanned<FileNumber>>,
    /// The answer "perceived".
    #[serde(default = "yes")]
    #[schemars(with = "AnswerLabel")]
    pub yes: Spanned<AnswerLabel>,
    /// The answer "not perceived" (differs from `yes`, also in case).
    #[serde(default = "no")]
    #[schemars(with = "AnswerLabel")]
    pub no: Spanned<AnswerLabel>,
}

/// The `[quest]` table (checked in `super::quest`): QUEST+ over a grid
/// of levels, each a library entry. A level, a threshold and `stop_sd`
/// are in `unit`; a logistic's slope is per `unit`, a Weibull's is its
/// exponent.
#[derive(Debug, Deserialize, JsonSchema)]
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
    #[schemars(with = "Vec<Label>", length(min = 2, max = MAX_LEVELS))]
    pub levels: Spanned<Vec<Label>>,
    /// The psychometric function's core: `logistic` or `weibull`
    /// [logistic].
    #[serde(default)]
    pub shape: ShapeFile,
    /// Candidate thresholds, `unit`: 1 to 200 finite numbers, ascending
    /// (above 0 for a Weibull) [the levels].
    #[schemars(
        with = "Option<Vec<f64>>",
        length(min = 1, max = MAX_LEVELS),
        inner(range(min = -MAX_NUMBER, max = MAX_NUMBER))
    )]
    pub thresholds: Option<Spanned<Vec<f64>>>,
    /// Candidate slopes: 1 to 20 numbers above 0 and at most 1e6
    /// (required: a slope's size depends on the unit).
    #[schemars(
        with = "Vec<f64>",
        length(min = 1, max = MAX_QUEST_GRID),
        inner(range(min = 0.0, max = MAX_SLOPE))
    )]
    pub slopes: Spanned<Vec<f64>>,
    /// Candidate lapse rates: 1 to 20 numbers from 0, below 0.5 [0.02].
    #[schemars(
        with = "Option<Vec<f64>>",
        length(min = 1, max = MAX_QUEST_GRID),
        inner(range(min = 0.0, max = MAX_LAPSE)),
        extend("default" = DEFAULT_LAPSES)
    )]
    pub lapses: Option<Spanned<Vec<f64>>>,
    /// The guess rate, "perceived" far below threshold: from 0, below 1,
    /// and with every lapse rate below 1 [0].
    #[schemars(with = "Option<f64>", range(min = 0.0, max = 1.0), extend("default" = 0.0))]
    pub guess: Option<Spanned<f64>>,
    /// Presentations that end it, 1 to 1000 [50].
    #[serde(default)]
    pub trials: Presentations,
    /// Ends it earlier once the threshold's posterior standard deviation
    /// is below this, `unit`, above 0 [none: `trials` presentations].
    #[schemars(with = "Option<f64>", range(min = 0.0, max = MAX_NUMBER))]
    pub stop_sd: Option<Spanned<f64>>,
    /// The answer "perceived" [yes].
    #[serde(default = "yes")]
    #[schemars(with = "AnswerLabel")]
    pub yes: Spanned<AnswerLabel>,
    /// The answer "not perceived" [no].
    #[serde(default = "no")]
    #[schemars(with = "AnswerLabel")]
    pub no: Spanned<AnswerLabel>,
}

/// A psychometric function's core in a `[quest]` table.
#[derive(Debug, Clone, Copy, Default, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub(super) enum ShapeFile {
    /// `1 / (1 + exp(-slope (x - threshold)))`.
    #[default]
    Logistic,
    /// `1 - exp(-(x / threshold)^slope)`.
    Weibull,
}

/// The `[report]` table (checked in `check::report`): what `lmhost study
/// report` tests.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct ReportFile {
    /// The significance level, between 0 and 1 (exclusive).
    #[schemars(
        with = "Option<f64>",
        extend("exclusiveMinimum" = 0.0, "exclusiveMaximum" = 1.0, "default" = DEFAULT_ALPHA)
    )]
    pub alpha: Option<Spanned<f64>>,
    /// How a participant's repeats of a condition are combined.
    #[serde(default)]
    pub repeats: RepeatsFile,
    /// The factors a Friedman test compares (each of 3 or more levels);
    /// default: every such factor.
    #[schemars(with = "Option<Vec<Name>>")]
    pub friedman: Option<Spanned<Vec<Name>>>,
    /// Paired comparisons (Wilcoxon signed-rank, Holm-corrected) of a
    /// factor's levels.
    #[serde(default)]
    pub pairs: Vec<PairsFile>,
}

/// How the conditions are ordered in each set.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub(super) enum OrderFile {
    /// Each set a fresh random permutation.
    #[default]
    Random,
    /// Each set in the protocol's order (the factors' product, first
    /// factor slowest).
    Sequential,
    /// Every set's trials shuffled together.
    FullRandom,
    /// Each set in the participant's row of a balanced Latin square.
    LatinSquare,
}

/// How a participant's repeats of a condition are combined.
#[derive(Debug, Default, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub(super) enum RepeatsFile {
    /// Their mean.
    #[default]
    Mean,
    /// Their median.
    Median,
}

/// A `[[report.pairs]]`: paired comparisons of one factor's levels.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct PairsFile {
    /// The factor.
    #[schemars(with = "Name")]
    pub factor: Spanned<Name>,
    /// The pairs of its levels, e.g. `[["2", "4"], ["4", "6"]]`; default
    /// every pair.
    #[schemars(with = "Option<Vec<(Label, Label)>>")]
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
/// An answer label's default (`#[serde(default = …)]` takes a function
/// per label): it has no place in the file, so an empty span.
fn default_answer(label: &str) -> Spanned<AnswerLabel> {
    Spanned::new(0..0, AnswerLabel(label.into()))
}
fn yes() -> Spanned<AnswerLabel> {
    default_answer("yes")
}
fn no() -> Spanned<AnswerLabel> {
    default_answer("no")
}
fn quarter() -> Step {
    Step(0.25)
}
fn hundred() -> Depth {
    Depth(100.0)
}
fn stronger() -> Spanned<AnswerLabel> {
    default_answer("stronger")
}
fn weaker() -> Spanned<AnswerLabel> {
    default_answer("weaker")
}
fn same() -> Spanned<AnswerLabel> {
    default_answer("same")
}
