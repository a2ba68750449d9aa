//! `trials.csv`'s header, once: every column's name and what it holds, in
//! the order written. The runner fills a [`Row`] by column name, resume
//! and the report check every value against what its column holds, and
//! the protocol refuses factor and question names that would repeat a
//! column. Nothing here knows the protocol's file format.

/// The columns before the factors.
pub const PARTICIPANT: &str = "participant";
/// The 1-based trial number.
pub const TRIAL: &str = "trial";
/// The 1-based set.
pub const SET: &str = "set";
/// The library entry presented.
pub const STIMULUS: &str = "stimulus";
/// The block's name, where the protocol has blocks.
pub const BLOCK: &str = "block";
/// `1` in a practice block's rows, else `0` (where the protocol has
/// blocks); `study report` leaves practice rows out.
pub const PRACTICE: &str = "practice";
/// The columns after the factors: timing as realised and played.
pub const TIMING: [&str; 12] = [
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
];
/// What a timing or health column holds (counts are whole).
fn measured(name: &str) -> Holds {
    match name {
        "steps" | "onset_us" | "offset_us" | "on_phases" | "mutes" => Holds::Tally,
        "present_fraction" => Holds::Fraction,
        MISSED_DEADLINES | LEASE_EXPIRIES => Holds::Tally,
        _ => Holds::Measured,
    }
}

/// Wall-clock time of the trial's start, RFC 3339 UTC (to the ms).
pub const TIME_UTC: &str = "time_utc";
/// The device's missed deadlines during the trial (its status before and
/// after; empty when the device does not count them).
pub const MISSED_DEADLINES: &str = "missed_deadlines";
/// The device's lease expiries (mutes for want of the host) during the
/// trial.
pub const LEASE_EXPIRIES: &str = "lease_expiries";
/// What a "not perceived" answer is typed as and recorded as, in a column
/// whose question allows it: its own value, never a number.
pub const NOT_PERCEIVED: &str = "na";
/// The response-time column of answer column `column`: seconds from the
/// question being asked to its answer.
pub fn rt_column(column: &str) -> String {
    format!("{column}_rt_s")
}
/// How many answers the trial took (questions and procedure), so a resumed
/// run skips exactly those in a responses file.
pub const ANSWERS: &str = "answers";
/// The adjustment's columns, where used.
pub const START_DEPTH: &str = "start_depth_mm";
/// Adjustments made (answers that changed the depth).
pub const ADJUSTMENTS: &str = "adjustments";
/// The adjustment answers in order, `|`-joined.
pub const ADJUST_ANSWERS: &str = "adjust_answers";
/// Every depth presented, `|`-joined.
pub const DEPTHS: &str = "depths_mm";
/// The depth the trial ended at.
pub const FINAL_DEPTH: &str = "final_depth_mm";
/// The staircase's columns, where used: the level of each presentation
/// (`|`-joined level labels).
pub const STAIRCASE_LEVELS: &str = "staircase_levels";
/// Its answers in order, `|`-joined.
pub const STAIRCASE_ANSWERS: &str = "staircase_answers";
/// The level at each reversal, `|`-joined.
pub const STAIRCASE_REVERSALS: &str = "staircase_reversals";
/// Presentations at a level the grid's ends cut a staircase's move short
/// to (a move the trial ended before presenting is not counted).
pub const STAIRCASE_AT_LIMIT: &str = "staircase_at_limit";
/// The threshold: a staircase's mean level of the last reversals (empty
/// without a reversal), QUEST+'s posterior mean.
pub const THRESHOLD: &str = "threshold";
/// QUEST+'s columns, where used: the level of each presentation.
pub const QUEST_LEVELS: &str = "quest_levels";
/// Its answers in order, `|`-joined.
pub const QUEST_ANSWERS: &str = "quest_answers";
/// The threshold's posterior standard deviation.
pub const THRESHOLD_SD: &str = "threshold_sd";
/// The response time of each adjustment answer, s, `|`-joined (as
/// [`rt_column`] is for a question).
pub const ADJUST_RT: &str = "adjust_rt_s";
/// The median force of the gauge's 2 s series at the depth the trial
/// ended at, N (Experiment 3 run with a stage and gauge; empty without).
pub const FORCE: &str = "force_n";
/// Joins the values of a list column (option orders, adjustment answers
/// and depths); labels may not contain it.
pub const LIST_SEPARATOR: char = '|';

/// Every name the runner writes itself (factor and question names must
/// differ from them).
pub fn fixed() -> impl Iterator<Item = &'static str> {
    [
        PARTICIPANT,
        TRIAL,
        SET,
        BLOCK,
        PRACTICE,
        STIMULUS,
        TIME_UTC,
        ANSWERS,
    ]
    .into_iter()
    .chain(TIMING)
    .chain([MISSED_DEADLINES, LEASE_EXPIRIES])
    .chain([
        START_DEPTH,
        ADJUSTMENTS,
        ADJUST_ANSWERS,
        DEPTHS,
        FINAL_DEPTH,
        ADJUST_RT,
        FORCE,
    ])
    .chain([
        STAIRCASE_LEVELS,
        STAIRCASE_ANSWERS,
        STAIRCASE_REVERSALS,
        STAIRCASE_AT_LIMIT,
        THRESHOLD,
    ])
    .chain([QUEST_LEVELS, QUEST_ANSWERS, THRESHOLD_SD])
}

/// Longest label (factor level, option, adjustment answer), bytes.
pub const MAX_LABEL_BYTES: usize = 200;

/// Whether `s` is a time as `provenance::rfc3339_utc` writes it
/// (`2026-11-26T08:41:59.123Z`); never empty, for a run always writes one.
pub fn is_rfc3339_utc(s: &str) -> bool {
    // Digits where the pattern has `0`, the pattern's byte elsewhere.
    const PATTERN: &[u8; 24] = b"0000-00-00T00:00:00.000Z";
    let num = |r: std::ops::Range<usize>| s[r].parse::<u32>().unwrap_or(u32::MAX);
    s.len() == PATTERN.len()
        && s.bytes().zip(PATTERN).all(|(c, &p)| match p {
            b'0' => c.is_ascii_digit(),
            _ => c == p,
        })
        && (1..=12).contains(&num(5..7))
        && (1..=31).contains(&num(8..10))
        && num(11..13) < 24
        && num(14..16) < 60
        && num(17..19) < 61
}

/// What a column holds, and so which values it accepts.
#[derive(Debug, Clone, PartialEq)]
pub enum Holds {
    /// The participant's id.
    Participant,
    /// A 1-based count (trial, set).
    Count,
    /// A library entry's id.
    Stimulus,
    /// One of a factor's levels.
    Level(Vec<String>),
    /// A measured quantity, from 0 (empty when not measured).
    Measured,
    /// A measured count, a whole number from 0 (empty when not measured).
    Tally,
    /// A measured share, 0 to 1 (empty when not measured).
    Fraction,
    /// A wall-clock time, RFC 3339 UTC.
    Time,
    /// A count of answers.
    Answers,
    /// A Likert point, 1..=points (empty: not asked).
    Likert(u32),
    /// One of these labels (empty: not asked).
    Choice(Vec<String>),
    /// A number in `min..=max` (empty: not asked).
    Number(f64, f64),
    /// These names in the order shown, `|`-joined.
    Order(Vec<String>),
    /// A depth in `min..=max` mm.
    Depth(f64, f64),
    /// Depths in `min..=max` mm, `|`-joined.
    Depths(f64, f64),
    /// A count of adjustments, at most this many.
    Adjustments(u32),
    /// The adjustment's answers, `|`-joined, each one of these labels.
    AdjustAnswers(Vec<String>),
    /// A staircase's levels, `|`-joined, each one of these labels (empty:
    /// none).
    Levels(Vec<String>),
    /// Seconds (response times), `|`-joined; empty when none.
    Seconds,
    /// A procedure's estimate (a threshold) in its levels' unit, within
    /// `min..=max`: a staircase's levels (it averages some), QUEST+'s
    /// candidate thresholds (it is their posterior mean); empty when it
    /// has none. Summarised by the report.
    Estimate(f64, f64),
    /// A force in N, at least 0 (empty: not measured).
    Force,
}

/// How far a written estimate may lie outside its range: it is written to
/// 6 decimals (`{:.6}`), rounded by at most half the last.
pub const ESTIMATE_ROUNDING: f64 = 0.5e-6;

/// Largest force a column holds, N (a gauge's capacity is 50 to a few
/// hundred newtons; a finger is never pushed harder).
pub const MAX_FORCE_N: f64 = 1_000.0;

impl Holds {
    /// The kind recorded in `session.json`'s `columns` (condition and
    /// answer columns only).
    pub fn kind(&self) -> Option<&'static str> {
        Some(match self {
            Self::Level(_) => "factor",
            Self::Likert(_) => "likert",
            Self::Choice(_) => "choice",
            Self::Number(..) => "number",
            Self::Depth(..) => "depth",
            Self::Force => "force",
            Self::Estimate(..) => "estimate",
            _ => return None,
        })
    }

    /// The number an answer or depth value stands for, when it has one.
    pub fn number(&self, value: &str) -> Option<f64> {
        match self {
            Self::Likert(_)
            | Self::Number(..)
            | Self::Depth(..)
            | Self::Force
            | Self::Estimate(..) => value.parse().ok(),
            _ => None,
        }
    }

    /// Checks `value`; the error says what the column accepts.
    pub fn check(&self, value: &str) -> Result<(), String> {
        let list = |v: &str| {
            v.split(LIST_SEPARATOR)
                .map(str::to_owned)
                .collect::<Vec<_>>()
        };
        let count =
            |v: &str, lo: u64| v.parse::<u64>().is_ok_and(|n| n >= lo) && !v.starts_with('+');
        let number = |v: &str, lo: f64, hi: f64| {
            v.parse::<f64>()
                .is_ok_and(|x| x.is_finite() && lo <= x && x <= hi)
        };
        let range = |lo: f64, hi: f64| {
            format!(
                "from {} to {}",
                crate::limits::show(lo),
                crate::limits::show(hi)
            )
        };
        let ok = match self {
            Self::Participant => !value.is_empty(),
            Self::Count => count(value, 1),
            Self::Stimulus => crate::plan::library::check_id(value).is_ok(),
            Self::Level(levels) => levels.iter().any(|l| l == value),
            Self::Measured => value.is_empty() || number(value, 0.0, f64::MAX),
            Self::Tally => value.is_empty() || count(value, 0),
            Self::Fraction => value.is_empty() || number(value, 0.0, 1.0),
            // Written to 6 decimals: rounded by at most half the last.
            Self::Estimate(lo, hi) => {
                value.is_empty() || number(value, lo - ESTIMATE_ROUNDING, hi + ESTIMATE_ROUNDING)
            }
            Self::Time => is_rfc3339_utc(value),
            Self::Answers => count(value, 0),
            Self::Likert(points) => {
                value.is_empty()
                    || value
                        .parse::<u32>()
                        .is_ok_and(|v| (1..=*points).contains(&v))
            }
            Self::Choice(labels) => value.is_empty() || labels.iter().any(|l| l == value),
            Self::Number(lo, hi) => value.is_empty() || number(value, *lo, *hi),
            Self::Order(names) => {
                let mut got = list(value);
                got.sort();
                let mut want = names.clone();
                want.sort();
                got == want
            }
            Self::Depth(lo, hi) => number(value, *lo, *hi),
            Self::Depths(lo, hi) => list(value).iter().all(|v| number(v, *lo, *hi)),
            Self::Adjustments(max) => value.parse::<u32>().is_ok_and(|n| n <= *max),
            Self::AdjustAnswers(labels) | Self::Levels(labels) => {
                value.is_empty() || list(value).iter().all(|v| labels.contains(v))
            }
            Self::Seconds => {
                value.is_empty() || list(value).iter().all(|v| number(v, 0.0, f64::MAX))
            }
            Self::Force => value.is_empty() || number(value, 0.0, MAX_FORCE_N),
        };
        if ok {
            return Ok(());
        }
        use crate::error::some_of;
        Err(match self {
            Self::Participant => "give the participant's id".into(),
            Self::Count => "give a whole number from 1".into(),
            Self::Stimulus => "give a library entry's id".into(),
            Self::Level(l) => format!("give one of the levels {}", some_of(l, ", ")),
            Self::Measured => "give a number from 0 or nothing".into(),
            Self::Tally => "give a whole number from 0 or nothing".into(),
            Self::Fraction => "give a fraction from 0 to 1 or nothing".into(),
            Self::Estimate(lo, hi) => format!("give a number {} or nothing", range(*lo, *hi)),
            Self::Time => "give a time as 2026-01-31T12:00:00.000Z".into(),
            Self::Answers => "give a whole number from 0".into(),
            Self::Likert(p) => format!("give 1 to {p} or nothing"),
            Self::Choice(l) => format!("give one of {} or nothing", some_of(l, ", ")),
            Self::Number(lo, hi) => format!("give a number {} or nothing", range(*lo, *hi)),
            Self::Order(n) => format!("give {} in some order, `|`-joined", some_of(n, ", ")),
            Self::Depth(lo, hi) => format!("give millimetres {}", range(*lo, *hi)),
            Self::Depths(lo, hi) => format!("give `|`-joined millimetres {}", range(*lo, *hi)),
            Self::Adjustments(max) => format!("give a whole number from 0 to {max}"),
            Self::AdjustAnswers(l) => format!("give `|`-joined answers of {}", some_of(l, ", ")),
            Self::Levels(l) => format!("give `|`-joined levels of {}", some_of(l, ", ")),
            Self::Seconds => "give `|`-joined seconds from 0, or nothing".into(),
            Self::Force => format!("give newtons {} or nothing", range(0.0, MAX_FORCE_N)),
        })
    }

    /// The most bytes a value may take in `trials.csv` (quoted, every
    /// quote doubled), with list columns of at most `items` values: bounds
    /// how much a file being resumed or reported may hold.
    fn max_bytes(&self, items: usize) -> usize {
        // A label quoted, every quote doubled.
        let label = |l: &[String]| 2 * l.iter().map(String::len).max().unwrap_or(0) + 2;
        // A number the runner writes (a count, `{:.4}` of a time); ids
        // and numbers hold nothing that needs quoting.
        const NUMBER: usize = 32;
        match self {
            Self::Participant | Self::Stimulus => crate::plan::library::MAX_ID_LEN,
            Self::Count
            | Self::Answers
            | Self::Adjustments(_)
            | Self::Measured
            | Self::Fraction
            | Self::Estimate(..)
            | Self::Time => NUMBER,
            Self::Level(l) | Self::Choice(l) => label(l),
            Self::Likert(_) => 1,
            // As the participant gave it.
            Self::Number(..) => MAX_LABEL_BYTES,
            Self::Depth(..) | Self::Tally => NUMBER,
            Self::Order(n) => label(n) * n.len().max(1),
            Self::Depths(..) | Self::Seconds => (NUMBER + 1) * items,
            Self::Force => NUMBER,
            Self::AdjustAnswers(l) | Self::Levels(l) => (label(l) + 1) * items,
        }
    }
}

/// One column.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// Its name in the header.
    pub name: String,
    /// What it holds.
    pub holds: Holds,
    /// Whether it may hold [`NOT_PERCEIVED`] (an answer column whose
    /// question allows it).
    pub not_perceived: bool,
}

impl Column {
    /// A column named `name` holding `holds`.
    pub fn new(name: impl Into<String>, holds: Holds) -> Self {
        Self {
            name: name.into(),
            holds,
            not_perceived: false,
        }
    }

    /// The same column, allowing [`NOT_PERCEIVED`] too.
    pub fn allowing_not_perceived(mut self) -> Self {
        self.not_perceived = true;
        self
    }

    /// Checks `value` against what the column holds.
    pub fn check(&self, value: &str) -> Result<(), String> {
        if self.not_perceived && value == NOT_PERCEIVED {
            return Ok(());
        }
        self.holds.check(value).map_err(|m| {
            if self.not_perceived {
                format!("{m}, or `{NOT_PERCEIVED}`")
            } else {
                m
            }
        })
    }

    fn max_bytes(&self, items: usize) -> usize {
        let b = self.holds.max_bytes(items);
        if self.not_perceived {
            b.max(NOT_PERCEIVED.len())
        } else {
            b
        }
    }
}

/// The method of adjustment's part of the header.
#[derive(Debug, Clone, PartialEq)]
pub struct AdjustColumns {
    /// Depth limits, mm.
    pub min_mm: f64,
    /// Depth limits, mm.
    pub max_mm: f64,
    /// Most adjustments.
    pub max: u32,
    /// The answers it accepts.
    pub labels: Vec<String>,
}

/// Which adaptive procedure's columns a header has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Adaptive {
    /// A `[staircase]`'s.
    Staircase,
    /// A `[quest]`'s.
    Quest,
}

/// The header: every column in order.
#[derive(Debug, Clone, PartialEq)]
pub struct Columns {
    list: Vec<Column>,
    /// Most adjustments or staircase presentations (sizes the lists).
    adjustments: u32,
}

impl Columns {
    /// The header of a protocol with these factor columns, question columns
    /// (answers and their `_order` columns) and adjustment. A name given
    /// twice is the error.
    pub fn new(
        factors: Vec<Column>,
        questions: Vec<Column>,
        adjust: Option<&AdjustColumns>,
    ) -> Result<Self, String> {
        let mut list = vec![
            Column::new(PARTICIPANT, Holds::Participant),
            Column::new(TRIAL, Holds::Count),
            Column::new(SET, Holds::Count),
            Column::new(STIMULUS, Holds::Stimulus),
        ];
        list.extend(factors);
        list.push(Column::new(TIME_UTC, Holds::Time));
        list.extend(
            TIMING
                .iter()
                .chain(&[MISSED_DEADLINES, LEASE_EXPIRIES])
                .map(|n| Column::new(*n, measured(n))),
        );
        list.push(Column::new(ANSWERS, Holds::Answers));
        list.extend(questions);
        if let Some(a) = adjust {
            list.extend([
                Column::new(START_DEPTH, Holds::Depth(a.min_mm, a.max_mm)),
                Column::new(ADJUSTMENTS, Holds::Adjustments(a.max)),
                Column::new(ADJUST_ANSWERS, Holds::AdjustAnswers(a.labels.clone())),
                Column::new(DEPTHS, Holds::Depths(a.min_mm, a.max_mm)),
                Column::new(FINAL_DEPTH, Holds::Depth(a.min_mm, a.max_mm)),
                Column::new(ADJUST_RT, Holds::Seconds),
                Column::new(FORCE, Holds::Force),
            ]);
        }
        for (i, c) in list.iter().enumerate() {
            if list[..i].iter().any(|x| x.name == c.name) {
                return Err(format!(
                    "column `{}` is used twice (factor and question names and trials.csv's own columns must differ)",
                    c.name
                ));
            }
        }
        Ok(Self {
            list,
            adjustments: adjust.map_or(0, |a| a.max),
        })
    }

    /// The same header with the blocks' columns after `set`: the block's
    /// name (one of `names`) and whether it is practice.
    pub fn with_blocks(mut self, names: Vec<String>) -> Result<Self, String> {
        let columns = [
            Column::new(BLOCK, Holds::Level(names)),
            Column::new(PRACTICE, Holds::Level(vec!["0".into(), "1".into()])),
        ];
        self.unused(&columns)?;
        let at = self.index(SET).map_or(0, |i| i + 1);
        self.list.splice(at..at, columns);
        Ok(self)
    }

    /// Refuses `columns` where one is already in the header.
    fn unused(&self, columns: &[Column]) -> Result<(), String> {
        match columns.iter().find(|c| self.index(&c.name).is_some()) {
            Some(c) => Err(format!(
                "column `{}` is used twice (factor and question names and trials.csv's own columns must differ)",
                c.name
            )),
            None => Ok(()),
        }
    }

    /// The same header with an adaptive procedure's columns after the
    /// rest: its `levels`, its two `answers`, the most presentations,
    /// `trials`, and the range its threshold lies in, `estimate`.
    pub fn with_adaptive(
        self,
        kind: Adaptive,
        levels: Vec<String>,
        answers: Vec<String>,
        trials: u32,
        estimate: (f64, f64),
    ) -> Result<Self, String> {
        let (lo, hi) = estimate;
        let columns = match kind {
            Adaptive::Staircase => vec![
                Column::new(STAIRCASE_LEVELS, Holds::Levels(levels.clone())),
                Column::new(STAIRCASE_ANSWERS, Holds::AdjustAnswers(answers)),
                Column::new(STAIRCASE_REVERSALS, Holds::Levels(levels)),
                Column::new(STAIRCASE_AT_LIMIT, Holds::Adjustments(trials)),
                Column::new(THRESHOLD, Holds::Estimate(lo, hi)),
            ],
            Adaptive::Quest => vec![
                Column::new(QUEST_LEVELS, Holds::Levels(levels)),
                Column::new(QUEST_ANSWERS, Holds::AdjustAnswers(answers)),
                Column::new(THRESHOLD, Holds::Estimate(lo, hi)),
                Column::new(THRESHOLD_SD, Holds::Measured),
            ],
        };
        self.with(columns, trials)
    }

    /// A procedure's `columns` after the rest, its lists at most `trials`
    /// long.
    fn with(mut self, columns: Vec<Column>, trials: u32) -> Result<Self, String> {
        self.unused(&columns)?;
        self.list.extend(columns);
        self.adjustments = self.adjustments.max(trials);
        Ok(self)
    }

    /// The columns in order.
    pub fn list(&self) -> &[Column] {
        &self.list
    }

    /// The names in order (the header line).
    pub fn names(&self) -> Vec<&str> {
        self.list.iter().map(|c| c.name.as_str()).collect()
    }

    /// Where column `name` is.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.list.iter().position(|c| c.name == name)
    }

    /// The column called `name`.
    pub fn get(&self, name: &str) -> Option<&Column> {
        self.list.iter().find(|c| c.name == name)
    }

    /// The most bytes one row may take, its line break included.
    pub fn max_row_bytes(&self) -> usize {
        // A list holds a depth per adjustment and the first.
        let items = self.adjustments as usize + 1;
        self.list
            .iter()
            .map(|c| c.max_bytes(items) + 1)
            .sum::<usize>()
            + 2
    }

    /// The fields of `row` in header order; a value for a column the
    /// header lacks, or one that would break the line, is an error (a
    /// runner that writes what it does not declare).
    pub fn fields(&self, row: &Row) -> Result<Vec<String>, String> {
        let mut out = vec![String::new(); self.list.len()];
        for (name, value) in &row.values {
            let i = self.index(name).ok_or_else(|| {
                format!("trials.csv has no column `{name}` for the value `{value}`")
            })?;
            if value.chars().any(char::is_control) {
                return Err(format!(
                    "the value of `{name}` holds a control character: `{}`",
                    value.escape_debug()
                ));
            }
            out[i].clone_from(value);
        }
        Ok(out)
    }
}

/// A trial's values by column name, as the runner and the procedure fill
/// them; [`Columns::fields`] puts them in the header's order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Row {
    values: Vec<(String, String)>,
}

impl Row {
    /// Sets column `name` (a second value replaces the first).
    pub fn set(&mut self, name: &str, value: impl Into<String>) {
        let value = value.into();
        match self.values.iter_mut().find(|(n, _)| n == name) {
            Some(v) => v.1 = value,
            None => self.values.push((name.to_owned(), value)),
        }
    }

    /// The value of column `name`, if set.
    pub fn get(&self, name: &str) -> Option<&str> {
        self.values
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }
}

#[cfg(test)]
mod tests;
