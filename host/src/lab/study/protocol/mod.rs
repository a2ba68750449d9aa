//! The protocol file (TOML): which library, how many sets, the trial's
//! timeline, the factors whose product names the conditions, the questions
//! and an optional method-of-adjustment loop. Checked whole before the
//! device opens: a bad field is one line naming the file, line and field.

mod blocks;
mod check;
mod errors;
mod file;
mod grid;
mod quest;
mod report;
mod staircase;
mod values;

pub use blocks::{Block, MAX_BLOCKS};
pub use grid::{Grid, LEVEL};
pub use quest::Quest;
pub use report::{PairSpec, ReportSpec};
pub use staircase::Staircase;

/// The protocol file's JSON Schema, from the types it is read into (see
/// [`crate::lab::study::schema`]).
pub(crate) fn file_schema(generator: schemars::SchemaGenerator) -> schemars::Schema {
    generator.into_root_schema_for::<file::File>()
}

use std::path::{Path, PathBuf};

use crate::error::InputError;
use crate::lab::session::Gate;
use crate::lab::study::columns::{Column, Columns, Holds};
use crate::plan::library::Library;

/// Most sets in a protocol.
pub const MAX_SETS: usize = 100;
/// Most conditions (the factors' product).
pub const MAX_CONDITIONS: usize = 1_000;
/// Most trials in a session (conditions × sets): over 2.5 h at a second
/// a trial, and what bounds `session.json` and `trials.csv`.
pub const MAX_TRIALS: usize = 10_000;
/// Most questions per trial.
pub const MAX_QUESTIONS: usize = 32;
/// Most Likert points, choice options or Likert items.
pub const MAX_OPTIONS: usize = 9;
/// Longest phase or interval, seconds.
pub const MAX_SECONDS: f64 = 3_600.0;
/// Most adjustments per trial.
pub const MAX_ADJUSTMENTS: u32 = 1_000;
/// Most levels in a staircase's grid.
pub const MAX_LEVELS: usize = 200;
/// Most answers in a row a staircase waits for before it moves.
pub const MAX_RUN: u32 = 10;
/// Most reversals or presentations of a staircase.
pub const MAX_STAIRCASE: u32 = 1_000;
/// Most candidate slopes or lapse rates of QUEST+.
pub const MAX_QUEST_GRID: usize = 20;
/// Most parameter triples (thresholds × slopes × lapses): with 200
/// levels, a table of 1 M likelihoods (8 MB), and each choice of the next
/// level 2 M multiplications and logarithms (milliseconds).
pub const MAX_QUEST_PARAMS: usize = 5_000;
/// Steepest slope.
pub const MAX_SLOPE: f64 = 1e6;
/// Highest lapse rate (a participant who misses half the time above
/// threshold is not doing the task).
pub const MAX_LAPSE: f64 = 0.5;
/// The lapse rates a `[quest]` table without `lapses` weighs.
pub const DEFAULT_LAPSES: [f64; 1] = [0.02];
/// Largest adjustment depth either way, mm (a gauge's travel is a few).
pub const MAX_DEPTH_MM: f64 = 1_000.0;
/// Largest number a number question accepts either way (its default
/// range): every answer, difference and plot range stays finite.
pub const MAX_NUMBER: f64 = 1e12;

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

/// How the conditions are ordered.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Order {
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

impl Order {
    /// Its name in the protocol file.
    pub fn name(self) -> &'static str {
        match self {
            Self::Random => "random",
            Self::Sequential => "sequential",
            Self::FullRandom => "full-random",
            Self::LatinSquare => "latin-square",
        }
    }
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
    /// The label of the "not perceived" answer, when the question allows
    /// it (typed as `na`, recorded as `na`, left out of the statistics).
    pub not_perceived: Option<String>,
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

    /// The names its items or options are shown by (its `_order` column).
    pub fn shown_names(&self) -> &[String] {
        match &self.kind {
            Kind::Likert { items, .. } => items,
            Kind::Choice { options } => options,
            Kind::Number { .. } => &[],
        }
    }

    /// Its columns and what they hold: one per answer, then the order
    /// shown when shuffled.
    pub fn column_list(&self) -> Vec<Column> {
        let holds = match &self.kind {
            Kind::Likert { points, .. } => Holds::Likert(*points),
            Kind::Choice { options } => Holds::Choice(options.clone()),
            Kind::Number { min, max } => Holds::Number(*min, *max),
        };
        // Each answer, then its response time.
        let mut v: Vec<Column> = Vec::new();
        for c in self.columns() {
            let rt = crate::lab::study::columns::rt_column(&c);
            let answer = Column::new(c, holds.clone());
            v.push(if self.not_perceived.is_some() {
                answer.allowing_not_perceived()
            } else {
                answer
            });
            v.push(Column::new(rt, Holds::Measured));
        }
        if self.shuffle {
            v.push(Column::new(
                format!("{}_order", self.id),
                Holds::Order(self.shown_names().to_vec()),
            ));
        }
        v
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

impl Adjustment {
    /// Its answers in the order shown.
    pub fn labels(&self) -> Vec<String> {
        vec![
            self.stronger.clone(),
            self.weaker.clone(),
            self.same.clone(),
        ]
    }
}

/// One condition: a level per factor and the library entry it names.
#[derive(Debug, Clone, PartialEq)]
pub struct Condition {
    /// Level per factor, in factor order.
    pub levels: Vec<String>,
    /// The library entry's id.
    pub stimulus: String,
}

/// A checked protocol and its library. Everything but the library is its
/// [`Unlinked`] part, which it dereferences to (`p.factors`, `p.trials()`).
#[derive(Debug, Clone)]
pub struct Protocol {
    /// The file it came from.
    pub path: PathBuf,
    /// Its text (copied to `session.json`, compared on `--resume`).
    pub text: String,
    /// The library file (resolved against the protocol's folder).
    pub library_path: PathBuf,
    /// The library.
    pub library: Library,
    /// The protocol itself, checked.
    pub checked: Unlinked,
}

impl std::ops::Deref for Protocol {
    type Target = Unlinked;
    fn deref(&self) -> &Unlinked {
        &self.checked
    }
}

impl std::ops::DerefMut for Protocol {
    fn deref_mut(&mut self) -> &mut Unlinked {
        &mut self.checked
    }
}

/// A protocol checked but for its library: all `study report` needs of
/// the protocol text a session recorded.
#[derive(Debug, Clone)]
pub struct Unlinked {
    /// Its name.
    pub name: String,
    /// The library file as given, and where.
    library: toml::Spanned<String>,
    /// The stimulus template, and where.
    stimulus: toml::Spanned<String>,
    /// Sets.
    pub sets: usize,
    /// How the conditions are ordered.
    pub order: Order,
    /// The blocks in the order run (empty: one block of every condition,
    /// `sets` and `order`).
    pub blocks: Vec<Block>,
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
    /// The staircase, if used.
    pub staircase: Option<Staircase>,
    /// QUEST+, if used.
    pub quest: Option<Quest>,
    /// trials.csv's header.
    pub columns: Columns,
    /// What `study report` tests.
    pub report: ReportSpec,
}

impl Unlinked {
    /// Parses and checks protocol `text` (`origin` names it in errors).
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, InputError> {
        let e = check::Errors { text, origin };
        let file: file::File = crate::plan::scene::from_toml(text, &crate::files::kind::PROTOCOL)
            .map_err(|m| e.bad(m))?;
        check::check(file, &e)
    }

    /// Trials in all: conditions × sets, or the blocks' sum.
    pub fn trials(&self) -> usize {
        if self.blocks.is_empty() {
            self.conditions.len() * self.sets
        } else {
            self.blocks.iter().map(Block::trials).sum()
        }
    }
}

/// Fills `{factor}` placeholders of `template` with `levels`.
pub fn expand(template: &str, factors: &[Factor], levels: &[String]) -> Result<String, String> {
    expand_level(template, factors, levels, None)
}

/// [`expand`], and `{level}` with a staircase's `level` when given.
pub fn expand_level(
    template: &str,
    factors: &[Factor],
    levels: &[String],
    level: Option<&str>,
) -> Result<String, String> {
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
        if let Some(l) = level.filter(|_| name == LEVEL) {
            out.push_str(l);
            rest = &rest[i + j + 1..];
            continue;
        }
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
        let u = Unlinked::from_toml(text, &origin)?;
        let e = check::Errors {
            text,
            origin: &origin,
        };
        let library_path = crate::files::in_folder(
            path.parent().unwrap_or(Path::new(".")),
            "library",
            Path::new(u.library.get_ref()),
        )
        .map_err(|_| {
            let m = "the path is empty: give the stimulus library's file, relative to the protocol";
            e.at(u.library.span(), "library", m)
        })?;
        let library = Library::load(&library_path).map_err(|x| {
            // The hint where the path is the trouble, not after a value
            // inside the library.
            let hint = match library_path.exists() {
                true => "",
                false => " (the path is relative to the protocol file)",
            };
            e.at(u.library.span(), "library", format!("{x}{hint}"))
        })?;
        if let Some(c) = u
            .conditions
            .iter()
            .find(|c| library.find(&c.stimulus).is_none())
        {
            return Err(e.at(
                u.stimulus.span(),
                "stimulus",
                format!(
                    "condition {} names stimulus `{}`, which is not in {}",
                    c.levels.join("/"),
                    c.stimulus.escape_debug(),
                    library_path.display()
                ),
            ));
        }
        let mut levels = (u
            .staircase
            .iter()
            .flat_map(|s| s.grid.entries.iter().flatten()))
        .map(|id| ("staircase", id))
        .chain(
            (u.quest.iter().flat_map(|q| q.grid.entries.iter().flatten())).map(|id| ("quest", id)),
        );
        if let Some((which, id)) = levels.find(|(_, id)| library.find(id).is_none()) {
            return Err(e.at(
                u.stimulus.span(),
                "stimulus",
                format!(
                    "the {which} names stimulus `{}`, which is not in {}",
                    id.escape_debug(),
                    library_path.display()
                ),
            ));
        }
        Ok(Self {
            path: path.to_owned(),
            text: text.to_owned(),
            library_path,
            library,
            checked: u,
        })
    }
}

#[cfg(test)]
mod tests;
