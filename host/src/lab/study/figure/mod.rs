//! `study report`'s figures in the paper's layout: one box-and-whisker
//! plot per answer column, boxes grouped by radius (the x axis) with the
//! LM type by colour, the answer's fixed range (a Likert scale's 1..=points,
//! a number's min..=max, the adjustment's depths), the protocol's words
//! (question text and scale labels, condition labels for level ids), n
//! under every box, outliers beyond 1.5 IQR as white dots, and each tested
//! pair that is significant or well powered marked above its boxes with the
//! paper's stars and power marks ([`crate::lab::stats::stars`],
//! [`crate::lab::stats::power_marks`]).
//!
//! A figure is printed 88 or 180 mm wide (`--width-mm`) with the text sizes
//! and units of `lmhost simulate`'s figures ([`crate::field::plot`]): PNG at
//! 288 dpi, SVG and PDF (text in an embedded font subset) at their printed
//! size. Experiment 3 is drawn in N when the rows hold the force
//! ([`FORCE`]), else as the final pushing depth in mm.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use super::analysis::{QuestionStats, Stat, condition_name};
use super::protocol::{Kind, Unlinked};
use crate::field::plot::{Canvas, Drawing, Figure};

mod draw;
#[cfg(test)]
mod tests;

pub use draw::Layout;

/// The column of Experiment 3's force (N), where the rows hold it: its
/// figure replaces the depth's.
pub const FORCE: &str = "force_n";

/// One box: a condition's values.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxData {
    /// Its group on the x axis (the radius).
    pub group: usize,
    /// Its series (the colour: the LM type).
    pub series: usize,
    /// The values, sorted.
    pub values: Vec<f64>,
}

/// A tested pair to mark above its boxes.
#[derive(Debug, Clone, PartialEq)]
pub struct Mark {
    /// The boxes (indices into [`BoxFigure::boxes`]).
    pub a: usize,
    /// The other box.
    pub b: usize,
    /// Stars and power marks, e.g. `** ++`.
    pub text: String,
}

/// What one figure shows, in plain values.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxFigure {
    /// The answer column it shows (its files are `box-{column}.*`).
    pub column: String,
    /// The question as asked (wrapped above the plot; empty: none).
    pub title: String,
    /// A line under it: the scale's end labels (empty: none).
    pub subtitle: String,
    /// The y axis' name with its unit.
    pub y_label: String,
    /// The y axis' fixed range.
    pub range: (f64, f64),
    /// The y ticks (inside `range`).
    pub ticks: Vec<f64>,
    /// The x axis' name (what groups the boxes).
    pub group_title: String,
    /// A label per group.
    pub groups: Vec<String>,
    /// A label per series (the legend).
    pub series: Vec<String>,
    /// The boxes.
    pub boxes: Vec<BoxData>,
    /// The marked pairs.
    pub marks: Vec<Mark>,
}

/// A condition's label for factor level `level`: an LM type id
/// (`lms-5hz`, `lmm-25hz`) as the paper writes it (`LM-S 5 Hz`), any other
/// level as given.
pub fn level_label(level: &str) -> String {
    let lm = |kind: &str, rest: &str| {
        let f = rest.strip_suffix("hz")?;
        (!f.is_empty() && f.chars().all(|c| c.is_ascii_digit() || c == '.'))
            .then(|| format!("{kind} {f} Hz"))
    };
    level
        .strip_prefix("lms-")
        .and_then(|r| lm("LM-S", r))
        .or_else(|| level.strip_prefix("lmm-").and_then(|r| lm("LM-M", r)))
        .unwrap_or_else(|| level.to_owned())
}

/// A column's name as words (`perceived_radius_mm` → `perceived radius`)
/// and its unit from its suffix (`mm`, `N`, `s`), if any.
fn words_and_unit(column: &str) -> (String, Option<&'static str>) {
    let (stem, unit) = [("_mm", "mm"), ("_n", "N"), ("_s", "s")]
        .into_iter()
        .find_map(|(suffix, unit)| column.strip_suffix(suffix).map(|s| (s, Some(unit))))
        .unwrap_or((column, None));
    (stem.replace('_', " "), unit)
}

/// Round `x` up to a "nice" number: 1, 2, 2.5 or 5 × 10^k.
fn nice_up(x: f64) -> f64 {
    let e = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .into_iter()
        .map(|m| m * e)
        .find(|v| *v >= x * (1.0 - 1e-12))
        .unwrap_or(10.0 * e)
}

/// About five ticks over `lo..=hi` at a nice step; the ends alone where
/// no step divides the span (none, or too wide for an f64).
fn ticks_over(lo: f64, hi: f64) -> Vec<f64> {
    let step = nice_up((hi - lo) / 5.0);
    if !(step.is_finite() && step > 0.0 && (hi - lo) / step <= 20.0) {
        return if hi > lo { vec![lo, hi] } else { vec![lo] };
    }
    let first = (lo / step).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

/// The y axis of column `column`: its name, fixed range, ticks, the
/// question text and the scale's end labels, from the protocol; `values`
/// only where the column has no fixed range (the force: 0 up to a nice
/// number above the largest value).
fn axis(
    protocol: &Unlinked,
    column: &str,
    values: impl Iterator<Item = f64>,
) -> (String, (f64, f64), Vec<f64>, String, String) {
    let (words, unit) = words_and_unit(column);
    let named = |w: &str| match unit {
        Some(u) => format!("{w} ({u})"),
        None => w.to_owned(),
    };
    let asked = protocol
        .questions
        .iter()
        .find(|q| q.columns().iter().any(|c| c == column));
    if let Some(q) = asked {
        match &q.kind {
            Kind::Likert {
                points, low, high, ..
            } => {
                let item = column.strip_prefix(&format!("{}_", q.id));
                let name = match item {
                    Some(i) => format!("{} rating: {i}", q.id.replace('_', " ")),
                    None => format!("{} rating", q.id.replace('_', " ")),
                };
                let top = f64::from(*points);
                let ends = if low.is_empty() && high.is_empty() {
                    String::new()
                } else {
                    format!("1 = {low}, {points} = {high}")
                };
                return (
                    name,
                    (1.0, top),
                    (1..=*points).map(f64::from).collect(),
                    q.text.clone(),
                    ends,
                );
            }
            Kind::Number { min, max } => {
                return (
                    named(&words),
                    (*min, *max),
                    ticks_over(*min, *max),
                    q.text.clone(),
                    String::new(),
                );
            }
            Kind::Choice { .. } => {}
        }
    }
    if column == FORCE {
        let top = values.fold(0.0f64, f64::max);
        let hi = if top > 0.0 { nice_up(top * 1.05) } else { 1.0 };
        return (
            "perceived force (N)".into(),
            (0.0, hi),
            ticks_over(0.0, hi),
            String::new(),
            String::new(),
        );
    }
    if column == super::columns::FINAL_DEPTH
        && let Some(a) = &protocol.adjustment
    {
        return (
            "final pushing depth (mm)".into(),
            (a.min_mm, a.max_mm),
            ticks_over(a.min_mm, a.max_mm),
            a.text.clone(),
            String::new(),
        );
    }
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let (lo, hi) = if lo.is_finite() && hi > lo {
        (lo, hi)
    } else if lo.is_finite() {
        (lo - 1.0, lo + 1.0)
    } else {
        (0.0, 1.0)
    };
    (
        named(&words),
        (lo, hi),
        ticks_over(lo, hi),
        String::new(),
        String::new(),
    )
}

/// The figures of `stats` (the report's per-condition values) with the
/// marks of `tests`, one per answer column, in the paper's layout; the
/// depth's is left out when the rows hold the force.
pub fn plan(protocol: &Unlinked, stats: &[Stat], tests: &[QuestionStats]) -> Vec<BoxFigure> {
    let factors = &protocol.factors;
    // The radius groups the boxes; else the last factor does.
    let g = factors
        .iter()
        .position(|f| f.name == "radius")
        .unwrap_or(factors.len().saturating_sub(1));
    let group_title = match factors.get(g) {
        Some(f) if f.name == "radius" => "orbit radius A (mm)".to_owned(),
        Some(f) => f.name.replace('_', " "),
        None => String::new(),
    };
    let groups: Vec<String> = factors
        .get(g)
        .map(|f| f.levels.iter().map(|l| level_label(l)).collect())
        .unwrap_or_default();
    // A series per combination of the other factors' levels, in the
    // protocol's order.
    let other = |levels: &[String]| -> Vec<String> {
        levels
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != g)
            .map(|(_, l)| level_label(l))
            .collect()
    };
    let mut series: Vec<Vec<String>> = Vec::new();
    for c in &protocol.conditions {
        let s = other(&c.levels);
        if !series.contains(&s) {
            series.push(s);
        }
    }
    let place = |levels: &[String]| -> Option<(usize, usize)> {
        let group = factors
            .get(g)?
            .levels
            .iter()
            .position(|l| *l == levels[g])?;
        let s = other(levels);
        Some((group, series.iter().position(|x| *x == s)?))
    };
    let mut columns: Vec<&str> = Vec::new();
    for st in stats {
        if !columns.contains(&st.question.as_str()) {
            columns.push(&st.question);
        }
    }
    if columns.contains(&FORCE) {
        columns.retain(|c| *c != super::columns::FINAL_DEPTH);
    }
    let mut out = Vec::new();
    for column in columns {
        let mut boxes: Vec<BoxData> = Vec::new();
        for st in stats.iter().filter(|s| s.question == column) {
            if st.levels.len() != factors.len() {
                continue;
            }
            if let Some((group, series)) = place(&st.levels) {
                boxes.push(BoxData {
                    group,
                    series,
                    values: st.values.clone(),
                });
            }
        }
        boxes.sort_by_key(|b| (b.group, b.series));
        let at = |name: &str| {
            let c = protocol
                .conditions
                .iter()
                .find(|c| condition_name(c) == name)?;
            let (group, series) = place(&c.levels)?;
            boxes
                .iter()
                .position(|b| b.group == group && b.series == series)
        };
        let marks = tests
            .iter()
            .filter(|t| t.question == column)
            .flat_map(|t| &t.analysis.pairs)
            .filter(|p| !p.stars.is_empty() || !p.power_marks.is_empty())
            .filter_map(|p| {
                let text = [p.stars, p.power_marks]
                    .into_iter()
                    .filter(|s| !s.is_empty())
                    .collect::<Vec<_>>()
                    .join(" ");
                Some(Mark {
                    a: at(&p.a)?,
                    b: at(&p.b)?,
                    text,
                })
            })
            .collect();
        let values = boxes.iter().flat_map(|b| b.values.iter().copied());
        let (y_label, range, ticks, title, subtitle) = axis(protocol, column, values);
        out.push(BoxFigure {
            column: column.to_owned(),
            title,
            subtitle,
            y_label,
            range,
            ticks,
            group_title: group_title.clone(),
            groups: groups.clone(),
            series: series.iter().map(|s| s.join(", ")).collect(),
            boxes,
            marks,
        });
    }
    out
}

/// Writes `box` to `stem` plus each of `fig.formats`' extensions at
/// `fig.width_mm`, each file whole or absent; returns the paths written.
pub fn write(stem: &Path, b: &BoxFigure, fig: &Figure) -> anyhow::Result<Vec<PathBuf>> {
    crate::field::plot::register_font();
    fig.check()?;
    let lay = Layout::new(b, fig.width_mm)
        .map_err(|x| anyhow::anyhow!("laying out {}: {x}", stem.display()))?;
    crate::field::plot::write_formats(stem, fig, &Boxes { lay, b })
}

/// The box figure [`write`] draws.
struct Boxes<'a> {
    lay: Layout,
    b: &'a BoxFigure,
}

impl Drawing for Boxes<'_> {
    fn size(&self) -> (u32, u32) {
        self.lay.size
    }

    fn draw<B: DrawingBackend>(&self, on: &Canvas<B>, font_k: f64) -> Result<(), String> {
        draw::draw(on, &self.lay.with_font_k(font_k), self.b)
    }
}
